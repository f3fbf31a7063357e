// The interpolant of a cell, one home for every shader that interpolates (Rust:
// `field::interpolant`). Only the trilinear interpolant exists. Two forms are here until every
// shader uses the first: `interp_value` / `interp_gradient` interpolate in the f64 reference's
// order (x, then y, then z, with `precise` lerps: exact at 0 and 1), used by the analytic
// method; `trilinear_local` / `gradient_local` interpolate z first with `mix`, used by the
// fixed-step march and the mesh resolve (field.glsl). Depends on nothing (no `P`, no bindings).
#ifndef INTERPOLANT_GLSL
#define INTERPOLANT_GLSL

// The 8 corner values of one cell, as two vec4s: lo = (v000, v100, v010, v110) on the cell's
// z = 0 face, hi = (v001, v101, v011, v111) on its z = 1 face (vXYZ: corner x+X, y+Y, z+Z).
struct Corners {
    vec4 lo;
    vec4 hi;
};

// (1 - w) a + w b, exact at w = 0 (gives a) and w = 1 (gives b) as long as the compiler neither
// reassociates it nor turns it into a + w (b - a): `precise` forbids both (and FMA contraction,
// which would keep the end points exact anyway).
float lerp1(float a, float b, float w) {
    precise float r = (1.0 - w) * a + w * b;
    return r;
}

vec2 lerp2(vec2 a, vec2 b, float w) {
    precise vec2 r = (1.0 - w) * a + w * b;
    return r;
}

vec4 lerp4(vec4 a, vec4 b, float w) {
    precise vec4 r = (1.0 - w) * a + w * b;
    return r;
}

// Value of the trilinear interpolant at cell-local q: along x, then y, then z (the reference's
// order, which makes a face point evaluate to the same bits from both cells sharing the face).
float interp_value(Corners k, vec3 q) {
    // (x00, x10, x01, x11): the four x-edges at x = q.x.
    vec4 x = lerp4(vec4(k.lo.x, k.lo.z, k.hi.x, k.hi.z), vec4(k.lo.y, k.lo.w, k.hi.y, k.hi.w), q.x);
    vec2 y = lerp2(x.xz, x.yw, q.y);
    return lerp1(y.x, y.y, q.z);
}

// Gradient at cell-local q, in value per cell: each component is the bilinear interpolation of
// the 4 edge differences along that axis.
vec3 interp_gradient(Corners k, vec3 q) {
    float c0 = k.lo.x, c1 = k.lo.y, c2 = k.lo.z, c3 = k.lo.w;
    float c4 = k.hi.x, c5 = k.hi.y, c6 = k.hi.z, c7 = k.hi.w;
    return vec3(
        lerp1(lerp1(c1 - c0, c3 - c2, q.y), lerp1(c5 - c4, c7 - c6, q.y), q.z),
        lerp1(lerp1(c2 - c0, c3 - c1, q.x), lerp1(c6 - c4, c7 - c5, q.x), q.z),
        lerp1(lerp1(c4 - c0, c5 - c1, q.x), lerp1(c6 - c2, c7 - c3, q.x), q.y));
}

// Trilinear interpolation at local coordinates f in [0,1]^3.
float trilinear_local(Corners k, vec3 f) {
    vec4 x = mix(k.lo, k.hi, f.z);       // the 4 x-edges' ends on the plane z = f.z
    vec2 y = mix(x.xy, x.zw, f.y);       // the x-edge at y = f.y
    return mix(y.x, y.y, f.x);
}

// Gradient with respect to local coordinates.
vec3 gradient_local(Corners k, vec3 f) {
    vec4 x = mix(k.lo, k.hi, f.z);
    vec2 y = mix(x.xy, x.zw, f.y);
    float gx = y.y - y.x;
    float gy = mix(x.z - x.x, x.w - x.y, f.x);
    vec4 dz = k.hi - k.lo;
    vec2 dzy = mix(dz.xy, dz.zw, f.y);
    float gz = mix(dzy.x, dzy.y, f.x);
    return vec3(gx, gy, gz);
}

#endif
