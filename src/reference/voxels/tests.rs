//! The voxel walk against closed forms (a single voxel, a block, a half-space, ties, missing
//! voxels, both borders) and against a brute-force sampling of the nearest field.

use glam::DVec3;

use super::*;
use crate::field::interpolant::{Interpolant, Interpolated};
use crate::reference::field::clip_box;

const MIN: DVec3 = DVec3::new(-1.0, 0.5, 2.0);
const H: DVec3 = DVec3::new(0.5, 0.75, 0.25);

/// A grid of `dims` points at `MIN + i H`, point `(i, j, k)` holding `f(i, j, k)`.
fn grid(dims: [usize; 3], f: impl Fn(usize, usize, usize) -> f32) -> Grid {
    let mut values = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                values.push(f(i, j, k));
            }
        }
    }
    let last = DVec3::new((dims[0] - 1) as f64, (dims[1] - 1) as f64, (dims[2] - 1) as f64);
    Grid { dims, min: MIN, max: MIN + last * H, values }
}

/// World ray of index-space origin `o` and direction `d` (`t` is the same in both).
fn world(o: DVec3, d: DVec3) -> (DVec3, DVec3) {
    (MIN + o * H, d * H)
}

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn vec(&mut self) -> DVec3 {
        DVec3::new(self.next(), self.next(), self.next())
    }
}

const OPTS: AnalyticOptions =
    AnalyticOptions { newton_steps: 0, crossing: 1, clip: crate::vocab::Clip::NONE };

fn kth(k: u32) -> AnalyticOptions {
    AnalyticOptions { crossing: k, ..OPTS }
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * (1.0 + b.abs())
}

