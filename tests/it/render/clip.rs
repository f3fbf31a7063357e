//! `[[clip]]` planes and boxes, for every method in [`Method::ALL`]: the surface is cut open
//! exactly (no hit in a removed half-space, every kept hit unchanged), GPU = the f64
//! references on random planes (placed grids too), and the scene keys with their errors.

use std::path::Path;

use glam::DVec3;
use isoview::field::GridLimits;
use isoview::render::Renderer;
use isoview::scene::{self, Inside, Method, Scene};
use isoview::vocab::{Clip, Placement};

use crate::common::*;

/// A sphere cut by the plane x = 0.1 (x > 0.1 removed), seen from +x: no hit beyond the
/// plane, the far half's inner wall shows through the cut, and every pixel whose unclipped hit
/// was already kept finds the same hit (the analytic walk then starts at the plane, so it
/// visits fewer cells and its root's last bits may differ).
#[gpu_test]
fn a_clip_plane_cuts_the_surface_open_exactly() {
    let ctx = gpu();
    let grid = grid_from([17, 17, 17], DVec3::splat(-1.0), DVec3::ONE, |p| p.length() - 0.7);
    for method in Method::ALL {
        let mut renderer = Renderer::new(&ctx).unwrap();
        let mut scene = scene_for(&grid, DVec3::new(1.2, 0.8, 2.4), 48, method);
        let whole = renderer.render(&scene, &grid, 0.0).unwrap();
        scene.clip.push(DVec3::X, 0.1);
        let cut = renderer.render(&scene, &grid, 0.0).unwrap();
        assert!(cut.info.extra.iter().any(|(k, v)| k == "clip" && v == "[1, 0, 0] 0.1"));
        let (mut inner, mut same) = (0, 0);
        for (w, c) in whole.pixels.iter().zip(&cut.pixels) {
            if c.is_hit() {
                let p = v3(c.position);
                assert!(p.x <= 0.1 + 1e-5, "{method:?}: a hit at {p} in the removed half");
                // Through the cut the ray meets the inner wall: a normal facing away.
                let dir = (p - scene.camera.eye).normalize();
                inner += (v3(c.normal).dot(dir) > 0.0) as usize;
            }
            if w.is_hit() && v3(w.position).x < 0.1 - 1e-3 {
                assert!(c.is_hit() && w.cell == c.cell, "{method:?}: {w:?} became {c:?}");
                let moved = (v3(w.position) - v3(c.position)).length();
                let turned = (v3(w.normal) - v3(c.normal)).length();
                assert!(moved < 1e-5 && turned < 1e-4, "{method:?}: {w:?} became {c:?}");
                same += 1;
            }
        }
        assert!(inner > 100, "{method:?}: only {inner} pixels see the inside through the cut");
        assert!(same > 20, "{method:?}: {same}");
    }
}

/// GPU = reference under random planes and boxes, on unplaced and placed grids.
#[gpu_test]
fn clipped_gpu_equals_reference() {
    let ctx = gpu();
    let mut rng = Rng::new(61);
    for method in Method::ALL {
        let mut renderer = Renderer::new(&ctx).unwrap();
        for case in 0..4 {
            let k = rng.unit_vector() * 3.0;
            let grid = grid_from([11, 10, 9 + case], DVec3::splat(-1.0), DVec3::ONE, |p| {
                p.length() - 0.7 + 0.12 * k.dot(p).sin()
            });
            let eye = random_eye(&mut rng, &grid, false);
            let mut scene = scene_for(&grid, eye, 40, method);
            scene.surface.inside = [Inside::Below, Inside::Above][case % 2];
            for _ in 0..1 + case % 2 {
                scene.clip.push(rng.unit_vector(), rng.range(0.05, 0.45));
            }
            if case == 3 {
                let axis = rng.unit_vector();
                let m = glam::DMat3::from_axis_angle(axis, 0.8);
                let pl = Placement::from_axes(DVec3::ZERO, [m.x_axis, m.y_axis, m.z_axis]);
                scene.field.placement = pl.unwrap();
            }
            let gpu = renderer.render(&scene, &grid, 0.0).unwrap();
            let reference = reference_pixels(&scene, &grid);
            let ag = Agreement::same(&reference, &gpu.pixels);
            let (hits, mismatched, depth) = (ag.hits, ag.mismatched, ag.depth);
            assert!(hits > 40, "{method:?} case {case}: {hits} hits");
            assert!(mismatched * 50 <= hits, "{method:?} case {case}: {mismatched} hit/miss");
            let tol = if method == Method::FixedStep { 5e-2 } else { 3e-5 };
            assert!(depth < tol, "{method:?} case {case}: depth {depth:e}");
        }
    }
}

