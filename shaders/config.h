// shaders/config.h: the contract between the C++ Vulkan evaluator and the GLSL kernels, read
// by both (glslangValidator -I and the psub_vulkan target). Binding numbers, workgroup size,
// specialization constant ids, and the layouts of the push constants and group records.
// The C++ side checks every pipeline against it (psub/vulkan pipelines.cpp, reflectSpirv).
#ifndef PSUB_SHADERS_CONFIG_H
#define PSUB_SHADERS_CONFIG_H

// Invocations per workgroup (one row each). Dispatches are 2-D when a chunk has more
// workgroups than maxComputeWorkGroupCount[0].
#define PSUB_WORKGROUP_SIZE 64

// A vertex-like buffer (positions of a level, face normals, normals) larger than
// maxStorageBufferRange is bound as up to this many consecutive windows.
#define PSUB_VERTEX_WINDOWS 4

// One descriptor set, the same layout for every kernel: the input vertex buffer's windows,
// the output vertex buffer's windows, then three table arrays (each bound at the window of
// the chunk being dispatched).
#define PSUB_BINDING_SOURCE 0        // PSUB_BINDING_SOURCE + w, w < PSUB_VERTEX_WINDOWS
#define PSUB_BINDING_DESTINATION 4   // PSUB_BINDING_DESTINATION + w
#define PSUB_BINDING_TABLE_A 8       // level: group records; CSR kernels: chunk-relative offsets
#define PSUB_BINDING_TABLE_B 9       // level: destinations; CSR kernels: column indices
#define PSUB_BINDING_TABLE_C 10      // level: source indices; factorized: weights
#define PSUB_BINDING_COUNT 11

// Specialization constants, fixed per pipeline.
#define PSUB_SPEC_COMPONENTS 0         // values combined per element (the evaluator's width; 3 for normals)
#define PSUB_SPEC_SOURCE_STRIDE 1      // floats per input element
#define PSUB_SPEC_DESTINATION_STRIDE 2 // floats per output element
#define PSUB_SPEC_SOURCE_WINDOWED 3    // the input is bound as more than one window
#define PSUB_SPEC_DESTINATION_WINDOWED 4

// Push constants, per dispatch (all 32-bit).
//   rowCount           rows in this dispatch; invocations beyond it return at once
//   rowBase            the first row's element number in the output (CSR kernels)
//   groupBase          level kernel: first group record of this chunk
//   groupCount         level kernel: group records of this chunk (at least 1 when rows > 0)
//   tableBase          level kernel: first destination in the TABLE_B window;
//                      CSR kernels: first offset in the TABLE_A window
//   sourceWindowSize   elements per input window (when windowed)
//   destinationWindowSize
//   pad
#define PSUB_PUSH_CONSTANT_MEMBERS                                                              \
    uint rowCount;                                                                             \
    uint rowBase;                                                                              \
    uint groupBase;                                                                            \
    uint groupCount;                                                                           \
    uint tableBase;                                                                            \
    uint sourceWindowSize;                                                                     \
    uint destinationWindowSize;                                                                \
    uint pad;

// One row group of the per-level table as seen by one chunk (std430, 32 bytes): rows
// rowBegin.. (chunk-relative) have 1 + n + m source indices from indexBegin (relative to the
// chunk's index window): the centre, n edge neighbours, m diagonals, with these weights.
#define PSUB_GROUP_RECORD_MEMBERS                                                               \
    uint rowBegin;                                                                             \
    uint indexBegin;                                                                           \
    uint n;                                                                                    \
    uint m;                                                                                    \
    float centre;                                                                              \
    float edge;                                                                                \
    float diagonal;                                                                            \
    uint pad;

#endif
