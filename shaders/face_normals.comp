#version 450
// shaders/face_normals.comp: first half of the per-frame normals. Face f's Newell normal
// (twice its area along its normal) from the refined positions (the first three values of
// each element), written per face: no atomics, so the result never depends on scheduling.
// Face corners are faceVerts[offsets[f] .. offsets[f + 1]) (offsets chunk-relative).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, binding = PSUB_BINDING_TABLE_A) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = PSUB_BINDING_TABLE_B) readonly buffer Corners { uint corners[]; };

void main() {
    const uint row = rowIndex();
    if (row >= pc.rowCount) return;
    const uint begin = offsets[pc.tableBase + row], end = offsets[pc.tableBase + row + 1u];
    precise vec3 n = vec3(0.0);
    const vec3 first = readElement(corners[begin]).xyz;
    vec3 a = first;
    for (uint c = begin; c < end; ++c) {
        const vec3 b = c + 1u < end ? readElement(corners[c + 1u]).xyz : first;
        n.x += (a.y - b.y) * (a.z + b.z);
        n.y += (a.z - b.z) * (a.x + b.x);
        n.z += (a.x - b.x) * (a.y + b.y);
        a = b;
    }
    writeElement(pc.rowBase + row, vec4(n, 0.0));
}
