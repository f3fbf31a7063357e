//! Extraction of a z-range of a grid from a *window* that holds only the point layers that
//! range needs, and the join of such ranges into the whole grid's mesh: the entry point for
//! meshing a grid that no one process holds (MPI ranks in `cluster`, z-slabs streamed from a
//! file too large for memory).
//!
//! ```text
//!   whole grid: dims, min, max (a Lattice)         window: a Grid of the point layers
//!   cell layers 0 .. cell_layers(algo, dims)        point_layers(algo, dims, cells), i.e.
//!   ┌─────────────┐                                 the range's own points, one ghost layer
//!   │   cells b.. │                                 below (normals average the cells around a
//!   ├─────────────┤ ─┐                              vertex) and one or two above (the layer
//!   │ cells a..b  │  ├─ extract_window(window, ..)  the next range owns is numbered here too),
//!   ├─────────────┤ ─┘     -> SlabMesh              clamped to the grid
//!   │ cells ..a   │
//!   └─────────────┘   SlabMeshes of consecutive ranges, pushed in order -> Joiner -> Mesh
//! ```
//!
//! Why the joined mesh is [`super::reference`]'s bit for bit (see `slabs` for the details):
//! vertices are numbered in increasing owner id (lattice edge or cell), so a range's vertices
//! are one contiguous run of the whole mesh's numbering, which starts after the vertices of
//! the ranges below it. A range numbers its own vertices from 0 and the next range's first
//! layer after its own, where that range's numbering starts; the join adds the exclusive
//! prefix sum of the ranges' vertex counts. MC33's added vertices come after every edge
//! vertex; a range positions them itself and names them by placeholders that the join
//! replaces. Triangles are emitted in cell (or edge) order within a range, and ranges are
//! joined in order. The window's [`Field`] keeps the whole grid's indices, origin and
//! spacing, so every position and normal is computed from the same numbers as in one piece.
//!
//! Every method that the multi-threaded extraction cuts into slabs works here; `extended-mc`
//! and `dual-contouring-qef` with `mesh_error` (whose cells look at neighbours of any
//! distance, see `emc` and `octree`) are refused ([`MeshError::NotInSlabs`]). A
//! [`SlabMesh`] travels between processes as 32-bit words ([`SlabMesh::to_words`]).

use std::ops::Range;

use glam::DVec3;

use super::field::Field;
use super::slabs::{self, Join, Part};
use super::MeshAlgorithm;
use super::{Mesh, MeshBudget, MeshError, Request};
use crate::field::interpolant::STENCIL;
use crate::field::Grid;
use crate::vocab::SharpSettings;

/// The whole grid a window belongs to: its points per axis and its box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lattice {
    pub dims: [usize; 3],
    /// World-space position of point (0, 0, 0).
    pub min: DVec3,
    /// World-space position of point (nx-1, ny-1, nz-1).
    pub max: DVec3,
}

impl Lattice {
    pub fn of(grid: &Grid) -> Self {
        Lattice { dims: grid.dims, min: grid.min, max: grid.max }
    }

    /// World-space size of one cell: [`Grid::spacing`]'s arithmetic, so the same bits.
    pub fn spacing(&self) -> DVec3 {
        let c = self.dims.map(|n| n.saturating_sub(1) as f64);
        (self.max - self.min) / DVec3::new(c[0], c[1], c[2])
    }
}

/// Why `algo` with `sharp` cannot be extracted in z-ranges; None when it can.
pub fn not_in_slabs(algo: MeshAlgorithm, sharp: &SharpSettings) -> Option<&'static str> {
    (algo.method().not_in_slabs)(sharp)
}

/// The padding of the dual methods' cell lattice along z (`dual`).
fn padding(algo: MeshAlgorithm) -> usize {
    algo.method().padding
}

/// The cell layers along z that `algo` numbers on a grid of `dims` points, which ranges of
/// [`extract_window`] split: the grid's `nz - 1`, or the `nz + 1` of the dual methods' padded
/// lattice (`dual-contouring` puts cells around the box).
pub fn cell_layers(algo: MeshAlgorithm, dims: [usize; 3]) -> usize {
    (dims[2] + 2 * padding(algo)).saturating_sub(1)
}

