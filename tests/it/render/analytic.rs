//! The analytic GPU pass (`shaders/analytic.comp`, f32) against its f64 reference
//! (`reference::analytic`), renders with answers known in closed form (the plane from a linear
//! field and the render under validation, common to every method, are in `methods.rs`),
//! empty-space skipping (bit-identical images) and the k-th crossing.
//!
//! # Metric
//!
//! Every pixel's ray is traced by the reference in full (`trace_detailed`). The ray is
//! **grazing** when f32 rounding may legitimately change its outcome, judged on the reference's
//! own walk, with `R` the grid's value range and `L` the box diagonal:
//!
//! - a counted crossing where the field's slope along the ray is small,
//!   `|dg/dt| < SLOPE_TOL * R / L`: the root is ill-conditioned (a ray tangent to the surface,
//!   a saddle), and f32 cannot place it within the depth tolerance;
//! - a local extremum of `g = f - iso` along the ray with `|g| < VALUE_TOL * R`, at a root of
//!   a cell cubic's derivative or at a cell face where the slope changes sign (the field is only
//!   C0 across faces): a near-tangent pair of crossings, which rounding can make or unmake;
//! - `|g| < VALUE_TOL * R` where the ray's span starts or ends (the eye, the box faces): the
//!   surface meets the end of the span, and rounding decides whether a crossing is inside it.
//!
//! On the other rays the GPU must agree with the reference: hit or miss on at least 99.99% of
//! them (`HIT_AGREEMENT`), and on all of them the number of crossings, the depth within
//! `DEPTH_TOL * L` and the normal within `NORMAL_TOL_DEG` where both hit. Colours, positions
//! and cells are checked too (a cell may differ only for a hit on a cell face).

use glam::DVec3;
use isoview::field::Grid;
use isoview::frame::{Frame, Pixel};
use isoview::passes::bricks;
use isoview::reference::analytic::{self, cubic::Cubic, CellVisit};
use isoview::reference::field::{to_grid, value_at};
use isoview::render::{Accel, GpuGrid, Renderer};
use isoview::scene::{Inside, Method, Scene, Shading};

use crate::common::*;

/// Depth error allowed on non-grazing hits, relative to the box diagonal.
const DEPTH_TOL: f64 = 1e-5;
/// Normal error allowed on non-grazing hits, degrees.
const NORMAL_TOL_DEG: f64 = 0.1;
/// Grazing: slope along the ray below this times `R / L`.
const SLOPE_TOL: f64 = 0.02;
/// Grazing: an extremum or span end within this times `R` of the isovalue.
const VALUE_TOL: f64 = 1e-5;
/// Fraction of non-grazing rays on which hit or miss must agree.
const HIT_AGREEMENT: f64 = 0.9999;

/// What one comparison found, summed over renders.
#[derive(Debug, Default)]
struct Stats {
    rays: usize,
    grazing: usize,
    /// Grazing rays on which hit or miss and the crossings agree anyway.
    grazing_agree: usize,
    /// Non-grazing rays that hit in one and miss in the other.
    hit_mismatch: usize,
    /// Non-grazing rays where both hit.
    hits: usize,
    crossings_mismatch: usize,
    depth_fail: usize,
    normal_fail: usize,
    /// Non-grazing rays whose `steps` differ from the reference's cells visited (only counted
    /// when the render had skipping off).
    steps_mismatch: usize,
    /// Largest depth error on non-grazing hits, relative to the diagonal.
    max_depth: f64,
    max_normal_deg: f64,
    /// Rays on which the reference evaluated a value exactly equal to the isovalue.
    exact_zero_rays: usize,
    /// The first few disagreements, for the failure message.
    notes: Vec<String>,
}

impl Stats {
    fn add(&mut self, o: Stats) {
        self.rays += o.rays;
        self.grazing += o.grazing;
        self.grazing_agree += o.grazing_agree;
        self.hit_mismatch += o.hit_mismatch;
        self.hits += o.hits;
        self.crossings_mismatch += o.crossings_mismatch;
        self.depth_fail += o.depth_fail;
        self.normal_fail += o.normal_fail;
        self.steps_mismatch += o.steps_mismatch;
        self.max_depth = self.max_depth.max(o.max_depth);
        self.max_normal_deg = self.max_normal_deg.max(o.max_normal_deg);
        self.exact_zero_rays += o.exact_zero_rays;
        for n in o.notes {
            if self.notes.len() < 12 {
                self.notes.push(n);
            }
        }
    }

    fn note(&mut self, s: String) {
        if self.notes.len() < 12 {
            self.notes.push(s);
        }
    }

    fn non_grazing(&self) -> usize {
        self.rays - self.grazing
    }

    fn report(&self, label: &str) {
        let ng = self.non_grazing();
        eprintln!(
            "{label}: {} rays, {} grazing ({:.3}%, {} of them agree anyway); non-grazing: hit/miss agree {:.4}% ({} differ), \
             {} hits compared, max depth error {:.2e} x diagonal, max normal error {:.2e} deg, \
             crossings differ on {}, steps differ on {}; {} rays met a value equal to the isovalue",
            self.rays,
            self.grazing,
            100.0 * self.grazing as f64 / self.rays.max(1) as f64,
            self.grazing_agree,
            100.0 * (ng - self.hit_mismatch) as f64 / ng.max(1) as f64,
            self.hit_mismatch,
            self.hits,
            self.max_depth,
            self.max_normal_deg,
            self.crossings_mismatch,
            self.steps_mismatch,
            self.exact_zero_rays,
        );
    }

    /// The accuracy contract on non-grazing rays.
    fn check(&self, label: &str) {
        self.report(label);
        let ng = self.non_grazing();
        let notes = self.notes.join("\n  ");
        assert!(
            (ng - self.hit_mismatch) as f64 >= HIT_AGREEMENT * ng as f64,
            "{label}: hit/miss differ on {} of {ng} non-grazing rays:\n  {notes}",
            self.hit_mismatch
        );
        assert_eq!(self.crossings_mismatch, 0, "{label}: crossings differ:\n  {notes}");
        assert_eq!(self.depth_fail, 0, "{label}: depth errors:\n  {notes}");
        assert_eq!(self.normal_fail, 0, "{label}: normal errors:\n  {notes}");
    }
}

