// The camera (Rust: `camera::Camera`). Needs `RenderParams P`. P.orthographic != 0: orthographic.

// The pixel centre's offset from the view's centre, in the image plane: at unit distance
// (perspective) or in world units from the eye (orthographic).
vec3 pixel_offset(uvec2 px) {
    float sx = 2.0 * (float(px.x) + 0.5) / float(P.width) - 1.0;
    float sy = 1.0 - 2.0 * (float(px.y) + 0.5) / float(P.height);
    return sx * P.right + sy * P.up;
}

bool camera_orthographic() {
    return P.orthographic != 0u;
}

// The ray through pixel `px`: from the eye (perspective: the contract's pinhole), or from the
// image plane through the eye along the view (orthographic).
void camera_ray(uvec2 px, out vec3 o, out vec3 d) {
    float sx = 2.0 * (float(px.x) + 0.5) / float(P.width) - 1.0;
    float sy = 1.0 - 2.0 * (float(px.y) + 0.5) / float(P.height);
    if (camera_orthographic()) {
        o = P.eye + pixel_offset(px);
        d = P.forward;
    } else {
        // Kept as this one expression: its rounding is what the goldens hold.
        o = P.eye;
        d = normalize(P.forward + sx * P.right + sy * P.up);
    }
}