/// The point layers (whole-grid z indices) that a window must hold to extract cell layers
/// `cells` (as [`cell_layers`] counts them) of a grid of `dims` points.
pub fn point_layers(algo: MeshAlgorithm, dims: [usize; 3], cells: Range<usize>) -> Range<usize> {
    if cells.is_empty() {
        return 0..0;
    }
    // Cell layers a..b own the points a..=b (less the padding for the dual methods); one
    // ghost layer below, for the normals of the vertices on the lowest layer, which average
    // the cells on both sides. Above: layer b + 1, the first of the next range, whose
    // vertices this range numbers (marching cubes' family) or whose cells' positions its
    // quad split reads (the dual methods); the normals on the plane between, which average
    // the cells on both sides, up to layer b + 1 too (the QEF of `dual-contouring-qef` reads
    // them at the crossings of the next range's first cells, one padded layer further up).
    // (Each of those cells reads its stencil: trilinear, its own two point layers.)
    let lo = cells.start.saturating_sub(padding(algo) + STENCIL.below + 1);
    let hi = cells.end + STENCIL.above + 1;
    lo..hi.min(dims[2])
}

/// The most point layers [`point_layers`] holds beyond its cell layers: the padding (1 at most),
/// the ghost layer below and the one above, and the stencil's reach (trilinear: 4 in all).
pub const GHOST_LAYERS: usize = 1 + STENCIL.below + STENCIL.above + 2;

/// The `k`-th of `n` consecutive, nearly equal shares of `layers` cell layers (the first
/// `layers % n` one layer deeper; empty when `n > layers` and `k >= layers`).
pub fn share(layers: usize, n: usize, k: usize) -> Range<usize> {
    let (q, r) = (layers / n.max(1), layers % n.max(1));
    let start = k * q + k.min(r);
    start..start + q + usize::from(k < r)
}

/// The mesh of a z-range, numbered locally: the input of [`Joiner::push`].
#[derive(Default)]
pub struct SlabMesh(Part);

impl SlabMesh {
    /// Vertices the range owns (edge or cell vertices and added ones).
    pub fn vertex_count(&self) -> usize {
        self.0.verts.normals.len() + self.0.added.normals.len()
    }

    /// Triangles of the range.
    pub fn triangle_count(&self) -> usize {
        self.0.indices.len() / 3
    }