/// The inside voxels `lo..=hi` (per axis) of a grid of `dims` points are the box
/// `[lo - ½, hi + ½]` in index space: every ray aimed at it from outside the grid enters it
/// at the slab entry, on the face of the entry axis, and leaves it at the slab exit; `steps`
/// is one voxel plus one per plane crossed on the way, `|v_in - v_0|` per axis.
fn check_block(dims: [usize; 3], lo: [usize; 3], hi: [usize; 3], seed: u64) {
    let inside_voxel =
        |i: usize, j: usize, k: usize| (0..3).all(|a| (lo[a]..=hi[a]).contains(&[i, j, k][a]));
    let g = grid(dims, |i, j, k| if inside_voxel(i, j, k) { -1.0 } else { 1.0 });
    let mirrored = grid(dims, |i, j, k| if inside_voxel(i, j, k) { 2.0 } else { -2.0 });
    let (blo, bhi) = (lo.map(|v| v as f64 - 0.5), hi.map(|v| v as f64 + 0.5));
    let centre = DVec3::from(blo).lerp(DVec3::from(bhi), 0.5);
    let n = DVec3::new((dims[0] - 1) as f64, (dims[1] - 1) as f64, (dims[2] - 1) as f64);
    let mut rng = Rng(seed);
    let mut rays = Vec::new();
    // Along each axis both ways, then oblique rays from every side.
    for a in 0..3 {
        for s in [1.0, -1.0] {
            let mut d = DVec3::ZERO;
            d[a] = s;
            let mut o = centre + (rng.vec() - 0.5) * 0.9 * (DVec3::from(bhi) - DVec3::from(blo));
            o[a] = if s > 0.0 { -2.0 } else { n[a] + 2.0 };
            rays.push((o, d));
        }
    }
    for _ in 0..300 {
        let target = DVec3::from(blo) + rng.vec() * (DVec3::from(bhi) - DVec3::from(blo));
        let o = n * 0.5 + (rng.vec() - 0.5).normalize() * n.length() * 1.5;
        rays.push((o, (target - o) * (0.3 + rng.next())));
    }
    for (o, d) in rays {
        // The slabs of the block, in closed form.
        let (mut near, mut far, mut na, mut fa) = (f64::NEG_INFINITY, f64::INFINITY, 0, 0);
        for a in 0..3 {
            if d[a] == 0.0 {
                continue;
            }
            let (t0, t1) = ((blo[a] - o[a]) / d[a], (bhi[a] - o[a]) / d[a]);
            let (tn, tf) = if d[a] > 0.0 { (t0, t1) } else { (t1, t0) };
            if tn > near {
                (near, na) = (tn, a);
            }
            if tf < far {
                (far, fa) = (tf, a);
            }
        }
        assert!(near < far, "the ray {o} {d} is aimed at the block");
        // The voxel at the grid's entry (round half up) and the first inside one.
        let span = clip_box(&Grid { min: DVec3::ZERO, max: n, ..g.clone() }, o, d).unwrap();
        let entry = (o + d * span.0).clamp(DVec3::ZERO, n);
        let v0 = entry.to_array().map(|x| (x + 0.5).floor());
        let hit_point = o + d * near;
        let v_in: [f64; 3] = std::array::from_fn(|a| {
            if a == na {
                if d[a] > 0.0 {
                    lo[a] as f64
                } else {
                    hi[a] as f64
                }
            } else {
                (hit_point[a] + 0.5).floor()
            }
        });
        let steps = 1 + (0..3).map(|a| (v_in[a] - v0[a]).abs() as u32).sum::<u32>();
        let (wo, wd) = world(o, d);
        for (grid, inside) in [(&g, Inside::Below), (&mirrored, Inside::Above)] {
            let r = trace(grid, 0.0, inside, wo, wd, &OPTS);
            let hit = r.hit.unwrap_or_else(|| panic!("ray {o} {d} misses"));
            assert!(close(hit.t, near), "ray {o} {d}: t {} vs {near}", hit.t);
            assert_eq!(hit.axis, na);
            let mut normal = DVec3::ZERO;
            normal[na] = -d[na].signum();
            assert_eq!(hit.normal, normal, "ray {o} {d}");
            assert_eq!(hit.voxel, v_in.map(|v| v as usize), "ray {o} {d}");
            assert!(hit.entering && hit.crossing == 1 && !r.inside_at_start);
            assert_eq!(hit.grid_coords[na], if d[na] > 0.0 { blo[na] } else { bhi[na] });
            assert!((hit.position - (wo + wd * near)).length() < 1e-12);
            assert_eq!(r.voxels_visited, steps, "ray {o} {d}");
            assert_eq!(r.crossings, 2, "in and out");
            // The second crossing leaves the block through the slab exit.
            let out = trace(grid, 0.0, inside, wo, wd, &kth(2)).hit.expect("the exit");
            assert!(close(out.t, far) && out.axis == fa && !out.entering);
            assert_eq!(out.normal[fa], d[fa].signum());
            assert!(trace(grid, 0.0, inside, wo, wd, &kth(3)).hit.is_none());
        }
    }
}

/// Closed form 5 (reference level): one inside voxel is the cube of side one cell centred on
/// its point.
#[test]
fn a_single_inside_voxel_is_a_unit_cube_around_its_point() {
    check_block([5, 5, 5], [2, 2, 2], [2, 2, 2], 1);
    check_block([4, 6, 5], [1, 3, 2], [1, 3, 2], 2);
}

/// Closed form 5: a 3×3×3 block of inside voxels, its six faces and the voxels walked.
#[test]
fn a_block_of_voxels_has_six_faces_and_counted_steps() {
    check_block([7, 7, 7], [2, 2, 2], [4, 4, 4], 3);
    check_block([8, 6, 9], [3, 1, 2], [5, 3, 6], 4);
}

