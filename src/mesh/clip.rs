//! Clipping a mesh against `[[clip]]` planes (the mesh files `extract` writes; renders clip per
//! ray instead). Each plane keeps `dot(normal, p) <= offset`, the rule of `vocab::Clip`: every
//! triangle is cut by one plane after the other (Sutherland–Hodgman) and fanned back into
//! triangles. A point made where an edge crosses a plane is shared by the triangles on both
//! sides of that edge (keyed by the edge's two vertices and the plane), so the clipped mesh
//! stays welded; its normal is the edge's normals interpolated and renormalised.

use std::collections::HashMap;

use glam::DVec3;

use super::Mesh;
use crate::vocab::{Clip, Placement};

impl Mesh {
    /// This mesh, extracted in the grid's own frame, as `isoview extract` writes it: placed in
    /// world space ([`Mesh::place`]), then cut by `clip`'s planes (world coordinates). The
    /// one rule for every extraction the CLI runs (sampled, memory-mapped, across ranks).
    pub fn in_world(mut self, placement: &Placement, clip: &Clip) -> Mesh {
        self.place(placement);
        match clip.count {
            0 => self,
            _ => self.clipped(clip),
        }
    }

    /// This mesh cut by `clip`'s planes (in the mesh's own coordinates). Vertices no triangle
    /// uses any more are dropped; quads are not kept (a clipped quad is no longer one).
    pub fn clipped(&self, clip: &Clip) -> Mesh {
        if clip.count == 0 {
            return self.clone();
        }
        let mut positions: Vec<DVec3> =
            self.positions.iter().map(|p| DVec3::from(p.map(f64::from))).collect();
        let mut normals: Vec<DVec3> =
            self.normals.iter().map(|n| DVec3::from(n.map(f64::from))).collect();
        let mut triangles: Vec<[u32; 3]> =
            self.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        for &(n, offset) in clip.planes() {
            let side: Vec<f64> = positions.iter().map(|p| n.dot(*p) - offset).collect();
            // Keyed by the edge's vertices: a fresh map per plane, since the same edge is cut
            // at another point by another plane.
            let mut made: HashMap<(u32, u32), u32> = HashMap::new();
            let mut out = Vec::with_capacity(triangles.len());
            for t in &triangles {
                let kept = t.map(|v| side[v as usize] <= 0.0);
                if kept.iter().all(|&k| k) {
                    out.push(*t);
                    continue;
                }
                if !kept.iter().any(|&k| k) {
                    continue;
                }
                // The polygon this plane leaves of the triangle, in its winding order.
                let mut poly: Vec<u32> = Vec::with_capacity(4);
                for i in 0..3 {
                    let (a, b) = (t[i], t[(i + 1) % 3]);
                    if kept[i] {
                        poly.push(a);
                    }
                    if kept[i] != kept[(i + 1) % 3] {
                        let key = (a.min(b), a.max(b));
                        let v = *made.entry(key).or_insert_with(|| {
                            let (p, q) = (key.0 as usize, key.1 as usize);
                            let s = side[p] / (side[p] - side[q]);
                            positions.push(positions[p].lerp(positions[q], s));
                            let m = normals[p].lerp(normals[q], s);
                            normals.push(if m.length() > 0.0 { m.normalize() } else { normals[p] });
                            (positions.len() - 1) as u32
                        });
                        poly.push(v);
                    }
                }
                for i in 1..poly.len() - 1 {
                    out.push([poly[0], poly[i], poly[i + 1]]);
                }
            }
            triangles = out;
        }
        // Keep only the vertices still used, in their first-use order.
        let mut remap = vec![u32::MAX; positions.len()];
        let mut mesh =
            Mesh { positions: Vec::new(), normals: Vec::new(), indices: Vec::new(), quads: None };
        for t in &triangles {
            for &v in t {
                if remap[v as usize] == u32::MAX {
                    remap[v as usize] = mesh.positions.len() as u32;
                    mesh.positions.push(positions[v as usize].as_vec3().to_array());
                    mesh.normals.push(normals[v as usize].as_vec3().to_array());
                }
                mesh.indices.push(remap[v as usize]);
            }
        }
        mesh
    }
}
