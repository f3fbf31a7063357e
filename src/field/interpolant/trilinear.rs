//! The trilinear interpolant, the one CPU implementation (f64): the corners source, the CPU
//! references (`reference::trilinear` re-exports these), the slices and the extractors' normals
//! all evaluate it here. Its GPU twin is `shaders/include/interpolant.glsl` (`interp_value`,
//! `interp_gradient`): the same arithmetic in the same order, in f32.
//!
//! [`trilerp`] interpolates along x, then y, then z, with [`lerp`]`(a, b, w) = (1 - w) a + w b`
//! (GLSL's `mix`), which returns `a` and `b` bit for bit at `w = 0` and `w = 1`: a cell's corners
//! are reproduced exactly, and two cells sharing a face give bitwise identical values at a point
//! of that face (see `reference::trilinear`, "Face exactness").
//!
//! Corner order: `[v000, v100, v010, v110, v001, v101, v011, v111]` (vXYZ is the corner at
//! x+X, y+Y, z+Z), as `Grid::corners` returns them.

use glam::DVec3;

use super::{cell_missing, clamped, finite_range, Kernel, Stencil};

/// The trilinear interpolant as a [`Kernel`]: [`trilerp`], [`gradient`] and [`cell_missing`]
/// on the 8 corners, bit for bit.
pub struct Trilinear;

impl Kernel for Trilinear {
    const STENCIL: Stencil = Stencil { below: 0, above: 1 };
    type Cell = [f64; 8];

    /// The 8 corners in corner order. The clamp changes no index of a cell of the grid (its
    /// upper corner is at most the last point); it makes a 1-point axis read its one point.
    #[inline]
    fn gather(
        read: impl Fn([usize; 3]) -> f64,
        [i, j, k]: [usize; 3],
        [nx, ny, nz]: [usize; 3],
    ) -> [f64; 8] {
        std::array::from_fn(|n| {
            read([
                clamped(i, n & 1, 0, nx),
                clamped(j, n >> 1 & 1, 0, ny),
                clamped(k, n >> 2, 0, nz),
            ])
        })
    }

    #[inline]
    fn value(c: &[f64; 8], q: DVec3) -> f64 {
        trilerp(c, q)
    }

    #[inline]
    fn gradient(c: &[f64; 8], q: DVec3) -> DVec3 {
        gradient(c, q.x, q.y, q.z)
    }

    /// The corners' range: the interpolant is a convex combination of them.
    #[inline]
    fn hull(c: &[f64; 8]) -> [f64; 2] {
        finite_range(*c)
    }

    #[inline]
    fn missing(c: &[f64; 8]) -> bool {
        cell_missing(c)
    }
}

/// `(1 - w) a + w b`: exact at `w = 0` (gives `a`) and `w = 1` (gives `b`).
#[inline]
pub fn lerp(a: f64, b: f64, w: f64) -> f64 {
    (1.0 - w) * a + w * b
}

/// Value of the trilinear interpolant of corners `c` at cell-local `q` in `[0, 1]^3` (x first,
/// then y, then z).
#[inline]
pub fn trilerp(c: &[f64; 8], q: DVec3) -> f64 {
    let x00 = lerp(c[0], c[1], q.x);
    let x10 = lerp(c[2], c[3], q.x);
    let x01 = lerp(c[4], c[5], q.x);
    let x11 = lerp(c[6], c[7], q.x);
    let y0 = lerp(x00, x10, q.y);
    let y1 = lerp(x01, x11, q.y);
    lerp(y0, y1, q.z)
}

/// Gradient (index space, value per cell) of the trilinear interpolant of corner values `v` at
/// cell-local `(x, y, z)` in `[0, 1]³`, as a sum of products. This is THE gradient, CPU and GPU:
/// the mesh normals (`mesh::field`), the CPU references (fixed-step and analytic normals, the
/// analytic cubic's `c1`) and every shader (`interp_gradient` in
/// `shaders/include/interpolant.glsl`, the same terms in the same order, `precise`). The form
/// is this one, not the bilerp of edge differences (equal in exact arithmetic, not bit for bit),
/// because meshes must keep their bytes and their normals have always been these bits.
#[inline]
pub fn gradient(v: &[f64; 8], x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::from(gradient_in(v, x, y, z, 1.0))
}

/// [`gradient`]'s arithmetic (the same terms in the same order) on any number type whose
/// operations are f64's, such as several cells' f64 lanes at once (`one` is its 1.0): the mesh
/// extractors compute a row's normals this way, bit for bit [`gradient`]'s.
#[inline(always)]
pub fn gradient_in<T>(v: &[T; 8], x: T, y: T, z: T, one: T) -> [T; 3]
where
    T: Copy + std::ops::Add<Output = T> + std::ops::Sub<Output = T> + std::ops::Mul<Output = T>,
{
    let (mx, my, mz) = (one - x, one - y, one - z);
    [
        my * mz * (v[1] - v[0])
            + y * mz * (v[3] - v[2])
            + my * z * (v[5] - v[4])
            + y * z * (v[7] - v[6]),
        mx * mz * (v[2] - v[0])
            + x * mz * (v[3] - v[1])
            + mx * z * (v[6] - v[4])
            + x * z * (v[7] - v[5]),
        mx * my * (v[4] - v[0])
            + x * my * (v[5] - v[1])
            + mx * y * (v[6] - v[2])
            + x * y * (v[7] - v[3]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_kernel_gathers_in_corner_order_and_is_the_free_functions_bit_for_bit() {
        let read = |[i, j, k]: [usize; 3]| (i * 100 + j * 10 + k) as f64 + 0.25;
        let c = Trilinear::gather(read, [3, 5, 7], [9, 9, 9]);
        assert_eq!(c, [357.25, 457.25, 367.25, 467.25, 358.25, 458.25, 368.25, 468.25]);
        // The last cell reads the last points; only an axis of one point is clamped.
        assert_eq!(Trilinear::gather(read, [3, 5, 7], [5, 7, 9])[7], 468.25);
        assert_eq!(Trilinear::gather(read, [3, 0, 7], [5, 1, 9])[7], 408.25);
        let c = [0.3, -1.7, 2.9, 0.01, -0.4, 1.3, -2.2, 0.8];
        for q in [DVec3::new(0.1, 0.7, 0.33), DVec3::ZERO, DVec3::ONE, DVec3::new(1.0, 0.5, 0.0)] {
            assert_eq!(Trilinear::value(&c, q).to_bits(), trilerp(&c, q).to_bits());
            assert_eq!(Trilinear::gradient(&c, q), gradient(&c, q.x, q.y, q.z));
        }
        assert!(!Trilinear::missing(&c));
        assert_eq!(Trilinear::hull(&c), [-2.2, 2.9]);
        let mut holed = c;
        holed[6] = f64::NAN;
        assert!(Trilinear::missing(&holed));
        assert_eq!(Trilinear::hull(&holed), [-1.7, 2.9], "the hull is over the finite corners");
    }
}
