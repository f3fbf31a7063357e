//! Exact root isolation of a polynomial of degree at most 9 given in Bernstein form on `[0, 1]`:
//! the root finder of the tricubic interpolants, whose field along a ray segment in one cell is
//! such a polynomial (PLAN26 §3). Pure arithmetic in fixed-size arrays, no recursion, no
//! allocation, every loop bounded: `shaders/include/bernstein.glsl` is to copy it line for line
//! in `f32`, and this `f64` version is its reference.
//!
//! # Why Bernstein form
//!
//! With `g(s) = sum_j b_j C(n, j) s^j (1 - s)^(n - j)`:
//!
//! - `b_0 = g(0)` and `b_n = g(1)`: the ends are values, so the walk can put the exact face
//!   values there and adjacent cells agree bit for bit.
//! - `g` lies in the convex hull of its coefficients, and **Descartes' rule** bounds its roots:
//!   the number of roots in the open `(0, 1)`, with multiplicity, is at most `V`, the number of
//!   sign changes of `b_0, ..., b_n`, and has the parity of `V`. So `V = 0`: no root inside;
//!   `V = 1`: exactly one, simple.
//! - Halving (de Casteljau at `1/2`) is `n (n + 1) / 2` operations `0.5 * (a + b)`, well
//!   conditioned on `[0, 1]` and the same in `f32` (unlike the monomial basis at degree 9), and it
//!   never increases the variations: `V(left) + V(right) <= V(parent)`.
//!
//! # The walk
//!
//! A node is the dyadic interval `[k 2^-l, (k + 1) 2^-l]`, written `(l, k)`. Its coefficients
//! are recomputed from the root's by `l` halvings along the bits of `k` (most significant first:
//! 0 keeps the left half, 1 the right), so the walk needs no stack, only `(l, k)` and a node
//! count:
//!
//! ```text
//!   l = 0   [0 ----------------------------------------------- 1]   V = 3: descend left
//!   l = 1   [0 ---------- 1/2]                                      V = 2: descend left
//!   l = 2   [0 - 1/4] [1/4 - 1/2]                                   leaves (V <= 1), left first
//!   l = 1                     [1/2 ----------------------------- 1] leaf
//! ```
//!
//! 1. Start at `(0, 0)`. At each node: its coefficients `c`, `V` = [`Bernstein::variations`].
//! 2. The node is a **leaf** when it is *resolved* (below), or `l == depth` ([`DEPTH`] = 16), or
//!    the node budget ([`NODES`] = 129) is spent. Otherwise descend left: `(l + 1, 2k)`.
//! 3. After a leaf: while `k` is odd, `k >>= 1`, `l -= 1`; stop if `l == 0`; else `k += 1` (the
//!    right sibling of the deepest left child on the path).
//!
//! Leaves therefore come **in `u` order and partition `[0, 1]`**. A leaf's end values are its
//! first and last coefficients. Two neighbouring leaves share an end, the apex of their common
//! ancestor's halving, computed by the same operations from the same bits for both (a left half
//! keeps its parent's first coefficient and a right half its last, untouched). So the inside
//! predicate is decided on **one sequence of points**, `0 = u_0 < u_1 < ... < u_m = 1`, with
//! `g(u_0) = b_0` and `g(u_m) = b_n` exactly, as the trilinear walk does with its split points.
//!
//! # Resolved leaves and the crossing rule
//!
//! The crossing rule is the trilinear reference's (`super` module doc): the predicate is
//! `inside_g` (a value equal to the isovalue, `g == 0`, is outside), and a **crossing** is a
//! change of the predicate between two consecutive points of the sequence, located exactly at
//! an end whose `g` is `0`, otherwise refined inside the leaf. That is only exact where the
//! predicate changes at most once on the closed leaf, so that its ends tell. A node is
//! **resolved** when that holds by Descartes' rule:
//!
//! - `V == 0` and not both end coefficients `0`: `g` has one sign on the open interval, which a
//!   nonzero end shares; the predicate can only change at an end that is exactly `0`;
//! - `V == 1` and both ends nonzero: one simple root inside, where it changes once;
//! - every coefficient `0`: `g == 0`, outside throughout.
//!
//! (PLAN26 §3.2 made every `V <= 1` node a leaf. With an end exactly `0` that misses crossings:
//! `[0, -1, 1]` with `Below` is `0` at `u = 0`, inside on `(0, 2/3)` and outside after, two
//! crossings between two outside ends. Such nodes are split like `V >= 2` ones; their children
//! separate the zero end from the inside root, down to the depth cap.)
//!
//! Zeros are skipped when counting `V` (`[1, 0, -1]` has one variation, `[1, 0, 1]` none); so is
//! NaN, which only a missing cell could bring, and the walk does not pass missing cells here.
//!
//! **Unresolved leaves** (the depth or node cap reached with the node not resolved): a crossing
//! is counted exactly when the end predicates differ, and then refined inside the leaf (some root
//! there). In exact arithmetic a leaf at depth 16 is unresolved only near two roots of `g` (real,
//! or a complex pair near the axis) within about `2^-16` of the segment of the leaf, or a root
//! that close to a zero end. This widens
//! the trilinear module doc's near-tangency clause ("two crossings a rounding error apart may
//! appear or vanish together") to `2^-16` of a segment. So a **tangency** (a double root) that is
//! not exactly at a point of the sequence reports no crossing from either side, while an exact
//! double root at a point of the sequence (say `g(1/2) == 0` computed exactly) follows the
//! contract: touching from inside is two crossings at the same `u`, from outside none.
//!
//! **The caps.** Since halving diminishes variations, a level holds at most `floor(9 / 2) = 4`
//! nodes with `V >= 2`, so with no node end exactly 0 there are at most `1 + 2 + 4 * 14 = 59`
//! inner nodes over levels `0..16` and `1 + 2 * 59 = 119` nodes in exact arithmetic. Nodes split
//! for a zero end hold an exact root at a dyadic point; the children of one with both ends 0
//! are resolved (no root inside, nonzero apex), so they add little. The budget of 129 (PLAN26's
//! `1 + 2 * 4 * 16`) bounds the walk whatever rounding and zeros do. When it is spent, the node
//! at hand and every node after it is a leaf (unresolved unless resolved anyway), so the walk
//! still covers `[0, 1]` and ends after at most [`DEPTH`] more nodes (the pending right
//! siblings): at most `NODES + DEPTH` nodes in all.
//!
//! # Refinement
//!
//! A leaf whose ends differ and are nonzero is refined by [`super::cubic::refine_with`] (secant
//! start, Newton kept in the bracket by the predicate, bisection fallback, `CONVERGED`) on the
//! leaf's own coefficients in its local `s`, evaluated by de Casteljau
//! ([`Bernstein::eval_with_derivative`]); then `u = lo + s 2^-l`, one rounding.
//!
//! # Building polynomials
//!
//! [`Bernstein::from_power`], [`Bernstein::elevate`] and [`Scaled`] (products are convolutions
//! in scaled form, `b~_j = C(n, j) b_j`) build the segment's polynomial from per-axis ones
//! (PLAN26 §3.1); the ends of a product are the products of the ends (one rounding each).
//!
//! # Notes for the `f32` port
//!
//! - Halve with `precise` and the operands in this order, so that neighbouring leaves still
//!   share their ends bit for bit.
//! - Bound the walk's loop by `BERNSTEIN_NODES + BERNSTEIN_DEPTH` passes (never reached).
//! - `2^-l` and `k 2^-l` are exact in `f32` for `l <= 16`; `u = lo + s 2^-l` is one rounding.
//! - `CONVERGED` becomes `4 * FLT_EPSILON`, in the leaf's `s`.