/// Closed form 5: the half-space `x - c` sampled on the grid: every ray that crosses the plane
/// where the samples change sign hits it there, normal `+x`, `cell.x` the inside voxel.
#[test]
fn a_half_space_is_cut_at_the_plane_between_its_samples() {
    let g = grid([6, 4, 5], |i, _, _| i as f32 - 2.3);
    let n = DVec3::new(5.0, 3.0, 4.0);
    let mut rng = Rng(5);
    let mut hits = 0;
    for _ in 0..400 {
        let o = rng.vec() * (n + 4.0) - 2.0;
        let d = (rng.vec() * n - o).normalize();
        let (wo, wd) = world(o, d);
        let r = trace(&g, 0.0, Inside::Below, wo, wd, &OPTS);
        let t = (2.5 - o.x) / d.x;
        let (t_lo, t_hi) = r.span.expect("aimed at the box");
        match r.hit {
            Some(hit) => {
                hits += 1;
                assert!(close(hit.t, t), "t {} vs {t}", hit.t);
                assert_eq!((hit.normal, hit.voxel[0], hit.axis), (DVec3::X, 2, 0));
                assert_eq!(hit.entering, d.x < 0.0);
                assert_eq!(hit.grid_coords.x, 2.5);
            }
            None => assert!(!(t > t_lo && t < t_hi), "ray {o} {d} misses the plane at {t}"),
        }
    }
    assert!(hits > 100, "{hits}");
}

/// A value equal to the isovalue is outside, for both inside modes.
#[test]
fn a_voxel_at_the_isovalue_is_outside() {
    let row = [-1.0f32, 0.0, -1.0, 1.0, 1.0];
    let (o, d) = world(DVec3::new(-1.0, 0.4, 0.6), DVec3::X);
    for (sign, inside) in [(1.0, Inside::Below), (-1.0, Inside::Above)] {
        let g = grid([5, 2, 2], |i, _, _| sign * row[i]);
        let r = trace(&g, 0.0, inside, o, d, &OPTS);
        assert!(r.inside_at_start);
        assert_eq!(r.crossings, 3);
        let hits: Vec<FaceHit> =
            (1..=3).map(|k| trace(&g, 0.0, inside, o, d, &kth(k)).hit.unwrap()).collect();
        let got: Vec<(f64, bool, f64, usize)> =
            hits.iter().map(|h| (h.t, h.entering, h.normal.x, h.voxel[0])).collect();
        assert_eq!(
            got,
            [(1.5, false, 1.0, 0), (2.5, true, -1.0, 2), (3.5, false, 1.0, 2)],
            "{inside:?}"
        );
        assert_eq!(r.voxels_visited, 2, "the hit is found entering voxel 1");
        // Everything at the isovalue: outside everywhere, no surface.
        let flat = grid([5, 2, 2], |_, _, _| 0.0);
        let r = trace(&flat, 0.0, inside, o, d, &OPTS);
        assert_eq!((r.hit, r.crossings, r.inside_at_start, r.voxels_visited), (None, 0, false, 5));
    }
}

/// A missing voxel has no inside state: no face borders it, whatever its neighbours.
#[test]
fn missing_voxels_hold_no_face() {
    let row = [-1.0f32, f32::NAN, 1.0, -1.0, -1.0];
    let g = grid([5, 2, 2], |i, _, _| row[i]);
    let (o, d) = world(DVec3::new(-1.0, 0.4, 0.6), DVec3::X);
    let r = trace(&g, 0.0, Inside::Below, o, d, &OPTS);
    let hit = r.hit.expect("the face between voxels 2 and 3");
    assert_eq!((hit.t, hit.entering, hit.normal, hit.voxel), (3.5, true, -DVec3::X, [3, 0, 1]));
    assert_eq!((r.crossings, r.inside_at_start, r.voxels_visited), (1, true, 4));
    // Starting in the missing voxel: not inside.
    let (o, d) = world(DVec3::new(1.2, 0.4, 0.6), DVec3::X);
    let r = trace(&g, 0.0, Inside::Below, o, d, &OPTS);
    assert!(!r.inside_at_start && r.crossings == 1);
    // Every voxel missing: nothing.
    let holes = grid([5, 2, 2], |_, _, _| f32::INFINITY);
    let r = trace(&holes, 0.0, Inside::Below, o, d, &OPTS);
    assert_eq!((r.hit, r.crossings), (None, 0));
}

