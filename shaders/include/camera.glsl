// The contract's pinhole camera (Rust: `camera::Camera`). Needs `RenderParams P`.
vec3 ray_dir(uvec2 px) {
    float sx = 2.0 * (float(px.x) + 0.5) / float(P.image.x) - 1.0;
    float sy = 1.0 - 2.0 * (float(px.y) + 0.5) / float(P.image.y);
    return normalize(P.forward.xyz + sx * P.right.xyz + sy * P.up.xyz);
}