// The tricubic walk (`tricubic`) uses the isolation; `eval`, `halves`, `from_power`, `elevate`,
// `product`, `nodes` and `crossings` serve the tests until the mesh oracle (PLAN26 C14).
#![allow(dead_code)]
// Index loops, as the GLSL port writes them line for line.
#![allow(clippy::needless_range_loop)]

use super::cubic::{inside_g, refine_with};
use crate::scene::Inside;
use crate::shaders::consts;

/// The highest degree a [`Bernstein`] holds (tricubic along a line: 3 + 3 + 3).
pub const MAX_DEGREE: usize = 9;

/// Deepest level of the isolation walk (`BERNSTEIN_DEPTH`, shared with the shaders by build.rs):
/// leaves are at least `2^-16` of the segment long.
pub const DEPTH: u32 = consts::BERNSTEIN_DEPTH;

/// Node budget of one isolation (`BERNSTEIN_NODES`, shared with the shaders by build.rs); see
/// the module doc for what it bounds.
pub const NODES: u32 = consts::BERNSTEIN_NODES;

/// Binomial coefficients `C(n, k)` for `n <= MAX_DEGREE`, exact integers as `f64`.
const BINOMIAL: [[f64; MAX_DEGREE + 1]; MAX_DEGREE + 1] = {
    let mut t = [[0.0; MAX_DEGREE + 1]; MAX_DEGREE + 1];
    let mut n = 0;
    while n <= MAX_DEGREE {
        t[n][0] = 1.0;
        let mut k = 1;
        while k <= n {
            t[n][k] = t[n - 1][k - 1] + t[n - 1][k];
            k += 1;
        }
        n += 1;
    }
    t
};

