//! The f64 mirror of `shaders/slice.comp`'s `value`: the trilinear interpolant of the grid at
//! each pixel centre's grid index coordinates ([`PlaneGrid::pixel_grid_point`]).

use super::plane::PlaneGrid;
use crate::field::Grid;
use crate::reference::field::value_at;

/// The field at every pixel centre of a `width x height` picture of `plane`, row 0 at the top.
pub fn values(grid: &Grid, plane: &PlaneGrid, width: u32, height: u32) -> Vec<f64> {
    let mut out = Vec::with_capacity(width as usize * height as usize);
    for py in 0..height {
        for px in 0..width {
            out.push(value_at(grid, plane.pixel_grid_point(px, py, width, height)));
        }
    }
    out
}