/// Why the reference's ray is grazing (see the module doc), or None.
fn grazing(visits: &[CellVisit], range: f64, diag: f64) -> Option<String> {
    let value_tol = VALUE_TOL * range;
    let slope_tol = SLOPE_TOL * range / diag;
    let (first, last) = (visits.first()?, visits.last()?);
    if first.splits[0].g.abs() < value_tol {
        return Some(format!("span starts at g = {:.2e}", first.splits[0].g));
    }
    if last.splits.last()?.g.abs() < value_tol {
        return Some(format!("span ends at g = {:.2e}", last.splits.last()?.g));
    }
    for (i, v) in visits.iter().enumerate() {
        let cubic = Cubic { c: v.coefficients.monomial().expect("trilinear") };
        let dt = v.t_out - v.t_in;
        for s in &v.splits[1..v.splits.len() - 1] {
            if s.g.abs() < value_tol {
                return Some(format!("extremum g = {:.2e} in cell {:?}", s.g, v.cell));
            }
        }
        for r in v.roots.iter().filter(|r| r.crossing > 0) {
            let slope = cubic.eval_with_derivative(r.u).1 / dt;
            if slope.is_nan() || slope.abs() < slope_tol {
                return Some(format!("slope {slope:.2e} at crossing {}", r.crossing));
            }
        }
        if let Some(next) = visits.get(i + 1) {
            let g = v.splits.last()?.g;
            let left = cubic.eval_with_derivative(1.0).1;
            let right = next.coefficients.coefficients()[1];
            if g.abs() < value_tol && left * right <= 0.0 {
                return Some(format!("kink extremum g = {g:.2e} leaving cell {:?}", v.cell));
            }
        }
    }
    None
}

/// Whether the reference met a value exactly equal to the isovalue.
fn met_exact_zero(visits: &[CellVisit]) -> bool {
    visits.iter().any(|v| v.splits.iter().any(|s| s.g == 0.0))
}

fn v3(a: [f32; 3]) -> DVec3 {
    DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64)
}

/// Compares a GPU frame with the reference, pixel by pixel (see the module doc).
fn compare(scene: &Scene, grid: &Grid, gpu: &[Pixel], skip: bool) -> Stats {
    let cam = isoview::camera::Camera::new(&scene.camera, &scene.image);
    let (lo, hi) = grid.range();
    let range = (hi - lo).max(f32::MIN_POSITIVE) as f64;
    let diag = (grid.max - grid.min).length();
    let (iso, inside) = (scene.surface.isovalue, scene.surface.inside);
    let opts = analytic::options(scene);
    let reference = analytic::render(scene, grid);
    let mut st = Stats::default();
    for py in 0..scene.image.height {
        for px in 0..scene.image.width {
            let i = (py * scene.image.width + px) as usize;
            let (g, r) = (&gpu[i], &reference[i]);
            let dir = cam.ray(px, py).1;
            let (res, visits) = analytic::trace_detailed(grid, iso, inside, cam.eye, dir, &opts);
            st.rays += 1;
            st.exact_zero_rays += met_exact_zero(&visits) as usize;
            let at = format!("pixel ({px},{py})");

            // Every GPU hit lies on the surface, grazing or not.
            if g.is_hit() {
                let p = v3(g.position);
                assert!(p.is_finite() && g.depth > 0.0, "{at}: GPU hit {g:?}");
                let f = value_at(grid, to_grid(grid, p));
                assert!((f - iso).abs() < 1e-3 * range, "{at}: GPU hit off the surface: {f}");
            }
            if grazing(&visits, range, diag).is_some() {
                st.grazing += 1;
                st.grazing_agree +=
                    (g.is_hit() == r.is_hit() && g.crossings == r.crossings) as usize;
                continue;
            }
            if g.is_hit() != r.is_hit() {
                st.hit_mismatch += 1;
                st.note(format!("{at}: hit/miss: GPU {g:?} vs reference {r:?}"));
                continue;
            }
            if g.crossings != r.crossings {
                st.crossings_mismatch += 1;
                st.note(format!("{at}: crossings {} vs {}", g.crossings, r.crossings));
            }
            if !skip && g.steps != r.steps {
                st.steps_mismatch += 1;
            }
            if !r.is_hit() {
                assert_eq!(g.rgba, r.rgba, "{at}: background");
                assert_eq!((g.normal, g.position, g.cell), (r.normal, r.position, r.cell), "{at}");
                continue;
            }
            st.hits += 1;
            let dz = (g.depth as f64 - r.depth as f64).abs() / diag;
            st.max_depth = st.max_depth.max(dz);
            if dz > DEPTH_TOL {
                st.depth_fail += 1;
                st.note(format!("{at}: depth {} vs {} ({dz:.2e} x diagonal)", g.depth, r.depth));
                continue;
            }
            assert!((v3(g.position) - v3(r.position)).length() <= 2.0 * DEPTH_TOL * diag, "{at}");
            if g.cell != r.cell {
                // Only for a hit on a cell face, where the gradient (so the normal and the
                // colour) jumps from one cell to the next: the field is only C0 there.
                let h = res.hit.unwrap();
                let on_face = (0..3).any(|a| h.local[a] < 1e-4 || h.local[a] > 1.0 - 1e-4);
                assert!(on_face, "{at}: cell {:?} vs {:?}", g.cell, r.cell);
                continue;
            }
            let cos = v3(g.normal).normalize().dot(v3(r.normal)).clamp(-1.0, 1.0);
            let angle = cos.acos().to_degrees();
            st.max_normal_deg = st.max_normal_deg.max(angle);
            if angle > NORMAL_TOL_DEG {
                st.normal_fail += 1;
                st.note(format!("{at}: normal {:?} vs {:?} ({angle:.3} deg)", g.normal, r.normal));
            }
            for c in 0..4 {
                assert!((g.rgba[c] - r.rgba[c]).abs() < 2e-3, "{at}: colour {g:?} vs {r:?}");
            }
        }
    }
    st
}

fn render(renderer: &mut Renderer, scene: &Scene, grid: &Grid) -> Frame {
    renderer.render(scene, grid, 0.0).unwrap()
}

/// An analytic scene around `grid`, skipping off (so `steps` can be compared).
fn analytic_scene(grid: &Grid, eye: DVec3, size: u32) -> Scene {
    let mut s = scene_for(grid, eye, size, Method::Analytic);
    s.render.skip = false;
    s
}

#[gpu_test]
fn analytic_matches_reference_on_random_grids_and_cameras() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(31);
    let mut total = Stats::default();
    for case in 0..20 {
        let grid = if case < 16 {
            let dims = [
                2 + (rng.next_u64() % 11) as usize,
                2 + (rng.next_u64() % 11) as usize,
                2 + (rng.next_u64() % 11) as usize,
            ];
            random_grid(&mut rng, dims)
        } else {
            smooth_grid(&mut rng, 14 + case)
        };
        let eye = random_eye(&mut rng, &grid, case % 4 == 3);
        let mut scene = analytic_scene(&grid, eye, 48);
        scene.surface.isovalue = rng.range(-0.3, 0.3);
        scene.surface.inside = if case % 2 == 0 { Inside::Below } else { Inside::Above };
        scene.render.shading = [Shading::Lambert, Shading::Normal][case % 2];
        let frame = render(&mut renderer, &scene, &grid);
        total.add(compare(&scene, &grid, &frame.pixels, false));
    }
    total.check("random grids");
    assert!(total.hits > total.rays / 5, "too few hits to mean anything: {total:?}");
    assert!(total.steps_mismatch * 1000 <= total.rays, "steps differ on {total:?}");
    assert!(total.grazing * 100 <= total.rays, "too many grazing rays: {total:?}");
}

