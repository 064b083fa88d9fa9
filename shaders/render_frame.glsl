// The renderer's per-frame uniform block (render/renderer.cpp's FrameUniforms mirrors it,
// std140): camera matrices, colours, the key light, the lines' pull towards the eye and the
// texture's factor.
layout(set = 0, binding = 0, std140) uniform Frame {
    mat4 view;
    mat4 projection;
    vec4 surfaceColour;
    vec4 lineColour;
    vec4 keyLight;  // xyz: unit direction towards the light, view space
    vec4 params;    // x: fraction of the distance to the eye that lines are pulled forward
    vec4 baseColourFactor;  // multiplies the texture (textured surfaces)
} frame;
