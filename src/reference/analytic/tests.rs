//! Tests of the analytic tracer: against a brute-force reference (dense sampling of the
//! predicate along the ray, then bisection, in `f64`) on random grids and rays, and against
//! answers known in closed form.

use glam::DVec3;

use super::*;
use crate::reference::trilinear::cell_corners;

/// xorshift64*, enough for reproducible test inputs.
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1)
    }
    fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    /// Uniform in `[0, 1)`.
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    fn vec(&mut self, lo: f64, hi: f64) -> DVec3 {
        DVec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    fn direction(&mut self) -> DVec3 {
        loop {
            let v = self.vec(-1.0, 1.0);
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
}

fn grid_from_fn(dims: [usize; 3], min: DVec3, max: DVec3, f: impl Fn(DVec3) -> f64) -> Grid {
    let mut grid = Grid { dims, min, max, values: vec![0.0; dims[0] * dims[1] * dims[2]] };
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let idx = grid.index(i, j, k);
                grid.values[idx] = f(grid.point(i, j, k)) as f32;
            }
        }
    }
    grid
}

fn random_grid(rng: &mut Rng, max_points: usize) -> Grid {
    let dims = [
        2 + rng.below(max_points - 1),
        2 + rng.below(max_points - 1),
        2 + rng.below(max_points - 1),
    ];
    let min = rng.vec(-2.0, 1.0);
    let max = min + rng.vec(0.5, 3.0);
    let count = dims[0] * dims[1] * dims[2];
    let values = (0..count).map(|_| rng.range(-1.0, 1.0) as f32).collect();
    Grid { dims, min, max, values }
}

fn diagonal(grid: &Grid) -> f64 {
    (grid.max - grid.min).length()
}

fn opts(newton_steps: u32) -> AnalyticOptions {
    AnalyticOptions { newton_steps, crossing: 1, ..Default::default() }
}

/// Brute force: the span by its own slab test, the predicate sampled at `samples` evenly spaced
/// points of it, each change bisected on the predicate (direct trilinear evaluation at the ray
/// point, no cubic) to the bottom. Returns the span and the crossings' `t`, in order.
fn brute(
    grid: &Grid,
    iso: f64,
    inside: Inside,
    origin: DVec3,
    dir: DVec3,
    samples: usize,
) -> Option<((f64, f64), Vec<f64>)> {
    let h = grid.spacing();
    let o = (origin - grid.min) / h;
    let d = dir / h;
    let c = grid.cells();
    let n = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
    let (mut lo, mut hi) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < 0.0 || o[a] > n[a] {
                return None;
            }
        } else {
            let t0 = -o[a] / d[a];
            let t1 = (n[a] - o[a]) / d[a];
            lo = lo.max(t0.min(t1));
            hi = hi.min(t0.max(t1));
        }
    }
    if lo > hi || lo.is_nan() || hi.is_nan() {
        return None;
    }
    let eval = |t: f64| -> bool {
        let q = (o + d * t).clamp(DVec3::ZERO, n);
        let cell = [0, 1, 2].map(|a| q[a].floor().min(n[a] - 1.0).max(0.0));
        let f = trilerp(&cell_corners(grid, cell.map(|x| x as usize)), q - DVec3::from_array(cell));
        inside.contains(f, iso)
    };
    let mut roots = Vec::new();
    let ts: Vec<f64> =
        (0..samples).map(|i| lo + (hi - lo) * i as f64 / (samples - 1) as f64).collect();
    let mut prev = eval(ts[0]);
    for w in ts.windows(2) {
        let p = eval(w[1]);
        if p != prev {
            let (mut a, mut b) = (w[0], w[1]);
            for _ in 0..200 {
                let m = 0.5 * (a + b);
                if m <= a || m >= b {
                    break;
                }
                if eval(m) == prev {
                    a = m;
                } else {
                    b = m;
                }
            }
            roots.push(0.5 * (a + b));
        }
        prev = p;
    }
    Some(((lo, hi), roots))
}

/// A trilinear visit's cubic.
fn monomial(v: &CellVisit) -> [f64; 4] {
    v.coefficients.monomial().expect("a trilinear visit has a monomial cubic")
}

/// A trilinear visit's 8 corners.
fn corners(v: &CellVisit) -> [f64; 8] {
    v.samples[..].try_into().expect("a trilinear visit has 8 corners")
}

/// The `t` of every counted crossing, from the detailed trace.
fn crossing_ts(visits: &[CellVisit]) -> Vec<f64> {
    visits.iter().flat_map(|v| v.roots.iter()).filter(|r| r.crossing > 0).map(|r| r.t).collect()
}

/// Checks the structural invariants of a detailed trace against its result.
fn check_trace(res: &AnalyticHit, visits: &[CellVisit], label: &str) {
    assert_eq!(visits.len() as u32, res.cells_total, "{label}: cells");
    let ts = crossing_ts(visits);
    assert_eq!(ts.len() as u32, res.crossings, "{label}: crossings");
    for w in ts.windows(2) {
        assert!(w[0] <= w[1], "{label}: crossings out of order {ts:?}");
    }
    for w in visits.windows(2) {
        assert_eq!(w[0].t_out, w[1].t_in, "{label}: segments do not chain");
        let (a, b) = (w[0].splits.last().unwrap(), &w[1].splits[0]);
        assert_eq!(a.g.to_bits(), b.g.to_bits(), "{label}: face value not carried");
    }
    for v in visits {
        assert!(v.t_in <= v.t_out, "{label}");
        for q in [v.q_in, v.q_out] {
            assert!(q.min_element() >= 0.0 && q.max_element() <= 1.0, "{label}: {q}");
        }
        let g0 = v.splits[0].g;
        assert_eq!(v.coefficients.coefficients()[0], g0, "{label}");
        for r in &v.roots {
            assert!(r.bracket.0 <= r.u && r.u <= r.bracket.1, "{label}: root left its bracket");
            assert!(v.t_in <= r.t && r.t <= v.t_out, "{label}: root left its segment");
        }
    }
}

/// Compares one ray with the brute force. Returns the number of analytic crossings that the
/// brute force could not see (close pairs at near-tangencies).
fn compare_with_brute(
    grid: &Grid,
    iso: f64,
    inside: Inside,
    origin: DVec3,
    dir: DVec3,
    label: &str,
) -> usize {
    compare_with_brute_n(grid, iso, inside, origin, dir, label, 20_000)
}

