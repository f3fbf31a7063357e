//! `extended-mc`: Kobbelt, Botsch, Schwanecke & Seidel's feature-sensitive marching cubes
//! (SIGGRAPH 2001), on marching cubes' table (`mc.rs`) and Hermite data (`hermite.rs`).
//!
//! ```text
//!   marching cubes in a cell           extended MC: a feature vertex ● at the QEF minimiser,
//!   across a box edge                  the cell's polygon fanned round it; then edge flips
//!      ×───────×                       join feature vertices of neighbouring cells
//!      │ ╲     │                          ×───────×
//!      │   ╲   │  ← cuts the corner       │ ╲   ╱ │
//!      ×─────╲─×                          ×───●───×   ← on the edge
//! ```
//!
//! 1. **Vertices** on crossed lattice edges as marching cubes (one per x, y, z edge, numbered
//!    in edge id `3 p + axis` order), placed at the Hermite crossing (for `hermite =
//!    "trilinear"` that is marching cubes' own crossing).
//! 2. **Per cell** (in cell order), marching cubes' triangles (Bourke's table, in table order)
//!    are grouped into connected pieces (sharing a lattice edge), each a triangulated disk
//!    whose boundary loop runs through its crossings. A piece is a *feature* when two of its
//!    crossings' Hermite normals are more than `render.feature_angle` apart (Kobbelt's opening
//!    angle test). A feature piece gets a vertex at the minimiser of its crossings' QEF
//!    (`qef.rs`: the pseudo-inverse's rank tells an edge from a corner, as Kobbelt's second
//!    angle test does), kept inside the cell, and its triangles are replaced by the fan from
//!    that vertex over the boundary loop (same orientation, same boundary, so neighbouring
//!    cells still match). Other pieces keep marching cubes' triangles. Feature vertices are
//!    numbered after all edge vertices, in cell order.
//! 3. **Edge flips**: an edge between two edge vertices whose two triangles' third vertices
//!    are both feature vertices (the feature runs across the edge between two cells) is
//!    flipped to join the feature vertices, restoring the feature line. Edges are visited in
//!    triangle order (each triangle's edges in order); a flip is skipped when the new edge
//!    already exists or a triangle was flipped already in this pass.
//!
//! Normals are the field's at every vertex (as every method). Not threaded: the threaded
//! CPU extraction runs this reference as it is. Memory: one `u32` per lattice edge, 48 bytes
//! of Hermite data per crossing besides the mesh, and a table of every directed edge for the
//! flips: about 5 times the mesh (4 GB for the 746 MB mesh of a 256^3 noise grid). It is
//! checked against the mesh cap as it grows ([`MeshBudget::check_working`]), before each
//! table is allocated, since the mesh itself is counted only once it is done.

use glam::DVec3;

use super::edges::{offset, Vertices};
use super::hermite::Hermite;
use super::mc::case_index;
use super::qef::Qef;
use super::tables::{MC_EDGES, MC_TRIANGLES};
use super::{to_u32, Mesh, MeshBudget, MeshError};

/// Bytes held per crossing while extracting: its vertex (f32 position and normal, 24) and its
/// Hermite data (f64 crossing and normal, 48).
const CROSSING_BYTES: u64 = 24 + 48;

/// What the edge-flip table of `indices` entries takes: hashbrown's buckets for that
/// capacity (a power of two at least 8/7 of it), 16 bytes of key and value and 1 control
/// byte each, and the flags of `indices / 3` triangles.
fn flip_table_bytes(indices: usize) -> u64 {
    let buckets = (indices as u64).saturating_mul(8).div_ceil(7).max(1).next_power_of_two();
    buckets.saturating_mul(17).saturating_add(indices as u64 / 3)
}

/// The rule of `extended-mc`.
pub(crate) struct Emc<'f, 'g, 's> {
    pub hermite: Hermite<'f, 'g, 's>,
    pub threshold: f64,
    pub clamp: bool,
    /// cos of `render.feature_angle`.
    pub cos_feature: f64,
}

