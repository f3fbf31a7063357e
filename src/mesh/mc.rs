//! Marching cubes (Lorensen & Cline) with Paul Bourke's 256-case table.
//!
//! Rules, as a GPU pass reproduces them:
//!
//! * **Vertices**: one per crossed x, y or z lattice edge; edge id `3 * p + axis` for the edge
//!   from point `p` along `axis`; vertices numbered in increasing edge id.
//! * **Case** of cell `c`: bit `b` set iff Bourke vertex `b`, our corner
//!   [`MC_VERTEX_CORNER`]`[b]`, is inside.
//! * **Triangles**: cells in linear order; within a cell, the rows of [`MC_TRIANGLES`] in table
//!   order, each triple `(e0, e1, e2)` emitted as `(v(e0), v(e2), v(e1))` (counter-clockwise seen
//!   from outside), where `v(e)` is the vertex of the lattice edge [`MC_EDGES`]`[e]` of the cell.
//!
//! The table resolves no ambiguity: a face with two diagonally opposite inside corners is cut
//! the same way whichever cell it belongs to (the table separates the inside corners), so the
//! mesh has no cracks between cells, but it does not follow the trilinear interpolant on such
//! faces or inside ambiguous cells, and neighbouring cells' choices can disagree with each
//! other's topology: a closed surface can come out with holes where the two cells sharing an
//! ambiguous face triangulate it inconsistently (see the tests, which count them).

use std::ops::Range;

use super::edges::{EdgeLayers, Vertices};
use super::field::Field;
use super::slabs::{self, Part};
use super::tables::{MC_EDGES, MC_TRIANGLES, MC_VERTEX_CORNER};
use super::{Mesh, MeshError};

/// Edge families of marching cubes: x, y, z.
const FAMILIES: &[u8] = &[1, 2, 4];

/// The Bourke case index from a mask of inside corners (bit `n` for our corner `n`).
pub(crate) fn case_index(corner_mask: u8) -> usize {
    let mut case = 0;
    for (b, &c) in MC_VERTEX_CORNER.iter().enumerate() {
        if corner_mask & (1 << c) != 0 {
            case |= 1 << b;
        }
    }
    case
}

/// [`case_index`] of every corner mask, looked up once per cell.
const CASE_OF_MASK: [usize; 256] = {
    let mut t = [0; 256];
    let mut m = 0;
    while m < 256 {
        let mut b = 0;
        while b < 8 {
            if m & (1 << MC_VERTEX_CORNER[b]) != 0 {
                t[m] |= 1 << b;
            }
            b += 1;
        }
        m += 1;
    }
    t
};

/// The reference: the whole grid as one slab.
pub(crate) fn extract(f: &Field) -> Result<Mesh, MeshError> {
    let layers = f.dims[2] - 1;
    slabs::run(layers, layers, false, |cells| extract_slab(f, cells))
}

/// The vertices of the edges starting in point layers `cells` (and in the last point layer if
/// `cells` ends at the grid's top) and the triangles of cell layers `cells`, numbered locally
/// (see `slabs`).
pub(crate) fn extract_slab(f: &Field, cells: Range<usize>) -> Result<Part, MeshError> {
    let [nx, ny, _] = f.dims;
    let mut verts = Vertices::default();
    let mut indices = Vec::new();
    let mut edges = EdgeLayers::new(f, FAMILIES);
    let mut active = vec![0u8; nx - 1];
    edges.build(cells.start, &mut verts)?;
    for k in cells.clone() {
        edges.enter_cell_layer(k, &cells, &mut verts)?;
        for j in 0..ny - 1 {
            // Cells with corners on one side have no triangles (Bourke's rows 0 and 255).
            edges.active_cells(j, k, &mut active);
            for i in (0..nx - 1).filter(|&i| active[i] != 0) {
                if edges.cell_missing(i, j, k) {
                    continue; // no surface (`field::interpolant::cell_missing`)
                }
                let mask = edges.corner_mask(i, j, k);
                let row = &MC_TRIANGLES[CASE_OF_MASK[usize::from(mask)]];
                for tri in row.chunks_exact(3).take_while(|t| t[0] >= 0) {
                    let v = |e: i8| {
                        let (corner, axis) = MC_EDGES[e as usize];
                        let o = super::edges::offset(corner);
                        edges.id(i + o[0], j + o[1], k + o[2], usize::from(axis))
                    };
                    indices.extend_from_slice(&[v(tri[0]), v(tri[2]), v(tri[1])]);
                }
            }
        }
    }
    Ok(Part { verts, indices, ..Default::default() })
}
