//! What every render method must do: one test per property, looping over [`Method::ALL`], so a
//! new method is tested as soon as it joins `ALL`; where methods differ (a grid, what a pixel
//! records) a `match` without a catch-all arm says so, and fails to compile until the new method
//! is placed. Every failure message names the method.

use glam::DVec3;
use isoview::gpu::{validation_messages, Context, ContextOptions};
use isoview::render::Renderer;
use isoview::scene::{Inside, Method};

use crate::common::*;

/// A render under the validation layer reports nothing, and leaves nothing alive when its
/// context goes (the layer reports objects still alive at `vkDestroyDevice`).
#[gpu_test]
fn validation_layer_reports_nothing_for_a_render() {
    for method in Method::ALL {
        let ctx = Context::new(&ContextOptions { device: None, validation: true }).expect(
            "Vulkan with VK_LAYER_KHRONOS_validation (apt-get install vulkan-validationlayers)",
        );
        let dims = match method {
            Method::Analytic => [19, 18, 17],
            Method::FixedStep | Method::Mesh => [9, 8, 7],
        };
        let grid = grid_from(dims, DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.length() - 0.7);
        let scene = scene_for(&grid, DVec3::new(0.3, 0.2, 3.0), 24, method);
        let before = validation_messages();
        let frame = Renderer::new(&ctx).unwrap().render(&scene, &grid, 0.0).unwrap();
        drop(ctx);
        assert!(frame.pixels.iter().any(|p| p.is_hit()), "{method:?}: no hit");
        assert_eq!(
            validation_messages(),
            before,
            "{method:?}: validation warnings or errors (printed above)"
        );
    }
}

/// f = x + 2y - z: the surface f = 0.1 is a plane with normal (1, 2, -1)/sqrt(6), which every
/// method draws exactly (the mesh too: every algorithm's mesh of f = 0.1 lies in the plane, dual
/// methods inside the grid, marching cubes exactly).
#[gpu_test]
fn linear_field_renders_an_exact_plane() {
    let ctx = gpu();
    let grid =
        grid_from([6, 5, 7], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.x + 2.0 * p.y - p.z);
    for method in Method::ALL {
        let mut renderer = Renderer::new(&ctx).unwrap();
        // The inside modes drawn, and whether pixels count crossings (fixed-step writes no
        // crossings channel).
        let (insides, counts_crossings): (&[Inside], bool) = match method {
            Method::Analytic => (&Inside::ALL, true),
            Method::Mesh => (&[Inside::Below], true),
            Method::FixedStep => (&[Inside::Below], false),
        };
        for &inside in insides {
            let mut scene = scene_for(&grid, DVec3::new(2.5, 1.0, 3.0), 48, method);
            if method == Method::Analytic {
                scene.render.skip = false;
            }
            scene.surface.isovalue = 0.1;
            scene.surface.inside = inside;
            let frame = renderer.render(&scene, &grid, 0.0).unwrap();
            let sign = if inside == Inside::Below { 1.0 } else { -1.0 };
            let n = DVec3::new(1.0, 2.0, -1.0).normalize() * sign;
            let mut hits = 0;
            for p in &frame.pixels {
                if !p.is_hit() {
                    if counts_crossings {
                        assert!(
                            p.crossings == 0,
                            "{method:?} {inside:?}: a ray that misses the plane crosses \
                             nothing: {p:?}"
                        );
                    }
                    continue;
                }
                hits += 1;
                let pos = DVec3::from(p.position.map(f64::from));
                assert!(
                    (pos.dot(DVec3::new(1.0, 2.0, -1.0)) - 0.1).abs() < 1e-5,
                    "{method:?} {inside:?}: {pos} off the plane"
                );
                assert!(
                    (DVec3::from(p.normal.map(f64::from)) - n).length() < 1e-5,
                    "{method:?} {inside:?}: normal {:?}",
                    p.normal
                );
                let eye_dist = (pos - scene.camera.eye).length();
                assert!(
                    (eye_dist - p.depth as f64).abs() < 1e-5,
                    "{method:?} {inside:?}: depth {} at {eye_dist}",
                    p.depth
                );
                if counts_crossings {
                    assert_eq!(p.crossings, 1, "{method:?} {inside:?}");
                }
            }
            assert!(
                hits > 150,
                "{method:?} {inside:?}: the plane covers part of the image: {hits}"
            );
            assert_eq!(frame.info.method, method.name(), "{method:?}");
        }
    }
}