#[test]
fn clip_interval_keeps_the_intersection_of_the_half_spaces() {
    let mut c = Clip::NONE;
    assert_eq!(c.interval(DVec3::ZERO, DVec3::X), Some((f64::NEG_INFINITY, f64::INFINITY)));
    c.push(DVec3::X, 1.0); // x <= 1
    c.push(DVec3::new(-2.0, 0.0, 0.0), 1.0); // -2x <= 1: x >= -0.5
    assert_eq!(c.interval(DVec3::new(-3.0, 5.0, 0.0), DVec3::X), Some((2.5, 4.0)));
    // Parallel to a plane: wholly kept or wholly removed.
    assert!(c.interval(DVec3::new(2.0, 0.0, 0.0), DVec3::Y).is_none());
    assert!(c.interval(DVec3::new(0.5, 0.0, 0.0), DVec3::Y).is_some());
    // The same planes in a rotated frame give the same interval for the same ray.
    let m = glam::DMat3::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 1.0);
    let pl =
        Placement::from_axes(DVec3::new(0.5, -1.0, 2.0), [m.x_axis, m.y_axis, m.z_axis]).unwrap();
    let g = c.in_grid_frame(&pl);
    let (o, d) = (DVec3::new(-3.0, 5.0, 0.0), DVec3::X);
    let (a, b) = g.interval(pl.point_to_grid(o), pl.vector_to_grid(d)).unwrap();
    assert!((a - 2.5).abs() < 1e-12 && (b - 4.0).abs() < 1e-12, "{a} {b}");
}

fn parse(text: &str) -> Result<Scene, String> {
    scene::from_str_with(text, "t.toml", Path::new("."), &[], &GridLimits::default())
        .map_err(|e| e.to_string())
}

const CELL: &str = "[field]\nsource = \"corners\"\nvalues = [-1, 1, 1, 1, 1, 1, 1, 1]\n";

#[test]
fn clip_tables_are_read_and_checked() {
    let s = parse(&format!(
        "{CELL}[[clip]]\nnormal = [0, 0, 2]\noffset = 0.5\n[[clip]]\nbox = {{ min = [0, 0, 0], max = [1, 2, 3] }}\n"
    ))
    .unwrap();
    assert_eq!(s.clip.count, 7);
    assert_eq!(s.clip.planes()[0], (DVec3::new(0.0, 0.0, 2.0), 0.5));
    // A box: +x <= max.x, -x <= -min.x, then y, then z.
    assert_eq!(s.clip.planes()[3], (DVec3::Y, 2.0));
    assert_eq!(s.clip.planes()[4], (DVec3::NEG_Y, 0.0));
    assert_eq!(s.clip.planes()[5], (DVec3::Z, 3.0));
    let e = parse(&format!("{CELL}[[clip]]\nnormal = [0, 0, 0]\n")).unwrap_err();
    assert_eq!(e, "t.toml:5:10: clip[0].normal: must not be the zero vector");
    let e = parse(&format!(
        "{CELL}[[clip]]\nnormal = [1, 0, 0]\nbox = {{ min = [0, 0, 0], max = [1, 1, 1] }}\n"
    ))
    .unwrap_err();
    assert!(e.contains("clip[0].normal: a clip entry is a plane or a box, not both"), "{e}");
    let e = parse(&format!("{CELL}[[clip]]\noffset = 1\n")).unwrap_err();
    assert!(e.contains("clip[0].normal") && e.contains("missing"), "{e}");
    let e = parse(&format!("{CELL}[[clip]]\nnormal = [1, 0, 0]\nofset = 1\n")).unwrap_err();
    assert!(e.contains("clip[0].ofset: unknown key"), "{e}");
    let e = parse(&format!("clip = 3\n{CELL}")).unwrap_err();
    assert!(e.contains("clip") && e.contains("array of tables"), "{e}");
    let boxes = "[[clip]]\nbox = { min = [0, 0, 0], max = [1, 1, 1] }\n".repeat(3);
    let e = parse(&format!("{CELL}{boxes}")).unwrap_err();
    assert!(e.contains("clip[2].box: more than 12 clip planes"), "{e}");
}

