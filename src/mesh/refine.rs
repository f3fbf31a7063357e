//! Meshes of every interpolant, and of cells split finer (`render.mesh_refine = k`).
//!
//! The extractors read a lattice of samples, decide topology from its points' inside flags and
//! place each vertex on a crossed lattice edge. For trilinear cells at `k = 1` that lattice is
//! the grid, and the crossing on an edge (linear along it) is the line through its end values.
//! For any other interpolant, or `k > 1`, the lattice is the grid's cells split `k` ways per
//! axis:
//!
//! ```text
//!   grid points  o-----------o-----------o        k = 3: lattice point P sits at the grid's
//!   lattice      o---+---+---o---+---+---o        index-space coordinates u = P / k
//! ```
//!
//! * a lattice point's sample is the chosen interpolant's value there (`Interpolated`, f64,
//!   rounded to f32; NaN where the interpolant's stencil holds missing data), and the inside
//!   rule reads these samples, so topology is the methods' own on the finer lattice;
//! * the crossing on a crossed lattice edge is the interpolant's own: where the inside rule
//!   first changes along the edge's segment, refined to f64 precision
//!   (`Interpolated::first_crossing`); where rounding the ends to f32 made the edge crossed
//!   though the f64 values are on one side, the line through the samples;
//! * a vertex's normal is the interpolant's exact gradient at the vertex.
//!
//! Only the methods whose vertices are lattice-edge crossings read this
//! (`Method::lattice_edges`); the lattice is held whole, under the grid cap
//! (`ISOVIEW_MAX_GRID_MIB`), and is not cut into z-ranges (MPI ranks, mapped files).
//! `nearest` is not refined: its surface is the voxels' faces (`mesh::voxel_faces`).

use glam::DVec3;
use rayon::prelude::*;

use super::MeshError;
use crate::field::interpolant::{Interpolant, Interpolated};
use crate::field::{Grid, GridLimits};
use crate::vocab::Inside;

/// The most `render.mesh_refine` (sub-cells per cell along each axis).
pub const MAX_REFINE: usize = 16;

/// The interpolant a refined lattice samples, for its crossings and normals.
pub(crate) struct Exact<'g> {
    field: Interpolated<'g>,
    /// Sub-cells per cell along each axis.
    k: f64,
}

impl Exact<'_> {
    /// The crossing parameter on the lattice edge from point `start` to `start + d` (lattice
    /// indices), or None where the interpolant's inside rule does not change along it.
    pub fn crossing(
        &self,
        start: [usize; 3],
        d: [usize; 3],
        iso: f64,
        inside: Inside,
    ) -> Option<f64> {
        let a = DVec3::new(start[0] as f64, start[1] as f64, start[2] as f64);
        let d = DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64);
        self.field.first_crossing(a / self.k, (a + d) / self.k, iso, inside)
    }

    /// The interpolant's gradient (value per world unit) at lattice coordinates `u`.
    pub fn gradient(&self, u: DVec3) -> DVec3 {
        self.field.gradient_at(u / self.k)
    }
}

/// The lattice and interpolant of a mesh that is not trilinear cells at `k = 1`.
pub(crate) struct Refined<'g> {
    pub lattice: Grid,
    pub exact: Exact<'g>,
}

/// Whether `interp` at `k` meshes the grid itself (trilinear cells, `k = 1`).
pub fn on_grid(interp: Interpolant, k: usize) -> bool {
    interp == Interpolant::Trilinear && k == 1
}

/// The lattice of `grid`'s cells split `k` ways, sampled with `interp` (see the module
/// documentation), under `limits`: [`MeshError::Field`] naming `render.mesh_refine` over it.
pub(crate) fn refine(
    grid: &Grid,
    interp: Interpolant,
    k: usize,
    limits: GridLimits,
) -> Result<Refined<'_>, MeshError> {
    let dims = grid.dims.map(|n| (n - 1) * k + 1);
    let what = format!(
        "the {}x{}x{} lattice of render.mesh_refine = {k} (field.interpolation = \"{}\")",
        dims[0],
        dims[1],
        dims[2],
        interp.name()
    );
    limits.check(dims.map(|n| n as u64), &what)?;
    let field = Interpolated::new(grid, interp);
    let kf = k as f64;
    let layer = dims[0] * dims[1];
    let mut values = vec![0f32; layer * dims[2]];
    values.par_chunks_mut(layer).enumerate().for_each(|(z, out)| {
        let mut read = field.reader();
        for (p, v) in out.iter_mut().enumerate() {
            let u = DVec3::new((p % dims[0]) as f64, (p / dims[0]) as f64, z as f64) / kf;
            *v = read(u).map_or(f32::NAN, |v| v as f32);
        }
    });
    let lattice = Grid { dims, min: grid.min, max: grid.max, values };
    Ok(Refined { lattice, exact: Exact { field, k: kf } })
}
