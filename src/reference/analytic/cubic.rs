//! The cubic `g(u) = f(q_in + u (q_out - q_in)) - iso` of one cell segment, its derivative's
//! roots, and the bracketed root refinement. Pure arithmetic, no grid: this is the part of the
//! tracer that the GLSL shader copies line for line.

use glam::DVec3;

use crate::field::interpolant::{Kernel, Trilinear};
use crate::scene::Inside;

/// The trilinear interpolant of a cell in the monomial basis (the root finder's own form: the
/// cubic's `c2` and `c3` come from it):
/// `f = a0 + ax x + ay y + az z + axy x y + axz x z + ayz y z + axyz x y z` (cell-local).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Monomial {
    pub a0: f64,
    pub ax: f64,
    pub ay: f64,
    pub az: f64,
    pub axy: f64,
    pub axz: f64,
    pub ayz: f64,
    pub axyz: f64,
}

impl Monomial {
    /// Coefficients of the interpolant of corners `c` (corner order).
    pub fn from_corners(c: &[f64; 8]) -> Self {
        Monomial {
            a0: c[0],
            ax: c[1] - c[0],
            ay: c[2] - c[0],
            az: c[4] - c[0],
            axy: (c[3] - c[2]) - (c[1] - c[0]),
            axz: (c[5] - c[4]) - (c[1] - c[0]),
            ayz: (c[6] - c[4]) - (c[2] - c[0]),
            axyz: ((c[7] - c[6]) - (c[5] - c[4])) - ((c[3] - c[2]) - (c[1] - c[0])),
        }
    }

    /// Mixed second derivatives `(f_yz, f_xz, f_xy)` at cell-local `q` (the diagonal of the
    /// Hessian is zero).
    pub fn mixed(&self, q: DVec3) -> DVec3 {
        DVec3::new(
            self.ayz + self.axyz * q.x,
            self.axz + self.axyz * q.y,
            self.axy + self.axyz * q.z,
        )
    }
}

/// `g(u) = c[3] u^3 + c[2] u^2 + c[1] u + c[0]` for `u` in `[0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cubic {
    pub c: [f64; 4],
}

impl Cubic {
    /// The cubic of the segment from cell-local `q_in` to `q_out` in a cell with corners
    /// `corners`; `g_in` is `f(q_in) - iso`, passed in so that `g(0)` is bit for bit the value
    /// the walk carries across the face (it equals `trilerp(corners, q_in) - iso`).
    ///
    /// With `D = q_out - q_in` (a Taylor expansion of the trilinear interpolant, whose Hessian
    /// has a zero diagonal and whose only third derivative is `f_xyz = axyz`):
    ///
    /// ```text
    /// c0 = g_in
    /// c1 = grad f(q_in) . D
    /// c2 = Dx Dy f_xy(q_in) + Dx Dz f_xz(q_in) + Dy Dz f_yz(q_in)
    /// c3 = axyz Dx Dy Dz
    /// ```
    pub fn along_segment(corners: &[f64; 8], q_in: DVec3, q_out: DVec3, g_in: f64) -> Self {
        let d = q_out - q_in;
        let m = Monomial::from_corners(corners);
        let mixed = m.mixed(q_in); // (f_yz, f_xz, f_xy)
        Cubic {
            c: [
                g_in,
                Trilinear::gradient(corners, q_in).dot(d),
                d.x * d.y * mixed.z + d.x * d.z * mixed.y + d.y * d.z * mixed.x,
                m.axyz * d.x * d.y * d.z,
            ],
        }
    }

    /// `g(u)` (Horner).
    #[inline]
    pub fn eval(&self, u: f64) -> f64 {
        let c = &self.c;
        ((c[3] * u + c[2]) * u + c[1]) * u + c[0]
    }

    /// `(g(u), g'(u))` (Horner).
    #[inline]
    pub fn eval_with_derivative(&self, u: f64) -> (f64, f64) {
        let c = &self.c;
        let g = ((c[3] * u + c[2]) * u + c[1]) * u + c[0];
        let dg = (3.0 * c[3] * u + 2.0 * c[2]) * u + c[1];
        (g, dg)
    }