/// The last plane of the box belongs to the last point, the first to the first: a ray lying in
/// a box face reads that face's points; box faces are not surface.
#[test]
fn the_box_faces_belong_to_the_border_points() {
    // Points x = 0 and x = 3 are inside for y >= 1; x = 1, 2 are outside.
    let g = grid([4, 3, 2], |i, j, _| if (i == 0 || i == 3) && j >= 1 { -1.0 } else { 1.0 });
    for x in [0.0, 3.0] {
        let (o, d) = world(DVec3::new(x, -1.0, 0.3), DVec3::Y);
        let hit = trace(&g, 0.0, Inside::Below, o, d, &OPTS).hit.expect("in the face plane");
        assert_eq!((hit.t, hit.voxel, hit.normal), (1.5, [x as usize, 1, 0], -DVec3::Y));
        // Just inside the box, the neighbouring voxel: nothing there.
        let inner = if x == 0.0 { 0.6 } else { 2.4 };
        let (o, d) = world(DVec3::new(inner, -1.0, 0.3), DVec3::Y);
        assert!(trace(&g, 0.0, Inside::Below, o, d, &OPTS).hit.is_none());
    }
    // Entering the box through the face x = 3 while inside is no crossing; leaving the voxel is.
    let (o, d) = world(DVec3::new(5.0, 1.2, 0.3), -DVec3::X);
    let r = trace(&g, 0.0, Inside::Below, o, d, &OPTS);
    let hit = r.hit.unwrap();
    assert!(r.inside_at_start && !hit.entering);
    assert_eq!((hit.t, hit.normal, hit.voxel), (2.5, -DVec3::X, [3, 1, 0]));
    assert_eq!(r.crossings, 2, "out of point 3, into point 0");
    // A ray starting exactly on a face plane goes into the voxel it heads for.
    let (o, d) = world(DVec3::new(2.5, 1.2, 0.3), DVec3::X);
    let r = trace(&g, 0.0, Inside::Below, o, d, &OPTS);
    assert!(r.inside_at_start && r.crossings == 0 && r.voxels_visited == 1);
    let (o, d) = world(DVec3::new(2.5, 1.2, 0.3), -DVec3::X);
    let r = trace(&g, 0.0, Inside::Below, o, d, &OPTS);
    assert!(!r.inside_at_start && r.crossings == 1);
}

