//! `field.interpolation` on the GPU: the fixed-step march through each interpolant against its
//! f64 reference (`reference::fixed_step::render_sampled`) on random grids, the answers known in
//! closed form (Catmull-Rom reproduces a quadric, the B-spline shrinks it by its kernel's
//! variance, nearest's surface is voxel faces), the device's own filtering measured against
//! exact trilinear, and the one table of refusals (`Interpolant::refusal`) as the CLI says it.

use glam::DVec3;
use isoview::camera::Camera;
use isoview::field::interpolant::Interpolant;
use isoview::field::Grid;
use isoview::frame::Pixel;
use isoview::reference::fixed_step::{self, DeviceModel, Sampling};
use isoview::render::Renderer;
use isoview::scene::{Inside, Method, Scene, Shading};

use crate::common::*;

/// Depth and position of GPU (f32) against the reference (f64), relative to the box diagonal.
const DEPTH_TOL: f64 = 2e-5;
/// Normals: largest allowed |n_gpu - n_ref|.
const NORMAL_TOL: f64 = 1e-3;
/// A smooth interpolant's hit/miss and steps may differ only where a sample's value is this
/// close to the isovalue, relative to the samples' range (f32 rounding of sample positions).
const MARGIN_TOL: f64 = 1e-4;

fn scene_with(grid: &Grid, eye: DVec3, size: u32, interp: Interpolant) -> Scene {
    let mut scene = scene_for(grid, eye, size, Method::FixedStep);
    scene.field.interpolation = interp;
    scene
}

#[derive(Default, Debug)]
struct Tally {
    rays: usize,
    hits: usize,
    /// Pixels that differ where the two arithmetics may disagree (a sample within rounding of
    /// the isovalue, or for nearest of a voxel face).
    excused: usize,
}

impl std::ops::AddAssign for Tally {
    fn add_assign(&mut self, t: Tally) {
        self.rays += t.rays;
        self.hits += t.hits;
        self.excused += t.excused;
    }
}

/// Whether grid coordinate `u` lies within `tol` of a voxel face (a half-integer plane) on
/// some axis: where f32 and f64 may put a sample in different voxels.
fn near_voxel_face(u: DVec3, tol: f64) -> bool {
    (0..3).any(|a| ((u[a] - 0.5) - (u[a] - 0.5).round()).abs() < tol)
}

/// Compares the GPU's pixels with the reference's, pixel by pixel (the tolerances above). A
/// pixel may differ only where the two arithmetics may disagree: for the smooth interpolants
/// where a sample is within rounding of the isovalue; for nearest, whose values jump at voxel
/// faces, where a sample of the march is within rounding of a face (hit, miss, steps), where a
/// bisection midpoint was (the depth then moves by at most the final bracket), or where the hit
/// is near a voxel edge (the face's axis and the inside voxel).
fn compare(scene: &Scene, grid: &Grid, gpu: &[Pixel]) -> Tally {
    use isoview::reference::field::{clip_box, to_grid};
    let interp = scene.field.interpolation;
    let nearest = interp == Interpolant::Nearest;
    let sampling = Sampling::new(interp);
    let cam = Camera::new(&scene.camera, &scene.image);
    let (lo, hi) = grid.range();
    let margin_tol = MARGIN_TOL * (hi - lo) as f64;
    let diag = (grid.max - grid.min).length();
    let reference = fixed_step::render_sampled(scene, grid, sampling);
    let (iso, inside, steps) = (scene.surface.isovalue, scene.surface.inside, scene.render.steps);
    let mut tally = Tally::default();
    for py in 0..scene.image.height {
        for px in 0..scene.image.width {
            let i = (py * scene.image.width + px) as usize;
            let (g, r) = (&gpu[i], &reference[i]);
            let (o, d) = cam.ray(px, py);
            let span = clip_box(grid, o, d);
            let sample_tie = || {
                let m = fixed_step::march_sampled(
                    grid,
                    sampling,
                    iso,
                    inside,
                    o,
                    d,
                    steps,
                    &scene.clip,
                );
                if !nearest {
                    return m.margin < margin_tol;
                }
                span.is_some_and(|(t0, t1)| {
                    (0..steps).any(|s| {
                        let t = t0 + (t1 - t0) * (s as f64 / (steps - 1) as f64);
                        near_voxel_face(to_grid(grid, o + d * t), 1e-4)
                    })
                })
            };
            tally.rays += 1;
            if g.is_hit() != r.is_hit() || g.steps != r.steps {
                assert!(
                    sample_tie(),
                    "{}: pixel ({px},{py}): GPU {g:?} vs reference {r:?}",
                    interp.name()
                );
                tally.excused += 1;
                continue;
            }
            if !r.is_hit() {
                assert_eq!(g.rgba, r.rgba, "{}: pixel ({px},{py}) background", interp.name());
                continue;
            }
            tally.hits += 1;
            let dz = (g.depth as f64 - r.depth as f64).abs();
            let dn = (v3(g.normal) - v3(r.normal)).length();
            if dz <= DEPTH_TOL * diag && dn <= NORMAL_TOL && g.cell == r.cell {
                for c in 0..4 {
                    assert!(
                        (g.rgba[c] - r.rgba[c]).abs() < 2e-3,
                        "{}: pixel ({px},{py}) colour {:?} vs {:?}",
                        interp.name(),
                        g.rgba,
                        r.rgba
                    );
                }
                continue;
            }
            let excused = if nearest {
                // The final bracket: a step over 2^REFINE_BISECTIONS.
                let (t0, t1) = span.unwrap();
                let bracket = (t1 - t0) / (steps - 1) as f64 / 256.0;
                let u = to_grid(grid, v3(r.position));
                let near_edge =
                    (0..3).filter(|&a| ((u[a] - 0.5) - (u[a] - 0.5).round()).abs() < 1e-3).count()
                        >= 2;
                dz <= bracket + DEPTH_TOL * diag
                    && (dn <= NORMAL_TOL && g.cell == r.cell || near_edge)
            } else {
                sample_tie()
            };
            assert!(
                excused,
                "{}: pixel ({px},{py}): depth {} vs {}, normal {:?} vs {:?}, cell {:?} vs {:?}",
                interp.name(),
                g.depth,
                r.depth,
                g.normal,
                r.normal,
                g.cell,
                r.cell
            );
            tally.excused += 1;
        }
    }
    tally
}

