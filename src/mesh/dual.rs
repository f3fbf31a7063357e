//! The dual methods: naive surface nets and dual contouring as GEL does it.
//!
//! Both put one vertex in each *active* cell (a cell with a crossed edge), at the mean of the
//! crossing points of its crossed edges, and join the four cells around each crossed lattice
//! edge with a quad, split into two triangles by [`QuadSplit`]:
//!
//! ```text
//!        c ↑                       quad around a crossed edge along axis a, seen from +a
//!          │   (-1, 0)───(0, 0)    (the edge pierces the page at the centre ×); cells by
//!          │     │    ×    │       their offsets along the other two axes (b, c) =
//!          │   (-1,-1)───(0,-1)    (a+1, a+2) mod 3: q0..q3 = (-1,-1), (0,-1), (0,0), (-1,0),
//!          └──────────────→ b      counter-clockwise about +a; reversed if the edge's start
//!                                  point is outside (the surface then faces -a)
//! ```
//!
//! * **`surface-nets`** ([`Boundary::Open`]): cells of the grid only; a crossed edge on the
//!   grid's boundary faces (fewer than four cells around it) makes no quad, so a surface that
//!   reaches the boundary stays open there.
//! * **`dual-contouring`** ([`Boundary::Closed`]), after `HMesh::volume_polygonize` in GEL
//!   (J. A. Bærentzen, `src/GEL/HMesh/polygonize.cpp`, `dual_connectivity = true`): the grid is
//!   padded with one layer of points outside the box that count as *outside*, and one layer of
//!   cells around it (cell coordinates -1 and n-1). An edge from an inside boundary point to a
//!   padding point is crossed, with its crossing pinned to the boundary point (GEL's `t = 0`), so
//!   wherever the inside region meets the box the surface is capped by quads lying in the box
//!   faces and the mesh is closed. Vertices of padding cells lie on the box faces; their
//!   normals are the box's outward normal (the sum of the unit normals of the padding axes,
//!   normalised), not the field gradient. Differences from GEL: GEL builds a half-edge mesh, so
//!   its stitching splits a vertex whose quads do not form a single fan (a non-manifold
//!   configuration) into several, where this keeps one vertex per cell; and GEL's
//!   `remove_needles` clean-up of triangles is not done.
//!
//! Rules, as a GPU pass reproduces them:
//!
//! * **Cells** are numbered linearly over `(nx - 1, ny - 1, nz - 1)` cells (surface nets) or over
//!   `(nx + 1, ny + 1, nz + 1)` padded cells, cell `c` stored at `c + 1` (dual contouring).
//!   Vertices are numbered in increasing cell number over active cells.
//! * **Vertex** = mean of the crossing points of the cell's crossed edges, summed in the order
//!   x edges, y edges, z edges, and within axis `a` by the edge's offsets along
//!   `(b, c) = (a+1, a+2) mod 3`: (0,0), (1,0), (0,1), (1,1).
//! * **Quads** in increasing edge id `3 * p + axis` (`p` the padded point number for dual
//!   contouring); the two triangles of a quad are consecutive.

use std::ops::Range;

use glam::DVec3;

use super::dcqef::DcQef;
use super::edges::Vertices;
use super::field::Field;
use super::slabs::{self, Part};
use super::{ExtractOptions, Mesh, MeshError, QuadSplit};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Boundary {
    /// Surface nets: no faces on the grid boundary.
    Open,
    /// Dual contouring (GEL): outside beyond the boundary, surface capped.
    Closed,
}

/// The grid as the dual methods see it: padded by `pad` points on every side.
struct Padded<'f, 'g, 'q> {
    f: &'f Field<'g>,
    pad: usize,
    /// Cells per axis.
    nc: [usize; 3],
    /// `dual-contouring-qef`'s vertex rule for the cells of the grid; None: the mean.
    qef: Option<&'q DcQef<'q, 'q, 'q>>,
}

