// shaders/common.glsl: what every PSub kernel shares: the push constants, the specialization
// constants, the row numbering of a (possibly 2-D) dispatch, and element access to the input
// and output vertex buffers, each bound as one window or as up to PSUB_VERTEX_WINDOWS.
// Buffers with a stride of 4 floats are also read and written as vec4 (one load per element
// instead of one per value: lavapipe runs each non-uniform load as a loop over the lanes).
#include "config.h"

#if PSUB_VERTEX_WINDOWS != 4
#error "common.glsl spells out four windows"
#endif

layout(local_size_x = PSUB_WORKGROUP_SIZE, local_size_y = 1, local_size_z = 1) in;

layout(push_constant) uniform PushConstants { PSUB_PUSH_CONSTANT_MEMBERS } pc;

layout(constant_id = PSUB_SPEC_COMPONENTS) const uint kComponents = 3;
layout(constant_id = PSUB_SPEC_SOURCE_STRIDE) const uint kSourceStride = 3;
layout(constant_id = PSUB_SPEC_DESTINATION_STRIDE) const uint kDestinationStride = 3;
layout(constant_id = PSUB_SPEC_SOURCE_WINDOWED) const bool kSourceWindowed = false;
layout(constant_id = PSUB_SPEC_DESTINATION_WINDOWED) const bool kDestinationWindowed = false;
layout(constant_id = PSUB_SPEC_TEXELS) const bool kTexels = false;

layout(std430, binding = PSUB_BINDING_SOURCE + 0) readonly buffer Source0 { float v[]; } source0;
layout(std430, binding = PSUB_BINDING_SOURCE + 1) readonly buffer Source1 { float v[]; } source1;
layout(std430, binding = PSUB_BINDING_SOURCE + 2) readonly buffer Source2 { float v[]; } source2;
layout(std430, binding = PSUB_BINDING_SOURCE + 3) readonly buffer Source3 { float v[]; } source3;
layout(std430, binding = PSUB_BINDING_DESTINATION + 0) writeonly buffer Destination0 { float v[]; } destination0;
layout(std430, binding = PSUB_BINDING_DESTINATION + 1) writeonly buffer Destination1 { float v[]; } destination1;
layout(std430, binding = PSUB_BINDING_DESTINATION + 2) writeonly buffer Destination2 { float v[]; } destination2;
layout(std430, binding = PSUB_BINDING_DESTINATION + 3) writeonly buffer Destination3 { float v[]; } destination3;
// The same bindings seen as vec4 elements (used when the stride is 4).
layout(std430, binding = PSUB_BINDING_SOURCE + 0) readonly buffer SourceVector0 { vec4 v[]; } sourceVector0;
layout(std430, binding = PSUB_BINDING_SOURCE + 1) readonly buffer SourceVector1 { vec4 v[]; } sourceVector1;
layout(std430, binding = PSUB_BINDING_SOURCE + 2) readonly buffer SourceVector2 { vec4 v[]; } sourceVector2;
layout(std430, binding = PSUB_BINDING_SOURCE + 3) readonly buffer SourceVector3 { vec4 v[]; } sourceVector3;
layout(std430, binding = PSUB_BINDING_DESTINATION + 0) writeonly buffer DestinationVector0 { vec4 v[]; } destinationVector0;
layout(std430, binding = PSUB_BINDING_DESTINATION + 1) writeonly buffer DestinationVector1 { vec4 v[]; } destinationVector1;
layout(std430, binding = PSUB_BINDING_DESTINATION + 2) writeonly buffer DestinationVector2 { vec4 v[]; } destinationVector2;
layout(std430, binding = PSUB_BINDING_DESTINATION + 3) writeonly buffer DestinationVector3 { vec4 v[]; } destinationVector3;

// The input windows and the table windows as texel buffers (config.h): used when kTexels.
layout(binding = PSUB_BINDING_SOURCE_TEXELS + 0) uniform samplerBuffer sourceTexels0;
layout(binding = PSUB_BINDING_SOURCE_TEXELS + 1) uniform samplerBuffer sourceTexels1;
layout(binding = PSUB_BINDING_SOURCE_TEXELS + 2) uniform samplerBuffer sourceTexels2;
layout(binding = PSUB_BINDING_SOURCE_TEXELS + 3) uniform samplerBuffer sourceTexels3;
layout(binding = PSUB_BINDING_TABLE_A_TEXELS) uniform usamplerBuffer tableTexelsA;
layout(binding = PSUB_BINDING_TABLE_B_TEXELS) uniform usamplerBuffer tableTexelsB;
layout(binding = PSUB_BINDING_TABLE_C_TEXELS) uniform usamplerBuffer tableTexelsC;

// Texel `i` of input window `window` (a whole element when the stride is 4, else one float in .x).
vec4 sourceTexel(uint window, uint i) {
    if (!kSourceWindowed || window == 0u) return texelFetch(sourceTexels0, int(i));
    if (window == 1u) return texelFetch(sourceTexels1, int(i));
    if (window == 2u) return texelFetch(sourceTexels2, int(i));
    return texelFetch(sourceTexels3, int(i));
}

