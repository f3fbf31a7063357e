//! The quadratic error function of dual contouring (Ju, Losasso, Schaefer & Warren 2002;
//! Lindstrom 2000): given tangent planes `(pᵢ, nᵢ)` (a crossing point and the unit surface
//! normal there), the vertex is the minimiser of
//!
//! ```text
//!   E(x) = Σᵢ (nᵢ · (x - pᵢ))²  =  xᵀ(AᵀA)x - 2 xᵀ(Aᵀb) + bᵀb,     rows of A: nᵢᵀ, bᵢ = nᵢ · pᵢ
//! ```
//!
//! kept as the 3×3 matrix `AᵀA`, the vector `Aᵀb` and the scalar `bᵀb` (so two QEFs merge by
//! adding them, as the octree does), plus the sum and count of the points (the *mass point*
//! `m`, their mean).
//!
//! **Solve** (Lindstrom's mass-point regularisation): write `x = m + y` and solve
//! `AᵀA y = Aᵀb - AᵀA m` with the pseudo-inverse of `AᵀA`, dropping the eigenvalues whose
//! singular value `√λ` is below `threshold · √λ_max`. Along a dropped direction the planes do
//! not pin the vertex down (a flat piece has one plane direction, an edge two, a corner three),
//! and the pseudo-inverse leaves `y` at 0 there, so the vertex stays at the mass point along
//! it: a flat cell gets the crossings' mean projected onto the plane, an edge cell the point of
//! the edge nearest the mean, a corner cell the corner. Then, optionally, the vertex is kept in
//! the cell's box (a nearly singular system can still throw it far off): an edge's vertex
//! slides along the edge to the nearest point inside the box, so it stays on the feature line;
//! otherwise it is clamped to the box.
//!
//! The symmetric 3×3 eigen-decomposition is cyclic Jacobi, written out here: the crate has no
//! linear-algebra dependency (glam has no eigen-solver, and `nalgebra` for one 3×3 solve would
//! be a heavy addition to a lean default build). Jacobi is unconditionally convergent on
//! symmetric matrices and accurate to rounding for small eigenvalues, which the threshold reads.

use glam::{DMat3, DVec3};

/// A QEF accumulated from tangent planes (all coordinates in one space, here grid index space).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Qef {
    /// `AᵀA`, symmetric.
    pub ata: DMat3,
    /// `Aᵀb`.
    pub atb: DVec3,
    /// `bᵀb`.
    pub btb: f64,
    /// Sum of the points (the mass point is `mass / count`).
    pub mass: DVec3,
    pub count: u32,
}

impl Default for Qef {
    /// No planes. (Not derived: glam's `DMat3::default()` is the identity.)
    fn default() -> Self {
        Qef { ata: DMat3::ZERO, atb: DVec3::ZERO, btb: 0.0, mass: DVec3::ZERO, count: 0 }
    }
}

impl Qef {
    /// Adds the plane through `p` with normal `n` (unit, or zero: then only the point counts
    /// towards the mass point).
    pub fn add(&mut self, p: DVec3, n: DVec3) {
        let d = n.dot(p);
        self.ata += DMat3::from_cols(n * n.x, n * n.y, n * n.z);
        self.atb += n * d;
        self.btb += d * d;
        self.mass += p;
        self.count += 1;
    }

    /// The sum of two QEFs (the QEF of all their planes).
    pub fn merged(&self, o: &Qef) -> Qef {
        Qef {
            ata: self.ata + o.ata,
            atb: self.atb + o.atb,
            btb: self.btb + o.btb,
            mass: self.mass + o.mass,
            count: self.count + o.count,
        }
    }

    /// The mean of the points.
    pub fn mass_point(&self) -> DVec3 {
        self.mass / f64::from(self.count.max(1))
    }

    /// `E(x)`, the sum of squared distances from `x` to the planes (never below 0).
    pub fn error(&self, x: DVec3) -> f64 {
        (x.dot(self.ata * x) - 2.0 * x.dot(self.atb) + self.btb).max(0.0)
    }

    /// The minimiser (see the module docs), clamped into `[lo, hi]` when `clamp` is given.
    pub fn solve(&self, threshold: f64, clamp: Option<(DVec3, DVec3)>) -> DVec3 {
        let m = self.mass_point();
        let rhs = self.atb - self.ata * m;
        let (vals, vecs) = eigen_symmetric(self.ata);
        let max = vals.max_element().max(0.0);
        let cut = threshold * threshold * max;
        let mut y = DVec3::ZERO;
        let mut free = Vec::new();
        for i in 0..3 {
            let l = vals[i];
            let v = vecs.col(i);
            if max > 0.0 && l > cut {
                y += v * (v.dot(rhs) / l);
            } else {
                free.push(v);
            }
        }
        let x = m + y;
        let Some((lo, hi)) = clamp else {
            return x;
        };
        if x.cmpge(lo).all() && x.cmple(hi).all() {
            return x;
        }
        // An edge (one free direction): every point of the line x + t v is a minimiser, so
        // take the one nearest x on the part of the line inside the box, which keeps the
        // vertex on the feature line; otherwise (a plane, a corner, or a line that misses the
        // box) clamp.
        if let [v] = free[..] {
            let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
            for a in 0..3 {
                if v[a].abs() > 1e-12 {
                    let (p, q) = ((lo[a] - x[a]) / v[a], (hi[a] - x[a]) / v[a]);
                    t0 = t0.max(p.min(q));
                    t1 = t1.min(p.max(q));
                } else if x[a] < lo[a] || x[a] > hi[a] {
                    t0 = f64::INFINITY;
                }
            }
            if t0 <= t1 {
                let t = 0f64.clamp(t0, t1);
                return (x + v * t).clamp(lo, hi);
            }
        }
        x.clamp(lo, hi)
    }
}