/// [`compare_with_brute`] with `samples` brute-force samples over the span.
fn compare_with_brute_n(
    grid: &Grid,
    iso: f64,
    inside: Inside,
    origin: DVec3,
    dir: DVec3,
    label: &str,
    samples: usize,
) -> usize {
    let (res, visits) = trace_detailed(grid, iso, inside, origin, dir, &opts(64));
    check_trace(&res, &visits, label);
    let plain = trace(grid, iso, inside, origin, dir, &opts(64));
    assert_eq!(plain, res, "{label}: trace and trace_detailed differ");
    let Some(((lo, hi), expected)) = brute(grid, iso, inside, origin, dir, samples) else {
        assert!(res.span.is_none() || res.crossings == 0, "{label}: brute force missed the box");
        return 0;
    };
    let got = crossing_ts(&visits);
    let tol = 1e-9 * diagonal(grid) / dir.length();
    let spacing = (hi - lo) / (samples - 1) as f64;
    // Walk both lists: every brute-force crossing must be matched; analytic crossings skipped
    // on the way must come in pairs closer than two sample spacings (a dip the samples jumped).
    let mut unmatched = Vec::new();
    let mut j = 0;
    for (i, &b) in expected.iter().enumerate() {
        let k = got[j..]
            .iter()
            .position(|&a| (a - b).abs() <= tol)
            .unwrap_or_else(|| panic!("{label}: brute-force crossing {i} at t = {b} not found in {got:?} (brute {expected:?})"));
        unmatched.extend_from_slice(&got[j..j + k]);
        j += k + 1;
    }
    unmatched.extend_from_slice(&got[j..]);
    assert!(
        unmatched.len() % 2 == 0,
        "{label}: odd unmatched {unmatched:?} in {got:?} vs {expected:?}"
    );
    for p in unmatched.chunks(2) {
        assert!(
            p[1] - p[0] < 2.0 * spacing,
            "{label}: unmatched pair {p:?} too far apart; {got:?} vs {expected:?}"
        );
    }
    // The first hit is the first crossing.
    match (res.hit, got.first()) {
        (Some(h), Some(&t)) => {
            assert_eq!(h.t, t, "{label}");
            assert_eq!(h.crossing, 1, "{label}");
        }
        (None, None) => {}
        (h, t) => panic!("{label}: hit {h:?} vs first crossing {t:?}"),
    }
    unmatched.len()
}

#[test]
fn random_grids_match_brute_force() {
    let mut rng = Rng::new(1);
    let mut rays = 0;
    let mut crossings = 0;
    let mut invisible = 0;
    for g in 0..60 {
        let grid = random_grid(&mut rng, 7);
        let iso = rng.range(-0.5, 0.5);
        let lo = grid.min - (grid.max - grid.min) * 0.5;
        let hi = grid.max + (grid.max - grid.min) * 0.5;
        for r in 0..8 {
            let origin =
                DVec3::new(rng.range(lo.x, hi.x), rng.range(lo.y, hi.y), rng.range(lo.z, hi.z));
            let target = DVec3::new(
                rng.range(grid.min.x, grid.max.x),
                rng.range(grid.min.y, grid.max.y),
                rng.range(grid.min.z, grid.max.z),
            );
            let dir = if r == 7 { rng.direction() } else { (target - origin).normalize() };
            for inside in [Inside::Below, Inside::Above] {
                let label = format!("grid {g} ray {r} {inside:?}");
                invisible += compare_with_brute(&grid, iso, inside, origin, dir, &label);
                crossings += trace(&grid, iso, inside, origin, dir, &opts(64)).crossings;
                rays += 1;
            }
        }
    }
    assert!(crossings as usize > rays / 2, "too few crossings to mean anything: {crossings}");
    assert!(invisible * 50 < crossings as usize, "too many near-tangent pairs: {invisible}");
}

#[test]
fn kth_crossing_matches_the_list() {
    let mut rng = Rng::new(2);
    let mut multi = 0;
    for g in 0..40 {
        let grid = random_grid(&mut rng, 6);
        let iso = rng.range(-0.3, 0.3);
        for _ in 0..6 {
            let origin = grid.min - rng.vec(0.1, 1.0);
            let target = grid.max - (grid.max - grid.min) * rng.vec(0.0, 0.5);
            let dir = (target - origin).normalize();
            for inside in [Inside::Below, Inside::Above] {
                let (all, visits) = trace_detailed(&grid, iso, inside, origin, dir, &opts(64));
                let ts = crossing_ts(&visits);
                if ts.len() > 1 {
                    multi += 1;
                }
                let mut entering = None;
                for k in 1..=ts.len() as u32 + 1 {
                    let o = AnalyticOptions { newton_steps: 64, crossing: k, ..Default::default() };
                    let res = trace(&grid, iso, inside, origin, dir, &o);
                    assert_eq!(res.crossings, all.crossings, "grid {g}");
                    assert_eq!(res.cells_total, all.cells_total, "grid {g}");
                    match res.hit {
                        Some(h) => {
                            assert_eq!(h.t, ts[k as usize - 1], "grid {g} k {k}");
                            assert_eq!(h.crossing, k);
                            assert!(res.cells_visited <= res.cells_total);
                            // Crossings alternate between entering and leaving, unless two sit
                            // at the same t (a touch from inside).
                            if let Some(prev) = entering {
                                assert_ne!(prev, h.entering, "grid {g} k {k}");
                            } else {
                                assert_eq!(h.entering, !all.inside_at_start, "grid {g}");
                            }
                            entering = Some(h.entering);
                        }
                        None => {
                            assert_eq!(k as usize, ts.len() + 1, "grid {g}");
                            assert_eq!(res.cells_visited, res.cells_total);
                        }
                    }
                }
            }
        }
    }
    assert!(multi > 20, "only {multi} rays with several crossings");
}

