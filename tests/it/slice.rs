//! Slices: contours against the bilinear zero set and a scan-line check of their orientation on
//! random grids; loop counts of fields whose contours are known (two blobs, a ring, a saddle
//! under every ambiguity rule, contours that leave the box); refinement on the source; the GPU
//! `value` channel against its f64 reference; every shipped scene; the `[slice]` scene table;
//! and the `slice` and `probe --slice` commands.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Arc;

use glam::{DVec2, DVec3};
use isoview::field::interpolant::Interpolant;
use isoview::field::{FieldSpec, Grid, GridLimits};
use isoview::gpu::Context;
use isoview::output::exr;
use isoview::reference::field;
use isoview::render::GpuGrid;
use isoview::scene::{self, Ambiguity, Bounds, Inside, Scene, SdfShape};
use isoview::slice::image::colormap_half_range;
use isoview::slice::{
    self, extract, picture_size, Axis, Contour, ContourOptions, PlaneGrid, RootKind, SliceRenderer,
    SliceStyle, SourceField,
};

use crate::common::*;

/// Contour points may miss the bilinear zero set by this fraction of the plane's value range.
const ZERO_SET_TOL: f64 = 1e-6;
/// GPU `value` (f32) against the f64 reference: this fraction of the grid's largest |value|
/// (f32 rounding of the pixel's grid coordinates times the field's slope, and of the lerps).
const VALUE_TOL: f64 = 1e-5;

