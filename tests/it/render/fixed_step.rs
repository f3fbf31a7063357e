//! The fixed-step GPU pass against its f64 reference, and renders with known answers (the plane
//! from a linear field and the render under validation, common to every method, are in
//! `methods.rs`).

use glam::DVec3;
use isoview::field::Grid;
use isoview::frame::Pixel;
use isoview::reference::{field, fixed_step};
use isoview::render::Renderer;
use isoview::scene::{Inside, Method, Scene, Shading};

use crate::common::*;

/// Tolerances of GPU (f32) against the reference (f64), relative to the box diagonal.
const DEPTH_TOL: f64 = 2e-5;
/// Normals: largest allowed |n_gpu - n_ref| (about 0.06 degrees).
const NORMAL_TOL: f64 = 1e-3;
/// Hit/miss and step counts may differ only where some sample's value is this close to the
/// isovalue, relative to the grid's value range (f32 rounding of sample positions).
const MARGIN_TOL: f64 = 1e-4;

struct Agreement {
    rays: usize,
    hits: usize,
    excused: usize,
}

fn compare_with_reference(scene: &Scene, grid: &Grid, gpu: &[Pixel]) -> Agreement {
    let cam = isoview::camera::Camera::new(&scene.camera, &scene.image);
    let (lo, hi) = grid.range();
    let margin_tol = MARGIN_TOL * (hi - lo) as f64;
    let diag = (grid.max - grid.min).length();
    let reference = fixed_step::render(scene, grid);
    let mut agreement = Agreement { rays: 0, hits: 0, excused: 0 };
    for py in 0..scene.image.height {
        for px in 0..scene.image.width {
            let i = (py * scene.image.width + px) as usize;
            let (g, r) = (&gpu[i], &reference[i]);
            let m = fixed_step::march(
                grid,
                scene.surface.isovalue,
                scene.surface.inside,
                cam.eye,
                cam.ray(px, py).1,
                scene.render.steps,
            );
            agreement.rays += 1;
            if g.is_hit() != r.is_hit() || g.steps != r.steps {
                assert!(
                    m.margin < margin_tol,
                    "pixel ({px},{py}): GPU {g:?} vs reference {r:?}, margin {}",
                    m.margin
                );
                agreement.excused += 1;
                continue;
            }
            if !r.is_hit() {
                assert_eq!(g.rgba, r.rgba, "pixel ({px},{py}) background");
                continue;
            }
            agreement.hits += 1;
            let dz = (g.depth as f64 - r.depth as f64).abs();
            if dz > DEPTH_TOL * diag {
                // A different bracket (two crossings in one step) is a tie, like hit/miss.
                assert!(
                    m.margin < margin_tol,
                    "pixel ({px},{py}): depth {} vs {}",
                    g.depth,
                    r.depth
                );
                agreement.excused += 1;
                continue;
            }
            let dn = (DVec3::from(g.normal.map(f64::from)) - DVec3::from(r.normal.map(f64::from)))
                .length();
            assert!(dn < NORMAL_TOL, "pixel ({px},{py}): normal {:?} vs {:?}", g.normal, r.normal);
            for a in 0..3 {
                assert!((g.position[a] - r.position[a]).abs() as f64 <= DEPTH_TOL * diag * 2.0);
            }
            if g.cell != r.cell {
                // Only on a cell face: the hit's grid coordinate is within rounding of an integer.
                let u = field::to_grid(grid, DVec3::from(r.position.map(f64::from)));
                let on_face = (0..3).any(|a| (u[a] - u[a].round()).abs() < 1e-4);
                assert!(on_face, "pixel ({px},{py}): cell {:?} vs {:?}", g.cell, r.cell);
            }
            for c in 0..4 {
                assert!((g.rgba[c] - r.rgba[c]).abs() < 2e-3, "pixel ({px},{py}) colour");
            }
        }
    }
    agreement
}

#[gpu_test]
fn fixed_step_matches_reference_on_random_grids_and_cameras() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(7);
    let (mut rays, mut hits, mut excused) = (0, 0, 0);
    for case in 0..12 {
        let dims = [
            2 + (rng.next_u64() % 7) as usize,
            2 + (rng.next_u64() % 7) as usize,
            2 + (rng.next_u64() % 7) as usize,
        ];
        let grid = random_grid(&mut rng, dims);
        let eye = random_eye(&mut rng, &grid, case % 4 == 3);
        let mut scene = scene_for(&grid, eye, 40, Method::FixedStep);
        scene.render.steps = 16 + (rng.next_u64() % 100) as u32;
        scene.surface.isovalue = rng.range(-0.3, 0.3);
        scene.surface.inside = if case % 2 == 0 { Inside::Below } else { Inside::Above };
        scene.render.shading = [Shading::Lambert, Shading::Normal, Shading::Cells][case % 3];
        let frame = renderer.render(&scene, &grid, 0.0).unwrap();
        let a = compare_with_reference(&scene, &grid, &frame.pixels);
        rays += a.rays;
        hits += a.hits;
        excused += a.excused;
    }
    eprintln!("fixed-step vs reference: {rays} rays, {hits} hits compared, {excused} ties");
    assert!(hits > rays / 10, "too few hits to mean anything: {hits} of {rays}");
    assert!(excused * 1000 < rays, "too many ties: {excused} of {rays}");
}