impl Padded<'_, '_, '_> {
    /// The grid point of padded point `q`, if it lies in the grid.
    fn real(&self, q: [usize; 3]) -> Option<[usize; 3]> {
        let mut p = [0; 3];
        for a in 0..3 {
            if q[a] < self.pad || q[a] >= self.f.dims[a] + self.pad {
                return None;
            }
            p[a] = q[a] - self.pad;
        }
        Some(p)
    }

    fn inside(&self, q: [usize; 3]) -> bool {
        self.real(q).is_some_and(|p| self.f.is_inside(p[0], p[1], p[2]))
    }

    /// Whether padded cell `c` is missing: a corner in the grid is missing data
    /// (`field::interpolant::cell_missing`; padding points are outside, never missing).
    fn cell_missing(&self, c: [usize; 3]) -> bool {
        (0..8usize).any(|n| {
            let q = [c[0] + (n & 1), c[1] + ((n >> 1) & 1), c[2] + ((n >> 2) & 1)];
            self.real(q).is_some_and(|p| self.f.is_missing(p[0], p[1], p[2]))
        })
    }

    /// Crossing point (grid index space) of the edge from padded point `q` along `axis`, and
    /// whether it runs inside → outside, or None if the edge is not crossed.
    fn crossing(&self, q: [usize; 3], axis: usize) -> Option<(DVec3, bool)> {
        let mut r = q;
        r[axis] += 1;
        let (ia, ib) = (self.inside(q), self.inside(r));
        if ia == ib {
            return None;
        }
        let s = match (self.real(q), self.real(r)) {
            (Some(a), Some(b)) => {
                let f = self.f;
                let mut d = [0; 3];
                d[axis] = 1;
                f.crossing_on(a, d, f.value(a[0], a[1], a[2]), f.value(b[0], b[1], b[2]))
            }
            (Some(_), None) => 0.0,
            (None, _) => 1.0,
        };
        let mut u = DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64) - self.pad as f64;
        u[axis] += s;
        Some((u, ia))
    }

    /// The vertex of padded cell `c`, if active: its index-space position, the index-space
    /// inside → outside direction summed over its crossed edges, and where its normal is
    /// taken (the vertex, or for `dual-contouring-qef` the vertex clamped into its cell: an
    /// unclamped QEF vertex may leave the cell, and the GPU's slab holds its own cells only).
    fn cell_vertex(&self, c: [usize; 3]) -> Option<(DVec3, DVec3, DVec3)> {
        // A cell is active iff its corners are not all on one side (its edges connect all 8
        // corners): 8 inside tests settle the common case of a cell far from the surface
        // before the 12 edges are looked at.
        let first = self.inside(c);
        let mixed = (1..8usize).any(|n| {
            self.inside([c[0] + (n & 1), c[1] + ((n >> 1) & 1), c[2] + ((n >> 2) & 1)]) != first
        });
        // A missing cell has no vertex, so no quad is made around its edges.
        if !mixed || self.cell_missing(c) {
            return None;
        }
        let mut sum = DVec3::ZERO;
        let mut dir = DVec3::ZERO;
        let mut n = 0u32;
        for axis in 0..3 {
            let (b, cc) = ((axis + 1) % 3, (axis + 2) % 3);
            for m in 0..4 {
                let mut q = c;
                q[b] += m & 1;
                q[cc] += m >> 1;
                if let Some((u, out_pos)) = self.crossing(q, axis) {
                    sum += u;
                    let mut d = DVec3::ZERO;
                    d[axis] = if out_pos { 1.0 } else { -1.0 };
                    dir += d;
                    n += 1;
                }
            }
        }
        if n == 0 {
            return None;
        }
        let grid_cell = (0..3).all(|a| c[a] >= self.pad && c[a] - self.pad + 1 < self.f.dims[a]);
        match self.qef {
            Some(q) if grid_cell => {
                let g = c.map(|x| x - self.pad);
                let u = q.vertex(g);
                let lo = DVec3::new(g[0] as f64, g[1] as f64, g[2] as f64);
                Some((u, dir, u.clamp(lo, lo + 1.0)))
            }
            _ => {
                let u = sum / f64::from(n);
                Some((u, dir, u))
            }
        }
    }

    /// Outward box normal of a padding cell (None for a cell of the grid).
    fn padding_normal(&self, c: [usize; 3]) -> Option<DVec3> {
        if self.pad == 0 {
            return None;
        }
        let mut n = DVec3::ZERO;
        for a in 0..3 {
            if c[a] == 0 {
                n[a] = -1.0;
            } else if c[a] == self.nc[a] - 1 {
                n[a] = 1.0;
            }
        }
        (n != DVec3::ZERO).then(|| n.normalize())
    }
}

/// The reference: the whole (padded) grid as one slab.
pub(crate) fn extract(
    f: &Field,
    boundary: Boundary,
    opts: ExtractOptions,
    qef: Option<&DcQef>,
) -> Result<Mesh, MeshError> {
    let layers = cell_layers(f, boundary);
    slabs::run(layers, layers, opts.keep_quads, |cells| extract_slab(f, boundary, opts, qef, cells))
}

/// Padding of the grid for `boundary` (the rows of `method` say the same).
pub(crate) fn padding(boundary: Boundary) -> usize {
    match boundary {
        Boundary::Open => 0,
        Boundary::Closed => 1,
    }
}

