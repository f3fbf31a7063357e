//! The nearest-point interpolant in f64: the value of the grid point nearest to `u`, rounding
//! half up along each axis, so the field is constant on voxels `[i - ½, i + ½)` centred on
//! the points, and the surface is the faces between inside and outside voxels.
//!
//! A cell reads its 8 corners (along each axis cell `c` only sees points `c` and `c + 1`, so
//! its stencil is trilinear's, `{ below: 0, above: 1 }`): at cell-local `q` it takes corner
//! `(q.x >= ½) + 2 (q.y >= ½) + 4 (q.z >= ½)`. The last plane of the grid belongs to the last
//! cell at `q = 1` (`Grid::cell_of`), so it reads the last point: the clamp at the far border;
//! at the near border `q = 0` reads point 0.

use glam::DVec3;

use super::{cell_missing, finite_range, is_missing, Kernel, Stencil, Trilinear};
use crate::field::Grid;

/// The nearest-point interpolant as a [`Kernel`] on the 8 corners (corner order as
/// [`Trilinear`]'s).
pub struct Nearest;

/// The corner nearest to cell-local `q`, half up: `(q.x >= ½) + 2 (q.y >= ½) + 4 (q.z >= ½)`.
#[inline]
pub fn corner(q: DVec3) -> usize {
    usize::from(q.x >= 0.5) + 2 * usize::from(q.y >= 0.5) + 4 * usize::from(q.z >= 0.5)
}

/// The point whose voxel holds grid coordinates `u` (in the box): the corner [`Nearest::value`]
/// reads in the cell [`Grid::cell_of`] picks, so the last plane belongs to the last point.
pub fn voxel_of(grid: &Grid, u: DVec3) -> [usize; 3] {
    let c = grid.cell_of(u);
    std::array::from_fn(|a| c[a] + usize::from(u[a] - c[a] as f64 >= 0.5))
}

impl Kernel for Nearest {
    const STENCIL: Stencil = Stencil { below: 0, above: 1 };
    type Cell = [f64; 8];

    #[inline]
    fn gather(read: impl Fn([usize; 3]) -> f64, cell: [usize; 3], dims: [usize; 3]) -> [f64; 8] {
        Trilinear::gather(read, cell, dims)
    }

    #[inline]
    fn value(c: &[f64; 8], q: DVec3) -> f64 {
        c[corner(q)]
    }

    /// Zero: the field is constant on each voxel (and not differentiable on its faces). Its
    /// normals are the faces' (`Caps::gradient` is false).
    #[inline]
    fn gradient(_: &[f64; 8], _: DVec3) -> DVec3 {
        DVec3::ZERO
    }

    /// The corners' range: the value is one of them.
    #[inline]
    fn hull(c: &[f64; 8]) -> [f64; 2] {
        finite_range(*c)
    }

    #[inline]
    fn missing(c: &[f64; 8]) -> bool {
        cell_missing(c)
    }

    /// Only the corner it reads: a voxel beside a missing one keeps its value.
    #[inline]
    fn missing_at(c: &[f64; 8], q: DVec3) -> bool {
        is_missing(c[corner(q)])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::interpolant::{Interpolant, Interpolated};

    #[test]
    fn the_nearest_corner_rounds_half_up() {
        let c = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0];
        let v = |x, y, z| Nearest::value(&c, DVec3::new(x, y, z));
        assert_eq!(v(0.0, 0.0, 0.0), 0.0);
        assert_eq!(v(0.49999, 0.2, 0.1), 0.0);
        assert_eq!(v(0.5, 0.2, 0.1), 1.0, "half up");
        assert_eq!(v(0.2, 0.5, 0.1), 2.0);
        assert_eq!(v(0.2, 0.1, 0.5), 4.0);
        assert_eq!(v(1.0, 1.0, 1.0), 7.0);
        assert_eq!(v(0.7, 0.2, 0.9), 5.0);
        assert_eq!(Nearest::gradient(&c, DVec3::splat(0.3)), DVec3::ZERO);
        assert_eq!(Nearest::hull(&c), [0.0, 7.0]);
    }

    #[test]
    fn only_the_chosen_voxel_decides_missing() {
        let mut c = [0.5; 8];
        c[3] = f64::NAN;
        assert!(Nearest::missing(&c));
        assert!(Nearest::missing_at(&c, DVec3::new(0.6, 0.7, 0.1)));
        assert!(!Nearest::missing_at(&c, DVec3::new(0.6, 0.2, 0.1)));
        assert!(!Nearest::missing_at(&c, DVec3::new(0.6, 0.7, 0.5)));
    }

    /// Through [`Interpolated`], on a grid of 3 × 4 × 2 points: every point's voxel, the near
    /// border (u = 0) and the far one (the last plane, at q = 1 of the last cell).
    #[test]
    fn each_voxel_holds_its_point_up_to_both_borders() {
        let dims = [3, 4, 2];
        let values = (0..24).map(|n| n as f32).collect();
        let grid = Grid { dims, min: DVec3::ZERO, max: DVec3::new(2.0, 3.0, 1.0), values };
        let f = Interpolated::new(&grid, Interpolant::Nearest);
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let p = DVec3::new(i as f64, j as f64, k as f64);
                    let want = f64::from(grid.at(i, j, k));
                    // The voxel [p - ½, p + ½), within the box.
                    let last = DVec3::new(2.0, 3.0, 1.0);
                    for d in [-0.5, -0.25, 0.0, 0.25, 0.4999] {
                        let u = (p + DVec3::splat(d)).clamp(DVec3::ZERO, last);
                        assert_eq!(f.value_at(u), want, "point {p} at {u}");
                        assert_eq!(voxel_of(&grid, u), [i, j, k], "voxel at {u}");
                    }
                    if (p + 0.5).cmple(last).all() {
                        assert_ne!(f.value_at(p + 0.5), want, "half up leaves {p}");
                    }
                }
            }
        }
        assert_eq!(f.gradient_at(DVec3::splat(0.7)), DVec3::ZERO);
    }
}