/// Random grids with missing voxels, random rays (from outside and inside the box), both inside
/// modes: the walk against a brute-force sampling of the nearest field along the ray. The ray
/// is cut at every voxel plane it meets (the points where the field can change) and the field
/// is sampled through the kernel ([`Interpolated`]) at the middle of every piece: the crossings
/// are the changes between consecutive finite pieces.
#[test]
fn random_rays_agree_with_brute_force_sampling() {
    let mut rng = Rng(7);
    let (mut hits, mut total, mut dense) = (0, 0, 0);
    for case in 0..60 {
        let dims = [
            2 + (rng.next() * 6.0) as usize,
            2 + (rng.next() * 6.0) as usize,
            2 + (rng.next() * 6.0) as usize,
        ];
        let mut g = grid(dims, |_, _, _| 0.0);
        for v in g.values.iter_mut() {
            *v = if rng.next() < 0.05 { f32::NAN } else { (rng.next() - 0.5) as f32 };
        }
        let f = Interpolated::new(&g, Interpolant::Nearest);
        let n = DVec3::new((dims[0] - 1) as f64, (dims[1] - 1) as f64, (dims[2] - 1) as f64);
        for r in 0..40 {
            let o = if r % 4 == 0 {
                rng.vec() * n
            } else {
                n * 0.5 + (rng.vec() - 0.5).normalize() * (n.length() + 1.0)
            };
            let d = rng.vec() * n - o;
            let iso = (rng.next() - 0.5) * 0.4;
            let inside = if r % 2 == 0 { Inside::Below } else { Inside::Above };
            let (wo, wd) = world(o, d);
            let (walk, visits) = trace_detailed(&g, iso, inside, wo, wd, &OPTS);
            let (t_lo, t_hi) = walk.span.expect("every ray is aimed into the box");
            total += 1;
            let mut cuts = vec![t_lo, t_hi];
            for a in 0..3 {
                for i in 0..dims[a] - 1 {
                    let t = (i as f64 + 0.5 - o[a]) / d[a];
                    if t > t_lo && t < t_hi {
                        cuts.push(t);
                    }
                }
            }
            cuts.sort_by(f64::total_cmp);
            let mut crossings = Vec::new();
            let mut before: Option<bool> = None;
            for w in cuts.windows(2).filter(|w| w[1] > w[0]) {
                let u = g.to_grid(wo + wd * (0.5 * (w[0] + w[1])));
                let v = f.value_at(u);
                let state = (!is_missing(v)).then(|| inside.contains(v, iso));
                if let (Some(was), Some(is)) = (before, state) {
                    if was != is {
                        crossings.push((w[0], is, voxel_of(&g, u)));
                    }
                }
                before = state;
            }
            assert_eq!(walk.crossings as usize, crossings.len(), "case {case} ray {r}");
            match (walk.hit, crossings.first()) {
                (None, None) => {}
                (Some(hit), Some(&(t, entering, v_after))) => {
                    hits += 1;
                    assert!(close(hit.t, t), "case {case} ray {r}: t {} vs {t}", hit.t);
                    assert_eq!(hit.entering, entering);
                    if entering {
                        assert_eq!(hit.voxel, v_after);
                    }
                    // The normal is a unit axis pointing out of the inside voxel.
                    let out = hit.grid_coords + hit.normal * 0.25;
                    let beyond = f.value_at(out.clamp(DVec3::ZERO, n));
                    assert!(!is_missing(beyond) && !inside.contains(beyond, iso));
                }
                (a, b) => panic!("case {case} ray {r}: walk {a:?} vs brute force {b:?}"),
            }
            // Uniform samples, which know nothing of the planes: their first change brackets
            // the walk's first hit, unless the ray passes through a voxel in less than two
            // samples' spacing (a sliver the samples can step over).
            let m = 2000;
            let ds = (t_hi - t_lo) / f64::from(m);
            if visits.iter().any(|v| v.t_out - v.t_in < 2.0 * ds) {
                continue;
            }
            dense += 1;
            let state_at = |t: f64| {
                let v = f.value_at(g.to_grid(wo + wd * t));
                (!is_missing(v)).then(|| inside.contains(v, iso))
            };
            let mut first = None;
            let mut before = state_at(t_lo);
            for i in 1..=m {
                let t = t_lo + (t_hi - t_lo) * (f64::from(i) / f64::from(m));
                let state = state_at(t);
                if matches!((before, state), (Some(a), Some(b)) if a != b) {
                    first = Some((t - ds, t));
                    break;
                }
                before = state;
            }
            match (walk.hit, first) {
                (None, None) => {}
                (Some(hit), Some((a, b))) => {
                    let slack = 1e-9 * (t_hi - t_lo);
                    assert!(hit.t >= a - slack && hit.t <= b + slack, "case {case} ray {r}");
                }
                (a, b) => panic!("case {case} ray {r}: walk {a:?} vs dense samples {b:?}"),
            }
        }
    }
    assert!(hits > total / 4 && total > 1500, "{hits} hits of {total} rays");
    assert!(dense > total / 2, "{dense} of {total} rays without slivers");
}

