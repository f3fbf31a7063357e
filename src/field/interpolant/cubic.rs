//! The tricubic interpolants in f64: the uniform cubic B-spline and Catmull-Rom, one
//! [`Kernel`] ([`Cubic`]) over two sets of weights ([`Weights`]). In the cell with lower corner
//! `(i, j, k)` and local `(u, v, w)` in `[0, 1]³`,
//!
//! ```text
//! f = Σ_{a,b,c ∈ {-1,0,1,2}} w_a(u) w_b(v) w_c(w) s[i+a, j+b, k+c]
//! ```
//!
//! with indices outside the grid clamped to the edge point (the contract,
//! `shared/design/interface.md`). The samples are gathered as 4×4×4, offsets `-1..=2`, sample
//! `(a, b, c)` (from 0) at index `a + 4b + 16c`:
//!
//! ```text
//!   offset  -1    0    1    2        the cell is [0, 1] between offsets 0 and 1;
//!            o----o====o----o        o = a sample it reads; its neighbour across the
//!                 0    1             face at 1 reads offsets 0..=3 of this one
//! ```
//!
//! # Face exactness
//!
//! Two cells sharing a face give the same bits at a point of that face (as trilinear does,
//! `trilinear`'s "Face exactness"), which lets a ray tracer evaluate a cell's entry value
//! from its own samples and still agree with the cell it left. Three rules make it so:
//!
//! 1. **Weights** are Horner in `t` on the *integer* numerators ([`Weights::NUM`]), divided by
//!    [`Weights::DEN`] **last**. At `t = 0` and `t = 1` Horner sums small integers, exactly, so
//!    a face weight is `fl(k / DEN)` for an integer `k`, and the rows are such that weight
//!    `a` at `t = 1` has the numerator of weight `a - 1` at `t = 0` (B-spline: 0, 1, 4, 1 and
//!    1, 4, 1, 0). Dividing first (`NUM / DEN` as coefficients) would round each coefficient
//!    and then their sum: not `fl(k / DEN)`, and not the same in both cells.
//! 2. **Contraction** runs along x, then y, then z, each a sum over the offsets in ascending
//!    order, `((w₀s₀ + w₁s₁) + w₂s₂) + w₃s₃`, in plain multiplies and adds (Rust never fuses
//!    them; the GLSL twin is `precise`).
//! 3. At the face, the cell below holds `0 s₋₁, w s₀, w' s₁, w'' s₂` and the cell above
//!    `w s₀, w' s₁, w'' s₂, 0 s₃`: the same terms in the same order plus a term of weight
//!    exactly 0 at the opposite end, and `0 s + x == x` and `x + 0 s == x` bit for bit for
//!    finite `s` (up to the sign of a zero result, which no comparison sees). A face across x
//!    leaves every x-row's sum identical, and y and z then use the same weights on the same
//!    values; a face across y or z is the same argument one contraction later.
//!
//! The tests below check it on random samples for faces in x, y and z, and at the borders,
//! where the clamp repeats the edge point.
//!
//! # Bounds
//!
//! [`Kernel::hull`] is the range of the cell's tricubic Bézier net (per axis, the 4 samples to
//! the segment's 4 Bézier points, [`Weights::BEZIER`]), which holds the value and every
//! Bernstein coefficient of a ray segment through the cell (those are blossoms of the tensor
//! form at points of `[0, 1]³`, convex combinations of the net), computed in f64 (callers that
//! skip on it keep a margin for its rounding). Per axis the blossoms of the weights
//! ([`blossom`]) are multi-affine with constant signs on `[0, 1]³`, so `Σ_a |P_a|` is largest
//! at a vertex: B-spline's are all `>= 0` (a convex combination: the samples' range bounds
//! it), Catmull-Rom's `Σ_a |P_a|` reaches `L = 4/3`, so with `s` in `[m, M]` every coefficient
//! lies in `[m - κ (M - m), M + κ (M - m)]` with `κ = (L³ - 1) / 2 = 37/54`
//! ([`Weights::KAPPA`]; the tests check the vertices, that the bound is attained, and random
//! nets).

use std::marker::PhantomData;

use glam::DVec3;

use super::{clamped, finite_range, is_missing, Kernel, Stencil};

