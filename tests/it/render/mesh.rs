//! The mesh render (`render.method = "mesh"`) against its f64 reference on random meshes and
//! cameras, and against the exact surface: a fine sphere SDF grid compared with the fixed-step
//! render and the analytic reference (the plane from a linear field and the render under
//! validation, common to every method, are in `methods.rs`).

use glam::DVec3;
use isoview::camera::Camera;
use isoview::field::Grid;
use isoview::frame::Pixel;
use isoview::mesh::{reference, Mesh, Request};
use isoview::passes::mesh_render;
use isoview::reference::{analytic, field, mesh as reference};
use isoview::render::{GpuGrid, Renderer};
use isoview::scene::{Inside, MeshAlgorithm, Method, Scene, Shading};

use crate::common::*;

/// Rays whose f64 trace passes closer than this (radians) to an edge of a tested triangle may
/// hit or miss differently in f32; such pixels are excused (and counted).
const EDGE_MARGIN: f64 = 2e-5;
/// Depth, GPU vs reference, relative to the box diagonal.
const DEPTH_TOL: f64 = 2e-5;
/// Normals: largest |n_gpu - n_ref|.
const NORMAL_TOL: f64 = 2e-3;

fn v(a: [f32; 3]) -> DVec3 {
    DVec3::from(a.map(f64::from))
}

struct Agreement {
    rays: usize,
    hits: usize,
    excused: usize,
    steps_off: usize,
}

fn compare(scene: &Scene, grid: &Grid, mesh: &Mesh, gpu: &[Pixel]) -> Agreement {
    let (reference, traces) = reference::render(scene, grid, mesh);
    let diag = (grid.max - grid.min).length();
    let mut a = Agreement { rays: 0, hits: 0, excused: 0, steps_off: 0 };
    for (i, ((g, r), tr)) in gpu.iter().zip(&reference).zip(&traces).enumerate() {
        let (px, py) = (i as u32 % scene.image.width, i as u32 / scene.image.width);
        a.rays += 1;
        // The tested count depends on screen boxes rounded to whole pixels: f32 and f64 may
        // disagree by a triangle where a box edge falls on a pixel centre.
        if g.steps != r.steps {
            assert!(
                (g.steps - r.steps).abs() <= 2.0,
                "({px},{py}): steps {} vs {}",
                g.steps,
                r.steps
            );
            a.steps_off += 1;
        }
        let near_edge = tr.margin < EDGE_MARGIN;
        if g.is_hit() != r.is_hit() || g.crossings != r.crossings {
            assert!(near_edge, "({px},{py}): GPU {g:?} vs reference {r:?}, margin {}", tr.margin);
            a.excused += 1;
            continue;
        }
        if !r.is_hit() {
            assert_eq!(g.rgba, r.rgba, "({px},{py}) background");
            assert_eq!((g.cell, g.normal, g.position), (r.cell, r.normal, r.position));
            continue;
        }
        a.hits += 1;
        let dz = (g.depth as f64 - r.depth as f64).abs();
        let dn = (v(g.normal) - v(r.normal)).length();
        if dz > DEPTH_TOL * diag || dn > NORMAL_TOL {
            // Another triangle won by a hair (a shared edge, or two sheets at one depth).
            assert!(
                near_edge,
                "({px},{py}): depth {} vs {}, normal {:?} vs {:?}",
                g.depth, r.depth, g.normal, r.normal
            );
            a.excused += 1;
            continue;
        }
        assert!((v(g.position) - v(r.position)).length() <= 2.0 * DEPTH_TOL * diag);
        if g.cell != r.cell {
            let u = field::to_grid(grid, v(r.position));
            let on_face = (0..3).any(|k| (u[k] - u[k].round()).abs() < 1e-4);
            assert!(on_face, "({px},{py}): cell {:?} vs {:?}", g.cell, r.cell);
        }
        for c in 0..4 {
            assert!((g.rgba[c] - r.rgba[c]).abs() < 5e-3, "({px},{py}) colour {g:?} vs {r:?}");
        }
    }
    a
}

fn render_mesh(renderer: &mut Renderer, scene: &Scene, grid: &Grid, mesh: &Mesh) -> Vec<Pixel> {
    let ctx = renderer.context().clone();
    let gpu_grid = GpuGrid::upload(&ctx, grid).unwrap();
    let buffers = mesh_render::upload(&ctx, mesh).unwrap();
    renderer.render_mesh(scene, grid, &gpu_grid, &buffers, 0.0).unwrap().pixels
}

