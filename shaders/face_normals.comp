#version 450
// shaders/face_normals.comp: first half of the per-frame normals. Face f's Newell normal
// (twice its area along its normal) from the refined positions (the first three values of
// each element), written per face: no atomics, so the result never depends on scheduling.
// A quad's is computed as the cross product of its diagonals, (p2 - p0) x (p3 - p1), equal in
// exact arithmetic and the CPU's way (compute/cpu_evaluator.cpp), operation for operation.
// Face corners are faceVerts[offsets[f] .. offsets[f + 1]) (offsets chunk-relative).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, binding = PSUB_BINDING_TABLE_A) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = PSUB_BINDING_TABLE_B) readonly buffer Corners { uint corners[]; };

uint offsetAt(uint i) { return kTexels ? texelFetch(tableTexelsA, int(i)).x : offsets[i]; }
uint entryAt(uint i) { return kTexels ? texelFetch(tableTexelsB, int(i)).x : corners[i]; }

// PSUB_SPEC_ROW_N = 4: every face is a quad, its corners at 4 row from pc.tableBase in the
// TABLE_B window (no offsets; one uvec4 fetch). The tiled form's listed faces (those beside its
// tiles' inner points) come in this layout too, in a table of their own.
layout(constant_id = PSUB_SPEC_ROW_N) const uint kCorners = 0xffffffffu;

void main() {
    const uint row = rowIndex();
    if (row >= pc.rowCount) return;
    precise vec3 n = vec3(0.0);
    if (kCorners == 4u) {
        const uint base = pc.tableBase + 4u * row;
        const uvec4 c = kTexels ? texelFetch(tableTexelsB, int(base / 4u))
                                : uvec4(corners[base], corners[base + 1u], corners[base + 2u], corners[base + 3u]);
        const vec3 n4 = quadNormal(readElement(c.x).xyz, readElement(c.y).xyz, readElement(c.z).xyz, readElement(c.w).xyz);
        writeElement(pc.rowBase + row, vec4(n4, 0.0));
        return;
    }
    const uint begin = offsetAt(pc.tableBase + row), end = offsetAt(pc.tableBase + row + 1u);
    if (end - begin == 4u) {
        writeElement(pc.rowBase + row, vec4(quadNormal(readElement(entryAt(begin)).xyz, readElement(entryAt(begin + 1u)).xyz,
                                                       readElement(entryAt(begin + 2u)).xyz,
                                                       readElement(entryAt(begin + 3u)).xyz), 0.0));
        return;
    }
    const vec3 first = readElement(entryAt(begin)).xyz;
    vec3 a = first;
    for (uint c = begin; c < end; ++c) {
        const vec3 b = c + 1u < end ? readElement(entryAt(c + 1u)).xyz : first;
        n.x += (a.y - b.y) * (a.z + b.z);
        n.y += (a.z - b.z) * (a.x + b.x);
        n.z += (a.x - b.x) * (a.y + b.y);
        a = b;
    }
    writeElement(pc.rowBase + row, vec4(n, 0.0));
}
