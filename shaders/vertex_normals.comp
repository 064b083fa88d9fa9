#version 450
// shaders/vertex_normals.comp: second half of the per-frame normals. Vertex v's unit normal is
// the sum of its faces' Newell normals (area-weighted), gathered in table order from
// faces[offsets[v] .. offsets[v + 1]) (offsets chunk-relative), then normalised; 0 when the
// sum is 0. Same order of operations as the CPU evaluator.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, binding = PSUB_BINDING_TABLE_A) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = PSUB_BINDING_TABLE_B) readonly buffer Faces { uint faces[]; };

void main() {
    const uint row = rowIndex();
    if (row >= pc.rowCount) return;
    const uint begin = offsets[pc.tableBase + row], end = offsets[pc.tableBase + row + 1u];
    precise vec3 n = vec3(0.0);
    for (uint j = begin; j < end; ++j) n += readElement(faces[j]).xyz;
    precise float size = sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    precise float scale = size > 0.0 ? 1.0 / size : 0.0;
    writeElement(pc.rowBase + row, vec4(n * scale, 0.0));
}