#[test]
fn default_newton_steps_are_converged_on_simple_roots() {
    // With 10 steps (secant start, bracketed Newton) a root that is not near a tangency is
    // found to f64 accuracy.
    let mut rng = Rng::new(3);
    let mut checked = 0;
    for _ in 0..60 {
        let grid = random_grid(&mut rng, 6);
        let iso = rng.range(-0.3, 0.3);
        for _ in 0..6 {
            let origin = grid.min - rng.vec(0.1, 1.0);
            let dir = (grid.max - origin - (grid.max - grid.min) * rng.vec(0.0, 0.9)).normalize();
            let (_, visits) = trace_detailed(&grid, iso, Inside::Below, origin, dir, &opts(10));
            let (_, exact) = trace_detailed(&grid, iso, Inside::Below, origin, dir, &opts(200));
            for (v, w) in visits.iter().zip(&exact) {
                let cubic = Cubic { c: monomial(v) };
                let scale = monomial(v).iter().fold(0.0f64, |m, c| m.max(c.abs()));
                for (r, s) in v.roots.iter().zip(&w.roots) {
                    let (_, slope) = cubic.eval_with_derivative(s.u);
                    if slope.abs() > 1e-2 * scale {
                        assert!((r.t - s.t).abs() <= 1e-12 * diagonal(&grid), "{} vs {}", r.t, s.t);
                        checked += 1;
                    }
                }
            }
        }
    }
    assert!(checked > 100, "{checked}");
}

#[test]
fn linear_field_gives_the_exact_plane() {
    // f = x + 2y - 0.5z is trilinear and its grid values are exact in f32 (dyadic points).
    let a = DVec3::new(1.0, 2.0, -0.5);
    let grid =
        grid_from_fn([5, 5, 5], DVec3::new(-1.0, 0.0, 2.0), DVec3::new(1.0, 4.0, 10.0), |p| {
            a.dot(p)
        });
    let mut rng = Rng::new(4);
    let mut hits = 0;
    for n in 0..400 {
        let iso = rng.range(-2.0, 8.0);
        let origin = rng.vec(-4.0, 14.0);
        let target = DVec3::new(rng.range(-1.0, 1.0), rng.range(0.0, 4.0), rng.range(2.0, 10.0));
        let dir = (target - origin).normalize();
        for inside in [Inside::Below, Inside::Above] {
            let res = trace(&grid, iso, inside, origin, dir, &opts(10));
            let t = (iso - a.dot(origin)) / a.dot(dir);
            let (lo, hi) = res.span.expect("aimed at the box");
            let expect_hit = t > lo + 1e-9 && t < hi - 1e-9;
            assert!(res.crossings <= 1, "ray {n}");
            match res.hit {
                Some(h) => {
                    assert!(
                        expect_hit || (t - lo).abs() < 1e-9 || (t - hi).abs() < 1e-9,
                        "ray {n}"
                    );
                    assert!((h.t - t).abs() < 1e-12 * diagonal(&grid), "ray {n}: {} vs {t}", h.t);
                    assert!((h.position - (origin + dir * t)).length() < 1e-11);
                    let normal = match inside {
                        Inside::Below => a.normalize(),
                        Inside::Above => -a.normalize(),
                    };
                    assert!((h.normal - normal).length() < 1e-12, "ray {n}: {}", h.normal);
                    // Entering exactly when the ray runs against the normal.
                    assert_eq!(h.entering, dir.dot(normal) < 0.0, "ray {n}");
                    hits += 1;
                }
                None => assert!(!expect_hit, "ray {n}: missed t = {t} in [{lo}, {hi}]"),
            }
        }
    }
    assert!(hits > 200, "{hits}");
}

#[test]
fn sphere_sdf_grid() {
    let radius = 0.6;
    let grid =
        grid_from_fn([33, 33, 33], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.length() - radius);
    let h = 2.0 / 32.0;
    let mut rng = Rng::new(5);
    for n in 0..200 {
        let origin = rng.direction() * rng.range(2.0, 4.0);
        let target = rng.vec(-0.3, 0.3);
        let dir = (target - origin).normalize();
        let res = trace(&grid, 0.0, Inside::Below, origin, dir, &opts(10));
        let hit = res.hit.expect("aimed at the core");
        assert_eq!(res.crossings, 2, "ray {n}");
        assert!(hit.entering && !res.inside_at_start);
        assert!(
            (hit.position.length() - radius).abs() < 0.5 * h * h,
            "ray {n}: |p| = {}",
            hit.position.length()
        );
        // The trilinear gradient is first-order accurate: a few degrees at 16 cells per unit.
        assert!(hit.normal.dot(hit.position.normalize()) > 0.995, "ray {n}");
        assert!(hit.normal.dot(dir) < 0.0);
        if n % 10 == 0 {
            compare_with_brute(&grid, 0.0, Inside::Below, origin, dir, &format!("sphere ray {n}"));
            compare_with_brute(
                &grid,
                0.0,
                Inside::Above,
                origin,
                dir,
                &format!("sphere ray {n} above"),
            );
        }
        // The same ray with the inside flipped: same place, reversed normal.
        let above = trace(&grid, 0.0, Inside::Above, origin, dir, &opts(10)).hit.unwrap();
        assert_eq!(above.t, hit.t);
        assert_eq!(above.normal, -hit.normal);
        assert!(!above.entering);
    }
    // From the centre: inside at the start; the first crossing leaves, normal along the ray.
    for n in 0..50 {
        let dir = rng.direction();
        let origin = rng.vec(-0.05, 0.05);
        let res = trace(&grid, 0.0, Inside::Below, origin, dir, &opts(10));
        let hit = res.hit.unwrap();
        assert!(res.inside_at_start && !hit.entering && res.crossings == 1, "ray {n}");
        assert_eq!(res.span.unwrap().0, 0.0);
        assert!((hit.position.length() - radius).abs() < 0.5 * h * h);
        assert!(hit.normal.dot(dir) > 0.9, "ray {n}");
        compare_with_brute(&grid, 0.0, Inside::Below, origin, dir, &format!("inner ray {n}"));
    }
    // Rays that pass the sphere by.
    for n in 0..50 {
        let side = rng.direction();
        let dir = side.any_orthonormal_vector();
        let origin = side * rng.range(0.75, 0.95) - dir * 3.0;
        let res = trace(&grid, 0.0, Inside::Below, origin, dir, &opts(10));
        assert!(res.hit.is_none() && res.crossings == 0 && res.span.is_some(), "ray {n}");
        assert_eq!(res.cells_visited, res.cells_total);
    }
}

fn single_cell(values: [f64; 8]) -> Grid {
    Grid {
        dims: [2, 2, 2],
        min: DVec3::ZERO,
        max: DVec3::ONE,
        values: values.map(|v| v as f32).to_vec(),
    }
}

