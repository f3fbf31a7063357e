//! Multi-threaded extraction: the grid cut into slabs of cell layers along z, each slab
//! extracted by the reference's own per-cell code on a `rayon` worker, the slabs joined in
//! order. The result is the reference's mesh, bit for bit: same arithmetic, same vertex
//! numbering, same triangle order.
//!
//! ```text
//!   z ↑   cell layers        slab      vertices it owns          ids it also needs
//!     │  ┌───────────┐
//!     │  │  5  4  3  │ ───── s = 1   edges/cells of layers 3..6  (none past the grid)
//!     │  ├───────────┤                                            ┌ layer 3, numbered after
//!     │  │  2  1  0  │ ───── s = 0   edges/cells of layers 0..3 ──┘ its own vertices
//!     │  └───────────┘
//! ```
//!
//! Vertices are numbered in increasing owner id (lattice edge or cell), so the vertices of a
//! slab are one contiguous run of the reference's numbering, starting at the number of
//! vertices owned by the slabs below it (an exclusive prefix sum of the slab counts, as the
//! GPU passes do per slab). A slab's last cells need the ids of the layer just above it,
//! which the next slab owns; the slab numbers that layer itself, continuing after its own
//! vertices, which is exactly where the next slab's numbering starts. So every index a slab
//! writes is its *local* id plus the slab's offset, whichever slab owns the vertex. Triangles
//! (and quads) are written in cell (or edge) order within a slab, and slabs are joined in
//! order, which is the reference's order.
//!
//! MC33's added vertices come after all edge vertices; a slab refers to its `c`-th added
//! vertex as `u32::MAX - c` (as the reference does), and the join replaces the placeholder by
//! the total edge vertex count plus the added vertices of the slabs below plus `c`.
//!
//! The reference itself is the one-slab case of the same functions.

use std::ops::Range;

use glam::DVec3;
use rayon::prelude::*;

use super::edges::Vertices;
use super::field::Field;
use super::{to_u32, Mesh, MeshError};

/// What one slab extracted, numbered locally (its first own vertex is 0).
#[derive(Default)]
pub(crate) struct Part {
    /// The slab's own vertices, in the reference's order.
    pub verts: Vertices,
    /// Triangles, three local vertex ids each; ids at or past `verts.positions.len()` are
    /// vertices of the next slab; ids above `u32::MAX - centres.len()` are added vertices
    /// (MC33).
    pub indices: Vec<u32>,
    /// Quads of the dual methods, four local vertex ids each.
    pub quads: Vec<u32>,
    /// MC33's added vertices: index-space position and fallback normal direction.
    pub centres: Vec<(DVec3, DVec3)>,
}

/// Default slab depth for `layers` cell layers: about 8 slabs per worker thread, so that
/// slabs with much surface do not leave a thread idle, and at least 4 layers per slab (each
/// slab numbers one layer beyond its own).
pub(crate) fn default_depth(layers: usize) -> usize {
    let threads = rayon::current_num_threads().max(1);
    layers.div_ceil(8 * threads).max(4)
}

/// Extracts the `layers` cell layers in slabs of `depth` layers (the last one shorter) on the
/// current rayon pool with `slab`, and joins the parts. `keep_quads` returns the quads too.
pub(crate) fn run(
    f: &Field,
    layers: usize,
    depth: usize,
    keep_quads: bool,
    slab: impl Fn(Range<usize>) -> Result<Part, MeshError> + Sync,
) -> Result<Mesh, MeshError> {
    let depth = depth.max(1);
    let ranges: Vec<Range<usize>> =
        (0..layers).step_by(depth).map(|a| a..(a + depth).min(layers)).collect();
    let parts = if ranges.len() == 1 {
        vec![slab(ranges[0].clone())?]
    } else {
        ranges.into_par_iter().map(&slab).collect::<Result<Vec<_>, _>>()?
    };
    join(f, parts, keep_quads)
}

/// Joins the slabs' parts (in slab order) into one mesh in the reference's numbering.
pub(crate) fn join(f: &Field, mut parts: Vec<Part>, keep_quads: bool) -> Result<Mesh, MeshError> {
    // Offsets: exclusive prefix sums of the edge (or cell) vertices and the added vertices.
    let mut offsets = Vec::with_capacity(parts.len());
    let (mut edge_total, mut centre_total) = (0usize, 0usize);
    for p in &parts {
        offsets.push((edge_total, centre_total));
        edge_total += p.verts.normals.len();
        centre_total += p.centres.len();
    }
    to_u32(edge_total + centre_total, "vertices")?;
    to_u32(parts.iter().map(|p| p.indices.len()).sum(), "indices")?;

    // Renumber: local id + the slab's offset; added vertex c of the slab after every edge
    // vertex and every added vertex of the slabs below.
    let renumber = |p: &mut Part, (edge_off, centre_off): (usize, usize)| {
        let first = u32::MAX - p.centres.len() as u32;
        let has_centres = !p.centres.is_empty();
        for x in p.indices.iter_mut().chain(p.quads.iter_mut()) {
            *x = if has_centres && *x > first {
                (edge_total + centre_off) as u32 + (u32::MAX - *x)
            } else {
                *x + edge_off as u32
            };
        }
    };
    if parts.len() == 1 {
        renumber(&mut parts[0], offsets[0]);
    } else {
        parts.par_iter_mut().zip(offsets).for_each(|(p, o)| renumber(p, o));
    }

    let mut parts = parts.into_iter();
    let mut first = parts.next().unwrap_or_default();
    first.verts.drop_borrowed();
    let mut mesh = Mesh {
        positions: first.verts.positions,
        normals: first.verts.normals,
        indices: first.indices,
        quads: Some(first.quads),
    };
    let mut centres = first.centres;
    for mut p in parts {
        p.verts.drop_borrowed();
        mesh.positions.extend_from_slice(&p.verts.positions);
        mesh.normals.extend_from_slice(&p.verts.normals);
        mesh.indices.extend_from_slice(&p.indices);
        if let Some(q) = &mut mesh.quads {
            q.extend_from_slice(&p.quads);
        }
        centres.extend_from_slice(&p.centres);
    }
    if !centres.is_empty() {
        let added: Vec<([f32; 3], [f32; 3])> =
            centres.par_iter().map(|&(u, dir)| (f.world(u), f.normal(u, dir))).collect();
        mesh.positions.extend(added.iter().map(|a| a.0));
        mesh.normals.extend(added.iter().map(|a| a.1));
    }
    if !keep_quads {
        mesh.quads = None;
    }
    Ok(mesh)
}
