#version 450
// shaders/tile_unrolled.comp: the tiled form's regular tiles for CPU devices (lavapipe), where
// workgroup-shared memory is slow (docs/tiled.md, "On Vulkan"). One invocation computes one
// block of PSUB_TILE_BLOCK x PSUB_TILE_BLOCK lattice intervals of a tile: with t and the block
// side compiled in, every loop unrolls and every grid index is a constant, so the grids live in
// registers (and the stack) instead of memory whose address differs between lanes. The last
// block of a row or column may reach past the tile's side: its window is clamped to the tile's
// gathered grid and the points past the side are not written. At most 4 values per vertex
// (one vec4 per grid point). Same sums as tile.comp and the CPU kernel, so the same bits.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"

layout(constant_id = PSUB_SPEC_TILE_STEPS) const uint kSteps = 1;  // t, double steps (1 to 3)
const uint kHalo = kSteps + 1u;  // ceil(c_t) = 2, 3, 4 (docs/tiled.md)
const uint kBlock = PSUB_TILE_BLOCK;  // M, the block's side
const uint kWindow = (kBlock >> kSteps) + 2u * kHalo + 1u;  // the block's level-B window side
const uint kGrid = PSUB_TILE_GRID;
const uint kSide1 = 2u * kWindow - 9u, kSide2 = 2u * kSide1 - 9u;  // the grids after one and two double steps
const uint kLastSide = kSteps == 1u ? kWindow : kSteps == 2u ? kSide1 : kSide2;  // the last step's grid

vec4 grid[kGrid * kGrid];              // the current level's grid, row by row
vec4 qv[(kGrid - 2u) * (kGrid - 2u)];  // its inner vertices' V-points
vec4 qf[(kGrid - 1u) * (kGrid - 1u)];  // its cells' F-points

#include "tile_common.glsl"

// The first half of a double step on the n x n grid (tile.comp, quincunx).
void quincunx(const uint n) {
    const uint nv = n - 2u, nf = n - 1u;
    [[unroll]] for (uint y = 1u; y + 1u < n; ++y)
        [[unroll]] for (uint x = 1u; x + 1u < n; ++x) qv[(y - 1u) * nv + x - 1u] = quincunxVertex(y * n + x, n);
    [[unroll]] for (uint y = 0u; y + 1u < n; ++y)
        [[unroll]] for (uint x = 0u; x + 1u < n; ++x) qf[y * nf + x] = quincunxFace(y * n + x, n);
}

// The second half (tile.comp, fineKind): the fine points of parities (px, py) in [0, side)^2
// from p0, into the grid.
void fineKind(const uint px, const uint py, const uint n, const uint p0, const uint side) {
    const uint nv = n - 2u, nf = n - 1u;
    [[unroll]] for (uint y = py; y < side; y += 2u)
        [[unroll]] for (uint x = px; x < side; x += 2u) {
            const uint i = (p0 + x) / 2u + 2u, j = (p0 + y) / 2u + 2u;
            grid[y * side + x] = finePoint(px, py, (j - 1u) * nv + i - 1u, j * nf + i, nv, nf);
        }
}

void fineStep(const uint n, const uint p0, const uint side) {
    fineKind(0u, 0u, n, p0, side);
    fineKind(1u, 0u, n, p0, side);
    fineKind(0u, 1u, n, p0, side);
    fineKind(1u, 1u, n, p0, side);
}

// Writes lattice point (x, y) of the block, as emit() does. A point of the tile's ring has X or Y
// 0 or L, multiples of 2^t (the block's origin is a multiple of 16, and L = TiledTable::lattice,
// the tile's side in level-B cells times 2^t), so a point where neither x nor y is one is inner or
// past the side: it needs no border entry, which lavapipe would fetch in every lane, even those
// that skip it.
void emitPoint(const uint x, const uint y, vec4 value) {
    const uint step = 1u << kSteps;
    if (x % step == 0u || y % step == 0u) {
        emit(x, y, value);
        return;
    }
    const uint X = blockX0 + x, Y = blockY0 + y;
    if (X < blockL && Y < blockL) writeValues(outputBegin + (Y - 1u) * (blockL - 1u) + X - 1u, firstValue, value);
}

// The window's point gathered at `i`, its values past kComponents (a narrower vertex's padding)
// 0: the zeros fold through every sum when compiling, so only the vertex's own values are
// computed (at width 3 a quarter of the arithmetic less: positions about 10% faster on
// lavapipe), and the padding is written as 0.
vec4 windowValue(uint i) {
    vec4 value = readValues(gatheredAt(i), firstValue);
    if (kComponents < 4u) value.w = 0.0;
    if (kComponents < 3u) value.z = 0.0;
    if (kComponents < 2u) value.y = 0.0;
    return value;
}

void main() {
    const uint block = rowIndex();
    if (block >= pc.rowCount) return;
    readBlock(block);
    // The window's last row and column within the tile's gathered grid.
    const uint lastX = gridSide - 1u - (blockX0 >> kSteps), lastY = gridSide - 1u - (blockY0 >> kSteps);
    const uint r0 = (kHalo << kSteps) + 4u - (4u << kSteps);  // lattice point (0, 0) in the last fine grid
    for (firstValue = 0u; firstValue < kComponents; firstValue += 4u) {
        [[unroll]] for (uint y = 0u; y < kWindow; ++y)
            [[unroll]] for (uint x = 0u; x < kWindow; ++x)
                grid[y * kWindow + x] = windowValue(gatherFirst + min(y, lastY) * gridSide + min(x, lastX));
        // Spelt out per step, no loop over the steps: with one (even never run), lavapipe
        // unrolled nothing (50 s to compile, slower than the workgroup kernel).
        if (kSteps >= 2u) {
            quincunx(kWindow);
            fineStep(kWindow, 0u, kSide1);
        }
        if (kSteps >= 3u) {
            quincunx(kSide1);
            fineStep(kSide1, 0u, kSide2);
        }
        quincunx(kLastSide);
        // The last grid whole, then written row by row (each lane's points in output order:
        // about 10% faster on lavapipe at t = 1 and 2 than written by parity as fineStep makes them).
        fineStep(kLastSide, r0, kBlock + 1u);
        [[unroll]] for (uint y = 0u; y <= kBlock; ++y)
            [[unroll]] for (uint x = 0u; x <= kBlock; ++x) emitPoint(x, y, grid[y * (kBlock + 1u) + x]);
    }
}
