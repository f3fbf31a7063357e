//! The trilinear interpolant of a [`Grid`], in `f64`, at world points: the spaces, [`locate`], and
//! the value and gradient at a point, around `field::interpolant::trilinear`'s per-cell
//! arithmetic (the one value and gradient, CPU and GPU). Every CPU reference evaluates the field
//! through these functions.
//!
//! # Spaces
//!
//! - **World space**: the scene's coordinates; the grid box is `[grid.min, grid.max]`.
//! - **Index space**: `(p - grid.min) / grid.spacing()`; grid point `(i, j, k)` sits at
//!   `(i, j, k)` and the box is `[0, nx-1] x [0, ny-1] x [0, nz-1]`. The map is affine, so a ray
//!   keeps its parameter `t` in both spaces.
//! - **Cell-local space**: index space minus the cell's corner 000; the cell is `[0, 1]^3`.
//!
//! # Corner order
//!
//! A cell's corners are `[v000, v100, v010, v110, v001, v101, v011, v111]` (vXYZ is the corner at
//! x+X, y+Y, z+Z), as [`Grid::corners`] returns them, widened to `f64`.
//!
//! # Face exactness
//!
//! [`trilerp`] interpolates along x, then y, then z, with [`lerp`]`(a, b, w) = (1 - w) a + w b`,
//! which returns `a` and `b` bit for bit at `w = 0` and `w = 1`. So two cells sharing a face give
//! bitwise identical values at a point of that face, provided both see the same non-snapped local
//! coordinates and the crossed coordinate is exactly 0 in one and exactly 1 in the other. The
//! analytic tracer relies on this (see `analytic`); the GPU keeps the same order
//! (`shaders/include/interpolant.glsl`, `precise`).
//!
//! # Gradients at faces
//!
//! The interpolant is only C0 across cells: on a shared face the two cells' gradients differ in
//! the component normal to the face. [`locate`] picks the cell `clamp(floor(q), 0, n - 2)`, so a
//! point on an interior face belongs to the cell on its + side. Callers that know which cell a
//! point belongs to (a ray tracer does) should use [`Trilinear::gradient`] with that cell
//! instead: the one gradient, CPU and GPU (`field::interpolant::trilinear::gradient`).

use glam::DVec3;

use crate::field::interpolant::{Kernel, Trilinear};
use crate::field::Grid;

pub use crate::field::interpolant::trilinear::{lerp, trilerp};

/// Component-wise [`lerp`].
#[inline]
pub fn lerp3(a: DVec3, b: DVec3, w: f64) -> DVec3 {
    DVec3::new(lerp(a.x, b.x, w), lerp(a.y, b.y, w), lerp(a.z, b.z, w))
}

/// The 8 corner values of cell `cell`, widened to `f64`, in corner order.
pub fn cell_corners(grid: &Grid, cell: [usize; 3]) -> [f64; 8] {
    grid.corners(cell[0], cell[1], cell[2]).map(f64::from)
}

/// Index-space coordinates of world point `p` (may lie outside the box).
pub fn to_index(grid: &Grid, p: DVec3) -> DVec3 {
    (p - grid.min) / grid.spacing()
}

/// The cell containing world point `p` and the point's cell-local coordinates, or `None` when
/// `p` is outside the (closed) box or not finite. Points on an interior face go to the cell on
/// the face's + side; points on the box's max faces go to the last cell (local coordinate 1).
pub fn locate(grid: &Grid, p: DVec3) -> Option<([usize; 3], DVec3)> {
    let q = to_index(grid, p);
    let cells = grid.cells();
    let mut cell = [0usize; 3];
    let mut local = DVec3::ZERO;
    for a in 0..3 {
        let n = cells[a] as f64;
        if !(q[a] >= 0.0 && q[a] <= n) {
            return None;
        }
        let c = q[a].floor().min(n - 1.0).max(0.0);
        cell[a] = c as usize;
        local[a] = q[a] - c;
    }
    Some((cell, local))
}

/// Field value at world point `p`, `None` outside the box.
pub fn value_at(grid: &Grid, p: DVec3) -> Option<f64> {
    let (cell, q) = locate(grid, p)?;
    Some(Trilinear::value(&cell_corners(grid, cell), q))
}

/// World-space gradient of the field in cell `cell` at cell-local `q` (value per world unit).
pub fn world_gradient(grid: &Grid, cell: [usize; 3], q: DVec3) -> DVec3 {
    Trilinear::gradient(&cell_corners(grid, cell), q) / grid.spacing()
}

