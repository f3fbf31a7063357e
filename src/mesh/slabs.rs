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
//! MC33's added vertices come after all edge vertices; a slab positions its `c`-th added
//! vertex itself (the field is at hand there) and refers to it as `u32::MAX - c` (as the
//! reference does); the join replaces the placeholder by the total edge vertex count plus the
//! added vertices of the slabs below plus `c`.
//!
//! The join is incremental ([`Join`]): slabs are pushed in order, and the joined slabs so far
//! are themselves a part of the same form (local ids from 0, the next slab's vertices past its
//! own, added vertices as placeholders), so consecutive slabs can be joined where they were
//! extracted and the results joined again: a rank joins its slabs, rank 0 joins the ranks'
//! (`window`, `cluster`).
//!
//! The reference itself is the one-slab case of the same functions.

use std::ops::Range;

use rayon::prelude::*;

use super::edges::Vertices;
use super::{to_u32, Mesh, MeshBudget, MeshError};

/// What one slab extracted, numbered locally (its first own vertex is 0).
#[derive(Default)]
pub(crate) struct Part {
    /// The slab's own vertices, in the reference's order (followed, until the join, by the
    /// positions of the dual methods' borrowed vertices, see [`Vertices::push_borrowed`]).
    pub verts: Vertices,
    /// Triangles, three local vertex ids each; ids at or past `verts.normals.len()` are
    /// vertices of the next slab; ids above `u32::MAX - added.normals.len()` are added
    /// vertices (MC33).
    pub indices: Vec<u32>,
    /// Quads of the dual methods, four local vertex ids each.
    pub quads: Vec<u32>,
    /// MC33's added vertices, positioned, in the order of their placeholders.
    pub added: Vertices,
}

/// Default slab depth for `layers` cell layers: about 8 slabs per worker thread, so that
/// slabs with much surface do not leave a thread idle, and at least 4 layers per slab (each
/// slab numbers one layer beyond its own).
pub(crate) fn default_depth(layers: usize) -> usize {
    let threads = rayon::current_num_threads().max(1);
    layers.div_ceil(8 * threads).max(4)
}

/// Extracts the cell layers `cells` in slabs of `depth` layers (the last one shorter) on the
/// current rayon pool with `slab`, and joins the parts into one part (numbered from the
/// first vertex of `cells`). No layers: an empty part. Every slab's part is added to `budget`
/// as it is done, so an extraction over the cap stops there (a failed slab makes rayon start
/// no more) rather than after the whole mesh is held.
pub(crate) fn run_part(
    cells: Range<usize>,
    depth: usize,
    budget: &MeshBudget,
    slab: impl Fn(Range<usize>) -> Result<Part, MeshError> + Sync,
) -> Result<Part, MeshError> {
    let depth = depth.max(1);
    let ranges: Vec<Range<usize>> =
        cells.clone().step_by(depth).map(|a| a..(a + depth).min(cells.end)).collect();
    let counted = |cells: Range<usize>| -> Result<Part, MeshError> {
        let p = slab(cells)?;
        budget.add(p.own_vertices(), p.indices.len() / 3, p.quads.len())?;
        Ok(p)
    };
    let parts = match ranges.len() {
        0 => return Ok(Part::default()),
        1 => vec![counted(ranges[0].clone())?],
        _ => ranges.into_par_iter().map(counted).collect::<Result<Vec<_>, _>>()?,
    };
    join_all(parts)
}

impl Part {
    /// The vertices the part owns: edge or cell vertices and added ones (not the borrowed).
    pub fn own_vertices(&self) -> usize {
        self.verts.normals.len() + self.added.normals.len()
    }
}

