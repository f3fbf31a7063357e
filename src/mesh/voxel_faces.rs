//! `field.interpolation = "nearest"`: the mesh is the voxels' faces.
//!
//! A nearest field is constant on each point's voxel (the box of half a cell around the
//! point, `field::interpolant::nearest`), so its isosurface is the set of faces between an
//! inside voxel and an outside one, clipped to the grid's box like every surface:
//!
//! ```text
//!        +-----+-----+           point (i, j, k) inside, (i+1, j, k) outside: the face
//!        |  ●  |  ○  |           x = i + 1/2, y in [j - 1/2, j + 1/2], z in [k - 1/2, k + 1/2]
//!        +-----+-----+           (index space; clipped to [0, n - 1]), normal +x
//! ```
//!
//! One quad per such neighbour pair, whatever `render.mesh` says (the methods are ways of
//! placing vertices between samples; here the surface is known exactly). Every quad has its
//! own four vertices carrying the face's outward normal (inside → outside), as voxel meshes
//! do for flat shading, so `--stats` counts their edges as open: weld by position to close
//! them. Faces come in point order (x fastest, then y, then z), and at each point in axis
//! order x, y, z, for the pair of the point and its neighbour above; each quad is
//! counter-clockwise seen from outside and split along its first diagonal (`QuadSplit::Fixed`).
//! A pair with a missing sample (NaN) has no face. `render.mesh_refine` changes nothing.

use glam::DVec3;

use super::field::Field;
use super::{to_u32, Mesh, MeshBudget, MeshError, Request};
use crate::field::interpolant::is_missing;
use crate::field::Grid;

/// The voxel-face mesh of `grid` for `x`'s isovalue and inside rule, each point layer's faces
/// counted into `budget` as they are made.
pub(crate) fn extract(grid: &Grid, x: &Request, budget: &MeshBudget) -> Result<Mesh, MeshError> {
    let f = Field::new(grid, x.iso, x.inside);
    let [nx, ny, nz] = grid.dims;
    let side = |v: f32| {
        let v = f64::from(v);
        (!is_missing(v)).then(|| x.inside.contains(v, x.iso))
    };
    let mut mesh = Mesh::default();
    let keep = x.keeps_quads();
    let mut quads = Vec::new();
    let hi = [nx - 1, ny - 1, nz - 1].map(|n| n as f64);
    for k in 0..nz {
        let (v0, t0) = (mesh.positions.len(), mesh.indices.len() / 3);
        for j in 0..ny {
            for i in 0..nx {
                let p = [i, j, k];
                let Some(here) = side(grid.values[grid.index(i, j, k)]) else { continue };
                for a in 0..3 {
                    let mut q = p;
                    q[a] += 1;
                    if q[a] >= grid.dims[a] {
                        continue;
                    }
                    let Some(there) = side(grid.values[grid.index(q[0], q[1], q[2])]) else {
                        continue;
                    };
                    if here == there {
                        continue;
                    }
                    // Outward: from the inside point towards the outside one.
                    let sign = if here { 1.0 } else { -1.0 };
                    let (b, c) = ((a + 1) % 3, (a + 2) % 3);
                    let span = |e: usize| {
                        let m = p[e] as f64;
                        ((m - 0.5).max(0.0), (m + 0.5).min(hi[e]))
                    };
                    let ((b0, b1), (c0, c1)) = (span(b), span(c));
                    let corner = |bv: f64, cv: f64| {
                        let mut u = DVec3::ZERO;
                        u[a] = p[a] as f64 + 0.5;
                        u[b] = bv;
                        u[c] = cv;
                        u
                    };
                    // e_b × e_c = e_a: (b0,c0) (b1,c0) (b1,c1) (b0,c1) runs counter-clockwise
                    // seen from +e_a; the other way round for -e_a.
                    let ring = if here {
                        [corner(b0, c0), corner(b1, c0), corner(b1, c1), corner(b0, c1)]
                    } else {
                        [corner(b0, c0), corner(b0, c1), corner(b1, c1), corner(b1, c0)]
                    };
                    let mut normal = [0.0f32; 3];
                    normal[a] = sign;
                    let base = to_u32(mesh.positions.len() + 3, "vertices")? - 3;
                    for u in ring {
                        mesh.positions.push(f.world(u));
                        mesh.normals.push(normal);
                    }
                    let q = [base, base + 1, base + 2, base + 3];
                    mesh.indices.extend_from_slice(&[q[0], q[1], q[2], q[0], q[2], q[3]]);
                    if keep {
                        quads.extend_from_slice(&q);
                    }
                }
            }
        }
        let quad_indices = if keep { (mesh.indices.len() / 3 - t0) * 2 } else { 0 };
        budget.add(mesh.positions.len() - v0, mesh.indices.len() / 3 - t0, quad_indices)?;
    }
    mesh.quads = keep.then_some(quads);
    Ok(mesh)
}