/// Random grids and cameras, inside rules, isovalues, step counts and shadings, through each
/// interpolant the GPU marches exactly (device's filter has no f64 reference: its test is
/// below). Shown to fail with one B-spline weight numerator changed in interpolant.glsl and
/// with nearest rounding half down.
#[gpu_test]
fn fixed_step_through_each_interpolant_matches_its_reference() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    for interp in [Interpolant::CubicBspline, Interpolant::CatmullRom, Interpolant::Nearest] {
        let mut rng = Rng::new(11);
        let mut total = Tally::default();
        for case in 0..6 {
            let dims = [0; 3].map(|_| 2 + (rng.next_u64() % 6) as usize);
            let grid = random_grid(&mut rng, dims);
            let eye = random_eye(&mut rng, &grid, case % 3 == 2);
            let mut scene = scene_with(&grid, eye, 24, interp);
            scene.render.steps = 16 + (rng.next_u64() % 80) as u32;
            scene.surface.isovalue = rng.range(-0.3, 0.3);
            scene.surface.inside = if case % 2 == 0 { Inside::Below } else { Inside::Above };
            scene.render.shading = [Shading::Lambert, Shading::Normal, Shading::Cells][case % 3];
            let frame = renderer.render(&scene, &grid, 0.0).unwrap();
            total += compare(&scene, &grid, &frame.pixels);
        }
        eprintln!("fixed-step {}: {total:?}", interp.name());
        assert!(total.hits > total.rays / 10, "{}: too few hits: {total:?}", interp.name());
        // Nearest: every hit's bisection closes in on a voxel face, so a midpoint within f32
        // rounding of the face is common (each such pixel is within one bracket, above).
        let most = if interp == Interpolant::Nearest { 30 } else { 1000 };
        assert!(total.excused * most < total.rays, "{}: too many ties: {total:?}", interp.name());
    }
}

/// The cubic marches on larger smooth grids, where a ray changes cell many times between its
/// samples' neighbours in the SIMD group: the march read a cell's 64 samples in a loop, which
/// llvmpipe runs with run-time indices into the samples (the lane-dependence tricubic.comp
/// records) and counts towards its loop cap; the loops are now unrolled, as the walk's.
#[gpu_test]
fn the_cubic_marches_match_their_references_on_smooth_grids() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    for interp in [Interpolant::CubicBspline, Interpolant::CatmullRom] {
        let mut rng = Rng::new(31);
        let mut total = Tally::default();
        for case in 0..3 {
            let grid = smooth_grid(&mut rng, 24 + 8 * case);
            let eye = random_eye(&mut rng, &grid, case == 2);
            let mut scene = scene_with(&grid, eye, 48, interp);
            scene.render.steps = 150 + 50 * case as u32;
            scene.surface.isovalue = rng.range(-0.2, 0.2);
            let frame = renderer.render(&scene, &grid, 0.0).unwrap();
            total += compare(&scene, &grid, &frame.pixels);
        }
        eprintln!("fixed-step {} on smooth grids: {total:?}", interp.name());
        assert!(total.hits > total.rays / 10, "{}: too few hits: {total:?}", interp.name());
        assert!(total.excused * 1000 < total.rays, "{}: too many ties: {total:?}", interp.name());
    }
}

/// The GPU's voxel walk (`render.method = "analytic"` with `nearest`, `shaders/voxels.comp`)
/// against `reference::voxels` on random grids (values on a coarse lattice, so voxels often
/// equal an isovalue), cameras inside and outside, the k-th crossing, `count_crossings`, several
/// isovalues, a clip plane and missing voxels: every channel equal (depth and position to f32
/// rounding), except on rays the reference walks through a voxel for almost no length (within
/// rounding of a voxel edge, where f32 may step the axes in another order). Shown to fail with
/// the face normal's sign flipped and with the voxel planes going up moved by 0.01.
#[gpu_test]
fn the_voxel_walk_matches_its_reference() {
    use isoview::reference::voxels;
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(23);
    let (mut rays, mut hits, mut excused) = (0, 0, 0);
    for case in 0..10 {
        let dims = [0; 3].map(|_| 2 + (rng.next_u64() % 9) as usize);
        let mut grid = random_grid(&mut rng, dims);
        for v in &mut grid.values {
            *v = ((*v * 4.0).round() / 4.0).clamp(-1.0, 1.0);
        }
        if case % 3 == 1 {
            let n = grid.values.len();
            grid.values[(rng.next_u64() as usize) % n] = f32::NAN;
        }
        let eye = random_eye(&mut rng, &grid, case % 4 == 3);
        let mut scene = scene_with(&grid, eye, 28, Interpolant::Nearest);
        scene.render.method = Method::Analytic;
        scene.surface.inside = if case % 2 == 0 { Inside::Below } else { Inside::Above };
        scene.render.count_crossings = case % 2 == 1;
        scene.render.shading = [Shading::Lambert, Shading::Cells, Shading::Steps][case % 3];
        match case % 5 {
            1 => scene.render.crossing = 2,
            2 => {
                scene.surface.isovalue = -0.25;
                scene.surface.more[0] = 0.25;
                scene.surface.count = 2;
            }
            4 => {
                let c = 0.5 * (grid.min + grid.max);
                scene.clip.push(DVec3::new(1.0, 0.5, 0.0), c.x + 0.5 * c.y);
            }
            _ => scene.surface.isovalue = [-0.25, 0.0, 0.25][(rng.next_u64() % 3) as usize],
        }
        let gpu = renderer.render(&scene, &grid, 0.0).unwrap().pixels;
        let reference = voxels::render(&scene, &grid);
        let cam = Camera::new(&scene.camera, &scene.image);
        let diag = (grid.max - grid.min).length();
        for (i, (g, r)) in gpu.iter().zip(&reference).enumerate() {
            rays += 1;
            let same = g.is_hit() == r.is_hit()
                && g.steps == r.steps
                && g.crossings == r.crossings
                && g.cell == r.cell
                && g.normal == r.normal
                && g.surface == r.surface
                && (!r.is_hit() || (g.depth as f64 - r.depth as f64).abs() <= DEPTH_TOL * diag);
            if same {
                hits += r.is_hit() as usize;
                for c in 0..4 {
                    assert!(
                        (g.rgba[c] - r.rgba[c]).abs() < 2e-3,
                        "case {case} pixel {i}: colour {g:?} vs {r:?}"
                    );
                }
                continue;
            }
            // A tie: the reference's walk visits a voxel for (almost) no length somewhere.
            let (px, py) = (i as u32 % scene.image.width, i as u32 / scene.image.width);
            let (o, d) = cam.ray(px, py);
            let opts = isoview::reference::analytic::options(&scene);
            let tie = scene.surface.isovalues().iter().any(|&iso| {
                let (_, visits) =
                    voxels::trace_detailed(&grid, iso, scene.surface.inside, o, d, &opts);
                visits.iter().any(|v| v.t_out - v.t_in < 1e-4 * diag)
            });
            assert!(tie, "case {case} pixel ({px},{py}): GPU {g:?} vs reference {r:?}");
            excused += 1;
        }
    }
    eprintln!("voxel walk vs reference: {rays} rays, {hits} hits equal, {excused} ties");
    assert!(hits > rays / 10, "too few hits: {hits} of {rays}");
    assert!(excused * 50 < rays, "too many ties: {excused} of {rays}");
}

