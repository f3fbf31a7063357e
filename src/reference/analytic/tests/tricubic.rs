//! The tricubic interpolants' analytic walk (PLAN26 §10, closed forms 1–4 at reference level):
//! exact surfaces of fields the kernels reproduce, degree-9 tensor polynomials against a
//! brute-force scan of their closed form, and random grids against a brute-force scan of the
//! interpolant itself.

use super::*;
use crate::field::interpolant::cubic::{blossom, BSplineWeights, CatmullRomWeights};
use crate::field::interpolant::{BSpline, CatmullRom, Interpolant, Interpolated};
use crate::reference::analytic::tricubic::segment;

const CUBICS: [Interpolant; 2] = [Interpolant::CubicBspline, Interpolant::CatmullRom];

fn trace_with(
    grid: &Grid,
    interp: Interpolant,
    iso: f64,
    inside: Inside,
    origin: DVec3,
    dir: DVec3,
) -> (AnalyticHit, Vec<CellVisit>) {
    let field = Interpolated::new(grid, interp);
    let (res, visits) = trace_detailed_interpolated(&field, iso, inside, origin, dir, &opts(64));
    let plain = trace_interpolated(&field, iso, inside, origin, dir, &opts(64));
    assert_eq!(plain, res, "{}: trace and trace_detailed differ", interp.name());
    (res, visits)
}

/// The world box of the points whose cubic stencils stay inside the grid (indices
/// `1 ..= n - 2`): there the edge clamp is never used and the kernels reproduce what they
/// reproduce exactly.
fn interior(grid: &Grid) -> (DVec3, DVec3) {
    let h = grid.spacing();
    (grid.min + h, grid.max - h)
}

fn in_box(rng: &mut Rng, (lo, hi): (DVec3, DVec3)) -> DVec3 {
    DVec3::new(rng.range(lo.x, hi.x), rng.range(lo.y, hi.y), rng.range(lo.z, hi.z))
}

/// Where the ray leaves the box `[lo, hi]`, for an origin inside it.
fn exit_t(origin: DVec3, dir: DVec3, (lo, hi): (DVec3, DVec3)) -> f64 {
    (0..3)
        .filter(|&a| dir[a] != 0.0)
        .map(|a| ((if dir[a] > 0.0 { hi[a] } else { lo[a] }) - origin[a]) / dir[a])
        .fold(f64::INFINITY, f64::min)
}

/// Every change of the predicate of `f(t)` over `[lo, hi]`: `samples` even samples, each change
/// bisected to the bottom.
fn scan(f: impl Fn(f64) -> bool, (lo, hi): (f64, f64), samples: usize) -> Vec<f64> {
    let mut roots = Vec::new();
    let at = |i: usize| lo + (hi - lo) * i as f64 / (samples - 1) as f64;
    let mut prev = f(at(0));
    for i in 1..samples {
        let p = f(at(i));
        if p != prev {
            let (mut a, mut b) = (at(i - 1), at(i));
            for _ in 0..200 {
                let m = 0.5 * (a + b);
                if m <= a || m >= b {
                    break;
                }
                if f(m) == prev {
                    a = m;
                } else {
                    b = m;
                }
            }
            roots.push(0.5 * (a + b));
        }
        prev = p;
    }
    roots
}

