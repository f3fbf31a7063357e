//! The tricubic interpolants' part of the analytic walk (PLAN26 §3.1–3.3): in each cell, the
//! segment's field minus the isovalue as a Bernstein polynomial of degree 9 on `u` in `[0, 1]`,
//! cut into pieces by `bernstein`'s isolation, whose leaves are the pieces of the walk.
//!
//! # The segment polynomial
//!
//! In the cell, `f(q) = Σ_{abc} w_a(x) w_b(y) w_c(z) s_abc`, and along the segment
//! `q(u) = q_in + u (q_out - q_in)` each weight is a cubic in `u`. Its Bernstein coefficients on
//! `[0, 1]` are values of its **blossom** (the symmetric multi-affine form with `P(t, t, t) =
//! w(t)`, `cubic::blossom`): `β_{a,j} = P_a(x0, ..., x0, x1, ..., x1)` with `3 - j` copies of
//! `x0 = q_in.x` and `j` of `x1 = q_out.x`, because `t(u) = x0 (1 - u) + x1 u` is affine. Then:
//!
//! 1. contract x: `π_bc = Σ_a s_abc β^x_a`, 16 cubics;
//! 2. multiply by the y and z weights in scaled Bernstein form (`bernstein::Scaled`, where a
//!    product is a convolution): `Q_c = Σ_b π_bc β^y_b` (degree 6), `F = Σ_c Q_c β^z_c`
//!    (degree 9), unscaled once;
//! 3. subtract the isovalue from every coefficient (the weights are a partition of unity, so
//!    the constant's coefficients are all `iso`), and **replace `b_0` and `b_9` by the walk's
//!    face values** `g_in`, `g_out`: the polynomial's ends are then the bits the neighbouring
//!    cells use (both evaluate a face point with `Kernel::value`, exact at faces), and the
//!    predicate along the ray is decided on one sequence of points, as for trilinear. The
//!    replaced ends differ from the computed ones by rounding only.
//!
//! # Pieces, crossings and the hit
//!
//! The pieces are the isolation's leaves in `u` order (`bernstein`'s walk: depth 16, 129
//! nodes); a leaf's ends are its first and last coefficients, shared bit for bit with its
//! neighbours. The walk's crossing rule is unchanged: a change of the predicate between a
//! leaf's ends is one crossing, exactly at an end that is `0`, otherwise refined in the leaf
//! (Newton on its own coefficients, `cubic::refine_with`). An unresolved leaf (a cap reached)
//! counts a crossing exactly when its ends differ: the module doc's near-tangency clause,
//! widened to `2^-16` of a segment. The normal is the kernel's exact gradient in the hit cell.

use glam::DVec3;

use super::bernstein::{Bernstein, Isolation, Leaf, Scaled, MAX_DEGREE};
use super::cubic::inside_g;
use super::{LeafTrace, Piece, Polynomial, RayCell, SplitPoint};
use crate::field::interpolant::cubic::{blossom, Cubic, Weights};
use crate::field::interpolant::Kernel;
use crate::field::Grid;
use crate::scene::Inside;

/// The Bernstein coefficients (degree 3, on `u` in `[0, 1]`) of the 4 weights along the
/// segment `t0 -> t1` of one axis: `[weight a][coefficient j]`.
fn weight_blossoms<W: Weights>(t0: f64, t1: f64) -> [Bernstein; 4] {
    std::array::from_fn(|a| {
        let b: [f64; 4] = std::array::from_fn(|j| {
            blossom::<W>(a, std::array::from_fn(|i| if i < 3 - j { t0 } else { t1 }))
        });
        Bernstein::new(&b)
    })
}