#[gpu_test]
fn mesh_render_matches_reference_on_random_meshes_and_cameras() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(11);
    let (mut rays, mut hits, mut excused, mut steps_off) = (0, 0, 0, 0);
    for case in 0..12 {
        let dims = [
            3 + (rng.next_u64() % 6) as usize,
            3 + (rng.next_u64() % 6) as usize,
            3 + (rng.next_u64() % 6) as usize,
        ];
        let grid = random_grid(&mut rng, dims);
        let eye = random_eye(&mut rng, &grid, case % 4 == 3);
        let mut scene = scene_for(&grid, eye, 40, Method::Mesh);
        scene.surface.isovalue = rng.range(-0.3, 0.3);
        scene.surface.inside = if case % 2 == 0 { Inside::Below } else { Inside::Above };
        scene.render.shading = [Shading::Lambert, Shading::Normal, Shading::Cells][case % 3];
        scene.render.mesh = MeshAlgorithm::ALL[case % 5];
        let mesh = reference(
            &grid,
            &Request::new(scene.surface.isovalue, scene.surface.inside, scene.render.mesh),
        )
        .unwrap();
        let pixels = render_mesh(&mut renderer, &scene, &grid, &mesh);
        let a = compare(&scene, &grid, &mesh, &pixels);
        rays += a.rays;
        hits += a.hits;
        excused += a.excused;
        steps_off += a.steps_off;
    }
    eprintln!(
        "mesh render vs reference: {rays} rays, {hits} hits compared, {excused} excused near \
         edges, {steps_off} tested counts off by at most 2"
    );
    assert!(hits > rays / 10, "too few hits to mean anything: {hits} of {rays}");
    assert!(excused * 200 < rays, "too many excused: {excused} of {rays}");
    assert!(steps_off * 100 < rays, "too many tested counts off: {steps_off} of {rays}");
}

/// `count` triangles in [-1, 1]^3, each within `reach` of a random centre, random normals.
fn triangle_soup(rng: &mut Rng, count: u32, reach: f64) -> Mesh {
    let mut mesh = Mesh::default();
    for t in 0..count {
        let c = DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
        for _ in 0..3 {
            let p = c + rng.unit_vector() * rng.range(0.05, reach);
            mesh.positions.push(p.as_vec3().to_array());
            mesh.normals.push(rng.unit_vector().as_vec3().to_array());
        }
        mesh.indices.extend([3 * t, 3 * t + 1, 3 * t + 2]);
    }
    mesh
}

#[gpu_test]
fn random_triangle_soup_and_a_camera_among_the_triangles_match_the_reference() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(5);
    let grid = grid_from([3, 3, 3], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.x);
    let mesh = triangle_soup(&mut rng, 60, 0.5);
    let (mut rays, mut excused) = (0, 0);
    for (k, eye) in [DVec3::new(0.1, 0.2, 0.05), DVec3::new(2.5, 1.0, -2.0)].into_iter().enumerate()
    {
        let mut scene = scene_for(&grid, eye, 48, Method::Mesh);
        scene.camera.target = DVec3::new(0.3, -0.2, 1.0) * (1.0 - 2.0 * k as f64);
        let pixels = render_mesh(&mut renderer, &scene, &grid, &mesh);
        let a = compare(&scene, &grid, &mesh, &pixels);
        assert!(a.hits > a.rays / 10, "{} hits of {}", a.hits, a.rays);
        rays += a.rays;
        excused += a.excused;
    }
    assert!(excused * 100 < rays, "too many excused: {excused} of {rays}");
}

/// llvmpipe ends an invocation's loops after 65,535 passes: the raster tested a triangle's
/// box pixel by pixel in one invocation, so a triangle over more pixels than that was drawn
/// in its first rows only (a coarse sphere up close at 1024^2 lost 434,610 of its pixels, exit
/// 0). A coarse sphere (4^3 points, marching cubes: boxes of ~100,000 pixels here) at 320^2,
/// without and with clip planes (which make a pixel cost more passes: smaller chunks): every
/// pixel as the reference's. Seen failing with every triangle drawn by the first stage.
#[gpu_test]
fn triangles_over_many_pixels_are_drawn_whole() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let grid = grid_from([4, 4, 4], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.length() - 0.7);
    let request = Request::new(0.0, Inside::Below, MeshAlgorithm::MarchingCubes);
    let mesh = reference(&grid, &request).unwrap();
    for clips in 0..2 {
        let mut scene = scene_for(&grid, DVec3::new(1.2, 0.9, 1.3), 320, Method::Mesh);
        for k in 0..clips * 12 {
            // Planes that remove nothing in view (x > 2 + k): only the pixels' cost changes.
            scene.clip.push(DVec3::new(1.0, 0.0, 0.0), 2.0 + k as f64);
        }
        let pixels = render_mesh(&mut renderer, &scene, &grid, &mesh);
        let a = compare(&scene, &grid, &mesh, &pixels);
        assert!(a.hits > a.rays / 2, "{clips}: {} hits of {}", a.hits, a.rays);
        assert!(a.excused * 200 < a.rays, "{clips}: {} excused of {}", a.excused, a.rays);
    }
}

