//! Surface nets for the threaded path: the slab of [`super::dual`]'s `surface-nets`
//! (`Boundary::Open`, mean vertices) with the same vertices, normals, quads and triangles, bit
//! for bit, reached with less work per cell.
//!
//! `dual` is the reference and stays as the definition (its single-threaded `extract`, which
//! the threaded path is tested against). It asks every cell for its vertex through padded-point
//! lookups, tests 8 corners and then re-tests both ends of each of the 12 edges, and finds the
//! quads by computing the crossing point of every lattice edge only to read its direction. Here:
//!
//! ```text
//!   point layer z     flags[z % 2]   inside rule of every point, 1 or 0, once per layer
//!   cell row          differs        OR of the XORs of each cell's corners with corner 0,
//!                                    whole rows at a time (vectorised): a cell is active
//!                                    iff nonzero; only active cells are visited
//!   active cell       mask           its 8 corner flags; the 12 edges from a fixed table in
//!                                    the reference's order, crossed iff their ends' bits
//!                                    differ; crossing points in f64 as `Field::crossing`
//!   point row         crossed        OR of the XORs with the +x, +y, +z neighbours: only
//!                                    points that start a crossed edge make quads
//! ```
//!
//! What decides a position or a normal is the reference's arithmetic in the reference's
//! order (the sum of the crossing points, x edges first, each `q + s` along its axis, divided
//! by the count; `Field::normal` at the mean), so nothing is rounded differently.

use std::ops::Range;

use glam::DVec3;

use super::dual::split;
use super::edges::Vertices;
use super::field::{Field, MISSING};
use super::slabs::Part;
use super::{ExtractOptions, MeshError};

/// The 12 edges of a cell in the reference's order (axis x, y, z; within axis `a` by the
/// offsets along `(a + 1, a + 2) mod 3`: (0,0), (1,0), (0,1), (1,1)): start corner (bits
/// x = 1, y = 2, z = 4) and axis. The end corner is the start plus the axis bit.
const EDGES: [(u8, usize); 12] = {
    let mut t = [(0u8, 0usize); 12];
    let mut axis = 0;
    while axis < 3 {
        let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
        let mut m = 0;
        while m < 4 {
            t[4 * axis + m] = ((((m & 1) << b) | ((m >> 1) << c)) as u8, axis);
            m += 1;
        }
        axis += 1;
    }
    t
};

/// For each corner mask, bit `e` set iff edge `EDGES[e]` is crossed (its ends' bits differ):
/// a cell visits its crossed edges in order by their set bits, without a branch per edge.
const CROSSED: [u16; 256] = {
    let mut t = [0u16; 256];
    let mut mask = 0;
    while mask < 256 {
        let mut e = 0;
        while e < 12 {
            let (start, axis) = EDGES[e];
            let end = start | 1 << axis;
            if (mask >> start & 1) != (mask >> end & 1) {
                t[mask] |= 1 << e;
            }
            e += 1;
        }
        mask += 1;
    }
    t
};

/// For edge `e` of [`EDGES`]: low nibble, the slot (0..4) of the previous cell's `carry` that
/// holds its crossing (the y and z edges at x = 0: 4, 5, 8, 10), else 4; high nibble, the slot
/// it is kept in for the next cell (those at x = 1: 6, 7, 9, 11), else 4.
const REUSE: [u8; 12] = [0x44, 0x44, 0x44, 0x44, 0x40, 0x41, 0x04, 0x14, 0x42, 0x24, 0x43, 0x34];