/// Matches the walk's crossings `got` with the scan's `expected`: each within `tol`, except
/// pairs closer than two sample spacings (a dip the samples jumped over, or two roots within
/// `2^-16` of a segment that the walk's unresolved leaf reports as none: the near-tangency
/// clause). Returns how many such unmatched crossings there were.
fn match_crossings(got: &[f64], expected: &[f64], tol: f64, spacing: f64, label: &str) -> usize {
    let (mut extra_got, mut extra_exp) = (Vec::new(), Vec::new());
    let (mut i, mut j) = (0, 0);
    while i < got.len() || j < expected.len() {
        match (got.get(i), expected.get(j)) {
            (Some(&a), Some(&b)) if (a - b).abs() <= tol => {
                i += 1;
                j += 1;
            }
            (Some(&a), Some(&b)) if a < b => {
                extra_got.push(a);
                i += 1;
            }
            (Some(&a), None) => {
                extra_got.push(a);
                i += 1;
            }
            (_, Some(&b)) => {
                extra_exp.push(b);
                j += 1;
            }
            (None, None) => unreachable!(),
        }
    }
    for extra in [&extra_got, &extra_exp] {
        assert!(extra.len() % 2 == 0, "{label}: odd unmatched {extra:?}; {got:?} vs {expected:?}");
        for p in extra.chunks(2) {
            assert!(
                p[1] - p[0] < 2.0 * spacing,
                "{label}: unmatched pair {p:?} too far apart; {got:?} vs {expected:?}"
            );
        }
    }
    extra_got.len() + extra_exp.len()
}

#[test]
fn the_segment_polynomial_is_the_interpolant_along_the_segment() {
    let mut rng = Rng::new(31);
    for n in 0..200 {
        let s: [f64; 64] = std::array::from_fn(|_| rng.range(-1.0, 1.0));
        let q_in = rng.vec(0.0, 1.0);
        let q_out = if n % 10 == 0 { q_in } else { rng.vec(0.0, 1.0) };
        let iso = rng.range(-0.3, 0.3);
        for bspline in [true, false] {
            let (value, b): (fn(&[f64; 64], DVec3) -> f64, _) = if bspline {
                let v = <BSpline as Kernel>::value;
                let ends = (v(&s, q_in) - iso, v(&s, q_out) - iso);
                (v, segment::<BSplineWeights>(&s, q_in, q_out, iso, ends))
            } else {
                let v = <CatmullRom as Kernel>::value;
                let ends = (v(&s, q_in) - iso, v(&s, q_out) - iso);
                (v, segment::<CatmullRomWeights>(&s, q_in, q_out, iso, ends))
            };
            assert_eq!(b.degree, 9);
            assert_eq!(b.ends(), (value(&s, q_in) - iso, value(&s, q_out) - iso), "face values");
            for i in 0..=16 {
                let u = i as f64 / 16.0;
                let f = value(&s, lerp3(q_in, q_out, u)) - iso;
                assert!((b.eval(u) - f).abs() < 1e-13, "{n} {bspline} u {u}: {} vs {f}", b.eval(u));
            }
        }
    }
    // The blossom's diagonal is the weight (the coefficients above rest on it).
    assert_eq!(blossom::<BSplineWeights>(3, [0.5; 3]), 0.125 / 6.0);
}

#[test]
fn a_linear_field_gives_the_exact_plane_with_every_interpolant() {
    // Closed form 1: both cubic kernels reproduce linear fields, so away from the edge clamp
    // the tricubic surface of a linear field is trilinear's, the exact plane. Dyadic spacing and
    // coefficients keep the f32 samples exact.
    let a = DVec3::new(1.0, 2.0, -0.5);
    let grid =
        grid_from_fn([9, 10, 11], DVec3::new(-1.0, 0.0, 2.0), DVec3::new(1.0, 4.5, 3.25), |p| {
            a.dot(p)
        });
    let inner = interior(&grid);
    let mut rng = Rng::new(32);
    for n in 0..300 {
        // Origin and hit both in the interior box, so the whole path to the hit is there.
        let origin = in_box(&mut rng, inner);
        let target = in_box(&mut rng, inner);
        let dir = (target - origin).normalize();
        let iso = a.dot(origin.lerp(target, rng.range(0.05, 0.95)));
        let t = (iso - a.dot(origin)) / a.dot(dir);
        for inside in [Inside::Below, Inside::Above] {
            let normal = match inside {
                Inside::Below => a.normalize(),
                Inside::Above => -a.normalize(),
            };
            let tri = trace(&grid, iso, inside, origin, dir, &opts(64)).hit.expect("trilinear");
            for interp in CUBICS {
                let label = format!("ray {n} {} {inside:?}", interp.name());
                let (res, visits) = trace_with(&grid, interp, iso, inside, origin, dir);
                check_trace(&res, &visits, &label);
                let h = res.hit.unwrap_or_else(|| panic!("{label}: no hit at t = {t}"));
                assert!((h.t - t).abs() < 1e-12 * diagonal(&grid), "{label}: {} vs {t}", h.t);
                assert!((h.t - tri.t).abs() < 1e-12 * diagonal(&grid), "{label}: trilinear");
                assert!((h.normal - normal).length() < 1e-12, "{label}: {}", h.normal);
                assert_eq!(h.entering, dir.dot(normal) < 0.0, "{label}");
            }
        }
    }
}