/// One cell over the unit cube.
fn single_cell(values: [f64; 8]) -> Grid {
    Grid {
        dims: [2, 2, 2],
        min: DVec3::ZERO,
        max: DVec3::ONE,
        values: values.iter().map(|&v| v as f32).collect(),
    }
}

#[gpu_test]
fn every_single_cell_sign_configuration() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(32);
    let mut total = Stats::default();
    for pattern in 0..256u32 {
        for draw in 0..2 {
            let values: [f64; 8] = std::array::from_fn(|c| {
                let sign = if pattern >> c & 1 == 1 { -1.0 } else { 1.0 };
                sign * rng.range(0.05, 1.0)
            });
            let grid = single_cell(values);
            let eye = random_eye(&mut rng, &grid, draw == 1 && pattern % 4 == 0);
            let mut scene = analytic_scene(&grid, eye, 24);
            scene.surface.inside =
                if (pattern + draw) % 2 == 0 { Inside::Below } else { Inside::Above };
            let frame = render(&mut renderer, &scene, &grid);
            total.add(compare(&scene, &grid, &frame.pixels, false));
        }
    }
    total.check("256 sign configurations");
    assert!(total.hits > total.rays / 10, "{total:?}");
}

#[gpu_test]
fn ambiguous_faces_and_tunnels() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(33);
    // (values, what the trilinear surface is), marching-cubes cases 3, 4, 6, 7, 10, 12, 13.
    let cases: [([f64; 8], &str); 8] = [
        ([-0.8, 1.0, 0.6, -0.6, 0.7, 1.1, 0.9, 1.3], "face ambiguous, two sheets (case 3)"),
        ([-0.8, 0.3, 0.2, -0.6, 0.7, 1.1, 0.9, 1.3], "face ambiguous, joined (case 3)"),
        ([-1.0, 0.3, 0.25, 0.35, 0.3, 0.25, 0.2, -0.9], "interior tunnel (case 4)"),
        ([-1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, -0.9], "diagonal corners apart (case 4)"),
        ([-1.0, -0.8, 0.6, 0.5, 0.4, 0.7, 0.9, -0.7], "case 6"),
        ([-0.5, 0.9, 0.8, -0.6, 0.7, -0.4, 1.0, 0.9], "case 7"),
        ([-0.5, 0.6, 0.7, -0.4, 0.6, -0.3, -0.4, 0.8], "case 13"),
        ([-0.6, 0.5, 0.4, -0.7, -0.3, 0.8, 0.6, -0.5], "case 10"),
    ];
    let mut total = Stats::default();
    for (values, what) in cases {
        let grid = single_cell(values);
        for view in 0..4 {
            let eye = random_eye(&mut rng, &grid, view == 3);
            for inside in Inside::ALL {
                let mut scene = analytic_scene(&grid, eye, 64);
                scene.surface.inside = inside;
                let frame = render(&mut renderer, &scene, &grid);
                let st = compare(&scene, &grid, &frame.pixels, false);
                assert!(st.hits > 0 || view == 3, "{what}: nothing hit");
                total.add(st);
            }
        }
    }
    total.check("ambiguous cells");
}

/// A grid with unit spacing from the origin (so index space is world space) whose values are
/// often exactly 0: rays along grid lines meet values equal to the isovalue exactly.
fn dyadic_grid_with_zeros(rng: &mut Rng, n: usize) -> Grid {
    let values = (0..n * n * n)
        .map(|_| match rng.next_u64() % 6 {
            0 | 1 => 0.0,
            2 => 1.0,
            3 => -1.0,
            _ => rng.range(-1.0, 1.0) as f32,
        })
        .collect();
    let max = DVec3::splat((n - 1) as f64);
    Grid { dims: [n; 3], min: DVec3::ZERO, max, values }
}

#[gpu_test]
fn rays_along_grid_planes_lines_and_diagonals() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(34);
    // Eye, target, up: integer eye positions and exact directions, so that with an odd image
    // the middle row and column lie in grid planes and the centre ray runs along a grid line
    // (axis views) or through edges and corners (diagonal views). The last flag: the centre
    // ray is exact in f32 as in f64, so GPU and reference must agree on it without excuses.
    // (A diagonal ray entering the box through an edge or corner is not: the reference snaps
    // only the entry axis onto the box face, the other coordinates are rounded.)
    let views = [
        (DVec3::new(4.0, 4.0, 14.0), DVec3::new(4.0, 4.0, 0.0), DVec3::Y, true),
        (DVec3::new(-6.0, 3.0, 5.0), DVec3::new(4.0, 3.0, 5.0), DVec3::Y, true),
        (DVec3::new(5.0, 13.0, 2.0), DVec3::new(5.0, 0.0, 2.0), DVec3::Z, true),
        (DVec3::new(3.0, 5.0, 4.0), DVec3::new(3.0, 5.0, -4.0), DVec3::Y, true), // eye inside
        (DVec3::new(0.0, 0.0, 4.0), DVec3::new(6.0, 6.0, 4.0), DVec3::Z, true),  // from a face
        (DVec3::new(1.0, 1.0, 1.0), DVec3::new(8.0, 8.0, 8.0), DVec3::Y, true),  // from a point
        (DVec3::new(-2.0, -2.0, 4.0), DVec3::new(6.0, 6.0, 4.0), DVec3::Z, false),
        (DVec3::new(-3.0, -3.0, -3.0), DVec3::new(4.0, 4.0, 4.0), DVec3::Y, false),
    ];
    let mut total = Stats::default();
    let (mut centre_rays, mut centre_hits) = (0, 0);
    for g in 0..3 {
        let grid = dyadic_grid_with_zeros(&mut rng, 9);
        for (v, &(eye, target, up, exact)) in views.iter().enumerate() {
            for inside in Inside::ALL {
                let mut scene = analytic_scene(&grid, eye, 33);
                scene.camera.target = target;
                scene.camera.up = up;
                scene.camera.fov_y_deg = 50.0;
                scene.surface.inside = inside;
                let frame = render(&mut renderer, &scene, &grid);
                total.add(compare(&scene, &grid, &frame.pixels, false));

                // The centre ray is exact in both: same hit, cell, crossings and steps, no
                // excuses (its values at cell faces are grid values, often exactly 0).
                if !exact {
                    continue;
                }
                let (g_px, r_px) =
                    (frame.pixel(16, 16), analytic::render(&scene, &grid)[16 * 33 + 16]);
                let at = format!("grid {g} view {v} {inside:?}");
                assert_eq!(g_px.is_hit(), r_px.is_hit(), "{at}: {g_px:?} vs {r_px:?}");
                assert_eq!(
                    (g_px.cell, g_px.crossings, g_px.steps),
                    (r_px.cell, r_px.crossings, r_px.steps),
                    "{at}"
                );
                if r_px.is_hit() {
                    assert!((g_px.depth - r_px.depth).abs() <= 1e-6 * r_px.depth, "{at}");
                }
                centre_rays += 1;
                centre_hits += r_px.is_hit() as usize;
            }
        }
    }
    total.check("rays along grid planes");
    assert!(total.exact_zero_rays > total.rays / 20, "values equal to the isovalue: {total:?}");
    assert_eq!(centre_rays, 36);
    assert!(centre_hits > 6, "centre rays that hit: {centre_hits}");
}

