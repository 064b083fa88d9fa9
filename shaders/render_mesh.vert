#version 450
// The shaded surface: world positions and normals to view space.
#extension GL_GOOGLE_include_directive : require
#include "render_frame.glsl"

layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 0) out vec3 viewNormal;
layout(location = 1) out vec3 viewPosition;

void main() {
    const vec4 p = frame.view * vec4(position, 1.0);
    viewPosition = p.xyz;
    viewNormal = mat3(frame.view) * normal;
    gl_Position = frame.projection * p;
}