    /// Roots of `g'(u) = 3 c3 u^2 + 2 c2 u + c1` strictly inside `(0, 1)`, ascending, as
    /// `(roots, count)`.
    ///
    /// - `3 c3 == 0`: linear `2 c2 u + c1` (no root when `c2 == 0` too: `g` is linear or
    ///   constant).
    /// - discriminant `< 0`: none; `== 0`: the double root `-B / 2A` (a flat inflection; splitting
    ///   there is harmless).
    /// - otherwise the cancellation-free pair `q = -(B + sign(B) sqrt(disc)) / 2`, `q / A`,
    ///   `C / q`, with `sign(0) = +1`. A tiny `A` sends `q / A` far outside `[0, 1]` (or to
    ///   infinity), so no epsilon is needed.
    ///
    /// Roots equal to 0 or 1, infinities and NaNs are dropped by the strict `0 < r < 1` test.
    pub fn derivative_roots(&self) -> ([f64; 2], usize) {
        let a = 3.0 * self.c[3];
        let b = 2.0 * self.c[2];
        let c = self.c[1];
        let mut r = [f64::NAN; 2];
        if a == 0.0 {
            if b != 0.0 {
                r[0] = -c / b;
            }
        } else {
            let disc = b * b - 4.0 * a * c;
            if disc == 0.0 {
                r[0] = -b / (2.0 * a);
            } else if disc > 0.0 {
                let s = disc.sqrt();
                let q = -0.5 * (b + if b >= 0.0 { s } else { -s });
                r[0] = q / a;
                r[1] = c / q;
                if r[1] < r[0] {
                    r.swap(0, 1);
                }
            }
        }
        let mut out = [0.0; 2];
        let mut n = 0;
        for x in r {
            if x > 0.0 && x < 1.0 {
                out[n] = x;
                n += 1;
            }
        }
        (out, n)
    }
}

/// Whether a value `g = f - iso` is inside: the same answer as `Inside::contains(f, iso)`
/// (IEEE subtraction is exact in sign and `f - iso == 0` exactly when `f == iso`).
#[inline]
pub fn inside_g(inside: Inside, g: f64) -> bool {
    match inside {
        Inside::Below => g < 0.0,
        Inside::Above => g > 0.0,
    }
}

/// A Newton step this small (in `u`, the segment being `[0, 1]`) that still leaves the bracket
/// is rounding: the iterate has converged against one end of the bracket. (The `f32` port uses
/// `4 * FLT_EPSILON`.)
pub const CONVERGED: f64 = 4.0 * f64::EPSILON;

/// Refines the one root of `g` in the bracket `[lo, hi]`, where `g` is monotone, the predicate
/// differs at the two ends, and neither end is exactly on the surface (`g != 0`; the walk
/// resolves those without refining). `g_lo`, `g_hi` are the values the walk decided the bracket
/// with (for a segment end, the carried face value).
///
/// 1. Start at the secant (regula falsi) point `lo + (hi - lo) g_lo / (g_lo - g_hi)`, or at the
///    midpoint if that is not strictly inside `(lo, hi)`.
/// 2. Up to `steps` times: evaluate `g, g'` at `u`; stop if `g == 0`; shrink the bracket to the
///    side whose predicate differs from `u`'s; take the Newton step `u - g / g'`, or the
///    midpoint if it is not strictly inside the new bracket (this also catches `g' == 0`, NaN and
///    infinities), except that a step no larger than [`CONVERGED`] that leaves the bracket means
///    convergence and stops (bisecting there would throw the converged iterate away, because the
///    far end of a bracket approached from one side never moves); stop if the step leaves `u`
///    unchanged.
/// 3. Return `u` (always inside `[lo, hi]`).
///
/// Every iterate, starting with the initial guess, is pushed to `iterates` when given.
pub fn refine(
    cubic: &Cubic,
    inside: Inside,
    bracket: (f64, f64),
    g_ends: (f64, f64),
    steps: u32,
    iterates: Option<&mut Vec<f64>>,
) -> f64 {
    refine_with(|u| cubic.eval_with_derivative(u), inside, bracket, g_ends, steps, iterates)
}

