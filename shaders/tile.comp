#version 450
// shaders/tile.comp: the tiled form's regular tiles (docs/tiled.md). One workgroup computes one
// block of at most 16 x 16 or 32 x 32 lattice intervals of a tile: it gathers the level-B window
// the block needs into workgroup-shared memory, runs the 2t P-S steps there with the regular
// masks (the intermediate levels never leave the workgroup), and writes the block's points that
// its tile owns straight to the finest level, and optionally their normals too. Same arithmetic,
// in the same order, as the CPU kernel (compute/tiled_kernels.cpp), marked precise.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// The workgroup's invocations (a specialization constant; the host asks 512 for blocks of 32 and
// 256 for blocks of 16 by default): every pass loops over its points in steps of it, so it
// changes how many lanes share a pass, never the sums.
layout(local_size_x_id = PSUB_SPEC_TILE_THREADS) in;
const uint kThreads = gl_WorkGroupSize.x;

// The shared grids' side: the largest grid any step keeps, for the block side the host chose
// from the device's shared memory (PSUB_TILE_GRID for blocks of 16, more for blocks of 32).
layout(constant_id = PSUB_SPEC_TILE_GRID) const uint kGrid = PSUB_TILE_GRID;
// Non-zero: also the unit normals of the tiles' inner points (emitWithNormals), the last fine
// pass keeping a grid of this side (the widest block's side + 3) in `grid`.
layout(constant_id = PSUB_SPEC_TILE_NORMALS) const uint kKeptSide = 0;
const bool kNormals = kKeptSide != 0u;
shared vec4 grid[kKeptSide > kGrid ? kKeptSide * kKeptSide : kGrid * kGrid];  // the current level's grid, row by row
shared vec4 qv[(kGrid - 2u) * (kGrid - 2u)];  // its inner vertices' V-points
shared vec4 qf[(kGrid - 1u) * (kGrid - 1u)];  // its cells' F-points

#include "tile_common.glsl"

// (i % n, i / n) without an integer division: lavapipe runs each one per lane (x86 has no
// vector integer division), which made divisions most of the kernel's time there. Exact for
// i < 2^16 and n <= kGrid: (i + 0.5) / n is at least 0.5 / n away from an integer.
uvec2 cell(uint i, uint n) {
    const uint y = uint((float(i) + 0.5) / float(n));
    return uvec2(i - y * n, y);
}

// The first half of a double step on the n x n grid: V-points of its inner vertices, F-points
// of its cells (compute/tiled_kernels.cpp, quincunxBody).
void quincunx(uint n) {
    const uint nv = n - 2u, nf = n - 1u;
    for (uint i = gl_LocalInvocationIndex; i < nv * nv; i += kThreads) {
        const uvec2 xy = cell(i, nv) + 1u;
        const uint c = xy.y * n + xy.x;
        qv[i] = quincunxVertex(c, n);
    }
    for (uint i = gl_LocalInvocationIndex; i < nf * nf; i += kThreads) {
        const uvec2 xy = cell(i, nf);
        const uint c = xy.y * n + xy.x;
        qf[i] = quincunxFace(c, n);
    }
}

// The second half: the fine grid of the given side (spacing 1/2, its (0, 0) at the coarse grid's
// (2, 2) + p0 / 2, p0 even) from the quincunx level of the n x n grid (compute/tiled_kernels.cpp,
// fineBody), into the grid (side x side) or, when `last`, to the finest level. One invocation
// per 2 x 2 cell of fine points: the four share their V(i, j) and F(i, j), and one loop keeps
// every invocation busy where four loops, one per parity, left half of them idle on the small
// grids. The sides are odd, so the last row and column of cells hold their even points alone.
void put(uint x, uint y, uint side, const bool last, vec4 value) {
    if (last) emit(x, y, value);
    else grid[y * side + x] = value;
}

