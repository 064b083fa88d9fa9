#version 450
// Wireframe lines: one flat colour.
#extension GL_GOOGLE_include_directive : require
#include "render_frame.glsl"

layout(location = 0) out vec4 colour;

void main() { colour = frame.lineColour; }