/// The GPU's tricubic walk (`render.method = "analytic"` with `cubic-bspline` or `catmull-rom`,
/// `shaders/tricubic.comp`) against `reference::analytic`'s Bernstein walk on random grids,
/// cameras inside and outside, the k-th crossing, `count_crossings`, two isovalues, a clip
/// plane and a missing sample: hit or miss, steps, crossings, cell, depth (to 2e-5 of the
/// diagonal) and normal equal, except on grazing rays (the reference meets a value within 1e-4
/// of the samples' range of the isovalue at a leaf end, or hits at a glancing angle), where
/// f32 and f64 may decide differently. Shown to fail with a Catmull-Rom numerator changed
/// (-3 -> -3.01) and with the isolation's halves swapped in `restrict_to`. (Recomputing b0
/// instead of carrying the face value passes: the two differ by rounding only, as
/// `tricubic`'s doc says.)
#[gpu_test]
fn the_tricubic_walk_matches_its_reference() {
    use isoview::field::interpolant::Interpolated;
    use isoview::reference::analytic;
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    for interp in [Interpolant::CubicBspline, Interpolant::CatmullRom] {
        let mut rng = Rng::new(31);
        let (mut rays, mut hits, mut excused) = (0, 0, 0);
        for case in 0..8 {
            let dims = [0; 3].map(|_| 3 + (rng.next_u64() % 5) as usize);
            let mut grid = random_grid(&mut rng, dims);
            if case % 4 == 1 {
                let n = grid.values.len();
                grid.values[(rng.next_u64() as usize) % n] = f32::NAN;
            }
            let eye = random_eye(&mut rng, &grid, case % 4 == 3);
            let mut scene = scene_with(&grid, eye, 24, interp);
            scene.render.method = Method::Analytic;
            scene.surface.inside = if case % 2 == 0 { Inside::Below } else { Inside::Above };
            scene.render.count_crossings = case % 2 == 1;
            scene.render.shading = [Shading::Lambert, Shading::Cells, Shading::Normal][case % 3];
            scene.surface.isovalue = rng.range(-0.3, 0.3);
            match case % 4 {
                1 => scene.render.crossing = 2,
                2 => {
                    scene.surface.more[0] = scene.surface.isovalue + 0.35;
                    scene.surface.count = 2;
                }
                3 => {
                    let c = 0.5 * (grid.min + grid.max);
                    scene.clip.push(DVec3::new(0.3, 1.0, 0.0), 0.3 * c.x + c.y);
                }
                _ => {}
            }
            let gpu = renderer.render(&scene, &grid, 0.0).unwrap().pixels;
            let reference = analytic::render(&scene, &grid);
            let cam = Camera::new(&scene.camera, &scene.image);
            let diag = (grid.max - grid.min).length();
            let (lo, hi) = grid.range();
            let value_tol = 1e-4 * (hi - lo) as f64;
            let opts = analytic::options(&scene);
            let field = Interpolated::new(&grid, interp);
            for (i, (g, r)) in gpu.iter().zip(&reference).enumerate() {
                rays += 1;
                let same = g.is_hit() == r.is_hit()
                    && g.steps == r.steps
                    && g.crossings == r.crossings
                    && g.surface == r.surface
                    && (!r.is_hit()
                        || ((g.depth as f64 - r.depth as f64).abs() <= DEPTH_TOL * diag
                            && (v3(g.normal) - v3(r.normal)).length() <= NORMAL_TOL
                            && g.cell == r.cell));
                if same {
                    hits += r.is_hit() as usize;
                    continue;
                }
                let (px, py) = (i as u32 % scene.image.width, i as u32 / scene.image.width);
                let (o, d) = cam.ray(px, py);
                let grazing = scene.surface.isovalues().iter().any(|&iso| {
                    let (a, visits) = analytic::trace_detailed_interpolated(
                        &field,
                        iso,
                        scene.surface.inside,
                        o,
                        d,
                        &opts,
                    );
                    visits.iter().any(|v| v.splits.iter().any(|s| s.g.abs() < value_tol))
                        || a.hit.is_some_and(|h| h.normal.dot(d.normalize()).abs() < 0.02)
                });
                // A hit on a cell face may name either cell.
                let on_face = r.is_hit() && g.is_hit() && g.cell != r.cell && {
                    let u = isoview::reference::field::to_grid(&grid, v3(r.position));
                    (0..3).any(|a| (u[a] - u[a].round()).abs() < 1e-4)
                };
                assert!(
                    grazing || on_face,
                    "{} case {case} pixel ({px},{py}): GPU {g:?} vs reference {r:?}",
                    interp.name()
                );
                excused += 1;
            }
        }
        eprintln!(
            "tricubic walk {}: {rays} rays, {hits} hits equal, {excused} grazing",
            interp.name()
        );
        assert!(hits > rays / 10, "{}: too few hits: {hits} of {rays}", interp.name());
        assert!(
            excused * 50 < rays,
            "{}: too many grazing rays: {excused} of {rays}",
            interp.name()
        );
    }
}

/// llvmpipe ends an invocation's loops after 65,535 passes: the tricubic walk through thousands
/// of candidate cells is cut short there, and goes on in rounds from its checkpoint
/// (`passes::tricubic::Resume`). 64 rays along a 4,096-point rod with a crossing in every cell,
/// leaving it through its sides from ~1,700 cells on, in workgroups of long and short rays:
/// counting crossings past a first-cell hit (the hit's record kept across rounds), the 3,500th
/// crossing, and two surfaces (the grid from a storage buffer, and once from the grid image);
/// every pixel's hit, steps, crossings, cell, depth and normal as the reference's. Without the rounds the B-spline counted 2,979 of 4,095 (and the
/// workgroups lost more: seen failing with `Resume::pending` answering false).
#[gpu_test]
fn the_tricubic_walk_goes_on_where_the_loop_cap_cut_it() {
    use isoview::reference::analytic;
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let grid = rod(4096, |p| (std::f64::consts::PI * p.x).cos());
    let diag = (grid.max - grid.min).length();
    for interp in [Interpolant::CubicBspline, Interpolant::CatmullRom] {
        // Case 1 also from the grid image (the build for grids over the storage buffer range).
        for (case, buffer) in [(0, true), (1, true), (2, true), (1, false)] {
            renderer.grid_buffer = buffer;
            let mut scene = along_rod(&grid, Method::Analytic);
            scene.field.interpolation = interp;
            scene.image.width = 8;
            scene.image.height = 8;
            // Off the rod's axis (along_rod's eye): no ray leaves it through an edge, where
            // f32 and f64 may step differently.
            scene.camera.fov_y_deg = 0.1;
            match case {
                0 => scene.render.count_crossings = true,
                1 => {
                    scene.render.count_crossings = false;
                    scene.render.crossing = 3500;
                }
                _ => {
                    scene.render.count_crossings = true;
                    // Inside the B-spline's range here, +-1/3 (it smooths the samples' +-1).
                    scene.surface.more[0] = 0.2;
                    scene.surface.count = 2;
                }
            }
            let gpu = renderer.render(&scene, &grid, 0.0).unwrap().pixels;
            let reference = analytic::render(&scene, &grid);
            let (mut long, mut hits) = (0, 0);
            for (i, (g, r)) in gpu.iter().zip(&reference).enumerate() {
                let what = format!("{} case {case} pixel {i}", interp.name());
                assert_eq!(g.is_hit(), r.is_hit(), "{what}: GPU {g:?} vs reference {r:?}");
                assert_eq!(
                    (g.steps, g.crossings, g.surface),
                    (r.steps, r.crossings, r.surface),
                    "{what}"
                );
                // Cells walked: one crossing of each surface per cell, or the steps.
                let cells = match scene.render.count_crossings {
                    true => r.crossings as f32 / scene.surface.count as f32,
                    false => r.steps,
                };
                long += (cells > 3000.0) as usize;
                if r.is_hit() {
                    hits += 1;
                    assert_eq!(g.cell, r.cell, "{what}");
                    assert!((g.depth - r.depth).abs() as f64 <= DEPTH_TOL * diag, "{what}");
                    assert!((v3(g.normal) - v3(r.normal)).length() <= NORMAL_TOL, "{what}");
                }
            }
            // Rays of every length: some past the cap, some not; and hits to compare.
            assert!(long > 8 && long < 60, "{} case {case}: {long} long rays", interp.name());
            assert!(hits > 8, "{} case {case}: {hits} hits", interp.name());
        }
    }
}