#[gpu_test]
fn corner_equal_to_the_isovalue() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(35);
    // The contract: a value equal to the isovalue is outside. (values, inside, any inside at all)
    let cases: [([f64; 8], Inside, bool); 8] = [
        // One corner on the surface, the rest outside: a touch from outside, never a hit.
        ([0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0], Inside::Below, false),
        ([0.0, -1.0, -1.0, -1.0, -1.0, -1.0, -1.0, -1.0], Inside::Above, false),
        // The same corner with the rest inside: the surface passes through the corner.
        ([0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0], Inside::Above, true),
        ([0.0, -1.0, -1.0, -1.0, -1.0, -1.0, -1.0, -1.0], Inside::Below, true),
        // A face of zeros: with the rest outside, nothing; with the rest inside, the face is
        // the surface (entering through it is a crossing at the box face).
        ([0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0], Inside::Below, false),
        ([0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0], Inside::Above, true),
        // An edge of zeros between inside and outside corners, and a saddle through zero.
        ([0.0, 0.0, -1.0, 0.5, 1.0, -0.5, 0.0, 1.0], Inside::Below, true),
        ([0.0, 1.0, -1.0, 0.0, -1.0, 0.0, 0.0, 1.0], Inside::Above, true),
    ];
    let mut total = Stats::default();
    for (c, (values, inside, any)) in cases.into_iter().enumerate() {
        let grid = single_cell(values);
        for view in 0..4 {
            let eye = random_eye(&mut rng, &grid, view == 3);
            let mut scene = analytic_scene(&grid, eye, 48);
            scene.surface.inside = inside;
            let frame = render(&mut renderer, &scene, &grid);
            if !any {
                assert!(
                    frame.pixels.iter().all(|p| !p.is_hit() && p.crossings == 0),
                    "case {c}: nothing is inside, nothing may be hit"
                );
            }
            total.add(compare(&scene, &grid, &frame.pixels, false));
        }
    }
    total.check("corners equal to the isovalue");
    // Values equal to the isovalue are exact in f32 too: even the rays the metric calls grazing
    // (they meet a value within VALUE_TOL of the isovalue: here, exactly on it) agree.
    assert_eq!(total.grazing_agree, total.grazing, "{total:?}");
    assert!(total.exact_zero_rays > 1000, "{total:?}");
}

#[gpu_test]
fn grazing_rays() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut total = Stats::default();
    // A sphere seen at its limb, close up: most rays pass near tangency.
    let sphere =
        grid_from([33, 33, 33], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.length() - 0.6);
    for (target, fov) in [(DVec3::new(0.6, 0.0, 0.0), 4.0), (DVec3::new(0.42, 0.42, 0.0), 1.0)] {
        let mut scene = analytic_scene(&sphere, DVec3::new(0.0, 0.0, 3.0), 64);
        scene.camera.target = target;
        scene.camera.fov_y_deg = fov;
        let frame = render(&mut renderer, &scene, &sphere);
        total.add(compare(&scene, &sphere, &frame.pixels, false));
    }
    // A plane seen almost edge-on: f = z - 0.05 x, rays nearly parallel to it.
    let plane = grid_from([9, 9, 9], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.z - 0.05 * p.x);
    let mut scene = analytic_scene(&plane, DVec3::new(-3.0, 0.1, 0.02), 64);
    scene.camera.target = DVec3::new(1.0, 0.0, 0.0);
    scene.camera.fov_y_deg = 10.0;
    let frame = render(&mut renderer, &scene, &plane);
    total.add(compare(&scene, &plane, &frame.pixels, false));
    total.check("grazing views");
    assert!(total.grazing > 0, "the views must contain grazing rays: {total:?}");
}

#[gpu_test]
fn sphere_sdf_grid_renders_a_sphere() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let grid = grid_from([33, 33, 33], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.length() - 0.6);
    let scene = analytic_scene(&grid, DVec3::new(0.0, 0.0, 3.0), 64);
    let frame = render(&mut renderer, &scene, &grid);
    let cam = isoview::camera::Camera::new(&scene.camera, &scene.image);
    for py in 0..64 {
        for px in 0..64 {
            let p = frame.pixel(px, py);
            let d = cam.ray(px, py).1;
            let closest = (cam.eye - d * cam.eye.dot(d)).length();
            if closest < 0.58 {
                assert!(p.is_hit(), "({px},{py}) should hit");
                let pos = v3(p.position);
                // The trilinear surface of a 33^3 SDF grid is within 2e-3 of the sphere.
                assert!((pos.length() - 0.6).abs() < 2e-3, "|{pos}| = {}", pos.length());
                assert!(v3(p.normal).dot(pos.normalize()) > 0.995, "normal at {pos}");
                assert_eq!(p.crossings, 2, "({px},{py}) goes in and out");
            } else if closest > 0.62 {
                assert!(!p.is_hit(), "({px},{py}) should miss");
                assert_eq!((p.depth, p.cell, p.crossings), (f32::INFINITY, [-1; 3], 0));
            }
        }
    }
    // From the centre, every ray leaves the sphere once.
    let inner = analytic_scene(&grid, DVec3::new(0.01, 0.02, 0.03), 32);
    let frame = render(&mut renderer, &inner, &grid);
    for p in &frame.pixels {
        assert!(p.is_hit() && p.crossings == 1, "{p:?}");
        assert!((v3(p.position).length() - 0.6).abs() < 2e-3);
    }
    assert_eq!(frame.pixels.len(), 32 * 32);
    let st = compare(&scene, &grid, &render(&mut renderer, &scene, &grid).pixels, false);
    st.check("sphere");
}

/// Bitwise equality of every channel but `steps`.
fn same_but_steps(a: &Pixel, b: &Pixel) -> bool {
    let mut a = *a;
    let mut b = *b;
    a.steps = 0.0;
    b.steps = 0.0;
    bytemuck::bytes_of(&a) == bytemuck::bytes_of(&b)
}

