// Clip planes (`[[clip]]`). Needs `RenderParams P`.

// The clip planes' interval of the ray o + t d, intersected into [t0, t1] (Rust:
// `vocab::Clip::interval`); false when a plane removes the whole ray.
bool clip_interval(vec3 o, vec3 d, inout float t0, inout float t1) {
    for (uint i = 0u; i < P.clip_count; i++) {
        vec3 n = P.clip[i].xyz;
        float s = dot(n, d);
        float v = dot(n, o) - P.clip[i].w;
        if (s == 0.0) {
            if (v > 0.0) return false;
            continue;
        }
        float t = -v / s;
        if (s > 0.0) {
            t1 = min(t1, t);
        } else {
            t0 = max(t0, t);
        }
    }
    return t0 <= t1;
}