/// The parts of consecutive slabs joined at once: what pushing them in order into a [`Join`]
/// gives, but with every vector allocated once at its final length and the parts copied into
/// their places (and renumbered on the way) in parallel. Pushed one by one, the joined vectors
/// grow by doubling, each growth a copy and fresh pages, and the copies run on one thread.
fn join_all(mut parts: Vec<Part>) -> Result<Part, MeshError> {
    for p in &mut parts {
        p.verts.drop_borrowed();
    }
    if parts.len() == 1 {
        return Ok(parts.pop().expect("one part")); // its own ids: nothing to renumber
    }
    let total = |f: fn(&Part) -> usize| parts.iter().map(f).sum::<usize>();
    let (nv, na) = (total(|p| p.verts.normals.len()), total(|p| p.added.normals.len()));
    to_u32(total(|p| p.indices.len()), "indices")?;
    to_u32(nv + na, "vertices")?;
    // Zeroed allocations this large are fresh pages, touched first by the copies below.
    let mut out = Part::default();
    out.verts.positions = vec![[0.0; 3]; nv];
    out.verts.normals = vec![[0.0; 3]; nv];
    out.indices = vec![0; total(|p| p.indices.len())];
    out.quads = vec![0; total(|p| p.quads.len())];
    let positions = split(&mut out.verts.positions, parts.iter().map(|p| p.verts.normals.len()));
    let normals = split(&mut out.verts.normals, parts.iter().map(|p| p.verts.normals.len()));
    let indices = split(&mut out.indices, parts.iter().map(|p| p.indices.len()));
    let quads = split(&mut out.quads, parts.iter().map(|p| p.quads.len()));
    for p in &parts {
        out.added.positions.extend_from_slice(&p.added.positions);
        out.added.normals.extend_from_slice(&p.added.normals);
    }
    let (mut edge_off, mut added_off) = (0usize, 0usize);
    let mut jobs = Vec::with_capacity(parts.len());
    for (p, (((pos, nor), idx), qua)) in
        parts.into_iter().zip(positions.into_iter().zip(normals).zip(indices).zip(quads))
    {
        let offsets = (edge_off as u32, added_off as u32);
        edge_off += p.verts.normals.len();
        added_off += p.added.normals.len();
        jobs.push((p, pos, nor, idx, qua, offsets));
    }
    // Each job owns its part and frees it once copied: the joined mesh's pages are touched as
    // the parts' are returned, so the join holds the mesh about once, not twice.
    jobs.into_par_iter().for_each(|(p, pos, nor, idx, qua, (edge_off, added_off))| {
        pos.copy_from_slice(&p.verts.positions);
        nor.copy_from_slice(&p.verts.normals);
        let renumber = Renumber::new(&p, edge_off, added_off);
        for (o, &x) in idx.iter_mut().zip(&p.indices) {
            *o = renumber.id(x);
        }
        for (o, &x) in qua.iter_mut().zip(&p.quads) {
            *o = renumber.id(x);
        }
        drop(p);
    });
    Ok(out)
}

/// How a part's vertex ids become ids of the joined part that holds `edge_off` edge vertices
/// and `added_off` added vertices of the parts before it: edge ids move up by `edge_off`; added
/// vertices' placeholders (counting down from 2^32 - 1) move down by `added_off`. The one rule
/// of [`Join::push`] and [`join_all`].
struct Renumber {
    first_added: u32,
    has_added: bool,
    edge_off: u32,
    added_off: u32,
}

impl Renumber {
    fn new(p: &Part, edge_off: u32, added_off: u32) -> Self {
        Renumber {
            first_added: u32::MAX - p.added.normals.len() as u32,
            has_added: !p.added.normals.is_empty(),
            edge_off,
            added_off,
        }
    }

    /// An id of the next slab may pass 2^32 - 1 when the whole mesh would; `finish` rejects
    /// that mesh, so wrapping here changes no result.
    fn id(&self, x: u32) -> u32 {
        if self.has_added && x > self.first_added {
            x - self.added_off
        } else {
            x.wrapping_add(self.edge_off)
        }
    }
}

/// `v` cut into consecutive pieces of `lens` (which sum to its length).
fn split<T>(mut v: &mut [T], lens: impl Iterator<Item = usize>) -> Vec<&mut [T]> {
    let mut pieces = Vec::new();
    for n in lens {
        let (piece, rest) = std::mem::take(&mut v).split_at_mut(n);
        pieces.push(piece);
        v = rest;
    }
    pieces
}

/// Extracts the cell layers `cells` in slabs of `depth` layers, `batch` slabs at a time on the
/// current rayon pool, and hands each slab's part to `sink` in slab order with its ids made
/// the whole mesh's: what [`join_all`] does to each part, without the joined copy. Memory
/// holds one batch of parts, not the mesh. Added vertices (MC33) would stay placeholders,
/// which only the whole mesh's edge vertex count resolves ([`finish`]): the caller streams
/// no method that makes them (`mesh::not_streamed`).
pub(crate) fn stream_parts<E: From<MeshError>>(
    cells: Range<usize>,
    depth: usize,
    batch: usize,
    slab: &(dyn Fn(Range<usize>) -> Result<Part, MeshError> + Sync),
    mut sink: impl FnMut(Part) -> Result<(), E>,
) -> Result<(), E> {
    let depth = depth.max(1);
    let ranges: Vec<Range<usize>> =
        cells.clone().step_by(depth).map(|a| a..(a + depth).min(cells.end)).collect();
    let (mut edge_off, mut added_off, mut indices) = (0usize, 0usize, 0usize);
    for group in ranges.chunks(batch.max(1)) {
        let parts = group.par_iter().cloned().map(slab).collect::<Result<Vec<_>, _>>()?;
        for mut p in parts {
            p.verts.drop_borrowed();
            let (nv, na) = (p.verts.normals.len(), p.added.normals.len());
            indices += p.indices.len();
            to_u32(indices, "indices")?;
            to_u32(edge_off + nv + added_off + na, "vertices")?;
            let renumber = Renumber::new(&p, edge_off as u32, added_off as u32);
            p.indices.iter_mut().chain(&mut p.quads).for_each(|x| *x = renumber.id(*x));
            edge_off += nv;
            added_off += na;
            sink(p)?;
        }
    }
    Ok(())
}