/// Renders `grid` through `interp` from a few directions, by fixed-step and, for the
/// interpolants it traces, the analytic method, and checks every hit on a sphere of `radius`
/// (about the box's centre) to `tol`, with outward normals.
fn renders_sphere(grid: &Grid, interp: Interpolant, radius: f64, tol: f64) {
    renders_sphere_by(grid, interp, Method::FixedStep, radius, tol);
    if interp != Interpolant::Trilinear {
        renders_sphere_by(grid, interp, Method::Analytic, radius, tol);
    }
}

fn renders_sphere_by(grid: &Grid, interp: Interpolant, method: Method, radius: f64, tol: f64) {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut hits = 0;
    for eye in [DVec3::new(0.0, 0.0, 3.0), DVec3::new(2.1, -1.3, 1.7), DVec3::new(-2.5, 1.9, -0.4)]
    {
        let mut scene = scene_with(grid, eye, 40, interp);
        scene.render.method = method;
        scene.render.steps = 400;
        let frame = renderer.render(&scene, grid, 0.0).unwrap();
        for p in frame.pixels.iter().filter(|p| p.is_hit()) {
            let pos = v3(p.position);
            assert!(
                (pos.length() - radius).abs() < tol,
                "{} {}: |{pos}| = {}, expected {radius}",
                interp.name(),
                method.name(),
                pos.length()
            );
            assert!(v3(p.normal).dot(pos.normalize()) > 0.9999, "{}: normal", interp.name());
            hits += 1;
        }
    }
    assert!(hits > 1000, "{}: {hits} hits", interp.name());
}

/// The contract's closed forms: x² + y² + z² − r² sampled on a grid (spacing h), away from the
/// border by two cells, is reproduced by Catmull-Rom (it reproduces quadratics), so the surface
/// is the sphere of radius r; the B-spline of a sampled x² is x² + h²/3, so the same samples
/// give the sphere of radius √(r² − h²). Trilinear's surface of the same samples is off by far
/// more (checked, so the tolerance means something).
#[gpu_test]
fn quadric_samples_give_the_exact_and_the_shrunk_sphere() {
    let (n, r) = (17, 0.6);
    let h = 2.0 / (n - 1) as f64;
    let grid =
        grid_from([n; 3], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.length_squared() - r * r);
    let diag = (grid.max - grid.min).length();
    renders_sphere(&grid, Interpolant::CatmullRom, r, 1e-5 * diag);
    renders_sphere(&grid, Interpolant::CubicBspline, (r * r - h * h).sqrt(), 1e-5 * diag);
    // Trilinear of the same samples lies outside the sphere between the points (the chord
    // of a convex function): by up to ~h²/(8r), 500 times the tolerance.
    let result = std::panic::catch_unwind(|| {
        renders_sphere(&grid, Interpolant::Trilinear, r, 1e-5 * diag);
    });
    assert!(result.is_err(), "trilinear should not reproduce the sphere to 1e-5");
}

/// Nearest's surface of f = x sampled at x = 0, 1, ..., 4 with the isovalue between two samples
/// is the face between their voxels, the plane x = i + ½, whatever the isovalue between them;
/// its normal is the face's (from the inside voxel to the outside one) and `cell` the inside
/// voxel's point. Fixed-step finds it to within its final bracket (a step over 2^8).
#[gpu_test]
fn nearest_surfaces_are_the_voxel_faces() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let grid = grid_from([5, 4, 4], DVec3::ZERO, DVec3::new(4.0, 3.0, 3.0), |p| p.x);
    for (iso, inside, face, normal, inside_point) in [
        (1.3, Inside::Below, 1.5, 1.0, 1),
        (1.9, Inside::Below, 1.5, 1.0, 1),
        (2.5, Inside::Above, 2.5, -1.0, 3),
        (3.01, Inside::Above, 3.5, -1.0, 4),
    ] {
        let mut scene = scene_with(&grid, DVec3::new(-3.0, 1.4, 1.6), 24, Interpolant::Nearest);
        scene.camera.target = DVec3::new(2.0, 1.5, 1.5);
        scene.surface.isovalue = iso;
        scene.surface.inside = inside;
        scene.render.steps = 200;
        let frame = renderer.render(&scene, &grid, 0.0).unwrap();
        let mut hits = 0;
        for p in frame.pixels.iter().filter(|p| p.is_hit()) {
            let pos = v3(p.position);
            assert!((pos.x - face).abs() < 1e-4, "iso {iso}: hit at {pos}, face x = {face}");
            assert_eq!(p.normal, [normal as f32, 0.0, 0.0], "iso {iso}: the face's normal");
            assert_eq!(p.cell[0], inside_point, "iso {iso}: the inside voxel");
            hits += 1;
        }
        assert!(hits > 200, "iso {iso}: {hits} hits");
    }
}

