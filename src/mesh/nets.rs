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
//!    (phase 1)                       the reference's order, crossed iff their ends' bits
//!                                    differ; crossing points in f64 as `Field::crossing`,
//!                                    summed; the sum, count and corners kept in `Batch`
//!   cell row          Batch::solve   the row's positions and normals, LANES cells at a time
//!    (phase 2)                       (`lanes`): their chains of divisions and square roots
//!                                    overlap instead of waiting one for the other
//!   point row         crossed        OR of the XORs with the +x, +y, +z neighbours: only
//!                                    points that start a crossed edge make quads
//! ```
//!
//! What decides a position or a normal is the reference's arithmetic in the reference's
//! order (the sum of the crossing points, x edges first, each `q + s` along its axis, divided
//! by the count; `Field::normal` at the mean), so nothing is rounded differently. Two things
//! the reference's way of writing it cost here, measured on the 256³ gyroid (one thread):
//! `u[axis] += s` with `axis` known only at run time stored one lane of `u` on the stack and
//! read all three back, a load that waits for the store (about 35 of 200 ms); and each
//! vertex's normal right after its position, one long chain after the other (about 40 ms more
//! than phase 2).

use std::ops::Range;

use glam::DVec3;

use super::dual::split;
use super::edges::Vertices;
use super::field::{crossing, Field, MISSING};
use super::lanes::{self, F64x4, LANES};
use super::slabs::Part;
use super::{to_u32, ExtractOptions, MeshError};

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

/// For each corner mask, the inside → outside direction summed over the crossed edges (+1
/// along an edge's axis where its start corner is inside, -1 where its end is): the fallback
/// of a vertex whose gradient vanishes, as the reference sums it edge by edge (small integers,
/// exact in any order).
const DIRECTIONS: [[i8; 3]; 256] = {
    let mut t = [[0i8; 3]; 256];
    let mut mask = 0;
    while mask < 256 {
        let mut e = 0;
        while e < 12 {
            let (start, axis) = EDGES[e];
            if CROSSED[mask] >> e & 1 == 1 {
                t[mask][axis] += if (mask >> start) & 1 == 1 { 1 } else { -1 };
            }
            e += 1;
        }
        mask += 1;
    }
    t
};

/// Offset bits of corner `n` (x = 1, y = 2, z = 4) as index-space offsets.
const CORNER: [[f64; 3]; 8] = {
    let mut t = [[0.0; 3]; 8];
    let mut n = 0;
    while n < 8 {
        t[n] = [(n & 1) as f64, ((n >> 1) & 1) as f64, ((n >> 2) & 1) as f64];
        n += 1;
    }
    t
};

/// The unit vector along each axis.
const UNIT: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// [`LANES`] active cells of a row, lane by lane, between the two phases of [`extract_slab`].
#[derive(Clone, Copy)]
struct Chunk {
    /// The sums of their crossing points and the counts.
    sum: [F64x4; 3],
    count: F64x4,
    /// Their x (index space; y and z are the row's).
    cx: F64x4,
    /// Their corner values.
    v: [F64x4; 8],
}

/// The active cells of a cell row: what phase 1 of [`extract_slab`] found, what phase 2 made.
struct Batch {
    chunks: Vec<Chunk>,
    masks: Vec<u8>,
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    /// Whether `normals` holds the cell's normal (false: compute it one by one).
    ok: Vec<bool>,
}

impl Batch {
    fn new(ncx: usize) -> Self {
        let n = ncx.div_ceil(LANES) * LANES;
        // Lanes past the row's cells compute harmless numbers that are never read.
        let idle = Chunk {
            sum: [F64x4::splat(0.5); 3],
            count: F64x4::splat(1.0),
            cx: F64x4::splat(0.0),
            v: [F64x4::splat(0.0); 8],
        };
        Batch {
            chunks: vec![idle; n / LANES],
            masks: vec![0; n],
            positions: vec![[0.0; 3]; n],
            normals: vec![[0.0; 3]; n],
            ok: vec![false; n],
        }
    }