#[test]
fn every_single_cell_sign_configuration() {
    // All 256 sign patterns of the corners (the 15 marching-cubes classes and their ambiguous
    // faces and interiors), random magnitudes, random rays through the cell.
    let mut rng = Rng::new(6);
    for pattern in 0..256usize {
        for m in 0..3 {
            let values: [f64; 8] = std::array::from_fn(|c| {
                let mag = rng.range(0.05, 1.0);
                if pattern >> c & 1 == 1 {
                    mag
                } else {
                    -mag
                }
            });
            let grid = single_cell(values);
            for r in 0..6 {
                let origin = rng.direction() * 2.0 + DVec3::splat(0.5);
                let dir = (rng.vec(0.1, 0.9) - origin).normalize();
                let inside = if r % 2 == 0 { Inside::Below } else { Inside::Above };
                let label = format!("pattern {pattern:08b} m {m} ray {r}");
                // One cell: 5000 samples are as dense per cell as 20000 over a larger grid.
                compare_with_brute_n(&grid, 0.0, inside, origin, dir, &label, 5_000);
            }
        }
    }
}

#[test]
fn saddle_face_two_sheets_and_touch() {
    // f = (1 - 2x)(1 - 2y), the same on z = 0 and z = 1: the ambiguous face configuration.
    let grid = single_cell([1.0, -1.0, -1.0, 1.0, 1.0, -1.0, -1.0, 1.0]);
    let origin = DVec3::new(-1.0, -1.0, 0.5);
    let dir = DVec3::new(1.0, 1.0, 0.0); // along the diagonal; enters the cell at t = 1
                                         // iso = 0.1, Below: f = (1 - 2u)^2 on the diagonal dips under 0.1 around the centre.
    let (res, visits) = trace_detailed(&grid, 0.1, Inside::Below, origin, dir, &opts(10));
    let s = 0.1f64.sqrt() / 2.0;
    let ts = crossing_ts(&visits);
    assert_eq!(ts.len(), 2);
    assert!((ts[0] - (1.5 - s)).abs() < 1e-15 && (ts[1] - (1.5 + s)).abs() < 1e-15, "{ts:?}");
    assert!(res.hit.unwrap().entering);
    // The other diagonal stays inside the whole way.
    let res = trace(
        &grid,
        0.1,
        Inside::Below,
        DVec3::new(-1.0, 2.0, 0.5),
        DVec3::new(1.0, -1.0, 0.0),
        &opts(10),
    );
    assert!(res.inside_at_start && res.crossings == 0 && res.hit.is_none());

    // iso = 0: the two sheets meet in the line x = y = 1/2, and the diagonal touches it.
    // Below: f = (1 - 2u)^2 >= 0 is never inside, the touch is from outside: no crossing.
    let res = trace(&grid, 0.0, Inside::Below, origin, dir, &opts(10));
    assert_eq!((res.crossings, res.hit), (0, None));
    // Above: inside on both sides, exactly on the surface at u = 1/2 (a derivative root):
    // two crossings at the same t, the first a hit with the zero-gradient fallback normal.
    let (res, visits) = trace_detailed(&grid, 0.0, Inside::Above, origin, dir, &opts(10));
    assert_eq!(res.crossings, 2);
    assert_eq!(visits[0].derivative_roots, vec![0.5]);
    assert!(visits[0].roots.iter().all(|r| r.exact && r.t == 1.5));
    let hit = res.hit.unwrap();
    assert_eq!((hit.t, hit.entering), (1.5, false));
    assert_eq!(hit.normal, -dir.normalize());
    let second = trace(
        &grid,
        0.0,
        Inside::Above,
        origin,
        dir,
        &AnalyticOptions { newton_steps: 10, crossing: 2, ..Default::default() },
    );
    assert_eq!(second.hit.map(|h| (h.t, h.entering)), Some((1.5, true)));
}

#[test]
fn diagonal_corners_separated_or_tunnel() {
    // v000 = v111 = 1, the other six corners equal to -a. Along the main diagonal
    // f(u, u, u) = 1 - 3(1 + a) u + 3(1 + a) u^2 (axyz = 0 by symmetry).
    let origin = DVec3::splat(-0.5);
    let dir = DVec3::ONE; // through the corners (0,0,0) at t = 0.5 and (1,1,1) at t = 1.5
                          // Others = -1: f = 1 - 6u + 6u^2 < 0 in the middle, the positive corners are separated.
    let grid = single_cell([1.0, -1.0, -1.0, -1.0, -1.0, -1.0, -1.0, 1.0]);
    let (res, visits) = trace_detailed(&grid, 0.0, Inside::Above, origin, dir, &opts(10));
    assert_eq!(res.cells_total, 1);
    assert!(res.inside_at_start);
    let ts = crossing_ts(&visits);
    let r = 3f64.sqrt() / 6.0;
    assert_eq!(ts.len(), 2);
    assert!((ts[0] - (1.0 - r)).abs() < 1e-15 && (ts[1] - (1.0 + r)).abs() < 1e-15, "{ts:?}");
    // Others = -0.25: f = 1 - 3.75u + 3.75u^2 >= 1/16 > 0: a tunnel joins the two corners.
    let grid = single_cell([1.0, -0.25, -0.25, -0.25, -0.25, -0.25, -0.25, 1.0]);
    let res = trace(&grid, 0.0, Inside::Above, origin, dir, &opts(10));
    assert!(res.inside_at_start && res.crossings == 0);
    // The centre line x = y = 1/2 runs through the tunnel at f = 1/16 all the way.
    let res = trace(&grid, 0.0, Inside::Above, DVec3::new(0.5, 0.5, -1.0), DVec3::Z, &opts(10));
    assert!(res.inside_at_start && res.crossings == 0);
    // With iso above 1/16 the tunnel closes and that line crosses nothing either (outside).
    let res = trace(&grid, 0.07, Inside::Above, DVec3::new(0.5, 0.5, -1.0), DVec3::Z, &opts(10));
    assert!(!res.inside_at_start && res.crossings == 0);
    compare_with_brute(
        &grid,
        0.0,
        Inside::Above,
        DVec3::new(0.2, 0.3, -1.0),
        DVec3::new(0.1, 0.05, 1.0),
        "tunnel",
    );
    compare_with_brute(&grid, 0.03, Inside::Below, origin, dir, "tunnel diagonal");
}