#[gpu_test]
fn sphere_sdf_grid_renders_a_sphere() {
    let ctx = gpu();
    let grid = grid_from([33, 33, 33], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.length() - 0.6);
    let scene = scene_for(&grid, DVec3::new(0.0, 0.0, 3.0), 64, Method::FixedStep);
    let frame = Renderer::new(&ctx).unwrap().render(&scene, &grid, 0.0).unwrap();
    let cam = isoview::camera::Camera::new(&scene.camera, &scene.image);
    for py in 0..64 {
        for px in 0..64 {
            let p = frame.pixel(px, py);
            let d = cam.ray(px, py).1;
            // Distance of the ray from the centre decides hit or miss, away from the silhouette.
            let closest = (cam.eye - d * cam.eye.dot(d)).length();
            if closest < 0.58 {
                assert!(p.is_hit(), "({px},{py}) should hit");
                let pos = DVec3::from(p.position.map(f64::from));
                // Trilinear surface of a 33^3 SDF grid: within 2e-3 of the true sphere (h = 1/16).
                assert!((pos.length() - 0.6).abs() < 2e-3, "|{pos}| = {}", pos.length());
                let nrm = DVec3::from(p.normal.map(f64::from));
                assert!(nrm.dot(pos.normalize()) > 0.995, "normal {nrm} at {pos}");
            } else if closest > 0.62 {
                assert!(!p.is_hit(), "({px},{py}) should miss");
                assert_eq!(p.depth, f32::INFINITY);
                assert_eq!(p.cell, [-1; 3]);
            }
        }
    }
}

#[gpu_test]
fn tall_images_render_in_bands_identically() {
    let ctx = gpu();
    let grid = grid_from([9, 9, 9], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.length() - 0.7);
    // 4096 wide: MAX_BAND_PIXELS (2^20) / 4096 = 256 rows per band, so 600 rows take 3 bands.
    let mut scene = scene_for(&grid, DVec3::new(0.3, 0.2, 3.0), 16, Method::FixedStep);
    scene.image.width = 4096;
    scene.image.height = 600;
    scene.camera.fov_y_deg = 50.0;
    let frame = Renderer::new(&ctx).unwrap().render(&scene, &grid, 0.0).unwrap();
    assert_eq!(frame.pixels.len(), 4096 * 600);
    let reference = fixed_step::render(&scene, &grid);
    let mismatched =
        frame.pixels.iter().zip(&reference).filter(|(g, r)| g.is_hit() != r.is_hit()).count();
    assert!(mismatched < 10, "{mismatched} hit/miss mismatches across bands");
    // Every band wrote its rows: rows near the top and bottom of each band hit where expected.
    for row in [0u32, 255, 256, 511, 512, 599] {
        let p = frame.pixel(2048, row);
        let r = &reference[(row * 4096 + 2048) as usize];
        assert_eq!(p.is_hit(), r.is_hit(), "row {row}");
        assert_eq!(p.steps, r.steps, "row {row}");
    }
}

#[gpu_test]
fn grids_larger_than_one_staging_slab_upload_in_pieces() {
    let ctx = gpu();
    // 300^3 f32 = 103 MiB: two 64 MiB staging slabs, and more than lavapipe's 128 MiB storage
    // buffer range would allow as one buffer of a slightly larger grid.
    let n = 300;
    let grid = grid_from([n, n, n], DVec3::splat(-1.0), DVec3::splat(1.0), |p| {
        (p - DVec3::new(0.1, -0.2, 0.3)).length() - 0.5
    });
    // Looking from +z the rays meet the upper slab's part of the sphere first, from -z the
    // lower slab's (the boundary is at grid z = 186, world z = 0.244).
    let mut renderer = Renderer::new(&ctx).unwrap();
    for (eye_z, upper) in [(3.0, true), (-3.0, false)] {
        let mut scene = scene_for(&grid, DVec3::new(0.4, 0.3, eye_z), 32, Method::FixedStep);
        scene.render.steps = 300;
        let frame = renderer.render(&scene, &grid, 0.0).unwrap();
        let a = compare_with_reference(&scene, &grid, &frame.pixels);
        assert!(a.hits > 100, "{} hits", a.hits);
        let in_slab = |z: f32| if upper { z > 0.244 } else { z < 0.244 };
        let hits: Vec<f32> =
            frame.pixels.iter().filter(|p| p.is_hit()).map(|p| p.position[2]).collect();
        assert!(hits.iter().filter(|&&z| in_slab(z)).count() * 2 > hits.len());
    }
}

