//! Brute-force tests of the Bernstein root isolation: polynomials with known roots (built factor
//! by factor, independently of [`Bernstein::product`]), random coefficients against dense
//! sampling, and the edge cases of the module doc (zeros, tangencies, caps).

use super::*;

const BOTH: [Inside; 2] = [Inside::Below, Inside::Above];

/// Deterministic pseudo-random numbers (SplitMix64).
struct Rng(u64);

impl Rng {
    /// Uniform in `[0, 1)`.
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.unit() * n as f64) as usize
    }
    fn coefficients(&mut self, n: usize) -> Vec<f64> {
        (0..n).map(|_| self.range(-1.0, 1.0)).collect()
    }
}

/// `scale * prod (u - r)` in Bernstein form, one linear factor at a time: with
/// `u - r = -r (1 - u) + (1 - r) u`, `B_{m,k} (1 - u) = (m + 1 - k) / (m + 1) B_{m+1,k}` and
/// `B_{m,k} u = (k + 1) / (m + 1) B_{m+1,k+1}`.
fn from_roots(scale: f64, roots: &[f64]) -> Bernstein {
    let mut p = vec![scale];
    for &r in roots {
        let m1 = p.len() as f64;
        let q: Vec<f64> = (0..=p.len())
            .map(|k| {
                let up = if k >= 1 { k as f64 / m1 * (1.0 - r) * p[k - 1] } else { 0.0 };
                let keep = if k < p.len() { (m1 - k as f64) / m1 * -r * p[k] } else { 0.0 };
                up + keep
            })
            .collect();
        p = q;
    }
    Bernstein::new(&p)
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

/// `g(s)` summed term by term in the Bernstein basis, and `g'(s)` from the difference form
/// `n sum (b_{j+1} - b_j) B_{n-1,j}`.
fn direct(g: &Bernstein, s: f64) -> (f64, f64) {
    let n = g.degree;
    let basis =
        |m: usize, j: usize| binomial(m, j) * s.powi(j as i32) * (1.0 - s).powi((m - j) as i32);
    let value = (0..=n).map(|j| g.b[j] * basis(n, j)).sum();
    let slope = if n == 0 {
        0.0
    } else {
        n as f64 * (0..n).map(|j| (g.b[j + 1] - g.b[j]) * basis(n - 1, j)).sum::<f64>()
    };
    (value, slope)
}

/// How far rounding can move root `r` of `scale * prod (u - roots)`, coefficients `g`:
/// a few ulps of the largest coefficient over the slope there.
fn tolerance(g: &Bernstein, scale: f64, roots: &[f64], r: f64) -> f64 {
    let size = g.coefficients().iter().fold(0.0f64, |m, c| m.max(c.abs()));
    let slope: f64 = scale * roots.iter().filter(|&&q| q != r).map(|q| r - q).product::<f64>();
    64.0 * f64::EPSILON * size / slope.abs() + 1e-15
}

fn leaves(g: &Bernstein) -> Vec<Leaf> {
    Isolation::new(g).collect()
}

fn all_crossings(g: &Bernstein, inside: Inside) -> Vec<Crossing> {
    crossings(g, inside, 100).collect()
}

/// Leaves cover `[0, 1]` in order, without gaps, and neighbours share their end values bit
/// for bit; the first starts at `b_0`, the last ends at `b_n`.
fn assert_partition(g: &Bernstein, leaves: &[Leaf]) {
    assert_eq!(leaves[0].lo(), 0.0);
    assert_eq!(leaves[0].c.b[0].to_bits(), g.b[0].to_bits());
    let last = leaves.last().unwrap();
    assert_eq!(last.hi(), 1.0);
    assert_eq!(last.c.ends().1.to_bits(), g.ends().1.to_bits());
    for w in leaves.windows(2) {
        assert_eq!(w[0].hi(), w[1].lo(), "gap between {:?} and {:?}", w[0], w[1]);
        assert_eq!(w[0].c.ends().1.to_bits(), w[1].c.b[0].to_bits(), "end at {}", w[1].lo());
    }
}

#[test]
fn de_casteljau_matches_the_basis_sum_and_is_exact_at_the_ends() {
    let mut rng = Rng(1);
    for _ in 0..200 {
        let n = 1 + rng.below(10);
        let g = Bernstein::new(&rng.coefficients(n));
        assert_eq!(g.eval(0.0).to_bits(), g.b[0].to_bits());
        assert_eq!(g.eval(1.0).to_bits(), g.ends().1.to_bits());
        for _ in 0..10 {
            let s = rng.unit();
            let (v, d) = g.eval_with_derivative(s);
            let (v0, d0) = direct(&g, s);
            assert!((v - v0).abs() < 1e-14 && (g.eval(s) - v0).abs() < 1e-14, "{g:?} at {s}");
            assert!((d - d0).abs() < 1e-12, "{g:?} at {s}: {d} vs {d0}");
        }
    }
}

#[test]
fn halves_and_restrictions_are_the_polynomial_on_the_subintervals() {
    let mut rng = Rng(2);
    for _ in 0..100 {
        let n = 1 + rng.below(10);
        let g = Bernstein::new(&rng.coefficients(n));
        let (left, right) = g.halves();
        assert_eq!(left.b[0].to_bits(), g.b[0].to_bits());
        assert_eq!(right.ends().1.to_bits(), g.ends().1.to_bits());
        assert_eq!(left.ends().1.to_bits(), right.b[0].to_bits(), "the apex is shared");
        for _ in 0..5 {
            let s = rng.unit();
            assert!((left.eval(s) - g.eval(0.5 * s)).abs() < 1e-14);
            assert!((right.eval(s) - g.eval(0.5 + 0.5 * s)).abs() < 1e-14);
            let level = rng.below(17) as u32;
            let k = rng.below(1 << level) as u32;
            let c = g.restrict(level, k);
            let w = 1.0 / (1u32 << level) as f64;
            assert!((c.eval(s) - g.eval((k as f64 + s) * w)).abs() < 1e-13, "({level}, {k})");
        }
    }
}

#[test]
fn variations_skip_zeros() {
    let v = |c: &[f64]| Bernstein::new(c).variations();
    assert_eq!(v(&[1.0, -1.0, 1.0]), 2);
    assert_eq!(v(&[1.0, 0.0, -1.0]), 1);
    assert_eq!(v(&[1.0, 0.0, 0.0, 1.0]), 0);
    assert_eq!(v(&[0.0, -1.0, 0.0, 1.0, 0.0]), 1);
    assert_eq!(v(&[-0.0, 0.0, 2.0]), 0);
    assert_eq!(v(&[0.0; 10]), 0);
    assert_eq!(v(&[-3.0]), 0);
    assert_eq!(v(&[1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0]), 9);
}

/// Random roots in `[-0.5, 1.5]`, at least `1e-3` apart and from the ends, degree 1 to 9,
/// random scale and sign: every root in `(0, 1)` is found once, in order, to the accuracy the
/// conditioning allows, entering and leaving alternately; leaves partition `[0, 1]`.
#[test]
fn known_roots_are_found_in_order() {
    let mut rng = Rng(3);
    let mut checked = 0;
    while checked < 400 {
        let n = 1 + rng.below(9);
        let mut roots: Vec<f64> = (0..n).map(|_| rng.range(-0.5, 1.5)).collect();
        roots.sort_by(f64::total_cmp);
        let apart = roots.windows(2).all(|w| w[1] - w[0] > 1e-3)
            && roots.iter().all(|r| (r.abs() > 1e-3) && ((r - 1.0).abs() > 1e-3));
        if !apart {
            continue;
        }
        checked += 1;
        let scale = rng.range(0.5, 4.0) * if rng.unit() < 0.5 { -1.0 } else { 1.0 };
        let g = from_roots(scale, &roots);
        let inner: Vec<f64> = roots.iter().copied().filter(|r| *r > 0.0 && *r < 1.0).collect();
        let ls = leaves(&g);
        assert_partition(&g, &ls);
        assert!(ls.iter().all(|l| l.resolved), "{roots:?}");
        for inside in BOTH {
            let found = all_crossings(&g, inside);
            assert_eq!(found.len(), inner.len(), "{roots:?} {inside:?}: {found:?}");
            for (c, &r) in found.iter().zip(&inner) {
                let tol = tolerance(&g, scale, &roots, r);
                assert!((c.u - r).abs() <= tol, "{roots:?}: {} vs {r} (tol {tol:e})", c.u);
                assert!(c.resolved && !c.exact);
                assert!(c.bracket.0 <= c.u && c.u <= c.bracket.1);
                // Entering where the closed form goes inside just after the root.
                let after = scale * roots.iter().map(|q| (r + 1e-9) - q).product::<f64>();
                assert_eq!(c.entering, inside_g(inside, after), "{roots:?} at {r}");
            }
        }
    }
}

/// Random coefficients, degree 0 to 9, against the predicate sampled at `2^12 + 1` points and
/// bisected: every sampled crossing is found, and any extra crossing comes with a second one
/// inside the same sampling step (two roots the samples cannot see). The first crossing is the
/// smallest.
#[test]
fn random_polynomials_agree_with_dense_sampling() {
    const N: usize = 1 << 12;
    let mut rng = Rng(4);
    let mut extra_pairs = 0;
    for case in 0..400 {
        let n = 1 + rng.below(10);
        let g = Bernstein::new(&rng.coefficients(n));
        let inside = BOTH[case % 2];
        let p = |s: f64| inside_g(inside, g.eval(s));
        let mut dense = Vec::new();
        for i in 0..N {
            let (mut a, mut b) = (i as f64 / N as f64, (i + 1) as f64 / N as f64);
            if p(a) == p(b) {
                continue;
            }
            let pa = p(a);
            for _ in 0..60 {
                let m = 0.5 * (a + b);
                if p(m) == pa {
                    a = m;
                } else {
                    b = m;
                }
            }
            dense.push(0.5 * (a + b));
        }
        let found = all_crossings(&g, inside);
        assert!(found.windows(2).all(|w| w[0].u <= w[1].u), "not in order: {found:?}");
        let mut j = 0;
        for &d in &dense {
            // Skip pairs of found crossings in one sampling step, unseen by the samples.
            while j + 1 < found.len()
                && (found[j].u * N as f64).floor() == (found[j + 1].u * N as f64).floor()
                && (found[j].u - d).abs() > 1.0 / N as f64
            {
                j += 2;
                extra_pairs += 1;
            }
            let c = found.get(j).unwrap_or_else(|| panic!("{g:?}: {d} not found in {found:?}"));
            let slope = g.eval_with_derivative(d).1.abs();
            let tol = 1e-15 + 1e-14 / slope;
            assert!((c.u - d).abs() <= tol, "{g:?} {inside:?}: {} vs sampled {d}", c.u);
            j += 1;
        }
        assert!(
            found.len() == j || (found.len() - j) % 2 == 0,
            "{g:?}: unmatched crossings {:?}",
            &found[j..]
        );
    }
    assert!(extra_pairs < 20, "{extra_pairs} pairs unseen by sampling: a suspicious number");
}

#[test]
fn clusters_of_close_roots() {
    // 1e-4 apart: resolved, all found.
    let roots = [0.4, 0.4001, 0.4002, 0.7];
    let g = from_roots(1.0, &roots);
    for inside in BOTH {
        let found = all_crossings(&g, inside);
        assert_eq!(found.len(), 4, "{found:?}");
        for (c, r) in found.iter().zip(roots) {
            let tol = tolerance(&g, 1.0, &roots, r);
            assert!((c.u - r).abs() <= tol && c.resolved, "{} vs {r} (tol {tol:e})", c.u);
        }
    }
    // Two roots within 2^-16 (one leaf at the depth cap): they vanish together, and the leaf
    // holding them says it is unresolved.
    let g = from_roots(1.0, &[0.3, 0.300_001, 0.8]);
    let ls = leaves(&g);
    assert_partition(&g, &ls);
    let cap = ls.iter().find(|l| !l.resolved).expect("an unresolved leaf");
    assert_eq!(cap.level, DEPTH);
    assert!(cap.lo() <= 0.3 && 0.300_001 <= cap.hi(), "{cap:?}");
    for inside in BOTH {
        let found = all_crossings(&g, inside);
        assert_eq!(found.len(), 1, "{found:?}");
        assert!((found[0].u - 0.8).abs() < 1e-12);
    }
    // Three within 2^-16: the ends differ, one crossing, refined somewhere in that leaf.
    let g = from_roots(-2.0, &[0.3, 0.300_000_3, 0.300_000_6]);
    for inside in BOTH {
        let found = all_crossings(&g, inside);
        assert_eq!(found.len(), 1, "{found:?}");
        let c = found[0];
        assert!(!c.resolved && c.bracket.1 - c.bracket.0 == 1.0 / 65536.0, "{c:?}");
        assert!(c.bracket.0 <= c.u && c.u <= c.bracket.1);
    }
}

/// A double root (tangency). Not at a point of the sequence: no crossing from either side, the
/// leaves around it unresolved at the depth cap. At `u = 1/2`, computed exactly 0: touching
/// from inside is two crossings at exactly 1/2, from outside none (the contract).
#[test]
fn double_roots() {
    for scale in [1.0, -1.0] {
        let g = from_roots(scale, &[0.3, 0.3]);
        let ls = leaves(&g);
        assert!(ls
            .iter()
            .any(|l| !l.resolved && l.level == DEPTH && l.lo() <= 0.3 && 0.3 <= l.hi()));
        for inside in BOTH {
            assert_eq!(all_crossings(&g, inside), [], "{scale} {inside:?}");
        }
    }
    // -(2u - 1)^2: inside (Below) on both sides of 1/2.
    let touch = Bernstein::new(&[-1.0, 1.0, -1.0]);
    assert_eq!(touch.restrict(1, 0).ends().1, 0.0, "the apex is exactly 0");
    let found = all_crossings(&touch, Inside::Below);
    assert_eq!(found.len(), 2, "{found:?}");
    assert!(found.iter().all(|c| c.u == 0.5 && c.exact && c.resolved));
    assert_eq!((found[0].entering, found[1].entering), (false, true));
    assert_eq!(all_crossings(&touch, Inside::Above), []);
    let bump = Bernstein::new(&[1.0, -1.0, 1.0]);
    assert_eq!(all_crossings(&bump, Inside::Below), []);
    assert_eq!(all_crossings(&bump, Inside::Above).len(), 2);
}

/// Coefficients exactly 0 at the ends and values exactly 0 at dyadic points: the crossing is
/// there, exactly, and a crossing between two outside ends of a `V <= 1` node is not lost.
#[test]
fn exact_zeros_at_the_ends_and_at_dyadic_points() {
    let us = |g: &Bernstein, inside| {
        all_crossings(g, inside).iter().map(|c| (c.u, c.entering, c.exact)).collect::<Vec<_>>()
    };
    // 3u^2 - 2u: 0 at u = 0, negative on (0, 2/3).
    let g = Bernstein::new(&[0.0, -1.0, 1.0]);
    let found = us(&g, Inside::Below);
    assert_eq!(found.len(), 2, "{found:?}");
    assert_eq!(found[0], (0.0, true, true));
    assert!((found[1].0 - 2.0 / 3.0).abs() < 1e-15 && !found[1].1);
    let found = us(&g, Inside::Above);
    assert_eq!(found.len(), 1);
    assert!((found[0].0 - 2.0 / 3.0).abs() < 1e-15 && found[0].1);
    // -2u(1 - u): 0 at both ends, inside (Below) between them.
    let g = Bernstein::new(&[0.0, -1.0, 0.0]);
    assert_eq!(us(&g, Inside::Below), [(0.0, true, true), (1.0, false, true)]);
    assert_eq!(us(&g, Inside::Above), []);
    // (1 - u)(1 - 3u): 0 at 1/3 and at u = 1.
    let g = Bernstein::new(&[1.0, -1.0, 0.0]);
    let found = us(&g, Inside::Below);
    assert_eq!(found.len(), 2, "{found:?}");
    assert!((found[0].0 - 1.0 / 3.0).abs() < 1e-15 && found[0].1);
    assert_eq!(found[1], (1.0, false, true));
    // 3 (4u - 1)(2u - 1)(4u - 3): integer coefficients, so the apexes at 1/4, 1/2, 3/4 are
    // exactly 0.
    let g = Bernstein::new(&[-9.0, 13.0, -13.0, 9.0]);
    for (inside, first) in [(Inside::Below, false), (Inside::Above, true)] {
        let found = us(&g, inside);
        assert_eq!(found.len(), 3, "{found:?}");
        for (c, (u, entering)) in found.iter().zip([(0.25, first), (0.5, !first), (0.75, first)]) {
            assert_eq!((c.0, c.1), (u, entering), "{inside:?}: {found:?}");
        }
        assert!(found[0].2 && found[1].2, "{found:?}");
    }
    // Zero ends with nothing between: the touch at the end is outside, no crossing.
    let g = Bernstein::new(&[0.0, 1.0, 2.0, 0.0]);
    assert_eq!(us(&g, Inside::Below), []);
    assert_eq!(us(&g, Inside::Above), [(0.0, true, true), (1.0, false, true)]);
}

#[test]
fn zero_and_constant_polynomials() {
    for c in
        [vec![0.0], vec![0.0; 10], vec![-0.0, 0.0, 0.0], vec![2.0; 4], vec![-1.5], vec![-3.0; 10]]
    {
        let g = Bernstein::new(&c);
        let ls = leaves(&g);
        assert_eq!(ls.len(), 1, "{c:?}");
        assert!(ls[0].resolved && ls[0].level == 0);
        for inside in BOTH {
            assert_eq!(all_crossings(&g, inside), [], "{c:?}");
        }
    }
}

/// With the caps hit, the leaves still partition `[0, 1]` (so the crossings keep the parity of
/// the end predicates, and the first is in the first changing leaf), the walk stays within
/// `budget + depth` nodes, and the forced leaves say they are unresolved.
#[test]
fn caps_bound_the_walk() {
    // Four pairs 1e-7 apart: every pair stays V = 2 down to the depth cap.
    let pairs = [0.1, 0.35, 0.6, 0.85];
    let roots: Vec<f64> = pairs.iter().flat_map(|&r| [r, r + 1e-7]).collect();
    let g = from_roots(1.0, &roots);
    let mut walk = Isolation::new(&g);
    let ls: Vec<Leaf> = walk.by_ref().collect();
    assert_partition(&g, &ls);
    assert_eq!(walk.nodes(), 119, "the module doc's bound, attained");
    assert_eq!(ls.iter().filter(|l| !l.resolved).count(), 4);
    assert!(ls.iter().filter(|l| !l.resolved).all(|l| l.level == DEPTH));
    for inside in BOTH {
        assert_eq!(all_crossings(&g, inside), []);
    }
    // The depth cap at 3: each leaf near a pair is forced, and the crossings are those of the
    // end predicates (none here).
    let ls: Vec<Leaf> = Isolation::with_caps(&g, 3, NODES).collect();
    assert_partition(&g, &ls);
    assert!(ls.iter().all(|l| l.level <= 3));
    assert_eq!(ls.iter().filter(|l| !l.resolved).count(), 4);
    // Node budgets from 1 up: a bounded, complete walk; crossings agree with the ends' parity.
    let g = from_roots(1.0, &[0.1, 0.2, 0.3, 0.45, 0.5, 0.55, 0.8, 0.9, 0.95]);
    let full = all_crossings(&g, Inside::Below);
    assert_eq!(full.len(), 9);
    for budget in 1..40 {
        let mut walk = Isolation::with_caps(&g, DEPTH, budget);
        let ls: Vec<Leaf> = walk.by_ref().collect();
        assert_partition(&g, &ls);
        assert!(walk.nodes() <= budget + DEPTH, "budget {budget}: {} nodes", walk.nodes());
        let found: Vec<Crossing> =
            ls.iter().filter_map(|l| l.crossing(Inside::Below, 100, None)).collect();
        assert_eq!(found.len() % 2, 1, "budget {budget}: {found:?}");
        assert!(found.windows(2).all(|w| w[0].u <= w[1].u));
        // The first crossing found lies in the first leaf whose ends differ.
        let first = ls.iter().find(|l| l.changes(Inside::Below)).unwrap();
        assert_eq!(found[0].bracket, (first.lo(), first.hi()));
        if budget < 9 {
            assert!(ls.iter().any(|l| !l.resolved), "budget {budget}");
        }
    }
}

/// The first crossing found is the smallest root in `(0, 1)`.
#[test]
fn the_first_crossing_is_the_smallest_root() {
    let mut rng = Rng(6);
    for _ in 0..200 {
        let n = 2 + rng.below(8);
        let roots: Vec<f64> = (0..n).map(|_| rng.range(-0.3, 1.3)).collect();
        let scale = rng.range(-2.0, 2.0);
        let g = from_roots(scale, &roots);
        let Some(first) = roots.iter().copied().filter(|r| *r > 0.0 && *r < 1.0).reduce(f64::min)
        else {
            continue;
        };
        let close = roots.iter().any(|&r| r != first && (r - first).abs() < 1e-3);
        if close || !(1e-3..=1.0 - 1e-3).contains(&first) {
            continue;
        }
        for inside in BOTH {
            // Stop at the first leaf that changes, as the shader does.
            let leaf = Isolation::new(&g).find(|l| l.changes(inside)).unwrap();
            let c = leaf.crossing(inside, 100, None).unwrap();
            let tol = tolerance(&g, scale, &roots, first).max(1e-12);
            assert!((c.u - first).abs() <= tol, "{roots:?}: {} vs {first}", c.u);
        }
    }
}

#[test]
fn refinement_iterates_stay_in_the_leaf() {
    let g = from_roots(3.0, &[0.123, 0.5, 0.77, 1.4]);
    for leaf in Isolation::new(&g) {
        let mut iterates = Vec::new();
        if let Some(c) = leaf.crossing(Inside::Above, 50, Some(&mut iterates)) {
            assert!(!iterates.is_empty());
            assert!(iterates.iter().all(|&u| leaf.lo() <= u && u <= leaf.hi()), "{iterates:?}");
            assert_eq!(*iterates.last().unwrap(), c.u);
        }
    }
    // Zero steps: the secant guess in the leaf.
    let g = Bernstein::new(&[-1.0, 1.0]);
    let c = Isolation::new(&g).next().unwrap().crossing(Inside::Below, 0, None).unwrap();
    assert_eq!(c.u, 0.5);
}

#[test]
fn products_and_conversions_keep_the_polynomial() {
    let mut rng = Rng(5);
    for _ in 0..200 {
        let (m, n) = (rng.below(5), rng.below(5));
        let a = Bernstein::new(&rng.coefficients(m + 1));
        let b = Bernstein::new(&rng.coefficients(n + 1));
        let p = a.product(&b);
        assert_eq!(p.degree, m + n);
        assert_eq!(p.b[0].to_bits(), (a.b[0] * b.b[0]).to_bits());
        assert_eq!(p.ends().1.to_bits(), (a.ends().1 * b.ends().1).to_bits());
        // Sums of products, as §3.1 accumulates them.
        let c = Bernstein::new(&rng.coefficients(m + 1));
        let mut acc = Scaled::zero(m + n);
        acc.mul_add(&Scaled::from(&a), &Scaled::from(&b));
        acc.mul_add(&Scaled::from(&c), &Scaled::from(&b));
        let sum = acc.unscale();
        let power = rng.coefficients(m + 1);
        let from_power = Bernstein::from_power(&power);
        let elevated = if m + n < MAX_DEGREE { Some(p.elevate()) } else { None };
        for _ in 0..10 {
            let s = rng.unit();
            assert!((p.eval(s) - a.eval(s) * b.eval(s)).abs() < 1e-14);
            assert!((sum.eval(s) - (a.eval(s) + c.eval(s)) * b.eval(s)).abs() < 1e-14);
            let horner = power.iter().rev().fold(0.0, |acc, &ci| acc * s + ci);
            assert!((from_power.eval(s) - horner).abs() < 1e-14, "{power:?} at {s}");
            if let Some(e) = elevated {
                assert!((e.eval(s) - p.eval(s)).abs() < 1e-14);
            }
        }
    }
    // The roots survive: the product of factors built independently.
    let g = from_roots(1.0, &[0.2, 0.6]).product(&from_roots(-1.0, &[0.4, 1.3, -0.1]));
    let found = all_crossings(&g, Inside::Below);
    let us: Vec<f64> = found.iter().map(|c| c.u).collect();
    assert!(
        us.len() == 3 && [0.2, 0.4, 0.6].iter().zip(&us).all(|(r, u)| (r - u).abs() < 1e-14),
        "{us:?}"
    );
}