/// A grid whose spacing is a power of two in every axis, so that index-space directions made of
/// small integers are exact and rays pass exactly through grid points, edges and faces.
fn dyadic_grid(rng: &mut Rng, dims: [usize; 3]) -> Grid {
    let spacing = DVec3::new(0.25, 0.5, 0.125);
    let min = DVec3::new(-1.0, 0.5, 2.0);
    let max = min
        + spacing * DVec3::new((dims[0] - 1) as f64, (dims[1] - 1) as f64, (dims[2] - 1) as f64);
    let values = (0..dims[0] * dims[1] * dims[2]).map(|_| rng.range(-1.0, 1.0) as f32).collect();
    Grid { dims, min, max, values }
}

#[test]
fn axis_parallel_rays() {
    let mut rng = Rng::new(7);
    for g in 0..20 {
        let grid =
            if g % 2 == 0 { random_grid(&mut rng, 8) } else { dyadic_grid(&mut rng, [6, 5, 7]) };
        let iso = rng.range(-0.3, 0.3);
        for r in 0..12 {
            let axis = r % 3;
            let sign = if r % 2 == 0 { 1.0 } else { -1.0 };
            let mut dir = DVec3::ZERO;
            dir[axis] = sign;
            // The other two coordinates: inside a cell, on a grid plane, or on a grid line.
            let mut idx = DVec3::new(rng.range(0.0, 1.0), rng.range(0.0, 1.0), rng.range(0.0, 1.0))
                * DVec3::from_array(grid.cells().map(|c| c as f64));
            for a in 0..3 {
                if a != axis && (r / 3 + a) % 3 != 0 {
                    // On a grid plane; the max face only where it is exact (dyadic spacing).
                    let top = grid.cells()[a] as f64 - if g % 2 == 0 { 1.0 } else { 0.0 };
                    idx[a] = idx[a].round().min(top);
                }
            }
            idx[axis] = if sign > 0.0 { -0.5 } else { grid.cells()[axis] as f64 + 0.5 };
            let origin = grid.min + idx * grid.spacing();
            for inside in [Inside::Below, Inside::Above] {
                let label = format!("grid {g} axis ray {r} {inside:?}");
                compare_with_brute(&grid, iso, inside, origin, dir, &label);
                let res = trace(&grid, iso, inside, origin, dir, &opts(10));
                assert_eq!(res.cells_total as usize, grid.cells()[axis], "{label}");
            }
        }
    }
}

#[test]
fn rays_along_grid_planes_lines_edges_and_corners() {
    let mut rng = Rng::new(8);
    // Index-space directions; those with two or three non-zero components go through edges
    // and corners of cells, those with a zero component lie in a grid plane.
    let dirs = [
        [1, 1, 0],
        [1, -1, 0],
        [0, 1, 1],
        [1, 0, -1],
        [1, 1, 1],
        [-1, 1, 1],
        [2, 1, 0],
        [1, 2, 2],
        [0, 0, 1],
        [1, 0, 0],
    ];
    for g in 0..12 {
        let grid = dyadic_grid(&mut rng, [5 + g % 3, 6, 5]);
        let iso = rng.range(-0.3, 0.3);
        let h = grid.spacing();
        let cells = grid.cells();
        for (r, di) in dirs.iter().enumerate() {
            let di = DVec3::new(di[0] as f64, di[1] as f64, di[2] as f64);
            // Through a grid point, from 8 index steps back.
            let p = DVec3::new(
                rng.below(cells[0] + 1) as f64,
                rng.below(cells[1] + 1) as f64,
                rng.below(cells[2] + 1) as f64,
            );
            let origin = grid.min + (p - di * 8.0) * h;
            let dir = di * h;
            for inside in [Inside::Below, Inside::Above] {
                compare_with_brute(
                    &grid,
                    iso,
                    inside,
                    origin,
                    dir,
                    &format!("grid {g} dir {r} {inside:?}"),
                );
            }
            // Exact ties step all axes together: the (1,1,1) diagonal from corner (0,0,0) visits
            // one cell per step.
        }
        let n = cells[0].min(cells[1]).min(cells[2]);
        let origin = grid.min - h;
        let res = trace(&grid, iso, Inside::Below, origin, h, &opts(10));
        assert_eq!(res.cells_total as usize, n, "grid {g}");
        let (_, visits) = trace_detailed(&grid, iso, Inside::Below, origin, h, &opts(10));
        for (s, v) in visits.iter().enumerate() {
            assert_eq!(v.cell, [s as i32; 3]);
            assert_eq!((v.q_in, v.q_out), (DVec3::ZERO, DVec3::ONE));
        }
    }
}

#[test]
fn rays_starting_inside_the_box() {
    let mut rng = Rng::new(9);
    for g in 0..40 {
        let grid = random_grid(&mut rng, 6);
        let iso = rng.range(-0.3, 0.3);
        for r in 0..6 {
            let origin = grid.min + (grid.max - grid.min) * rng.vec(0.0, 1.0);
            let dir = rng.direction();
            for inside in [Inside::Below, Inside::Above] {
                let label = format!("grid {g} inner ray {r} {inside:?}");
                compare_with_brute(&grid, iso, inside, origin, dir, &label);
                let res = trace(&grid, iso, inside, origin, dir, &opts(10));
                assert_eq!(res.span.unwrap().0, 0.0, "{label}");
                let f = crate::reference::trilinear::value_at(&grid, origin).unwrap();
                assert_eq!(res.inside_at_start, inside.contains(f, iso), "{label}");
                if let Some(h) = res.hit {
                    assert_eq!(h.entering, !res.inside_at_start, "{label}");
                }
            }
        }
    }
}