/// A polynomial of degree `degree <= 9` on `[0, 1]` in the Bernstein basis:
/// `g(s) = sum_{j <= degree} b[j] C(degree, j) s^j (1 - s)^(degree - j)`. Entries of `b` above
/// `degree` are 0 and never read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bernstein {
    pub b: [f64; MAX_DEGREE + 1],
    pub degree: usize,
}

impl Bernstein {
    /// From `b_0, ..., b_n` (1 to 10 of them; more or none is a programming error).
    pub fn new(coefficients: &[f64]) -> Self {
        let n = coefficients.len();
        assert!((1..=MAX_DEGREE + 1).contains(&n), "Bernstein degree {} > 9", n as i64 - 1);
        let mut b = [0.0; MAX_DEGREE + 1];
        b[..n].copy_from_slice(coefficients);
        Bernstein { b, degree: n - 1 }
    }

    /// `b_0, ..., b_n`.
    pub fn coefficients(&self) -> &[f64] {
        &self.b[..=self.degree]
    }

    /// `g(0)` and `g(1)`, the first and last coefficients.
    pub fn ends(&self) -> (f64, f64) {
        (self.b[0], self.b[self.degree])
    }

    /// `g(s)` by de Casteljau: `(1 - s) a + s b` per step, exact at `s = 0` and `s = 1`.
    pub fn eval(&self, s: f64) -> f64 {
        let n = self.degree;
        let t = 1.0 - s;
        let mut p = self.b;
        for r in 1..=n {
            for i in 0..=n - r {
                p[i] = t * p[i] + s * p[i + 1];
            }
        }
        p[0]
    }

    /// `(g(s), g'(s))` by de Casteljau: the last step's two points `p0`, `p1` give
    /// `g = (1 - s) p0 + s p1` and `g' = n (p1 - p0)` (`s` units).
    pub fn eval_with_derivative(&self, s: f64) -> (f64, f64) {
        let n = self.degree;
        if n == 0 {
            return (self.b[0], 0.0);
        }
        let t = 1.0 - s;
        let mut p = self.b;
        for r in 1..n {
            for i in 0..=n - r {
                p[i] = t * p[i] + s * p[i + 1];
            }
        }
        (t * p[0] + s * p[1], n as f64 * (p[1] - p[0]))
    }

    /// Keeps the left half, `[0, 1/2]` rescaled to `[0, 1]`: de Casteljau at `1/2` in place,
    /// `b_0` untouched and the apex last.
    pub fn keep_left(&mut self) {
        let n = self.degree;
        for r in 1..=n {
            for i in (r..=n).rev() {
                self.b[i] = 0.5 * (self.b[i - 1] + self.b[i]);
            }
        }
    }

    /// Keeps the right half, `[1/2, 1]` rescaled to `[0, 1]`: the same triangle as
    /// [`Bernstein::keep_left`] (same operands, same order), `b_n` untouched and the apex first.
    pub fn keep_right(&mut self) {
        let n = self.degree;
        for r in 1..=n {
            for i in 0..=n - r {
                self.b[i] = 0.5 * (self.b[i] + self.b[i + 1]);
            }
        }
    }

    /// Both halves; `left.b[n]` and `right.b[0]` are the same apex, bit for bit.
    pub fn halves(&self) -> (Bernstein, Bernstein) {
        let (mut left, mut right) = (*self, *self);
        left.keep_left();
        right.keep_right();
        (left, right)
    }

    /// The node `(level, k)`: the restriction to `[k 2^-level, (k + 1) 2^-level]`, rescaled to
    /// `[0, 1]`, by `level` halvings along the bits of `k`, most significant first.
    pub fn restrict(&self, level: u32, k: u32) -> Bernstein {
        let mut c = *self;
        for i in (0..level).rev() {
            if (k >> i) & 1 == 0 {
                c.keep_left();
            } else {
                c.keep_right();
            }
        }
        c
    }

    /// `V`: sign changes of `b_0, ..., b_n`, skipping zeros (and NaN, which compares as
    /// neither sign).
    pub fn variations(&self) -> u32 {
        let mut v = 0;
        let mut last = 0;
        for &c in self.coefficients() {
            let sign = if c > 0.0 {
                1
            } else if c < 0.0 {
                -1
            } else {
                0
            };
            if sign != 0 {
                if last != 0 && sign != last {
                    v += 1;
                }
                last = sign;
            }
        }
        v
    }