#[gpu_test]
fn skipping_leaves_images_bit_identical() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(36);
    let torus = {
        let (r0, r1) = (0.6, 0.25);
        grid_from([64, 64, 64], DVec3::splat(-1.0), DVec3::splat(1.0), |p| {
            DVec3::new((p.x * p.x + p.z * p.z).sqrt() - r0, p.y, 0.0).length() - r1
        })
    };
    let corner_sphere = grid_from([64, 64, 64], DVec3::splat(-1.0), DVec3::splat(1.0), |p| {
        (p - DVec3::splat(-0.7)).length() - 0.2
    });
    let mut scenes: Vec<(String, Grid, Scene)> = Vec::new();
    for (name, grid) in [("torus", &torus), ("corner sphere", &corner_sphere)] {
        for (v, eye) in
            [DVec3::new(2.2, 1.6, 2.4), DVec3::new(-0.3, -0.6, 0.5)].into_iter().enumerate()
        {
            let mut s = scene_for(grid, eye, 64, Method::Analytic);
            s.camera.target = DVec3::new(-0.3, -0.3, -0.3);
            s.render.crossing = 1 + v as u32;
            scenes.push((format!("{name} view {v}"), grid.clone(), s));
        }
    }
    for case in 0..6 {
        let grid = smooth_grid(&mut rng, 20 + 3 * case);
        let eye = random_eye(&mut rng, &grid, case % 3 == 2);
        let mut s = scene_for(&grid, eye, 48, Method::Analytic);
        s.surface.isovalue = rng.range(-0.5, 0.5);
        s.surface.inside = if case % 2 == 0 { Inside::Below } else { Inside::Above };
        s.render.shading = [Shading::Lambert, Shading::Normal, Shading::Cells][case % 3];
        s.render.crossing = 1 + (case % 3) as u32;
        scenes.push((format!("smooth {case}"), grid, s));
    }
    // Exact ties: axis and diagonal views of a unit-spaced grid, rays along grid planes.
    let dyadic = {
        let mut g = dyadic_grid_with_zeros(&mut rng, 33);
        for (n, v) in g.values.iter_mut().enumerate() {
            let x = n % 33;
            *v += if x < 20 { 3.0 } else { 0.0 };
        }
        g
    };
    for (eye, target, up) in [
        (DVec3::new(16.0, 16.0, 60.0), DVec3::new(16.0, 16.0, 0.0), DVec3::Y),
        (DVec3::new(-8.0, -8.0, 16.0), DVec3::new(24.0, 24.0, 16.0), DVec3::Z),
        (DVec3::new(-8.0, -8.0, -8.0), DVec3::new(24.0, 24.0, 24.0), DVec3::Y),
    ] {
        let mut s = scene_for(&dyadic, eye, 65, Method::Analytic);
        s.camera.target = target;
        s.camera.up = up;
        scenes.push(("dyadic".into(), dyadic.clone(), s));
    }

    let mut total_hits = 0;
    for (name, grid, scene) in &scenes {
        let gpu_grid = GpuGrid::upload(&ctx, grid).unwrap();
        let mut on = scene.clone();
        on.render.skip = true;
        let mut off = scene.clone();
        off.render.skip = false;
        let a = renderer.render_uploaded(&on, grid, &gpu_grid, 0.0).unwrap();
        let b = renderer.render_uploaded(&off, grid, &gpu_grid, 0.0).unwrap();
        let differ = a.pixels.iter().zip(&b.pixels).filter(|(x, y)| !same_but_steps(x, y)).count();
        let (sa, sb): (f64, f64) = (
            a.pixels.iter().map(|p| p.steps as f64).sum(),
            b.pixels.iter().map(|p| p.steps as f64).sum(),
        );
        let hits = a.pixels.iter().filter(|p| p.is_hit()).count();
        eprintln!(
            "skipping, {name}: {hits} hits, steps {sa} with skipping vs {sb} without ({:.2}x)",
            sb / sa
        );
        assert_eq!(differ, 0, "{name}: {differ} pixels differ with skipping");
        total_hits += hits;
        assert!(sa <= sb, "{name}: skipping must not add work");
        if name.contains("sphere") || name.contains("torus") {
            assert!(sa * 1.5 < sb, "{name}: skipping must save work on sparse scenes");
        }
    }
    assert!(total_hits > 10_000, "{total_hits}");
}

/// Scenes whose walks jump a lot, exactly: sparse grids where most bricks and superbricks are
/// empty, random and tie-making views (diagonals through brick corners of a unit-spaced grid),
/// every crossing counted, the k-th crossing, several surfaces, both inside sides.
fn jump_scenes(rng: &mut Rng) -> Vec<(String, Grid, Scene)> {
    let n = 2 * bricks::SUPER * bricks::BRICK + 9; // 2 superbricks and a partial one per axis
    let sphere = grid_from([n, n - 7, n + 5], DVec3::splat(-1.0), DVec3::splat(1.0), |p| {
        (p - DVec3::new(0.3, -0.2, 0.25)).length() - 0.3
    });
    let torus = grid_from([n; 3], DVec3::splat(-1.0), DVec3::splat(1.0), |p| {
        DVec3::new((p.x * p.x + p.z * p.z).sqrt() - 0.6, p.y, 0.0).length() - 0.15
    });
    // Unit spacing: index space is world space, so views along diagonals put rays exactly
    // through brick and superbrick edges and corners (planes of several axes at one t).
    let dyadic = {
        let mut g = dyadic_grid_with_zeros(rng, n);
        for (i, v) in g.values.iter_mut().enumerate() {
            *v += if i % n < 2 * bricks::SUPER * bricks::BRICK + 3 { 3.0 } else { 0.0 };
        }
        g
    };
    let c = (n - 1) as f64;
    let mut scenes: Vec<(String, Grid, Scene)> = Vec::new();
    for (case, (name, grid)) in
        [("sphere", &sphere), ("torus", &torus), ("sphere", &sphere), ("torus", &torus)]
            .into_iter()
            .enumerate()
    {
        let eye = random_eye(rng, grid, false);
        let mut s = scene_for(grid, eye, 56, Method::Analytic);
        s.render.crossing = 1 + (case % 2) as u32;
        s.render.count_crossings = case == 1;
        s.surface.inside = if case == 2 { Inside::Above } else { Inside::Below };
        scenes.push((format!("{name} {case}"), grid.clone(), s));
    }
    let mut several = scene_for(&torus, DVec3::new(2.2, 1.6, 2.4), 56, Method::Analytic);
    several.surface.isovalue = -0.05;
    several.surface.more[..2].copy_from_slice(&[0.0, 0.04]);
    several.surface.count = 3;
    scenes.push(("torus, three surfaces".into(), torus.clone(), several));
    for (eye, target, up) in [
        (DVec3::new(-8.0, -8.0, -8.0), DVec3::splat(c), DVec3::Y),
        (DVec3::new(-16.0, -16.0, c / 2.0), DVec3::new(c, c, c / 2.0), DVec3::Z),
        (DVec3::new(c + 8.0, -8.0, c + 8.0), DVec3::new(0.0, c, 0.0), DVec3::Y),
        (DVec3::new(c / 2.0, c / 2.0, 3.0 * c), DVec3::new(c / 2.0, c / 2.0, 0.0), DVec3::Y),
    ] {
        let mut s = scene_for(&dyadic, eye, 64, Method::Analytic);
        s.camera.target = target;
        s.camera.up = up;
        scenes.push(("dyadic".into(), dyadic.clone(), s));
    }
    scenes
}

