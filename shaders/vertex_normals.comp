#version 450
// shaders/vertex_normals.comp: second half of the per-frame normals. Vertex v's unit normal is
// the sum of its faces' Newell normals (area-weighted), gathered in table order from
// faces[offsets[v] .. offsets[v + 1]) (offsets chunk-relative), then normalised; 0 when the
// sum is 0. Same order of operations as the CPU evaluator.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, binding = PSUB_BINDING_TABLE_A) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = PSUB_BINDING_TABLE_B) readonly buffer Faces { uint faces[]; };
layout(std430, binding = PSUB_BINDING_TABLE_C) readonly buffer Vertices { uint vertices[]; };

uint offsetAt(uint i) { return kTexels ? texelFetch(tableTexelsA, int(i)).x : offsets[i]; }
uint entryAt(uint i) { return kTexels ? texelFetch(tableTexelsB, int(i)).x : faces[i]; }
uint vertexAt(uint i) { return kTexels ? texelFetch(tableTexelsC, int(i)).x : vertices[i]; }

// PSUB_SPEC_ROW_N = 8 or 4: every vertex is in at most that many faces (or those in more are
// written again after this pass); vertex row's kWords words (its faces in table order, then
// pc.groupBase: an element of the input that holds zero) sit at kWords row from pc.tableBase (no
// offsets; pc.groupCount = kWords / 4 uvec4s). The first four are added unconditionally (adding
// +0 changes no sum), the next four in a loop that lavapipe skips unless a lane of the SIMD
// group needs it.
layout(constant_id = PSUB_SPEC_ROW_N) const uint kWords = 0xffffffffu;
const bool kFixedWords = kWords == 4u || kWords == 8u;
// PSUB_SPEC_LISTED: with kFixedWords, row r's sum is written at vertex offsets[pc.rowBase + r]
// (TABLE_A; its words at 8 r as ever: the tiled form's vertices that its tile normals pass
// leaves, their words in a table of their own); with CSR rows, at vertex vertices[pc.rowBase + r]
// (TABLE_C: the vertices in more faces than the fixed layout holds).
layout(constant_id = PSUB_SPEC_LISTED) const bool kListed = false;

uvec4 vertexWords(uint i) {
    if (kTexels) return texelFetch(tableTexelsB, int(i));
    return uvec4(faces[4u * i], faces[4u * i + 1u], faces[4u * i + 2u], faces[4u * i + 3u]);
}

void main() {
    const uint row = rowIndex();
    if (row >= pc.rowCount) return;
    precise vec3 n = vec3(0.0);
    const uint vertex = !kListed    ? pc.rowBase + row
                        : kFixedWords ? offsetAt(pc.rowBase + row)
                                      : vertexAt(pc.rowBase + row);
    if (kFixedWords) {
        const uint base = (pc.tableBase + kWords * row) / 4u;
        const uvec4 q = vertexWords(base);
        n += readElement(q.x).xyz;
        n += readElement(q.y).xyz;
        n += readElement(q.z).xyz;
        n += readElement(q.w).xyz;
        // pc.groupCount (2 or 1) uvec4 per vertex: a bound the compiler cannot see, so that it keeps
        // the loop (an unrolled one would be a branch, whose both sides lavapipe runs).
        for (uint k = 1u; k < pc.groupCount; ++k) {
            const uvec4 r = vertexWords(base + k);
            if (r.x == pc.groupBase) break;
            n += readElement(r.x).xyz;
            n += readElement(r.y).xyz;
            n += readElement(r.z).xyz;
            n += readElement(r.w).xyz;
        }
    } else {
        const uint begin = offsetAt(pc.tableBase + row), end = offsetAt(pc.tableBase + row + 1u);
        for (uint j = begin; j < end; ++j) n += readElement(entryAt(j)).xyz;
    }
    precise float size = sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    precise float scale = size > 0.0 ? 1.0 / size : 0.0;
    writeElement(vertex, vec4(n * scale, 0.0));
}