/// `x² + y² + z²` sampled at spacing 1/8 on `[-1, 1]³` (exact in f32).
fn squares() -> Grid {
    grid_from_fn([17, 17, 17], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.length_squared())
}

/// Rays from the interior box outside the sphere of `radius`, at its core: the first crossing
/// must be the sphere's entry, with the radial normal.
fn exact_sphere(interp: Interpolant, iso: f64, radius: f64) {
    let grid = squares();
    let inner = interior(&grid);
    let mut rng = Rng::new(33);
    let mut n = 0;
    while n < 300 {
        let origin = in_box(&mut rng, inner);
        if origin.length() < radius + 0.05 {
            continue;
        }
        n += 1;
        let dir = (rng.vec(-0.3, 0.3) - origin).normalize();
        let (b, c) = (origin.dot(dir), origin.length_squared() - radius * radius);
        let t = -b - (b * b - c).sqrt();
        let label = format!("{} ray {n}", interp.name());
        let (res, visits) = trace_with(&grid, interp, iso, Inside::Below, origin, dir);
        check_trace(&res, &visits, &label);
        let h = res.hit.unwrap_or_else(|| panic!("{label}: no hit"));
        assert!((h.t - t).abs() < 1e-12, "{label}: t {} vs {t}", h.t);
        assert!(h.entering && !res.inside_at_start, "{label}");
        assert!((h.normal - h.position.normalize()).length() < 1e-9, "{label}: {}", h.normal);
        // Inside out: same place, reversed normal.
        let above = trace_with(&grid, interp, iso, Inside::Above, origin, dir).0.hit.unwrap();
        assert_eq!((above.t, above.normal), (h.t, -h.normal), "{label}");
    }
}

#[test]
fn catmull_rom_reproduces_the_quadric_sphere() {
    // Closed form 2: Catmull-Rom reproduces quadratics, so |p|² = r² is the exact sphere.
    exact_sphere(Interpolant::CatmullRom, 0.36, 0.6);
}

#[test]
fn bspline_shrinks_the_sphere_by_its_moments() {
    // Closed form 3: the B-spline maps x² to x² + h²/3 per axis, so the surface |p|² = r² of
    // the samples is the sphere of radius sqrt(r² - h²) (h = 1/8 on all three axes).
    exact_sphere(Interpolant::CubicBspline, 0.36, (0.36f64 - 1.0 / 64.0).sqrt());
}

/// `c0 + c1 x + c2 x² + c3 x³`.
fn poly(c: [f64; 4], x: f64) -> f64 {
    ((c[3] * x + c[2]) * x + c[1]) * x + c[0]
}

/// The uniform cubic B-spline's image of a cubic at unit spacing (its moments: 1, x, x² + 1/3,
/// x³ + x).
fn bspline_image(c: [f64; 4]) -> [f64; 4] {
    [c[0] + c[2] / 3.0, c[1] + c[3], c[2], c[3]]
}

