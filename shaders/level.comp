#version 450
// shaders/level.comp: one level of the per-level, kind-coded stencil table. One dispatch per
// level (or per chunk of a level too large for one binding): row r of the chunk finds its row
// group (a binary search over the chunk's few group records), then sums its sources with the
// group's three weights: centre, edge neighbours, diagonals. Rows of a group are contiguous,
// so a workgroup almost never sees two groups. Same arithmetic, in the same order, as the CPU
// kernel (psub/evaluator.h), with no contraction into fused multiply-adds.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

struct GroupRecord { PSUB_GROUP_RECORD_MEMBERS };

layout(std430, binding = PSUB_BINDING_TABLE_A) readonly buffer Groups { GroupRecord groups[]; };
layout(std430, binding = PSUB_BINDING_TABLE_B) readonly buffer Destinations { uint destinations[]; };
layout(std430, binding = PSUB_BINDING_TABLE_C) readonly buffer Indices { uint indices[]; };

// The last group record of this chunk starting at or before `row` (binary search).
uint findGroup(uint row) {
    uint lo = 0u, hi = pc.groupCount - 1u;
    while (lo < hi) {
        const uint mid = (lo + hi + 1u) >> 1;
        if (groups[pc.groupBase + mid].rowBegin <= row) lo = mid;
        else hi = mid - 1u;
    }
    return lo;
}

void applyRow(uint row, GroupRecord g) {
    const uint base = g.indexBegin + (row - g.rowBegin) * (1u + g.n + g.m);
    if (kComponents <= 4u) {  // one vec4 per source
        precise vec4 centre = g.centre * readElement(indices[base]), edges = vec4(0.0), diagonals = vec4(0.0);
        for (uint j = 1u; j <= g.n; ++j) edges += readElement(indices[base + j]);
        for (uint j = 1u + g.n; j <= g.n + g.m; ++j) diagonals += readElement(indices[base + j]);
        precise vec4 value = centre + g.edge * edges + g.diagonal * diagonals;
        writeElement(destinations[pc.tableBase + row], value);
        return;
    }
    precise float centre[kComponents], edges[kComponents], diagonals[kComponents];
    const Place c = sourcePlace(indices[base]);
    for (uint i = 0u; i < kComponents; ++i) {
        centre[i] = g.centre * readSource(c, i);
        edges[i] = 0.0;
        diagonals[i] = 0.0;
    }
    for (uint j = 1u; j <= g.n; ++j) {
        const Place p = sourcePlace(indices[base + j]);
        for (uint i = 0u; i < kComponents; ++i) edges[i] += readSource(p, i);
    }
    for (uint j = 1u + g.n; j <= g.n + g.m; ++j) {
        const Place p = sourcePlace(indices[base + j]);
        for (uint i = 0u; i < kComponents; ++i) diagonals[i] += readSource(p, i);
    }
    const Place target = destinationPlace(destinations[pc.tableBase + row]);
    for (uint i = 0u; i < kComponents; ++i) {
        precise float value = centre[i] + g.edge * edges[i] + g.diagonal * diagonals[i];
        writeDestination(target, i, value);
    }
}

void main() {
    // The group is looked up once per workgroup (the same for all its invocations, so the
    // loads are uniform); only a workgroup that straddles two groups looks up per row.
    const uint first = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * PSUB_WORKGROUP_SIZE;
    const uint found = findGroup(first);
    const GroupRecord g = groups[pc.groupBase + found];
    const uint last = min(first + PSUB_WORKGROUP_SIZE, pc.rowCount) - 1u;
    const bool straddles = found + 1u < pc.groupCount && groups[pc.groupBase + found + 1u].rowBegin <= last;
    const uint row = first + gl_LocalInvocationID.x;
    if (row >= pc.rowCount) return;
    if (!straddles) applyRow(row, g);
    else applyRow(row, groups[pc.groupBase + findGroup(row)]);
}
