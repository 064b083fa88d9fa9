#version 450
// shaders/tile.comp: the tiled form's regular tiles (docs/tiled.md). One workgroup computes one
// block of at most PSUB_TILE_BLOCK x PSUB_TILE_BLOCK lattice points of a tile: it gathers the
// level-B window the block needs into workgroup-shared memory, runs the 2t P-S steps there with
// the regular masks (the intermediate levels never leave the workgroup), and writes the block's
// points that its tile owns straight to the finest level. Same arithmetic, in the same order,
// as the CPU kernel (compute/tiled_kernels.cpp), marked precise.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// TABLE_A: the dispatch's block records (config.h, PSUB_TILE_RECORD_MEMBERS); TABLE_B: the tiled
// table's gathered level-B vertices; TABLE_C: its border points' drawing positions.
layout(std430, binding = PSUB_BINDING_TABLE_A) readonly buffer Blocks { uvec4 blocks[]; };
layout(std430, binding = PSUB_BINDING_TABLE_B) readonly buffer Gather { uint gathered[]; };
layout(std430, binding = PSUB_BINDING_TABLE_C) readonly buffer Border { uint border[]; };

const uint kGrid = PSUB_TILE_GRID;
shared vec4 grid[kGrid * kGrid];              // the current level's grid, row by row
shared vec4 qv[(kGrid - 2u) * (kGrid - 2u)];  // its inner vertices' V-points
shared vec4 qf[(kGrid - 1u) * (kGrid - 1u)];  // its cells' F-points

uvec4 blockWord4(uint i) { return kTexels ? texelFetch(tableTexelsA, int(i)) : blocks[i]; }
uint gatheredAt(uint i) { return kTexels ? texelFetch(tableTexelsB, int(i)).x : gathered[i]; }
uint borderAt(uint i) { return kTexels ? texelFetch(tableTexelsC, int(i)).x : border[i]; }

// Values first .. first + 3 of input element `element` (those beyond kComponents 0).
vec4 readValues(uint element, uint first) {
    if (kComponents <= 4u) return readElement(element);
    const Place p = sourcePlace(element);
    vec4 value = vec4(0.0);
    for (uint i = 0u; i < 4u && first + i < kComponents; ++i) value[i] = readSource(p, first + i);
    return value;
}

void writeValues(uint element, uint first, vec4 value) {
    if (kComponents <= 4u) {
        writeElement(element, value);
        return;
    }
    const Place p = destinationPlace(element);
    for (uint i = 0u; i < 4u && first + i < kComponents; ++i) writeDestination(p, first + i, value[i]);
}

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
        precise vec4 value = 0.25 * grid[c] + 0.125 * ((grid[c - n] + grid[c + n]) + (grid[c - 1u] + grid[c + 1u])) +
                             0.0625 * ((grid[c - n - 1u] + grid[c + n + 1u]) + (grid[c - n + 1u] + grid[c + n - 1u]));
        qv[i] = value;
    }
    for (uint i = gl_LocalInvocationIndex; i < nf * nf; i += PSUB_WORKGROUP_SIZE) {
        const uvec2 xy = cell(i, nf);
        const uint c = xy.y * n + xy.x;
        precise vec4 value = 0.25 * ((grid[c] + grid[c + n + 1u]) + (grid[c + 1u] + grid[c + n]));
        qf[i] = value;
    }
}

// The block being computed (set once per workgroup, in main).
uint blockX0, blockY0, blockL, blockM, outputBegin, outputEnd, borderFirst, firstValue;

