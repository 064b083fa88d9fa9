#version 450
// The textured surface: base colour = texture * factor (glTF's baseColorTexture and
// baseColorFactor), lit as the one-colour surface (render_lighting.glsl).
#extension GL_GOOGLE_include_directive : require
#include "render_frame.glsl"
#include "render_lighting.glsl"

layout(set = 0, binding = 3) uniform sampler2D baseColour;

layout(location = 0) in vec3 viewNormal;
layout(location = 1) in vec3 viewPosition;
layout(location = 2) in vec2 textureUv;
layout(location = 0) out vec4 colour;

void main() {
    const vec3 base = texture(baseColour, textureUv).rgb * frame.baseColourFactor.rgb;
    colour = litColour(base, viewNormal, viewPosition);
}
