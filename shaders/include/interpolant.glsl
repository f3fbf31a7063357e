// The interpolant of a cell, one home for every shader that interpolates (Rust:
// `field::interpolant`). Only the trilinear interpolant exists. `interp_value` and
// `interp_gradient` are the f64 reference's arithmetic in f32: x, then y, then z, with
// `precise` lerps (exact at 0 and 1), and the sum-of-products gradient. Depends on nothing
// (no `P`, no bindings), so every shader can include it.
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

// Gradient at cell-local q, in value per cell: the sum-of-products form of the f64 one
// (`field::interpolant::trilinear::gradient`), term for term and in the same order; `precise`
// (no reassociation, no fused multiply-adds) so that every shader that calls it gets the same
// bits from the same corners.
vec3 interp_gradient(Corners k, vec3 q) {
    float v0 = k.lo.x, v1 = k.lo.y, v2 = k.lo.z, v3 = k.lo.w;
    float v4 = k.hi.x, v5 = k.hi.y, v6 = k.hi.z, v7 = k.hi.w;
    float x = q.x, y = q.y, z = q.z;
    precise float mx = 1.0 - x, my = 1.0 - y, mz = 1.0 - z;
    precise vec3 g = vec3(
        my * mz * (v1 - v0) + y * mz * (v3 - v2) + my * z * (v5 - v4) + y * z * (v7 - v6),
        mx * mz * (v2 - v0) + x * mz * (v3 - v1) + mx * z * (v6 - v4) + x * z * (v7 - v5),
        mx * my * (v4 - v0) + x * my * (v5 - v1) + mx * y * (v6 - v2) + x * y * (v7 - v3));
    return g;
}

// Corners from 8 values in corner order (v000, v100, v010, v110, v001, v101, v011, v111).
Corners corners_of(float v[8]) {
    Corners k;
    k.lo = vec4(v[0], v[1], v[2], v[3]);
    k.hi = vec4(v[4], v[5], v[6], v[7]);
    return k;
}

// The interpolant applied to each component of 8 vectors in corner order (smooth normals
// interpolate the point gradients so): `interp_value` per component, the same bits.
vec3 interp_value3(vec3 g[8], vec3 q) {
    vec3 r;
    for (int a = 0; a < 3; a++) {
        float v[8];
        for (int n = 0; n < 8; n++) {
            v[n] = g[n][a];
        }
        r[a] = interp_value(corners_of(v), q);
    }
    return r;
}

#endif
