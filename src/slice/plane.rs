//! The slicing plane, its picture's pixel mapping, and the field restricted to it.
//!
//! # Spaces
//!
//! - **World space**: the scene's coordinates.
//! - **Plane (u, v)**: the two world axes other than the slicing axis, in xyz order: `u` is the
//!   picture's right, `v` its up (`--axis x`: (y, z); `--axis y`: (x, z); `--axis z`: (x, y)).
//! - **Plane index space**: `(u, v)` measured in grid cells from the grid's first point, so plane
//!   point `(i, j)` is a grid point and the plane's box is `[0, nu - 1] x [0, nv - 1]`.
//!
//! # The field on the plane
//!
//! With the plane at grid index coordinate `w = k0 + t` along the slicing axis (`k0` the layer of
//! cells it cuts, `t` in `[0, 1]`), the trilinear interpolant restricted to the plane is, in each
//! cross-section cell, the *bilinear* interpolant of the 4 corner values
//! `lerp(value(k0), value(k0 + 1), t)`: a grid of [`PlaneGrid::values`] at the grid's own
//! resolution. On a grid plane (`t = 0`) they are the grid's samples.

use glam::{DVec2, DVec3};

use super::SliceError;
use crate::field::interpolant::trilinear::lerp;
use crate::field::interpolant::{is_missing, Interpolant, Interpolated};
use crate::field::Grid;

/// A slicing axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    /// The world axis index (0, 1, 2).
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }

    /// `"x"`, `"y"` or `"z"`.
    pub fn name(self) -> &'static str {
        ["x", "y", "z"][self.index()]
    }

    /// Parses `x`, `y` or `z` (any case).
    pub fn parse(s: &str) -> Option<Axis> {
        match s.trim().to_ascii_lowercase().as_str() {
            "x" => Some(Axis::X),
            "y" => Some(Axis::Y),
            "z" => Some(Axis::Z),
            _ => None,
        }
    }

    /// The world axes of the plane's `u` (right) and `v` (up): the other two, in xyz order.
    pub fn plane_axes(self) -> (usize, usize) {
        match self {
            Axis::X => (1, 2),
            Axis::Y => (0, 2),
            Axis::Z => (0, 1),
        }
    }
}

/// The field on an axis-aligned plane through the grid box, at the grid's resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaneGrid {
    pub axis: Axis,
    /// World coordinate of the plane along `axis`.
    pub at: f64,
    /// World axes of `u` and `v` ([`Axis::plane_axes`]).
    pub axes: (usize, usize),
    /// Grid points along `u` and `v`.
    pub dims: [usize; 2],
    /// World `(u, v)` of plane point `(0, 0)` and of the last point.
    pub min: DVec2,
    pub max: DVec2,
    /// Layer of grid cells the plane cuts, `clamp(floor(w), 0, n - 2)`.
    pub layer: usize,
    /// Position of the plane inside that layer, `w - layer` in `[0, 1]`.
    pub weight: f64,
    /// `nu * nv` values, u fastest: `lerp(grid(.., layer), grid(.., layer + 1), weight)`;
    /// for another interpolant, its value at each plane point (NaN where it is missing).
    pub values: Vec<f64>,
    /// The field's interpolant (`field.interpolation`; [`PlaneGrid::through`]).
    pub interp: Interpolant,
    /// For the cubic interpolants, whether each plane cell is missing (its 3D cell's 4x4x4
    /// stencil holds missing data), u fastest; None: a corner value says
    /// ([`PlaneGrid::cell_missing`]).
    pub missing: Option<Vec<bool>>,
}

