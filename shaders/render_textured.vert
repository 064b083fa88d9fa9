#version 450
// The textured surface, vertex pulling: each corner carries its surface vertex and its UV (a
// static buffer); positions and normals, rewritten every frame, are read from storage buffers
// by that vertex (3 floats each, tightly packed).
#extension GL_GOOGLE_include_directive : require
#include "render_frame.glsl"

layout(set = 0, binding = 1, std430) readonly buffer Positions { float positions[]; };
layout(set = 0, binding = 2, std430) readonly buffer Normals { float normals[]; };

layout(location = 0) in uint vertexIndex;
layout(location = 1) in vec2 uv;
layout(location = 0) out vec3 viewNormal;
layout(location = 1) out vec3 viewPosition;
layout(location = 2) out vec2 textureUv;

void main() {
    const uint i = 3u * vertexIndex;
    const vec3 position = vec3(positions[i], positions[i + 1u], positions[i + 2u]);
    const vec3 normal = vec3(normals[i], normals[i + 1u], normals[i + 2u]);
    const vec4 p = frame.view * vec4(position, 1.0);
    viewPosition = p.xyz;
    viewNormal = mat3(frame.view) * normal;
    textureUv = uv;
    gl_Position = frame.projection * p;
}