/// The trilinear march reads a whole grid from a storage buffer (its default) or from the grid
/// image (`Renderer::grid_buffer = false`): the same samples, so the same bits in every channel,
/// on smooth random grids with missing samples, inside and outside cameras, orthographic views,
/// clip planes and several surfaces.
#[gpu_test]
fn grid_buffer_and_grid_image_marches_agree_bit_for_bit() {
    use isoview::render::GpuGrid;
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(89);
    let mut hits = 0;
    for case in 0..6 {
        let mut grid = smooth_grid(&mut rng, 10 + 6 * case);
        if case % 2 == 1 {
            // A few missing samples (field.nan = "empty"): cells the march must not cross.
            for _ in 0..8 {
                let n = (rng.next_u64() as usize) % grid.values.len();
                grid.values[n] = f32::NAN;
            }
        }
        let eye = random_eye(&mut rng, &grid, case % 3 == 2);
        let mut s = scene_for(&grid, eye, 40, Method::FixedStep);
        s.render.steps = 24 + 40 * case as u32;
        s.surface.isovalue = rng.range(-0.4, 0.4);
        s.surface.inside = if case % 2 == 0 { Inside::Below } else { Inside::Above };
        if case == 1 {
            s.camera.projection = isoview::scene::Projection::Orthographic;
            s.camera.ortho_height = 2.0 * (s.camera.target - s.camera.eye).length() * 0.4;
        }
        if case == 3 {
            assert!(s.clip.push(DVec3::new(0.3, -1.0, 0.2).normalize(), 0.1));
        }
        if case == 4 {
            s.surface.more[0] = s.surface.isovalue + 0.2;
            s.surface.count = 2;
        }
        let gpu_grid = GpuGrid::upload(&ctx, &grid).unwrap();
        let mut frames = Vec::new();
        for buffer in [true, false] {
            renderer.grid_buffer = buffer;
            frames.push(renderer.render_uploaded(&s, &grid, &gpu_grid, 0.0).unwrap());
        }
        let differ = frames[0]
            .pixels
            .iter()
            .zip(&frames[1].pixels)
            .filter(|(x, y)| bytemuck::bytes_of(*x) != bytemuck::bytes_of(*y))
            .count();
        assert_eq!(differ, 0, "case {case}: {differ} pixels differ between the buffer and image");
        hits += frames[0].pixels.iter().filter(|p| p.is_hit()).count();
    }
    assert!(hits > 2_000, "{hits}");
}

/// Seventh attack pass: past ~21,800 samples a ray marched on lavapipe lost its surface, exit
/// 0 (steps = 131,072 on the sphere scene: no pixel hit). llvmpipe ends all loops of an
/// invocation after 65,535 back-edges in all (gallivm's LP_MAX_TGSI_LOOP_ITERATIONS), and a
/// sample cost three. A sample now costs one, and a march of more than `LOOP_STEPS` takes
/// MARCH_UNROLL samples per back-edge. A 1,400-point rod looked at along its length, at
/// `LOOP_STEPS` (the loop's most) and at `scene::MAX_STEPS` samples (the plane at x = 1,300.25
/// is 93% of the samples in; the far one, past the box, is never met): every interpolant's march,
/// the trilinear one from its buffer and its image, finds what its reference finds, after as
/// many samples. Seen failing before the change: the steps channel stopped at 21,844.
#[gpu_test]
fn a_march_of_the_most_steps_allowed_ends_where_its_reference_does() {
    use isoview::field::interpolant::Interpolant;
    use isoview::passes::raymarch::LOOP_STEPS;
    use isoview::scene::MAX_STEPS;
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let steps_and_planes = [LOOP_STEPS, MAX_STEPS as u32]
        .into_iter()
        .flat_map(|steps| [(steps, 1300.25, true), (steps, 5000.0, false)]);
    for (steps, plane, hit) in steps_and_planes {
        let grid = rod(1400, |p| p.x - plane);
        let mut scene = along_rod(&grid, Method::FixedStep);
        scene.render.steps = steps;
        scene.surface.isovalue = 0.0;
        for (interp, buffer) in [
            (Interpolant::Trilinear, true),
            (Interpolant::Trilinear, false),
            (Interpolant::CubicBspline, true),
            (Interpolant::CatmullRom, true),
            (Interpolant::Nearest, true),
        ] {
            scene.field.interpolation = interp;
            renderer.grid_buffer = buffer;
            let frame = renderer.render(&scene, &grid, 0.0).unwrap();
            let sampling = fixed_step::Sampling::new(interp);
            let reference = fixed_step::render_sampled(&scene, &grid, sampling);
            let what = format!("{} (buffer {buffer}), {steps} steps, plane {plane}", interp.name());
            for (g, r) in frame.pixels.iter().zip(&reference) {
                assert_eq!((g.is_hit(), g.steps), (hit, r.steps), "{what}: {g:?}");
                assert_eq!(r.is_hit(), hit, "{what}: the reference");
                if hit {
                    assert!(r.steps > 0.9 * steps as f32, "{what}: {} samples", r.steps);
                    assert!((g.position[0] - r.position[0]).abs() < 1e-2, "{what}: {g:?}");
                } else {
                    assert_eq!(g.steps, steps as f32, "{what}");
                }
            }
        }
    }
}