/// `extract` with clip planes: a closed sphere mesh cut by x <= 0.1 keeps every vertex in the
/// kept half, stays welded (its only open edges lie on the plane), and keeps Archimedes' share
/// of the area: the zone's height over the diameter.
#[test]
fn a_clipped_mesh_is_cut_exactly_and_stays_welded() {
    use isoview::mesh;
    use isoview::scene::MeshAlgorithm;
    use std::collections::HashMap;

    let r = 0.7;
    let grid = grid_from([40, 40, 40], DVec3::splat(-1.0), DVec3::ONE, |p| p.length() - r);
    let whole = mesh::reference(
        &grid,
        &mesh::Request::new(0.0, Inside::Below, MeshAlgorithm::MarchingCubes),
    )
    .unwrap();
    let mut clip = Clip::NONE;
    clip.push(DVec3::new(2.0, 0.0, 0.0), 0.2); // 2x <= 0.2: x <= 0.1
    let cut = whole.clipped(&clip);
    let area = |m: &isoview::mesh::Mesh| -> f64 {
        (0..m.triangle_count())
            .map(|t| {
                let [a, b, c] = m.triangle(t).map(|v| v3(m.positions[v as usize]));
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    };
    let share = area(&cut) / area(&whole);
    let want = (r + 0.1) / (2.0 * r);
    assert!((share - want).abs() < 0.01, "area share {share}, Archimedes {want}");
    for p in &cut.positions {
        assert!(p[0] as f64 <= 0.1 + 1e-6, "vertex {p:?} in the removed half");
    }
    let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
    for t in 0..cut.triangle_count() {
        let v = cut.triangle(t);
        for i in 0..3 {
            let (a, b) = (v[i], v[(i + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let open: Vec<_> = uses.iter().filter(|(_, &n)| n == 1).collect();
    assert!(open.len() > 20, "the cut opens the sphere: {} open edges", open.len());
    for ((a, b), _) in open {
        for v in [a, b] {
            let x = cut.positions[*v as usize][0] as f64;
            assert!((x - 0.1).abs() < 1e-6, "an open edge off the cut plane at x = {x}");
        }
    }
    assert!(uses.values().all(|&n| n <= 2), "non-manifold edges after clipping");
    // Through the CLI: a [[clip]] scene's mesh file is the clipped mesh.
    let dir = scratch("clip-extract");
    let scene = write(
        &dir,
        "s.toml",
        "[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = 0.7\nresolution = [24, 24, 24]\n\
         bounds = { min = [-1, -1, -1], max = [1, 1, 1] }\n[[clip]]\nnormal = [0, 1, 0]\noffset = -0.2\n",
    );
    let ply = dir.join("m.ply").display().to_string();
    let o = isoview(&["extract", &scene, "-o", &ply, "--device", "cpu"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let m = isoview::field::TriangleMesh::read(std::path::Path::new(&ply)).unwrap();
    assert!(!m.triangles.is_empty() && m.positions.iter().all(|p| p.y <= -0.2 + 1e-6));
}

/// `Mesh::in_world`, the one place + clip of `isoview extract`: the mesh placed (here a
/// mirroring placement, which also reverses the winding) and then cut in world coordinates;
/// with no plane, only placed.
#[test]
fn in_world_places_then_clips() {
    use isoview::mesh;
    use isoview::scene::MeshAlgorithm;

    let grid = grid_from([12, 12, 12], DVec3::splat(-1.0), DVec3::ONE, |p| p.length() - 0.6);
    let x = mesh::Request::new(0.0, Inside::Below, MeshAlgorithm::MarchingCubes);
    let m = mesh::reference(&grid, &x).unwrap();
    let axes = [DVec3::Y, DVec3::X, DVec3::Z]; // swaps x and y: a mirror
    let placement = Placement::from_axes(DVec3::new(0.3, 0.0, 0.0), axes).unwrap();
    assert!(placement.mirrors());
    let mut placed = m.clone();
    placed.place(&placement);
    assert_ne!(placed, m);
    assert_eq!(m.clone().in_world(&placement, &Clip::NONE), placed);
    let mut clip = Clip::NONE;
    clip.push(DVec3::X, 0.35);
    let got = m.in_world(&placement, &clip);
    assert_eq!(got, placed.clipped(&clip));
    assert!(got.triangle_count() < placed.triangle_count());
}
