//! Fixed-step ray marching in f64, step for step as `shaders/raymarch.comp`, for every
//! interpolant ([`Sampling`]):
//!
//! 1. clip the ray to the grid box: `[t0, t1]`, `t0 >= 0` (the eye may be inside);
//! 2. take `steps` samples at `t_i = t0 + (t1 - t0) i / (steps - 1)`;
//! 3. at the first change of the inside predicate (`Inside::contains`) between samples
//!    `i - 1` and `i`, refine: [`REFINE_BISECTIONS`] bisections keeping the change bracketed,
//!    then one secant step on the final bracket;
//! 4. normal, inside → outside: the analytic gradient of the interpolant at the hit (`-dir`
//!    where it vanishes); for `nearest`, whose gradient is zero, the face between the voxels
//!    of the refined bracket's ends: the lowest axis along which their points differ, pointing
//!    from the inside voxel to the outside one; for `device`, the central differences a shader
//!    takes of its own lookups ([`DeviceModel::gradient_at`]).
//!
//! `cell.*` is the cell holding the hit, except for `nearest`: the point of the inside voxel
//! (the end of the refined bracket that is inside).
//!
//! Missing data (`field.nan = "empty"`, [`crate::field::interpolant::Kernel::missing_at`]): a
//! missing sample (trilinear and cubic: its cell's stencil holds a missing value; nearest: its
//! voxel is missing; device: the filtered value is not finite) has no inside state, and a step
//! with such a sample at either end has no crossing; a bisection midpoint that is missing moves
//! the far end of the bracket (its value kept), and a crossing whose refined point is missing is
//! no hit: the march goes on from the step's far sample.
//!
//! A ray that enters the box reports `steps` samples visited up to and including the sample
//! after the crossing, or all of them on a miss; a ray that misses the box reports 0.

use glam::DVec3;

use super::field::{cell_of, clip_box, to_grid};
use super::shade::{nearest_surface, render_with_interp, RayHit};
use super::trilinear::cell_corners;
use crate::field::interpolant::nearest::voxel_of;
use crate::field::interpolant::{is_missing, Interpolant, Interpolated, Kernel, Trilinear};
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

/// A CPU model of the device's linear texture filter (`interpolation = "device"`), which is
/// not a reference: the device's filtering exists only on the GPU. The Vulkan spec lets the
/// texture unit compute the fractional weights with `subTexelPrecisionBits` bits; the model
/// rounds each cell-local coordinate to `round(f 2^bits) / 2^bits` and interpolates the 8
/// corners trilinearly with those weights (the sampler's CLAMP_TO_EDGE is the clamp of the
/// coordinates into the box). The terraces an SDF shows under such a filter are its steps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceModel {
    pub bits: u32,
}

impl DeviceModel {
    /// 8 fractional bits, common hardware's (Vulkan requires at least 4).
    pub const COMMON: DeviceModel = DeviceModel { bits: 8 };

    /// The normal's step: a shader differentiating its lookups samples at ±1/64 cell, which
    /// spans 8 quanta of 8-bit weights.
    pub const DELTA: f64 = 1.0 / 64.0;

    /// A weight `f` in `[0, 1]` as the filter holds it: `round(f 2^bits) / 2^bits` (scaling by
    /// a power of 2 is exact).
    pub fn quantise(self, f: f64) -> f64 {
        let scale = f64::from(self.bits).exp2();
        (f * scale).round() / scale
    }

    /// The filtered value at grid coordinates `u` (clamped into the box).
    pub fn value_at(self, grid: &Grid, u: DVec3) -> f64 {
        let [nx, ny, nz] = grid.dims.map(|n| (n - 1) as f64);
        let u = u.clamp(DVec3::ZERO, DVec3::new(nx, ny, nz));
        let c = cell_of(grid, u);
        let q = u - DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
        let q = DVec3::new(self.quantise(q.x), self.quantise(q.y), self.quantise(q.z));
        Trilinear::value(&cell_corners(grid, c), q)
    }

    /// The gradient a shader takes of its lookups at grid coordinates `u`, in world units:
    /// `(value(u + δ e_a) - value(u - δ e_a)) / 2δ` per axis, δ = [`DeviceModel::DELTA`].
    pub fn gradient_at(self, grid: &Grid, u: DVec3) -> DVec3 {
        let diff = |e: DVec3| {
            (self.value_at(grid, u + e * Self::DELTA) - self.value_at(grid, u - e * Self::DELTA))
                / (2.0 * Self::DELTA)
        };
        DVec3::new(diff(DVec3::X), diff(DVec3::Y), diff(DVec3::Z)) / grid.spacing()
    }
}

/// What fixed-step samples: the interpolant, with the model that stands for `device`'s
/// filter (used only when `interp` is [`Interpolant::Device`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sampling {
    pub interp: Interpolant,
    pub device: DeviceModel,
}

