//! The f64 mirror of `shaders/slice.comp`'s `value`: the trilinear interpolant of the grid at
//! each pixel centre's grid index coordinates ([`PlaneGrid::pixel_grid_point`]); NaN (no data)
//! where that point's cell is missing ([`crate::field::interpolant::cell_missing`]), and the
//! picture shows [`NO_DATA`] there.

use super::plane::PlaneGrid;
use crate::field::interpolant::{cell_missing, Interpolant, Interpolated};
use crate::field::Grid;
use crate::reference::field::{cell_of, value_at};
use crate::reference::trilinear::cell_corners;

/// The colour of a pixel with no data (linear RGB; `NO_DATA` in `shaders/slice.comp`): a
/// mid grey, outside the diverging colormap's hues.
pub const NO_DATA: [f32; 3] = [0.2, 0.2, 0.2];

/// The field at every pixel centre of a `width x height` picture of `plane`, row 0 at the top.
///
/// Through another interpolant (`plane.interp`, the shader's variant), its value there
/// (`Interpolated`), NaN where it is missing.
pub fn values(grid: &Grid, plane: &PlaneGrid, width: u32, height: u32) -> Vec<f64> {
    let mut out = Vec::with_capacity(width as usize * height as usize);
    if plane.interp != Interpolant::Trilinear {
        let field = Interpolated::new(grid, plane.interp);
        for py in 0..height {
            for px in 0..width {
                let u = plane.pixel_grid_point(px, py, width, height);
                out.push(if field.missing_at(u) { f64::NAN } else { field.value_at(u) });
            }
        }
        return out;
    }
    for py in 0..height {
        for px in 0..width {
            let u = plane.pixel_grid_point(px, py, width, height);
            let missing = cell_missing(&cell_corners(grid, cell_of(grid, u)));
            out.push(if missing { f64::NAN } else { value_at(grid, u) });
        }
    }
    out
}
