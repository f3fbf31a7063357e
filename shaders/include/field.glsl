// The trilinear field on the grid, read exactly with texelFetch (no hardware filtering: real
// GPUs filter with ~8-bit weights). Mirrors `reference::field` (f64).
// Needs: `RenderParams P` and `sampler3D u_grid` declared before inclusion.

// THE inside rule (Rust: `Inside::contains`): strictly below (or above) is inside; equal is
// outside.
bool is_inside(float v) {
    return P.surface.y > 0.0 ? v < P.surface.x : v > P.surface.x;
}

float grid_value(ivec3 p) {
    return texelFetch(u_grid, p, 0).r;
}

// World position -> continuous grid coordinates, clamped into the box.
vec3 to_grid(vec3 pos) {
    return clamp((pos - P.box_min.xyz) * P.inv_spacing.xyz, vec3(0.0), vec3(P.dims.xyz - 1));
}

// The cell holding grid coordinates u: floor, clamped so the last grid plane belongs to the
// last cell.
ivec3 cell_of(vec3 u) {
    return clamp(ivec3(floor(u)), ivec3(0), P.dims.xyz - 2);
}

// Corner values of cell c: v[n] at corner (n & 1, (n >> 1) & 1, (n >> 2) & 1).
void cell_corners(ivec3 c, out float v[8]) {
    for (int n = 0; n < 8; n++) {
        v[n] = grid_value(c + ivec3(n & 1, (n >> 1) & 1, (n >> 2) & 1));
    }
}

// Trilinear interpolation of corner values at local coordinates f in [0,1]^3.
float trilinear_local(float v[8], vec3 f) {
    float x00 = mix(v[0], v[1], f.x);
    float x10 = mix(v[2], v[3], f.x);
    float x01 = mix(v[4], v[5], f.x);
    float x11 = mix(v[6], v[7], f.x);
    return mix(mix(x00, x10, f.y), mix(x01, x11, f.y), f.z);
}

// Gradient with respect to local coordinates.
vec3 gradient_local(float v[8], vec3 f) {
    float gx = mix(mix(v[1] - v[0], v[3] - v[2], f.y), mix(v[5] - v[4], v[7] - v[6], f.y), f.z);
    float gy = mix(mix(v[2] - v[0], v[3] - v[1], f.x), mix(v[6] - v[4], v[7] - v[5], f.x), f.z);
    float gz = mix(mix(v[4] - v[0], v[5] - v[1], f.x), mix(v[6] - v[2], v[7] - v[3], f.x), f.y);
    return vec3(gx, gy, gz);
}

// Field value at grid coordinates u (already inside the box).
float field_at(vec3 u) {
    ivec3 c = cell_of(u);
    float v[8];
    cell_corners(c, v);
    return trilinear_local(v, u - vec3(c));
}

// Unit world-space normal at grid coordinates u, pointing from inside to outside; `fallback`
// where the gradient vanishes.
vec3 normal_at(vec3 u, vec3 fallback) {
    ivec3 c = cell_of(u);
    float v[8];
    cell_corners(c, v);
    vec3 g = gradient_local(v, u - vec3(c)) * P.inv_spacing.xyz * P.surface.y;
    float len = length(g);
    return len > 0.0 ? g / len : fallback;
}

// Ray/box intersection (slabs). Returns false when the ray misses the box or the box lies
// behind the eye; else [t0, t1] with t0 >= 0. Zero direction components are handled
// explicitly instead of relying on 1/0.
bool clip_box(vec3 o, vec3 d, out float t0, out float t1) {
    t0 = 0.0;
    t1 = 3.402823466e38;
    for (int a = 0; a < 3; a++) {
        float lo = P.box_min[a];
        float hi = P.box_max[a];
        if (d[a] == 0.0) {
            if (o[a] < lo || o[a] > hi) return false;
        } else {
            float ta = (lo - o[a]) / d[a];
            float tb = (hi - o[a]) / d[a];
            t0 = max(t0, min(ta, tb));
            t1 = min(t1, max(ta, tb));
        }
    }
    return t0 <= t1;
}