impl Sampling {
    /// `interp`, with [`DeviceModel::COMMON`] for `device`.
    pub fn new(interp: Interpolant) -> Self {
        Sampling { interp, device: DeviceModel::COMMON }
    }

    /// The value at grid coordinates `u` and whether it is missing.
    fn sample(self, grid: &Grid, u: DVec3) -> (f64, bool) {
        match self.interp {
            Interpolant::Trilinear
            | Interpolant::CubicBspline
            | Interpolant::CatmullRom
            | Interpolant::Nearest => {
                let f = Interpolated::new(grid, self.interp);
                (f.value_at(u), f.missing_at(u))
            }
            Interpolant::Device => {
                let v = self.device.value_at(grid, u);
                (v, is_missing(v))
            }
        }
    }
}

/// Unit normal from the world gradient `g`, inside → outside (`-dir` where it vanishes).
fn oriented(g: DVec3, inside: Inside, dir: DVec3) -> DVec3 {
    let g = g * if inside == Inside::Below { 1.0 } else { -1.0 };
    let len = g.length();
    if len > 0.0 {
        g / len
    } else {
        -dir
    }
}

/// `nearest`'s face at a refined bracket: the normal and the inside voxel's point, from the
/// voxels of the bracket's ends `ua` (inside when `a_inside`) and `ub`. The face's axis is the
/// lowest along which the two points differ; with none (unreachable: the ends' values differ)
/// the normal is `-dir`.
fn voxel_face(
    grid: &Grid,
    ua: DVec3,
    ub: DVec3,
    a_inside: bool,
    dir: DVec3,
) -> (DVec3, [usize; 3]) {
    let (va, vb) = (voxel_of(grid, ua), voxel_of(grid, ub));
    let (vin, vout) = if a_inside { (va, vb) } else { (vb, va) };
    let normal = (0..3).find(|&a| vin[a] != vout[a]).map_or(-dir, |a| {
        let mut n = DVec3::ZERO;
        n[a] = if vout[a] > vin[a] { 1.0 } else { -1.0 };
        n
    });
    (normal, vin)
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
    let sampling = Sampling::new(Interpolant::Trilinear);
    march_sampled(grid, sampling, isovalue, inside, origin, dir, steps, clip)
}

/// [`march_clipped`] through `sampling`'s interpolant.
#[allow(clippy::too_many_arguments)]
pub fn march_sampled(
    grid: &Grid,
    sampling: Sampling,
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
    // The value at t and whether it is missing.
    let sample = |t: f64| sampling.sample(grid, to_grid(grid, origin + dir * t));
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
                // The crossing fell on a missing sample: no hit here; march on.
                (ta, fa, ina, gap) = (tb, fb, inb, missing);
                continue;
            }
            let position = origin + dir * t;
            let u = to_grid(grid, position);
            let gradient = |g: DVec3| (oriented(g, inside, dir), cell_of(grid, u));
            let (normal, cell) = match sampling.interp {
                Interpolant::Trilinear | Interpolant::CubicBspline | Interpolant::CatmullRom => {
                    gradient(Interpolated::new(grid, sampling.interp).gradient_at(u))
                }
                Interpolant::Device => gradient(sampling.device.gradient_at(grid, u)),
                Interpolant::Nearest => {
                    let at = |t: f64| to_grid(grid, origin + dir * t);
                    voxel_face(grid, at(a), at(b), ina, dir)
                }
            };
            let hit = RayHit { t, position, normal, grid_coords: u, cell, surface: 0 };
            return March { hit: Some(hit), steps: count, margin };
        }
        (ta, fa, ina, gap) = (tb, fb, inb, missing);
    }
    March { hit: None, steps: count, margin }
}

/// The whole image, as the GPU's fixed-step pass produces it.
pub fn render(scene: &Scene, grid: &Grid) -> Vec<Pixel> {
    render_sampled(scene, grid, Sampling::new(Interpolant::Trilinear))
}