    /// Whether a node with these coefficients and `v` variations is resolved: the predicate
    /// changes at most once on it, so its ends tell (see the module doc).
    pub fn resolved(&self, v: u32) -> bool {
        let (first, last) = self.ends();
        match v {
            0 => first != 0.0 || last != 0.0 || self.coefficients().iter().all(|&c| c == 0.0),
            1 => first != 0.0 && last != 0.0,
            _ => false,
        }
    }

    /// From the power basis, `g(s) = sum_i c_i s^i` (1 to 10 coefficients):
    /// `b_j = sum_{i <= j} C(j, i) / C(n, i) c_i`. Exact at `b_0 = c_0`.
    pub fn from_power(c: &[f64]) -> Bernstein {
        let mut out = Bernstein::new(c);
        let n = out.degree;
        for j in 0..=n {
            let mut sum = 0.0;
            for (i, &ci) in c.iter().enumerate().take(j + 1) {
                sum += BINOMIAL[j][i] / BINOMIAL[n][i] * ci;
            }
            out.b[j] = sum;
        }
        out
    }

    /// The same polynomial one degree higher (at most 9):
    /// `b'_j = (j b_{j-1} + (n + 1 - j) b_j) / (n + 1)`, ends unchanged.
    pub fn elevate(&self) -> Bernstein {
        let n = self.degree;
        assert!(n < MAX_DEGREE, "cannot elevate degree {n}");
        let mut out = Bernstein { b: [0.0; MAX_DEGREE + 1], degree: n + 1 };
        out.b[0] = self.b[0];
        out.b[n + 1] = self.b[n];
        let m = (n + 1) as f64;
        for j in 1..=n {
            out.b[j] = (j as f64 * self.b[j - 1] + (m - j as f64) * self.b[j]) / m;
        }
        out
    }

    /// The product (degrees adding up to at most 9), through the scaled form.
    pub fn product(&self, other: &Bernstein) -> Bernstein {
        let mut out = Scaled::zero(self.degree + other.degree);
        out.mul_add(&Scaled::from(self), &Scaled::from(other));
        out.unscale()
    }
}

/// A polynomial in **scaled** Bernstein form, `b~_j = C(n, j) b_j`, in which the product of
/// two polynomials is the plain convolution of their coefficients (PLAN26 §3.1 step 3). The
/// ends are not scaled (`C(n, 0) = C(n, n) = 1`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scaled {
    pub b: [f64; MAX_DEGREE + 1],
    pub degree: usize,
}

impl Scaled {
    /// The zero polynomial of degree `degree`, to accumulate products into.
    pub fn zero(degree: usize) -> Scaled {
        assert!(degree <= MAX_DEGREE, "Bernstein degree {degree} > 9");
        Scaled { b: [0.0; MAX_DEGREE + 1], degree }
    }

    pub fn from(p: &Bernstein) -> Scaled {
        let n = p.degree;
        let mut b = [0.0; MAX_DEGREE + 1];
        for j in 0..=n {
            b[j] = BINOMIAL[n][j] * p.b[j];
        }
        Scaled { b, degree: n }
    }

    /// `self += a * b`, where `a.degree + b.degree == self.degree`.
    pub fn mul_add(&mut self, a: &Scaled, b: &Scaled) {
        assert_eq!(a.degree + b.degree, self.degree, "degrees of a product");
        for i in 0..=a.degree {
            for j in 0..=b.degree {
                self.b[i + j] += a.b[i] * b.b[j];
            }
        }
    }

    /// Back to [`Bernstein`]: `b_j = b~_j / C(n, j)`.
    pub fn unscale(&self) -> Bernstein {
        let n = self.degree;
        let mut b = [0.0; MAX_DEGREE + 1];
        for j in 0..=n {
            b[j] = self.b[j] / BINOMIAL[n][j];
        }
        Bernstein { b, degree: n }
    }
}

/// A leaf of the isolation walk: the node `(level, k)`, i.e. `[lo, hi]` with
/// `lo = k 2^-level`, `hi = (k + 1) 2^-level` (exact), and its coefficients there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Leaf {
    pub level: u32,
    pub k: u32,
    /// The restriction to the leaf, rescaled to `[0, 1]`: `c.b[0] = g(lo)`, `c.b[n] = g(hi)`.
    pub c: Bernstein,
    /// Its sign variations.
    pub variations: u32,
    /// Resolved (the ends tell the predicate), rather than a leaf forced by a cap.
    pub resolved: bool,
}