    /// As 32-bit words: the counts of vertices, indices, quad indices and added vertices,
    /// then positions, normals (f32 bits), indices, quads, added positions and normals.
    pub fn to_words(&self) -> Vec<u32> {
        let p = &self.0;
        let nv = p.verts.normals.len();
        let head = [nv, p.indices.len(), p.quads.len(), p.added.normals.len()];
        let floats = |v: &[[f32; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        let mut w = Vec::with_capacity(4 + 6 * (nv + head[3]) + head[1] + head[2]);
        w.extend(head.iter().map(|&n| n as u32));
        w.extend(floats(&p.verts.positions[..nv]));
        w.extend(floats(&p.verts.normals));
        w.extend_from_slice(&p.indices);
        w.extend_from_slice(&p.quads);
        w.extend(floats(&p.added.positions));
        w.extend(floats(&p.added.normals));
        w
    }

    /// Reads [`SlabMesh::to_words`]' words back; None when their counts do not add up.
    pub fn from_words(w: &[u32]) -> Option<SlabMesh> {
        let [nv, ni, nq, na] = match w.get(..4)? {
            &[a, b, c, d] => [a, b, c, d].map(|n| n as usize),
            _ => return None,
        };
        if w.len() != 4 + 6 * nv + ni + nq + 6 * na {
            return None;
        }
        let mut rest = &w[4..];
        let mut take = |n: usize| {
            let (a, b) = rest.split_at(n);
            rest = b;
            a
        };
        let vec3 = |s: &[u32]| -> Vec<[f32; 3]> {
            s.chunks_exact(3).map(|c| [0, 1, 2].map(|i| f32::from_bits(c[i]))).collect()
        };
        let mut p = Part::default();
        p.verts.positions = vec3(take(3 * nv));
        p.verts.normals = vec3(take(3 * nv));
        p.indices = take(ni).to_vec();
        p.quads = take(nq).to_vec();
        p.added.positions = vec3(take(3 * na));
        p.added.normals = vec3(take(3 * na));
        Some(SlabMesh(p))
    }
}

/// Extracts the cell layers `cells` (as [`cell_layers`] counts them) of the grid `lattice`
/// from `window`, which holds its point layers `first..first + window.dims[2]` (at least
/// [`point_layers`]), in slabs on the current rayon pool. Empty `cells`: an empty mesh.
/// `window.min` and `window.max` are not read: positions come from `lattice`.
pub fn extract_window(
    window: &Grid,
    first: usize,
    lattice: &Lattice,
    x: &Request,
    cells: Range<usize>,
) -> Result<SlabMesh, MeshError> {
    if !x.iso.is_finite() {
        return Err(MeshError::BadIsovalue(x.iso));
    }
    if let Some(why) = not_in_slabs(x.algo, &x.sharp) {
        return Err(MeshError::NotInSlabs(why));
    }
    if !x.on_grid() {
        return Err(MeshError::NotInSlabs(
            "the lattice of field.interpolation and render.mesh_refine (held whole)",
        ));
    }
    if cells.is_empty() {
        return Ok(SlabMesh::default());
    }
    let dims = lattice.dims;
    let layers = cell_layers(x.algo, dims);
    let need = point_layers(x.algo, dims, cells.clone());
    let held = first..first + window.dims[2];
    let want = window.dims.iter().product::<usize>();
    let bad = |why: String| Err(MeshError::BadWindow(why));
    if dims.iter().any(|&n| n < 2) {
        return bad(format!("the grid's dimensions {dims:?} are under 2"));
    }
    if window.dims[..2] != dims[..2] || window.values.len() != want {
        return bad(format!(
            "the window's dimensions {:?} ({} samples) do not match the grid's {dims:?}",
            window.dims,
            window.values.len()
        ));
    }
    if cells.end > layers || need.start < held.start || need.end > held.end {
        return bad(format!(
            "cell layers {cells:?} of {layers} need point layers {need:?}, the window holds {held:?}"
        ));
    }
    let f = Field::window(window, first, lattice, x.iso, x.inside);
    let depth = slabs::default_depth(cells.len());
    // Counted against the cap where the ranges are joined (`Joiner::with_budget`).
    extract_part(&f, x, cells, depth, &MeshBudget::unlimited()).map(SlabMesh)
}

/// The part of cell layers `cells` of `f`, in slabs of `depth` layers, each added to `budget`.
pub(crate) fn extract_part(
    f: &Field,
    x: &Request,
    cells: Range<usize>,
    depth: usize,
    budget: &MeshBudget,
) -> Result<Part, MeshError> {
    with_slab(f, x, |slab| slabs::run_part(cells.clone(), depth, budget, slab))
}

/// A slab of cell layers as `x`'s method extracts it.
pub(crate) type Slab<'s> = &'s (dyn Fn(Range<usize>) -> Result<Part, MeshError> + Sync);

/// `run` given the function that extracts a slab of `f` with `x`'s method (the one choice of
/// per-slab code, for the joined extraction and the streamed one).
pub(crate) fn with_slab<T, E: From<MeshError>>(
    f: &Field,
    x: &Request,
    run: impl FnOnce(Slab) -> Result<T, E>,
) -> Result<T, E> {
    let m = x.algo.method();
    let make = match (m.slab, (m.not_in_slabs)(&x.sharp)) {
        (Some(make), None) => make,
        (_, why) => return Err(MeshError::NotInSlabs(why.unwrap_or(m.name)).into()),
    };
    run(&*make(f, x)?)
}

/// Joins the [`SlabMesh`]es of consecutive z-ranges, pushed from the bottom up, into the
/// whole grid's mesh.
#[derive(Default)]
pub struct Joiner(Join);

impl Joiner {
    pub fn new() -> Self {
        Joiner::default()
    }

    /// A joiner that adds every range pushed to `budget` and refuses
    /// ([`MeshError::OverCap`]) once it passes its cap.
    pub fn with_budget(budget: std::sync::Arc<MeshBudget>) -> Self {
        Joiner(Join { budget, ..Join::default() })
    }

    /// Appends the next range's mesh (the range just above the last one pushed).
    pub fn push(&mut self, part: SlabMesh) -> Result<(), MeshError> {
        self.0.push(part.0)
    }

    /// The mesh of every range pushed, which must together be every cell layer; the quads
    /// too with `keep_quads` (pass [`Request::keeps_quads`]).
    pub fn finish(self, keep_quads: bool) -> Result<Mesh, MeshError> {
        slabs::finish(self.0.part, keep_quads)
    }
}

#[cfg(test)]
#[path = "window_tests.rs"]
mod tests;
