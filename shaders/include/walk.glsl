// Steps 1-3 of the exact walks over cells and voxels (`reference::analytic` and
// `reference::voxels`, whose module docs number them): the pixel's ray in the grid's index
// space, its span inside the box and the clip planes, and its entry point. voxels.comp and
// tricubic.comp share it; analytic.comp keeps the same steps inline, laid out for its
// specialization constants and brick levels. Needs `RenderParams P`, camera.glsl and clip.glsl.

// The walk's ray: world origin and direction (grid frame) and the same in index space.
struct WalkRay {
    vec3 eye;   // the ray's origin: the eye, or its pixel on the orthographic image plane
    vec3 dir;   // unit direction
    vec3 o;     // origin in index space (the eye's from the CPU, in f64)
    vec3 d;     // direction in index space, dir * inv_spacing
    vec3 n;     // cells per axis
    float t_lo; // the span inside the box and the clip planes, t_lo >= 0
    float t_hi;
    vec3 p;     // entry point at t_lo, on the entry face when the ray enters through it,
                // clamped into [0, n]
};

// Steps 1-3 for pixel px; false when the ray has no span (it misses the box, the clip planes
// remove it, or it cannot be walked).
bool walk_ray(uvec2 px, out WalkRay w) {
    float INF = uintBitsToFloat(0x7f800000u);
    camera_ray(px, w.eye, w.dir);
    // 1. Index space.
    w.n = vec3(P.dims - 1);
    w.o = P.eye_grid;
    if (camera_orthographic()) w.o += pixel_offset(px) * P.inv_spacing;
    w.d = w.dir * P.inv_spacing;
    vec3 o = w.o, d = w.d, n = w.n;
    w.t_lo = 0.0;
    w.t_hi = 0.0;
    w.p = vec3(0.0);
    bool usable = !any(isnan(o)) && !any(isinf(o)) && !any(isnan(d)) && !any(isinf(d))
        && d != vec3(0.0);
    // 2. Slab clip, then the clip planes (a later entry enters through a plane).
    float t_enter = -INF;
    float t_exit = INF;
    int enter_axis = -1;
    for (int a = 0; a < 3 && usable; a++) {
        if (d[a] == 0.0) {
            if (!(o[a] >= 0.0 && o[a] <= n[a])) usable = false;
            continue;
        }
        float t0 = (0.0 - o[a]) / d[a];
        float t1 = (n[a] - o[a]) / d[a];
        float near = d[a] > 0.0 ? t0 : t1;
        float far = d[a] > 0.0 ? t1 : t0;
        if (near > t_enter) {
            t_enter = near;
            enter_axis = a;
        }
        if (far < t_exit) t_exit = far;
    }
    float c_lo = -INF;
    float c_hi = INF;
    if (usable && !clip_interval(w.eye, w.dir, c_lo, c_hi)) usable = false;
    if (c_lo > t_enter) {
        t_enter = c_lo;
        enter_axis = -1;
    }
    t_exit = min(t_exit, c_hi);
    if (!usable || !(t_enter <= t_exit && t_exit > 0.0 && t_exit < INF)) return false;
    w.t_lo = max(t_enter, 0.0);
    w.t_hi = t_exit;
    // 3. Entry point.
    vec3 p = o + w.t_lo * d;
    if (w.t_lo == t_enter && enter_axis >= 0) {
        p[enter_axis] = d[enter_axis] > 0.0 ? 0.0 : n[enter_axis];
    }
    w.p = clamp(p, vec3(0.0), n);
    return true;
}

// A ray pass's record of a miss (and the start of every record).
Pixel miss_pixel() {
    Pixel r;
    r.rgba = P.background;
    r.normal = vec3(0.0);
    r.depth = uintBitsToFloat(0x7f800000u);
    r.position = vec3(0.0);
    r.steps = 0.0;
    r.cell = ivec3(-1);
    r.crossings = P.count_crossings != 0u ? 0 : -1;  // -1: not counted
    r.surface = -1;
    r.value = uintBitsToFloat(0x7fc00000u);  // NaN: no [color] value
    r.pad0 = 0u;
    r.pad1 = 0u;
    return r;
}
