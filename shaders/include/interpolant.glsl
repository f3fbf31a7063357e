// The interpolant of a cell, one home for every shader that interpolates (Rust:
// `field::interpolant`). `interp_value` and `interp_gradient` are the trilinear interpolant,
// the f64 reference's arithmetic in f32: x, then y, then z, with `precise` lerps (exact at 0
// and 1), and the sum-of-products gradient. The tricubic ones (`cubic_*`, compiled where a
// variant defines INTERP_BSPLINE or INTERP_CATMULL_ROM) are `field::interpolant::cubic`'s:
// Horner on the integer weight numerators divided last, contracted along x, then y, then z.
// Nearest's corner is `nearest_corner`. Depends on nothing (no `P`, no bindings), so every
// shader can include it.
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

// g / |g| (a gradient made a normal), or `fallback` where g vanishes or is not finite. |g|^2
// overflows f32 past about 1.8e19 (samples near the ray methods' bound of 1e30, or tiny
// spacings) and underflows below about 1e-19: there g is first scaled by a power of 2 (exact),
// so the result is g's direction whatever its size; between 1e-18 and 1e18 it is divided as
// it always was, bit for bit.
vec3 unit_or(vec3 g, vec3 fallback) {
    float m = max(abs(g.x), max(abs(g.y), abs(g.z)));
    if (!(m > 0.0) || isinf(m)) return fallback;
    if (m > 1e18 || m < 1e-18) g *= exp2(-floor(log2(m)));
    float len = length(g);
    return len > 0.0 && !isinf(len) ? g / len : fallback;
}

// The nearest corner of a cell to cell-local q, half up (Rust: `nearest::corner`): its index
// in corner order, (q.x >= 1/2) + 2 (q.y >= 1/2) + 4 (q.z >= 1/2).
int nearest_corner(vec3 q) {
    ivec3 h = ivec3(greaterThanEqual(q, vec3(0.5)));
    return h.x + 2 * h.y + 4 * h.z;
}

// The value of that corner.
float nearest_value(Corners k, vec3 q) {
    int n = nearest_corner(q);
    vec4 face = n < 4 ? k.lo : k.hi;
    return face[n & 3];
}

#if defined(INTERP_BSPLINE) || defined(INTERP_CATMULL_ROM)
#define INTERP_CUBIC 1
// Row a + 1: the integer numerators of weight a's coefficients of 1, t, t^2, t^3 (Rust:
// `Weights::NUM`), over CUBIC_DEN.
#ifdef INTERP_BSPLINE
const float CUBIC_DEN = 6.0;
const vec4 CUBIC_NUM[4] = vec4[4](vec4(1.0, -3.0, 3.0, -1.0), vec4(4.0, 0.0, -6.0, 3.0),
                                  vec4(1.0, 3.0, 3.0, -3.0), vec4(0.0, 0.0, 0.0, 1.0));
#else
const float CUBIC_DEN = 2.0;
const vec4 CUBIC_NUM[4] = vec4[4](vec4(0.0, -1.0, 2.0, -1.0), vec4(2.0, 0.0, -5.0, 3.0),
                                  vec4(0.0, 1.0, 4.0, -3.0), vec4(0.0, 0.0, -1.0, 1.0));
#endif

// The 4 weights at t (offsets -1..2), Horner on the numerators, divided last (`cubic::weights`).
vec4 cubic_weights(float t) {
    precise vec4 w;
    for (int a = 0; a < 4; a++) {
        vec4 n = CUBIC_NUM[a];
        w[a] = (((n.w * t + n.z) * t + n.y) * t + n.x) / CUBIC_DEN;
    }
    return w;
}

// Their derivatives in t (`cubic::derivative_weights`).
vec4 cubic_derivative_weights(float t) {
    precise vec4 w;
    for (int a = 0; a < 4; a++) {
        vec4 n = CUBIC_NUM[a];
        w[a] = ((3.0 * n.w * t + 2.0 * n.z) * t + n.y) / CUBIC_DEN;
    }
    return w;
}

// The 4x4x4 samples of a cell, offsets -1..2, sample (a, b, c) at a + 4 b + 16 c.
struct Samples {
    float s[64];
};

// w0 s0 + w1 s1 + w2 s2 + w3 s3, in that order (`cubic::dot4`).
float cubic_dot4(vec4 w, float s0, float s1, float s2, float s3) {
    precise float r = w.x * s0 + w.y * s1 + w.z * s2 + w.w * s3;
    return r;
}

// The tensor contraction with per-axis weights: along x, then y, then z (`cubic::contract`).
float cubic_contract(Samples k, vec4 wx, vec4 wy, vec4 wz) {
    float plane[4];
    for (int c = 0; c < 4; c++) {
        float row[4];
        for (int b = 0; b < 4; b++) {
            int r = 4 * b + 16 * c;
            row[b] = cubic_dot4(wx, k.s[r], k.s[r + 1], k.s[r + 2], k.s[r + 3]);
        }
        plane[c] = cubic_dot4(wy, row[0], row[1], row[2], row[3]);
    }
    return cubic_dot4(wz, plane[0], plane[1], plane[2], plane[3]);
}

// The value at cell-local q.
float cubic_value(Samples k, vec3 q) {
    return cubic_contract(k, cubic_weights(q.x), cubic_weights(q.y), cubic_weights(q.z));
}

// The gradient at cell-local q, in value per cell.
vec3 cubic_gradient(Samples k, vec3 q) {
    vec4 wx = cubic_weights(q.x), wy = cubic_weights(q.y), wz = cubic_weights(q.z);
    vec4 dx = cubic_derivative_weights(q.x), dy = cubic_derivative_weights(q.y);
    vec4 dz = cubic_derivative_weights(q.z);
    return vec3(cubic_contract(k, dx, wy, wz), cubic_contract(k, wx, dy, wz),
                cubic_contract(k, wx, wy, dz));
}
#endif

#endif