/// Cell layers along z of the (padded) grid.
pub(crate) fn cell_layers(f: &Field, boundary: Boundary) -> usize {
    f.dims[2] + 2 * padding(boundary) - 1
}

/// The vertices of (padded) cell layers `cells` (placed by `qef` when given) and the quads of the crossed edges starting in
/// point layers `cells.start + 1 ..= cells.end` (from point layer 0 in the first slab, to the
/// last in the last one), numbered locally (see `slabs`). The quads of a slab's top point layer
/// need the cells of the layer above, which the next slab owns: they are numbered after the
/// slab's own vertices and given positions (the quad split reads them) but no normals.
pub(crate) fn extract_slab(
    f: &Field,
    boundary: Boundary,
    opts: ExtractOptions,
    qef: Option<&DcQef>,
    cells: Range<usize>,
) -> Result<Part, MeshError> {
    let pad = padding(boundary);
    let np = f.dims.map(|n| n + 2 * pad);
    let nc = np.map(|n| n - 1);
    let g = Padded { f, pad, nc, qef };

    let mut verts = Vertices::default();
    let mut quads: Vec<u32> = Vec::new();
    let mut indices: Vec<u32> = Vec::new();
    // Vertex ids of cell layers z (slot z % 2).
    let layer = nc[0] * nc[1];
    let mut ids = [vec![u32::MAX; layer], vec![u32::MAX; layer]];

    let points_end = if cells.end == nc[2] { np[2] } else { cells.end + 1 };
    for qz in cells.start..points_end {
        // Number the active cells of cell layer qz.
        if qz < nc[2] {
            let own = qz < cells.end;
            let slot = &mut ids[qz % 2];
            for cy in 0..nc[1] {
                for cx in 0..nc[0] {
                    let c = [cx, cy, qz];
                    slot[cx + nc[0] * cy] = match g.cell_vertex(c) {
                        None => u32::MAX,
                        Some((u, _, _)) if !own => verts.push_borrowed(f, u)?,
                        Some((u, dir, at)) => match g.padding_normal(c) {
                            None => verts.push_normal_at(f, u, at, dir)?,
                            Some(n) => {
                                let id = verts.push(f, u, dir)?;
                                verts.normals[id as usize] = [n.x as f32, n.y as f32, n.z as f32];
                                id
                            }
                        },
                    };
                }
            }
        }
        // The quads of point layer `cells.start` belong to the slab below.
        if qz == cells.start && qz > 0 {
            continue;
        }
        // Quads of the crossed edges that start in point layer qz.
        for qy in 0..np[1] {
            for qx in 0..np[0] {
                let q = [qx, qy, qz];
                for axis in 0..3 {
                    if q[axis] + 1 >= np[axis] {
                        continue;
                    }
                    let Some((_, out_pos)) = g.crossing(q, axis) else {
                        continue;
                    };
                    let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
                    if q[b] == 0 || q[c] == 0 || q[b] >= nc[b] || q[c] >= nc[c] {
                        continue; // fewer than four cells around this edge
                    }
                    let cell = |db: usize, dc: usize| {
                        let mut cc = q;
                        cc[b] -= 1 - db;
                        cc[c] -= 1 - dc;
                        ids[cc[2] % 2][cc[0] + nc[0] * cc[1]]
                    };
                    let mut quad = [cell(0, 0), cell(1, 0), cell(1, 1), cell(0, 1)];
                    // A missing cell around the edge (an edge with a missing end has only
                    // those): no quad.
                    if quad.contains(&u32::MAX) {
                        continue;
                    }
                    if !out_pos {
                        quad.swap(1, 3);
                    }
                    quads.extend_from_slice(&quad);
                    split(&verts.positions, quad, opts.split, &mut indices);
                }
            }
        }
    }
    Ok(Part { verts, indices, quads, added: Vertices::default() })
}

/// Appends the two triangles of `quad` per `rule`.
pub(crate) fn split(positions: &[[f32; 3]], q: [u32; 4], rule: QuadSplit, out: &mut Vec<u32>) {
    let p = |i: usize| {
        let v = positions[q[i] as usize];
        DVec3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2]))
    };
    let along_02 = match rule {
        QuadSplit::Fixed => true,
        QuadSplit::Shorter => p(0).distance_squared(p(2)) <= p(1).distance_squared(p(3)),
    };
    if along_02 {
        out.extend_from_slice(&[q[0], q[1], q[2], q[0], q[2], q[3]]);
    } else {
        out.extend_from_slice(&[q[0], q[1], q[3], q[1], q[2], q[3]]);
    }
}
