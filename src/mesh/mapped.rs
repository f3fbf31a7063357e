//! Extraction from a grid read from its file in parts (`field.residency`): the cell layers in
//! z-ranges, each read from the file into a window of the point layers it needs
//! ([`super::window`]), extracted, joined, and the window dropped before the next is read, so
//! memory holds one window and the mesh, never the grid.
//!
//! A window whose every point is outside the surface holds no vertex and no face (no edge
//! changes sign, and the closing faces of `dual-contouring` only close inside regions), so its
//! range joins as an empty mesh without being extracted: on a sparse file, reading it is all
//! the work. The joined mesh is the whole grid's bit for bit (`tests/it/field/residency.rs`).

use std::sync::Arc;

use super::window::{self, Joiner, Lattice, SlabMesh};
use super::{Mesh, MeshBudget, MeshError, Request};
use crate::field::parts::Parts;
use crate::field::NanPolicy;

/// Bytes of samples one window holds at most (at least its range's point layers).
pub const WINDOW_BYTES: usize = 256 << 20;

/// The mesh of `x` over the whole mapped grid, read `window_bytes` at a time (at most; at least
/// the layers one cell layer needs).
pub fn extract_mapped(
    grid: &dyn Parts,
    x: &Request,
    window_bytes: usize,
) -> Result<Mesh, MeshError> {
    extract_mapped_within(grid, x, window_bytes, &Arc::new(MeshBudget::unlimited()))
}

/// [`extract_mapped`], adding every window's mesh to `budget` as it is joined: past its cap,
/// [`MeshError::OverCap`] (checked per window: a window's own slabs are held until then).
pub fn extract_mapped_within(
    grid: &dyn Parts,
    x: &Request,
    window_bytes: usize,
    budget: &Arc<MeshBudget>,
) -> Result<Mesh, MeshError> {
    if !x.on_grid() {
        // Before any window is read: an all-outside window would skip the check in
        // `window::extract_window` and mesh trilinear cells silently.
        return Err(MeshError::Refused(format!(
            // Said of the stream, not of a key: a grid over the cap under the default "auto"
            // (or a .vdb tree) streams as well as one the user set to "active".
            "extract reads a grid in parts (field.residency = \"active\", or a grid over the \
             memory cap) as trilinear cells at render.mesh_refine = 1, not field.interpolation \
             = \"{}\" at render.mesh_refine = {} (a lattice held whole); a grid under the \
             memory cap (ISOVIEW_MAX_GRID_MIB) is read whole with field.residency = \"auto\" \
             (the default) or \"whole\"",
            x.interp.name(),
            x.refine
        )));
    }
    let dims = grid.dims();
    let (min, max) = grid.bounds();
    let lattice = Lattice { dims, min, max };
    let [nx, ny, _] = dims;
    // A window holds at least one cell layer and its ghost layers (and the marching's edge
    // layers as large): a grid whose xy layers alone are over the window is refused, not
    // allocated.
    let least = (nx as u64 * ny as u64 * 4).saturating_mul(1 + window::GHOST_LAYERS as u64);
    if least > window_bytes as u64 {
        return Err(MeshError::Refused(format!(
            "{}: an xy layer of {nx}x{ny} points takes {} MiB, and extract's window of {} MiB \
             must hold {} of them; a grid this wide is not extracted in parts",
            grid.label(),
            (nx as u64 * ny as u64 * 4) >> 20,
            window_bytes >> 20,
            1 + window::GHOST_LAYERS
        )));
    }
    let layers = window::cell_layers(x.algo, dims);
    // Cell layers per range: the window holds them plus up to window::GHOST_LAYERS more.
    let plane = nx * ny * 4;
    let depth = (window_bytes / plane).saturating_sub(window::GHOST_LAYERS).max(1);
    let mut joiner = Joiner::with_budget(budget.clone());
    let mut start = 0;
    while start < layers {
        let cells = start..(start + depth).min(layers);
        let points = window::point_layers(x.algo, dims, cells.clone());
        let n = [nx, ny, points.len()];
        // `field.nan = "error"` refuses a non-finite sample as the whole grid's read would.
        let values = match grid.nan() {
            NanPolicy::Error => grid.read_finite([0, 0, points.start], n)?,
            NanPolicy::Empty => grid.read_box([0, 0, points.start], n)?,
        };
        let outside = values.iter().all(|&v| !x.inside.contains(v as f64, x.iso));
        let part = if outside {
            SlabMesh::default()
        } else {
            let held = crate::field::Grid { dims: n, min, max, values };
            window::extract_window(&held, points.start, &lattice, x, cells.clone())?
        };
        joiner.push(part)?;
        start = cells.end;
    }
    joiner.finish(x.keeps_quads())
}