/// `interpolation = "device"`: the texture unit's linear filter, measured. On f = x along x
/// (exact under trilinear), the device's surface of each isovalue is where its filtered value
/// crosses it; the filter's weights are exact to within the device's `subTexelPrecisionBits`
/// (the Vulkan limit the model takes), so every hit lies within one quantum (2^-bits of a
/// cell) of the exact plane and of the model of that many bits (`DeviceModel`). The largest
/// offset seen is printed: the terraces' height on this device.
#[gpu_test]
fn the_device_filter_is_within_its_precision_of_exact_trilinear() {
    let ctx = gpu();
    if !ctx.info.r32f_linear_filter {
        panic!(
            "{} cannot filter R32_SFLOAT linearly: this test needs a device that can",
            ctx.info.name
        );
    }
    let bits = ctx.info.sub_texel_precision_bits;
    let quantum = (-(bits as f64)).exp2();
    let model = DeviceModel { bits };
    let mut renderer = Renderer::new(&ctx).unwrap();
    let grid = grid_from([4, 3, 3], DVec3::ZERO, DVec3::new(3.0, 2.0, 2.0), |p| p.x);
    let mut worst: f64 = 0.0;
    let mut rng = Rng::new(5);
    for _ in 0..24 {
        let iso = rng.range(0.05, 2.95);
        let mut scene = scene_with(&grid, DVec3::new(6.0, 1.0, 1.0), 8, Interpolant::Device);
        scene.camera.target = DVec3::new(0.0, 1.0, 1.0);
        scene.camera.fov_y_deg = 1.0;
        scene.surface.isovalue = iso;
        scene.surface.inside = Inside::Above;
        scene.render.steps = 512;
        let frame = renderer.render(&scene, &grid, 0.0).unwrap();
        let reference = fixed_step::render_sampled(
            &scene,
            &grid,
            Sampling { interp: Interpolant::Device, device: model },
        );
        for (p, r) in frame.pixels.iter().zip(&reference) {
            assert!(p.is_hit(), "iso {iso}: every ray meets the plane");
            let x = p.position[0] as f64;
            worst = worst.max((x - iso).abs());
            assert!((x - iso).abs() <= quantum + 1e-4, "iso {iso}: device hit at x = {x}");
            let xr = r.position[0] as f64;
            assert!((x - xr).abs() <= quantum + 1e-4, "iso {iso}: x = {x}, the model's {xr}");
            let n = v3(p.normal);
            assert!(n.dot(DVec3::NEG_X) > 0.999, "iso {iso}: normal {n}");
        }
    }
    eprintln!(
        "device filter on {}: subTexelPrecisionBits = {bits}, largest offset from the exact \
         plane {worst:.3e} cells",
        ctx.info.name
    );
}

/// The one table of refusals, as the CLI says it: a verb or method that does not read the
/// scene's interpolant exits 2 with one line naming `field.interpolation`, before reading a
/// sample; fixed-step renders every interpolant, the analytic method all but `device`; an
/// unknown name lists the five.
#[gpu_test]
fn each_verb_refuses_the_interpolants_it_does_not_read() {
    let dir = scratch("interp-refusals");
    let scene = write(
        &dir,
        "s.toml",
        "[image]\nwidth = 16\nheight = 16\n[field]\nsource = \"sdf\"\nshape = \"sphere\"\n\
         radius = 0.5\nresolution = [8, 8, 8]\nbounds = { min = [-1, -1, -1], max = [1, 1, 1] }\n",
    );
    let out = dir.join("o.exr");
    let o = out.to_str().unwrap();
    let set = |i: &str| format!("field.interpolation=\"{i}\"");
    let (mesh, sliced) = (dir.join("m.ply"), dir.join("s.exr"));
    let (m, sl) = (mesh.to_str().unwrap(), sliced.to_str().unwrap());
    for interp in ["cubic-bspline", "catmull-rom", "nearest", "device"] {
        let i = set(interp);
        let key = format!("s.toml: field.interpolation = \"{interp}\": ");
        let why = if interp == "device" {
            "is what the GPU's texture unit returns"
        } else {
            "does not read"
        };
        for method in ["analytic", "mesh"] {
            let me = format!("render.method=\"{method}\"");
            let r = isoview(&["render", &scene, "-o", o, "--set", &i, "--set", &me], &[]);
            if interp != "device" {
                // Nearest's voxel walk, the cubic ones' Bernstein walk; the meshes of
                // `mesh::refine` and `mesh::voxel_faces`.
                assert!(r.status.success(), "{interp}, {method}: {}", stderr(&r));
                std::fs::remove_file(&out).unwrap();
                continue;
            }
            assert_fails(&r, 2, &[&key, why]);
        }
        for args in [
            vec!["extract", &scene, "-o", m],
            vec!["slice", &scene, "-o", sl, "--axis", "z", "--at", "0"],
            vec!["probe", &scene, "--pixel", "3,3"],
            vec!["probe", &scene, "--slice", "z=0", "--segment", "-1,-1,1,1"],
        ] {
            let mut a: Vec<&str> = args.clone();
            a.extend(["--set", &i]);
            let r = isoview(&a, &[]);
            let segment = args[2] == "--slice";
            if !segment && interp != "device" {
                // The probe runs the f64 references, which every kernel has; extract meshes
                // each (`mesh::refine`, `mesh::voxel_faces`); slice draws each.
                assert!(r.status.success(), "{interp}, {}: {}", args[0], stderr(&r));
                for f in [&mesh, &sliced] {
                    let _ = std::fs::remove_file(f);
                }
                continue;
            }
            let why = if segment && interp != "device" {
                "probe --slice reports each plane cell's bilinear quadratic"
            } else {
                why
            };
            assert_fails(&r, 2, &[&key, why]);
        }
        for f in [&out, &mesh, &sliced] {
            assert!(!f.exists(), "{interp}: {} written", f.display());
        }
        let fixed = "render.method=\"fixed-step\"";
        let r = isoview(&["render", &scene, "-o", o, "--set", &i, "--set", fixed], &[]);
        assert!(r.status.success(), "{interp} by fixed-step: {}", stderr(&r));
        std::fs::remove_file(&out).unwrap();
        let smooth = "render.normals=\"smooth\"";
        let r = isoview(
            &["render", &scene, "-o", o, "--set", &i, "--set", fixed, "--set", smooth],
            &[],
        );
        if interp == "device" {
            // Point gradients stand in for the device's filter of a trilinear field too.
            assert!(r.status.success(), "device, smooth normals: {}", stderr(&r));
            std::fs::remove_file(&out).unwrap();
        } else {
            assert_fails(&r, 2, &["render.normals", "\"smooth\" interpolates point gradients"]);
        }
    }
    let r = isoview(&["render", &scene, "-o", o, "--set", &set("tricubic")], &[]);
    let names = ["field.interpolation", "\"trilinear\"", "\"cubic-bspline\"", "\"catmull-rom\""];
    assert_fails(&r, 2, &names);
    assert_fails(&r, 2, &["\"nearest\"", "\"device\""]);
    // [field2] is sampled trilinearly for colour.
    let f2 = "field2={source=\"sdf\",shape=\"sphere\",radius=0.5,resolution=[4,4,4],interpolation=\"nearest\"}";
    let r = isoview(&["render", &scene, "-o", o, "--set", f2, "--set", "color.by=\"field2\""], &[]);
    assert_fails(&r, 2, &["field2.interpolation", "[field2] is sampled trilinearly"]);
}

