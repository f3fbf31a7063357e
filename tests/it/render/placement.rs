//! Grids placed in world space by a rigid map (`vocab::Placement`: a scan header's orientation).
//! Every method traces in the grid's own frame and moves its outputs to world space; these
//! tests check that this is the world picture, for every method in [`Method::ALL`]:
//!
//! - a placed grid seen by a camera moved with it is the unplaced grid's picture, with
//!   positions and normals moved (depth, colour, steps, cells unchanged);
//! - a sphere sampled in an oblique, mirrored frame is drawn where the sphere is in world space;
//! - the GPU agrees with the f64 references on placed grids;
//! - a placed mesh keeps its normals outward (winding reversed under a mirror).

use glam::{DMat3, DVec3};
use isoview::field::FieldSpec;
use isoview::mesh::{self, ExtractOptions};
use isoview::render::Renderer;
use isoview::scene::{Inside, MeshAlgorithm, Method, Scene};
use isoview::vocab::Placement;

use crate::common::*;

/// A rotation by `angle` about `axis`, about `pivot`; with `mirror`, x is flipped first.
fn placement(axis: DVec3, angle: f64, pivot: DVec3, mirror: bool) -> Placement {
    let flip = DMat3::from_diagonal(DVec3::new(if mirror { -1.0 } else { 1.0 }, 1.0, 1.0));
    let m = DMat3::from_axis_angle(axis.normalize(), angle) * flip;
    Placement::from_axes(pivot, [m.x_axis, m.y_axis, m.z_axis]).unwrap()
}

fn placed(scene: &Scene, p: Placement) -> Scene {
    let mut s = scene.clone();
    s.field.placement = p;
    s
}

/// A placed grid seen by the camera moved with it gives the unplaced picture, moved: the
/// placement is the world picture, not an approximation of it.
#[gpu_test]
fn a_placed_grid_seen_by_the_moved_camera_is_the_unplaced_picture_moved() {
    let ctx = gpu();
    let mut rng = Rng::new(77);
    for method in Method::ALL {
        let mut renderer = Renderer::new(&ctx).unwrap();
        let grid = grid_from([12, 10, 9], DVec3::new(-1.0, -0.8, -0.7), DVec3::ONE, |p| {
            (2.0 * p.x).sin() + (3.0 * p.y).cos() * 0.7 + p.z * p.z - 0.4
        });
        let eye = random_eye(&mut rng, &grid, false);
        let scene = scene_for(&grid, eye, 40, method);
        let pl =
            placement(rng.unit_vector(), rng.range(0.3, 2.5), DVec3::new(0.4, -2.0, 1.5), false);
        let mut moved = placed(&scene, pl);
        moved.camera.eye = pl.point_to_world(scene.camera.eye);
        moved.camera.target = pl.point_to_world(scene.camera.target);
        moved.camera.up = pl.vector_to_world(scene.camera.up);
        let a = renderer.render(&scene, &grid, 0.0).unwrap();
        let b = renderer.render(&moved, &grid, 0.0).unwrap();
        let diag = (grid.max - grid.min).length();
        let ag = Agreement::of(&a.pixels, &b.pixels, |p, n| {
            (pl.point_to_world(p), pl.vector_to_world(n))
        });
        let (mismatched, depth, pos, deg) =
            (ag.mismatched, ag.depth / diag, ag.position / diag, ag.normal_deg);
        let hits = a.pixels.iter().filter(|p| p.is_hit()).count();
        assert!(hits > 200, "{method:?}: only {hits} hits");
        // The moved camera's rays equal the original ones to ~1e-16 before rounding to f32:
        // at most a silhouette pixel may flip.
        assert!(mismatched <= 2, "{method:?}: {mismatched} pixels hit in one picture only");
        assert!(depth < 1e-5 && pos < 1e-5 && deg < 0.05, "{method:?}: {depth} {pos} {deg}");
        let same =
            a.pixels.iter().zip(&b.pixels).filter(|(a, b)| {
                a.is_hit() && b.is_hit() && a.cell == b.cell && a.steps == b.steps
            });
        assert!(same.count() + 4 >= hits, "{method:?}: cells or steps moved");
        assert!(
            b.info.extra.iter().any(|(k, v)| k == "placement" && v.starts_with("pivot [0.4, -2")),
            "{method:?}: the header records the placement: {:?}",
            b.info.extra
        );
        assert!(!a.info.extra.iter().any(|(k, _)| k == "placement"), "{method:?}");
    }
}