/// [`run_part`] over all `layers` cell layers, finished into the mesh; `keep_quads` returns
/// the quads too.
pub(crate) fn run(
    layers: usize,
    depth: usize,
    keep_quads: bool,
    slab: impl Fn(Range<usize>) -> Result<Part, MeshError> + Sync,
) -> Result<Mesh, MeshError> {
    let part = run_part(0..layers, depth, &MeshBudget::unlimited(), slab)?;
    finish(part, keep_quads)
}

/// Joins parts pushed in slab order; the joined part numbers its vertices from 0. Every part
/// pushed is added to `budget` first (unlimited by default; shared with the other surfaces of
/// a scene, whose meshes are held with this one).
#[derive(Default)]
pub(crate) struct Join {
    pub part: Part,
    pub budget: std::sync::Arc<MeshBudget>,
}

impl Join {
    /// Appends the next slab's part: its local ids move past the vertices joined so far (the
    /// ids of its next slab's vertices with them), its placeholders past the added vertices
    /// joined so far.
    pub fn push(&mut self, mut p: Part) -> Result<(), MeshError> {
        self.budget.add(p.own_vertices(), p.indices.len() / 3, p.quads.len())?;
        p.verts.drop_borrowed();
        let all = &mut self.part;
        let edge_off = all.verts.normals.len();
        let added_off = all.added.normals.len();
        let vertices = edge_off + p.verts.normals.len() + added_off + p.added.normals.len();
        to_u32(vertices, "vertices")?;
        to_u32(all.indices.len() + p.indices.len(), "indices")?;
        let renumber = Renumber::new(&p, edge_off as u32, added_off as u32);
        let renumber = |x: &mut u32| *x = renumber.id(*x);
        p.indices.par_iter_mut().with_min_len(1 << 16).for_each(renumber);
        p.quads.par_iter_mut().with_min_len(1 << 16).for_each(renumber);
        if edge_off == 0 && added_off == 0 && all.indices.is_empty() && all.quads.is_empty() {
            *all = p;
            return Ok(());
        }
        all.verts.positions.extend_from_slice(&p.verts.positions);
        all.verts.normals.extend_from_slice(&p.verts.normals);
        all.indices.extend_from_slice(&p.indices);
        all.quads.extend_from_slice(&p.quads);
        all.added.positions.extend_from_slice(&p.added.positions);
        all.added.normals.extend_from_slice(&p.added.normals);
        Ok(())
    }
}

/// The mesh of a part that holds every slab (every id its own): the added vertices after
/// every edge vertex, placeholders replaced by their ids; `keep_quads` keeps the quads.
pub(crate) fn finish(part: Part, keep_quads: bool) -> Result<Mesh, MeshError> {
    let Part { mut verts, mut indices, mut quads, added } = part;
    verts.drop_borrowed();
    let edge_total = verts.normals.len();
    to_u32(edge_total + added.normals.len(), "vertices")?;
    if !added.normals.is_empty() {
        let first_added = u32::MAX - added.normals.len() as u32;
        let edge_total = edge_total as u32;
        let place = |x: &mut u32| {
            if *x > first_added {
                *x = edge_total + (u32::MAX - *x);
            }
        };
        indices.par_iter_mut().with_min_len(1 << 16).for_each(place);
        quads.par_iter_mut().with_min_len(1 << 16).for_each(place);
    }
    let mut mesh = Mesh {
        positions: verts.positions,
        normals: verts.normals,
        indices,
        quads: keep_quads.then_some(quads),
    };
    mesh.positions.extend_from_slice(&added.positions);
    mesh.normals.extend_from_slice(&added.normals);
    Ok(mesh)
}
