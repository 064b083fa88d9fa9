#version 450
// The shaded surface: Lambert from a headlight and a key light, two-sided (a normal facing
// away from the eye is flipped, so open surfaces and either winding look the same).
#extension GL_GOOGLE_include_directive : require
#include "render_frame.glsl"

layout(location = 0) in vec3 viewNormal;
layout(location = 1) in vec3 viewPosition;
layout(location = 0) out vec4 colour;

void main() {
    const vec3 toEye = normalize(-viewPosition);
    vec3 n = dot(viewNormal, viewNormal) > 1e-30 ? normalize(viewNormal) : toEye;
    if (dot(n, toEye) < 0.0) n = -n;
    const float head = max(dot(n, toEye), 0.0);
    const float key = max(dot(n, frame.keyLight.xyz), 0.0);
    const vec3 lit = frame.surfaceColour.rgb * (0.15 + 0.55 * head + 0.45 * key);
    colour = vec4(min(lit, vec3(1.0)), 1.0);
}