#[test]
fn surface_on_a_grid_plane() {
    // f = x - 2 on integer points: the surface is the grid plane x = 2, every crossing lands
    // exactly on a cell face, at the face's t, in the cell on the inside side.
    let grid = grid_from_fn([5, 3, 3], DVec3::ZERO, DVec3::new(4.0, 2.0, 2.0), |p| p.x - 2.0);
    for (origin, dir) in [
        (DVec3::new(-0.5, 0.3, 0.7), DVec3::X),
        (DVec3::new(4.5, 0.3, 0.7), -DVec3::X),
        (DVec3::new(-0.5, 0.3, 0.7), DVec3::new(1.0, 0.25, 0.125)),
        (DVec3::new(4.5, 1.0, 1.0), DVec3::new(-1.0, 0.0, 0.0)),
    ] {
        let t = (2.0 - origin.x) / dir.x;
        for inside in [Inside::Below, Inside::Above] {
            let (res, visits) = trace_detailed(&grid, 0.0, inside, origin, dir, &opts(10));
            let hit = res.hit.unwrap();
            assert_eq!(res.crossings, 1, "{origin} {inside:?}");
            assert_eq!(hit.t, t, "{origin} {inside:?}");
            let inside_cell = match inside {
                Inside::Below => 1,
                Inside::Above => 2,
            };
            assert_eq!(hit.cell[0], inside_cell, "{origin} {inside:?}");
            let root = visits.iter().flat_map(|v| &v.roots).next().unwrap();
            assert!(root.exact && root.iterates.is_empty());
            let normal = if inside == Inside::Below { DVec3::X } else { -DVec3::X };
            assert_eq!(hit.normal, normal);
            assert_eq!(hit.entering, dir.dot(normal) < 0.0);
        }
    }
    // Starting on the surface: the change at t = 0 is not a crossing.
    let on = DVec3::new(2.0, 0.5, 0.5);
    for dir in [DVec3::X, -DVec3::X, DVec3::new(-1.0, 0.3, 0.2), DVec3::new(1.0, -0.3, 0.2)] {
        for inside in [Inside::Below, Inside::Above] {
            let (res, visits) = trace_detailed(&grid, 0.0, inside, on, dir, &opts(10));
            assert_eq!((res.crossings, res.hit), (0, None), "{dir} {inside:?}");
            assert!(!res.inside_at_start);
            // Heading inside: one dropped root (crossing number 0) in the trace.
            let heads_inside = match inside {
                Inside::Below => dir.x < 0.0,
                Inside::Above => dir.x > 0.0,
            };
            let roots: Vec<u32> =
                visits.iter().flat_map(|v| &v.roots).map(|r| r.crossing).collect();
            assert_eq!(roots, if heads_inside { vec![0] } else { vec![] }, "{dir} {inside:?}");
        }
    }
    // A box face on the surface: f = x - 4 is zero on the face x = 4 and inside (Below)
    // everywhere else. Entering through that face, or leaving through it, is a crossing there.
    let grid = grid_from_fn([5, 3, 3], DVec3::ZERO, DVec3::new(4.0, 2.0, 2.0), |p| p.x - 4.0);
    let res = trace(&grid, 0.0, Inside::Below, DVec3::new(5.0, 1.0, 1.0), -DVec3::X, &opts(10));
    assert_eq!(res.hit.map(|h| (h.t, h.entering, h.cell[0])), Some((1.0, true, 3)));
    let res = trace(&grid, 0.0, Inside::Below, DVec3::new(-1.0, 1.0, 1.0), DVec3::X, &opts(10));
    assert_eq!(res.hit.map(|h| (h.t, h.entering, h.cell[0])), Some((5.0, false, 3)));
    assert!(res.inside_at_start);
    // The opposite face is not surface: entering inside there is no crossing.
    // (this ray leaves through the face y = 2, also inside).
    let res = trace(
        &grid,
        0.0,
        Inside::Below,
        DVec3::new(-1.0, 1.0, 1.0),
        DVec3::new(1.0, 0.5, 0.0),
        &opts(10),
    );
    assert_eq!((res.crossings, res.inside_at_start), (0, true));
}

#[test]
fn corner_equal_to_the_isovalue() {
    // 3x3x3 points, centre 0, the rest -1: with iso 0 and Below, the only surface point is the
    // centre, inside all around it.
    let mut values = [-1.0f32; 27];
    values[13] = 0.0;
    let grid =
        Grid { dims: [3, 3, 3], min: DVec3::ZERO, max: DVec3::splat(2.0), values: values.to_vec() };
    let dir = DVec3::new(0.5, 0.25, 0.75);
    let origin = DVec3::ONE - dir * 2.0; // through the centre at t = 2, an exact tie of 3 planes
    let (res, visits) = trace_detailed(&grid, 0.0, Inside::Below, origin, dir, &opts(10));
    assert_eq!(res.crossings, 2);
    assert!(res.inside_at_start);
    let hit = res.hit.unwrap();
    assert_eq!((hit.t, hit.entering, hit.cell), (2.0, false, [0, 0, 0]));
    assert!((hit.normal - DVec3::ONE.normalize()).length() < 1e-15);
    assert_eq!(visits.len(), 2, "diagonal step through the corner");
    let second = trace(
        &grid,
        0.0,
        Inside::Below,
        origin,
        dir,
        &AnalyticOptions { newton_steps: 10, crossing: 2, ..Default::default() },
    );
    let h2 = second.hit.unwrap();
    assert_eq!((h2.t, h2.entering, h2.cell), (2.0, true, [1, 1, 1]));
    assert!((h2.normal + DVec3::ONE.normalize()).length() < 1e-15);
    // A ray that misses the point by a little sees nothing.
    let res = trace(&grid, 0.0, Inside::Below, origin + DVec3::new(1e-3, 0.0, 0.0), dir, &opts(10));
    assert_eq!((res.crossings, res.inside_at_start), (0, true));
    // With Above nothing is inside: the centre is a touch from outside.
    let res = trace(&grid, 0.0, Inside::Above, origin, dir, &opts(10));
    assert_eq!((res.crossings, res.inside_at_start), (0, false));
    // Along a grid line through the centre (an axis ray through corners).
    let res = trace(&grid, 0.0, Inside::Below, DVec3::new(-1.0, 1.0, 1.0), DVec3::X, &opts(10));
    assert_eq!(res.crossings, 2);
    assert_eq!(res.hit.map(|h| (h.t, h.cell)), Some((2.0, [0, 1, 1])));

    // A plateau: x-profile -1, 0, 0, -1 (iso 0, Below): outside on [1, 2], inside around it.
    let grid = grid_from_fn([4, 2, 2], DVec3::ZERO, DVec3::new(3.0, 1.0, 1.0), |p| {
        if p.x == 1.0 || p.x == 2.0 {
            0.0
        } else {
            -1.0
        }
    });
    let (res, visits) =
        trace_detailed(&grid, 0.0, Inside::Below, DVec3::new(-1.0, 0.5, 0.5), DVec3::X, &opts(10));
    let ts = crossing_ts(&visits);
    assert_eq!(ts, vec![2.0, 3.0]);
    assert_eq!(res.hit.map(|h| (h.cell[0], h.entering)), Some((0, false)));
    assert!(visits[1].roots.is_empty(), "the plateau cell has no crossing");
    assert!(visits[2].roots[0].entering);
}