/// The screen box rule (`reference::mesh::screen_box`, which `mesh_raster.comp` follows) loses
/// no hit: triangles around and behind eyes among them, perspective and orthographic, every
/// pixel's nearest hit and hit count with the boxes as when every triangle is tested on every
/// pixel (the GPU-against-reference tests share the rule, so they could not tell), and the
/// GPU's render as the reference's. Seen failing with the off-screen ways of an edge through
/// the eye's plane left out.
#[gpu_test]
fn screen_boxes_lose_no_hit() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(17);
    let grid = grid_from([3, 3, 3], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.x);
    let mesh = triangle_soup(&mut rng, 80, 0.9);
    let (mut hits, mut straddling) = (0, 0);
    for case in 0..8 {
        let eye = DVec3::new(rng.range(-0.8, 0.8), rng.range(-0.8, 0.8), rng.range(-0.8, 0.8));
        let mut scene = scene_for(&grid, eye, 40, Method::Mesh);
        scene.camera.target = eye + rng.unit_vector();
        if case % 4 == 3 {
            scene.camera.projection = isoview::scene::Projection::Orthographic;
        }
        let cam = Camera::new(&scene.camera, &scene.image);
        // And a floor just under the eye, reaching behind it: near the eye its picture runs
        // off the screen's edge, far from every vertex's.
        let mut mesh = mesh.clone();
        let n = mesh.positions.len() as u32;
        for p in [
            DVec3::new(-3.0, -0.05, -3.0),
            DVec3::new(3.0, -0.05, -3.0),
            DVec3::new(0.0, -0.05, 6.0),
        ] {
            mesh.positions.push((eye + p).as_vec3().to_array());
            mesh.normals.push([0.0, 1.0, 0.0]);
        }
        mesh.indices.extend([n, n + 1, n + 2]);
        let triangle = |t: usize| {
            mesh.triangle(t).map(|v| DVec3::from(mesh.positions[v as usize].map(f64::from)))
        };
        let boxes: Vec<_> = (0..mesh.triangle_count())
            .map(|t| {
                let [a, b, c] = triangle(t);
                let z = [a, b, c].map(|p| (p - cam.eye).dot(cam.forward));
                straddling += (z.iter().any(|&z| z > 0.0) && z.iter().any(|&z| z <= 0.0)) as usize;
                reference::screen_box(&cam, a, b, c)
            })
            .collect();
        let everywhere = vec![Some([0, 39, 0, 39]); mesh.triangle_count()];
        for py in 0..40 {
            for px in 0..40 {
                let boxed = reference::trace(&mesh, &cam, &scene.clip, &boxes, px, py);
                let all = reference::trace(&mesh, &cam, &scene.clip, &everywhere, px, py);
                assert_eq!(
                    (boxed.hit.map(|h| h.0), boxed.hits),
                    (all.hit.map(|h| h.0), all.hits),
                    "case {case} pixel ({px},{py})"
                );
                hits += boxed.hits as usize;
            }
        }
        let pixels = render_mesh(&mut renderer, &scene, &grid, &mesh);
        let a = compare(&scene, &grid, &mesh, &pixels);
        assert!(a.excused * 50 < a.rays, "case {case}: {} excused of {}", a.excused, a.rays);
    }
    assert!(hits > 1000 && straddling > 40, "{hits} hits, {straddling} straddling triangles");
}

/// A sphere of radius 0.6 as an SDF on a 65^3 grid over [-1, 1]^3 (h = 1/32).
fn sphere_grid() -> Grid {
    grid_from([65, 65, 65], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.length() - 0.6)
}

/// Largest gap between the mesh of a fine sphere grid and the exact trilinear surface, measured
/// along the normal (depth difference times |cos| of the ray's angle to the normal), on rays
/// that meet the sphere within 60° of its normal; along such a ray a gap g is a depth
/// difference of up to 2g. Sphere of radius r = 0.6 sampled at spacing h = 1/32:
/// * mc33 (vertices on the surface, flat triangles between): about h^2 / (8 r) ≈ 2e-4;
///   tolerance 3e-4.
/// * surface-nets (vertices at the mean of a cell's crossings, inside the surface's hull):
///   up to about h^2 ≈ 1e-3; tolerance 1e-3.
const SPHERE_GAP_TOL: [(MeshAlgorithm, f64); 2] =
    [(MeshAlgorithm::Mc33, 3e-4), (MeshAlgorithm::SurfaceNets, 1e-3)];

