//! `render.normals = "smooth"`: the trilinear interpolation of per-point central-difference
//! gradients, for every method in [`Method::ALL`]: GPU = the f64 reference, exact on fields
//! that central differences differentiate exactly, continuous across cell faces (where the
//! exact trilinear gradient jumps), and smoother pictures of coarse grids.

use glam::DVec3;
use isoview::reference::field::{gradient_at, smooth_gradient_at};
use isoview::render::Renderer;
use isoview::scene::{Inside, Method, Normals};

use crate::common::*;

/// Central differences are exact for quadratics inside the grid, and one-sided differences
/// for linear fields on its faces: there the smooth gradient is the field's own.
#[test]
fn smooth_gradient_is_exact_where_differences_are() {
    let (a, b) = (DVec3::new(0.3, -1.2, 0.7), DVec3::new(0.5, 0.25, -0.75));
    let linear = grid_from([5, 6, 4], DVec3::new(-1.0, 0.0, 2.0), DVec3::new(1.0, 3.0, 3.0), |p| {
        a.dot(p) + 0.1
    });
    for u in [DVec3::ZERO, DVec3::new(4.0, 5.0, 3.0), DVec3::new(1.3, 2.7, 0.2)] {
        assert!((smooth_gradient_at(&linear, u) - a).length() < 1e-5, "{u}");
    }
    // f = b.(p*p): at interior grid points the central difference is exact, 2 b p.
    let quad = grid_from([7, 7, 7], DVec3::splat(-1.5), DVec3::splat(1.5), |p| b.dot(p * p));
    for u in [DVec3::new(2.0, 3.0, 4.0), DVec3::new(1.0, 5.0, 2.0)] {
        let p = quad.point(u.x as usize, u.y as usize, u.z as usize);
        assert!((smooth_gradient_at(&quad, u) - 2.0 * b * p).length() < 1e-5, "{u}");
    }
}

/// Across a cell face the smooth gradient is continuous; the exact trilinear one jumps.
#[test]
fn smooth_gradient_is_continuous_across_cell_faces() {
    let mut rng = Rng::new(9);
    let grid = random_grid(&mut rng, [6, 6, 6]);
    let (mut smooth_jump, mut exact_jump) = (0.0f64, 0.0f64);
    for _ in 0..200 {
        let mut u = DVec3::new(rng.range(0.0, 5.0), rng.range(0.0, 5.0), rng.range(0.0, 5.0));
        let axis = (rng.next_u64() % 3) as usize;
        u[axis] = 1.0 + (rng.next_u64() % 4) as f64; // an interior cell face
        let (mut lo, mut hi) = (u, u);
        lo[axis] -= 1e-9;
        hi[axis] += 1e-9;
        let d = |f: &dyn Fn(DVec3) -> DVec3| (f(hi) - f(lo)).length();
        smooth_jump = smooth_jump.max(d(&|x| smooth_gradient_at(&grid, x)));
        exact_jump = exact_jump.max(d(&|x| gradient_at(&grid, x)));
    }
    assert!(smooth_jump < 1e-6, "smooth gradient jumps by {smooth_jump}");
    assert!(exact_jump > 0.1, "the exact gradient should jump across faces: {exact_jump}");
}

/// GPU = reference with smooth normals, every method; the same hits and depths as with
/// trilinear normals (only normals and colours change).
#[gpu_test]
fn smooth_normals_gpu_equals_reference() {
    let ctx = gpu();
    let mut rng = Rng::new(23);
    for method in Method::ALL {
        let mut renderer = Renderer::new(&ctx).unwrap();
        for case in 0..3 {
            let k = rng.unit_vector() * 4.0;
            let grid = grid_from([8 + case, 9, 7], DVec3::splat(-1.0), DVec3::ONE, |p| {
                p.length() - 0.6 + 0.2 * k.dot(p).sin()
            });
            let eye = random_eye(&mut rng, &grid, false);
            let mut scene = scene_for(&grid, eye, 40, method);
            scene.surface.inside = [Inside::Below, Inside::Above][case % 2];
            let exact = renderer.render(&scene, &grid, 0.0).unwrap();
            scene.render.normals = Normals::Smooth;
            let gpu = renderer.render(&scene, &grid, 0.0).unwrap();
            assert!(gpu.info.extra.iter().any(|(k, v)| k == "normals" && v == "smooth"));
            let reference = reference_pixels(&scene, &grid);
            let (mut hits, mut mismatched, mut worst, mut changed) = (0, 0, 0.0f64, 0);
            for ((g, r), e) in gpu.pixels.iter().zip(&reference).zip(&exact.pixels) {
                assert_eq!((g.depth.to_bits(), g.cell), (e.depth.to_bits(), e.cell), "{method:?}");
                hits += r.is_hit() as usize;
                if g.is_hit() != r.is_hit() {
                    mismatched += 1;
                    continue;
                }
                if !r.is_hit() {
                    continue;
                }
                let cos = v3(g.normal).dot(v3(r.normal)).clamp(-1.0, 1.0);
                worst = worst.max(cos.acos().to_degrees());
                changed += ((v3(g.normal) - v3(e.normal)).length() > 1e-3) as usize;
            }
            assert!(hits > 100 && mismatched * 100 <= hits, "{method:?}: {hits} {mismatched}");
            let tol = if method == Method::FixedStep { 10.0 } else { 0.5 };
            assert!(worst < tol, "{method:?} case {case}: normals {worst} degrees apart");
            assert!(changed * 2 > hits, "{method:?}: smooth normals changed only {changed}");
        }
    }
}

/// A sphere on a coarse grid: neighbouring pixels whose hits lie in different cells turn their
/// normals about as much as neighbours within one cell with smooth normals, but much more with
/// the exact trilinear ones (whose gradient jumps across the face: the faceting).
#[gpu_test]
fn smooth_normals_soften_the_cell_faces_of_a_coarse_sphere() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let grid = grid_from([7, 7, 7], DVec3::splat(-1.0), DVec3::ONE, |p| p.length() - 0.7);
    let mut scene = scene_for(&grid, DVec3::new(1.2, 0.9, 2.6), 96, Method::Analytic);
    // Mean turn between horizontal neighbours across a cell face over the mean within a cell.
    let faceting = |frame: &isoview::frame::Frame| {
        let (mut across, mut within) = ((0.0, 0), (0.0, 0));
        for y in 0..96 {
            for x in 0..95 {
                let (a, b) = (frame.pixel(x, y), frame.pixel(x + 1, y));
                if !(a.is_hit() && b.is_hit()) {
                    continue;
                }
                let turn = v3(a.normal).dot(v3(b.normal)).clamp(-1.0, 1.0).acos();
                let sum = if a.cell != b.cell { &mut across } else { &mut within };
                sum.0 += turn;
                sum.1 += 1;
            }
        }
        assert!(across.1 > 50 && within.1 > 500, "{across:?} {within:?}");
        (across.0 / across.1 as f64) / (within.0 / within.1 as f64)
    };
    let exact = faceting(&renderer.render(&scene, &grid, 0.0).unwrap());
    scene.render.normals = Normals::Smooth;
    let smooth = faceting(&renderer.render(&scene, &grid, 0.0).unwrap());
    assert!(
        smooth < 1.5 && exact > 2.0 * smooth,
        "turn across cell faces over turn within cells: smooth {smooth}, exact {exact}"
    );
}