/// The second level of the min/max grid (superbricks of `bricks::SUPER`³ bricks) changes no
/// bit of any channel, `steps` included (a superbrick jump counts the brick jumps it replaces):
/// sparse grids where most superbricks are empty, random and tie-making views (diagonals
/// through brick corners of a unit-spaced grid), every crossing counted, the k-th crossing,
/// several surfaces, an MPI-style block upload.
#[gpu_test]
fn superbricks_leave_images_bit_identical() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    // The plain walk's levels (the occupancy walk has none).
    renderer.accel = Accel::Plain;
    let scenes = jump_scenes(&mut Rng::new(73));
    let mut jumped = 0;
    for (name, grid, scene) in &scenes {
        let gpu_grid = GpuGrid::upload(&ctx, grid).unwrap();
        let as_block = GpuGrid::upload_block(
            &ctx,
            grid.dims,
            isoview::render::block::Block::whole(grid.dims),
            &grid.values,
            &bricks::reference(grid),
        )
        .unwrap();
        let mut frames = Vec::new();
        for (levels, uploaded) in [(1, &gpu_grid), (2, &gpu_grid), (2, &as_block)] {
            renderer.brick_levels = Some(levels);
            frames.push(renderer.render_uploaded(scene, grid, uploaded, 0.0).unwrap());
            assert_eq!(renderer.last_brick_levels, Some(levels));
        }
        renderer.brick_levels = None;
        renderer.render_uploaded(scene, grid, &gpu_grid, 0.0).unwrap();
        let chosen = renderer.last_brick_levels.unwrap();
        for (i, other) in frames[1..].iter().enumerate() {
            let differ = frames[0]
                .pixels
                .iter()
                .zip(&other.pixels)
                .filter(|(x, y)| bytemuck::bytes_of(*x) != bytemuck::bytes_of(*y))
                .count();
            assert_eq!(differ, 0, "{name} ({i}): {differ} pixels differ with superbricks");
        }
        let hits = frames[0].pixels.iter().filter(|p| p.is_hit()).count();
        let steps: f64 = frames[0].pixels.iter().map(|p| p.steps as f64).sum();
        eprintln!("superbricks, {name}: {hits} hits, {steps} steps, levels chosen {chosen}");
        assert!(hits > 0, "{name}");
        jumped += usize::from(chosen == 2);
    }
    // The sparse grids are the case superbricks are for: the renderer picks them there.
    assert!(jumped >= scenes.len() - 1, "superbricks chosen for {jumped} scenes");
}

/// The occupancy structure's walks (one pass and two) are the plain walk, bit for bit in every
/// channel but `steps`, on scenes whose walks jump a lot and exactly (`jump_scenes`), and smooth
/// random grids with random cameras, orthographic and inside the box too, clip planes, bands of
/// a few rows and a strided picture (the two-pass walk lists rays per band); and each ray's
/// `steps` (the work its walk did) is never more than the plain walk's, the two ways of the
/// occupancy walk agreeing on it exactly.
#[gpu_test]
fn the_occupancy_walk_is_the_plain_walk_bit_for_bit() {
    use isoview::render::Progressive;
    let ctx = gpu();
    assert!(ctx.info.subgroup_ballot, "lavapipe has subgroup ballots: the two-pass walk runs");
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(79);
    let mut scenes = jump_scenes(&mut rng);
    for case in 0..8 {
        let grid = smooth_grid(&mut rng, 17 + 5 * case);
        let eye = random_eye(&mut rng, &grid, case % 4 == 3);
        let mut s = scene_for(&grid, eye, 40, Method::Analytic);
        s.surface.isovalue = rng.range(-0.4, 0.4);
        if case % 3 == 1 {
            s.camera.projection = isoview::scene::Projection::Orthographic;
            s.camera.ortho_height = 2.0 * (s.camera.target - s.camera.eye).length() * 0.4;
        }
        s.render.count_crossings = case % 2 == 0;
        if case % 4 == 1 {
            let mut clip = isoview::vocab::Clip::NONE;
            assert!(clip.push(DVec3::new(0.3, -1.0, 0.2).normalize(), 0.1));
            s.clip = clip;
        }
        scenes.push((format!("smooth {case}"), grid, s));
    }
    let (mut hits, mut saved) = (0usize, 0.0f64);
    for (name, grid, scene) in &scenes {
        let gpu_grid = GpuGrid::upload(&ctx, grid).unwrap();
        let mut frames = Vec::new();
        for accel in [Accel::Plain, Accel::Occupancy, Accel::TwoPass] {
            renderer.accel = accel;
            frames.push(renderer.render_uploaded(scene, grid, &gpu_grid, 0.0).unwrap());
        }
        // Bands of 3 rows and every other pixel, the two-pass walk against the plain one.
        let mut strided = Vec::new();
        for accel in [Accel::Plain, Accel::TwoPass] {
            renderer.accel = accel;
            let mut keep = |_: isoview::passes::Band, _: &[Pixel]| true;
            let how = Progressive { stride: 2, band_rows: 3, after_band: &mut keep };
            strided.push(renderer.render_progressive(scene, grid, &gpu_grid, 0.0, how).unwrap());
        }
        for (what, a, b) in [
            ("one pass", &frames[0], &frames[1]),
            ("two passes", &frames[0], &frames[2]),
            ("strided, two passes", &strided[0], &strided[1]),
        ] {
            let differ =
                a.pixels.iter().zip(&b.pixels).filter(|(x, y)| !same_but_steps(x, y)).count();
            assert_eq!(differ, 0, "{name}, {what}: {differ} pixels differ from the plain walk");
            let more = a.pixels.iter().zip(&b.pixels).filter(|(x, y)| y.steps > x.steps).count();
            assert_eq!(more, 0, "{name}, {what}: {more} rays did more work than the plain walk");
        }
        let same = frames[1].pixels.iter().zip(&frames[2].pixels);
        assert!(
            same.clone().all(|(x, y)| bytemuck::bytes_of(x) == bytemuck::bytes_of(y)),
            "{name}"
        );
        hits += frames[0].pixels.iter().filter(|p| p.is_hit()).count();
        let sum = |f: &Frame| f.pixels.iter().map(|p| p.steps as f64).sum::<f64>();
        saved += sum(&frames[0]) - sum(&frames[1]);
    }
    assert!(hits > 10_000, "{hits} hits");
    assert!(saved > 0.0, "the occupancy walk saved no work");
}