/// The sphere |w - c| = r sampled on a grid whose frame is rotated and mirrored: every method
/// draws it around `c` in world space, normals pointing away from `c`. Without the
/// placement the hits would be elsewhere.
#[gpu_test]
fn a_sphere_sampled_in_an_oblique_mirrored_frame_is_drawn_where_it_is() {
    let ctx = gpu();
    let (min, max) = (DVec3::new(2.0, 1.0, -3.0), DVec3::new(4.0, 3.2, -1.0));
    let pl = placement(DVec3::new(1.0, -2.0, 0.7), 1.1, min, true);
    let centre = pl.point_to_world(0.5 * (min + max));
    let r = 0.75;
    let grid = grid_from([33, 35, 33], min, max, |p| (pl.point_to_world(p) - centre).length() - r);
    for method in Method::ALL {
        let mut renderer = Renderer::new(&ctx).unwrap();
        let mut scene = Scene::new(FieldSpec::from_grid(grid.clone()));
        scene.field.placement = pl;
        scene.image.width = 48;
        scene.image.height = 48;
        scene.render.method = method;
        scene.camera.eye = centre + DVec3::new(0.5, 1.0, 3.5);
        scene.camera.target = centre;
        let frame = renderer.render(&scene, &grid, 0.0).unwrap();
        let mut hits = 0;
        for p in frame.pixels.iter().filter(|p| p.is_hit()) {
            hits += 1;
            let w = v3(p.position);
            let off = (w - centre).length() - r;
            assert!(off.abs() < 0.02, "{method:?}: hit {w} is {off} off the sphere");
            let cos = v3(p.normal).normalize().dot((w - centre).normalize());
            assert!(cos > 0.99, "{method:?}: normal {:?} at {w}: cos {cos}", p.normal);
            let seen = (w - scene.camera.eye).length();
            assert!(
                (seen - p.depth as f64).abs() < 1e-4,
                "{method:?}: depth {} vs {seen}",
                p.depth
            );
        }
        // The sphere covers about a third of the picture from there.
        assert!(hits > 48 * 48 / 6, "{method:?}: {hits} hits");
    }
}

/// The GPU's picture of a placed grid equals the method's f64 reference (which places its
/// pixels through the same rule), at the tolerances of the unplaced comparisons.
#[gpu_test]
fn gpu_equals_reference_on_placed_grids() {
    let ctx = gpu();
    let mut rng = Rng::new(5);
    for method in Method::ALL {
        let mut renderer = Renderer::new(&ctx).unwrap();
        for case in 0..3 {
            let grid = grid_from([9 + case, 8, 10], DVec3::splat(-1.0), DVec3::ONE, |p| {
                p.length() - 0.6 + 0.2 * (3.0 * p.x).sin() * (2.0 * p.z).cos()
            });
            let pl =
                placement(rng.unit_vector(), rng.range(0.2, 3.0), rng.unit_vector(), case == 1);
            let mut scene = placed(&scene_for(&grid, DVec3::ZERO, 36, method), pl);
            scene.camera.target = pl.point_to_world(DVec3::ZERO);
            scene.camera.eye = scene.camera.target + rng.unit_vector() * 3.5;
            scene.surface.inside = [Inside::Below, Inside::Above][case % 2];
            if method == Method::Analytic {
                scene.render.skip = false;
            }
            let gpu = renderer.render(&scene, &grid, 0.0).unwrap();
            let reference = reference_pixels(&scene, &grid);
            let ag = Agreement::same(&reference, &gpu.pixels);
            let diag = 2.0 * 3f64.sqrt();
            let (mismatched, depth, pos, deg) =
                (ag.mismatched, ag.depth / diag, ag.position / diag, ag.normal_deg);
            let hits = reference.iter().filter(|p| p.is_hit()).count();
            assert!(hits > 100, "{method:?} case {case}: {hits} hits");
            assert!(mismatched * 100 <= hits, "{method:?} case {case}: {mismatched} hit/miss");
            let (depth_tol, deg_tol) = match method {
                Method::Analytic | Method::Mesh => (1e-5, 0.5),
                // Fixed-step: the GPU's f32 sample positions may pick the neighbouring step.
                Method::FixedStep => (2e-2, 10.0),
            };
            assert!(
                depth < depth_tol && pos < depth_tol * 2.0 && deg < deg_tol,
                "{method:?} case {case}: depth {depth:e} position {pos:e} normal {deg} deg"
            );
        }
    }
}

