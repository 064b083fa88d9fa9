// shaders/config.h: the contract between the C++ Vulkan evaluator and the GLSL kernels, read
// by both (glslangValidator -I and the psub_vulkan target). Binding numbers, workgroup size,
// specialization constant ids, and the layouts of the push constants and group records.
// The C++ side checks every pipeline against it (psub/vulkan pipelines.cpp, reflectSpirv).
#ifndef PSUB_SHADERS_CONFIG_H
#define PSUB_SHADERS_CONFIG_H

// Invocations per workgroup (one row each). Dispatches are 2-D when a chunk has more
// workgroups than maxComputeWorkGroupCount[0]. 128 (the least maxComputeWorkGroupInvocations
// the specification allows) measured a few percent faster than 64 on lavapipe; 256 no faster.
#define PSUB_WORKGROUP_SIZE 128

// A vertex-like buffer (positions of a level, face normals, normals) larger than
// maxStorageBufferRange is bound as up to this many consecutive windows.
#define PSUB_VERTEX_WINDOWS 4

// One descriptor set, the same layout for every kernel: the input vertex buffer's windows,
// the output vertex buffer's windows, then three table arrays (each bound at the window of
// the chunk being dispatched).
#define PSUB_BINDING_SOURCE 0        // PSUB_BINDING_SOURCE + w, w < PSUB_VERTEX_WINDOWS
#define PSUB_BINDING_DESTINATION 4   // PSUB_BINDING_DESTINATION + w
#define PSUB_BINDING_TABLE_A 8       // level: group records; CSR kernels: chunk-relative offsets; tile: block records
#define PSUB_BINDING_TABLE_B 9       // level: row words (as TABLE_C); CSR kernels: column indices; tile: gathered vertices
#define PSUB_BINDING_TABLE_C 10      // level: row words (sources, destination); factorized: weights; tile: border positions
// The same input windows and table windows again as uniform texel buffers (read with
// texelFetch when PSUB_SPEC_TEXELS is on): the input as R32G32B32A32_SFLOAT when its stride is
// 4 floats, else R32_SFLOAT (one texel per float); each table as R32_UINT, or as
// R32G32B32A32_UINT where a kernel fetches 4 words at once (level rows, quads' corners, vertex
// faces). lavapipe fetches
// texels with straight-line gathers, where it runs every non-uniform storage-buffer load as a
// loop over the SIMD lanes with a bounds check and a branch per lane and value.
#define PSUB_BINDING_SOURCE_TEXELS 11   // PSUB_BINDING_SOURCE_TEXELS + w, w < PSUB_VERTEX_WINDOWS
#define PSUB_BINDING_TABLE_A_TEXELS 15
#define PSUB_BINDING_TABLE_B_TEXELS 16
#define PSUB_BINDING_TABLE_C_TEXELS 17
#define PSUB_BINDING_STORAGE_COUNT 11   // bindings below this are storage buffers, the rest texel buffers
#define PSUB_BINDING_COUNT 18

// Specialization constants, fixed per pipeline.
#define PSUB_SPEC_COMPONENTS 0         // values combined per element (the evaluator's width; 3 for normals)
#define PSUB_SPEC_SOURCE_STRIDE 1      // floats per input element
#define PSUB_SPEC_DESTINATION_STRIDE 2 // floats per output element
#define PSUB_SPEC_SOURCE_WINDOWED 3    // the input is bound as more than one window
#define PSUB_SPEC_DESTINATION_WINDOWED 4
#define PSUB_SPEC_TEXELS 5             // inputs and tables are read through the texel-buffer bindings
#define PSUB_SPEC_ROW_N 6              // level kernel: the rows' edge count when compiled in (0xffffffff: any)
#define PSUB_SPEC_ROW_M 7              // level kernel: the rows' diagonal count likewise
#define PSUB_SPEC_TILE_STEPS 8         // tile_unrolled.comp: t, the double steps it unrolls
#define PSUB_SPEC_LISTED 9             // vertex normals: row r's normal written at the vertex listed
                                       // in TABLE_A (fixed layout) or TABLE_C (CSR), not at a range
#define PSUB_SPEC_TILE_GRID 10         // tile.comp: the side of its shared grids (see below)
#define PSUB_SPEC_TILE_NORMALS 11      // tile.comp, non-zero: also the tiles' inner points' unit normals,
                                       // written to PSUB_BINDING_DESTINATION + 1 (the positions in one
                                       // window), the last fine grid kept at this side (block side + 3)
#define PSUB_SPEC_TILE_THREADS 12      // tile.comp: its workgroup's invocations (512 for blocks of 32, 256 for 16, unless asked)
#define PSUB_SPEC_IMPLICIT_DESTINATION 13  // level kernel: row r writes element pc.rowBase + r (its
                                           // group's destinations consecutive), its words the
                                           // sources alone

