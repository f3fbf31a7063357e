//! Fixed-step ray marching in f64, step for step as `shaders/raymarch.comp`:
//!
//! 1. clip the ray to the grid box: `[t0, t1]`, `t0 >= 0` (the eye may be inside);
//! 2. take `steps` samples at `t_i = t0 + (t1 - t0) i / (steps - 1)`;
//! 3. at the first change of the inside predicate (`Inside::contains`) between samples
//!    `i - 1` and `i`, refine: [`REFINE_BISECTIONS`] bisections keeping the change bracketed,
//!    then one secant step on the final bracket;
//! 4. normal: the analytic gradient of the trilinear interpolant at the hit, inside → outside
//!    (`-dir` where the gradient vanishes).
//!
//! Missing data (`field.nan = "empty"`, [`crate::field::interpolant::cell_missing`]): a sample
//! whose cell is missing has no inside state, and a step with such a sample at either end has
//! no crossing; a bisection midpoint in a missing cell moves the far end of the bracket (its
//! value kept), and a crossing whose refined point lies in a missing cell is no hit: the march
//! goes on from the step's far sample.
//!
//! A ray that enters the box reports `steps` samples visited up to and including the sample
//! after the crossing, or all of them on a miss; a ray that misses the box reports 0.

use glam::DVec3;

use super::field::{cell_of, clip_box, gradient_at, to_grid, value_at};
use super::shade::{nearest_surface, render_with, RayHit};
use super::trilinear::cell_corners;
use crate::field::interpolant::cell_missing;
use crate::field::Grid;
use crate::frame::Pixel;
use crate::scene::{Inside, Scene};
use crate::vocab::Clip;

/// Bisections of the bracket before the final secant step.
pub const REFINE_BISECTIONS: u32 = 8;

/// One marched ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct March {
    pub hit: Option<RayHit>,
    /// Samples taken (not counting refinement).
    pub steps: u32,
    /// Smallest |value - isovalue| over the samples whose inside test decided the outcome
    /// (every sample up to the hit, or all of them on a miss). A GPU in f32 can only disagree
    /// with this reference about hit or miss where the margin is tiny.
    pub margin: f64,
}

/// Unit normal from the gradient, inside → outside.
pub fn oriented_normal(grid: &Grid, u: DVec3, inside: Inside, dir: DVec3) -> DVec3 {
    let g = gradient_at(grid, u) * if inside == Inside::Below { 1.0 } else { -1.0 };
    let len = g.length();
    if len > 0.0 {
        g / len
    } else {
        -dir
    }
}

pub fn march(
    grid: &Grid,
    isovalue: f64,
    inside: Inside,
    origin: DVec3,
    dir: DVec3,
    steps: u32,
) -> March {
    march_clipped(grid, isovalue, inside, origin, dir, steps, &Clip::NONE)
}

