//! The trilinear field in f64 as the GPU's ray passes address it (`shaders/include/field.glsl`):
//! world point → grid coordinates clamped into the box → the cell from `floor`, the last plane
//! belonging to the last cell. The interpolation itself is [`super::trilinear`]'s.

use glam::DVec3;

use crate::field::interpolant::{Interpolant, Interpolated, Kernel, Trilinear};
use crate::field::Grid;

/// World position → continuous grid coordinates, clamped into the box ([`Grid::to_grid`]).
pub fn to_grid(grid: &Grid, pos: DVec3) -> DVec3 {
    grid.to_grid(pos)
}

/// The cell holding grid coordinates `u` ([`Grid::cell_of`]).
pub fn cell_of(grid: &Grid, u: DVec3) -> [usize; 3] {
    grid.cell_of(u)
}

/// Field value at grid coordinates `u` ([`Grid::value_at`]).
pub fn value_at(grid: &Grid, u: DVec3) -> f64 {
    grid.value_at(u)
}

/// World-space gradient at grid coordinates `u` ([`Interpolated::gradient_at`]).
pub fn gradient_at(grid: &Grid, u: DVec3) -> DVec3 {
    Interpolated::new(grid, Interpolant::Trilinear).gradient_at(u)
}

/// `render.normals = "smooth"` (GPU: `smooth_gradient` in `shaders/include/field.glsl`): the
/// gradient at grid point `p` by central differences in index units, one-sided on the box's
/// faces.
pub fn point_gradient(grid: &Grid, p: [usize; 3]) -> DVec3 {
    let mut g = DVec3::ZERO;
    for a in 0..3 {
        let last = grid.dims[a] - 1;
        let (mut lo, mut hi) = (p, p);
        if p[a] > 0 {
            lo[a] -= 1;
        }
        if p[a] < last {
            hi[a] += 1;
        }
        let w = if p[a] == 0 || p[a] == last { 1.0 } else { 0.5 };
        let v = |q: [usize; 3]| f64::from(grid.at(q[0], q[1], q[2]));
        g[a] = (v(hi) - v(lo)) * w;
    }
    g
}

/// The point gradients of `u`'s cell interpolated trilinearly at `u`, in world units.
pub fn smooth_gradient_at(grid: &Grid, u: DVec3) -> DVec3 {
    let c = cell_of(grid, u);
    let f = u - DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
    let corners: [DVec3; 8] = std::array::from_fn(|n| {
        point_gradient(grid, [c[0] + (n & 1), c[1] + ((n >> 1) & 1), c[2] + ((n >> 2) & 1)])
    });
    let component = |a: usize| Trilinear::value(&corners.map(|g| g[a]), f);
    DVec3::new(component(0), component(1), component(2)) / grid.spacing()
}

/// Ray/box intersection by slabs: `Some((t0, t1))` with `0 <= t0 <= t1`, or None when the ray
/// misses the box or it lies behind the origin. Zero direction components are handled
/// explicitly.
pub fn clip_box(grid: &Grid, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, f64::MAX);
    for a in 0..3 {
        let (lo, hi) = (grid.min[a], grid.max[a]);
        if d[a] == 0.0 {
            if o[a] < lo || o[a] > hi {
                return None;
            }
        } else {
            let ta = (lo - o[a]) / d[a];
            let tb = (hi - o[a]) / d[a];
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trilinear_reproduces_corners_and_gradient_of_a_linear_field() {
        let grid = Grid {
            dims: [2, 2, 2],
            min: DVec3::ZERO,
            max: DVec3::new(2.0, 4.0, 8.0),
            values: (0..8)
                .map(|n| {
                    (1.0 + 2.0 * (n & 1) as f64 + 3.0 * ((n >> 1) & 1) as f64
                        - 4.0 * ((n >> 2) & 1) as f64) as f32
                })
                .collect(),
        };
        let u = DVec3::new(0.25, 0.5, 0.75);
        assert!((value_at(&grid, u) - (1.0 + 0.5 + 1.5 - 3.0)).abs() < 1e-12);
        let g = gradient_at(&grid, u);
        assert!((g - DVec3::new(1.0, 0.75, -0.5)).length() < 1e-12);
    }

    #[test]
    fn clip_box_handles_axis_parallel_and_inside_rays() {
        let grid =
            Grid { dims: [2, 2, 2], min: DVec3::ZERO, max: DVec3::ONE, values: vec![0.0; 8] };
        assert_eq!(clip_box(&grid, DVec3::new(0.5, 0.5, -1.0), DVec3::Z), Some((1.0, 2.0)));
        assert_eq!(clip_box(&grid, DVec3::new(1.5, 0.5, -1.0), DVec3::Z), None);
        assert_eq!(clip_box(&grid, DVec3::splat(0.5), DVec3::X), Some((0.0, 0.5)));
        assert_eq!(clip_box(&grid, DVec3::new(0.5, 0.5, 2.0), DVec3::Z), None);
    }
}