/// [`refine`] over any function: `eval(u)` returns `(g(u), g'(u))`. The tricubic interpolants'
/// leaves (`bernstein::Leaf::crossing`) call it with de Casteljau on the leaf's coefficients.
pub fn refine_with(
    mut eval: impl FnMut(f64) -> (f64, f64),
    inside: Inside,
    bracket: (f64, f64),
    g_ends: (f64, f64),
    steps: u32,
    mut iterates: Option<&mut Vec<f64>>,
) -> f64 {
    let (mut lo, mut hi) = bracket;
    let (g_lo, g_hi) = g_ends;
    let p_lo = inside_g(inside, g_lo);
    let ratio = g_lo / (g_lo - g_hi);
    let mut u = lo + (hi - lo) * ratio;
    if !(u > lo && u < hi) {
        u = 0.5 * (lo + hi);
    }
    if let Some(it) = iterates.as_deref_mut() {
        it.push(u);
    }
    for _ in 0..steps {
        let (g, dg) = eval(u);
        if g == 0.0 {
            break;
        }
        if inside_g(inside, g) == p_lo {
            lo = u;
        } else {
            hi = u;
        }
        let step = g / dg;
        let mut next = u - step;
        if !(next > lo && next < hi) {
            if step.abs() <= CONVERGED {
                break;
            }
            next = 0.5 * (lo + hi);
        }
        if next == u {
            break;
        }
        u = next;
        if let Some(it) = iterates.as_deref_mut() {
            it.push(u);
        }
    }
    u
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::trilinear::trilerp;

    #[test]
    fn coefficients_reproduce_the_interpolant() {
        let c = [0.3, -1.2, 0.7, 2.0, -0.4, 0.9, -1.5, 0.1];
        let q_in = DVec3::new(0.0, 0.3, 0.8);
        let q_out = DVec3::new(1.0, 0.55, 0.1);
        let cubic = Cubic::along_segment(&c, q_in, q_out, trilerp(&c, q_in) - 0.2);
        for n in 0..=10 {
            let u = n as f64 / 10.0;
            let f = trilerp(&c, q_in + (q_out - q_in) * u) - 0.2;
            assert!((cubic.eval(u) - f).abs() < 1e-14, "u = {u}");
        }
    }

    #[test]
    fn derivative_roots_cases() {
        // g = (u - 0.25)(u - 0.5)(u - 0.75) -> g' roots at 0.5 +- 1/sqrt(48).
        let g = Cubic { c: [-0.09375, 0.6875, -1.5, 1.0] };
        let (r, n) = g.derivative_roots();
        assert_eq!(n, 2);
        let s = (1.0f64 / 48.0).sqrt();
        assert!((r[0] - (0.5 - s)).abs() < 1e-15 && (r[1] - (0.5 + s)).abs() < 1e-15);
        // Quadratic g = (u - 0.4)^2: g' root at 0.4.
        let (r, n) = Cubic { c: [0.16, -0.8, 1.0, 0.0] }.derivative_roots();
        assert_eq!((n, r[0]), (1, 0.4));
        // Linear and constant: none.
        assert_eq!(Cubic { c: [1.0, 2.0, 0.0, 0.0] }.derivative_roots().1, 0);
        assert_eq!(Cubic { c: [1.0, 0.0, 0.0, 0.0] }.derivative_roots().1, 0);
        // Flat inflection: g = (u - 0.5)^3, disc = 0.
        let (r, n) = Cubic { c: [-0.125, 0.75, -1.5, 1.0] }.derivative_roots();
        assert_eq!((n, r[0]), (1, 0.5));
        // No real roots: g' = 3u^2 + 1.
        assert_eq!(Cubic { c: [0.0, 1.0, 0.0, 1.0] }.derivative_roots().1, 0);
        // Tiny leading coefficient: the far root leaves [0, 1], the near one stays accurate.
        let (r, n) = Cubic { c: [0.0, -0.3, 0.5, 1e-300] }.derivative_roots();
        assert_eq!(n, 1);
        assert!((r[0] - 0.3).abs() < 1e-15);
    }

    #[test]
    fn refine_converges_and_stays_in_bracket() {
        let g = Cubic { c: [-0.09375, 0.6875, -1.5, 1.0] };
        for inside in [Inside::Below, Inside::Above] {
            let mut it = Vec::new();
            let u = refine(&g, inside, (0.0, 0.5), (g.eval(0.0), g.eval(0.5)), 50, Some(&mut it));
            assert!((u - 0.25).abs() < 1e-15, "{u}");
            assert!(it.iter().all(|&x| (0.0..=0.5).contains(&x)));
        }
        // A double root nearby: Newton slows down but the bracket keeps it honest.
        let g = Cubic { c: [1e-12 - 0.25, 1.0, -1.0, 0.0] }; // -(u - 0.5)^2 + 1e-12
        let u = refine(&g, Inside::Below, (0.0, 0.5), (g.eval(0.0), g.eval(0.5)), 100, None);
        // Conditioning: |g'| = 2e-6 at the root, so rounding in g (~1e-17) moves it ~1e-11.
        assert!((u - (0.5 - 1e-6)).abs() < 1e-10, "{u}");
        // Zero steps: the secant guess.
        let g = Cubic { c: [-1.0, 2.0, 0.0, 0.0] };
        assert_eq!(refine(&g, Inside::Below, (0.0, 1.0), (-1.0, 1.0), 0, None), 0.5);
    }
}
