//! Marching tetrahedra: each cell split into the 6 tetrahedra of [`MT_TETS`] around its main
//! diagonal v000–v111.
//!
//! Every cell face is split along the diagonal from its lowest to its highest corner, by both
//! cells that share it, so the piecewise-linear interpolant over the tetrahedra is continuous
//! and its level set, which this extracts, is a closed 2-manifold wherever it does not reach the
//! grid boundary: every mesh edge is shared by exactly two triangles with opposite orientations.
//! The surface is that of the piecewise-linear interpolant, not of the trilinear one (vertices
//! on face and body diagonals interpolate linearly along the diagonal).
//!
//! Rules, as a GPU pass reproduces them:
//!
//! * **Vertices**: one per crossed lattice edge of the 7 families of [`MT_FAMILIES`] (offset
//!   bits `f + 1` for family `f`: x, y, xy, z, xz, yz, xyz); edge id `7 * p + f`; numbered in
//!   increasing edge id. The crossing on a diagonal interpolates the values at its two ends.
//! * **Triangles**: cells in linear order; tetrahedra in [`MT_TETS`] order; within a
//!   tetrahedron, the triangles of [`MT_TRIANGLES`] for its inside mask (bit `i` for its local
//!   corner `i`), each tetrahedron edge `(a, b)` of [`MT_TET_EDGES`] mapped to the lattice edge
//!   between cell corners `MT_TETS[t][a]` and `MT_TETS[t][b]` (it runs from the corner whose
//!   offset bits are a subset of the other's).
//!
//! [`MT_FAMILIES`]: super::tables::MT_FAMILIES

use std::ops::Range;

use super::edges::{EdgeLayers, Vertices};
use super::field::Field;
use super::slabs::{self, Part};
use super::tables::{MT_TETS, MT_TET_EDGES, MT_TRIANGLES};
use super::{Mesh, MeshError};

/// Edge families of marching tetrahedra: offset bits 1..=7.
const FAMILIES: &[u8] = &[1, 2, 3, 4, 5, 6, 7];

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
    edges.build(cells.start, &mut verts)?;
    for k in cells.clone() {
        edges.enter_cell_layer(k, &cells, &mut verts)?;
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                // With a missing corner the mask is not a case; such a cell is skipped either
                // way: no surface (`field::interpolant::cell_missing`).
                let mask = edges.corner_mask(i, j, k);
                if mask == 0 || mask == 0xff || edges.cell_missing(i, j, k) {
                    continue;
                }
                for tet in &MT_TETS {
                    let mut case = 0;
                    for (l, &c) in tet.iter().enumerate() {
                        if mask & (1 << c) != 0 {
                            case |= 1 << l;
                        }
                    }
                    let row = &MT_TRIANGLES[case];
                    for &e in row.iter().take_while(|&&e| e >= 0) {
                        let (a, b) = MT_TET_EDGES[e as usize];
                        let (ca, cb) = (tet[usize::from(a)], tet[usize::from(b)]);
                        indices.push(edges.corner_edge([i, j, k], ca, cb));
                    }
                }
            }
        }
    }
    Ok(Part { verts, indices, ..Default::default() })
}