/// The occupancy structure built on the device (the first analytic render of a whole grid with
/// skipping) equals its CPU twin (`occupancy::reference`) bit for bit: every brick's distance,
/// every mask word of the bricks that may hold a surface, on random grids with partial bricks,
/// missing samples and several surfaces; rebuilt when the isovalues change, not before, and not
/// by a strided picture.
#[gpu_test]
fn the_occupancy_structure_equals_its_cpu_twin() {
    use isoview::passes::occupancy::{self, MASK_WORDS};
    use isoview::render::params::RenderParams;
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(83);
    let mut occupied_bricks = 0;
    for (case, dims) in
        [[2, 2, 2], [9, 10, 11], [19, 10, 26], [34, 17, 9], [70, 41, 33], [129, 9, 20]]
            .into_iter()
            .enumerate()
    {
        let mut grid = random_grid(&mut rng, dims);
        let n = grid.values.len();
        for _ in 0..1 + case % 3 {
            grid.values[(rng.next_u64() as usize) % n] =
                [f32::NAN, f32::INFINITY, f32::NEG_INFINITY][case % 3];
        }
        let gpu_grid = GpuGrid::upload(&ctx, &grid).unwrap();
        let mut scene = scene_for(&grid, random_eye(&mut rng, &grid, false), 8, Method::Analytic);
        for count in [1, 3] {
            scene.surface.isovalue = rng.range(-0.6, 0.6);
            scene.surface.count = count;
            for k in 0..count - 1 {
                scene.surface.more[k] = rng.range(-0.6, 0.6);
            }
            // A strided picture (serve's coarse frame) does not build it for new isovalues.
            let mut keep = |_: isoview::passes::Band, _: &[Pixel]| true;
            let how =
                isoview::render::Progressive { stride: 3, band_rows: 4, after_band: &mut keep };
            renderer.render_progressive(&scene, &grid, &gpu_grid, 0.0, how).unwrap();
            assert!(!renderer.built_occupancy, "{dims:?}: a strided picture built it");
            renderer.render_uploaded(&scene, &grid, &gpu_grid, 0.0).unwrap();
            assert!(renderer.built_occupancy, "{dims:?}: new isovalues, a new structure");
            renderer.render_uploaded(&scene, &grid, &gpu_grid, 0.0).unwrap();
            assert!(!renderer.built_occupancy, "{dims:?}: the same isovalues, the same structure");
            let thresholds = RenderParams::new(&scene, &grid).surface_thresholds();
            let (reach, masks) = occupancy::reference(&grid, &thresholds);
            let (seen_reach, seen_masks): (Vec<u32>, Vec<u32>) = gpu_grid.with_occupancy(|o| {
                let o = o.expect("built");
                assert_eq!(o.key, occupancy::key(&thresholds));
                (
                    read_device_buffer(&ctx, &o.reach, reach.len()),
                    read_device_buffer(&ctx, &o.masks, masks.len()),
                )
            });
            assert_eq!(seen_reach, reach, "{dims:?}, {count} surfaces: distances");
            for (b, r) in reach.iter().enumerate() {
                if *r == 0 {
                    occupied_bricks += 1;
                    let words = b * MASK_WORDS..(b + 1) * MASK_WORDS;
                    assert_eq!(
                        seen_masks[words.clone()],
                        masks[words],
                        "{dims:?}, {count} surfaces: brick {b}'s mask"
                    );
                }
            }
        }
    }
    assert!(occupied_bricks > 20, "{occupied_bricks}");
}

/// The choice of levels: superbricks when enough of them are empty for the thresholds.
#[test]
fn superbricks_are_chosen_where_enough_are_empty() {
    let empty = [5.0f32, 6.0];
    let crossed = [-1.0f32, 1.0];
    let mut supers = vec![crossed; 16];
    assert_eq!(bricks::levels_for(&supers, &[0.0]), 1);
    supers[3] = empty;
    assert_eq!(bricks::levels_for(&supers, &[0.0]), 1, "1 in 16");
    supers[7] = empty;
    assert_eq!(bricks::levels_for(&supers, &[0.0]), 2, "2 in 16");
    // Empty for one surface is not empty: every threshold must be clear of the range.
    assert_eq!(bricks::levels_for(&supers, &[0.0, 5.5]), 1);
    // Within the margin of a threshold is not clear of it (5 - 4.999 < (6 + 4.999) / 1024).
    assert_eq!(bricks::levels_for(&supers, &[0.0, 4.999]), 1);
    assert_eq!(bricks::levels_for(&[], &[0.0]), 1);
}

/// The analytic shader's builds read the grid from a storage buffer (a whole grid, the default)
/// or from the grid image (an MPI rank's block; here a "block" that is the whole grid): same
/// bits in every channel, skipping on and off, smooth normals, several surfaces.
#[gpu_test]
fn grid_buffer_and_grid_image_builds_agree_bit_for_bit() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    // The block walks brick by brick: the whole grid's render too (`steps` compares; the
    // occupancy walk's equality with it is its own test).
    renderer.accel = Accel::Plain;
    let mut rng = Rng::new(71);
    let mut hits = 0;
    for case in 0..6 {
        let grid = smooth_grid(&mut rng, 12 + 5 * case);
        let eye = random_eye(&mut rng, &grid, case % 3 == 2);
        let mut s = scene_for(&grid, eye, 48, Method::Analytic);
        s.surface.isovalue = rng.range(-0.5, 0.5);
        s.surface.inside = if case % 2 == 0 { Inside::Below } else { Inside::Above };
        s.render.skip = case % 3 != 1;
        s.render.count_crossings = case == 4;
        if case == 3 {
            s.render.normals = isoview::scene::Normals::Smooth;
        }
        let whole = GpuGrid::upload(&ctx, &grid).unwrap();
        let as_block = GpuGrid::upload_block(
            &ctx,
            grid.dims,
            isoview::render::block::Block::whole(grid.dims),
            &grid.values,
            &bricks::reference(&grid),
        )
        .unwrap();
        let a = renderer.render_uploaded(&s, &grid, &whole, 0.0).unwrap();
        let b = renderer.render_uploaded(&s, &grid, &as_block, 0.0).unwrap();
        let differ = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .filter(|(x, y)| bytemuck::bytes_of(*x) != bytemuck::bytes_of(*y))
            .count();
        assert_eq!(differ, 0, "case {case}: {differ} pixels differ between the two builds");
        hits += a.pixels.iter().filter(|p| p.is_hit()).count();
    }
    assert!(hits > 2_000, "{hits}");
}

/// The brick min/max grid the first analytic render makes (on lavapipe, a CPU device: by the
/// CPU's threads, `bricks::ranges_threaded`) and the one `bricks.comp` builds (what a GPU
/// renders with) both equal the reference, missing samples left out, partial bricks too.
#[gpu_test]
fn brick_grid_holds_each_bricks_min_and_max() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let pipelines = bricks::pipelines(&ctx).unwrap();
    let mut rng = Rng::new(37);
    for dims in [[2, 2, 2], [9, 9, 9], [19, 10, 26], [17, 33, 8], [70, 41, 100], [8, 17, 25]] {
        let mut grid = random_grid(&mut rng, dims);
        let n = grid.values.len();
        grid.values[(rng.next_u64() as usize) % n] = f32::NAN;
        grid.values[(rng.next_u64() as usize) % n] = f32::NEG_INFINITY;
        let gpu_grid = GpuGrid::upload(&ctx, &grid).unwrap();
        let image =
            isoview::gpu::Image3d::upload(&ctx, "grid", grid.dims.map(|d| d as u32), &grid.values)
                .unwrap();
        let on_device =
            bricks::build(&ctx, &pipelines, &image, grid.dims, bricks::Bound::Corners).unwrap();
        let expected = bricks::levels(grid.dims, &bricks::reference(&grid));
        let seen: Vec<[f32; 2]> = read_device_buffer(&ctx, &on_device.buffer, expected.len());
        assert_eq!(seen, expected, "dims {dims:?}: bricks.comp");
        assert_eq!(bricks::ranges_threaded(&grid), bricks::reference(&grid), "dims {dims:?}");
        assert!(gpu_grid.bricks().is_none());
        let scene = scene_for(&grid, random_eye(&mut rng, &grid, false), 8, Method::Analytic);
        renderer.render_uploaded(&scene, &grid, &gpu_grid, 0.0).unwrap();
        let built = gpu_grid.bricks().expect("built by the analytic render");
        let expected = bricks::levels(grid.dims, &bricks::reference(&grid));
        assert_eq!(built.size, 8 * expected.len() as u64);
        let seen: Vec<[f32; 2]> = read_device_buffer(&ctx, built, expected.len());
        assert_eq!(seen, expected, "dims {dims:?}");
    }
}