/// Closed form 4: tensor polynomials `p(x) q(y) r(z)` on an integer grid (exact in f32), whose
/// interpolant is the image of each factor; every crossing in the interior box against a scan of
/// the closed form. Returns (crossings, unmatched near-tangent ones).
fn tensor_polynomial(interp: Interpolant, factors: [[f64; 4]; 3], seed: u64) -> (usize, usize) {
    let grid = grid_from_fn([8, 8, 8], DVec3::ZERO, DVec3::splat(7.0), |p| {
        poly(factors[0], p.x) * poly(factors[1], p.y) * poly(factors[2], p.z)
    });
    let image = match interp {
        Interpolant::CubicBspline => factors.map(bspline_image),
        _ => factors,
    };
    let closed = |p: DVec3| poly(image[0], p.x) * poly(image[1], p.y) * poly(image[2], p.z);
    let inner = interior(&grid);
    let mut rng = Rng::new(seed);
    let (mut total, mut unmatched) = (0, 0);
    for n in 0..150 {
        let origin = in_box(&mut rng, inner);
        let dir = rng.direction();
        let iso = rng.range(-8.0, 8.0);
        let t_end = exit_t(origin, dir, inner);
        for inside in [Inside::Below, Inside::Above] {
            let label = format!("{} ray {n} {inside:?}", interp.name());
            let (res, visits) = trace_with(&grid, interp, iso, inside, origin, dir);
            check_trace(&res, &visits, &label);
            let got: Vec<f64> = crossing_ts(&visits).into_iter().filter(|&t| t < t_end).collect();
            let samples = 20_000;
            let expected =
                scan(|t| inside.contains(closed(origin + dir * t), iso), (0.0, t_end), samples);
            // Crossings right at the interior box's end may fall on either side of it.
            let (got, expected) = trim(got, expected, t_end);
            let spacing = t_end / (samples - 1) as f64;
            unmatched += match_crossings(&got, &expected, 1e-9 * diagonal(&grid), spacing, &label);
            total += got.len();
            if let (Some(h), Some(&first)) = (res.hit, expected.first()) {
                if got.first().is_some_and(|&g| (g - first).abs() <= 1e-9 * diagonal(&grid)) {
                    assert!((h.t - first).abs() <= 1e-9 * diagonal(&grid), "{label}: first hit");
                }
            }
        }
    }
    (total, unmatched)
}

/// Drops crossings within 1e-9 of `end` from both lists.
fn trim(got: Vec<f64>, expected: Vec<f64>, end: f64) -> (Vec<f64>, Vec<f64>) {
    let keep = |v: Vec<f64>| v.into_iter().filter(|&t| end - t > 1e-9).collect();
    (keep(got), keep(expected))
}

#[test]
fn tensor_polynomials_of_degree_nine_match_their_closed_form() {
    // B-spline: cubic factors (degree 9 along a ray), their image by the moments.
    let cubic = [
        [-35.0, 34.5, -10.5, 1.0],   // (x - 2)(x - 5)(x - 3.5)
        [-36.0, 39.0, -11.5, 1.0],   // (y - 1.5)(y - 4)(y - 6)
        [-41.25, 37.75, -11.0, 1.0], // (z - 3)(z - 2.5)(z - 5.5)
    ];
    let (total, unmatched) = tensor_polynomial(Interpolant::CubicBspline, cubic, 34);
    assert!(total > 200, "too few crossings to mean anything: {total}");
    assert!(unmatched * 100 <= total, "too many near-tangent pairs: {unmatched} of {total}");
    // Catmull-Rom: quadratic factors, reproduced exactly (degree 6 along a ray).
    let quadratic = [
        [11.0, -7.5, 1.0, 0.0], // (x - 2)(x - 5.5)
        [4.5, -4.5, 1.0, 0.0],  // (y - 3)(y - 1.5)
        [10.0, -6.5, 1.0, 0.0], // (z - 4)(z - 2.5)
    ];
    let (total, unmatched) = tensor_polynomial(Interpolant::CatmullRom, quadratic, 35);
    assert!(total > 100, "too few crossings to mean anything: {total}");
    assert!(unmatched * 100 <= total, "too many near-tangent pairs: {unmatched} of {total}");
}