impl Emc<'_, '_, '_> {
    pub fn extract(&self, budget: &MeshBudget) -> Result<Mesh, MeshError> {
        let f = self.hermite.f;
        let [nx, ny, nz] = f.dims;
        let np = nx * ny * nz;
        let edge_table = (np as u64).saturating_mul(12);
        let check = |what, bytes| budget.check_working("extended-mc", what, bytes);
        check("its table of edge vertices, 12 bytes a grid point", edge_table)?;

        // 1. Edge vertices, with their Hermite normals (index space).
        let mut verts = Vertices::default();
        let mut hermite: Vec<(DVec3, DVec3)> = Vec::new(); // crossing, normal (index space)
        let mut ids = vec![u32::MAX; 3 * np];
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    for axis in 0..3 {
                        let p = [i, j, k];
                        if p[axis] + 1 >= f.dims[axis] {
                            continue;
                        }
                        let Some((u, n)) = self.hermite.edge(p, axis) else {
                            continue;
                        };
                        let mut dir = DVec3::ZERO;
                        dir[axis] = if f.is_inside(i, j, k) { 1.0 } else { -1.0 };
                        ids[3 * f.index(i, j, k) + axis] = verts.push(f, u, dir)?;
                        hermite.push((u, n));
                    }
                }
            }
            let held = edge_table + CROSSING_BYTES * hermite.len() as u64;
            check("its edge table and the crossings' vertices and Hermite data", held)?;
        }
        let edge_count = verts.positions.len();

        // 2. Cells.
        let mut indices: Vec<u32> = Vec::new();
        let mut feature = Vec::new(); // (index-space position, fallback direction)
        for k in 0..nz - 1 {
            for j in 0..ny - 1 {
                for i in 0..nx - 1 {
                    if f.cell_missing(i, j, k) {
                        continue; // no surface (`field::interpolant::cell_missing`)
                    }
                    let row = &MC_TRIANGLES[case_index(f.corner_mask(i, j, k))];
                    if row[0] < 0 {
                        continue;
                    }
                    let v = |e: i8| {
                        let (corner, axis) = MC_EDGES[e as usize];
                        let o = offset(corner);
                        ids[3 * f.index(i + o[0], j + o[1], k + o[2]) + usize::from(axis)]
                    };
                    let tris: Vec<[u32; 3]> = row
                        .chunks_exact(3)
                        .take_while(|t| t[0] >= 0)
                        .map(|t| [v(t[0]), v(t[2]), v(t[1])])
                        .collect();
                    for piece in pieces(&tris) {
                        let lp = boundary_loop(&piece);
                        let normals: Vec<DVec3> =
                            lp.iter().map(|&x| hermite[x as usize].1).collect();
                        if !self.is_feature(&normals) {
                            piece.iter().for_each(|t| indices.extend_from_slice(t));
                            continue;
                        }
                        let mut q = Qef::default();
                        let mut dir = DVec3::ZERO;
                        for &x in &lp {
                            let (u, n) = hermite[x as usize];
                            q.add(u, n);
                            dir += DVec3::from(verts.normals[x as usize].map(f64::from));
                        }
                        let lo = DVec3::new(i as f64, j as f64, k as f64);
                        let u = q.solve(self.threshold, self.clamp.then_some((lo, lo + 1.0)));
                        let id = to_u32(edge_count + feature.len(), "vertices")?;
                        feature.push((u, dir));
                        for w in 0..lp.len() {
                            indices.extend_from_slice(&[id, lp[w], lp[(w + 1) % lp.len()]]);
                        }
                    }
                }
            }
            let held = edge_table
                + CROSSING_BYTES * (hermite.len() + feature.len()) as u64
                + 4 * indices.len() as u64;
            check("its edge table, the crossings' Hermite data and the mesh so far", held)?;
        }
        for &(u, dir) in &feature {
            verts.push(f, u, dir / f.spacing())?;
        }
        to_u32(indices.len(), "indices")?;

        // 3. Flips. The edge table and the Hermite data are no longer needed: the mesh and
        // the flip table are what is held.
        drop((ids, hermite));
        let mesh = 24 * verts.positions.len() as u64 + 4 * indices.len() as u64;
        let table = flip_table_bytes(indices.len());
        check("the mesh and its table of directed edges for the edge flips", mesh + table)?;
        flip_features(&mut indices, edge_count as u32);
        Ok(Mesh { positions: verts.positions, normals: verts.normals, indices, quads: None })
    }

    /// Kobbelt's opening-angle test on a piece's crossing normals (zero normals ignored).
    fn is_feature(&self, normals: &[DVec3]) -> bool {
        let n: Vec<&DVec3> = normals.iter().filter(|n| n.length_squared() > 0.0).collect();
        n.iter().enumerate().any(|(a, x)| n[a + 1..].iter().any(|y| x.dot(**y) < self.cos_feature))
    }
}