// Writes the block's lattice point (x, y) if its tile owns it. Each point of the tile's lattice
// is written by one block (the right and top edges by the last block of their row or column).
void emit(uint x, uint y, vec4 value) {
    const uint X = blockX0 + x, Y = blockY0 + y, L = blockL, M = blockM;
    if ((x == M && X != L) || (y == M && Y != L)) return;
    uint at;
    if (X > 0u && X < L && Y > 0u && Y < L) {
        at = outputBegin + (Y - 1u) * (L - 1u) + X - 1u;
    } else {  // border entries: row 0 whole, the two ends of each row between, row L whole
        const uint e = Y == 0u ? X : Y == L ? 3u * L - 1u + X : L + 2u * Y - 1u + (X == L ? 1u : 0u);
        at = borderAt(borderFirst + e);
        if (at < outputBegin || at >= outputEnd) return;
    }
    writeValues(at, firstValue, value);
}

// The second half: the points (p0 + x, p0 + y), x and y in [0, side) of parities px and py, of
// the fine grid (spacing 1/2, its (0, 0) at the coarse grid's (2, 2)) from the quincunx level
// of the n x n grid (compute/tiled_kernels.cpp, fineBody); p0 even. Into the grid (side x side)
// or, when `last`, to the finest level. One parity class per call, its rule chosen by constants
// at each call site: lavapipe would run all four rules for every lane under a branch.
void fineKind(const uint px, const uint py, uint n, uint p0, uint side, const bool last) {
    const uint nv = n - 2u, nf = n - 1u, columns = (side + 1u - px) / 2u, rows = (side + 1u - py) / 2u;
    for (uint k = gl_LocalInvocationIndex; k < columns * rows; k += PSUB_WORKGROUP_SIZE) {
        const uvec2 ab = cell(k, columns);
        const uint x = 2u * ab.x + px, y = 2u * ab.y + py, i = (p0 + x) / 2u + 2u, j = (p0 + y) / 2u + 2u;
        // V(a, b) = qv[(b - 1) nv + a - 1], F(a, b) = qf[b nf + a].
        const uint v = (j - 1u) * nv + i - 1u, f = j * nf + i;
        precise vec4 value;
        if (px == 0u && py == 0u)  // the V-point of V(i, j)
            value = 0.25 * qv[v] + 0.125 * ((qf[f - nf - 1u] + qf[f]) + (qf[f - nf] + qf[f - 1u])) +
                    0.0625 * ((qv[v - 1u] + qv[v + 1u]) + (qv[v - nv] + qv[v + nv]));
        else if (py == 0u)  // the diamond across x
            value = 0.25 * ((qv[v] + qv[v + 1u]) + (qf[f - nf] + qf[f]));
        else if (px == 0u)  // the diamond across y
            value = 0.25 * ((qv[v] + qv[v + nv]) + (qf[f - 1u] + qf[f]));
        else  // the V-point of F(i, j)
            value = 0.25 * qf[f] + 0.125 * ((qv[v] + qv[v + nv + 1u]) + (qv[v + 1u] + qv[v + nv])) +
                    0.0625 * ((qf[f - 1u] + qf[f + 1u]) + (qf[f - nf] + qf[f + nf]));
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
    const uvec4 a = blockWord4(2u * (pc.tableBase + block)), b = blockWord4(2u * (pc.tableBase + block) + 1u);
    const uint gatherFirst = a.x, g = a.y;
    blockL = a.z;
    blockM = a.w;
    blockX0 = b.x & 0xffffu;
    blockY0 = b.x >> 16;
    outputBegin = b.y;
    outputEnd = b.z;
    borderFirst = b.w;
    const uint t = pc.groupBase, halo = pc.groupCount;
    const uint n0 = (blockM >> t) + 2u * halo + 1u;  // the block's window of the tile's gathered grid
    // The block's lattice point (0, 0) in the last fine grid (docs/tiled.md).
    const uint r0 = (halo << t) + 4u - (4u << t);
    for (firstValue = 0u; firstValue < kComponents; firstValue += 4u) {
        for (uint i = gl_LocalInvocationIndex; i < n0 * n0; i += PSUB_WORKGROUP_SIZE) {
            const uvec2 xy = cell(i, n0);
            grid[i] = readValues(gatheredAt(gatherFirst + xy.y * g + xy.x), firstValue);
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
