//! Root finding on the plane: bracketed 1D roots of the source along a cell edge (for refined
//! contours), and the crossings of the bilinear interpolant along a segment (`isoview probe
//! --slice`).
//!
//! # Along a segment
//!
//! Inside one cell, with cell-local coordinates `(fu, fv)` in `[0, 1]^2` and corner values
//! `v00, v10, v01, v11`, the bilinear interpolant is
//!
//! ```text
//!   f = v00 + (v10 - v00) fu + (v01 - v00) fv + (v00 - v10 - v01 + v11) fu fv
//! ```
//!
//! On the piece of a segment inside the cell, `(fu, fv) = (au + bu s, av + bv s)` for `s` in
//! `[0, 1]`, so `f(s) - isovalue = c0 + c1 s + c2 s^2` is a quadratic (linear when the segment
//! is parallel to an axis or the cell has no twist), whose roots are found in closed form
//! (the cancellation-free pair `q / c2`, `c0 / q`) and polished by a Newton step.

use glam::{DVec2, DVec3};

use super::plane::PlaneGrid;
use crate::scene::Inside;

/// The root of `g` on `[0, 1]` where the inside test changes: `g0 = g(0)` and `g1 = g(1)`
/// differ in `inside`. Illinois false position with a bisection every third step, until the
/// bracket is narrower than 1e-13 or after 200 steps; returns a point of the final bracket.
/// NaN values count as outside.
pub fn bracketed(
    mut g: impl FnMut(f64) -> f64,
    g0: f64,
    g1: f64,
    inside: impl Fn(f64) -> bool,
) -> f64 {
    let (mut a, mut b, mut ga, mut gb) = (0.0f64, 1.0f64, g0, g1);
    let in_a = inside(ga);
    let mut last_side = 0i8;
    for step in 0..200 {
        if b - a <= 1e-13 {
            break;
        }
        let secant = a + (b - a) * (ga / (ga - gb));
        let t = if step % 3 == 2 || !(secant > a && secant < b) { 0.5 * (a + b) } else { secant };
        let gt = g(t);
        if inside(gt) == in_a {
            a = t;
            ga = gt;
            if last_side == -1 {
                gb *= 0.5;
            }
            last_side = -1;
        } else {
            b = t;
            gb = gt;
            if last_side == 1 {
                ga *= 0.5;
            }
            last_side = 1;
        }
        if !(ga.is_finite() && gb.is_finite()) {
            // A NaN end: plain bisection from here on.
            ga = if inside(ga) { -1.0 } else { 1.0 };
            gb = -ga;
        }
    }
    let t = a + (b - a) * (ga / (ga - gb));
    if t >= a && t <= b {
        t
    } else {
        0.5 * (a + b)
    }
}

/// How the segment passes a root.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RootKind {
    /// From outside to inside.
    Entering,
    /// From inside to outside.
    Leaving,
    /// A double root: the field touches the isovalue without crossing it.
    Touching,
}

impl RootKind {
    pub fn name(self) -> &'static str {
        match self {
            RootKind::Entering => "entering",
            RootKind::Leaving => "leaving",
            RootKind::Touching => "touching",
        }
    }
}

/// A zero of `bilinear - isovalue` on the segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentRoot {
    /// Parameter on the cell's piece, `[0, 1]`.
    pub s: f64,
    /// Parameter on the whole segment (0 at its start, 1 at its end).
    pub t: f64,
    /// World `(u, v)` and world point.
    pub uv: DVec2,
    pub point: DVec3,
    pub kind: RootKind,
}

/// The piece of the segment inside one cell.
#[derive(Clone, Debug, PartialEq)]
pub struct SegmentCell {
    /// Plane cell `(i, j)`.
    pub cell: [usize; 2],
    /// `[v00, v10, v01, v11]` (vUV: the corner at u + U, v + V).
    pub corners: [f64; 4],
    /// Segment parameters where the piece enters and leaves the cell.
    pub t: (f64, f64),
    /// Cell-local coordinates there.
    pub local_in: DVec2,
    pub local_out: DVec2,
    /// `[c0, c1, c2]`: `bilinear - isovalue = c0 + c1 s + c2 s^2` over the piece.
    pub quadratic: [f64; 3],
    pub roots: Vec<SegmentRoot>,
}

/// What [`probe_segment`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct SegmentProbe {
    /// The segment, world `(u, v)`.
    pub a: DVec2,
    pub b: DVec2,
    /// The part of `[0, 1]` inside the plane's box (None: the segment misses it).
    pub span: Option<(f64, f64)>,
    pub cells: Vec<SegmentCell>,
}

impl SegmentProbe {
    pub fn roots(&self) -> impl Iterator<Item = &SegmentRoot> {
        self.cells.iter().flat_map(|c| c.roots.iter())
    }
}