/// One crossing, as [`Leaf::crossing`] finds it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    /// Segment parameter of the root, in `[lo, hi]` of the leaf.
    pub u: f64,
    /// At a leaf end whose `g` is exactly 0, unrefined.
    pub exact: bool,
    /// Outside to inside.
    pub entering: bool,
    /// The leaf `[lo, hi]`.
    pub bracket: (f64, f64),
    /// The leaf was resolved (false: a cap forced it, see the module doc).
    pub resolved: bool,
}

impl Leaf {
    /// `2^-level`, exact.
    pub fn width(&self) -> f64 {
        1.0 / (1u32 << self.level) as f64
    }

    pub fn lo(&self) -> f64 {
        self.k as f64 * self.width()
    }

    pub fn hi(&self) -> f64 {
        (self.k + 1) as f64 * self.width()
    }

    /// Whether the predicate differs at the two ends: the leaf holds a crossing.
    pub fn changes(&self, inside: Inside) -> bool {
        let (a, b) = self.c.ends();
        inside_g(inside, a) != inside_g(inside, b)
    }

    /// The leaf's crossing, if its ends differ: at the end exactly on the surface (`g == 0`;
    /// at most one is, both being outside), otherwise refined by up to `steps` Newton steps in
    /// the leaf. `iterates` (in `u`) as [`super::cubic::refine`]'s.
    pub fn crossing(
        &self,
        inside: Inside,
        steps: u32,
        iterates: Option<&mut Vec<f64>>,
    ) -> Option<Crossing> {
        if !self.changes(inside) {
            return None;
        }
        let (a, b) = self.c.ends();
        let (lo, w) = (self.lo(), self.width());
        let (u, exact) = if a == 0.0 {
            (lo, true)
        } else if b == 0.0 {
            (self.hi(), true)
        } else {
            let mut local = Vec::new();
            let s = refine_with(
                |s| self.c.eval_with_derivative(s),
                inside,
                (0.0, 1.0),
                (a, b),
                steps,
                iterates.as_ref().map(|_| &mut local),
            );
            if let Some(it) = iterates {
                it.extend(local.iter().map(|&s| lo + s * w));
            }
            (lo + s * w, false)
        };
        Some(Crossing {
            u,
            exact,
            entering: inside_g(inside, b),
            bracket: (lo, self.hi()),
            resolved: self.resolved,
        })
    }
}

/// The isolation walk of the module doc, as an iterator over its leaves in `u` order. Its state
/// is what the shader keeps: `(level, k)` and the node count.
#[derive(Clone, Debug)]
pub struct Isolation {
    root: Bernstein,
    depth: u32,
    budget: u32,
    level: u32,
    k: u32,
    nodes: u32,
    done: bool,
}

impl Isolation {
    /// The walk with the shared caps, [`DEPTH`] and [`NODES`].
    pub fn new(root: &Bernstein) -> Self {
        Self::with_caps(root, DEPTH, NODES)
    }

    /// The walk with other caps (tests); `depth <= 31`, `budget >= 1`.
    pub fn with_caps(root: &Bernstein, depth: u32, budget: u32) -> Self {
        assert!(depth <= 31 && budget >= 1, "isolation caps: depth {depth}, budget {budget}");
        Isolation { root: *root, depth, budget, level: 0, k: 0, nodes: 0, done: false }
    }

    /// Nodes visited so far (inner nodes and leaves).
    pub fn nodes(&self) -> u32 {
        self.nodes
    }
}

impl Iterator for Isolation {
    type Item = Leaf;

    fn next(&mut self) -> Option<Leaf> {
        // The shader's loop bound, `NODES + DEPTH` passes: the module doc shows the walk ends
        // within it, so this only stops a broken walk.
        if self.done || self.nodes >= self.budget + self.depth {
            return None;
        }
        loop {
            let c = self.root.restrict(self.level, self.k);
            self.nodes += 1;
            let variations = c.variations();
            let resolved = c.resolved(variations);
            if resolved || self.level == self.depth || self.nodes >= self.budget {
                let leaf = Leaf { level: self.level, k: self.k, c, variations, resolved };
                while self.k & 1 == 1 {
                    self.k >>= 1;
                    self.level -= 1;
                }
                if self.level == 0 {
                    self.done = true;
                } else {
                    self.k += 1;
                }
                return Some(leaf);
            }
            self.level += 1;
            self.k *= 2;
        }
    }
}

/// Every crossing of `g` on `[0, 1]` in `u` order (the walk with the shared caps, each changing
/// leaf's [`Leaf::crossing`]). The first one is the smallest `u`.
pub fn crossings(g: &Bernstein, inside: Inside, steps: u32) -> impl Iterator<Item = Crossing> {
    Isolation::new(g).filter_map(move |leaf| leaf.crossing(inside, steps, None))
}

#[cfg(test)]
mod tests;