/// [`march`] over the part of the ray inside the box that `clip` keeps (GPU: `clip_box`, then
/// `clip_interval`): the samples spread over that span.
pub fn march_clipped(
    grid: &Grid,
    isovalue: f64,
    inside: Inside,
    origin: DVec3,
    dir: DVec3,
    steps: u32,
    clip: &Clip,
) -> March {
    let none = March { hit: None, steps: 0, margin: f64::INFINITY };
    let Some((t0, t1)) = clip_box(grid, origin, dir) else {
        return none;
    };
    let Some((c0, c1)) = clip.interval(origin, dir) else {
        return none;
    };
    let (t0, t1) = (t0.max(c0), t1.min(c1));
    if t0 > t1 {
        return none;
    }
    // The value at t and whether its cell is missing.
    let sample = |t: f64| {
        let u = to_grid(grid, origin + dir * t);
        (value_at(grid, u), cell_missing(&cell_corners(grid, cell_of(grid, u))))
    };
    let (mut ta, (mut fa, mut gap)) = (t0, sample(t0));
    let mut ina = inside.contains(fa, isovalue);
    // f64::min ignores the NaN of a missing sample.
    let mut margin = (fa - isovalue).abs();
    let mut count = 1;
    for i in 1..steps {
        let tb = t0 + (t1 - t0) * (i as f64 / (steps - 1) as f64);
        let (fb, missing) = sample(tb);
        count += 1;
        margin = margin.min((fb - isovalue).abs());
        let inb = inside.contains(fb, isovalue);
        if inb != ina && !gap && !missing {
            let (mut a, mut va, mut b, mut vb) = (ta, fa, tb, fb);
            for _ in 0..REFINE_BISECTIONS {
                let tm = 0.5 * (a + b);
                let (fm, m) = sample(tm);
                if m {
                    b = tm;
                } else if inside.contains(fm, isovalue) == ina {
                    (a, va) = (tm, fm);
                } else {
                    (b, vb) = (tm, fm);
                }
            }
            let s = if vb != va { ((isovalue - va) / (vb - va)).clamp(0.0, 1.0) } else { 0.5 };
            let t = a + (b - a) * s;
            if sample(t).1 {
                // The crossing fell in a missing cell: no hit here; march on.
                (ta, fa, ina, gap) = (tb, fb, inb, missing);
                continue;
            }
            let position = origin + dir * t;
            let u = to_grid(grid, position);
            let hit = RayHit {
                t,
                position,
                normal: oriented_normal(grid, u, inside, dir),
                grid_coords: u,
                cell: cell_of(grid, u),
                surface: 0,
            };
            return March { hit: Some(hit), steps: count, margin };
        }
        (ta, fa, ina, gap) = (tb, fb, inb, missing);
    }
    March { hit: None, steps: count, margin }
}

/// The whole image, as the GPU's fixed-step pass produces it.
pub fn render(scene: &Scene, grid: &Grid) -> Vec<Pixel> {
    let (isos, inside, steps) =
        (scene.surface.isovalues(), scene.surface.inside, scene.render.steps);
    let clip = scene.clip.in_grid_frame(&scene.field.placement);
    render_with(scene, grid, |o, d| {
        nearest_surface(isos.iter().map(|&iso| {
            let m = march_clipped(grid, iso, inside, o, d, steps, &clip);
            (m.hit, m.steps, -1)
        }))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// f = z on the unit cube: the surface f = 0.25 is the plane z = 0.25.
    fn linear_grid() -> Grid {
        let mut values = Vec::new();
        for k in 0..5 {
            for _j in 0..5 {
                for _i in 0..5 {
                    values.push(k as f32 / 4.0);
                }
            }
        }
        Grid { dims: [5, 5, 5], min: DVec3::ZERO, max: DVec3::ONE, values }
    }

    #[test]
    fn linear_field_hits_the_plane_with_its_normal() {
        let grid = linear_grid();
        let o = DVec3::new(0.3, 0.4, 2.0);
        let d = DVec3::new(0.1, -0.05, -1.0).normalize();
        let m = march(&grid, 0.25, Inside::Below, o, d, 64);
        let hit = m.hit.expect("hit");
        let expected_t = (0.25 - 2.0) / d.z;
        assert!((hit.t - expected_t).abs() < 1e-12, "{} vs {expected_t}", hit.t);
        assert!((hit.normal - DVec3::Z).length() < 1e-12);
        let m = march(&grid, 0.25, Inside::Above, o, d, 64);
        assert!((m.hit.unwrap().normal + DVec3::Z).length() < 1e-12);
    }

    #[test]
    fn rays_missing_the_box_take_no_steps() {
        let m = march(&linear_grid(), 0.25, Inside::Below, DVec3::splat(3.0), DVec3::X, 64);
        assert_eq!((m.hit, m.steps), (None, 0));
    }

    #[test]
    fn eye_inside_the_box_marches_from_the_eye() {
        // From z = 0.9 looking down, the plane z = 0.25 is 0.65 away.
        let m =
            march(&linear_grid(), 0.25, Inside::Below, DVec3::new(0.5, 0.5, 0.9), -DVec3::Z, 100);
        assert!((m.hit.unwrap().t - 0.65).abs() < 1e-12);
    }
}