#[gpu_test]
fn fine_sphere_mesh_render_agrees_with_fixed_step_and_analytic_within_the_stated_tolerance() {
    let ctx = gpu();
    let grid = sphere_grid();
    let mut renderer = Renderer::new(&ctx).unwrap();
    for (algo, gap_tol) in SPHERE_GAP_TOL {
        let mut scene = scene_for(&grid, DVec3::new(0.4, 0.9, 2.6), 80, Method::Mesh);
        scene.render.mesh = algo;
        let mesh_frame = renderer.render(&scene, &grid, 0.0).unwrap();
        scene.render.method = Method::FixedStep;
        scene.render.steps = 400;
        let fixed = renderer.render(&scene, &grid, 0.0).unwrap();
        let cam = Camera::new(&scene.camera, &scene.image);
        let opts = analytic::AnalyticOptions::default();
        let (mut compared, mut worst_fixed, mut worst_exact, mut worst_gap) = (0, 0.0, 0.0, 0.0f64);
        for py in 0..80 {
            for px in 0..80 {
                let (m, f) = (mesh_frame.pixel(px, py), fixed.pixel(px, py));
                let d = cam.ray(px, py).1;
                let closest = (cam.eye - d * cam.eye.dot(d)).length();
                if closest > 0.6 * 60f64.to_radians().sin() {
                    continue;
                }
                assert!(m.is_hit() && f.is_hit(), "({px},{py}) should hit");
                let exact = analytic::trace(&grid, 0.0, Inside::Below, cam.eye, d, &opts);
                let t = exact.hit.expect("the analytic reference hits").t;
                let dz = (m.depth as f64 - t).abs();
                worst_fixed = f64::max(worst_fixed, (m.depth as f64 - f.depth as f64).abs());
                worst_exact = f64::max(worst_exact, dz);
                worst_gap = worst_gap.max(dz * v(m.normal).dot(d).abs());
                assert!(v(m.normal).dot(v(m.position).normalize()) > 0.995, "normal ({px},{py})");
                assert_eq!(m.crossings as u32, exact.crossings, "({px},{py}) crossings");
                compared += 1;
            }
        }
        eprintln!(
            "sphere r = 0.6 on 65^3, {}: {compared} rays within 60° of the normal, largest \
             |Z_mesh - Z_fixed| = {worst_fixed:.2e}, |Z_mesh - Z_analytic| = {worst_exact:.2e}, \
             gap along the normal {worst_gap:.2e}",
            algo.name()
        );
        assert!(compared > 1000);
        assert!(worst_fixed < 2.0 * gap_tol, "mesh vs fixed-step: {worst_fixed}");
        assert!(worst_exact < 2.0 * gap_tol, "mesh vs analytic: {worst_exact}");
        assert!(worst_gap < gap_tol, "gap along the normal: {worst_gap}");
    }
}

#[gpu_test]
fn tall_images_render_the_mesh_in_bands_identically() {
    let ctx = gpu();
    let grid = grid_from([9, 9, 9], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.length() - 0.7);
    let mut scene = scene_for(&grid, DVec3::new(0.3, 0.2, 3.0), 16, Method::Mesh);
    scene.image.width = 4096;
    scene.image.height = 600;
    scene.camera.fov_y_deg = 50.0;
    let frame = Renderer::new(&ctx).unwrap().render(&scene, &grid, 0.0).unwrap();
    assert_eq!(frame.pixels.len(), 4096 * 600);
    // Rows at the ends of each band (256 rows each) against the reference.
    let mesh =
        reference(&grid, &Request::new(0.0, Inside::Below, MeshAlgorithm::MarchingCubes)).unwrap();
    let cam = Camera::new(&scene.camera, &scene.image);
    let boxes: Vec<_> = (0..mesh.triangle_count())
        .map(|t| {
            let [a, b, c] = mesh.triangle(t).map(|i| v(mesh.positions[i as usize]));
            reference::screen_box(&cam, a, b, c)
        })
        .collect();
    for row in [0u32, 255, 256, 300, 511, 512, 599] {
        for col in (0..4096).step_by(97) {
            let tr = reference::trace(&mesh, &cam, &isoview::vocab::Clip::NONE, &boxes, col, row);
            let p = frame.pixel(col, row);
            if tr.margin > EDGE_MARGIN {
                assert_eq!(p.is_hit(), tr.hit.is_some(), "({col},{row})");
                assert_eq!(p.crossings as u32, tr.hits, "({col},{row})");
            }
        }
    }
}
