//! Hermite data: for a crossed lattice edge, the crossing point and the unit surface normal
//! there (`render.hermite`), in grid index space, what the QEF of the sharp-feature meshes is
//! built from.
//!
//! * **trilinear**: the crossing of every other method (`Field::crossing`, linear along the
//!   edge) and the normalised gradient of the trilinear interpolant there (the mean over the
//!   cells sharing the edge, `Field::gradient`). Any source.
//! * **source**: the source evaluated off the grid ([`PointField`]). The crossing is the root
//!   of `source - iso` on the edge, bracketed by the edge's end points and found by the
//!   Illinois variant of regula falsi to 1e-12 of the edge length (at most 62 evaluations); if
//!   the source does not change sign where the samples do (f32 rounding of a sample that is
//!   within rounding of the isovalue) the linear crossing is kept. The normal is the source's
//!   central-difference gradient with step 1e-5 cells. The lattice edges crossed, and hence
//!   the mesh's connectivity, are those of the samples either way.
//!
//! Index-space normals: a world-space plane `n_w · (x_w - p_w) = 0` with `x_w = min + u ⊙ s`
//! (`s` the spacing) is `(n_w ⊙ s) · (u - u_p) = 0`, so the index-space normal is `n_w ⊙ s`,
//! renormalised; the trilinear gradient in index space is that already.

use glam::DVec3;

use super::field::Field;
use crate::field::interpolant::is_missing;
use crate::field::PointField;

/// Where Hermite data comes from.
pub(crate) struct Hermite<'f, 'g, 's> {
    pub f: &'f Field<'g>,
    /// The source, for `hermite = "source"`; None: trilinear.
    pub source: Option<&'s PointField<'s>>,
}

impl Hermite<'_, '_, '_> {
    /// The crossing (index space) and unit index-space normal (zero where the gradient
    /// vanishes) of the edge from grid point `a` along `axis`, None if it is not crossed.
    pub fn edge(&self, a: [usize; 3], axis: usize) -> Option<(DVec3, DVec3)> {
        let f = self.f;
        let mut b = a;
        b[axis] += 1;
        let (va, vb) = (f.value(a[0], a[1], a[2]), f.value(b[0], b[1], b[2]));
        // An edge with a missing end is never crossed (`interpolant::cell_missing`).
        if f.inside.contains(va, f.iso) == f.inside.contains(vb, f.iso)
            || is_missing(va)
            || is_missing(vb)
        {
            return None;
        }
        let ua = DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
        let mut dir = DVec3::ZERO;
        dir[axis] = 1.0;
        let linear = ua + dir * f.crossing(va, vb);
        let (u, n) = match self.source {
            None => (linear, f.gradient(linear)),
            Some(src) => {
                let at = |s: f64| (src.eval)(f.world_f64(ua + dir * s)) - f.iso;
                let u = root(&at).map_or(linear, |s| ua + dir * s);
                (u, self.source_gradient(src, u))
            }
        };
        let n = if n.is_finite() && n.length_squared() > 0.0 { n.normalize() } else { DVec3::ZERO };
        Some((u, n))
    }

    /// The source's gradient at index-space `u`, as an index-space plane normal (`n_w ⊙ s`).
    fn source_gradient(&self, src: &PointField, u: DVec3) -> DVec3 {
        const H: f64 = 1e-5;
        let f = self.f;
        let mut g = DVec3::ZERO;
        for a in 0..3 {
            let mut d = DVec3::ZERO;
            d[a] = H;
            // World-space difference quotient, times the spacing: (f(u+h) - f(u-h)) / 2h in
            // index units is exactly that.
            g[a] = ((src.eval)(f.world_f64(u + d)) - (src.eval)(f.world_f64(u - d))) / (2.0 * H);
        }
        g
    }
}

/// The root in `[0, 1]` of `g`, which must change sign between 0 and 1 (else None): Illinois
/// regula falsi until the bracket or the step is below 1e-12 (at most 60 evaluations).
fn root(g: &impl Fn(f64) -> f64) -> Option<f64> {
    let (mut a, mut b) = (0.0f64, 1.0f64);
    let (mut ga, mut gb) = (g(a), g(b));
    if !(ga.is_finite() && gb.is_finite()) || ga.signum() == gb.signum() || ga == 0.0 || gb == 0.0 {
        return None;
    }
    let mut side = 0i8;
    let mut last = f64::NAN;
    for _ in 0..60 {
        let x = (a * gb - b * ga) / (gb - ga);
        // Converged: the bracket, or the step, below 1e-12 of the edge.
        if (b - a) < 1e-12 || (x - last).abs() < 1e-12 {
            return Some(x);
        }
        last = x;
        let gx = g(x);
        if gx == 0.0 {
            return Some(x);
        }
        if gx.signum() == gb.signum() {
            b = x;
            gb = gx;
            if side == 1 {
                ga *= 0.5;
            }
            side = 1;
        } else {
            a = x;
            ga = gx;
            if side == -1 {
                gb *= 0.5;
            }
            side = -1;
        }
    }
    Some((a * gb - b * ga) / (gb - ga))
}

#[cfg(test)]
mod tests {
    use super::root;

    #[test]
    fn illinois_finds_roots_of_kinked_functions() {
        // A kink (an SDF across a box edge) and a smooth curve.
        let kink = |s: f64| (s - 0.3).max(2.0 * (s - 0.3));
        assert!((root(&kink).unwrap() - 0.3).abs() < 1e-12);
        let curve = |s: f64| s * s * s - 0.2;
        assert!((root(&curve).unwrap() - 0.2f64.cbrt()).abs() < 1e-12);
        assert_eq!(root(&|s: f64| s + 1.0), None);
    }
}