#[test]
fn no_slip_through_faces_near_the_surface() {
    // Place the surface exactly through a point of an interior face (iso = the field there) and
    // shoot rays through that point, plus rays with iso a few ulps either side: the crossing
    // must be found, in one cell or the other, never in neither.
    let mut rng = Rng::new(10);
    let mut found = 0;
    for g in 0..30 {
        let grid =
            if g % 2 == 0 { random_grid(&mut rng, 5) } else { dyadic_grid(&mut rng, [4, 5, 4]) };
        let cells = grid.cells();
        for r in 0..12 {
            let axis = r % 3;
            let mut idx = DVec3::new(rng.unit(), rng.unit(), rng.unit())
                * DVec3::from_array(cells.map(|c| c as f64));
            if cells[axis] < 2 {
                continue;
            }
            idx[axis] = (1 + rng.below(cells[axis] - 1)) as f64;
            let point = grid.min + idx * grid.spacing();
            let base = crate::reference::trilinear::value_at(&grid, point).unwrap();
            let dir = rng.direction();
            let origin = point - dir * 3.0;
            for ulps in [-2i64, 0, 2] {
                let iso = f64::from_bits((base.to_bits() as i64 + ulps) as u64);
                for inside in [Inside::Below, Inside::Above] {
                    let label = format!("grid {g} ray {r} ulps {ulps} {inside:?}");
                    compare_with_brute(&grid, iso, inside, origin, dir, &label);
                    let (_, visits) = trace_detailed(&grid, iso, inside, origin, dir, &opts(64));
                    let near =
                        crossing_ts(&visits).iter().filter(|&&t| (t - 3.0).abs() < 1e-6).count();
                    // A transversal crossing at the face point is found exactly once. The
                    // field is only C0 across the face, so transversal means the same clear
                    // slope along the ray in both cells (opposite slopes make a kink that
                    // touches the isovalue: a near-tangency, 0 or 2 crossings).
                    if slope_across(&grid, idx, axis, dir).is_some() {
                        assert_eq!(near, 1, "{label}");
                        found += 1;
                    }
                }
            }
        }
    }
    assert!(found > 300, "{found}");
}

/// The field's slope along `dir` at index-space point `idx` on an interior face normal to
/// `axis`, when both cells sharing the face agree on its sign and it is clearly non-zero.
fn slope_across(grid: &Grid, idx: DVec3, axis: usize, dir: DVec3) -> Option<f64> {
    let cells = grid.cells();
    let mut slopes = [0.0; 2];
    for (side, slope) in slopes.iter_mut().enumerate() {
        let mut cell = [0usize; 3];
        let mut q = DVec3::ZERO;
        for a in 0..3 {
            let c = if a == axis {
                idx[a] - 1.0 + side as f64
            } else {
                idx[a].floor().min(cells[a] as f64 - 1.0)
            };
            cell[a] = c as usize;
            q[a] = idx[a] - c;
        }
        *slope = crate::reference::trilinear::world_gradient(grid, cell, q).dot(dir);
    }
    let scale = grid.spacing().max_element();
    (slopes[0] * slopes[1] > 0.0 && slopes[0].abs().min(slopes[1].abs()) * scale > 1e-3)
        .then_some(slopes[0])
}

#[test]
fn face_values_agree_between_independent_cells() {
    // The property a per-cell GPU port relies on: the exit value of one cell and the entry value
    // the next cell would compute on its own are the same bits.
    let mut rng = Rng::new(11);
    for _ in 0..50 {
        let grid = random_grid(&mut rng, 6);
        let origin = grid.min - rng.vec(0.1, 1.0);
        let dir = (grid.max - (grid.max - grid.min) * rng.vec(0.0, 0.8) - origin).normalize();
        let (_, visits) = trace_detailed(&grid, 0.1, Inside::Below, origin, dir, &opts(10));
        for w in visits.windows(2) {
            let own = trilerp(&corners(&w[1]), w[1].q_in) - 0.1;
            assert_eq!(own.to_bits(), w[1].splits[0].g.to_bits());
            let prev = trilerp(&corners(&w[0]), w[0].q_out) - 0.1;
            assert_eq!(prev.to_bits(), own.to_bits());
        }
    }
}

#[test]
fn coefficients_follow_the_field_along_each_segment() {
    let mut rng = Rng::new(12);
    for _ in 0..30 {
        let grid = random_grid(&mut rng, 6);
        let origin = grid.min - rng.vec(0.1, 1.0);
        let dir = (grid.max - origin).normalize();
        let (_, visits) = trace_detailed(&grid, -0.2, Inside::Above, origin, dir, &opts(10));
        for v in &visits {
            let cubic = Cubic { c: monomial(v) };
            for i in 0..=8 {
                let u = i as f64 / 8.0;
                let f = trilerp(&corners(v), lerp3(v.q_in, v.q_out, u)) + 0.2;
                assert!((cubic.eval(u) - f).abs() < 1e-13, "{} vs {f}", cubic.eval(u));
            }
            for s in &v.splits[1..v.splits.len() - 1] {
                assert!(v.derivative_roots.contains(&s.u));
            }
        }
    }
}