/// The per-voxel trace is the walk: voxels face to face, values read, the hit's t among the
/// visits' ends.
#[test]
fn the_detailed_trace_lists_the_voxels_walked() {
    let g = grid([5, 5, 5], |i, j, k| if [i, j, k] == [2, 2, 2] { -1.0 } else { 1.0 });
    let (o, d) = world(DVec3::new(-1.0, 2.2, 1.9), DVec3::X);
    let (r, visits) = trace_detailed(&g, 0.0, Inside::Below, o, d, &OPTS);
    assert_eq!(r, trace(&g, 0.0, Inside::Below, o, d, &OPTS));
    let walked: Vec<[usize; 3]> = visits.iter().map(|v| v.voxel).collect();
    assert_eq!(walked, (0..5).map(|i| [i, 2, 2]).collect::<Vec<_>>());
    assert_eq!(visits[2].inside, Some(true));
    assert_eq!(visits[2].t_in, r.hit.unwrap().t);
    assert!(visits.windows(2).all(|w| w[0].t_out == w[1].t_in));
    assert_eq!(r.voxels_total, 5);
}

fn scene(extra: &str) -> Scene {
    let text = format!(
        "[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = 0.6\nresolution = [5, 5, 5]\n\
         [image]\nwidth = 32\nheight = 32\n\
         [camera]\neye = [2.0, 2.2, -3.0]\ntarget = [2.0, 2.0, 2.0]\n[render]\n{extra}"
    );
    crate::scene::from_str(&text, "test", std::path::Path::new("."), &[]).expect("scene")
}

/// One inside voxel at (2, 2, 2) in a grid of 5³ points on `[0, 4]³`.
fn one_voxel() -> Grid {
    let values = (0..125).map(|n| if n == 62 { -1.0 } else { 1.0 }).collect();
    Grid { dims: [5, 5, 5], min: DVec3::ZERO, max: DVec3::splat(4.0), values }
}

/// `cells` shades voxels: a face is bright in its middle and dark only near the voxel's
/// edges, not along its own axis (every hit is on a voxel wall there), and the checker is
/// over the voxels' points.
#[test]
fn cells_shading_is_per_voxel() {
    use crate::reference::shade::Shader;
    let s = scene("shading = \"cells\"\n");
    let g = one_voxel();
    let voxels = Shader::for_interpolant(&s, &g, Interpolant::Nearest);
    let cells = Shader::for_interpolant(&s, &g, Interpolant::Trilinear);
    let hit = |u: DVec3, cell: [usize; 3]| RayHit {
        t: 1.0,
        position: u,
        normal: -DVec3::Z,
        grid_coords: u,
        cell,
        surface: 0,
    };
    let centre = hit(DVec3::new(2.0, 2.1, 1.5), [2, 2, 2]);
    let (v, c) = (voxels.shade(&centre, DVec3::Z, 1.0), cells.shade(&centre, DVec3::Z, 1.0));
    assert!((v - 4.0 * c).length() < 1e-12, "a voxel face's middle is not a cell border");
    let edge = voxels.shade(&hit(DVec3::new(2.49, 2.1, 1.5), [2, 2, 2]), DVec3::Z, 1.0);
    assert!((edge - 0.25 * v).length() < 1e-12, "near the voxel's x edge");
    let odd = voxels.shade(&hit(DVec3::new(2.0, 2.1, 2.5), [2, 2, 3]), DVec3::Z, 1.0);
    assert!((odd - 0.6 * v).length() < 1e-12, "the checker");
}

/// The render: every hit on the one voxel's near face, its normal the face's even with
/// `normals = "smooth"` (the point gradients approximate trilinear's surface, not the voxels').
#[test]
fn a_render_keeps_the_face_normals() {
    let g = one_voxel();
    let pixels = render(&scene("normals = \"smooth\"\n"), &g);
    let hits: Vec<_> = pixels.iter().filter(|p| p.is_hit()).collect();
    assert!(hits.len() > 20, "{}", hits.len());
    for p in hits {
        assert_eq!((p.normal, p.cell), ([0.0, 0.0, -1.0], [2, 2, 2]));
        assert!((p.position[2] - 1.5).abs() < 1e-6);
    }
}