/// `g(u) = f(q_in + u (q_out - q_in)) - iso` in Bernstein form (degree 9), from the 64 samples
/// `s` (`a + 4 b + 16 c`), with `b_0 = g_in` and `b_9 = g_out` (the module doc's step 3).
// Index loops, as the GLSL port (`cubic_segment`) writes them.
#[allow(clippy::needless_range_loop)]
pub fn segment<W: Weights>(
    s: &[f64; 64],
    q_in: DVec3,
    q_out: DVec3,
    iso: f64,
    (g_in, g_out): (f64, f64),
) -> Bernstein {
    let bx = weight_blossoms::<W>(q_in.x, q_out.x);
    let by = weight_blossoms::<W>(q_in.y, q_out.y).map(|p| Scaled::from(&p));
    let bz = weight_blossoms::<W>(q_in.z, q_out.z).map(|p| Scaled::from(&p));
    let mut f = Scaled::zero(MAX_DEGREE);
    for c in 0..4 {
        let mut q = Scaled::zero(6);
        for b in 0..4 {
            let mut pi = Bernstein::new(&[0.0; 4]);
            for j in 0..4 {
                let r = 4 * b + 16 * c;
                pi.b[j] = ((s[r] * bx[0].b[j] + s[r + 1] * bx[1].b[j]) + s[r + 2] * bx[2].b[j])
                    + s[r + 3] * bx[3].b[j];
            }
            q.mul_add(&Scaled::from(&pi), &by[b]);
        }
        f.mul_add(&q, &bz[c]);
    }
    let mut g = f.unscale();
    for b in &mut g.b[..=MAX_DEGREE] {
        *b -= iso;
    }
    g.b[0] = g_in;
    g.b[MAX_DEGREE] = g_out;
    g
}

/// The leaf's end as a point of the walk's sequence.
fn point(u: f64, g: f64, inside: Inside) -> SplitPoint {
    SplitPoint { u, g, inside: inside_g(inside, g) }
}

impl<W: Weights> RayCell for Cubic<W> {
    type Cell = [f64; 64];
    type Segment = Bernstein;
    type Local = Leaf;

    fn gather(grid: &Grid, cell: [usize; 3]) -> [f64; 64] {
        <Self as Kernel>::gather(|[i, j, k]| f64::from(grid.at(i, j, k)), cell, grid.dims)
    }

    fn missing(c: &[f64; 64]) -> bool {
        <Self as Kernel>::missing(c)
    }

    fn value(c: &[f64; 64], q: DVec3) -> f64 {
        <Self as Kernel>::value(c, q)
    }

    fn gradient(c: &[f64; 64], q: DVec3) -> DVec3 {
        <Self as Kernel>::gradient(c, q)
    }

    fn segment(
        c: &[f64; 64],
        q_in: DVec3,
        q_out: DVec3,
        iso: f64,
        g_ends: (f64, f64),
        _inside: Inside,
    ) -> Bernstein {
        segment::<W>(c, q_in, q_out, iso, g_ends)
    }

    fn pieces(seg: &Bernstein, inside: Inside) -> impl Iterator<Item = Piece<Leaf>> {
        Isolation::new(seg).map(move |leaf| {
            let (ga, gb) = leaf.c.ends();
            Piece {
                a: point(leaf.lo(), ga, inside),
                b: point(leaf.hi(), gb, inside),
                local: leaf,
                leaf: Some(LeafTrace {
                    u: (leaf.lo(), leaf.hi()),
                    variations: leaf.variations,
                    resolved: leaf.resolved,
                }),
            }
        })
    }

    fn refine(
        _seg: &Bernstein,
        piece: &Piece<Leaf>,
        inside: Inside,
        steps: u32,
        iterates: Option<&mut Vec<f64>>,
    ) -> f64 {
        // Called only when the ends differ and neither is 0, so the leaf has a crossing.
        piece.local.crossing(inside, steps, iterates).map_or(piece.a.u, |c| c.u)
    }

    fn describe(c: &[f64; 64], seg: Option<&Bernstein>) -> (Vec<f64>, Polynomial, Vec<f64>) {
        let coefficients = seg.map_or_else(Vec::new, |b| b.coefficients().to_vec());
        (c.to_vec(), Polynomial::Bernstein(coefficients), Vec::new())
    }
}