/// Clips `q(t) = qa + (qb - qa) t`, `t` in `[0, 1]`, to the box `[0, hi]` (Liang-Barsky).
fn clip(qa: DVec2, qb: DVec2, hi: DVec2) -> Option<(f64, f64)> {
    let d = qb - qa;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..2 {
        if d[k] == 0.0 {
            if qa[k] < 0.0 || qa[k] > hi[k] {
                return None;
            }
        } else {
            let (ta, tb) = ((0.0 - qa[k]) / d[k], (hi[k] - qa[k]) / d[k]);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

/// Real roots of `c0 + c1 s + c2 s^2` (none when it is identically 0).
pub fn quadratic_roots(c: [f64; 3]) -> Vec<f64> {
    let [c0, c1, c2] = c;
    if c2 == 0.0 {
        return if c1 == 0.0 { vec![] } else { vec![-c0 / c1] };
    }
    let disc = c1 * c1 - 4.0 * c2 * c0;
    if disc < 0.0 {
        return vec![];
    }
    let q = -0.5 * (c1 + c1.signum() * disc.sqrt());
    let mut r = vec![q / c2];
    if q != 0.0 && disc > 0.0 {
        r.push(c0 / q);
    }
    r.sort_by(f64::total_cmp);
    r
}

/// The zero crossings of the plane's bilinear interpolant (minus `isovalue`) along the segment
/// from world `(u, v)` `a` to `b`, cell by cell.
pub fn probe_segment(
    plane: &PlaneGrid,
    a: DVec2,
    b: DVec2,
    isovalue: f64,
    inside: Inside,
) -> SegmentProbe {
    let (qa, qb) = (plane.to_index(a), plane.to_index(b));
    let cells = plane.cells();
    let hi = DVec2::new(cells[0] as f64, cells[1] as f64);
    let span = clip(qa, qb, hi);
    let mut out = SegmentProbe { a, b, span, cells: Vec::new() };
    let Some((t0, t1)) = span else {
        return out;
    };
    let d = qb - qa;
    let at = |t: f64| qa + d * t;

    // Where the segment crosses grid lines, in order.
    let mut ts = vec![t0, t1];
    for k in 0..2 {
        if d[k] != 0.0 {
            let (lo, hi) = (at(t0)[k].min(at(t1)[k]), at(t0)[k].max(at(t1)[k]));
            for line in (lo.ceil() as i64)..=(hi.floor() as i64) {
                let t = (line as f64 - qa[k]) / d[k];
                if t > t0 && t < t1 {
                    ts.push(t);
                }
            }
        }
    }
    ts.sort_by(f64::total_cmp);
    ts.dedup();
    let pieces: Vec<(f64, f64)> =
        ts.windows(2).map(|w| (w[0], w[1])).filter(|(x, y)| y > x).collect();
    let last = pieces.len().saturating_sub(1);
    for (n, &(ta, tb)) in pieces.iter().enumerate() {
        let [i, j] = plane.cell_of(at(0.5 * (ta + tb)));
        let origin = DVec2::new(i as f64, j as f64);
        let unit = |q: DVec2| (q - origin).clamp(DVec2::ZERO, DVec2::ONE);
        let (la, lb) = (unit(at(ta)), unit(at(tb)));
        let [v00, v10, v11, v01] = plane.cell_corners(i, j);
        let twist = v00 - v10 - v01 + v11;
        let (du, dv) = (v10 - v00, v01 - v00);
        let (au, av, bu, bv) = (la.x, la.y, lb.x - la.x, lb.y - la.y);
        let c0 = v00 - isovalue + du * au + dv * av + twist * au * av;
        let c1 = du * bu + dv * bv + twist * (au * bv + av * bu);
        let c2 = twist * bu * bv;
        let scale = c0.abs() + c1.abs() + c2.abs();
        let mut roots = Vec::new();
        for s in quadratic_roots([c0, c1, c2]) {
            // Polish once, then keep roots on [0, 1), or [0, 1] on the last piece (a root on
            // a cell side belongs to the piece after it).
            let slope = c1 + 2.0 * c2 * s;
            let s = if slope != 0.0 { s - (c0 + s * (c1 + s * c2)) / slope } else { s };
            let tol = 1e-12;
            if s < -tol || s > 1.0 + tol || (s >= 1.0 - tol && n != last) {
                continue;
            }
            let s = s.clamp(0.0, 1.0);
            let slope = c1 + 2.0 * c2 * s;
            let kind = if slope.abs() <= 1e-12 * scale {
                RootKind::Touching
            } else if inside.contains(slope, 0.0) {
                // Just after the root g has the sign of the slope: entering when that is inside.
                RootKind::Entering
            } else {
                RootKind::Leaving
            };
            let t = ta + (tb - ta) * s;
            let uv = plane.to_uv(at(t));
            roots.push(SegmentRoot { s, t, uv, point: plane.to_world(uv), kind });
        }
        out.cells.push(SegmentCell {
            cell: [i, j],
            corners: [v00, v10, v01, v11],
            t: (ta, tb),
            local_in: la,
            local_out: lb,
            quadratic: [c0, c1, c2],
            roots,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bracketed_roots_converge() {
        let inside = |g: f64| g < 0.0;
        let t = bracketed(|t| t * t * t - 0.2, -0.2, 0.8, inside);
        assert!((t - 0.2f64.cbrt()).abs() < 1e-12, "{t}");
        // A step: the predicate change is all there is.
        let t = bracketed(|t| if t < 0.3 { -1.0 } else { 1.0 }, -1.0, 1.0, inside);
        assert!((t - 0.3).abs() < 1e-12, "{t}");
        // NaN counts as outside.
        let t = bracketed(|t| if t < 0.6 { -1.0 } else { f64::NAN }, -1.0, f64::NAN, inside);
        assert!((t - 0.6).abs() < 1e-12, "{t}");
    }

    #[test]
    fn quadratic_roots_without_cancellation() {
        assert_eq!(quadratic_roots([-2.0, 1.0, 1.0]), vec![-2.0, 1.0]);
        let r = quadratic_roots([1e-8, -1.0, 1e-9]);
        assert!((r[0] - 1e-8).abs() < 1e-20, "{r:?}");
        assert_eq!(quadratic_roots([1.0, 0.0, 1.0]), Vec::<f64>::new());
        assert_eq!(quadratic_roots([3.0, -6.0, 0.0]), vec![0.5]);
    }
}
