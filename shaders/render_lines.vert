#version 450
// Wireframe lines: pulled towards the eye by a small fraction of their distance, which moves
// their depth in front of the surface they lie on without moving them on screen.
#extension GL_GOOGLE_include_directive : require
#include "render_frame.glsl"

layout(location = 0) in vec3 position;

void main() {
    vec4 p = frame.view * vec4(position, 1.0);
    p.xyz *= 1.0 - frame.params.x;
    gl_Position = frame.projection * p;
}