/// `probe` through the scene's interpolant: Catmull-Rom's exact hit on the sphere its samples
/// reproduce (f64, to the samples' f32 rounding), each cell's segment a degree-9 Bernstein
/// polynomial with its leaves; nearest's voxel walk with each voxel's value and state, its hit
/// on the voxel face exactly, the face's normal, the inside voxel as the cell; the text report
/// names the interpolant; `/api/probe`'s JSON is the same report (`PixelProbe::json`).
#[test]
fn probe_reports_each_interpolant_s_exact_trace() {
    let dir = scratch("interp-probe");
    let scene = write(
        &dir,
        "s.toml",
        "[image]\nwidth = 32\nheight = 32\n[camera]\neye = [0.0, 0.0, 3.0]\n[field]\n\
         source = \"expr\"\nexpression = \"x*x + y*y + z*z - 0.36\"\nresolution = [17, 17, 17]\n\
         bounds = { min = [-1, -1, -1], max = [1, 1, 1] }\n[render]\nmethod = \"fixed-step\"\n",
    );
    let probe = |interp: &str, json: bool| {
        let set = format!("field.interpolation=\"{interp}\"");
        let mut args = vec!["probe", &scene, "--pixel", "16,16", "--set", &set];
        if json {
            args.push("--json");
        }
        let o = isoview(&args, &[]);
        assert!(o.status.success(), "{interp}: {}", stderr(&o));
        String::from_utf8(o.stdout).unwrap()
    };
    let report: serde_json::Value = serde_json::from_str(&probe("catmull-rom", true)).unwrap();
    let a = &report["analytic"];
    assert_eq!(a["interpolation"], "catmull-rom");
    let p: Vec<f64> =
        a["hit"]["position"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    assert!((r - 0.6).abs() < 1e-7, "Catmull-Rom's sphere: |p| = {r}");
    let cells = a["cells"].as_array().unwrap();
    assert!(!cells.is_empty());
    for c in cells {
        assert_eq!(c["corners"].as_array().unwrap().len(), 64, "the 64 samples");
        assert_eq!(c["bernstein"].as_array().unwrap().len(), 10, "degree 9");
        assert!(!c["leaves"].as_array().unwrap().is_empty());
        assert!(c.get("cubic").is_none(), "no monomial cubic for a tricubic cell");
    }
    assert!(report["fixed_step"]["hit"].is_object(), "fixed-step through Catmull-Rom hits too");
    assert!(probe("catmull-rom", false).contains("analytic (catmull-rom, newton_steps = 10)"));

    let report: serde_json::Value = serde_json::from_str(&probe("nearest", true)).unwrap();
    let a = &report["analytic"];
    assert_eq!(a["interpolation"], "nearest");
    let hit = &a["hit"];
    // The ray goes down z through x, y ~ 0: the face between voxels 13 (0.030625, outside) and
    // 12 (-0.11, inside) of z, at grid z = 12.5, world z = -1 + 12.5 / 8 = 0.5625.
    assert_eq!(hit["normal"], serde_json::json!([0.0, 0.0, 1.0]));
    assert_eq!(hit["cell"][2], 12);
    assert!((hit["position"][2].as_f64().unwrap() - 0.5625).abs() < 1e-12, "{hit}");
    let voxels = a["voxels"].as_array().unwrap();
    assert!(voxels.iter().any(|v| v["voxel"][2] == 13 && v["inside"] == false));
    assert!(voxels.iter().any(|v| v["voxel"][2] == 12 && v["inside"] == true));
    assert!(probe("nearest", false).contains("analytic, nearest's voxel walk"));
}

/// Samples near f32's limit: the ray methods' f32 arithmetic overflows there (the last attack
/// pass of issue #29: a 2³ grid of ±3.4e38 rendered with holes by analytic and with invented
/// surface by Catmull-Rom's fixed-step, while `probe` in f64 was right), so the ray methods
/// refuse a grid past `render::grid::GPU_SAMPLE_BOUND` (1e30) with one line, and the same
/// grid at the bound traces as its f64 reference does, for each interpolant and both methods,
/// normals included (the confirmation pass found them wrong from 1e20: |gradient|² overflowed;
/// `unit_or` in interpolant.glsl; seen failing without it at 1e25 and 1e-25).
#[gpu_test]
fn samples_past_the_gpu_bound_are_refused_and_traced_below_it() {
    use isoview::render::grid::GPU_SAMPLE_BOUND;
    let signs = [1.0, -1.0, 1.0, -1.0, -1.0, 1.0, -1.0, 1.0];
    let grid_of = |s: f64| {
        let values = signs.iter().map(|&x| (x * s) as f32).collect();
        Grid { dims: [2, 2, 2], min: DVec3::splat(-1.0), max: DVec3::ONE, values }
    };
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    for interp in [
        Interpolant::Trilinear,
        Interpolant::CatmullRom,
        Interpolant::CubicBspline,
        Interpolant::Nearest,
    ] {
        for method in [Method::Analytic, Method::FixedStep] {
            let big = grid_of(3.4e38);
            let mut scene = scene_with(&big, DVec3::new(2.2, 1.6, 2.4), 16, interp);
            scene.render.method = method;
            let Err(e) = renderer.render(&scene, &big, 0.0) else { panic!("not refused") };
            let e = e.to_string();
            assert!(e.contains("samples reach ±3.4e38, beyond the ±1e30"), "{e}");
            // At the bound, at 1e25 and at 1e-25 (where |gradient|² over- or underflows f32:
            // the normals are made through `unit_or`), as the f64 reference.
            for scale in [f64::from(GPU_SAMPLE_BOUND), 1e25, 1e-25] {
                let at = grid_of(scale);
                let gpu = renderer.render(&scene, &at, 0.0).unwrap().pixels;
                let reference = reference_pixels(&scene, &at);
                let label = format!("{} {} at {scale:e}", interp.name(), method.name());
                let pairs = || gpu.iter().zip(&reference);
                let agree = pairs().filter(|(g, r)| g.is_hit() == r.is_hit()).count();
                let hits = reference.iter().filter(|r| r.is_hit()).count();
                assert!(hits > 20, "{label}: {hits} hits");
                assert!(agree * 100 >= 99 * gpu.len(), "{label}: hit masks agree on {agree}");
                let both = pairs().filter(|(g, r)| g.is_hit() && r.is_hit()).count();
                let normals = pairs()
                    .filter(|(g, r)| g.is_hit() && r.is_hit())
                    .filter(|(g, r)| (v3(g.normal) - v3(r.normal)).length() < NORMAL_TOL)
                    .count();
                assert!(
                    normals * 100 >= 99 * both,
                    "{label}: normals agree on {normals} of {both}"
                );
            }
        }
    }
    // The CLI says it in one line, exit 2; probe (f64) reads the same grid.
    let dir = scratch("gpu-sample-bound");
    let mut npy = b"\x93NUMPY\x01\x00".to_vec();
    let mut header = "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 2, 2), }".to_string();
    while (header.len() + 11) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    npy.extend((header.len() as u16).to_le_bytes());
    npy.extend(header.as_bytes());
    for x in signs {
        npy.extend(((x * 3.4e38) as f32).to_le_bytes());
    }
    std::fs::write(dir.join("big.npy"), npy).unwrap();
    let scene = write(&dir, "big.toml", "[image]\nwidth = 16\nheight = 16\n[field]\nsource = \"npy\"\npath = \"big.npy\"\nbounds = { min = [-1, -1, -1], max = [1, 1, 1] }\n");
    let out = dir.join("a.exr");
    let r = isoview(&["render", &scene, "-o", out.to_str().unwrap()], &[]);
    assert_fails(&r, 2, &["big.toml: samples reach ±3.4e38, beyond the ±1e30"]);
    assert!(!out.exists());
    // The brick pool refuses it in the same one line, before its summary (which was printed
    // first, a second line on stderr) and before uploading a brick.
    let pooled = ["--set", "field.residency=\"active\""];
    let r = isoview(&["render", &scene, "-o", out.to_str().unwrap(), pooled[0], pooled[1]], &[]);
    assert_fails(&r, 2, &["big.toml: samples reach ±3.4e38, beyond the ±1e30"]);
    assert!(!stderr(&r).contains("bricks"), "{}", stderr(&r));
    assert!(!out.exists());
    // `serve` takes the state (only sampling the field shows its samples) and its frame
    // answers 400 with the command line's line.
    let server = crate::serve::api::Server::start(&scene, &[]);
    let frame = server.get("/api/frame");
    assert_eq!(frame.status, 400, "{}", frame.text());
    let line = stderr(&isoview(&["render", &scene, "-o", out.to_str().unwrap()], &[]));
    assert_eq!(frame.json()["error"].as_str().unwrap(), line.trim_end());
    let p = isoview(&["probe", &scene, "--pixel", "7,9"], &[]);
    assert!(p.status.success(), "{}", stderr(&p));
}

/// Bitwise equality of every channel but `steps`.
fn same_but_steps(a: &Pixel, b: &Pixel) -> bool {
    let (mut a, mut b) = (*a, *b);
    a.steps = 0.0;
    b.steps = 0.0;
    bytemuck::bytes_of(&a) == bytemuck::bytes_of(&b)
}

/// The walks that skip with their own bounds: nearest's voxel walk and the tricubic ones.
const SKIPPING_WALKS: [Interpolant; 3] =
    [Interpolant::Nearest, Interpolant::CubicBspline, Interpolant::CatmullRom];

/// Empty-space skipping in the voxel walk and the tricubic walks (`render.skip`, their brick
/// jumps) changes no bit of any channel but `steps`, which counts less
/// work on sparse grids and is the same with superbricks (`brick_levels` 2) as with bricks
/// alone; it is the reference's count (`reference::skipping`) on all but 0.2% of the pixels
/// where the reference and the GPU walk the same cells (equal hit, cell and crossings; rays
/// within rounding of a brick face may step through it differently in f32). Sparse SDFs (a
/// torus, a sphere in a corner), random smooth fields with random isovalues, eyes inside and
/// outside, the k-th crossing, several surfaces, stopping at the hit and counting every
/// crossing, and a quantized grid seen along its planes (ties).
#[gpu_test]
fn the_other_walks_skip_bit_identically() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(61);
    let torus = grid_from([64, 64, 64], DVec3::splat(-1.0), DVec3::splat(1.0), |p| {
        DVec3::new((p.x * p.x + p.z * p.z).sqrt() - 0.6, p.y, 0.0).length() - 0.25
    });
    let corner = grid_from([65, 62, 60], DVec3::splat(-1.0), DVec3::splat(1.0), |p| {
        (p - DVec3::splat(-0.7)).length() - 0.2
    });
    let mut quantized = random_grid(&mut rng, [33, 25, 17]);
    for (n, v) in quantized.values.iter_mut().enumerate() {
        *v = if n % 33 < 20 { 2.0 } else { (*v * 2.0).round() / 2.0 };
    }
    quantized.min = DVec3::ZERO;
    quantized.max = DVec3::new(32.0, 24.0, 16.0);
    for interp in SKIPPING_WALKS {
        let mut scenes: Vec<(String, &Grid, Scene, bool)> = Vec::new();
        for (name, grid) in [("torus", &torus), ("corner sphere", &corner)] {
            for (v, eye) in
                [DVec3::new(2.2, 1.6, 2.4), DVec3::new(-0.3, -0.6, 0.5)].into_iter().enumerate()
            {
                let mut s = scene_with(grid, eye, 40, interp);
                s.camera.target = DVec3::new(-0.3, -0.3, -0.3);
                s.render.crossing = 1 + v as u32;
                s.render.count_crossings = v == 0;
                scenes.push((format!("{name} view {v}"), grid, s, true));
            }
        }
        let smooth: Vec<Grid> = (0..3)
            .map(|c| {
                let waves: Vec<(DVec3, f64)> = (0..3)
                    .map(|_| (rng.unit_vector() * rng.range(2.0, 5.0), rng.range(0.0, 6.3)))
                    .collect();
                let n = 18 + 5 * c;
                grid_from([n, n + 3, n - 2], DVec3::splat(-1.0), DVec3::splat(1.0), |p| {
                    waves.iter().map(|(k, ph)| 0.4 * (k.dot(p) + ph).sin()).sum::<f64>()
                })
            })
            .collect();
        for (c, grid) in smooth.iter().enumerate() {
            let eye = random_eye(&mut rng, grid, c == 2);
            let mut s = scene_with(grid, eye, 32, interp);
            s.surface.isovalue = rng.range(-0.6, 0.6);
            s.surface.inside = if c % 2 == 0 { Inside::Below } else { Inside::Above };
            s.render.count_crossings = c == 1;
            if c == 0 {
                s.surface.more[0] = s.surface.isovalue + 0.3;
                s.surface.count = 2;
            }
            scenes.push((format!("smooth {c}"), grid, s, false));
        }
        for (eye, target, up) in [
            (DVec3::new(16.5, 12.5, 60.0), DVec3::new(16.5, 12.5, 0.0), DVec3::Y),
            (DVec3::new(-8.0, -8.5, 8.5), DVec3::new(24.0, 24.5, 8.5), DVec3::Z),
        ] {
            let mut s = scene_with(&quantized, eye, 33, interp);
            s.camera.target = target;
            s.camera.up = up;
            s.surface.isovalue = 0.25;
            scenes.push(("quantized".into(), &quantized, s, false));
        }
        for (name, grid, scene, sparse) in &scenes {
            let name = format!("{} {name}", interp.name());
            let mut scene = scene.clone();
            scene.render.method = Method::Analytic;
            let gpu_grid = isoview::render::GpuGrid::upload(&ctx, grid).unwrap();
            let mut frames = Vec::new();
            for (skip, levels) in [(false, None), (true, Some(1)), (true, Some(2))] {
                scene.render.skip = skip;
                renderer.brick_levels = levels;
                frames.push(renderer.render_uploaded(&scene, grid, &gpu_grid, 0.0).unwrap().pixels);
            }
            renderer.brick_levels = None;
            let [off, bricks, supers] = &frames[..] else { unreachable!() };
            let differ = off.iter().zip(bricks).filter(|(a, b)| !same_but_steps(a, b)).count();
            let first =
                off.iter().zip(bricks).enumerate().find(|(_, (a, b))| !same_but_steps(a, b));
            assert_eq!(differ, 0, "{name}: {differ} pixels differ with skipping, first {first:?}");
            let by_level = bricks.iter().zip(supers).filter(|(a, b)| a.steps != b.steps).count();
            assert_eq!(by_level, 0, "{name}: superbricks change {by_level} pixels' steps");
            let sum = |f: &[Pixel]| f.iter().map(|p| p.steps as f64).sum::<f64>();
            let (s_on, s_off) = (sum(bricks), sum(off));
            let hits = off.iter().filter(|p| p.is_hit()).count();
            // Skipping's count against the reference's, where both walk the same cells.
            let reference = isoview::reference::analytic::render(&scene, grid);
            let (mut same, mut compared) = (0, 0);
            for (g, r) in bricks.iter().zip(&reference) {
                if g.is_hit() == r.is_hit() && g.cell == r.cell && g.crossings == r.crossings {
                    compared += 1;
                    same += (g.steps == r.steps) as usize;
                }
            }
            eprintln!(
                "{name}: {hits} hits, steps {s_on} with skipping vs {s_off} without ({:.2}x); \
                 reference's count on {same} of {compared}",
                s_off / s_on
            );
            assert!(s_on <= s_off, "{name}: skipping must not add work");
            // Catmull-Rom's ranges are widened by 37/54 of their width on each side, so few of
            // the torus SDF's bricks are clear of its surface (none on view 1's rays).
            if *sparse && (interp != Interpolant::CatmullRom || name.contains("sphere")) {
                assert!(s_on * 1.5 < s_off, "{name}: skipping must save work on sparse scenes");
            }
            // Rays along the quantized grid's planes are ties, where f32 and f64 may step
            // through different zero-length visits (with or without skipping).
            if !name.contains("quantized") {
                assert!(compared * 10 > 9 * off.len(), "{name}: the reference walks elsewhere");
                assert!(
                    same * 1000 >= 998 * compared,
                    "{name}: steps {same} of {compared} as the reference's"
                );
            }
        }
    }
}

