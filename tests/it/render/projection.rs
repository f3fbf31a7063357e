//! `camera.projection = "orthographic"` (with `ortho_height`) and `camera.fit`, for every
//! method in [`Method::ALL`]: GPU = the f64 references, parallel rays seen in the pictures, and
//! the scene keys with their errors.

use std::path::Path;

use glam::DVec3;
use isoview::camera::Camera;
use isoview::field::GridLimits;
use isoview::render::Renderer;
use isoview::scene::{self, Inside, Method, Projection, Scene};

use crate::common::*;

fn orthographic(mut scene: Scene, height: f64) -> Scene {
    scene.camera.projection = Projection::Orthographic;
    scene.camera.ortho_height = height;
    scene
}

/// The plane f = z viewed straight down z: every ray is parallel, so the plane's depth is the
/// same in every pixel and each hit lies under its pixel's centre on the image plane. A
/// perspective camera fails both.
#[gpu_test]
fn orthographic_rays_are_parallel_in_every_method() {
    let ctx = gpu();
    let grid = grid_from([5, 6, 7], DVec3::splat(-1.0), DVec3::ONE, |p| p.z);
    for method in Method::ALL {
        let mut renderer = Renderer::new(&ctx).unwrap();
        let mut scene = orthographic(scene_for(&grid, DVec3::new(0.0, -0.2, 3.0), 24, method), 1.5);
        scene.camera.target = DVec3::new(0.0, -0.2, 0.0);
        scene.surface.isovalue = 0.25;
        scene.image.width = 32;
        let frame = renderer.render(&scene, &grid, 0.0).unwrap();
        let cam = Camera::for_scene(&scene);
        for py in 0..scene.image.height {
            for px in 0..scene.image.width {
                let p = frame.pixel(px, py);
                assert!(p.is_hit(), "{method:?} ({px},{py}): the plane fills the view");
                assert!((p.depth as f64 - 2.75).abs() < 1e-5, "{method:?}: depth {}", p.depth);
                let (o, _) = cam.ray(px, py);
                let pos = v3(p.position);
                assert!((pos.truncate() - o.truncate()).length() < 1e-5, "{method:?}: {pos} {o}");
                assert!((pos.z - 0.25).abs() < 1e-5, "{method:?}");
            }
        }
        // The picture spans 1.5 high and 2 wide (32 x 24): corner centres 1/32 and 1/24 in.
        let c = v3(frame.pixel(0, 0).position);
        let want = DVec3::new(-1.0 + 1.0 / 32.0, -0.2 + 0.75 - 0.75 / 24.0, 0.25);
        assert!((c - want).length() < 1e-5, "{method:?}: top-left hit {c}, want {want}");
        assert!(frame.info.extra.iter().any(|(k, v)| k == "projection" && v == "orthographic"));
    }
}

/// GPU = reference for orthographic views of random smooth fields, every method, from outside
/// and from inside the box (the image plane then cuts through the surface).
#[gpu_test]
fn orthographic_gpu_equals_reference() {
    let ctx = gpu();
    let mut rng = Rng::new(41);
    for method in Method::ALL {
        let mut renderer = Renderer::new(&ctx).unwrap();
        for case in 0..3 {
            let k = rng.unit_vector() * 3.0;
            let grid = grid_from([10, 9 + case, 11], DVec3::splat(-1.0), DVec3::ONE, |p| {
                p.length() - 0.65 + 0.15 * (k.dot(p)).sin()
            });
            let eye = random_eye(&mut rng, &grid, case == 2);
            let mut scene = orthographic(scene_for(&grid, eye, 36, method), rng.range(1.5, 3.0));
            scene.surface.inside = [Inside::Below, Inside::Above][case % 2];
            if method == Method::Analytic {
                scene.render.skip = case != 1;
            }
            let gpu = renderer.render(&scene, &grid, 0.0).unwrap();
            let reference = reference_pixels(&scene, &grid);
            let ag = Agreement::same(&reference, &gpu.pixels);
            let (hits, mismatched, worst_deg) = (ag.hits, ag.mismatched, ag.normal_deg);
            let worst_depth = ag.depth / 2.0;
            assert!(hits > 100, "{method:?} case {case}: {hits} hits");
            assert!(mismatched * 100 <= hits, "{method:?} case {case}: {mismatched} hit/miss");
            let (depth_tol, deg_tol) = match method {
                Method::Analytic | Method::Mesh => (1e-5, 0.5),
                Method::FixedStep => (2e-2, 10.0),
            };
            assert!(
                worst_depth < depth_tol && worst_deg < deg_tol,
                "{method:?} case {case}: depth {worst_depth:e}, normal {worst_deg} deg"
            );
        }
    }
}