    /// The positions of the first `n` cells (at y, z = `yz`), and with `normals` their
    /// normals where they lie strictly inside their cells and the gradient gives one
    /// ([`Field::units_in_corners`]; `ok` says where).
    fn solve(&mut self, f: &Field, n: usize, yz: [f64; 2], normals: bool) {
        let min = f.min().to_array().map(F64x4::splat);
        let sp = f.spacing().to_array().map(F64x4::splat);
        let (cy, cz) = (F64x4::splat(yz[0]), F64x4::splat(yz[1]));
        let one = F64x4::splat(1.0);
        for (k, chunk) in self.chunks[..n.div_ceil(LANES)].iter().enumerate() {
            let u = chunk.sum.map(|s| s / chunk.count);
            // `Field::world`, lane by lane.
            let p = [0, 1, 2].map(|a| (min[a] + u[a] * sp[a]).to_f32());
            let out = k * LANES..(k + 1) * LANES;
            for (i, pos) in self.positions[out.clone()].iter_mut().enumerate() {
                *pos = [p[0][i], p[1][i], p[2][i]];
            }
            if !normals {
                self.ok[out].fill(false);
                continue;
            }
            let lo = [chunk.cx, cy, cz];
            let mut inside = [true; LANES];
            for a in 0..3 {
                inside = lanes::and(inside, lanes::and(u[a].gt(lo[a]), u[a].lt(lo[a] + one)));
            }
            let (n, ok) = f.units_in_corners(&chunk.v, lo, u);
            self.normals[out.clone()].copy_from_slice(&n);
            self.ok[out].copy_from_slice(&lanes::and(inside, ok));
        }
    }
}

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
    // Vertex ids of cell layers z (slot z % 2). Only active cells are written (a missing one
    // gets u32::MAX), and only active cells are read: the four cells around a crossed edge.
    let mut ids = [vec![u32::MAX; ncx * ncy], vec![u32::MAX; ncx * ncy]];
    // Inside flags of point layers z (slot z % 2).
    let mut flags = [Vec::new(), Vec::new()];
    let mut differs = vec![0u8; ncx.max(nx)];
    f.inside_flags(f.layer(cells.start), &mut flags[cells.start % 2]);
    let refined = f.is_refined();
    let mut batch = Batch::new(ncx);

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
            let (lv, hv) = (f.layer(qz), f.layer(qz + 1));
            let slot = &mut ids[qz % 2];
            for cy in 0..ncy {
                let r = nx * cy;
                super::edges::cell_row_differs(lo, hi, r, nx, &mut differs[..ncx]);
                let row = &mut slot[ncx * cy..ncx * (cy + 1)];
                // Phase 1: each active cell's crossings summed, and its id.
                let mut n = 0;
                let first = verts.positions.len();
                let mut next = to_u32(first + ncx, "vertices")? - ncx as u32;
                for cx in 0..ncx {
                    if differs[cx] == 0 {
                        continue;
                    }
                    let p = r + cx;
                    let (py, pyx) = (p + nx, p + nx + 1);
                    let corner =
                        [lo[p], lo[p + 1], lo[py], lo[pyx], hi[p], hi[p + 1], hi[py], hi[pyx]];
                    // A missing cell has no vertex (`field::interpolant::cell_missing`).
                    if corner.iter().fold(0, |m, &c| m | c) & MISSING != 0 {
                        row[cx] = u32::MAX;
                        continue;
                    }
                    let mask = corner.iter().rev().fold(0u8, |m, &c| m << 1 | c);
                    let v = [lv[p], lv[p + 1], lv[py], lv[pyx], hv[p], hv[p + 1], hv[py], hv[pyx]]
                        .map(f64::from);
                    let c = [cx as f64, cy as f64, qz as f64];
                    // The crossing points summed in the reference's order, each `q + s` along
                    // its axis (the fourth lane takes no axis: it lets `axis & 3` index
                    // without a bounds check).
                    let mut sum = [0.0f64; 3];
                    let mut count = 0u32;
                    let mut crossed = CROSSED[usize::from(mask)];
                    while crossed != 0 {
                        let e = crossed.trailing_zeros() as usize;
                        crossed &= crossed - 1;
                        let (start, axis) = EDGES[e];
                        let start = usize::from(start);
                        let end = start | 1 << axis;
                        let s = if refined {
                            let o = super::edges::offset(start as u8);
                            let mut d = [0; 3];
                            d[axis] = 1;
                            f.crossing_on([cx + o[0], cy + o[1], qz + o[2]], d, v[start], v[end])
                        } else {
                            crossing(v[start], v[end], f.iso)
                        };
                        // `q + s` along the axis: `s * 1.0` is `s` and `s * 0.0` a zero, which
                        // leaves the other coordinates as they are (no store to a lane picked at
                        // run time, which the loads after it would wait for).
                        let (o, unit) = (CORNER[start & 7], UNIT[axis % 3]);
                        sum[0] += (c[0] + o[0]) + s * unit[0];
                        sum[1] += (c[1] + o[1]) + s * unit[1];
                        sum[2] += (c[2] + o[2]) + s * unit[2];
                        count += 1;
                    }
                    row[cx] = next;
                    next += 1;
                    let (chunk, i) = (&mut batch.chunks[n / LANES], n % LANES);
                    for (lanes, &x) in chunk.sum.iter_mut().zip(&sum) {
                        lanes.0[i] = x;
                    }
                    chunk.count.0[i] = f64::from(count);
                    chunk.cx.0[i] = c[0];
                    for (k, &x) in v.iter().enumerate() {
                        chunk.v[k].0[i] = x;
                    }
                    batch.masks[n] = mask;
                    n += 1;
                }
                // Phase 2: the positions and normals, LANES cells at a time.
                batch.solve(f, n, [cy as f64, qz as f64], own && !refined);
                verts.positions.extend_from_slice(&batch.positions[..n]);
                if !own {
                    continue; // the next slab's vertices: their positions only (for the split)
                }
                for i in 0..n {
                    let normal = if batch.ok[i] {
                        batch.normals[i]
                    } else {
                        let (chunk, j) = (&batch.chunks[i / LANES], i % LANES);
                        let sum = DVec3::from(chunk.sum.map(|x| x.0[j]));
                        let u = sum / chunk.count.0[j];
                        let c = DVec3::new(chunk.cx.0[j], cy as f64, qz as f64);
                        let dir =
                            DVec3::from(DIRECTIONS[usize::from(batch.masks[i])].map(f64::from));
                        if !refined && u.cmpgt(c).all() && u.cmplt(c + 1.0).all() {
                            // The gradient vanishes: the fallback.
                            f.normal_in_corners(&chunk.v.map(|x| x.0[j]), c, u, dir)
                        } else {
                            // On a face, edge or corner: the cells around it.
                            f.normal(u, dir)
                        }
                    };
                    verts.normals.push(normal);
                }
            }
        }
        // The quads of point layer `cells.start` belong to the slab below.
        if qz == cells.start && qz > 0 {
            continue;
        }
        let here = &flags[qz % 2];
        let above: &[u8] = if qz + 1 < nz { &flags[(qz + 1) % 2] } else { &[] };
        // Cell layers qz - 1 and qz; the edges of a point layer at the grid's bottom or top
        // have no quads along x and y, and those below the grid's top none along z either.
        let (below, cur) = (&ids[(qz + 1) % 2], &ids[qz % 2]);
        let inner_z = qz >= 1 && qz < ncz;
        for qy in 0..ny {
            let r = nx * qy;
            point_row_crossed(here, above, r, nx, qy + 1 < ny, &mut differs[..nx]);
            let inner_y = qy >= 1 && qy < ncy;
            // Rows qy - 1 and qy of the cell layers (clamped: read only when inner).
            let (ya, yb) = (ncx * qy.saturating_sub(1), ncx * qy.min(ncy - 1));
            for qx in 0..nx {
                if differs[qx] == 0 {
                    continue;
                }
                let p = r + qx;
                let inside = here[p];
                let inner_x = qx >= 1 && qx < ncx;
                // The four cells around each edge, (b, c) = (a + 1, a + 2) mod 3, at offsets
                // (-1,-1), (0,-1), (0,0), (-1,0).
                let mut emit = |quad: [u32; 4]| {
                    // A missing cell around the edge (an edge with a missing end has only
                    // those): no quad.
                    if quad.contains(&u32::MAX) {
                        return;
                    }
                    let mut quad = quad;
                    if inside == 0 {
                        quad.swap(1, 3);
                    }
                    if opts.keep_quads {
                        quads.extend_from_slice(&quad); // else `slabs::finish` drops them
                    }
                    split(&verts.positions, quad, opts.split, &mut indices);
                };
                if qx < ncx && inner_y && inner_z && here[p + 1] != inside {
                    emit([below[ya + qx], below[yb + qx], cur[yb + qx], cur[ya + qx]]);
                }
                if qy < ncy && inner_z && inner_x && here[p + nx] != inside {
                    emit([below[yb + qx - 1], cur[yb + qx - 1], cur[yb + qx], below[yb + qx]]);
                }
                if qz < ncz && inner_x && inner_y && above[p] != inside {
                    emit([cur[ya + qx - 1], cur[ya + qx], cur[yb + qx], cur[yb + qx - 1]]);
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