/// The tricubic walks skip only where their interpolant cannot reach an isovalue, which needs
/// both parts of the bound (`passes::bricks::Bound`): the brick's range over its cells' whole
/// stencils (a step from 1 to 0 between points 7 and 8: the B-spline's surface at 0.01 lies in
/// cell 8, of brick 1, whose own corners are all 0, and only the apron's point 7 reaches it),
/// and for Catmull-Rom the widening by its overshoot (the same step: its undershoot to -2/27
/// in cell 8 and overshoot to 1 + 2/27 in cell 6, surfaces at -0.03 and 1.03 beyond every
/// sample). Skipping on and off must agree bit for bit, with the surface in nearly every
/// pixel. Seen failing with the cubic brick ranges over trilinear's stencil (bricks.comp: all
/// 1024 pixels of the B-spline's first view differ) and with Catmull-Rom's widening set to 0
/// (bricks.comp: all 1024 of its first view at -0.03).
#[gpu_test]
fn the_tricubic_skip_bounds_hold_the_overshoot_and_the_apron() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let step = grid_from([40, 12, 12], DVec3::ZERO, DVec3::new(39.0, 11.0, 11.0), |p| {
        if p.x <= 7.0 {
            1.0
        } else {
            0.0
        }
    });
    let cases = [
        (Interpolant::CubicBspline, vec![0.01]),
        (Interpolant::CatmullRom, vec![-0.03]),
        (Interpolant::CatmullRom, vec![1.03]),
        (Interpolant::CatmullRom, vec![-0.03, 1.03]),
    ];
    for (interp, isos) in cases {
        for eye in [DVec3::new(60.0, 5.3, 5.6), DVec3::new(40.0, 28.0, -12.0)] {
            let mut scene = scene_with(&step, eye, 32, interp);
            scene.render.method = Method::Analytic;
            scene.camera.target = DVec3::new(7.5, 5.5, 5.5);
            scene.camera.fov_y_deg = 10.0;
            scene.render.count_crossings = false;
            scene.surface.isovalue = isos[0];
            if isos.len() > 1 {
                scene.surface.more[0] = isos[1];
                scene.surface.count = 2;
            }
            scene.surface.inside = if isos[0] < 0.5 { Inside::Below } else { Inside::Above };
            let gpu_grid = isoview::render::GpuGrid::upload(&ctx, &step).unwrap();
            let mut frames = Vec::new();
            for skip in [false, true] {
                scene.render.skip = skip;
                frames
                    .push(renderer.render_uploaded(&scene, &step, &gpu_grid, 0.0).unwrap().pixels);
            }
            let name = format!("{} at {isos:?} from {eye}", interp.name());
            let hits = frames[0].iter().filter(|p| p.is_hit()).count();
            let differ =
                frames[0].iter().zip(&frames[1]).filter(|(a, b)| !same_but_steps(a, b)).count();
            let sum = |f: &[Pixel]| f.iter().map(|p| p.steps as f64).sum::<f64>();
            eprintln!(
                "{name}: {hits} hits, {differ} pixels differ, steps {} vs {}",
                sum(&frames[1]),
                sum(&frames[0])
            );
            assert!(hits * 20 > 19 * frames[0].len(), "{name}: only {hits} hits");
            assert_eq!(differ, 0, "{name}: {differ} pixels differ with skipping");
            assert!(sum(&frames[1]) < sum(&frames[0]), "{name}: nothing was skipped");
        }
    }
}