fn opts(isovalue: f64, inside: Inside, ambiguity: Ambiguity, max_depth: u32) -> ContourOptions {
    ContourOptions { isovalue, inside, ambiguity, max_depth }
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn load(text: &str, overrides: &[&str]) -> Scene {
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    scene::from_str_with(text, "t.toml", Path::new("."), &overrides, &GridLimits::default())
        .unwrap_or_else(|e| panic!("{e}"))
}

fn load_file(name: &str, overrides: &[&str]) -> Scene {
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    scene::load(&root().join("scenes").join(name), &overrides).unwrap_or_else(|e| panic!("{e}"))
}

/// The scene's contours on `axis = at`.
fn contours_of(scene: &Scene, axis: Axis, at: f64) -> (Grid, PlaneGrid, Vec<Contour>) {
    let grid = scene.field.sample(0.0).unwrap();
    let plane = PlaneGrid::new(&grid, axis, at).unwrap();
    let set = slice::scene_contours(scene, &grid, &plane, 0.0).unwrap();
    (grid, plane, set.contours)
}

/// A random plane through the grid: on a grid layer one time in three.
fn random_plane(rng: &mut Rng, grid: &Grid) -> (Axis, f64) {
    let axis = [Axis::X, Axis::Y, Axis::Z][(rng.next_u64() % 3) as usize];
    let a = axis.index();
    let at = if rng.next_u64() % 3 == 0 {
        let k = (rng.next_u64() % grid.dims[a] as u64) as usize;
        grid.point(0, 0, 0)[a] + grid.spacing()[a] * k as f64
    } else {
        rng.range(grid.min[a], grid.max[a])
    };
    (axis, at.clamp(grid.min[a], grid.max[a]))
}

/// The segments of contours, `(from, to)`, plane index coordinates.
fn segments(contours: &[Contour]) -> Vec<(DVec2, DVec2)> {
    let mut out = Vec::new();
    for c in contours {
        let n = c.points.len();
        let count = if c.closed { n } else { n - 1 };
        out.extend((0..count).map(|i| (c.points[i], c.points[(i + 1) % n])));
    }
    out
}

/// Along the line `q[axis] = at` (plane index coordinates, not on a grid line), crossing a
/// contour segment must switch the bilinear field's inside test in the direction the
/// orientation says (inside on the left), and between crossings the state must agree with the
/// field at every grid line. This checks orientation, that no segment is missing or extra, and
/// that ambiguous cells were joined consistently.
fn scan_line(plane: &PlaneGrid, contours: &[Contour], o: &ContourOptions, axis: usize, at: f64) {
    let other = 1 - axis;
    let point = |s: f64| if axis == 1 { DVec2::new(s, at) } else { DVec2::new(at, s) };
    let inside = |s: f64| o.inside.contains(plane.bilinear(point(s)), o.isovalue);
    // (position along the line, entering?)
    let mut crossings: Vec<(f64, bool)> = Vec::new();
    for (a, b) in segments(contours) {
        if (a[axis] < at) == (b[axis] < at) {
            continue;
        }
        let s = a[other] + (b[other] - a[other]) * (at - a[axis]) / (b[axis] - a[axis]);
        // Walking along +other: for a horizontal line (axis = 1) a segment going up has the
        // inside on the left, i.e. behind us: we leave. For a vertical line a segment going
        // right has the inside above, ahead of us: we enter.
        let up = b[axis] > a[axis];
        crossings.push((s, if axis == 1 { !up } else { up }));
    }
    crossings.sort_by(|x, y| x.0.total_cmp(&y.0));
    let end = plane.cells()[other] as f64;
    let mut state = inside(0.0);
    let mut next = 0;
    for line in 0..=plane.cells()[other] {
        let s = line as f64;
        while next < crossings.len() && crossings[next].0 < s {
            let (at_s, entering) = crossings[next];
            assert_eq!(
                state, !entering,
                "crossing at {at_s} on line {axis}={at} goes the wrong way"
            );
            state = entering;
            next += 1;
        }
        assert_eq!(state, inside(s.min(end)), "state at grid line {s} of line {axis}={at}");
    }
    assert_eq!(next, crossings.len());
}

// ---- random grids ---------------------------------------------------------------------------

#[test]
fn contour_points_lie_on_the_bilinear_zero_set_and_are_oriented() {
    let mut rng = Rng::new(61);
    let mut checked = (0, 0);
    for trial in 0..60 {
        let dims = [
            2 + (rng.next_u64() % 9) as usize,
            2 + (rng.next_u64() % 9) as usize,
            2 + (rng.next_u64() % 9) as usize,
        ];
        let grid = random_grid(&mut rng, dims);
        let (axis, at) = random_plane(&mut rng, &grid);
        let plane = PlaneGrid::new(&grid, axis, at).unwrap();
        let (lo, hi) = plane.range();
        let inside = Inside::ALL[trial % 2];
        let isovalue = rng.range(lo, hi);
        let depth = [0, 0, 2][trial % 3];
        for ambiguity in [Ambiguity::Average, Ambiguity::Saddle] {
            let o = opts(isovalue, inside, ambiguity, depth);
            let set = extract(&plane, None, &o).unwrap();
            for c in &set.contours {
                assert!(c.points.len() >= if c.closed { 3 } else { 2 }, "{c:?}");
                for &q in &c.points {
                    // The 3D trilinear reference at the world point: independent of PlaneGrid.
                    let u = field::to_grid(&grid, plane.index_to_world(q));
                    let v = field::value_at(&grid, u);
                    assert!(
                        (v - isovalue).abs() <= ZERO_SET_TOL * (hi - lo),
                        "trial {trial}: point {q} has value {v}, isovalue {isovalue}"
                    );
                    checked.0 += 1;
                }
                if !c.closed {
                    // Open contours end on the box's sides.
                    let [cu, cv] = plane.cells().map(|n| n as f64);
                    for q in [c.points[0], c.points[c.points.len() - 1]] {
                        let on_side = q.x == 0.0 || q.y == 0.0 || q.x == cu || q.y == cv;
                        assert!(on_side, "trial {trial}: open contour ends at {q}");
                    }
                }
            }
            for _ in 0..4 {
                for line_axis in 0..2 {
                    let n = plane.cells()[line_axis] as f64;
                    let at = (rng.range(0.0, n) * 1e6).floor() / 1e6 + 1.3e-7;
                    scan_line(&plane, &set.contours, &o, line_axis, at);
                }
            }
            checked.1 += set.contours.len();
        }
    }
    assert!(checked.0 > 2000 && checked.1 > 200, "{checked:?}");
}

#[test]
fn stitching_is_exact_on_shared_edges() {
    // Every point of a closed contour appears once, and neighbouring cells share their points
    // bit for bit: no point of one contour is within 1e-12 of another's unless identical.
    let mut rng = Rng::new(7);
    let grid = random_grid(&mut rng, [12, 9, 5]);
    let plane = PlaneGrid::new(&grid, Axis::Z, 0.1).unwrap();
    let set = extract(&plane, None, &opts(0.0, Inside::Below, Ambiguity::Average, 0)).unwrap();
    let mut all: Vec<DVec2> = set.contours.iter().flat_map(|c| c.points.clone()).collect();
    let n = all.len();
    all.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    all.dedup();
    assert_eq!(all.len(), n, "a crossing was emitted twice");
}

// ---- fields with known contours -------------------------------------------------------------

#[test]
fn two_blobs_give_two_counterclockwise_loops() {
    let scene = load_file("torus.toml", &[]);
    let (_, _, contours) = contours_of(&scene, Axis::Z, 0.0);
    assert_eq!(contours.len(), 2);
    for c in &contours {
        assert!(c.closed);
        assert!(c.signed_area2() > 0.0, "an inside region must be counterclockwise");
    }
    // inside = "above" swaps inside and outside: the same loops, clockwise.
    let scene = load_file("torus.toml", &["surface.inside=\"above\""]);
    let (_, _, contours) = contours_of(&scene, Axis::Z, 0.0);
    assert_eq!(contours.len(), 2);
    assert!(contours.iter().all(|c| c.closed && c.signed_area2() < 0.0));
}

#[test]
fn a_ring_gives_nested_loops_of_opposite_orientation() {
    let scene = load_file("torus.toml", &[]);
    let (_, plane, contours) = contours_of(&scene, Axis::Y, 0.0);
    assert_eq!(plane.axes, (0, 2));
    assert_eq!(contours.len(), 2);
    let (mut outer, mut inner) = (&contours[0], &contours[1]);
    if outer.signed_area2().abs() < inner.signed_area2().abs() {
        std::mem::swap(&mut outer, &mut inner);
    }
    assert!(outer.closed && inner.closed);
    assert!(outer.signed_area2() > 0.0, "outer boundary of the ring: counterclockwise");
    assert!(inner.signed_area2() < 0.0, "hole of the ring: clockwise");
    // Radii R + r and R - r, about the origin (plane index (23.5, 23.5)).
    let radius = |c: &Contour| {
        let w: Vec<f64> = c.points.iter().map(|&q| plane.to_uv(q).length()).collect::<Vec<_>>();
        w.iter().sum::<f64>() / w.len() as f64
    };
    assert!((radius(outer) - 0.85).abs() < 0.01, "{}", radius(outer));
    assert!((radius(inner) - 0.35).abs() < 0.01, "{}", radius(inner));
}

/// Two inside grid points on the diagonal of the middle cell of a 3x3-cell plane; the corner
/// average is inside (-0.1), the saddle value inside (-0.1), the source at the centre outside
/// (1.4).
const SADDLE: &str = r#"
[field]
source = "expr"
expression = "0.8 - 1.8*(exp(-25*((x-1)^2 + (y-1)^2)) + exp(-25*((x-2)^2 + (y-2)^2))) + 0.6*exp(-25*((x-1.5)^2 + (y-1.5)^2))"
resolution = [4, 4, 2]
bounds = { min = [0.0, 0.0, 0.0], max = [3.0, 3.0, 1.0] }
"#;

#[test]
fn a_saddle_under_each_ambiguity_rule() {
    for (rule, loops, joined) in [("average", 1, 1), ("sample", 2, 0), ("saddle", 1, 1)] {
        let scene = load(SADDLE, &[&format!("slice.ambiguity=\"{rule}\"")]);
        let grid = scene.field.sample(0.0).unwrap();
        let plane = PlaneGrid::new(&grid, Axis::Z, 0.5).unwrap();
        let set = slice::scene_contours(&scene, &grid, &plane, 0.0).unwrap();
        assert_eq!(set.counts(), (loops, 0), "{rule}");
        assert_eq!((set.stats.ambiguous, set.stats.joined), (1, joined), "{rule}");
        assert!(set.contours.iter().all(|c| c.signed_area2() > 0.0), "{rule}");
    }
    // Refined on the source, the contours are the source's: two small circles of radius
    // sqrt(ln(2.25) / 25) = 0.18 about (1, 1) and (2, 2).
    let scene = load(SADDLE, &["slice.max_depth=5"]);
    let grid = scene.field.sample(0.0).unwrap();
    let plane = PlaneGrid::new(&grid, Axis::Z, 0.5).unwrap();
    let set = slice::scene_contours(&scene, &grid, &plane, 0.0).unwrap();
    assert!(set.stats.on_source);
    assert_eq!(set.counts(), (2, 0));
    let source = SourceField::from_spec(&scene.field, 0.0).unwrap();
    for c in &set.contours {
        for &q in &c.points {
            let v = (source.eval)(plane.index_to_world(q));
            assert!(v.abs() < 1e-9, "refined point off the source's zero set: {v}");
            let uv = plane.to_uv(q);
            let d = (uv - DVec2::ONE).length().min((uv - DVec2::splat(2.0)).length());
            assert!((d - (2.25f64.ln() / 25.0).sqrt()).abs() < 0.01, "radius {d}");
        }
    }
}

#[test]
fn contours_that_leave_the_box_are_open_and_oriented() {
    // A sphere centred on the box's corner edge: a quarter circle from the bottom side to the
    // left side, counterclockwise about the centre (inside on the left).
    let text = r#"
[field]
source = "sdf"
shape = "sphere"
radius = 0.5
center = [-1.0, -1.0, 0.0]
resolution = [21, 21, 5]
bounds = { min = [-1.0, -1.0, -1.0], max = [1.0, 1.0, 1.0] }
"#;
    let scene = load(text, &[]);
    let (_, plane, contours) = contours_of(&scene, Axis::Z, 0.0);
    assert_eq!(contours.len(), 1);
    let c = &contours[0];
    assert!(!c.closed);
    let (first, last) = (plane.to_uv(c.points[0]), plane.to_uv(c.points[c.points.len() - 1]));
    assert!(first.y == -1.0 && (first.x + 0.5).abs() < 0.01, "{first}");
    assert!(last.x == -1.0 && (last.y + 0.5).abs() < 0.01, "{last}");

    // A plane x = 0.3 (linear field): one vertical line, upward (inside x < 0.3 on its left).
    let text = r#"
[field]
source = "expr"
expression = "x - 0.3"
resolution = [6, 5, 4]
bounds = { min = [-1.0, -1.0, -1.0], max = [1.0, 1.0, 1.0] }
"#;
    for depth in ["0", "3"] {
        let scene = load(text, &[&format!("slice.max_depth={depth}")]);
        let (_, plane, contours) = contours_of(&scene, Axis::Z, -0.2);
        assert_eq!(contours.len(), 1);
        let c = &contours[0];
        assert!(!c.closed);
        // Grid values are f32 at depth 0, the source itself when refined.
        let tol = if depth == "0" { 1e-6 } else { 1e-12 };
        for &q in &c.points {
            assert!((plane.to_uv(q).x - 0.3).abs() < tol);
        }
        let (first, last) = (plane.to_uv(c.points[0]), plane.to_uv(c.points[c.points.len() - 1]));
        assert_eq!((first.y, last.y), (-1.0, 1.0), "depth {depth}");
    }
}

#[test]
fn refinement_follows_the_source_without_cracks() {
    // A torus slice refined 4 levels: still two loops (no cracks at T-junctions), every point
    // on the analytic circle |(x, y) -+ (0.6, 0)| = 0.25 within the root finder's tolerance.
    let scene = load_file("torus.toml", &["slice.max_depth=4"]);
    let (_, plane, contours) = contours_of(&scene, Axis::Z, 0.0);
    assert_eq!(contours.len(), 2);
    let coarse = contours_of(&load_file("torus.toml", &[]), Axis::Z, 0.0).2;
    for (c, k) in contours.iter().zip(&coarse) {
        assert!(c.closed && c.signed_area2() > 0.0);
        assert!(c.points.len() > 8 * k.points.len(), "{} vs {}", c.points.len(), k.points.len());
        for &q in &c.points {
            let p = plane.to_uv(q);
            let d = (p - DVec2::new(0.6, 0.0)).length().min((p + DVec2::new(0.6, 0.0)).length());
            assert!((d - 0.25).abs() < 1e-9, "{p}: {d}");
        }
    }
    // The gyroid at depth 2 on a z plane: every contour closed or ending on the box.
    let scene = load_file("gyroid.toml", &["slice.max_depth=2"]);
    let (_, plane, contours) = contours_of(&scene, Axis::Z, 0.1);
    assert!(!contours.is_empty());
    let [cu, cv] = plane.cells().map(|n| n as f64);
    for c in contours.iter().filter(|c| !c.closed) {
        for q in [c.points[0], c.points[c.points.len() - 1]] {
            assert!(q.x == 0.0 || q.y == 0.0 || q.x == cu || q.y == cv, "{q}");
        }
    }
}

#[test]
fn segment_probe_finds_the_quadratics_roots() {
    // f = x y - 0.125 on one cell [0,1]^2 (a hyperbola): along the diagonal from (0, 0) to
    // (1, 1), f = s^2 - 0.125 has its root at s = sqrt(0.125), entering for inside = "above".
    let text = r#"
[field]
source = "corners"
values = [-0.125, -0.125, -0.125, 0.875, -0.125, -0.125, -0.125, 0.875]

[surface]
inside = "above"
"#;
    let scene = load(text, &[]);
    let grid = scene.field.sample(0.0).unwrap();
    let plane = PlaneGrid::new(&grid, Axis::Z, 0.3).unwrap();
    let probe = slice::probe_segment(&plane, DVec2::ZERO, DVec2::ONE, 0.0, Inside::Above);
    assert_eq!(probe.cells.len(), 1);
    let roots: Vec<_> = probe.roots().collect();
    assert_eq!(roots.len(), 1);
    assert!((roots[0].t - 0.125f64.sqrt()).abs() < 1e-14, "{}", roots[0].t);
    assert_eq!(roots[0].kind, RootKind::Entering);
    assert_eq!(roots[0].point.z, 0.3);

    // Through many cells of a random grid: every root is a zero of the bilinear field, and
    // between roots the inside test is constant.
    let mut rng = Rng::new(5);
    let grid = random_grid(&mut rng, [9, 7, 4]);
    let plane = PlaneGrid::new(&grid, Axis::X, 0.2).unwrap();
    let (a, b) = (DVec2::new(-2.0, -1.3), DVec2::new(2.0, 1.1));
    let probe = slice::probe_segment(&plane, a, b, 0.05, Inside::Below);
    let (lo, hi) = plane.range();
    let roots: Vec<_> = probe.roots().map(|r| r.t).collect();
    assert!(roots.len() >= 2, "{roots:?}");
    for r in probe.roots() {
        let v = field::value_at(&grid, field::to_grid(&grid, r.point));
        assert!((v - 0.05).abs() < ZERO_SET_TOL * (hi - lo), "{v}");
    }
    let (t0, t1) = probe.span.unwrap();
    let mut stops = vec![t0];
    stops.extend(&roots);
    stops.push(t1);
    for w in stops.windows(2) {
        let inside = |t: f64| {
            let q = plane.to_index(a + (b - a) * t);
            plane.bilinear(q) < 0.05
        };
        let states: Vec<bool> =
            (1..10).map(|k| inside(w[0] + (w[1] - w[0]) * k as f64 / 10.0)).collect();
        assert!(states.iter().all(|&s| s == states[0]), "sign change between roots {w:?}");
    }
}

// ---- the GPU picture ------------------------------------------------------------------------

fn style(plane: &PlaneGrid, width: u32, height: u32, isovalue: f64, inside: Inside) -> SliceStyle {
    SliceStyle {
        width,
        height,
        isovalue,
        inside,
        half_range: colormap_half_range(plane, isovalue),
        line_width: 1.5,
        line_color: [0.0, 0.0, 0.0, 1.0],
    }
}

#[gpu_test]
fn gpu_value_matches_the_reference_on_random_grids() {
    let ctx = gpu();
    let mut renderer = SliceRenderer::new(&ctx).unwrap();
    let mut rng = Rng::new(23);
    let mut worst: f64 = 0.0;
    for trial in 0..12 {
        let dims = [
            2 + (rng.next_u64() % 20) as usize,
            2 + (rng.next_u64() % 20) as usize,
            2 + (rng.next_u64() % 20) as usize,
        ];
        let grid = random_grid(&mut rng, dims);
        let (axis, at) = random_plane(&mut rng, &grid);
        // Each interpolant's variant of the pass in turn (trilinear in a third of the trials).
        let interp = [
            Interpolant::Trilinear,
            Interpolant::CubicBspline,
            Interpolant::CatmullRom,
            Interpolant::Nearest,
        ][trial % 4];
        let plane = PlaneGrid::through(&grid, axis, at, interp).unwrap();
        let (w, h) = (9 + (rng.next_u64() % 60) as u32, 5 + (rng.next_u64() % 60) as u32);
        let inside = Inside::ALL[trial % 2];
        let set = extract(&plane, None, &opts(0.1, inside, Ambiguity::Average, 0)).unwrap();
        let gpu_grid = GpuGrid::upload(&ctx, &grid).unwrap();
        let image = renderer
            .render(&gpu_grid, &plane, &set.contours, &style(&plane, w, h, 0.1, inside))
            .unwrap();
        let reference = slice::reference::values(&grid, &plane, w, h);
        let (lo, hi) = grid.range();
        let scale = (lo.abs().max(hi.abs()) as f64).max(1e-30);
        for (n, (p, r)) in image.pixels.iter().zip(&reference).enumerate() {
            let err = (p.value as f64 - r).abs() / scale;
            worst = worst.max(err);
            assert!(
                err <= VALUE_TOL,
                "trial {trial} {}: pixel {n}: gpu {} vs {r}",
                interp.name(),
                p.value
            );
            assert_eq!(p.rgba[3], 1.0);
            assert!((0.0..=1.0).contains(&p.contour));
        }
        let drawn = image.pixels.iter().filter(|p| p.contour > 0.5).count();
        assert_eq!(set.contours.is_empty(), drawn == 0, "trial {trial}: {drawn} line pixels");
    }
    eprintln!("worst relative value error {worst:.2e}");
}

#[gpu_test]
fn gpu_picture_colours_inside_red_and_draws_the_contour() {
    let ctx = gpu();
    let scene = load_file("torus.toml", &[]);
    let (grid, plane, contours) = contours_of(&scene, Axis::Y, 0.0);
    let mut renderer = SliceRenderer::new(&ctx).unwrap();
    let gpu_grid = GpuGrid::upload(&ctx, &grid).unwrap();
    let image = renderer
        .render(&gpu_grid, &plane, &contours, &style(&plane, 64, 64, 0.0, Inside::Below))
        .unwrap();
    let px = |x: u32, y: u32| image.pixels[(y * 64 + x) as usize];
    // The ring's material at (x, z) = (0.6, 0): red; the hole and the corners: blue.
    let ring = px(51, 31);
    assert!(ring.value < 0.0 && ring.rgba[0] > ring.rgba[2], "{ring:?}");
    let hole = px(32, 32);
    assert!(hole.value > 0.0 && hole.rgba[2] > hole.rgba[0], "{hole:?}");
    // Pixels the loops pass through are covered by the line.
    for c in &contours {
        for &q in c.points.iter().step_by(5) {
            let x = (q.x / plane.cells()[0] as f64 * 64.0) as u32;
            let y = ((1.0 - q.y / plane.cells()[1] as f64) * 64.0) as u32;
            assert!(px(x.min(63), y.min(63)).contour > 0.5, "{q}");
        }
    }
}

#[test]
fn every_shipped_scene_slices_on_every_axis() {
    shipped_scene_slices(None);
}

#[gpu_test]
fn every_shipped_scene_slices_on_every_axis_on_the_gpu() {
    shipped_scene_slices(Some(gpu()));
}

/// Contours of every shipped scene on two planes per axis stay on the plane's grid; with `ctx`,
/// the GPU picture's values match the reference too.
fn shipped_scene_slices(ctx: Option<Arc<Context>>) {
    let mut renderer = ctx.as_ref().map(|c| SliceRenderer::new(c).unwrap());
    let mut names: Vec<PathBuf> = std::fs::read_dir(root().join("scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 10);
    for path in &names {
        let scene = scene::load(path, &[]).unwrap();
        let grid = scene.field.sample(0.0).unwrap();
        let gpu_grid = ctx.as_ref().map(|c| GpuGrid::upload(c, &grid).unwrap());
        for axis in [Axis::X, Axis::Y, Axis::Z] {
            let a = axis.index();
            for at in [0.5 * (grid.min[a] + grid.max[a]), grid.max[a]] {
                let plane = PlaneGrid::new(&grid, axis, at).unwrap();
                let set = slice::scene_contours(&scene, &grid, &plane, 0.0).unwrap();
                let [cu, cv] = plane.cells().map(|n| n as f64);
                for c in &set.contours {
                    assert!(c
                        .points
                        .iter()
                        .all(|q| q.x >= 0.0 && q.y >= 0.0 && q.x <= cu && q.y <= cv));
                }
                let (w, h) = picture_size(&plane, None, None, 40, 16384);
                if let (Some(r), Some(g)) = (&mut renderer, &gpu_grid) {
                    let st = style(&plane, w, h, scene.surface.isovalue, scene.surface.inside);
                    let image = r.render(g, &plane, &set.contours, &st).unwrap();
                    let reference = slice::reference::values(&grid, &plane, w, h);
                    let (lo, hi) = grid.range();
                    let scale = lo.abs().max(hi.abs()) as f64;
                    for (p, v) in image.pixels.iter().zip(&reference) {
                        assert!(
                            (p.value as f64 - v).abs() <= VALUE_TOL * scale,
                            "{}: {axis:?} = {at}: {} vs {v}",
                            path.display(),
                            p.value
                        );
                    }
                }
            }
        }
    }
}

// ---- the [slice] table ----------------------------------------------------------------------

const CELL: &str = "[field]\nsource = \"corners\"\nvalues = [-1, 1, 1, 1, 1, 1, 1, 1]\n";

fn scene_error(text: &str, overrides: &[&str]) -> String {
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    match scene::from_str_with(text, "t.toml", Path::new("."), &overrides, &GridLimits::default()) {
        Ok(_) => panic!("expected an error"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn slice_table_keys_defaults_and_errors() {
    let s = load(CELL, &[]);
    assert_eq!(s.slice, scene::SliceSettings::default());
    assert_eq!(s.slice.ambiguity, Ambiguity::Average);
    let s = load(
        &format!(
            "{CELL}[slice]\nambiguity = \"saddle\"\nmax_depth = 3\nwidth = 100\nheight = 50\n"
        ),
        &[],
    );
    assert_eq!(
        s.slice,
        scene::SliceSettings {
            ambiguity: Ambiguity::Saddle,
            max_depth: 3,
            width: Some(100),
            height: Some(50)
        }
    );
    assert_eq!(
        scene_error(&format!("{CELL}[slice]\nambiguity = \"centre\"\n"), &[]),
        "t.toml:5:13: slice.ambiguity: unknown value \"centre\" (expected \"average\", \
         \"sample\" or \"saddle\")"
    );
    assert_eq!(
        scene_error(&format!("{CELL}[slice]\nmax_depth = 11\n"), &[]),
        "t.toml:5:13: slice.max_depth: must be at most 10, got 11"
    );
    assert_eq!(
        scene_error(&format!("{CELL}[slice]\ndepth = 1\n"), &[]),
        "t.toml:5:1: slice.depth: unknown key ([slice] has ambiguity, max_depth, width, height)"
    );
    // "sample" needs a source it can evaluate.
    let npy = format!(
        "[field]\nsource = \"npy\"\npath = \"{}\"\n[slice]\nambiguity = \"sample\"\n",
        root().join("scenes/data/blobs.npy").display()
    );
    let e = scene_error(&npy, &[]);
    assert!(e.starts_with("t.toml:5:13: slice.ambiguity: \"sample\" evaluates"), "{e}");
    let e = scene_error(&npy.replace("ambiguity = \"sample\"\n", ""), &["slice.ambiguity=sample"]);
    assert!(e.starts_with("--set slice.ambiguity=sample: slice.ambiguity:"), "{e}");
}

#[test]
fn the_plane_must_meet_the_box() {
    let spec = FieldSpec::sdf(
        SdfShape::Sphere { radius: 0.5 },
        DVec3::ZERO,
        [5, 5, 5],
        Bounds { min: DVec3::splat(-1.0), max: DVec3::splat(1.0) },
    );
    let grid = spec.sample(0.0).unwrap();
    let e = PlaneGrid::new(&grid, Axis::X, 1.5).unwrap_err().to_string();
    assert_eq!(e, "the plane x = 1.5 misses the grid box (x from -1 to 1)");
    assert!(PlaneGrid::new(&grid, Axis::X, f64::NAN).is_err());
    assert!(PlaneGrid::new(&grid, Axis::X, -1.0).is_ok());
}

// ---- the commands ---------------------------------------------------------------------------

fn isoview(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_isoview")).args(args).output().expect("run isoview")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn assert_fails(o: &Output, code: i32, needle: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(code), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line expected: {err}");
    assert!(err.contains(needle), "`{needle}` missing from {err}");
}

#[test]
fn slice_command_input_errors_write_nothing() {
    let dir = scratch("slice-cli-errors");
    let scene = root().join("scenes/torus.toml").display().to_string();
    let p = |name: &str| dir.join(name).display().to_string();
    let exr_path = p("s.exr");

    // Input errors: one line, exit 2, nothing written.
    let o = isoview(&["slice", &scene, "-o", &exr_path, "--axis", "y", "--at", "1.5"]);
    assert_fails(&o, 2, "--at 1.5: the plane y = 1.5 misses the grid box");
    let o = isoview(&["slice", &scene, "-o", &p("s.png"), "--axis", "y", "--at", "0"]);
    assert_fails(&o, 2, "must end in .exr");
    let o = isoview(&[
        "slice",
        &scene,
        "-o",
        &exr_path,
        "--axis",
        "y",
        "--at",
        "0",
        "--set",
        "slice.max_depth=-1",
    ]);
    assert_fails(&o, 2, "slice.max_depth: must be at least 0");
    assert!(!Path::new(&exr_path).exists());
}

#[gpu_test]
fn slice_command_writes_exr_png_json_and_svg() {
    let dir = scratch("slice-cli");
    let scene = root().join("scenes/torus.toml").display().to_string();
    let p = |name: &str| dir.join(name).display().to_string();
    let (exr_path, png, json, svg) = (p("s.exr"), p("s.png"), p("s.json"), p("s.svg"));
    let o = isoview(&[
        "slice",
        &scene,
        "-o",
        &exr_path,
        "--axis",
        "y",
        "--at",
        "-0.0",
        "--json",
        &json,
        "--svg",
        &svg,
        "--png",
        &png,
        "--set",
        "slice.width=40",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("2 closed and 0 open contour(s)"), "{}", stderr(&o));

    let img = exr::read(Path::new(&exr_path)).unwrap();
    assert_eq!((img.width, img.height), (40, 40));
    let mut names: Vec<&str> = img.channel_names().collect();
    names.sort();
    assert_eq!(names, ["A", "B", "G", "R", "contour", "value"]);
    assert_eq!(img.attribute("isoview/slice/axis"), Some("y"));
    assert_eq!(img.attribute("isoview/method"), Some("slice"));
    assert_eq!(img.attribute("isoview/slice/colormap"), Some("RdBu (colorous RED_BLUE)"));
    assert!(img.attribute("isoview/slice/colormap_red").is_some());

    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let keys: Vec<&String> = v.as_object().unwrap().keys().collect();
    assert_eq!(keys.len(), 4, "{keys:?}");
    assert_eq!(v["axis"], "y");
    assert_eq!(v["at"], 0.0);
    assert_eq!(v["isovalue"], 0.0);
    let contours = v["contours"].as_array().unwrap();
    assert_eq!(contours.len(), 2);
    for c in contours {
        assert_eq!(c.as_object().unwrap().len(), 2);
        assert_eq!(c["closed"], true);
        let pts = c["points"].as_array().unwrap();
        assert!(pts.len() > 20);
        assert_ne!(pts[0], pts[pts.len() - 1], "a closed contour does not repeat its first point");
        for q in pts {
            let q = q.as_array().unwrap();
            assert_eq!(q.len(), 3);
            assert_eq!(q[1], 0.0, "world coordinates on the plane y = 0");
        }
    }
    let svg_text = std::fs::read_to_string(&svg).unwrap();
    assert!(svg_text.starts_with("<?xml"));
    assert_eq!(svg_text.matches("<path class=\"closed\"").count(), 2);
    let png_bytes = std::fs::read(&png).unwrap();
    assert_eq!(&png_bytes[1..4], b"PNG");
}

#[test]
fn probe_slice_prints_the_segment_roots() {
    let scene = root().join("scenes/torus.toml").display().to_string();
    let o = isoview(&["probe", &scene, "--slice", "z=0", "--segment", "-1,0,1,0"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("4 root(s)"), "{out}");
    assert!(out.contains("entering") && out.contains("leaving"));
    let o = isoview(&["probe", &scene, "--slice", "z=0", "--segment", "-1,0,1,0", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let roots: Vec<f64> = v["cells"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|c| {
            c["roots"].as_array().unwrap().iter().map(|r| r["point"][0].as_f64().unwrap())
        })
        .collect();
    assert_eq!(roots.len(), 4);
    // The torus' circles: x = -+0.85 and -+0.35 (to the grid's resolution).
    for (r, want) in roots.iter().zip([-0.85, -0.35, 0.35, 0.85]) {
        assert!((r - want).abs() < 0.01, "{r} vs {want}");
    }
    let o = isoview(&["probe", &scene, "--slice", "w=0", "--segment", "-1,0,1,0"]);
    assert_fails(&o, 2, "--slice w=0: expected AXIS=C");
    let o = isoview(&["probe", &scene, "--slice", "z=0", "--segment", "-1,0,1"]);
    assert_fails(&o, 2, "--segment -1,0,1: expected four");
}

// ---- other interpolants ----------------------------------------------------------------------

/// Slices through the other interpolants follow the interpolant itself. Away from the border
/// Catmull-Rom reproduces the sampled quadric x² + y² + z² − r², so its contour on the plane
/// z = c is the circle of radius √(r² − c²); the B-spline adds its kernel's variance h²/3 per
/// axis, so its circle has radius √(r² − c² − h²); on a grid plane and between planes, without
/// and with refinement, to 1e-6 of the diagonal (the bilinear contours of the same samples miss
/// by far more). Each contour is a closed loop around the inside, counter-clockwise.
#[test]
fn cubic_contours_are_the_exact_circles() {
    let (n, r) = (17, 0.6);
    let h = 2.0 / (n - 1) as f64;
    let grid = grid_from([n; 3], DVec3::splat(-1.0), DVec3::ONE, |p| p.length_squared() - r * r);
    let tol = 1e-6 * (grid.max - grid.min).length();
    let worst = |plane: &PlaneGrid, contours: &[Contour], radius: f64| {
        assert_eq!(contours.len(), 1, "one loop");
        assert!(contours[0].closed && contours[0].signed_area2() > 0.0, "counter-clockwise");
        let points = slice::contour::world_points(plane, &contours[0]);
        assert!(points.len() > 30, "{} points", points.len());
        points.iter().map(|p| (p.truncate().length() - radius).abs()).fold(0.0, f64::max)
    };
    for c in [0.0, 0.1] {
        for (interp, radius) in [
            (Interpolant::CatmullRom, (r * r - c * c).sqrt()),
            (Interpolant::CubicBspline, (r * r - c * c - h * h).sqrt()),
        ] {
            let plane = PlaneGrid::through(&grid, Axis::Z, c, interp).unwrap();
            let source = slice::interpolant_source(&grid, interp);
            for depth in [0, 2] {
                let o = opts(0.0, Inside::Below, Ambiguity::Average, depth);
                let set = extract(&plane, Some(&source), &o).unwrap();
                let off = worst(&plane, &set.contours, radius);
                let what = format!("{} z = {c} depth {depth}", interp.name());
                assert!(off < tol, "{what}: a point {off} off the circle of radius {radius}");
            }
        }
        let plane = PlaneGrid::new(&grid, Axis::Z, c).unwrap();
        let set = extract(&plane, None, &opts(0.0, Inside::Below, Ambiguity::Average, 0)).unwrap();
        let off = worst(&plane, &set.contours, (r * r - c * c).sqrt());
        assert!(off > 100.0 * tol, "bilinear is {off} off: the tolerance means nothing");
    }
}

/// Nearest's contours are its voxels' edges: every segment axis-aligned on a half-integer
/// line of the plane's index space (turning at cell centres), and the loops enclose exactly the
/// inside voxels: half the sum of their signed doubled areas is the count of inside points on
/// the plane (a blob away from the box's sides, one unit of area per voxel).
#[test]
fn nearest_contours_are_the_voxel_edges() {
    let grid = grid_from([13, 11, 9], DVec3::splat(-1.0), DVec3::ONE, |p| 0.7 - p.length());
    for at in [0.0, 0.3, -0.45] {
        let plane = PlaneGrid::through(&grid, Axis::Z, at, Interpolant::Nearest).unwrap();
        let o = opts(0.0, Inside::Above, Ambiguity::Average, 3);
        let set = extract(&plane, None, &o).unwrap();
        let inside = plane.values.iter().filter(|&&v| v > 0.0).count();
        assert!(inside > 10, "z = {at}: {inside} inside points");
        let area: f64 = set.contours.iter().map(|c| c.signed_area2()).sum::<f64>() / 2.0;
        assert!((area - inside as f64).abs() < 1e-9, "z = {at}: area {area}, {inside} voxels");
        for c in &set.contours {
            assert!(c.closed, "z = {at}: an open contour");
            let n = c.points.len();
            for i in 0..n {
                let (a, b) = (c.points[i], c.points[(i + 1) % n]);
                let half = |x: f64| (x - x.floor() - 0.5).abs() < 1e-12;
                assert!(a.x == b.x || a.y == b.y, "z = {at}: {a} -> {b} is not axis-aligned");
                assert!(
                    (a.x == b.x && half(a.x)) || (a.y == b.y && half(a.y)),
                    "z = {at}: {a} -> {b} is not on a voxel edge"
                );
            }
        }
    }
}

/// `slice` draws each interpolant (its variant of the pass, its contours); `probe --slice`
/// reports bilinear cells and refuses the others with one line.
#[test]
fn the_slice_command_reads_each_interpolant() {
    let dir = scratch("slice-interpolants");
    let scene = write(
        &dir,
        "s.toml",
        "[image]\nwidth = 32\nheight = 32\n[field]\nsource = \"sdf\"\nshape = \"sphere\"\n\
         radius = 0.5\nresolution = [8, 8, 8]\nbounds = { min = [-1, -1, -1], max = [1, 1, 1] }\n",
    );
    let (exr, json) = (dir.join("s.exr"), dir.join("s.json"));
    let mut seen = Vec::new();
    for interp in ["trilinear", "cubic-bspline", "catmull-rom", "nearest"] {
        let set = format!("field.interpolation=\"{interp}\"");
        let args = ["slice", &scene, "-o", exr.to_str().unwrap(), "--axis", "z", "--at", "0.1"];
        let r = isoview(&[&args[..], &["--json", json.to_str().unwrap(), "--set", &set]].concat());
        assert!(r.status.success(), "{interp}: {}", stderr(&r));
        seen.push((std::fs::read(&exr).unwrap(), std::fs::read(&json).unwrap()));
        let probe = ["probe", &scene, "--slice", "z=0", "--segment", "-1,-1,1,1", "--set", &set];
        let r = isoview(&probe);
        if interp == "trilinear" {
            assert!(r.status.success(), "{}", stderr(&r));
        } else {
            let line = format!("field.interpolation = \"{interp}\": probe --slice reports each plane cell's bilinear quadratic");
            assert_fails(&r, 2, &line);
        }
    }
    for i in 0..seen.len() {
        for j in i + 1..seen.len() {
            assert_ne!(seen[i].1, seen[j].1, "contours {i} and {j} are the same");
            assert_ne!(seen[i].0, seen[j].0, "pictures {i} and {j} are the same");
        }
    }
}