impl PlaneGrid {
    /// The field of `grid` on the plane `axis = at` (world space). Fails when the plane misses
    /// the grid box.
    pub fn new(grid: &Grid, axis: Axis, at: f64) -> Result<PlaneGrid, SliceError> {
        let a = axis.index();
        let (lo, hi) = (grid.min[a], grid.max[a]);
        if !(at.is_finite() && at >= lo && at <= hi) {
            return Err(SliceError::OutsideBox { axis: axis.name(), at, min: lo, max: hi });
        }
        let n = grid.dims[a];
        let w = ((at - lo) / (hi - lo) * (n - 1) as f64).clamp(0.0, (n - 1) as f64);
        let layer = (w.floor() as usize).min(n - 2);
        let weight = w - layer as f64;
        let axes = axis.plane_axes();
        let dims = [grid.dims[axes.0], grid.dims[axes.1]];
        let mut values = Vec::with_capacity(dims[0] * dims[1]);
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let point = |k: usize| {
                    let mut p = [0usize; 3];
                    p[axes.0] = i;
                    p[axes.1] = j;
                    p[a] = k;
                    f64::from(grid.at(p[0], p[1], p[2]))
                };
                values.push(lerp(point(layer), point(layer + 1), weight));
            }
        }
        Ok(PlaneGrid {
            axis,
            at,
            axes,
            dims,
            min: DVec2::new(grid.min[axes.0], grid.min[axes.1]),
            max: DVec2::new(grid.max[axes.0], grid.max[axes.1]),
            layer,
            weight,
            values,
            interp: Interpolant::Trilinear,
            missing: None,
        })
    }

    /// The plane `axis = at` of `grid` read with `interp`: [`PlaneGrid::new`] for trilinear;
    /// otherwise the interpolant's value at each plane point (`Interpolated`, NaN where it is
    /// missing) and, for the cubic ones, each plane cell's missing flag from its 3D cell's
    /// stencil. The contours then follow the interpolant itself (`slice::scene_contours`).
    pub fn through(
        grid: &Grid,
        axis: Axis,
        at: f64,
        interp: Interpolant,
    ) -> Result<PlaneGrid, SliceError> {
        let mut plane = PlaneGrid::new(grid, axis, at)?;
        if interp == Interpolant::Trilinear {
            return Ok(plane);
        }
        let field = Interpolated::new(grid, interp);
        let (axes, w) = (plane.axes, plane.w());
        let point = move |i: f64, j: f64| {
            let mut g = DVec3::ZERO;
            g[axes.0] = i;
            g[axes.1] = j;
            g[axis.index()] = w;
            g
        };
        let [nu, nv] = plane.dims;
        for j in 0..nv {
            for i in 0..nu {
                let g = point(i as f64, j as f64);
                plane.values[i + nu * j] =
                    if field.missing_at(g) { f64::NAN } else { field.value_at(g) };
            }
        }
        if interp.stencil().width() > 2 {
            let [cu, cv] = plane.cells();
            let flags = (0..cu * cv)
                .map(|c| field.missing_at(point((c % cu) as f64 + 0.5, (c / cu) as f64 + 0.5)));
            plane.missing = Some(flags.collect());
        }
        plane.interp = interp;
        Ok(plane)
    }

    /// Continuous grid index coordinate of the plane along its axis (`layer + weight`).
    pub fn w(&self) -> f64 {
        self.layer as f64 + self.weight
    }

    /// Cells along `u` and `v`.
    pub fn cells(&self) -> [usize; 2] {
        [self.dims[0] - 1, self.dims[1] - 1]
    }

    /// World size of one cell along `u` and `v`.
    pub fn spacing(&self) -> DVec2 {
        (self.max - self.min) / DVec2::new(self.cells()[0] as f64, self.cells()[1] as f64)
    }

    /// Value at plane point `(i, j)`.
    pub fn at(&self, i: usize, j: usize) -> f64 {
        self.values[i + self.dims[0] * j]
    }

    /// Corner values of cell `(i, j)` counterclockwise from its lower left:
    /// `[v(i, j), v(i+1, j), v(i+1, j+1), v(i, j+1)]` (the marching-squares corner order).
    pub fn cell_corners(&self, i: usize, j: usize) -> [f64; 4] {
        [self.at(i, j), self.at(i + 1, j), self.at(i + 1, j + 1), self.at(i, j + 1)]
    }

    /// The cell holding plane index point `q` (the last line belongs to the last cell).
    pub fn cell_of(&self, q: DVec2) -> [usize; 2] {
        let c = self.cells();
        [
            (q.x.floor().max(0.0) as usize).min(c[0] - 1),
            (q.y.floor().max(0.0) as usize).min(c[1] - 1),
        ]
    }

    /// The bilinear interpolant at plane index point `q` (clamped into the box): along u first,
    /// then v, like the trilinear reference.
    pub fn bilinear(&self, q: DVec2) -> f64 {
        let q = q.clamp(DVec2::ZERO, DVec2::new(self.cells()[0] as f64, self.cells()[1] as f64));
        let [i, j] = self.cell_of(q);
        let f = q - DVec2::new(i as f64, j as f64);
        let [c00, c10, c11, c01] = self.cell_corners(i, j);
        lerp(lerp(c00, c10, f.x), lerp(c01, c11, f.x), f.y)
    }

    /// Plane index point → world `(u, v)` (exactly `min` and `max` at the box's sides).
    pub fn to_uv(&self, q: DVec2) -> DVec2 {
        let c = self.cells();
        DVec2::new(
            lerp(self.min.x, self.max.x, q.x / c[0] as f64),
            lerp(self.min.y, self.max.y, q.y / c[1] as f64),
        )
    }

    /// World `(u, v)` → plane index point.
    pub fn to_index(&self, uv: DVec2) -> DVec2 {
        let c = self.cells();
        (uv - self.min) / (self.max - self.min) * DVec2::new(c[0] as f64, c[1] as f64)
    }

    /// World `(u, v)` → world point on the plane.
    pub fn to_world(&self, uv: DVec2) -> DVec3 {
        let mut p = [0.0; 3];
        p[self.axes.0] = uv.x;
        p[self.axes.1] = uv.y;
        p[self.axis.index()] = self.at;
        DVec3::from_array(p)
    }

    /// Plane index point → world point.
    pub fn index_to_world(&self, q: DVec2) -> DVec3 {
        self.to_world(self.to_uv(q))
    }

    /// World `(u, v)` at the centre of pixel `(px, py)` of a `width x height` picture of the
    /// plane's box (row 0 at the top): `u = min.u + (px + 0.5) / W (max.u - min.u)`,
    /// `v = max.v - (py + 0.5) / H (max.v - min.v)`.
    pub fn pixel_uv(&self, px: u32, py: u32, width: u32, height: u32) -> DVec2 {
        let size = self.max - self.min;
        DVec2::new(
            self.min.x + (px as f64 + 0.5) / width as f64 * size.x,
            self.max.y - (py as f64 + 0.5) / height as f64 * size.y,
        )
    }

    /// The 3D grid index coordinates of the centre of pixel `(px, py)` (what the shader
    /// computes): `(px + 0.5) / W (nu - 1)` along u, `(H - py - 0.5) / H (nv - 1)` along v,
    /// [`PlaneGrid::w`] along the axis.
    pub fn pixel_grid_point(&self, px: u32, py: u32, width: u32, height: u32) -> DVec3 {
        let c = self.cells();
        let mut g = [0.0; 3];
        g[self.axes.0] = (px as f64 + 0.5) / width as f64 * c[0] as f64;
        g[self.axes.1] = (height as f64 - py as f64 - 0.5) / height as f64 * c[1] as f64;
        g[self.axis.index()] = self.w();
        DVec3::from_array(g)
    }

    /// Smallest and largest value on the plane (the bilinear interpolant's range), missing
    /// data left out.
    pub fn range(&self) -> (f64, f64) {
        self.values
            .iter()
            .filter(|&&v| !is_missing(v))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)))
    }

    /// Whether plane cell `(i, j)` is missing: a corner value is missing data. Its values mix
    /// the two grid layers around the plane (a missing sample in either makes theirs missing), so
    /// this is [`crate::field::interpolant::cell_missing`] of the grid cell the plane cuts.
    pub fn cell_missing(&self, i: usize, j: usize) -> bool {
        if let Some(m) = &self.missing {
            return m[i + self.cells()[0] * j];
        }
        self.cell_corners(i, j).iter().any(|&v| is_missing(v))
    }
}