#[test]
fn random_grids_match_a_scan_of_the_interpolant() {
    // Every crossing of the walk against a dense scan of the interpolant itself along the ray
    // (`Interpolated::value_at`, no Bernstein form), bisected on the predicate.
    let mut rng = Rng::new(36);
    let (mut total, mut unmatched, mut unresolved) = (0, 0, 0);
    for g in 0..30 {
        let grid = random_grid(&mut rng, 7);
        let iso = rng.range(-0.3, 0.3);
        let lo = grid.min - (grid.max - grid.min) * 0.5;
        let hi = grid.max + (grid.max - grid.min) * 0.5;
        let h = grid.spacing();
        for r in 0..6 {
            let origin = in_box(&mut rng, (lo, hi));
            let target = in_box(&mut rng, (grid.min, grid.max));
            let dir = if r == 5 { rng.direction() } else { (target - origin).normalize() };
            for interp in CUBICS {
                let field = Interpolated::new(&grid, interp);
                for inside in [Inside::Below, Inside::Above] {
                    let label = format!("grid {g} ray {r} {} {inside:?}", interp.name());
                    let (res, visits) = trace_with(&grid, interp, iso, inside, origin, dir);
                    check_trace(&res, &visits, &label);
                    let Some(span) = res.span else { continue };
                    let samples = 20_000;
                    let n = DVec3::from_array(grid.cells().map(|c| c as f64));
                    let f = |t: f64| {
                        let u = ((origin + dir * t - grid.min) / h).clamp(DVec3::ZERO, n);
                        inside.contains(field.value_at(u), iso)
                    };
                    let expected = scan(f, span, samples);
                    let got = crossing_ts(&visits);
                    let spacing = (span.1 - span.0) / (samples - 1) as f64;
                    let tol = 1e-9 * diagonal(&grid);
                    unmatched += match_crossings(&got, &expected, tol, spacing, &label);
                    total += got.len();
                    unresolved +=
                        visits.iter().flat_map(|v| &v.leaves).filter(|l| !l.resolved).count();
                    // The hit is the first crossing, and where the scan saw it first too.
                    match (res.hit, got.first(), expected.first()) {
                        (Some(h), Some(&t), e) => {
                            assert_eq!(h.t, t, "{label}");
                            if e.is_some_and(|&e| (e - t).abs() <= tol) {
                                let p = (h.position - grid.min) / grid.spacing();
                                let g = field.value_at(p);
                                assert!((g - iso).abs() < 1e-12, "{label}: f = {g} at the hit");
                            }
                        }
                        (None, None, _) => {}
                        (hit, t, _) => panic!("{label}: hit {hit:?} vs first crossing {t:?}"),
                    }
                }
            }
        }
    }
    assert!(total > 500, "too few crossings to mean anything: {total}");
    assert!(unmatched * 100 <= total, "too many near-tangent pairs: {unmatched} of {total}");
    // Unresolved leaves only come from near-tangencies: rare.
    assert!(unresolved * 50 <= total, "{unresolved} unresolved leaves for {total} crossings");
}