#[test]
fn misses_and_degenerate_rays() {
    let mut rng = Rng::new(13);
    let grid = dyadic_grid(&mut rng, [4, 5, 3]);
    let o = AnalyticOptions::default();
    let miss = AnalyticHit::default();
    // Pointing away, passing by, zero or non-finite direction, non-finite origin.
    assert_eq!(trace(&grid, 0.0, Inside::Below, grid.max + DVec3::ONE, DVec3::ONE, &o), miss);
    assert_eq!(trace(&grid, 0.0, Inside::Below, grid.max + DVec3::ONE, DVec3::X, &o), miss);
    assert_eq!(trace(&grid, 0.0, Inside::Below, grid.min, DVec3::ZERO, &o), miss);
    assert_eq!(
        trace(&grid, 0.0, Inside::Below, grid.min, DVec3::new(f64::NAN, 1.0, 0.0), &o),
        miss
    );
    assert_eq!(trace(&grid, 0.0, Inside::Below, DVec3::splat(f64::INFINITY), DVec3::X, &o), miss);
    // A direction that underflows to zero in index space.
    let mut huge = grid.clone();
    huge.max = huge.min + DVec3::splat(1e300);
    assert_eq!(trace(&huge, 0.0, Inside::Below, huge.min, DVec3::splat(1e-300), &o), miss);
    // A flat box (min == max on one axis) has no cells.
    let mut flat = grid.clone();
    flat.max.z = flat.min.z;
    assert_eq!(trace(&flat, 0.0, Inside::Below, flat.min - DVec3::ONE, DVec3::ONE, &o), miss);
    // Grazing a box edge: a one-point span, visited but no crossing possible.
    let edge = DVec3::new(grid.min.x, grid.min.y, 0.5 * (grid.min.z + grid.max.z));
    let dir = DVec3::new(1.0, -1.0, 0.0);
    let res = trace(&grid, 0.0, Inside::Below, edge - dir, dir, &o);
    let (lo, hi) = res.span.unwrap();
    assert!((hi - lo).abs() < 1e-12 && res.crossings == 0 && res.hit.is_none());
    // Starting on the far face, heading out.
    let res = trace(&grid, 0.0, Inside::Below, grid.max, DVec3::ONE, &o);
    assert_eq!(res, miss);
    // A ray lying in a box face is inside the box.
    let res = trace(
        &grid,
        0.0,
        Inside::Below,
        DVec3::new(grid.min.x - 1.0, grid.min.y, grid.min.z),
        DVec3::X,
        &o,
    );
    assert!(res.span.is_some() && res.cells_total as usize == grid.cells()[0]);
    // crossing = 0 reads as 1.
    let origin = grid.min - DVec3::ONE;
    let dir = (grid.max - origin).normalize();
    let zero = AnalyticOptions { newton_steps: 10, crossing: 0, ..Default::default() };
    assert_eq!(
        trace(&grid, 0.0, Inside::Below, origin, dir, &zero),
        trace(&grid, 0.0, Inside::Below, origin, dir, &o)
    );
}

#[test]
fn unnormalised_directions_keep_their_t() {
    let mut rng = Rng::new(14);
    for _ in 0..30 {
        let grid = random_grid(&mut rng, 5);
        let origin = grid.min - rng.vec(0.1, 1.0);
        let dir = (grid.max - (grid.max - grid.min) * rng.vec(0.0, 0.8) - origin).normalize();
        let scale = rng.range(0.01, 100.0);
        let a = trace(&grid, 0.0, Inside::Below, origin, dir, &opts(64));
        let b = trace(&grid, 0.0, Inside::Below, origin, dir * scale, &opts(64));
        assert_eq!(a.crossings, b.crossings);
        if let (Some(ha), Some(hb)) = (a.hit, b.hit) {
            assert!((ha.t - hb.t * scale).abs() < 1e-9 * diagonal(&grid));
            assert!((ha.position - hb.position).length() < 1e-9 * diagonal(&grid));
            assert!((ha.normal - hb.normal).length() < 1e-9);
        }
    }
}

/// FNV-1a over 64-bit words.
fn fnv(hash: &mut u64, words: impl IntoIterator<Item = u64>) {
    for w in words {
        for byte in w.to_le_bytes() {
            *hash ^= u64::from(byte);
            *hash = hash.wrapping_mul(0x0100_0000_01b3);
        }
    }
}

/// The bits of everything a trilinear trace reports, hit and per-cell detail.
fn trace_bits(hash: &mut u64, res: &AnalyticHit, visits: &[CellVisit]) {
    let v3 = |v: DVec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
    if let Some(h) = res.hit {
        fnv(hash, [h.t.to_bits(), u64::from(h.entering), u64::from(h.crossing)]);
        fnv(hash, v3(h.position).into_iter().chain(v3(h.normal)).chain(v3(h.local)));
        fnv(hash, h.cell.map(|c| c as u64));
    }
    let (lo, hi) = res.span.unwrap_or((-1.0, -1.0));
    fnv(hash, [lo.to_bits(), hi.to_bits(), u64::from(res.inside_at_start)]);
    fnv(hash, [res.cells_visited, res.cells_total, res.crossings].map(u64::from));
    for v in visits {
        fnv(hash, v.cell.map(|c| c as u64));
        fnv(hash, [v.t_in.to_bits(), v.t_out.to_bits(), u64::from(v.missing)]);
        fnv(hash, v3(v.q_in).into_iter().chain(v3(v.q_out)));
        fnv(hash, v.derivative_roots.iter().map(|x| x.to_bits()));
        for s in &v.splits {
            fnv(hash, [s.u.to_bits(), s.g.to_bits(), u64::from(s.inside)]);
        }
        for r in &v.roots {
            fnv(hash, [r.crossing as u64, r.u.to_bits(), r.t.to_bits(), u64::from(r.exact)]);
            fnv(hash, [r.bracket.0.to_bits(), r.bracket.1.to_bits(), u64::from(r.entering)]);
            fnv(hash, r.iterates.iter().map(|x| x.to_bits()));
        }
    }
}

#[test]
fn trilinear_traces_keep_their_bits() {
    // A fingerprint of 3840 detailed traces (random grids, holes, every option), recorded before
    // the walk became generic over the interpolant (PLAN26 C3): the trilinear walk must not move
    // a bit. If this fails after a deliberate change to the trilinear reference, the GPU tests
    // (`render::analytic`) and the goldens have to be looked at too, then the number updated.
    let mut rng = Rng::new(41);
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    for g in 0..40 {
        let mut grid = random_grid(&mut rng, 7);
        if g % 5 == 4 {
            let n = grid.values.len();
            grid.values[rng.below(n)] = f32::NAN;
        }
        let iso = if g % 7 == 3 { f64::from(grid.values[0]) } else { rng.range(-0.5, 0.5) };
        let lo = grid.min - (grid.max - grid.min) * 0.5;
        let hi = grid.max + (grid.max - grid.min) * 0.5;
        for r in 0..12 {
            let origin =
                DVec3::new(rng.range(lo.x, hi.x), rng.range(lo.y, hi.y), rng.range(lo.z, hi.z));
            let target = grid.min + (grid.max - grid.min) * rng.vec(0.0, 1.0);
            let dir = if r % 4 == 3 { rng.direction() } else { (target - origin).normalize() };
            for inside in [Inside::Below, Inside::Above] {
                for (steps, crossing) in [(0, 1), (3, 1), (64, 2), (10, 3)] {
                    let o = AnalyticOptions { newton_steps: steps, crossing, ..Default::default() };
                    let (res, visits) = trace_detailed(&grid, iso, inside, origin, dir, &o);
                    trace_bits(&mut hash, &res, &visits);
                }
            }
        }
    }
    assert_eq!(hash, 11_387_521_989_531_088_764, "trilinear trace fingerprint");
}

mod tricubic;