/// World-space gradient at world point `p` (in the cell [`locate`] picks), `None` outside the
/// box.
pub fn gradient_at(grid: &Grid, p: DVec3) -> Option<DVec3> {
    let (cell, q) = locate(grid, p)?;
    Some(world_gradient(grid, cell, q))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::analytic::cubic::Monomial;

    fn xorshift(state: &mut u64) -> f64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn trilerp_reproduces_corners() {
        let c = [1.0, -2.0, 3.5, 0.25, -7.0, 11.0, 0.125, -0.5];
        for (n, &v) in c.iter().enumerate() {
            let q = DVec3::new((n & 1) as f64, ((n >> 1) & 1) as f64, ((n >> 2) & 1) as f64);
            assert_eq!(trilerp(&c, q), v);
        }
    }

    #[test]
    fn monomial_and_gradient_agree_with_trilerp() {
        let mut s = 0x9e37_79b9_7f4a_7c15;
        for _ in 0..200 {
            let c: [f64; 8] = std::array::from_fn(|_| xorshift(&mut s) * 2.0 - 1.0);
            let m = Monomial::from_corners(&c);
            let q = DVec3::new(xorshift(&mut s), xorshift(&mut s), xorshift(&mut s));
            let mono = m.a0
                + m.ax * q.x
                + m.ay * q.y
                + m.az * q.z
                + m.axy * q.x * q.y
                + m.axz * q.x * q.z
                + m.ayz * q.y * q.z
                + m.axyz * q.x * q.y * q.z;
            assert!((mono - trilerp(&c, q)).abs() < 1e-14);
            let g = Trilinear::gradient(&c, q);
            let mg = DVec3::new(
                m.ax + m.axy * q.y + m.axz * q.z + m.axyz * q.y * q.z,
                m.ay + m.axy * q.x + m.ayz * q.z + m.axyz * q.x * q.z,
                m.az + m.axz * q.x + m.ayz * q.y + m.axyz * q.x * q.y,
            );
            assert!((g - mg).abs().max_element() < 1e-14);
            let h = 1e-6;
            for a in 0..3 {
                let mut e = DVec3::ZERO;
                e[a] = h;
                let fd = (trilerp(&c, q + e) - trilerp(&c, q - e)) / (2.0 * h);
                assert!((fd - g[a]).abs() < 1e-8);
            }
        }
    }

    #[test]
    fn shared_faces_agree_bitwise() {
        let mut s = 0x1234_5678_9abc_def1;
        let grid = Grid {
            dims: [4, 4, 4],
            min: DVec3::ZERO,
            max: DVec3::splat(3.0),
            values: (0..64).map(|_| (xorshift(&mut s) * 2.0 - 1.0) as f32).collect(),
        };
        for _ in 0..500 {
            let u = xorshift(&mut s);
            let v = xorshift(&mut s);
            for axis in 0..3 {
                let mut a = [1usize, 1, 1];
                let mut b = [1usize, 1, 1];
                a[axis] = 0;
                b[axis] = 1;
                let mut qa = DVec3::new(u, v, u * v);
                let mut qb = qa;
                qa[axis] = 1.0;
                qb[axis] = 0.0;
                let fa = trilerp(&cell_corners(&grid, a), qa);
                let fb = trilerp(&cell_corners(&grid, b), qb);
                assert_eq!(fa.to_bits(), fb.to_bits(), "axis {axis}");
            }
        }
    }

    #[test]
    fn locate_and_world_gradient() {
        let grid = Grid {
            dims: [3, 5, 2],
            min: DVec3::new(-1.0, 0.0, 2.0),
            max: DVec3::new(1.0, 2.0, 3.0),
            values: (0..30)
                .map(|n| {
                    let (i, j, k) = (n % 3, (n / 3) % 5, n / 15);
                    (i as f32) * 1.0 + (j as f32) * 0.5 - (k as f32) * 2.0
                })
                .collect(),
        };
        // f = x_index + 0.5 y_index - 2 z_index; spacing (1, 0.5, 1).
        let p = DVec3::new(0.25, 1.3, 2.5);
        let (cell, q) = locate(&grid, p).unwrap();
        assert_eq!(cell, [1, 2, 0]);
        assert!((q - DVec3::new(0.25, 0.6, 0.5)).abs().max_element() < 1e-12);
        let f = value_at(&grid, p).unwrap();
        assert!((f - (1.25 + 0.5 * 2.6 - 1.0)).abs() < 1e-12);
        let g = gradient_at(&grid, p).unwrap();
        assert!((g - DVec3::new(1.0, 1.0, -2.0)).abs().max_element() < 1e-12);
        assert_eq!(locate(&grid, DVec3::new(1.0, 2.0, 3.0)).unwrap().0, [1, 3, 0]);
        assert!(locate(&grid, DVec3::new(1.0 + 1e-9, 1.0, 2.5)).is_none());
    }
}