void fineStep(uint n, uint p0, uint side, const bool last) {
    const uint nv = n - 2u, nf = n - 1u, cells = (side + 1u) / 2u;
    for (uint k = gl_LocalInvocationIndex; k < cells * cells; k += kThreads) {
        const uvec2 ab = cell(k, cells);
        const uint x = 2u * ab.x, y = 2u * ab.y, i = (p0 + x) / 2u + 2u, j = (p0 + y) / 2u + 2u;
        // V(a, b) = qv[(b - 1) nv + a - 1], F(a, b) = qf[b nf + a].
        const uint v = (j - 1u) * nv + i - 1u, f = j * nf + i;
        put(x, y, side, last, finePoint(0u, 0u, v, f, nv, nf));
        if (x + 1u < side) put(x + 1u, y, side, last, finePoint(1u, 0u, v, f, nv, nf));
        if (y + 1u < side) {
            put(x, y + 1u, side, last, finePoint(0u, 1u, v, f, nv, nf));
            if (x + 1u < side) put(x + 1u, y + 1u, side, last, finePoint(1u, 1u, v, f, nv, nf));
        }
    }
}

// With normals: the last fine pass keeps the block's points and a ring of two more in the grid
// (from lattice point (-2, -2), an even start for the pass's cells; side M + 3; the last fine
// grid reaches that far at t = 3 as it is, at t = 1 and 2 from main()'s wider window), then this
// writes each point its tile owns and gives each such inner point the unit normal of its four
// quads, read from the 3 x 3 points around it, to the destination's second binding (the
// normals; the positions then fit in the first). tile_normals.comp's sums in its order: the
// same bits.
void emitWithNormals(uint side) {
    const uint points = blockM + 1u;
    for (uint k = gl_LocalInvocationIndex; k < points * points; k += kThreads) {
        const uvec2 xy = cell(k, points);
        bool inner;
        const uint at = ownedAt(xy.x, xy.y, inner);
        if (at == kNowhere) continue;
        const uint c = (xy.y + 2u) * side + xy.x + 2u;
        writeValues(at, firstValue, grid[c]);
        if (!inner) continue;
        const vec3 p00 = grid[c - side - 1u].xyz, p10 = grid[c - side].xyz, p20 = grid[c - side + 1u].xyz;
        const vec3 p01 = grid[c - 1u].xyz, p11 = grid[c].xyz, p21 = grid[c + 1u].xyz;
        const vec3 p02 = grid[c + side - 1u].xyz, p12 = grid[c + side].xyz, p22 = grid[c + side + 1u].xyz;
        destinationVector1.v[at] = unitNormal(quadNormal(p00, p10, p11, p01), quadNormal(p10, p20, p21, p11),
                                              quadNormal(p01, p11, p12, p02), quadNormal(p11, p21, p22, p12));
    }
}

void main() {
    const uint block = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (block >= pc.rowCount) return;  // the whole workgroup: no barrier is skipped by some
    readBlock(block);
    const uint t = pc.groupBase;
    // With normals where the window's last fine grid ends at the block's own points (t = 1, 2):
    // one level-B cell more on each side, read clamped to the tile's gathered grid. A clamped
    // cell changes only points before or past the block, which a block at the tile's edge needs
    // for no normal (its ring points' normals are the listed passes').
    const uint halo = pc.groupCount + (kNormals && (pc.groupCount << t) + 4u < (4u << t) + 2u ? 1u : 0u);
    const uint n0 = (blockM >> t) + 2u * halo + 1u;  // the block's window of the tile's gathered grid
    // The block's lattice point (0, 0) in the last fine grid (docs/tiled.md).
    const uint r0 = (halo << t) + 4u - (4u << t);
    // The window's first cell in the tile's gathered grid (gatherFirst: its cell (X0, Y0) / 2^t).
    const ivec2 cell0 = ivec2(blockX0 >> t, blockY0 >> t) - int(halo - pc.groupCount);
    const uint tileFirst = gatherFirst - (blockY0 >> t) * gridSide - (blockX0 >> t);
    for (firstValue = 0u; firstValue < kComponents; firstValue += 4u) {
        for (uint i = gl_LocalInvocationIndex; i < n0 * n0; i += kThreads) {
            const uvec2 at = uvec2(clamp(cell0 + ivec2(cell(i, n0)), 0, int(gridSide) - 1));
            grid[i] = readValues(gatheredAt(tileFirst + at.y * gridSide + at.x), firstValue);
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
        if (kNormals) {
            fineStep(n, r0 - 2u, blockM + 3u, false);
            barrier();
            emitWithNormals(blockM + 3u);
        } else {
            fineStep(n, r0, blockM + 1u, true);
        }
        barrier();  // the next values' gather overwrites the grid
    }
}
