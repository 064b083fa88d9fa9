#version 450
// shaders/factorized.comp: the factorized (CSR) stencil table, control points straight to
// the finest level. Row r of the chunk is sum of weights[j] * source[indices[j]] for j in
// offsets[r] .. offsets[r + 1] (offsets relative to the chunk's index and weight windows).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, binding = PSUB_BINDING_TABLE_A) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = PSUB_BINDING_TABLE_B) readonly buffer Indices { uint indices[]; };
layout(std430, binding = PSUB_BINDING_TABLE_C) readonly buffer Weights { float weights[]; };

uint offsetAt(uint i) { return kTexels ? texelFetch(tableTexelsA, int(i)).x : offsets[i]; }
uint indexAt(uint i) { return kTexels ? texelFetch(tableTexelsB, int(i)).x : indices[i]; }
float weightAt(uint i) { return kTexels ? uintBitsToFloat(texelFetch(tableTexelsC, int(i)).x) : weights[i]; }

void main() {
    const uint row = rowIndex();
    if (row >= pc.rowCount) return;
    const uint begin = offsetAt(pc.tableBase + row), end = offsetAt(pc.tableBase + row + 1u);
    if (kComponents <= 4u) {  // one vec4 per source
        precise vec4 total = vec4(0.0);
        for (uint j = begin; j < end; ++j) total += weightAt(j) * readElement(indexAt(j));
        writeElement(pc.rowBase + row, total);
        return;
    }
    precise float sum[kComponents];
    for (uint i = 0u; i < kComponents; ++i) sum[i] = 0.0;
    for (uint j = begin; j < end; ++j) {
        const Place p = sourcePlace(indexAt(j));
        const float w = weightAt(j);
        for (uint i = 0u; i < kComponents; ++i) sum[i] += w * readSource(p, i);
    }
    const Place target = destinationPlace(pc.rowBase + row);
    for (uint i = 0u; i < kComponents; ++i) writeDestination(target, i, sum[i]);
}
