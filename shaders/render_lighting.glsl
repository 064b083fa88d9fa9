// The surface's lighting (render_mesh.frag, render_textured.frag): Lambert from a headlight and
// the key light, two-sided (a normal facing away from the eye is flipped, so open surfaces and
// either winding look the same), applied to a base colour. Needs render_frame.glsl.
vec4 litColour(vec3 base, vec3 viewNormal, vec3 viewPosition) {
    const vec3 toEye = normalize(-viewPosition);
    vec3 n = dot(viewNormal, viewNormal) > 1e-30 ? normalize(viewNormal) : toEye;
    if (dot(n, toEye) < 0.0) n = -n;
    const float head = max(dot(n, toEye), 0.0);
    const float key = max(dot(n, frame.keyLight.xyz), 0.0);
    const vec3 lit = base * (0.15 + 0.55 * head + 0.45 * key);
    return vec4(min(lit, vec3(1.0)), 1.0);
}