// Push constants, per dispatch (all 32-bit; 52 bytes, under the 128 every device has).
//   rowCount           rows in this dispatch; invocations beyond it return at once
//                      (tile kernel: blocks, one workgroup each)
//   rowBase            the first row's element number in the output (CSR kernels)
//   groupBase          level kernel: this dispatch's first group record in the TABLE_A window;
//                      vertex normals, fixed layout: the input element that holds zero;
//                      tile kernel: the double steps t
//   groupCount         level kernel: its group records (more than 1: groups of any shape);
//                      vertex normals, fixed layout: uvec4s of words per vertex (2); tile
//                      kernel: the halo
//   tableBase          CSR kernels: first offset in the TABLE_A window; face normals of
//                      quads and vertex normals of the fixed layout: first word of the
//                      dispatch in the TABLE_B window (a multiple of 4); tile kernel: the
//                      dispatch's first block record in the TABLE_A window
//   sourceWindowSize   elements per input window (when windowed)
//   destinationWindowSize
//   groupN, groupM     level kernel, a dispatch of one group: the group's shape,
//   groupIndexBegin    its record's indexBegin,
//   groupCentre, groupEdge, groupDiagonal   and its weights, so that its rows read no record
//                      (on lavapipe each read of one is a gather: the torus's per-level frame
//                      at 1M faces 14.4-14.8 -> 13.3-13.9 ms, the cow's tiled at 7 steps
//                      18.4-18.7 -> 17.8-18.0)
//   pad
#define PSUB_PUSH_CONSTANT_MEMBERS                                                              \
    uint rowCount;                                                                             \
    uint rowBase;                                                                              \
    uint groupBase;                                                                            \
    uint groupCount;                                                                           \
    uint tableBase;                                                                            \
    uint sourceWindowSize;                                                                     \
    uint destinationWindowSize;                                                                \
    uint groupN;                                                                               \
    uint groupM;                                                                               \
    uint groupIndexBegin;                                                                      \
    float groupCentre;                                                                         \
    float groupEdge;                                                                           \
    float groupDiagonal;

// One row group of the per-level table as seen by one dispatch (std430, 32 bytes): the
// group's rows are the dispatch's rows [rowBegin, rowBegin + rowCount) (rowBegin 0 in a dispatch
// of one group; in a dispatch of several, pc.groupCount records from pc.groupBase, each group's
// first row a multiple of the workgroup size). The group's row r has its words from indexBegin +
// r * stride (relative to the TABLE_C window; stride = 1 + n + m + 1 rounded up to a multiple of
// 4): 1 + n + m source indices (the centre, n edge neighbours, m diagonals, with these weights),
// then its destination.
#define PSUB_GROUP_RECORD_MEMBERS                                                               \
    uint rowBegin;                                                                             \
    uint indexBegin;                                                                           \
    uint n;                                                                                    \
    uint m;                                                                                    \
    float centre;                                                                              \
    float edge;                                                                                \
    float diagonal;                                                                            \
    uint rowCount;

// The tile kernels: tile.comp, one workgroup computes a block of at most PSUB_TILE_BLOCK x
// PSUB_TILE_BLOCK lattice intervals of one tile, in workgroup-shared grids of at most
// PSUB_TILE_GRID x PSUB_TILE_GRID points (the largest grid any of its steps keeps, t <= 3:
// 12.3 KiB of vec4 with the quincunx level's two grids, under the 16 KiB every device has), or
// of PSUB_TILE_WIDE_BLOCK and grids of up to PSUB_TILE_WIDE_GRID (27.7 KiB) where the device's
// shared memory holds them (the grid side a specialization constant, PSUB_SPEC_TILE_GRID);
// tile_unrolled.comp, one invocation computes a block of exactly PSUB_TILE_BLOCK, its grids
// unrolled into registers (the last block of a row or column cut by the tile's side).
// A block record (std430, 32 bytes, read as two uvec4):
//   gatherFirst   the block's level-B window's first vertex in the TABLE_B window (the tile's
//                 gathered grid, row (Y0 >> t), column (X0 >> t))
//   gridSide      g, the tile's gathered grid side (the window's row stride)
//   lattice       L, the tile's lattice side
//   blockSide     M: the largest multiple of 2^t dividing L, at most the kernel's block side
//                 (unrolled: PSUB_TILE_BLOCK)
//   origin        X0 | Y0 << 16: the block's first lattice point in the tile
//   outputBegin, outputEnd   the tile's drawing positions (inner points from outputBegin)
//   borderFirst   the tile's first border entry in the TABLE_C window
#define PSUB_TILE_BLOCK 16
#define PSUB_TILE_GRID 17
#define PSUB_TILE_WIDE_BLOCK 32
#define PSUB_TILE_WIDE_GRID 25
#define PSUB_TILE_RECORD_MEMBERS                                                                \
    uint gatherFirst;                                                                          \
    uint gridSide;                                                                             \
    uint lattice;                                                                              \
    uint blockSide;                                                                            \
    uint origin;                                                                               \
    uint outputBegin;                                                                          \
    uint outputEnd;                                                                            \
    uint borderFirst;

// tile_normals.comp: the tiled form's normals of tiles' inner points, from the refined
// positions by implicit addressing. One invocation per run of at most PSUB_NORMAL_RUN x
// PSUB_NORMAL_ROWS inner points of a tile; a run record (uvec4 in TABLE_A): x = the tile's first
// inner point's drawing position, y = L | y0 << 16 (the run's first row, from 1), z = the tile's
// first border entry in the TABLE_B window (the tiled table's border positions), w = the run's
// first x (from 1).
#define PSUB_NORMAL_RUN 8
#define PSUB_NORMAL_ROWS 4

#endif