/// [`render`] through `sampling`'s interpolant.
pub fn render_sampled(scene: &Scene, grid: &Grid, sampling: Sampling) -> Vec<Pixel> {
    let (isos, inside, steps) =
        (scene.surface.isovalues(), scene.surface.inside, scene.render.steps);
    let clip = scene.clip.in_grid_frame(&scene.field.placement);
    render_with_interp(scene, grid, sampling.interp, |o, d| {
        nearest_surface(isos.iter().map(|&iso| {
            let m = march_sampled(grid, sampling, iso, inside, o, d, steps, &clip);
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

    /// A grid of random values with a few missing ones, and rays through it from outside and
    /// inside the box.
    fn random_grid(dims: [usize; 3], seed: u64, holes: usize) -> Grid {
        let mut s = seed;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut values: Vec<f32> =
            (0..dims.iter().product()).map(|_| (next() - 0.5) as f32).collect();
        for _ in 0..holes {
            let i = (next() * values.len() as f64) as usize;
            values[i] = f32::NAN;
        }
        Grid { dims, min: DVec3::new(-1.0, 0.5, 2.0), max: DVec3::new(1.0, 2.0, 3.0), values }
    }

    fn random_rays(grid: &Grid, count: usize, seed: u64) -> Vec<(DVec3, DVec3)> {
        let mut s = seed;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let (lo, hi) = (grid.min, grid.max);
        (0..count)
            .map(|n| {
                let inner = lo + (hi - lo) * DVec3::new(next(), next(), next());
                let o = if n % 3 == 0 {
                    inner
                } else {
                    let c = 0.5 * (lo + hi);
                    c + (DVec3::new(next(), next(), next()) - 0.5).normalize() * 4.0
                };
                let target = lo + (hi - lo) * DVec3::new(next(), next(), next());
                let d = (target - o).normalize();
                (o, if d.is_finite() { d } else { DVec3::Z })
            })
            .collect()
    }

    /// FNV-1a over the bits of what `march` returns for the same rays.
    fn fingerprint(grid: &Grid, rays: &[(DVec3, DVec3)]) -> u64 {
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        let mut eat = |x: u64| {
            for b in x.to_le_bytes() {
                h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
            }
        };
        for &(o, d) in rays {
            for (iso, inside) in [(0.0, Inside::Below), (0.1, Inside::Above)] {
                let m = march(grid, iso, inside, o, d, 37);
                eat(u64::from(m.steps));
                eat(m.margin.to_bits());
                if let Some(hit) = m.hit {
                    for x in [hit.t, hit.normal.x, hit.normal.y, hit.normal.z, hit.grid_coords.x] {
                        eat(x.to_bits());
                    }
                    eat(hit.cell.iter().fold(0, |a, &c| a * 1000 + c as u64));
                }
            }
        }
        h
    }

    /// Trilinear fixed-step keeps its bits: the fingerprint was taken from the march before it
    /// went through `Interpolated` (any change to a sample, bisection, secant or normal moves
    /// it).
    #[test]
    fn trilinear_march_keeps_its_bits() {
        let grid = random_grid([7, 5, 6], 3, 6);
        let rays = random_rays(&grid, 400, 11);
        assert!(
            rays.iter()
                .filter(|&&(o, d)| march(&grid, 0.0, Inside::Below, o, d, 37).hit.is_some())
                .count()
                > 100
        );
        assert_eq!(fingerprint(&grid, &rays), 0x5a35_102c_9d7e_72e7);
    }

    /// Fixed-step through the cubic kernels on a linear field hits where trilinear does: both
    /// reproduce it away from the border (cells 1..n-3, where the 4-point stencil needs no
    /// clamp), the plane crosses only there, and the clamped border cells stay on one side.
    #[test]
    fn cubic_kernels_march_a_linear_field_to_trilinears_hits() {
        let dims = [12, 11, 13];
        let mut values = Vec::new();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    values.push((i as f64 + 0.25 * j as f64 - 0.5 * k as f64) as f32);
                }
            }
        }
        let grid =
            Grid { dims, min: DVec3::new(-1.0, 0.0, 1.0), max: DVec3::new(2.3, 1.0, 2.2), values };
        let iso = 5.3;
        let rays = random_rays(&grid, 300, 21);
        let steps = 61;
        let mut hits = 0;
        for (o, d) in rays {
            let clip = Clip::NONE;
            let tri = march_sampled(
                &grid,
                Sampling::new(Interpolant::Trilinear),
                iso,
                Inside::Below,
                o,
                d,
                steps,
                &clip,
            );
            let Some((t0, t1)) = clip_box(&grid, o, d) else { continue };
            // The bracket's width after the bisections.
            let tol = (t1 - t0) / f64::from(steps - 1) / f64::from(1u32 << REFINE_BISECTIONS);
            for interp in [Interpolant::CubicBspline, Interpolant::CatmullRom] {
                let m = march_sampled(
                    &grid,
                    Sampling::new(interp),
                    iso,
                    Inside::Below,
                    o,
                    d,
                    steps,
                    &clip,
                );
                // Only hits two cells from the border are the linear field's on both sides
                // (in the border cells the clamp bends the cubic ones in y and z).
                let interior = |h: &RayHit| {
                    (0..3).all(|a| {
                        h.grid_coords[a] >= 2.0 && h.grid_coords[a] <= (dims[a] - 3) as f64
                    })
                };
                match (m.hit, tri.hit) {
                    (None, None) => {}
                    (Some(a), Some(b)) if interior(&a) || interior(&b) => {
                        hits += 1;
                        assert_eq!(m.steps, tri.steps, "{}", interp.name());
                        assert!((a.t - b.t).abs() <= tol, "{}: {} vs {}", interp.name(), a.t, b.t);
                        assert!(
                            (a.normal - b.normal).length() < 1e-9,
                            "{}: {} vs {} at {}",
                            interp.name(),
                            a.normal,
                            b.normal,
                            a.grid_coords
                        );
                    }
                    (Some(h), None) | (None, Some(h)) if interior(&h) => {
                        panic!("{}: a hit at {} on one side only", interp.name(), h.grid_coords)
                    }
                    _ => {}
                }
            }
        }
        assert!(hits > 150, "{hits}");
    }

    /// Fixed-step through nearest on one inside voxel: hits within a refined bracket of the
    /// voxel's faces, with the face's normal and the voxel's point as `cell`.
    #[test]
    fn nearest_marches_to_the_voxel_faces() {
        let dims = [5, 5, 5];
        let values = (0..125).map(|n| if n == 62 { -1.0 } else { 1.0 }).collect();
        let grid = Grid { dims, min: DVec3::ZERO, max: DVec3::splat(4.0), values };
        let (lo, hi) = (DVec3::splat(1.5), DVec3::splat(2.5));
        let sampling = Sampling::new(Interpolant::Nearest);
        let mut hits = 0;
        for (n, (o, _)) in random_rays(&grid, 200, 31).into_iter().enumerate() {
            if n % 3 == 0 {
                continue; // the eye inside the box may sit in the voxel
            }
            let target = lo
                + (hi - lo)
                    * DVec3::new(
                        0.1 + 0.8 * ((n * 7) % 11) as f64 / 10.0,
                        0.1 + 0.8 * ((n * 3) % 7) as f64 / 6.0,
                        0.5,
                    );
            let d = (target - o).normalize();
            let m = march_sampled(&grid, sampling, 0.0, Inside::Below, o, d, 200, &Clip::NONE);
            let (t0, t1) = clip_box(&grid, o, d).unwrap();
            let tol = (t1 - t0) / 199.0 / f64::from(1u32 << REFINE_BISECTIONS);
            let (mut near, mut axis) = (f64::NEG_INFINITY, 0);
            for a in 0..3 {
                let (ta, tb) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
                if ta.min(tb) > near {
                    (near, axis) = (ta.min(tb), a);
                }
            }
            let Some(hit) = m.hit else {
                // A ray that crosses the voxel within a step (a corner) may step over it.
                continue;
            };
            hits += 1;
            assert!((hit.t - near).abs() <= tol, "t {} vs {near}", hit.t);
            let mut normal = DVec3::ZERO;
            normal[axis] = -d[axis].signum();
            assert_eq!((hit.normal, hit.cell), (normal, [2, 2, 2]));
        }
        assert!(hits > 100, "{hits}");
    }

    /// The device model: weights in steps of 2^-bits, so a ramp between two points takes
    /// 2^bits + 1 values, each within half a step of the exact one; on a linear field its
    /// differences are the exact gradient (±1/64 cell is a whole number of steps).
    #[test]
    fn the_device_model_quantises_the_weights() {
        let grid = Grid {
            dims: [2, 2, 2],
            min: DVec3::ZERO,
            max: DVec3::ONE,
            values: vec![0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0],
        };
        for bits in [4, 8] {
            let model = DeviceModel { bits };
            let mut seen: Vec<f64> = Vec::new();
            for i in 0..=4096 {
                let u = DVec3::new(i as f64 / 4096.0, 0.3, 0.7);
                let v = model.value_at(&grid, u);
                assert!(
                    (v - u.x).abs() <= 0.5 / f64::from(1u32 << bits) + 1e-15,
                    "{bits} bits at {u}"
                );
                if !seen.contains(&v) {
                    seen.push(v);
                }
            }
            assert_eq!(seen.len(), (1 << bits) + 1);
        }
        let model = DeviceModel::COMMON;
        let g = model.gradient_at(&grid, DVec3::new(0.37, 0.5, 0.5));
        assert_eq!(g, DVec3::X);
        // Fixed-step through the model finds the plane x = 0.3 within a weight step.
        let sampling = Sampling { interp: Interpolant::Device, device: model };
        let m = march_sampled(
            &grid,
            sampling,
            0.3,
            Inside::Below,
            DVec3::new(-1.0, 0.4, 0.6),
            DVec3::X,
            64,
            &Clip::NONE,
        );
        let hit = m.hit.expect("the plane");
        assert!((hit.t - 1.3).abs() <= 1.0 / 256.0, "{}", hit.t);
        assert_eq!(hit.normal, DVec3::X);
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