/// [`super::dual::extract_slab`] for `surface-nets`: the vertices of cell layers `cells` and
/// the quads of the crossed edges starting in point layers `cells.start + 1 ..= cells.end`
/// (see there), numbered locally.
pub(crate) fn extract_slab(
    f: &Field,
    opts: ExtractOptions,
    cells: Range<usize>,
) -> Result<Part, MeshError> {
    let [nx, ny, nz] = f.dims;
    let (ncx, ncy, ncz) = (nx - 1, ny - 1, nz - 1);
    let mut verts = Vertices::default();
    let mut quads: Vec<u32> = Vec::new();
    let mut indices: Vec<u32> = Vec::new();
    // Vertex ids of cell layers z (slot z % 2); inside flags of point layers z (slot z % 2).
    let mut ids = [vec![u32::MAX; ncx * ncy], vec![u32::MAX; ncx * ncy]];
    let mut flags = [Vec::new(), Vec::new()];
    let mut differs = vec![0u8; ncx.max(nx)];
    f.inside_flags(f.layer(cells.start), &mut flags[cells.start % 2]);

    let points_end = if cells.end == ncz { nz } else { cells.end + 1 };
    for qz in cells.start..points_end {
        if qz + 1 < nz {
            let (lo, hi) = flags.split_at_mut(1);
            let above = if qz % 2 == 0 { &mut hi[0] } else { &mut lo[0] };
            f.inside_flags(f.layer(qz + 1), above);
        }
        // Number the active cells of cell layer qz.
        if qz < ncz {
            let own = qz < cells.end;
            let (lo, hi) = (&flags[qz % 2], &flags[(qz + 1) % 2]);
            let values = [f.layer(qz), f.layer(qz + 1)];
            let slot = &mut ids[qz % 2];
            slot.fill(u32::MAX);
            for cy in 0..ncy {
                let r = nx * cy;
                super::edges::cell_row_differs(lo, hi, r, nx, &mut differs[..ncx]);
                // The crossings of this row's last cell's y and z edges at x + 1 (slot 4: none).
                let mut carry = [0.0f64; 5];
                // The cell `carry` is from: a missing cell in between leaves none.
                let mut carried_at = usize::MAX;
                for cx in (0..ncx).filter(|&cx| differs[cx] != 0) {
                    let p = r + cx;
                    let corner = |n: usize| {
                        let layer = if n & 4 == 0 { lo } else { hi };
                        layer[p + (n & 1) + nx * ((n >> 1) & 1)]
                    };
                    let mask = (0..8).fold(0u8, |m, n| m | corner(n) << n);
                    // A missing cell has no vertex (`field::interpolant::cell_missing`).
                    if (0..8).any(|n| corner(n) & MISSING != 0) {
                        continue;
                    }
                    let value = |n: u8| {
                        let n = usize::from(n);
                        f64::from(values[n >> 2][p + (n & 1) + nx * ((n >> 1) & 1)])
                    };
                    let c = [cx as f64, cy as f64, qz as f64];
                    let mut sum = DVec3::ZERO;
                    let mut dir = DVec3::ZERO;
                    let mut count = 0u32;
                    let mut crossed = CROSSED[usize::from(mask)];
                    let mut next = [0.0f64; 5];
                    while crossed != 0 {
                        let e = crossed.trailing_zeros() as usize;
                        let (start, axis) = EDGES[e];
                        crossed &= crossed - 1;
                        let end = start | 1 << axis;
                        let inside_start = mask >> start & 1;
                        // A y or z edge at x is the previous cell's at x + 1, and being crossed
                        // that cell was active and just visited: the same division, done once.
                        let from = usize::from(REUSE[e] & 15);
                        let s = if cx > 0 && from < 4 && carried_at == cx - 1 {
                            carry[from]
                        } else {
                            let b = |a: usize| usize::from((start >> a) & 1);
                            let p = [cx + b(0), cy + b(1), qz + b(2)];
                            let mut d = [0; 3];
                            d[axis] = 1;
                            f.crossing_on(p, d, value(start), value(end))
                        };
                        next[usize::from(REUSE[e] >> 4)] = s;
                        let bit = |a: usize| f64::from((start >> a) & 1);
                        let mut u = DVec3::new(c[0] + bit(0), c[1] + bit(1), c[2] + bit(2));
                        u[axis] += s;
                        sum += u;
                        dir[axis] += if inside_start == 1 { 1.0 } else { -1.0 };
                        count += 1;
                    }
                    carry = next;
                    carried_at = cx;
                    let u = sum / f64::from(count);
                    slot[cx + ncx * cy] = if !own {
                        verts.push_borrowed(f, u)?
                    } else if (0..3).all(|a| u[a] > c[a] && u[a] < c[a] + 1.0) {
                        // The common case: the normal of this one cell.
                        verts.push_with(f, u, f.normal_in_cell([cx, cy, qz], u, dir))?
                    } else {
                        verts.push(f, u, dir)? // on a face, edge or corner: the cells around it
                    };
                }
            }
        }
        // The quads of point layer `cells.start` belong to the slab below.
        if qz == cells.start && qz > 0 {
            continue;
        }
        let here = &flags[qz % 2];
        let above: &[u8] = if qz + 1 < nz { &flags[(qz + 1) % 2] } else { &[] };
        let cell_id = |x: usize, y: usize, z: usize| ids[z % 2][x + ncx * y];
        for qy in 0..ny {
            let r = nx * qy;
            point_row_crossed(here, above, r, nx, qy + 1 < ny, &mut differs[..nx]);
            for qx in (0..nx).filter(|&qx| differs[qx] != 0) {
                let p = r + qx;
                let inside = here[p];
                let crossed = [
                    qx + 1 < nx && here[p + 1] != inside,
                    qy + 1 < ny && here[p + nx] != inside,
                    qz + 1 < nz && above[p] != inside,
                ];
                for (axis, _) in crossed.iter().enumerate().filter(|(_, &c)| c) {
                    // The four cells around the edge, (b, c) = (a + 1, a + 2) mod 3, at
                    // offsets (-1,-1), (0,-1), (0,0), (-1,0); none if it lies on the boundary.
                    let quad = match axis {
                        0 if qy >= 1 && qz >= 1 && qy < ncy && qz < ncz => [
                            cell_id(qx, qy - 1, qz - 1),
                            cell_id(qx, qy, qz - 1),
                            cell_id(qx, qy, qz),
                            cell_id(qx, qy - 1, qz),
                        ],
                        1 if qz >= 1 && qx >= 1 && qz < ncz && qx < ncx => [
                            cell_id(qx - 1, qy, qz - 1),
                            cell_id(qx - 1, qy, qz),
                            cell_id(qx, qy, qz),
                            cell_id(qx, qy, qz - 1),
                        ],
                        2 if qx >= 1 && qy >= 1 && qx < ncx && qy < ncy => [
                            cell_id(qx - 1, qy - 1, qz),
                            cell_id(qx, qy - 1, qz),
                            cell_id(qx, qy, qz),
                            cell_id(qx - 1, qy, qz),
                        ],
                        _ => continue,
                    };
                    // A missing cell around the edge (an edge with a missing end has only
                    // those): no quad.
                    if quad.contains(&u32::MAX) {
                        continue;
                    }
                    let mut quad = quad;
                    if inside == 0 {
                        quad.swap(1, 3);
                    }
                    if opts.keep_quads {
                        quads.extend_from_slice(&quad); // else `slabs::finish` drops them
                    }
                    split(&verts.positions, quad, opts.split, &mut indices);
                }
            }
        }
    }
    Ok(Part { verts, indices, quads, added: Vertices::default() })
}

/// For the points of one row (from point `r` of layer `here`, the layer above `above`, empty
/// at the top; `next_row`: whether the row above exists): nonzero iff the point starts a
/// crossed x, y or z edge.
fn point_row_crossed(
    here: &[u8],
    above: &[u8],
    r: usize,
    nx: usize,
    next_row: bool,
    out: &mut [u8],
) {
    let row = &here[r..r + nx];
    out.fill(0);
    for x in 0..nx - 1 {
        out[x] = row[x] ^ row[x + 1];
    }
    if next_row {
        let up = &here[r + nx..r + 2 * nx];
        for x in 0..nx {
            out[x] |= row[x] ^ up[x];
        }
    }
    if !above.is_empty() {
        let up = &above[r..r + nx];
        for x in 0..nx {
            out[x] |= row[x] ^ up[x];
        }
    }
}