/// One tricubic interpolant's weights along an axis, for offsets `a = -1, 0, 1, 2` (rows 0..4).
pub trait Weights {
    /// The interpolant's name (`Interpolant::name`).
    const NAME: &'static str;
    /// The common denominator of [`Weights::NUM`].
    const DEN: f64;
    /// Row `a + 1`: the integer numerators of weight `a`'s coefficients of 1, t, t², t³
    /// (weight = numerators / DEN).
    const NUM: [[f64; 4]; 4];
    /// Row `j`: the segment's Bézier point `j` (on `[0, 1]`) from the 4 samples (columns,
    /// offsets -1..=2): the blossom of the weights at `(0^(3-j), 1^j)`.
    const BEZIER: [[f64; 4]; 4];
    /// How far the Bézier net may leave the samples' range, in units of its width (see the
    /// module's "Bounds"): 0 for a convex combination.
    const KAPPA: f64;
}

/// The uniform cubic B-spline: `(1-t)³/6, (3t³ - 6t² + 4)/6, (-3t³ + 3t² + 3t + 1)/6, t³/6`.
pub struct BSplineWeights;

impl Weights for BSplineWeights {
    const NAME: &'static str = "cubic-bspline";
    const DEN: f64 = 6.0;
    const NUM: [[f64; 4]; 4] = [
        [1.0, -3.0, 3.0, -1.0],
        [4.0, 0.0, -6.0, 3.0],
        [1.0, 3.0, 3.0, -3.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    const BEZIER: [[f64; 4]; 4] = [
        [1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0, 0.0],
        [0.0, 4.0 / 6.0, 2.0 / 6.0, 0.0],
        [0.0, 2.0 / 6.0, 4.0 / 6.0, 0.0],
        [0.0, 1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0],
    ];
    const KAPPA: f64 = 0.0;
}

/// Catmull-Rom: `(-t³ + 2t² - t)/2, (3t³ - 5t² + 2)/2, (-3t³ + 4t² + t)/2, (t³ - t²)/2`.
pub struct CatmullRomWeights;

impl Weights for CatmullRomWeights {
    const NAME: &'static str = "catmull-rom";
    const DEN: f64 = 2.0;
    const NUM: [[f64; 4]; 4] = [
        [0.0, -1.0, 2.0, -1.0],
        [2.0, 0.0, -5.0, 3.0],
        [0.0, 1.0, 4.0, -3.0],
        [0.0, 0.0, -1.0, 1.0],
    ];
    const BEZIER: [[f64; 4]; 4] = [
        [0.0, 1.0, 0.0, 0.0],
        [-1.0 / 6.0, 1.0, 1.0 / 6.0, 0.0],
        [0.0, 1.0 / 6.0, 1.0, -1.0 / 6.0],
        [0.0, 0.0, 1.0, 0.0],
    ];
    const KAPPA: f64 = 37.0 / 54.0;
}

/// A tricubic interpolant with weights `W`, as a [`Kernel`] on the 4×4×4 samples.
pub struct Cubic<W>(PhantomData<W>);

/// `interpolation = "cubic-bspline"`.
pub type BSpline = Cubic<BSplineWeights>;
/// `interpolation = "catmull-rom"`.
pub type CatmullRom = Cubic<CatmullRomWeights>;

/// The 4 weights at `t` (see the module's "Face exactness": Horner on the numerators, divided
/// by `DEN` last).
#[inline]
pub fn weights<W: Weights>(t: f64) -> [f64; 4] {
    W::NUM.map(|[n0, n1, n2, n3]| (((n3 * t + n2) * t + n1) * t + n0) / W::DEN)
}

/// The 4 weights' derivatives in `t`.
#[inline]
pub fn derivative_weights<W: Weights>(t: f64) -> [f64; 4] {
    W::NUM.map(|[_, n1, n2, n3]| ((3.0 * n3 * t + 2.0 * n2) * t + n1) / W::DEN)
}

/// The blossom of weight `a + 1 = row`: the symmetric function, affine in each argument,
/// with `blossom(row, [t, t, t]) = weights(t)[row]`. A segment's Bernstein coefficients along
/// an axis are these at its end points (`(x0^(3-j), x1^j)`).
pub fn blossom<W: Weights>(row: usize, [t1, t2, t3]: [f64; 3]) -> f64 {
    let [n0, n1, n2, n3] = W::NUM[row];
    let s1 = t1 + t2 + t3;
    let s2 = t1 * t2 + t1 * t3 + t2 * t3;
    let s3 = t1 * t2 * t3;
    (n0 + n1 * s1 / 3.0 + n2 * s2 / 3.0 + n3 * s3) / W::DEN
}

/// `Σ_a w[a] s[a]` over the 4 offsets, ascending (the module's "Face exactness").
#[inline]
fn dot4(w: &[f64; 4], s: [f64; 4]) -> f64 {
    w[0] * s[0] + w[1] * s[1] + w[2] * s[2] + w[3] * s[3]
}

/// The tensor contraction of the 64 samples with per-axis weights: along x, then y, then z.
#[inline]
fn contract(s: &[f64; 64], wx: &[f64; 4], wy: &[f64; 4], wz: &[f64; 4]) -> f64 {
    let row = |b: usize, c: usize| {
        let r = 4 * b + 16 * c;
        dot4(wx, [s[r], s[r + 1], s[r + 2], s[r + 3]])
    };
    let plane = |c: usize| dot4(wy, [row(0, c), row(1, c), row(2, c), row(3, c)]);
    dot4(wz, [plane(0), plane(1), plane(2), plane(3)])
}

/// `m` applied along the axis of `stride` (1, 4, 16) to each line of 4 in `v`.
fn along(v: &[f64; 64], stride: usize, m: &[[f64; 4]; 4]) -> [f64; 64] {
    std::array::from_fn(|n| {
        let j = n / stride % 4;
        let base = n - j * stride;
        dot4(&m[j], std::array::from_fn(|a| v[base + a * stride]))
    })
}

/// The cell's tricubic Bézier net (index `j + 4k + 16l`): its Bernstein coefficients on
/// `[0, 1]³`.
pub fn bezier_net<W: Weights>(s: &[f64; 64]) -> [f64; 64] {
    along(&along(&along(s, 1, &W::BEZIER), 4, &W::BEZIER), 16, &W::BEZIER)
}

impl<W: Weights> Kernel for Cubic<W> {
    const STENCIL: Stencil = Stencil { below: 1, above: 2 };
    type Cell = [f64; 64];

    #[inline]
    fn gather(
        read: impl Fn([usize; 3]) -> f64,
        [i, j, k]: [usize; 3],
        [nx, ny, nz]: [usize; 3],
    ) -> [f64; 64] {
        std::array::from_fn(|n| {
            read([
                clamped(i, n & 3, 1, nx),
                clamped(j, n >> 2 & 3, 1, ny),
                clamped(k, n >> 4, 1, nz),
            ])
        })
    }

    #[inline]
    fn value(c: &[f64; 64], q: DVec3) -> f64 {
        contract(c, &weights::<W>(q.x), &weights::<W>(q.y), &weights::<W>(q.z))
    }

    #[inline]
    fn gradient(c: &[f64; 64], q: DVec3) -> DVec3 {
        let w = [q.x, q.y, q.z].map(weights::<W>);
        let d = [q.x, q.y, q.z].map(derivative_weights::<W>);
        DVec3::new(
            contract(c, &d[0], &w[1], &w[2]),
            contract(c, &w[0], &d[1], &w[2]),
            contract(c, &w[0], &w[1], &d[2]),
        )
    }

    /// The range of the Bézier net's finite points (see the module's "Bounds"). Each point mixes
    /// all 64 samples, so a missing cell's hull is empty (`[inf, -inf]`): it holds no surface.
    fn hull(c: &[f64; 64]) -> [f64; 2] {
        finite_range(bezier_net::<W>(c))
    }

    #[inline]
    fn missing(c: &[f64; 64]) -> bool {
        c.iter().any(|&v| is_missing(v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::interpolant::{Interpolant, Interpolated, Trilinear};
    use crate::field::Grid;

    fn xorshift(state: &mut u64) -> f64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    fn random_cell(s: &mut u64) -> [f64; 64] {
        std::array::from_fn(|_| xorshift(s) * 2.0 - 1.0)
    }

    /// The samples of `f` at the 4×4×4 points around cell `(i, j, k)`, unclamped.
    fn sampled(f: impl Fn(DVec3) -> f64, [i, j, k]: [i64; 3]) -> [f64; 64] {
        std::array::from_fn(|n| {
            let p = [i + (n & 3) as i64 - 1, j + (n >> 2 & 3) as i64 - 1, k + (n >> 4) as i64 - 1];
            f(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        })
    }

    /// `v` along axis `a`.
    fn along_axis(a: usize, v: f64) -> DVec3 {
        let mut e = DVec3::ZERO;
        e[a] = v;
        e
    }

    fn random_q(s: &mut u64) -> DVec3 {
        DVec3::new(xorshift(s), xorshift(s), xorshift(s))
    }

    fn partition_of_unity<W: Weights>() {
        // At the ends the weights are exact: the numerators over DEN.
        assert_eq!(weights::<W>(0.0), W::NUM.map(|n| n[0] / W::DEN), "{}", W::NAME);
        assert_eq!(weights::<W>(1.0), W::NUM.map(|n| n.iter().sum::<f64>() / W::DEN));
        let mut s = 7;
        for _ in 0..1000 {
            let t = xorshift(&mut s);
            let sum: f64 = weights::<W>(t).iter().sum();
            assert!((sum - 1.0).abs() < 1e-15, "{} t {t}: {sum}", W::NAME);
            let d: f64 = derivative_weights::<W>(t).iter().sum();
            assert!(d.abs() < 1e-14, "{} t {t}: {d}", W::NAME);
        }
    }

    #[test]
    fn the_weights_are_a_partition_of_unity() {
        partition_of_unity::<BSplineWeights>();
        partition_of_unity::<CatmullRomWeights>();
    }

    #[test]
    fn the_weights_are_the_contracts_polynomials() {
        let mut s = 3;
        for _ in 0..100 {
            let t = xorshift(&mut s);
            let b = [
                (1.0 - t).powi(3) / 6.0,
                (3.0 * t.powi(3) - 6.0 * t * t + 4.0) / 6.0,
                (-3.0 * t.powi(3) + 3.0 * t * t + 3.0 * t + 1.0) / 6.0,
                t.powi(3) / 6.0,
            ];
            let c = [
                (-t.powi(3) + 2.0 * t * t - t) / 2.0,
                (3.0 * t.powi(3) - 5.0 * t * t + 2.0) / 2.0,
                (-3.0 * t.powi(3) + 4.0 * t * t + t) / 2.0,
                (t.powi(3) - t * t) / 2.0,
            ];
            for a in 0..4 {
                assert!((weights::<BSplineWeights>(t)[a] - b[a]).abs() < 1e-15, "B{a}({t})");
                assert!((weights::<CatmullRomWeights>(t)[a] - c[a]).abs() < 1e-15, "CR{a}({t})");
            }
        }
    }

    /// Value at a point of the face between two cells, from each cell's own samples.
    fn face_bits<W: Weights>(grid: &Grid, seed: u64) {
        let read = |[i, j, k]: [usize; 3]| f64::from(grid.at(i, j, k));
        let gather = |c: [usize; 3]| Cubic::<W>::gather(read, c, grid.dims);
        let mut s = seed;
        let cells = grid.cells();
        for axis in 0..3 {
            for _ in 0..400 {
                // A cell and its + neighbour along `axis`, anywhere (borders included).
                let mut lo: [usize; 3] =
                    std::array::from_fn(|a| (xorshift(&mut s) * cells[a] as f64) as usize);
                lo[axis] = (xorshift(&mut s) * (cells[axis] - 1) as f64) as usize;
                let mut hi = lo;
                hi[axis] += 1;
                let mut q = random_q(&mut s);
                q[axis] = 1.0;
                let below = Cubic::<W>::value(&gather(lo), q);
                q[axis] = 0.0;
                let above = Cubic::<W>::value(&gather(hi), q);
                assert_eq!(below.to_bits(), above.to_bits(), "{} axis {axis} cell {lo:?}", W::NAME);
            }
        }
    }

    fn random_grid(dims: [usize; 3], seed: u64) -> Grid {
        let mut s = seed;
        let n = dims.iter().product();
        let values = (0..n).map(|_| (xorshift(&mut s) * 2.0 - 1.0) as f32).collect();
        Grid { dims, min: DVec3::ZERO, max: DVec3::ONE, values }
    }

    #[test]
    fn two_cells_give_the_same_bits_on_their_face() {
        for seed in [1, 2, 3] {
            let grid = random_grid([6, 5, 7], seed);
            face_bits::<BSplineWeights>(&grid, seed);
            face_bits::<CatmullRomWeights>(&grid, seed);
        }
    }

    /// `f` is reproduced to `tol` (value) in cells two or more away from the border, where
    /// no clamp applies; `f` is given with its gradient.
    fn reproduces<K: Kernel<Cell = [f64; 64]>>(
        f: impl Fn(DVec3) -> f64 + Copy,
        g: impl Fn(DVec3) -> DVec3,
        tol: f64,
    ) {
        let mut s = 11;
        for _ in 0..200 {
            let cell = [0, 1, 2].map(|_| (xorshift(&mut s) * 8.0) as i64 - 4);
            let c = sampled(f, cell);
            let q = random_q(&mut s);
            let p = DVec3::new(cell[0] as f64, cell[1] as f64, cell[2] as f64) + q;
            assert!((K::value(&c, q) - f(p)).abs() < tol, "at {p}");
            assert!((K::gradient(&c, q) - g(p)).abs().max_element() < tol * 10.0, "at {p}");
        }
    }

    #[test]
    fn linear_fields_are_reproduced_by_all_three_smooth_kernels() {
        let f = |p: DVec3| 0.5 + 1.25 * p.x - 2.0 * p.y + 0.75 * p.z;
        let g = |_| DVec3::new(1.25, -2.0, 0.75);
        reproduces::<BSpline>(f, g, 1e-12);
        reproduces::<CatmullRom>(f, g, 1e-12);
        let mut s = 5;
        for _ in 0..100 {
            let q = random_q(&mut s);
            let c: [f64; 8] = std::array::from_fn(|n| {
                f(DVec3::new((n & 1) as f64, (n >> 1 & 1) as f64, (n >> 2) as f64))
            });
            assert!((Trilinear::value(&c, q) - f(q)).abs() < 1e-12);
            assert!((Trilinear::gradient(&c, q) - g(q)).abs().max_element() < 1e-12);
        }
    }

    #[test]
    fn catmull_rom_reproduces_quadratics() {
        let f = |p: DVec3| {
            p.x * p.x - 2.0 * p.y * p.y + 0.5 * p.z * p.z + p.x * p.y - 3.0 * p.y * p.z
                + 0.25 * p.z * p.x
                + p.x
                - 1.0
        };
        let g = |p: DVec3| {
            DVec3::new(
                2.0 * p.x + p.y + 0.25 * p.z + 1.0,
                -4.0 * p.y + p.x - 3.0 * p.z,
                p.z - 3.0 * p.y + 0.25 * p.x,
            )
        };
        reproduces::<CatmullRom>(f, g, 1e-11);
    }

    /// The B-spline's moments: x² becomes x² + h²/3 and x³ becomes x³ + h² x (h = 1 in index
    /// space), along each axis.
    #[test]
    fn the_bspline_of_x2_and_x3_adds_its_variance() {
        for a in 0..3 {
            let e = |v: f64| along_axis(a, v);
            // Value x² + 1/3, gradient 2x.
            let mut s = 17;
            for _ in 0..200 {
                let cell = [0, 1, 2].map(|_| (xorshift(&mut s) * 8.0) as i64 - 4);
                let q = random_q(&mut s);
                let p = DVec3::new(cell[0] as f64, cell[1] as f64, cell[2] as f64) + q;
                let c2 = sampled(|p| p[a] * p[a], cell);
                assert!((BSpline::value(&c2, q) - (p[a] * p[a] + 1.0 / 3.0)).abs() < 1e-12);
                assert!((BSpline::gradient(&c2, q) - e(2.0 * p[a])).length() < 1e-11);
                let c3 = sampled(|p| p[a].powi(3), cell);
                assert!((BSpline::value(&c3, q) - (p[a].powi(3) + p[a])).abs() < 1e-11);
                let d3 = e(3.0 * p[a] * p[a] + 1.0);
                assert!((BSpline::gradient(&c3, q) - d3).length() < 1e-10);
            }
        }
    }

    /// With a grid spacing h, through [`Interpolated`]: x² sampled gives x² + h²/3.
    #[test]
    fn the_bspline_moment_scales_with_the_spacing() {
        let (n, h) = (9usize, 0.5);
        let values = (0..n * n * n).map(|m| ((m % n) as f64 * h).powi(2) as f32).collect();
        let max = DVec3::splat((n - 1) as f64 * h);
        let grid = Grid { dims: [n; 3], min: DVec3::ZERO, max, values };
        let f = Interpolated::new(&grid, Interpolant::CubicBspline);
        let mut s = 23;
        for _ in 0..100 {
            // Cells 1..n-3 along x read no clamped point.
            let u = DVec3::new(1.0 + xorshift(&mut s) * (n - 4) as f64, 3.3, 4.7);
            let x = u.x * h;
            assert!((f.value_at(u) - (x * x + h * h / 3.0)).abs() < 1e-12, "at {u}");
            let g = f.gradient_at(u);
            assert!((g - DVec3::new(2.0 * x, 0.0, 0.0)).length() < 1e-11, "at {u}: {g}");
        }
    }

    fn central_differences<W: Weights>() {
        let mut s = 29;
        for _ in 0..200 {
            let c = random_cell(&mut s);
            let q = random_q(&mut s) * 0.98 + 0.01;
            let h = 1e-6;
            let fd = DVec3::from_array(std::array::from_fn(|a| {
                let e = along_axis(a, h);
                (Cubic::<W>::value(&c, q + e) - Cubic::<W>::value(&c, q - e)) / (2.0 * h)
            }));
            let g = Cubic::<W>::gradient(&c, q);
            assert!((g - fd).abs().max_element() < 1e-7, "{}: {g} vs {fd}", W::NAME);
        }
    }

    #[test]
    fn the_gradient_is_the_central_difference_of_the_value() {
        central_differences::<BSplineWeights>();
        central_differences::<CatmullRomWeights>();
    }

    /// The 8 vertices of `[0, 1]³`, a blossom's arguments.
    fn vertices() -> [[f64; 3]; 8] {
        std::array::from_fn(|n| [(n & 1) as f64, (n >> 1 & 1) as f64, (n >> 2) as f64])
    }

    #[test]
    fn the_blossoms_give_the_bezier_rows_and_the_weights() {
        fn check<W: Weights>() {
            for j in 0..4 {
                // (0^(3-j), 1^j)
                let t = std::array::from_fn(|m| if m < 3 - j { 0.0 } else { 1.0 });
                for (a, &b) in W::BEZIER[j].iter().enumerate() {
                    assert!((blossom::<W>(a, t) - b).abs() < 1e-15, "{} {j} {a}", W::NAME);
                }
            }
            let mut s = 31;
            for _ in 0..100 {
                let t = xorshift(&mut s);
                for a in 0..4 {
                    assert!((blossom::<W>(a, [t; 3]) - weights::<W>(t)[a]).abs() < 1e-15);
                }
            }
        }
        check::<BSplineWeights>();
        check::<CatmullRomWeights>();
    }

    #[test]
    fn bspline_blossoms_are_never_negative() {
        for a in 0..4 {
            for t in vertices() {
                assert!(blossom::<BSplineWeights>(a, t) >= 0.0, "row {a} at {t:?}");
            }
        }
        assert_eq!(BSplineWeights::KAPPA, 0.0);
    }

    #[test]
    fn catmull_rom_overshoots_by_at_most_kappa() {
        // Σ_a |P_a| at the vertices: at most 4/3, and 4/3 is reached.
        let l = vertices()
            .map(|t| (0..4).map(|a| blossom::<CatmullRomWeights>(a, t).abs()).sum::<f64>())
            .into_iter()
            .fold(0.0, f64::max);
        assert!((l - 4.0 / 3.0).abs() < 1e-15, "L = {l}");
        assert!((CatmullRomWeights::KAPPA - (l.powi(3) - 1.0) / 2.0).abs() < 1e-15);
        // Attained: 1 where the net point (1, 1, 1)'s weight is positive, 0 elsewhere.
        let b = CatmullRomWeights::BEZIER[1];
        let s: [f64; 64] =
            std::array::from_fn(|n| f64::from(b[n & 3] * b[n >> 2 & 3] * b[n >> 4] > 0.0));
        let net = bezier_net::<CatmullRomWeights>(&s);
        assert!((net[1 + 4 + 16] - (1.0 + CatmullRomWeights::KAPPA)).abs() < 1e-15);
        // Random samples: the net stays within the widened range.
        let mut st = 37;
        for _ in 0..2000 {
            let c = random_cell(&mut st);
            let [m, big_m] = finite_range(c);
            let k = CatmullRomWeights::KAPPA * (big_m - m);
            let [lo, hi] = CatmullRom::hull(&c);
            assert!(lo >= m - k - 1e-14 && hi <= big_m + k + 1e-14);
            let [lo, hi] = BSpline::hull(&c);
            assert!(lo >= m - 1e-15 && hi <= big_m + 1e-15);
        }
    }

    /// The net is the tricubic's Bernstein form: it reproduces the value.
    #[test]
    fn the_bezier_net_is_the_cells_bernstein_form() {
        fn check<W: Weights>() {
            let mut s = 41;
            let bern = |t: f64| {
                [(1.0 - t).powi(3), 3.0 * t * (1.0 - t).powi(2), 3.0 * t * t * (1.0 - t), t.powi(3)]
            };
            for _ in 0..100 {
                let c = random_cell(&mut s);
                let net = bezier_net::<W>(&c);
                let q = random_q(&mut s);
                let [bx, by, bz] = [q.x, q.y, q.z].map(bern);
                let v: f64 =
                    (0..64).map(|n| bx[n & 3] * by[n >> 2 & 3] * bz[n >> 4] * net[n]).sum();
                assert!((v - Cubic::<W>::value(&c, q)).abs() < 1e-14, "{}", W::NAME);
                let [lo, hi] = Cubic::<W>::hull(&c);
                assert!(lo <= v && v <= hi);
            }
            let mut holed = random_cell(&mut s);
            holed[21] = f64::NAN;
            assert!(Cubic::<W>::missing(&holed));
            // Every net point mixes all 64 samples (0 NaN is NaN): a missing cell has an empty
            // hull, and holds no surface anyway.
            assert_eq!(Cubic::<W>::hull(&holed), [f64::INFINITY, f64::NEG_INFINITY]);
        }
        check::<BSplineWeights>();
        check::<CatmullRomWeights>();
    }

    /// At the borders the stencil reads the edge point again: the same as a grid padded with
    /// copies of its edge planes.
    #[test]
    fn the_stencil_is_clamped_at_both_borders() {
        let dims = [4, 5, 3];
        let grid = random_grid(dims, 43);
        let read = |[i, j, k]: [usize; 3]| f64::from(grid.at(i, j, k));
        let padded = |[i, j, k]: [i64; 3]| {
            let c = |v: i64, n: usize| v.clamp(0, n as i64 - 1) as usize;
            f64::from(grid.at(c(i, dims[0]), c(j, dims[1]), c(k, dims[2])))
        };
        for cell in [[0, 0, 0], [2, 3, 1], [0, 3, 0], [2, 0, 1]] {
            let g = BSpline::gather(read, cell, dims);
            let want: [f64; 64] = std::array::from_fn(|n| {
                let o = [n & 3, n >> 2 & 3, n >> 4];
                padded(std::array::from_fn(|a| cell[a] as i64 + o[a] as i64 - 1))
            });
            assert_eq!(g, want, "cell {cell:?}");
        }
        // On the box's faces CR interpolates the edge samples (weight 1 at offset 0).
        let f = Interpolated::new(&grid, Interpolant::CatmullRom);
        for p in [[0, 0, 0], [3, 4, 2], [3, 0, 2], [0, 4, 1]] {
            let u = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            assert_eq!(f.value_at(u), f64::from(grid.at(p[0], p[1], p[2])), "point {p:?}");
        }
    }
}