/// Eigenvalues and unit eigenvectors (the columns, in the same order) of the symmetric `a`, by
/// cyclic Jacobi rotations until the off-diagonal part is below rounding (at most 32 sweeps;
/// 3×3 matrices converge in a handful).
pub(crate) fn eigen_symmetric(a: DMat3) -> (DVec3, DMat3) {
    let mut m = a.to_cols_array_2d(); // m[col][row]; symmetric, so m[i][j] is entry (i, j)
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..32 {
        let off = m[0][1] * m[0][1] + m[0][2] * m[0][2] + m[1][2] * m[1][2];
        let diag = m[0][0] * m[0][0] + m[1][1] * m[1][1] + m[2][2] * m[2][2];
        if off <= 1e-30 * diag || off == 0.0 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            let apq = m[p][q];
            if apq == 0.0 {
                continue;
            }
            // Rotation angle that zeroes (p, q) (Golub & Van Loan, symmetric Schur 2×2).
            let tau = (m[q][q] - m[p][p]) / (2.0 * apq);
            let t = tau.signum() / (tau.abs() + (1.0 + tau * tau).sqrt());
            let t = if tau == 0.0 { 1.0 } else { t };
            let c = 1.0 / (1.0 + t * t).sqrt();
            let s = t * c;
            // m <- Jᵀ m J on rows/columns p and q.
            for col in m.iter_mut() {
                let (mkp, mkq) = (col[p], col[q]);
                col[p] = c * mkp - s * mkq;
                col[q] = s * mkp + c * mkq;
            }
            let (mp, mq) = (m[p], m[q]);
            m[p] = std::array::from_fn(|k| c * mp[k] - s * mq[k]);
            m[q] = std::array::from_fn(|k| s * mp[k] + c * mq[k]);
            // v <- v J (eigenvectors are the columns v[.][col] -> stored as v[col][row]).
            let (vp, vq) = (v[p], v[q]);
            v[p] = std::array::from_fn(|row| c * vp[row] - s * vq[row]);
            v[q] = std::array::from_fn(|row| s * vp[row] + c * vq[row]);
        }
    }
    (DVec3::new(m[0][0], m[1][1], m[2][2]), DMat3::from_cols_array_2d(&v))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jacobi_reconstructs_random_symmetric_matrices() {
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..200 {
            let b = DMat3::from_cols_array(&std::array::from_fn(|_| rnd()));
            let a = b.transpose() * b;
            let (vals, vecs) = eigen_symmetric(a);
            let back = vecs * DMat3::from_diagonal(vals) * vecs.transpose();
            let err = (back - a).to_cols_array().iter().map(|x| x.abs()).fold(0.0, f64::max);
            assert!(err < 1e-12, "{a:?}: error {err}");
            let ortho = vecs.transpose() * vecs - DMat3::IDENTITY;
            assert!(ortho.to_cols_array().iter().all(|x| x.abs() < 1e-12));
        }
    }

    #[test]
    fn corner_edge_and_plane_are_recovered() {
        let planes = |q: &mut Qef, ns: &[DVec3], through: DVec3| {
            for (k, &n) in ns.iter().enumerate() {
                // Points on the plane, spread so the mass point is off the feature.
                let off = DVec3::new(0.1 * k as f64, 0.2, -0.15 * k as f64);
                let p = through + off - n * n.dot(off);
                q.add(p, n);
            }
        };
        let corner = DVec3::new(0.3, 0.6, 0.45);
        let mut q = Qef::default();
        planes(&mut q, &[DVec3::X, DVec3::Y, DVec3::Z, DVec3::X], corner);
        assert!(q.solve(0.1, None).distance(corner) < 1e-12);
        assert!(q.error(q.solve(0.1, None)) < 1e-24);

        // An edge along z: x and y pinned, z stays at the mass point's.
        let mut q = Qef::default();
        planes(&mut q, &[DVec3::X, DVec3::Y, DVec3::X, DVec3::Y], corner);
        let x = q.solve(0.1, None);
        assert!((x.x - corner.x).abs() < 1e-12 && (x.y - corner.y).abs() < 1e-12);
        assert!((x.z - q.mass_point().z).abs() < 1e-12);

        // A plane: the mass point projected onto it.
        let n = DVec3::new(1.0, 2.0, 2.0) / 3.0;
        let mut q = Qef::default();
        planes(&mut q, &[n, n, n], corner);
        let m = q.mass_point();
        assert!(q.solve(0.1, None).distance(m - n * n.dot(m - corner)) < 1e-12);

        // Clamping.
        let x = q.solve(0.1, Some((DVec3::ZERO, DVec3::splat(0.2))));
        assert!(x.max_element() <= 0.2);

        // An edge whose nearest point to the mass point lies outside the box: the vertex
        // slides along the edge into the box instead of leaving the line.
        let mut q = Qef::default();
        let dir = DVec3::new(1.0, 1.0, 0.0).normalize();
        let (n1, n2) = (DVec3::Z, DVec3::new(1.0, -1.0, 0.0).normalize());
        let on = DVec3::new(0.5, 0.5, 0.5);
        for k in 0..3 {
            let p = on + dir * (0.9 + 0.05 * k as f64);
            q.add(p, n1);
            q.add(p, n2);
        }
        let x = q.solve(0.1, Some((DVec3::ZERO, DVec3::ONE)));
        assert!((x - on).reject_from(dir).length() < 1e-12, "{x}");
        assert!(x.max_element() <= 1.0 + 1e-12);
    }
}
