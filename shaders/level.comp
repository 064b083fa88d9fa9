#version 450
// shaders/level.comp: row groups of one level of the per-level, kind-coded stencil table (a
// dispatch per large group, or per chunk of one too large for one binding; the small groups of a
// level's stage together, their records in turn). A group's record gives the shape (n edge
// neighbours, m diagonals), the three weights and where its rows start; row r's words are its
// 1 + n + m source indices, then its destination, padded to a multiple of 4 (one uvec4 fetch per
// 4 words). The common shapes are compiled in for a dispatch of one group (PSUB_SPEC_ROW_N/M):
// their loops unroll and the words are fetched up front. Same arithmetic,
// in the same order, as the CPU kernel (psub/evaluator.h), with no contraction into fused
// multiply-adds. A VertexFromFacePoints group's sources are points of the level it writes (its
// dispatch binds that level as the source too, after a barrier: docs/design.md).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

struct GroupRecord { PSUB_GROUP_RECORD_MEMBERS };

layout(constant_id = PSUB_SPEC_ROW_N) const uint kRowN = 0xffffffffu;
layout(constant_id = PSUB_SPEC_ROW_M) const uint kRowM = 0xffffffffu;
const bool kFixedShape = kRowN != 0xffffffffu && kRowM != 0xffffffffu;
// A dispatch of one group whose destinations are consecutive: row r writes element pc.rowBase +
// r, and its words are its sources alone (a quad's face point: one uvec4 fetch, 16 bytes, not 32).
layout(constant_id = PSUB_SPEC_IMPLICIT_DESTINATION) const bool kImplicitDestination = false;
const uint kDestinationWords = kImplicitDestination ? 0u : 1u;
// Words per row of a compiled-in shape, and its uvec4 count (at most 3: valence 4).
const uint kFixedStride = kFixedShape ? ((1u + kDestinationWords + kRowN + kRowM + 3u) & ~3u) : 4u;

layout(std430, binding = PSUB_BINDING_TABLE_A) readonly buffer Groups { GroupRecord groups[]; };
// TABLE_B and TABLE_C bind the same window of row words (storage-buffer path).
layout(std430, binding = PSUB_BINDING_TABLE_B) readonly buffer Destinations { uint destinations[]; };
layout(std430, binding = PSUB_BINDING_TABLE_C) readonly buffer Indices { uint indices[]; };

uint groupWord(uint i, uint word) { return texelFetch(tableTexelsA, int(8u * i + word)).x; }
GroupRecord groupAt(uint i) {
    if (!kTexels) return groups[i];
    return GroupRecord(groupWord(i, 0u), groupWord(i, 1u), groupWord(i, 2u), groupWord(i, 3u),
                       uintBitsToFloat(groupWord(i, 4u)), uintBitsToFloat(groupWord(i, 5u)),
                       uintBitsToFloat(groupWord(i, 6u)), groupWord(i, 7u));
}
uint groupRowBegin(uint i) { return kTexels ? groupWord(i, 0u) : groups[i].rowBegin; }

// Word j of the row whose words start at `base` (a multiple of 4); `q` holds the row's words
// when the shape is compiled in.
uint rowWord(uvec4 q[3], uint base, uint j, uint count) {
    if (kTexels && kFixedShape) return q[j >> 2][j & 3u];
    if (kTexels) return texelFetch(tableTexelsC, int((base + j) >> 2))[(base + j) & 3u];
    return j == count ? destinations[base + j] : indices[base + j];
}

void main() {
    uint row = rowIndex();
    if (row >= pc.rowCount) return;
    // A dispatch of one group has its record in the push constants: its rows read none (on
    // lavapipe every read of one is a gather; the torus's per-level frame at 1M faces was 20%
    // slower with two more a row). Several groups (never with the shape compiled in): the last
    // whose first row is this one or before.
    const bool several = !kFixedShape && pc.groupCount > 1u;
    GroupRecord g = GroupRecord(0u, pc.groupIndexBegin, pc.groupN, pc.groupM, pc.groupCentre,
                                pc.groupEdge, pc.groupDiagonal, pc.rowCount);
    if (several) {
        uint record = pc.groupBase;
        for (uint k = 1u; k < pc.groupCount && groupRowBegin(pc.groupBase + k) <= row; ++k) record = pc.groupBase + k;
        g = groupAt(record);
        row -= g.rowBegin;
        if (row >= g.rowCount) return;  // past the group's rows, before the next's
    }
    const uint n = kFixedShape ? kRowN : g.n, m = kFixedShape ? kRowM : g.m;
    const uint count = 1u + n + m;  // sources; the destination is word `count` (unless implicit)
    const uint stride = kFixedShape ? kFixedStride : (count + kDestinationWords + 3u) & ~3u;
    const uint base = g.indexBegin + row * stride;
    uvec4 q[3];
    if (kTexels && kFixedShape)
        for (uint k = 0u; k < 3u; ++k) q[k] = 4u * k < kFixedStride ? texelFetch(tableTexelsC, int(base / 4u + k)) : uvec4(0u);
    const uint destination = kImplicitDestination ? pc.rowBase + row : rowWord(q, base, count, count);
    if (kComponents <= 4u) {  // one vec4 per source
        precise vec4 centre = g.centre * readElement(rowWord(q, base, 0u, count)), edges = vec4(0.0), diagonals = vec4(0.0);
        for (uint j = 1u; j <= n; ++j) edges += readElement(rowWord(q, base, j, count));
        for (uint j = 1u + n; j <= n + m; ++j) diagonals += readElement(rowWord(q, base, j, count));
        precise vec4 value = centre + g.edge * edges + g.diagonal * diagonals;
        writeElement(destination, value);
        return;
    }
    precise float centre[kComponents], edges[kComponents], diagonals[kComponents];
    const Place c = sourcePlace(rowWord(q, base, 0u, count));
    for (uint i = 0u; i < kComponents; ++i) {
        centre[i] = g.centre * readSource(c, i);
        edges[i] = 0.0;
        diagonals[i] = 0.0;
    }
    for (uint j = 1u; j <= n; ++j) {
        const Place p = sourcePlace(rowWord(q, base, j, count));
        for (uint i = 0u; i < kComponents; ++i) edges[i] += readSource(p, i);
    }
    for (uint j = 1u + n; j <= n + m; ++j) {
        const Place p = sourcePlace(rowWord(q, base, j, count));
        for (uint i = 0u; i < kComponents; ++i) diagonals[i] += readSource(p, i);
    }
    const Place target = destinationPlace(destination);
    for (uint i = 0u; i < kComponents; ++i) {
        precise float value = centre[i] + g.edge * edges[i] + g.diagonal * diagonals[i];
        writeDestination(target, i, value);
    }
}