#[test]
fn cubic_face_values_are_the_neighbours_bits() {
    // Each cell's entry value, computed from its own 64 samples, is the bits the previous cell
    // computed for its exit (the b0 / b9 override keeps the polynomial's ends on them).
    let mut rng = Rng::new(37);
    for _ in 0..30 {
        let grid = random_grid(&mut rng, 6);
        let origin = grid.min - rng.vec(0.1, 1.0);
        let dir = (grid.max - (grid.max - grid.min) * rng.vec(0.0, 0.8) - origin).normalize();
        let (_, visits) =
            trace_with(&grid, Interpolant::CatmullRom, 0.1, Inside::Below, origin, dir);
        for w in visits.windows(2) {
            let cell = |v: &CellVisit| v.cell.map(|c| c as usize);
            let own = <CatmullRom as RayCell>::value(
                &<CatmullRom as RayCell>::gather(&grid, cell(&w[1])),
                w[1].q_in,
            ) - 0.1;
            let prev = <CatmullRom as RayCell>::value(
                &<CatmullRom as RayCell>::gather(&grid, cell(&w[0])),
                w[0].q_out,
            ) - 0.1;
            assert_eq!(own.to_bits(), prev.to_bits());
            let b = w[1].coefficients.coefficients();
            assert_eq!(b[0].to_bits(), own.to_bits());
            assert_eq!(w[0].coefficients.coefficients()[9].to_bits(), prev.to_bits());
        }
    }
}

#[test]
fn kth_crossing_and_aovs_of_the_tricubic_walk() {
    // §3.3: the k-th hit is the k-th of the listed crossings, `cells_visited` counts up to the
    // hit cell, `cell` and `local` locate it, the normal is the kernel's gradient, inside to
    // outside, and crossings alternate in direction.
    let mut rng = Rng::new(38);
    let mut multi = 0;
    for g in 0..20 {
        let grid = random_grid(&mut rng, 6);
        let iso = rng.range(-0.3, 0.3);
        for _ in 0..4 {
            let origin = grid.min - rng.vec(0.1, 1.0);
            let target = grid.max - (grid.max - grid.min) * rng.vec(0.0, 0.5);
            let dir = (target - origin).normalize();
            for interp in CUBICS {
                let field = Interpolated::new(&grid, interp);
                for inside in [Inside::Below, Inside::Above] {
                    let label = format!("grid {g} {} {inside:?}", interp.name());
                    let (all, visits) = trace_with(&grid, interp, iso, inside, origin, dir);
                    let ts = crossing_ts(&visits);
                    multi += usize::from(ts.len() > 1);
                    let mut entering = !all.inside_at_start;
                    for k in 1..=ts.len() as u32 + 1 {
                        let o = AnalyticOptions { newton_steps: 64, crossing: k, ..opts(64) };
                        let res = trace_interpolated(&field, iso, inside, origin, dir, &o);
                        assert_eq!(
                            (res.crossings, res.cells_total),
                            (all.crossings, all.cells_total)
                        );
                        let Some(h) = res.hit else {
                            assert_eq!(k as usize, ts.len() + 1, "{label}");
                            assert_eq!(res.cells_visited, res.cells_total, "{label}");
                            continue;
                        };
                        assert_eq!((h.t, h.crossing), (ts[k as usize - 1], k), "{label} k {k}");
                        assert_eq!(h.entering, entering, "{label} k {k}");
                        entering = !entering;
                        // The hit cell is the cells_visited-th visit, and holds the root.
                        let v = &visits[res.cells_visited as usize - 1];
                        assert_eq!(v.cell, h.cell, "{label} k {k}");
                        assert!(v.roots.iter().any(|r| r.t == h.t), "{label} k {k}");
                        let idx = DVec3::from_array(h.cell.map(f64::from)) + h.local;
                        assert!(
                            ((grid.min + idx * grid.spacing()) - h.position).length()
                                < 1e-12 * diagonal(&grid),
                            "{label} k {k}: local"
                        );
                        let grad = field.gradient_at(idx);
                        let outward = match inside {
                            Inside::Below => grad,
                            Inside::Above => -grad,
                        };
                        if outward.length() > 1e-6 {
                            assert!((h.normal - outward.normalize()).length() < 1e-9, "{label}");
                        }
                    }
                }
            }
        }
    }
    assert!(multi > 20, "only {multi} rays with several crossings");
}

