// The arithmetic of exact ray tracing in one trilinear cell, in f32: the GLSL port of
// `reference::analytic::cubic` and of `reference::trilinear` (f64), line for line.
// The cell's value and gradient (`interp_value`, `interp_gradient`) and `Corners` (lo = (v000,
// v100, v010, v110), hi = (v001, v101, v011, v111): the reference's corner order c[0..8]) are
// interpolant.glsl's.

#include "interpolant.glsl"

// A Newton step this small (in the segment parameter u in [0, 1]) that still leaves the bracket
// is rounding: the iterate has converged against one end of the bracket. The reference's
// 4 * f64::EPSILON becomes 4 * FLT_EPSILON.
const float CONVERGED = 4.0 * 1.1920928955078125e-7;

// The cubic g(u) = f(q_in + u (q_out - q_in)) - iso of one segment, as (c0, c1, c2, c3):
// c0 = g_in (the carried face value), c1 = grad f(q_in) . D,
// c2 = Dx Dy f_xy + Dx Dz f_xz + Dy Dz f_yz (at q_in), c3 = axyz Dx Dy Dz, with D = q_out - q_in.
vec4 cubic_along(Corners k, vec3 q_in, vec3 q_out, float g_in) {
    float c0 = k.lo.x, c1 = k.lo.y, c2 = k.lo.z, c3 = k.lo.w;
    float c4 = k.hi.x, c5 = k.hi.y, c6 = k.hi.z, c7 = k.hi.w;
    vec3 d = q_out - q_in;
    float axy = (c3 - c2) - (c1 - c0);
    float axz = (c5 - c4) - (c1 - c0);
    float ayz = (c6 - c4) - (c2 - c0);
    float axyz = ((c7 - c6) - (c5 - c4)) - ((c3 - c2) - (c1 - c0));
    vec3 mixed = vec3(ayz + axyz * q_in.x, axz + axyz * q_in.y, axy + axyz * q_in.z);
    return vec4(g_in,
                dot(interp_gradient(k, q_in), d),
                d.x * d.y * mixed.z + d.x * d.z * mixed.y + d.y * d.z * mixed.x,
                axyz * d.x * d.y * d.z);
}

// g(u) (Horner).
float cubic_eval(vec4 c, float u) {
    return ((c.w * u + c.z) * u + c.y) * u + c.x;
}

// g'(u) (Horner).
float cubic_slope(vec4 c, float u) {
    return (3.0 * c.w * u + 2.0 * c.z) * u + c.y;
}

// Roots of g'(u) = 3 c3 u^2 + 2 c2 u + c1 strictly inside (0, 1), ascending; returns how many.
// Linear when 3 c3 == 0 (none when c2 == 0 too); the cancellation-free quadratic formula
// otherwise. A tiny leading coefficient sends q / a far outside [0, 1] or to infinity, and the
// strict test drops infinities and NaNs: no epsilon.
int derivative_roots(vec4 c, out float r0, out float r1) {
    float a = 3.0 * c.w;
    float b = 2.0 * c.z;
    float cc = c.y;
    float x0 = -1.0, x1 = -1.0;  // -1: no root (outside (0, 1))
    if (a == 0.0) {
        if (b != 0.0) x0 = -cc / b;
    } else {
        float disc = b * b - 4.0 * a * cc;
        if (disc == 0.0) {
            x0 = -b / (2.0 * a);
        } else if (disc > 0.0) {
            float s = sqrt(disc);
            float q = -0.5 * (b + (b >= 0.0 ? s : -s));
            x0 = q / a;
            x1 = cc / q;
            if (x1 < x0) {
                float t = x0;
                x0 = x1;
                x1 = t;
            }
        }
    }
    int n = 0;
    r0 = 0.0;
    r1 = 0.0;
    if (x0 > 0.0 && x0 < 1.0) {
        r0 = x0;
        n = 1;
    }
    if (x1 > 0.0 && x1 < 1.0) {
        if (n == 0) r0 = x1; else r1 = x1;
        n++;
    }
    return n;
}

// The inside predicate on g = f - iso (reference: `inside_g`); `below` is true for
// inside = "below". IEEE subtraction keeps the sign, so this equals inside_of(f, iso). (A GPU that
// flushes denormals can turn a tiny difference into 0, i.e. outside: a rounding-level difference
// from the f64 reference.)
bool inside_g(bool below, float g) {
    return below ? g < 0.0 : g > 0.0;
}

// The one root of g in [lo, hi] (g monotone there, the predicate different at the ends, neither
// end exactly on the surface): secant start (midpoint if not strictly inside), then up to
// `steps` Newton steps with the bracket shrunk by the predicate at each iterate; a step that
// leaves the bracket becomes a bisection, unless it is no longer than CONVERGED (converged
// against an end: stop). Stops on g == 0 or a step that changes nothing.
float refine_root(vec4 c, bool below, float lo, float hi, float g_lo, float g_hi, uint steps) {
    bool p_lo = inside_g(below, g_lo);
    float u = lo + (hi - lo) * (g_lo / (g_lo - g_hi));
    if (!(u > lo && u < hi)) u = 0.5 * (lo + hi);
    for (uint i = 0u; i < steps; i++) {
        float g = cubic_eval(c, u);
        float dg = cubic_slope(c, u);
        if (g == 0.0) break;
        if (inside_g(below, g) == p_lo) lo = u; else hi = u;
        float step = g / dg;
        float next = u - step;
        if (!(next > lo && next < hi)) {
            if (abs(step) <= CONVERGED) break;
            next = 0.5 * (lo + hi);
        }
        if (next == u) break;
        u = next;
    }
    return u;
}

// Ray parameter of segment parameter u: t_in + u (t_out - t_in), at most t_out, exactly t_out
// at u = 1 (monotone in u, so crossings stay in order across cells).
float segment_t(float t_in, float t_out, float u) {
    return u >= 1.0 ? t_out : min(t_in + u * (t_out - t_in), t_out);
}