/// A placed mesh: positions and normals moved; under a mirror, every triangle's winding is
/// reversed so its geometric normal still agrees with the vertex normals (points outward).
#[test]
fn a_placed_mesh_keeps_its_normals_outward() {
    let grid = grid_from([10, 11, 12], DVec3::splat(-1.0), DVec3::ONE, |p| p.length() - 0.7);
    for mirror in [false, true] {
        let pl = placement(DVec3::new(0.3, 1.0, -0.4), 0.9, DVec3::new(1.0, 2.0, 3.0), mirror);
        for algorithm in MeshAlgorithm::ALL {
            let opts = ExtractOptions { keep_quads: true, ..Default::default() };
            let m = mesh::reference(
                &grid,
                &mesh::Request::new(0.0, Inside::Below, algorithm).with_opts(opts),
            )
            .unwrap();
            let mut w = m.clone();
            w.place(&pl);
            assert_eq!(w.vertex_count(), m.vertex_count());
            for (a, b) in m.positions.iter().zip(&w.positions) {
                assert!((pl.point_to_world(v3(*a)) - v3(*b)).length() < 1e-5);
            }
            let centre = pl.point_to_world(DVec3::ZERO);
            let mut agree = 0;
            for t in 0..w.triangle_count() {
                let [a, b, c] = w.triangle(t).map(|i| v3(w.positions[i as usize]));
                let g = (b - a).cross(c - a);
                let n: DVec3 = w.triangle(t).iter().map(|&i| v3(w.normals[i as usize])).sum();
                agree += (g.dot(n) > 0.0 && g.dot(a - centre) > 0.0) as usize;
            }
            assert!(
                agree * 100 >= w.triangle_count() * 99,
                "{algorithm:?} mirror {mirror}: {agree} of {} triangles face out",
                w.triangle_count()
            );
            if let (Some(q), Some(q0)) = (&w.quads, &m.quads) {
                assert_eq!(q.len(), q0.len());
                // Each quad's two triangles are still triangles 2q and 2q + 1.
                for (n, quad) in q.chunks_exact(4).enumerate() {
                    for t in [2 * n, 2 * n + 1] {
                        assert!(w.triangle(t).iter().all(|v| quad.contains(v)), "{algorithm:?}");
                    }
                }
            }
        }
    }
}

/// Headers store direction cosines rounded; nearly orthogonal axes are accepted and made
/// exactly orthonormal, sheared ones are refused with the angle.
#[test]
fn placement_from_axes_accepts_rounded_axes_and_refuses_shear() {
    let r = DMat3::from_axis_angle(DVec3::new(1.0, 1.0, 0.2).normalize(), 0.6);
    let rounded = [r.x_axis, r.y_axis, r.z_axis].map(|a| (a * 1e6).round() / 1e6 * 0.8);
    let p = Placement::from_axes(DVec3::ONE, rounded).unwrap();
    assert!((p.axes.transpose() * p.axes - DMat3::IDENTITY).abs_diff_eq(DMat3::ZERO, 1e-12));
    assert!((p.axes.x_axis - r.x_axis).length() < 1e-5 && !p.mirrors());
    let mirrored = Placement::from_axes(DVec3::ZERO, [-r.x_axis, r.y_axis, r.z_axis]).unwrap();
    assert!(mirrored.mirrors());
    let sheared = [DVec3::X, DVec3::new(0.1, 1.0, 0.0), DVec3::Z];
    let e = Placement::from_axes(DVec3::ZERO, sheared).unwrap_err();
    assert!(e.contains("sheared") && e.contains("84.2"), "{e}");
    assert!(Placement::from_axes(DVec3::ZERO, [DVec3::X, DVec3::ZERO, DVec3::Z]).is_err());
}