#[test]
fn a_missing_sample_empties_every_cell_whose_stencil_reads_it() {
    // field.nan = "empty": a tricubic cell is missing when any of its 64 samples is, so a NaN
    // empties the 4x4x4 cells around it, and no crossing is found there.
    let mut rng = Rng::new(39);
    for g in 0..20 {
        let mut grid = random_grid(&mut rng, 7);
        let hole = [0, 1, 2].map(|a| rng.below(grid.dims[a]));
        let idx = grid.index(hole[0], hole[1], hole[2]);
        grid.values[idx] = f32::NAN;
        let origin = grid.min - rng.vec(0.1, 1.0);
        let target = grid.min + (grid.max - grid.min) * rng.vec(0.2, 0.8);
        let dir = (target - origin).normalize();
        for interp in CUBICS {
            let (res, visits) = trace_with(&grid, interp, 0.0, Inside::Below, origin, dir);
            assert_eq!(crossing_ts(&visits).len() as u32, res.crossings);
            for v in &visits {
                // Offsets -1..=2 around the cell, clamped: does the stencil read the hole?
                let reads = (0..3).all(|a| {
                    let c = v.cell[a] as usize;
                    (0..4).any(|o| (c + o).saturating_sub(1).min(grid.dims[a] - 1) == hole[a])
                });
                assert_eq!(v.missing, reads, "grid {g} cell {:?} hole {hole:?}", v.cell);
                assert_eq!(v.samples.iter().any(|s| s.is_nan()), reads);
                if v.missing {
                    assert!(v.roots.is_empty() && v.leaves.is_empty());
                }
            }
        }
    }
}

