#version 450
// The shaded surface of one colour (render_lighting.glsl).
#extension GL_GOOGLE_include_directive : require
#include "render_frame.glsl"
#include "render_lighting.glsl"

layout(location = 0) in vec3 viewNormal;
layout(location = 1) in vec3 viewPosition;
layout(location = 0) out vec4 colour;

void main() {
    colour = litColour(frame.surfaceColour.rgb, viewNormal, viewPosition);
}
