#version 450
// shaders/tile_normals.comp: the tiled form's unit normals of its tiles' inner points, read
// from the refined positions (drawing order) by implicit addressing: a tile's inner point
// (x, y), 0 < x, y < L, sits at its first inner position + (y - 1)(L - 1) + x - 1, and its
// border points come from the tiled table's border list (config.h, "tile_normals.comp"). One
// invocation takes a run of PSUB_NORMAL_RUN x PSUB_NORMAL_ROWS points (8 x 4: 60 reads for 32
// points; runs of one row read 30 for 8 and were 10% slower on lavapipe): it reads the points
// around them once, forms the quads' normals between them and gives each point the sum of its
// four, in the CPU tile pass's order and operations (compute/tiled_kernels.cpp), so the same
// bits. The border points and the fallback's are the listed normal passes'.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"

layout(std430, binding = PSUB_BINDING_TABLE_A) readonly buffer Runs { uvec4 runs[]; };
layout(std430, binding = PSUB_BINDING_TABLE_B) readonly buffer Border { uint border[]; };

const uint kRun = PSUB_NORMAL_RUN, kRows = PSUB_NORMAL_ROWS, kRead = kRun + 2u;

uvec4 runAt(uint i) { return kTexels ? texelFetch(tableTexelsA, int(i)) : runs[i]; }
uint borderAt(uint i) { return kTexels ? texelFetch(tableTexelsB, int(i)).x : border[i]; }

// The drawing position of lattice point (x, y) of a tile (inner points from `first`, border
// entries from `ring`): one fetch under one branch (a branch per case, each with its fetch,
// took 11.4 against 9.1 ms at 1M points on lavapipe, which runs a branch's fetch for the whole
// SIMD group whenever one lane takes it).
uint latticePoint(uint x, uint y, uint L, uint first, uint ring) {
    uint point = first + (y - 1u) * (L - 1u) + x - 1u;
    if (x == 0u || y == 0u || x == L || y == L) point = borderAt(ring + ringEntry(x, y, L));
    return point;
}

void main() {
    const uint row = rowIndex();
    if (row >= pc.rowCount) return;
    const uvec4 run = runAt(pc.tableBase + row);
    const uint first = run.x, L = run.y & 0xffffu, y0 = run.y >> 16, ring = run.z, x0 = run.w;
    // Points (x0 - 1 + i, y0 - 1 + r), i < kRead, r < kRows + 2 (past the lattice's side: its
    // last point).
    vec3 p[(kRows + 2u) * kRead];
    [[unroll]] for (uint r = 0u; r < kRows + 2u; ++r)
        [[unroll]] for (uint i = 0u; i < kRead; ++i)
            p[r * kRead + i] = readElement(latticePoint(min(x0 + i - 1u, L), min(y0 + r - 1u, L), L, first, ring)).xyz;
    // Quads (x0 - 1 + i, y0 - 1 + r), i <= kRun, r <= kRows.
    vec3 q[(kRows + 1u) * (kRun + 1u)];
    [[unroll]] for (uint r = 0u; r <= kRows; ++r)
        [[unroll]] for (uint i = 0u; i <= kRun; ++i) {
            const uint a = r * kRead + i, b = a + kRead;
            q[r * (kRun + 1u) + i] = quadNormal(p[a], p[a + 1u], p[b + 1u], p[b]);
        }
    [[unroll]] for (uint r = 0u; r < kRows; ++r)
        [[unroll]] for (uint j = 0u; j < kRun; ++j)
            if (x0 + j < L && y0 + r < L) {
                const uint lo = r * (kRun + 1u) + j, hi = lo + kRun + 1u;
                writeElement(first + (y0 + r - 1u) * (L - 1u) + x0 + j - 1u,
                             unitNormal(q[lo], q[lo + 1u], q[hi], q[hi + 1u]));
            }
}