/// The picture size for a plane: `width` and `height` when both are given; one of them and
/// the cross-section's aspect ratio; or `default_width` and the aspect ratio. Sides are
/// clamped to `1..=max_side`.
pub fn picture_size(
    plane: &PlaneGrid,
    width: Option<u32>,
    height: Option<u32>,
    default_width: u32,
    max_side: u32,
) -> (u32, u32) {
    let size = plane.max - plane.min;
    let aspect = size.y / size.x;
    let side = |x: f64| (x.round().clamp(1.0, max_side as f64)) as u32;
    match (width, height) {
        (Some(w), Some(h)) => (w, h),
        (Some(w), None) => (w, side(w as f64 * aspect)),
        (None, Some(h)) => (side(h as f64 / aspect), h),
        (None, None) => (default_width, side(default_width as f64 * aspect)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> Grid {
        // value = x + 10 y + 100 z at points of a [3, 4, 5] grid over [0,2]x[0,3]x[0,8].
        let dims = [3, 4, 5];
        let mut g =
            Grid { dims, min: DVec3::ZERO, max: DVec3::new(2.0, 3.0, 8.0), values: Vec::new() };
        for k in 0..5 {
            for j in 0..4 {
                for i in 0..3 {
                    let p = g.point(i, j, k);
                    g.values.push((p.x + 10.0 * p.y + 100.0 * p.z) as f32);
                }
            }
        }
        g
    }

    #[test]
    fn planes_of_a_linear_field_are_linear() {
        let g = grid();
        for (axis, at) in [(Axis::Z, 3.0), (Axis::Z, 8.0), (Axis::X, 0.5), (Axis::Y, 1.25)] {
            let p = PlaneGrid::new(&g, axis, at).unwrap();
            for q in [DVec2::new(0.3, 0.7), DVec2::new(1.0, 2.0), DVec2::new(1.9, 0.1)] {
                let q = q.min(DVec2::new(p.cells()[0] as f64, p.cells()[1] as f64));
                let w = p.index_to_world(q);
                let want = w.x + 10.0 * w.y + 100.0 * w.z;
                assert!((p.bilinear(q) - want).abs() < 1e-9, "{axis:?} {at} {q}");
            }
        }
        let p = PlaneGrid::new(&g, Axis::Z, 8.0).unwrap();
        assert_eq!((p.layer, p.weight), (3, 1.0));
        assert_eq!(p.axes, (0, 1));
        assert!(matches!(
            PlaneGrid::new(&g, Axis::Y, 3.5),
            Err(SliceError::OutsideBox { axis: "y", .. })
        ));
    }

    #[test]
    fn pixel_mapping_matches_the_grid_point_mapping() {
        let g = grid();
        let p = PlaneGrid::new(&g, Axis::X, 1.0).unwrap();
        assert_eq!(p.axes, (1, 2));
        let uv = p.pixel_uv(0, 0, 6, 16);
        assert_eq!(uv, DVec2::new(0.25, 7.75));
        let gp = p.pixel_grid_point(0, 0, 6, 16);
        assert!((gp - DVec3::new(1.0, 0.25, 3.875)).length() < 1e-12);
        assert_eq!(picture_size(&p, None, None, 30, 100), (30, 80));
        assert_eq!(picture_size(&p, None, Some(40), 30, 100), (15, 40));
        assert_eq!(picture_size(&p, Some(3), Some(4), 30, 100), (3, 4));
    }
}