#[gpu_test]
fn kth_crossing_matches_reference() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(38);
    let mut total = Stats::default();
    let mut deeper = 0;
    for case in 0..6 {
        let grid = if case < 3 {
            random_grid(&mut rng, [5 + case, 6, 4 + case])
        } else {
            smooth_grid(&mut rng, 16)
        };
        let eye = random_eye(&mut rng, &grid, case == 2);
        let mut frames = Vec::new();
        for k in 1..=3 {
            let mut scene = analytic_scene(&grid, eye, 40);
            scene.render.crossing = k;
            scene.surface.inside = if case % 2 == 0 { Inside::Below } else { Inside::Above };
            let frame = render(&mut renderer, &scene, &grid);
            total.add(compare(&scene, &grid, &frame.pixels, false));
            frames.push(frame);
        }
        // The crossings channel does not depend on k; the k-th crossing exists exactly when the
        // ray crosses k times, and lies behind the (k-1)-th.
        for i in 0..frames[0].pixels.len() {
            let p: Vec<&Pixel> = frames.iter().map(|f| &f.pixels[i]).collect();
            for k in 0..3 {
                assert_eq!(p[k].crossings, p[0].crossings, "pixel {i}");
                assert_eq!(p[k].is_hit(), p[k].crossings > k as i32, "pixel {i} k = {}", k + 1);
                if k > 0 && p[k].is_hit() {
                    assert!(p[k].depth >= p[k - 1].depth, "pixel {i}");
                    deeper += 1;
                }
            }
        }
    }
    total.check("k-th crossing");
    assert!(deeper > 1000, "second and third crossings exercised: {deeper}");
}

/// The default (`render.count_crossings = false`) stops the walk at the shown crossing: every
/// channel but `crossings` is bit-identical to the counting walk (`steps` too: it counts passes
/// up to the hit), `crossings` is -1 everywhere, and the reference agrees.
#[gpu_test]
fn stopping_at_the_hit_changes_only_crossings() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(47);
    let mut hits = 0;
    for case in 0..6 {
        let grid = smooth_grid(&mut rng, 12 + 5 * case);
        let eye = random_eye(&mut rng, &grid, case % 3 == 2);
        let mut counting = scene_for(&grid, eye, 40, Method::Analytic);
        counting.surface.isovalue = rng.range(-0.3, 0.3);
        counting.render.crossing = 1 + (case % 2) as u32;
        counting.render.skip = case % 3 != 1;
        let mut stopping = counting.clone();
        stopping.render.count_crossings = false;
        assert!(!isoview::scene::RenderSettings::default().count_crossings, "off by default");
        let a = render(&mut renderer, &counting, &grid).pixels;
        let b = render(&mut renderer, &stopping, &grid).pixels;
        let reference = isoview::reference::analytic::render(&stopping, &grid);
        for (i, ((a, b), r)) in a.iter().zip(&b).zip(&reference).enumerate() {
            assert_eq!(b.crossings, -1, "case {case} pixel {i}");
            assert_eq!(r.crossings, -1, "case {case} pixel {i}: reference");
            let mut a = *a;
            a.crossings = -1;
            assert_eq!(bytemuck::bytes_of(&a), bytemuck::bytes_of(b), "case {case} pixel {i}");
            hits += b.is_hit() as usize;
        }
    }
    assert!(hits > 1000, "enough hits: {hits}");
}

#[test]
fn scene_keys_skip_and_crossing() {
    use isoview::field::GridLimits;
    use std::path::Path;
    let parse = |text: &str, overrides: &[&str]| {
        let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
        isoview::scene::from_str_with(
            text,
            "t.toml",
            Path::new("."),
            &overrides,
            &GridLimits::default(),
        )
    };
    let cell = "[field]\nsource = \"corners\"\nvalues = [-1, 1, 1, 1, 1, 1, 1, 1]\n";
    let s = parse(cell, &[]).unwrap();
    assert_eq!((s.render.skip, s.render.crossing), (true, 1));
    assert!(!s.render.count_crossings);
    assert!(parse(cell, &["render.count_crossings=true"]).unwrap().render.count_crossings);
    let s = parse(cell, &["render.skip=false", "render.crossing=3"]).unwrap();
    assert_eq!((s.render.skip, s.render.crossing), (false, 3));
    let text = format!("{cell}[render]\nskip = false\ncrossing = 2\n");
    let s = parse(&text, &[]).unwrap();
    assert_eq!((s.render.skip, s.render.crossing), (false, 2));
    let e = parse(&format!("{cell}[render]\ncrossing = 0\n"), &[]).unwrap_err().to_string();
    assert_eq!(e, "t.toml:5:12: render.crossing: must be at least 1, got 0");
    let e = parse(&format!("{cell}[render]\nskip = 1\n"), &[]).unwrap_err().to_string();
    assert_eq!(e, "t.toml:5:8: render.skip: expected true or false, got an integer 1");
}

/// llvmpipe ends all loops of an invocation after 65,535 back-edges (the fixed-step march's
/// long-march fix, docs/methods.md): the walks' loops per cell must leave room for the longest
/// ray, or (the tricubic walk) go on in rounds from where the cap cut them. A rod of the widest
/// grid lavapipe holds (4,096 points along x), a crossing in every cell, counted along its
/// length: every walk counts all 4,095 as its reference does (the tricubic walk alone stopped
/// at 3,449, 2,048 before its fixed loops were unrolled).
#[gpu_test]
fn every_walk_counts_a_crossing_in_each_of_4095_cells() {
    use isoview::field::interpolant::Interpolant;
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let grid = rod(4096, |p| (std::f64::consts::PI * p.x).cos());
    let mut scene = along_rod(&grid, Method::Analytic);
    scene.render.count_crossings = true;
    for interp in Interpolant::ALL {
        if interp == Interpolant::Device {
            continue; // no exact trace (fixed-step only)
        }
        scene.field.interpolation = interp;
        let g = renderer.render(&scene, &grid, 0.0).unwrap().pixels[0];
        let r = isoview::reference::analytic::render(&scene, &grid)[0];
        assert_eq!(r.crossings, 4095, "{}: the reference", interp.name());
        assert_eq!(g.crossings, r.crossings, "{}", interp.name());
    }
}
