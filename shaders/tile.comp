#version 450
// shaders/tile.comp: the tiled form's regular tiles (docs/tiled.md). One workgroup computes one
// block of at most PSUB_TILE_BLOCK x PSUB_TILE_BLOCK lattice points of a tile: it gathers the
// level-B window the block needs into workgroup-shared memory, runs the 2t P-S steps there with
// the regular masks (the intermediate levels never leave the workgroup), and writes the block's
// points that its tile owns straight to the finest level. Same arithmetic, in the same order,
// as the CPU kernel (compute/tiled_kernels.cpp), marked precise.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

const uint kGrid = PSUB_TILE_GRID;
shared vec4 grid[kGrid * kGrid];              // the current level's grid, row by row
shared vec4 qv[(kGrid - 2u) * (kGrid - 2u)];  // its inner vertices' V-points
shared vec4 qf[(kGrid - 1u) * (kGrid - 1u)];  // its cells' F-points

#include "tile_common.glsl"

// (i % n, i / n) without an integer division: lavapipe runs each one per lane (x86 has no
// vector integer division), which made divisions most of the kernel's time there. Exact for
// i < 2^16 and n <= PSUB_TILE_GRID: (i + 0.5) / n is at least 0.5 / n away from an integer.
uvec2 cell(uint i, uint n) {
    const uint y = uint((float(i) + 0.5) / float(n));
    return uvec2(i - y * n, y);
}

// The first half of a double step on the n x n grid: V-points of its inner vertices, F-points
// of its cells (compute/tiled_kernels.cpp, quincunxBody).
void quincunx(uint n) {
    const uint nv = n - 2u, nf = n - 1u;
    for (uint i = gl_LocalInvocationIndex; i < nv * nv; i += PSUB_WORKGROUP_SIZE) {
        const uvec2 xy = cell(i, nv) + 1u;
        const uint c = xy.y * n + xy.x;
        qv[i] = quincunxVertex(c, n);
    }
    for (uint i = gl_LocalInvocationIndex; i < nf * nf; i += PSUB_WORKGROUP_SIZE) {
        const uvec2 xy = cell(i, nf);
        const uint c = xy.y * n + xy.x;
        qf[i] = quincunxFace(c, n);
    }
}

// The second half: the points (p0 + x, p0 + y), x and y in [0, side) of parities px and py, of
// the fine grid (spacing 1/2, its (0, 0) at the coarse grid's (2, 2)) from the quincunx level
// of the n x n grid (compute/tiled_kernels.cpp, fineBody); p0 even. Into the grid (side x side)
// or, when `last`, to the finest level. One parity class per call (finePoint's constants).
void fineKind(const uint px, const uint py, uint n, uint p0, uint side, const bool last) {
    const uint nv = n - 2u, nf = n - 1u, columns = (side + 1u - px) / 2u, rows = (side + 1u - py) / 2u;
    for (uint k = gl_LocalInvocationIndex; k < columns * rows; k += PSUB_WORKGROUP_SIZE) {
        const uvec2 ab = cell(k, columns);
        const uint x = 2u * ab.x + px, y = 2u * ab.y + py, i = (p0 + x) / 2u + 2u, j = (p0 + y) / 2u + 2u;
        // V(a, b) = qv[(b - 1) nv + a - 1], F(a, b) = qf[b nf + a].
        const vec4 value = finePoint(px, py, (j - 1u) * nv + i - 1u, j * nf + i, nv, nf);
        if (last) emit(x, y, value);
        else grid[y * side + x] = value;
    }
}

void fineStep(uint n, uint p0, uint side, const bool last) {
    fineKind(0u, 0u, n, p0, side, last);
    fineKind(1u, 0u, n, p0, side, last);
    fineKind(0u, 1u, n, p0, side, last);
    fineKind(1u, 1u, n, p0, side, last);
}

void main() {
    const uint block = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (block >= pc.rowCount) return;  // the whole workgroup: no barrier is skipped by some
    readBlock(block);
    const uint t = pc.groupBase, halo = pc.groupCount;
    const uint n0 = (blockM >> t) + 2u * halo + 1u;  // the block's window of the tile's gathered grid
    // The block's lattice point (0, 0) in the last fine grid (docs/tiled.md).
    const uint r0 = (halo << t) + 4u - (4u << t);
    for (firstValue = 0u; firstValue < kComponents; firstValue += 4u) {
        for (uint i = gl_LocalInvocationIndex; i < n0 * n0; i += PSUB_WORKGROUP_SIZE) {
            const uvec2 xy = cell(i, n0);
            grid[i] = readValues(gatheredAt(gatherFirst + xy.y * gridSide + xy.x), firstValue);
        }
        uint n = n0;
        for (uint s = 0u; s + 1u < t; ++s) {
            barrier();
            quincunx(n);
            barrier();
            fineStep(n, 0u, 2u * n - 9u, false);
            n = 2u * n - 9u;
        }
        barrier();
        quincunx(n);
        barrier();
        fineStep(n, r0, blockM + 1u, true);
        barrier();  // the next values' gather overwrites the grid
    }
}