// The tiled form's border entry of lattice point (x, y) on a tile's outer ring (0 < x, y < L
// excluded): row 0 whole, the two ends of each row between, row L whole (TiledTable::border).
uint ringEntry(uint x, uint y, uint L) {
    return y == 0u ? x : y == L ? 3u * L - 1u + x : L + 2u * y - 1u + (x == L ? 1u : 0u);
}

// A quad's normal from its corners in order: the cross product of its diagonals, (p2 - p0) x
// (p3 - p1), the CPU's (compute/cpu_evaluator.cpp), the same bits from whichever corner it
// starts. The tiled form's normals (tile_normals.comp, and tile.comp with PSUB_SPEC_TILE_NORMALS):
// a lattice point's unit normal from its four quads' normals, those of quads (x - 1, y - 1),
// (x, y - 1), (x - 1, y) and (x, y), summed in the CPU tile pass's order
// (compute/tiled_kernels.cpp), so the same bits.
vec3 quadNormal(vec3 p0, vec3 p1, vec3 p2, vec3 p3) {
    precise vec3 a = p2 - p0, b = p3 - p1;
    precise vec3 n = vec3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
    return n;
}
vec4 unitNormal(vec3 q00, vec3 q10, vec3 q01, vec3 q11) {
    precise vec3 s = (q00 + q10) + (q01 + q11);
    precise float size = sqrt(s.x * s.x + s.y * s.y + s.z * s.z);
    precise float scale = size > 0.0 ? 1.0 / size : 0.0;
    return vec4(s * scale, 0.0);
}

// This invocation's row within the dispatch (workgroups numbered x first, then y).
uint rowIndex() {
    return (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * PSUB_WORKGROUP_SIZE +
           gl_LocalInvocationID.x;
}

// An element's place: the window holding it and the index of its first float there.
struct Place {
    uint window;
    uint first;
};

Place sourcePlace(uint element) {
    if (!kSourceWindowed) return Place(0u, element * kSourceStride);
    uint window = element / pc.sourceWindowSize;
    return Place(window, (element - window * pc.sourceWindowSize) * kSourceStride);
}

Place destinationPlace(uint element) {
    if (!kDestinationWindowed) return Place(0u, element * kDestinationStride);
    uint window = element / pc.destinationWindowSize;
    return Place(window, (element - window * pc.destinationWindowSize) * kDestinationStride);
}

// Component `c` of the element at `p`.
float readSource(Place p, uint c) {
    if (kTexels) {
        if (kSourceStride == 4u) return sourceTexel(p.window, p.first / 4u)[c];
        return sourceTexel(p.window, p.first + c).x;
    }
    if (!kSourceWindowed || p.window == 0u) return source0.v[p.first + c];
    if (p.window == 1u) return source1.v[p.first + c];
    if (p.window == 2u) return source2.v[p.first + c];
    return source3.v[p.first + c];
}

void writeDestination(Place p, uint c, float value) {
    if (!kDestinationWindowed || p.window == 0u) destination0.v[p.first + c] = value;
    else if (p.window == 1u) destination1.v[p.first + c] = value;
    else if (p.window == 2u) destination2.v[p.first + c] = value;
    else destination3.v[p.first + c] = value;
}

// The first min(kComponents, 4) values of input element `element` (the rest 0, or whatever
// the padding holds when the stride is 4).
vec4 readElement(uint element) {
    if (kTexels && kSourceStride == 4u) {
        if (!kSourceWindowed) return texelFetch(sourceTexels0, int(element));
        const uint window = element / pc.sourceWindowSize;
        return sourceTexel(window, element - window * pc.sourceWindowSize);
    }
    if (kSourceStride == 4u) {
        if (!kSourceWindowed) return sourceVector0.v[element];
        const uint window = element / pc.sourceWindowSize, local = element - window * pc.sourceWindowSize;
        if (window == 0u) return sourceVector0.v[local];
        if (window == 1u) return sourceVector1.v[local];
        if (window == 2u) return sourceVector2.v[local];
        return sourceVector3.v[local];
    }
    const Place p = sourcePlace(element);
    vec4 value = vec4(0.0);
    for (uint i = 0u; i < min(kComponents, 4u); ++i) value[i] = readSource(p, i);
    return value;
}

// Writes the first min(kComponents, 4) values of output element `element` (all four when
// the stride is 4: the padding too).
void writeElement(uint element, vec4 value) {
    if (kDestinationStride == 4u) {
        if (!kDestinationWindowed) {
            destinationVector0.v[element] = value;
            return;
        }
        const uint window = element / pc.destinationWindowSize, local = element - window * pc.destinationWindowSize;
        if (window == 0u) destinationVector0.v[local] = value;
        else if (window == 1u) destinationVector1.v[local] = value;
        else if (window == 2u) destinationVector2.v[local] = value;
        else destinationVector3.v[local] = value;
        return;
    }
    const Place p = destinationPlace(element);
    for (uint i = 0u; i < min(kComponents, 4u); ++i) writeDestination(p, i, value[i]);
}