fn parse(text: &str, sets: &[&str]) -> Result<Scene, String> {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    scene::from_str_with(text, "t.toml", Path::new("."), &sets, &GridLimits::default())
        .map_err(|e| e.to_string())
}

const BOX: &str = r#"
[image]
width = 200
height = 100
[camera]
eye = [5, 1, 2]
target = [4, 1, 2]
fov_y_deg = 30
[field]
source = "expr"
expression = "x"
resolution = [4, 4, 4]
bounds = { min = [1, 2, 3], max = [3, 6, 4] }
"#;

#[test]
fn fit_aims_at_the_box_and_fits_its_bounding_sphere() {
    let s = parse(BOX, &["camera.fit=true"]).unwrap();
    let centre = DVec3::new(2.0, 4.0, 3.5);
    let radius = 0.5 * DVec3::new(2.0, 4.0, 1.0).length();
    assert!((s.camera.target - centre).length() < 1e-12);
    // The view direction is kept: +x to -x.
    let forward = (s.camera.target - s.camera.eye).normalize();
    assert!((forward - DVec3::NEG_X).length() < 1e-12);
    // The sphere's silhouette touches the top and bottom (the narrower side): its angular
    // radius is half the vertical field of view.
    let distance = (s.camera.eye - centre).length();
    assert!(((radius / distance).asin().to_degrees() - 15.0).abs() < 1e-9, "{distance}");
    // Every corner of the box is in the picture.
    let cam = Camera::new(&s.camera, &s.image);
    for n in 0..8 {
        let c = DVec3::new([1.0, 3.0][n & 1], [2.0, 6.0][(n >> 1) & 1], [3.0, 4.0][(n >> 2) & 1]);
        let q = c - cam.eye;
        let z = q.dot(cam.forward);
        let sx = q.dot(cam.right_scaled) / (cam.right_scaled.length_squared() * z);
        let sy = q.dot(cam.up_scaled) / (cam.up_scaled.length_squared() * z);
        assert!(sx.abs() <= 1.0 && sy.abs() <= 1.0, "corner {c} at ({sx}, {sy})");
    }
    // Orthographic: the diameter fills the narrower side.
    let o = parse(BOX, &["camera.fit=true", "camera.projection=orthographic"]).unwrap();
    assert_eq!(o.camera.projection, Projection::Orthographic);
    assert!((o.camera.ortho_height - 2.0 * radius).abs() < 1e-12);
    // An explicit height wins over the fit's.
    let o =
        parse(BOX, &["camera.fit=true", "camera.projection=orthographic", "camera.ortho_height=9"]);
    assert_eq!(o.unwrap().camera.ortho_height, 9.0);
}

#[test]
fn ortho_height_defaults_to_the_perspective_framing_of_the_target() {
    let s = parse(BOX, &["camera.projection=\"orthographic\""]).unwrap();
    // |target - eye| = 1, fov 30: 2 tan 15 deg.
    assert!((s.camera.ortho_height - 2.0 * 15f64.to_radians().tan()).abs() < 1e-12);
    assert_eq!(parse(BOX, &[]).unwrap().camera.projection, Projection::Perspective);
}

#[test]
fn projection_keys_are_checked() {
    let e = parse(BOX, &["camera.projection=\"fisheye\""]).unwrap_err();
    assert!(e.contains("camera.projection") && e.contains("orthographic"), "{e}");
    let e = parse(BOX, &["camera.projection=orthographic", "camera.ortho_height=0"]).unwrap_err();
    assert!(e.contains("camera.ortho_height") && e.contains("positive"), "{e}");
    let e = parse(BOX, &["camera.fit=1"]).unwrap_err();
    assert!(e.contains("camera.fit"), "{e}");
}