/// The cell's triangles grouped into pieces connected through shared vertices, in order of
/// their first triangle.
fn pieces(tris: &[[u32; 3]]) -> Vec<Vec<[u32; 3]>> {
    let mut piece = vec![usize::MAX; tris.len()];
    let mut count = 0;
    for t in 0..tris.len() {
        if piece[t] != usize::MAX {
            continue;
        }
        piece[t] = count;
        // Flood fill (a cell has at most 5 triangles).
        let mut grew = true;
        while grew {
            grew = false;
            for u in 0..tris.len() {
                if piece[u] == usize::MAX
                    && (0..tris.len())
                        .any(|w| piece[w] == count && tris[w].iter().any(|x| tris[u].contains(x)))
                {
                    piece[u] = count;
                    grew = true;
                }
            }
        }
        count += 1;
    }
    (0..count)
        .map(|c| (0..tris.len()).filter(|&t| piece[t] == c).map(|t| tris[t]).collect())
        .collect()
}

/// The boundary loop of a piece (a triangulated disk, consistently oriented): its directed
/// edges that are not shared with another of its triangles, chained, starting with the first
/// such edge in triangle order.
fn boundary_loop(piece: &[[u32; 3]]) -> Vec<u32> {
    let edges: Vec<(u32, u32)> =
        piece.iter().flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]).collect();
    let outer: Vec<(u32, u32)> =
        edges.iter().copied().filter(|&(a, b)| !edges.contains(&(b, a))).collect();
    let mut lp = vec![outer[0].0];
    let mut at = outer[0].1;
    while at != lp[0] && lp.len() <= outer.len() {
        lp.push(at);
        at = outer.iter().find(|e| e.0 == at).map_or(lp[0], |e| e.1);
    }
    lp
}

/// Step 3 of the module docs: flips edges between edge vertices (ids below `first_feature`)
/// whose opposite vertices are both feature vertices.
fn flip_features(indices: &mut [u32], first_feature: u32) {
    use std::collections::HashMap;
    let tri_count = indices.len() / 3;
    // Directed edge -> triangle.
    let mut owner: HashMap<(u32, u32), usize> = HashMap::with_capacity(indices.len());
    for t in 0..tri_count {
        let v = &indices[3 * t..3 * t + 3];
        for e in 0..3 {
            owner.insert((v[e], v[(e + 1) % 3]), t);
        }
    }
    let mut touched = vec![false; tri_count];
    let is_feature = |x: u32| x >= first_feature;
    for t1 in 0..tri_count {
        for e in 0..3 {
            if touched[t1] {
                break;
            }
            let v = [indices[3 * t1], indices[3 * t1 + 1], indices[3 * t1 + 2]];
            let (u, w, a) = (v[e], v[(e + 1) % 3], v[(e + 2) % 3]);
            if is_feature(u) || is_feature(w) || !is_feature(a) {
                continue;
            }
            let Some(&t2) = owner.get(&(w, u)) else {
                continue;
            };
            if touched[t2] {
                continue;
            }
            let v2 = [indices[3 * t2], indices[3 * t2 + 1], indices[3 * t2 + 2]];
            let b = v2.iter().copied().find(|&x| x != u && x != w).unwrap_or(u);
            if !is_feature(b)
                || a == b
                || owner.contains_key(&(a, b))
                || owner.contains_key(&(b, a))
            {
                continue;
            }
            // (u, w, a) + (w, u, b) -> (a, u, b) + (b, w, a).
            for (x, y) in [(u, w), (w, a), (a, u), (w, u), (u, b), (b, w)] {
                owner.remove(&(x, y));
            }
            indices[3 * t1..3 * t1 + 3].copy_from_slice(&[a, u, b]);
            indices[3 * t2..3 * t2 + 3].copy_from_slice(&[b, w, a]);
            for (x, y, t) in
                [(a, u, t1), (u, b, t1), (b, a, t1), (b, w, t2), (w, a, t2), (a, b, t2)]
            {
                owner.insert((x, y), t);
            }
            touched[t1] = true;
            touched[t2] = true;
        }
    }
}