/// The tricubic walks' skipping bound (`passes::bricks::Bound`, `shaders/tricubic.comp`): on
/// random grids (sizes across brick boundaries and the grid's border, where the edge clamp
/// repeats points), every value of each interpolant sampled densely in a brick's cells, and
/// every Bernstein coefficient of random segments through them (what the walk decides the
/// predicate on, before de Casteljau averages them), lies in the brick's range: the samples
/// its cells' stencils read, for Catmull-Rom widened by `KAPPA` of its width on each side. In
/// f64 against the exact widening, and the f32 range the GPU skips with (the CPU twin of
/// bricks.comp) is that one up to rounding, far inside `SKIP_MARGIN`. The test also requires
/// the widening to be needed: Catmull-Rom leaves the unwidened range (why the stencil's apron is
/// needed too: `tests/it/render/interpolants.rs`, the skipping bounds test, which fails with
/// either bound too tight).
#[test]
fn brick_ranges_bound_the_cubic_interpolants() {
    use crate::field::interpolant::cubic::Weights;
    use crate::passes::bricks::{self, Bound, BRICK};
    let mut rng = Rng::new(57);
    for interp in CUBICS {
        let bound =
            if interp == Interpolant::CatmullRom { Bound::CatmullRom } else { Bound::Cubic };
        let kappa = if interp == Interpolant::CatmullRom { CatmullRomWeights::KAPPA } else { 0.0 };
        let (mut overshoots, mut outside_corners, mut checked) = (0, 0, 0);
        for case in 0..40 {
            let dims = [0; 3].map(|_| 2 + rng.below(20));
            let mut grid = random_grid(&mut rng, 3);
            grid.dims = dims;
            grid.values = (0..dims.iter().product::<usize>())
                .map(|_| {
                    // Steps and spikes make Catmull-Rom overshoot; smooth noise the rest.
                    let v = rng.range(-1.0, 1.0);
                    (if case % 2 == 0 { v.signum() } else { v }) as f32
                })
                .collect();
            let field = Interpolated::new(&grid, interp);
            let ranges = bricks::reference_for(&grid, bound);
            let corners = bricks::reference(&grid);
            let counts = bricks::brick_counts(dims);
            let stencil = bound.stencil();
            for (n, (&range, &corner)) in ranges.iter().zip(&corners).enumerate() {
                let b = [n % counts[0], n / counts[0] % counts[1], n / (counts[0] * counts[1])];
                // The exact range: the stencil's samples, widened in f64.
                let span = |a: usize| stencil.brick_points(b[a], BRICK, dims[a]);
                let (mut m, mut big_m) = (f64::INFINITY, f64::NEG_INFINITY);
                for k in span(2) {
                    for j in span(1) {
                        for i in span(0) {
                            let v = f64::from(grid.at(i, j, k));
                            (m, big_m) = (m.min(v), big_m.max(v));
                        }
                    }
                }
                let (lo, hi) = (m - kappa * (big_m - m), big_m + kappa * (big_m - m));
                let slack = 8.0 * f64::from(f32::EPSILON) * (lo.abs().max(hi.abs()));
                assert!(
                    (f64::from(range[0]) - lo).abs() <= slack
                        && (f64::from(range[1]) - hi).abs() <= slack,
                    "{} brick {b:?}: f32 range {range:?} vs [{lo}, {hi}]",
                    interp.name()
                );
                // The brick's cells in grid coordinates.
                let cell_lo = b.map(|c| (c * BRICK) as f64);
                let cell_hi: [f64; 3] =
                    std::array::from_fn(|a| (((b[a] + 1) * BRICK).min(dims[a] - 1)) as f64);
                let point = |rng: &mut Rng| {
                    DVec3::new(
                        rng.range(cell_lo[0], cell_hi[0]),
                        rng.range(cell_lo[1], cell_hi[1]),
                        rng.range(cell_lo[2], cell_hi[2]),
                    )
                };
                let tol = 1e-12 * (1.0 + lo.abs().max(hi.abs()));
                for _ in 0..200 {
                    let u = point(&mut rng);
                    let v = field.value_at(u);
                    checked += 1;
                    assert!(
                        v >= lo - tol && v <= hi + tol,
                        "{} brick {b:?} at {u}: {v} not in [{lo}, {hi}]",
                        interp.name()
                    );
                    overshoots += (v < m - 1e-9 || v > big_m + 1e-9) as usize;
                    outside_corners += (v < f64::from(corner[0]) - 1e-9
                        || v > f64::from(corner[1]) + 1e-9)
                        as usize;
                }
                // Segments inside one cell of the brick: their Bernstein coefficients.
                for _ in 0..20 {
                    let u0 = point(&mut rng);
                    let c = grid.cell_of(u0);
                    let base = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
                    let q_in = (u0 - base).clamp(DVec3::ZERO, DVec3::ONE);
                    let q_out = rng.vec(0.0, 1.0);
                    let s: [f64; 64] = std::array::from_fn(|i| {
                        let at = |a: usize, o: usize| (c[a] + o).saturating_sub(1).min(dims[a] - 1);
                        f64::from(grid.at(at(0, i & 3), at(1, i >> 2 & 3), at(2, i >> 4)))
                    });
                    let seg = match interp {
                        Interpolant::CatmullRom => {
                            segment::<CatmullRomWeights>(&s, q_in, q_out, 0.0, (0.0, 0.0))
                        }
                        _ => segment::<BSplineWeights>(&s, q_in, q_out, 0.0, (0.0, 0.0)),
                    };
                    // b_0 and b_9 are replaced by the face values (checked as values above).
                    for &coefficient in &seg.coefficients()[1..9] {
                        assert!(
                            coefficient >= lo - tol && coefficient <= hi + tol,
                            "{} brick {b:?} cell {c:?}: coefficient {coefficient} not in [{lo}, {hi}]",
                            interp.name()
                        );
                    }
                }
            }
        }
        eprintln!(
            "{}: {checked} values in their brick's range, {overshoots} past the samples', \
             {outside_corners} past the corners'",
            interp.name()
        );
        if interp == Interpolant::CatmullRom {
            assert!(
                overshoots > 0,
                "Catmull-Rom never left the samples' range: the test is too weak"
            );
        }
    }
}