/// The tricubic walks' min/max grids (`bricks.comp`'s cubic builds), built on the device by the
/// first render through each interpolant, equal their CPU twins (`bricks::reference_for`, with
/// the superbricks of `bricks::levels`, then the fine level of `bricks::fine_reference_for`)
/// bit for bit, missing samples included.
#[gpu_test]
fn the_tricubic_brick_grids_equal_their_cpu_twins() {
    use isoview::passes::bricks::{self, Bound};
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(67);
    for dims in [[2, 2, 2], [9, 10, 11], [19, 10, 26], [34, 17, 9]] {
        let mut grid = random_grid(&mut rng, dims);
        let n = grid.values.len();
        grid.values[(rng.next_u64() as usize) % n] = f32::NAN;
        let gpu_grid = isoview::render::GpuGrid::upload(&ctx, &grid).unwrap();
        for (interp, bound) in [
            (Interpolant::CubicBspline, Bound::Cubic),
            (Interpolant::CatmullRom, Bound::CatmullRom),
        ] {
            assert!(gpu_grid.cubic_bricks(bound).is_none());
            let mut scene = scene_with(&grid, random_eye(&mut rng, &grid, false), 8, interp);
            scene.render.method = Method::Analytic;
            renderer.render_uploaded(&scene, &grid, &gpu_grid, 0.0).unwrap();
            let built = gpu_grid.cubic_bricks(bound).expect("built by the analytic render");
            let expected = bricks::levels(grid.dims, &bricks::reference_for(&grid, bound));
            let seen: Vec<[f32; 2]> = read_device_buffer(&ctx, built, expected.len());
            assert_eq!(seen, expected, "{} dims {dims:?}", interp.name());
            // Then the fine level (the walk's per-cell test).
            let fine = bricks::fine_reference_for(&grid, bound);
            let all: Vec<[f32; 2]> = read_device_buffer(&ctx, built, expected.len() + fine.len());
            assert_eq!(all[expected.len()..], fine[..], "{} dims {dims:?}: fine", interp.name());
        }
    }
}
