//! `source = "mesh"`: the signed distance to a triangle mesh (STL, OBJ or PLY), sampled on a grid
//! with cubic cells around the mesh (FOSSIL's `resample_via_distance_field`: any mesh can then be
//! ray traced, or re-extracted watertight).
//!
//! ```text
//!        margin = 5% of the longest side, on every side
//!      ┌──────────────────────────────┐
//!      │   ┌──────────────────────┐   │   grid: `resolution` points along the longest axis,
//!      │   │  mesh bounding box   │   │   cubic cells of side h = (1.1 L) / (resolution - 1),
//!      │   └──────────────────────┘   │   the other axes rounded up to whole cells and centred
//!      └──────────────────────────────┘
//! ```
//!
//! Value at a grid point p: `sign(p) * min over triangles |p - T|`, negative inside. Both parts
//! are implemented here in f64 (no crate fitted: `mesh_to_sdf` and `parry3d` work in f32 and pull
//! in nalgebra; `mesh_to_sdf` signs by ray parity, which streaks on open meshes):
//!
//! * **Distance**: exact point-triangle distance (closest point by Voronoi regions of the
//!   triangle, Ericson, *Real-Time Collision Detection* 5.1.5), the nearest triangle found through
//!   a bounding-volume hierarchy (median split, branch and bound on box distances).
//! * **Sign**: the generalised winding number w(p) of Jacobson et al. (SIGGRAPH 2013), the sum of
//!   the triangles' signed solid angles over 4π: 1 inside a closed, outward-wound mesh, 0 outside,
//!   and a smooth, robust inside measure for meshes with holes, flipped parts or self-overlaps.
//!   p is inside where |w(p)| > 1/2 (so a mesh wound inside-out, w = -1 within, keeps its
//!   inside; the resampled surface then faces outward again). Evaluated as Barill et al. (SIGGRAPH 2018) do: exactly
//!   (Van Oosterom–Strackee solid angle) for nearby BVH leaves, by the node's dipole (the sum of
//!   its area-weighted normals at its area-weighted centroid) for nodes further than
//!   [`FAR_FIELD`] times their radius.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;

use super::{DataAccess, FieldError};
use crate::vocab::Bounds;

/// Fraction of the bounding box's longest side added as a margin on every side.
pub const MARGIN: f64 = 0.05;
/// A BVH node at least this many of its radii away counts by its dipole in the winding number.
pub const FAR_FIELD: f64 = 3.0;
/// Most triangles in a BVH leaf.
const LEAF_SIZE: usize = 8;
/// Most triangles read from a mesh file.
pub const MAX_TRIANGLES: usize = 1 << 26;

/// A triangle mesh as read from a file: positions (f64) and triangles.
#[derive(Clone, Debug, PartialEq)]
pub struct TriangleMesh {
    pub positions: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// The axis-aligned bounding box of the vertices that triangles use.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.triangles.iter().flatten().fold(
            (DVec3::INFINITY, DVec3::NEG_INFINITY),
            |(lo, hi), &v| {
                let p = self.positions[v as usize];
                (lo.min(p), hi.max(p))
            },
        )
    }

    /// Reads an STL (binary or ASCII), OBJ (polygons fan-triangulated) or PLY (ASCII or binary;
    /// `vertex` x, y, z and `face` vertex_indices / vertex_index, polygons fan-triangulated)
    /// file, by its extension.
    pub fn read(path: &Path) -> Result<TriangleMesh, FieldError> {
        Self::read_named(path, path, &DataAccess::Any)
    }

    /// [`TriangleMesh::read`] of `path`, the format told from `named`'s extension: the name
    /// the scene wrote, where `path` is what `serve` resolved it to (a link's target), opened
    /// as `access` says.
    pub fn read_named(
        path: &Path,
        named: &Path,
        access: &DataAccess,
    ) -> Result<TriangleMesh, FieldError> {
        let bad = |message: String| FieldError::BadMesh { path: path.to_path_buf(), message };
        let ext = named.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        let mesh = match ext.as_deref() {
            Some("stl") => {
                let mut file = open(path, access)?;
                let stl = stl_io::read_stl(&mut file)
                    .map_err(|e| bad(format!("not a valid STL file ({})", one_line(&e))))?;
                TriangleMesh {
                    positions: stl
                        .vertices
                        .iter()
                        .map(|v| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64))
                        .collect(),
                    triangles: stl
                        .faces
                        .iter()
                        .map(|f| f.vertices.map(|i| u32::try_from(i).unwrap_or(u32::MAX)))
                        .collect(),
                }
            }
            Some("obj") => read_obj(path, access)?,
            Some("ply") => read_ply(path, access)?,
            _ => {
                return Err(bad(
                    "unsupported mesh format: the file name must end in .stl, .obj or .ply"
                        .to_string(),
                ))
            }
        };
        mesh.check().map_err(bad)?;
        Ok(mesh)
    }

    /// Every index in range, every used position finite, at least one triangle, some extent.
    fn check(&self) -> Result<(), String> {
        if self.triangles.is_empty() {
            return Err("the mesh has no triangles".into());
        }
        if self.triangles.len() > MAX_TRIANGLES {
            return Err(format!(
                "the mesh has {} triangles, more than the {MAX_TRIANGLES} isoview reads",
                self.triangles.len()
            ));
        }
        let n = self.positions.len();
        for (t, tri) in self.triangles.iter().enumerate() {
            if let Some(&v) = tri.iter().find(|&&v| v as usize >= n) {
                return Err(format!("triangle {t} uses vertex {v}, but there are only {n}"));
            }
        }
        for tri in &self.triangles {
            for &v in tri {
                let p = self.positions[v as usize];
                // STL and OBJ positions are read in f32 (tobj's, the format's): a coordinate
                // past its range (1e300 in an OBJ) reads inf, which the file does not hold, so
                // the line says why. A PLY's double stays f64.
                if !p.is_finite() {
                    return Err(format!(
                        "vertex {v} is not finite: [{}, {}, {}] (NaN, or in an STL or OBJ a \
                         coordinate beyond ±3.4028235e38, the range of the 32-bit floats they \
                         are read in)",
                        p.x, p.y, p.z
                    ));
                }
            }
        }
        let (lo, hi) = self.bounds();
        if (hi - lo).max_element() <= 0.0 {
            return Err("the mesh has no extent (all its vertices coincide)".into());
        }
        Ok(())
    }
}

fn one_line(e: &dyn std::fmt::Display) -> String {
    super::error::one_line(&e.to_string())
}

fn open(path: &Path, access: &DataAccess) -> Result<std::io::BufReader<std::fs::File>, FieldError> {
    access.open(path).map(std::io::BufReader::new).map_err(|e| FieldError::io(path, &e))
}

/// Fan-triangulates polygon `face` into `out`.
fn fan(face: &[u32], out: &mut Vec<[u32; 3]>) {
    for i in 1..face.len().saturating_sub(1) {
        out.push([face[0], face[i], face[i + 1]]);
    }
}

fn read_obj(path: &Path, access: &DataAccess) -> Result<TriangleMesh, FieldError> {
    let bad = |message: String| FieldError::BadMesh { path: path.to_path_buf(), message };
    let mut file = open(path, access)?;
    let opts = tobj::LoadOptions { triangulate: true, single_index: false, ..Default::default() };
    // Materials are not needed: every material library resolves to nothing.
    let (models, _) = tobj::load_obj_buf(&mut file, &opts, |_| Ok(Default::default()))
        .map_err(|e| bad(format!("not a valid OBJ file ({})", one_line(&e))))?;
    let mut mesh = TriangleMesh { positions: Vec::new(), triangles: Vec::new() };
    for m in &models {
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(
            m.mesh
                .positions
                .chunks_exact(3)
                .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)),
        );
        mesh.triangles.extend(
            m.mesh.indices.chunks_exact(3).map(|t| [base + t[0], base + t[1], base + t[2]]),
        );
    }
    Ok(mesh)
}

fn read_ply(path: &Path, access: &DataAccess) -> Result<TriangleMesh, FieldError> {
    use ply_rs_bw::parser::Parser;
    use ply_rs_bw::ply::{DefaultElement, Property};
    let bad = |message: String| FieldError::BadMesh { path: path.to_path_buf(), message };
    let mut file = open(path, access)?;
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut file)
        .map_err(|e| bad(format!("not a valid PLY file ({})", one_line(&e))))?;
    let scalar = |e: &DefaultElement, k: &str| -> Option<f64> {
        Some(match e.get(k)? {
            Property::Char(v) => *v as f64,
            Property::UChar(v) => *v as f64,
            Property::Short(v) => *v as f64,
            Property::UShort(v) => *v as f64,
            Property::Int(v) => *v as f64,
            Property::UInt(v) => *v as f64,
            Property::Float(v) => *v as f64,
            Property::Double(v) => *v,
            _ => return None,
        })
    };
    let list = |e: &DefaultElement| -> Option<Vec<u32>> {
        let p = e.get("vertex_indices").or_else(|| e.get("vertex_index"))?;
        let to = |v: i64| u32::try_from(v).unwrap_or(u32::MAX);
        Some(match p {
            Property::ListChar(v) => v.iter().map(|&x| to(x as i64)).collect(),
            Property::ListUChar(v) => v.iter().map(|&x| x as u32).collect(),
            Property::ListShort(v) => v.iter().map(|&x| to(x as i64)).collect(),
            Property::ListUShort(v) => v.iter().map(|&x| x as u32).collect(),
            Property::ListInt(v) => v.iter().map(|&x| to(x as i64)).collect(),
            Property::ListUInt(v) => v.clone(),
            _ => return None,
        })
    };
    let empty = Vec::new();
    let vertices = ply.payload.get("vertex").unwrap_or(&empty);
    let mut mesh =
        TriangleMesh { positions: Vec::with_capacity(vertices.len()), triangles: Vec::new() };
    for (i, v) in vertices.iter().enumerate() {
        match (scalar(v, "x"), scalar(v, "y"), scalar(v, "z")) {
            (Some(x), Some(y), Some(z)) => mesh.positions.push(DVec3::new(x, y, z)),
            _ => return Err(bad(format!("vertex {i} lacks a numeric x, y or z"))),
        }
    }
    for (i, f) in ply.payload.get("face").unwrap_or(&empty).iter().enumerate() {
        let face =
            list(f).ok_or_else(|| bad(format!("face {i} lacks an integer list vertex_indices")))?;
        fan(&face, &mut mesh.triangles);
    }
    Ok(mesh)
}

/// The grid of a mesh field: `resolution` points along the longest side of the mesh's bounding
/// box grown by [`MARGIN`] on every side, cubic cells, the other axes rounded up to whole cells
/// and centred on the mesh. Returns the points per axis and the box.
pub fn grid_for(lo: DVec3, hi: DVec3, resolution: usize) -> ([usize; 3], Bounds) {
    let longest = (hi - lo).max_element();
    let margin = MARGIN * longest;
    let side = longest + 2.0 * margin;
    let h = side / (resolution - 1) as f64;
    let centre = 0.5 * (lo + hi);
    let mut dims = [0; 3];
    let (mut min, mut max) = (DVec3::ZERO, DVec3::ZERO);
    for a in 0..3 {
        let extent = hi[a] - lo[a] + 2.0 * margin;
        // Whole cells covering the extent (the longest axis exactly `resolution - 1`).
        let cells = if hi[a] - lo[a] == longest {
            resolution - 1
        } else {
            ((extent / h) * (1.0 - 1e-12)).ceil().max(1.0) as usize
        };
        dims[a] = cells + 1;
        min[a] = centre[a] - 0.5 * cells as f64 * h;
        max[a] = centre[a] + 0.5 * cells as f64 * h;
    }
    (dims, Bounds { min, max })
}

/// A node of the bounding-volume hierarchy.
#[derive(Clone, Debug)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Triangles `first .. first + count` of the reordered list for a leaf; for an inner node
    /// `first` is the left child (the right one follows its subtree: `right`).
    first: u32,
    count: u32,
    right: u32,
    /// Area-weighted centroid of the node's triangles.
    centre: DVec3,
    /// Sum of the triangles' area vectors `(b - a) x (c - a) / 2`.
    area_normal: DVec3,
    /// Largest distance from `centre` to a corner of the box.
    radius: f64,
}

/// The signed distance to a triangle mesh (see the module documentation).
#[derive(Debug)]
pub struct MeshSdf {
    /// Triangles' corners, in BVH order.
    tris: Vec<[DVec3; 3]>,
    nodes: Vec<Node>,
}

impl MeshSdf {
    pub fn new(mesh: &TriangleMesh) -> MeshSdf {
        let mut tris: Vec<[DVec3; 3]> =
            mesh.triangles.iter().map(|t| t.map(|v| mesh.positions[v as usize])).collect();
        let mut nodes = Vec::with_capacity(2 * tris.len() / LEAF_SIZE + 1);
        let n = tris.len();
        build(&mut tris, 0, n, &mut nodes);
        MeshSdf { tris, nodes }
    }

    /// Signed distance at `p`: negative inside (|winding number| above 1/2).
    pub fn distance(&self, p: DVec3) -> f64 {
        let d = self.unsigned_distance(p);
        if self.winding_number(p).abs() > 0.5 {
            -d
        } else {
            d
        }
    }

    /// Distance from `p` to the nearest point of the mesh.
    pub fn unsigned_distance(&self, p: DVec3) -> f64 {
        let mut best = f64::INFINITY;
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            if box_distance2(p, node.lo, node.hi) >= best {
                continue;
            }
            if node.count > 0 {
                for t in &self.tris[node.first as usize..(node.first + node.count) as usize] {
                    best = best.min((closest_point(p, t[0], t[1], t[2]) - p).length_squared());
                }
            } else {
                let (l, r) = (node.first, node.right);
                let dl = box_distance2(p, self.nodes[l as usize].lo, self.nodes[l as usize].hi);
                let dr = box_distance2(p, self.nodes[r as usize].lo, self.nodes[r as usize].hi);
                // Nearer child last, so it is visited first.
                if dl < dr {
                    stack.extend([r, l]);
                } else {
                    stack.extend([l, r]);
                }
            }
        }
        best.sqrt()
    }

    /// The generalised winding number at `p`.
    pub fn winding_number(&self, p: DVec3) -> f64 {
        let mut solid = 0.0;
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            let r = node.centre - p;
            let dist = r.length();
            if dist > FAR_FIELD * node.radius {
                solid += node.area_normal.dot(r) / (dist * dist * dist);
            } else if node.count > 0 {
                for t in &self.tris[node.first as usize..(node.first + node.count) as usize] {
                    solid += solid_angle(t[0] - p, t[1] - p, t[2] - p);
                }
            } else {
                stack.extend([node.first, node.right]);
            }
        }
        solid / (4.0 * PI)
    }
}

/// Builds the subtree over `tris[start..end]`, returns its node index.
fn build(tris: &mut [[DVec3; 3]], start: usize, end: usize, nodes: &mut Vec<Node>) -> u32 {
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let (mut clo, mut chi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let (mut area_sum, mut weighted, mut area_normal) = (0.0, DVec3::ZERO, DVec3::ZERO);
    for t in &tris[start..end] {
        let c = (t[0] + t[1] + t[2]) / 3.0;
        for v in t {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
        clo = clo.min(c);
        chi = chi.max(c);
        let an = 0.5 * (t[1] - t[0]).cross(t[2] - t[0]);
        let area = an.length();
        area_sum += area;
        weighted += area * c;
        area_normal += an;
    }
    let centre = if area_sum > 0.0 { weighted / area_sum } else { 0.5 * (lo + hi) };
    let radius = (0..8)
        .map(|k| {
            let corner = DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            (corner - centre).length()
        })
        .fold(0.0, f64::max);
    let index = nodes.len() as u32;
    nodes.push(Node {
        lo,
        hi,
        first: start as u32,
        count: (end - start) as u32,
        right: 0,
        centre,
        area_normal,
        radius,
    });
    if end - start <= LEAF_SIZE {
        return index;
    }
    // Median split along the longest axis of the centroids' box.
    let axis = (chi - clo).to_array().iter().enumerate().fold(0, |best, (a, &e)| {
        if e > (chi - clo)[best] {
            a
        } else {
            best
        }
    });
    let mid = start + (end - start) / 2;
    let key = |t: &[DVec3; 3]| t[0][axis] + t[1][axis] + t[2][axis];
    tris[start..end].select_nth_unstable_by(mid - start, |a, b| key(a).total_cmp(&key(b)));
    let left = build(tris, start, mid, nodes);
    let right = build(tris, mid, end, nodes);
    let node = &mut nodes[index as usize];
    node.first = left;
    node.count = 0;
    node.right = right;
    index
}

/// Squared distance from `p` to the box `[lo, hi]` (0 inside).
fn box_distance2(p: DVec3, lo: DVec3, hi: DVec3) -> f64 {
    (lo - p).max(p - hi).max(DVec3::ZERO).length_squared()
}

/// The point of triangle (a, b, c) closest to `p` (Ericson 5.1.5: by the Voronoi regions of the
/// vertices, edges and face).
pub fn closest_point(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom == 0.0 {
        // Degenerate (zero-area) triangle: the nearest of its three edges.
        let seg = |u: DVec3, v: DVec3| {
            let e = v - u;
            let s = if e.length_squared() > 0.0 {
                ((p - u).dot(e) / e.length_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            u + e * s
        };
        return [seg(a, b), seg(b, c), seg(c, a)]
            .into_iter()
            .min_by(|x, y| (*x - p).length_squared().total_cmp(&(*y - p).length_squared()))
            .unwrap_or(a);
    }
    a + ab * (vb / denom) + ac * (vc / denom)
}

/// Signed solid angle of triangle (a, b, c) seen from the origin (Van Oosterom and Strackee
/// 1983): positive when the triangle winds counter-clockwise seen from the origin's far side,
/// i.e. when its normal points away from the origin.
pub fn solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let det = a.dot(b.cross(c));
    let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    2.0 * det.atan2(den)
}

/// A validated mesh source: the file and its triangles (read once, at scene load).
#[derive(Clone, Debug)]
pub struct MeshSource {
    pub path: PathBuf,
    pub mesh: Arc<TriangleMesh>,
}

impl MeshSource {
    /// Reads the mesh file `path`, of the format `named` (the name written) says, opened as
    /// `access` says.
    pub fn open(path: &Path, named: &Path, access: &DataAccess) -> Result<MeshSource, FieldError> {
        let mesh = TriangleMesh::read_named(path, named, access)?;
        Ok(MeshSource { path: path.to_path_buf(), mesh: Arc::new(mesh) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An octahedron with vertices at distance 1 on the axes, wound outward.
    fn octahedron() -> TriangleMesh {
        let positions =
            vec![DVec3::X, DVec3::NEG_X, DVec3::Y, DVec3::NEG_Y, DVec3::Z, DVec3::NEG_Z];
        let mut triangles = Vec::new();
        for (x, y, z) in [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4)] {
            triangles.push([x, y, z]);
        }
        for (x, y, z) in [(2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)] {
            triangles.push([x, y, z]);
        }
        TriangleMesh { positions, triangles }
    }

    #[test]
    fn octahedron_distance_and_winding_are_exact() {
        let sdf = MeshSdf::new(&octahedron());
        // Faces lie in |x| + |y| + |z| = 1, at distance 1/sqrt(3) from the centre.
        assert!((sdf.distance(DVec3::ZERO) + 1.0 / 3f64.sqrt()).abs() < 1e-12);
        assert!((sdf.winding_number(DVec3::ZERO) - 1.0).abs() < 1e-12);
        assert!(sdf.winding_number(DVec3::new(2.0, 0.3, 0.1)).abs() < 1e-12);
        // Beyond a vertex: the distance to that vertex.
        assert!((sdf.distance(DVec3::new(0.0, 3.0, 0.0)) - 2.0).abs() < 1e-12);
        // Beyond an edge's midpoint (0.5, 0.5, 0) along (1, 1, 0).
        let p = DVec3::new(1.0, 1.0, 0.0);
        assert!((sdf.distance(p) - (p - DVec3::new(0.5, 0.5, 0.0)).length()).abs() < 1e-12);
    }

    #[test]
    fn bvh_queries_match_brute_force_on_a_fine_mesh() {
        // A UV sphere of 40 x 20 quads, radius 0.8.
        let (nu, nv) = (40, 20);
        let mut positions = vec![DVec3::new(0.0, 0.0, -0.8), DVec3::new(0.0, 0.0, 0.8)];
        for j in 1..nv {
            for i in 0..nu {
                let (th, ph) = (PI * j as f64 / nv as f64, 2.0 * PI * i as f64 / nu as f64);
                positions
                    .push(0.8 * DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), -th.cos()));
            }
        }
        let ring = |j: u32, i: u32| 2 + (j - 1) * nu + (i % nu);
        let mut triangles = Vec::new();
        for i in 0..nu {
            triangles.push([0, ring(1, i + 1), ring(1, i)]);
            triangles.push([1, ring(nv - 1, i), ring(nv - 1, i + 1)]);
            for j in 1..nv - 1 {
                let (a, b, c, d) = (ring(j, i), ring(j, i + 1), ring(j + 1, i + 1), ring(j + 1, i));
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            }
        }
        let mesh = TriangleMesh { positions, triangles };
        let sdf = MeshSdf::new(&mesh);
        let mut seed = 1u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 3.0 - 1.5
        };
        for _ in 0..300 {
            let p = DVec3::new(rnd(), rnd(), rnd());
            let brute = mesh
                .triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
                    (closest_point(p, a, b, c) - p).length()
                })
                .fold(f64::INFINITY, f64::min);
            let exact_w: f64 = mesh
                .triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|v| mesh.positions[v as usize] - p);
                    solid_angle(a, b, c)
                })
                .sum::<f64>()
                / (4.0 * PI);
            assert!((sdf.unsigned_distance(p) - brute).abs() < 1e-12, "{p}");
            let w = sdf.winding_number(p);
            assert!((w - exact_w).abs() < 0.05, "{p}: {w} vs {exact_w}");
            // The faces lie between radius 0.8 cos(9°) ≈ 0.79 and 0.8.
            if p.length() < 0.78 || p.length() > 0.8 {
                assert_eq!(w > 0.5, p.length() < 0.78, "{p}: winding {w}");
            }
        }
    }

    #[test]
    fn grid_is_cubic_with_the_margin_on_the_longest_axis() {
        let (dims, b) = grid_for(DVec3::new(0.0, 0.0, 0.0), DVec3::new(2.0, 1.0, 0.5), 23);
        assert_eq!(dims[0], 23);
        let h = (b.max - b.min) / DVec3::new(22.0, (dims[1] - 1) as f64, (dims[2] - 1) as f64);
        assert!((h.x - h.y).abs() < 1e-12 && (h.x - h.z).abs() < 1e-12);
        assert!((b.min.x + 0.1).abs() < 1e-12 && (b.max.x - 2.1).abs() < 1e-12);
        assert!(b.min.y <= -0.1 + 1e-12 && b.max.y >= 1.1 - 1e-12);
        assert!(b.min.z <= -0.1 + 1e-12 && b.max.z >= 0.6 - 1e-12);
    }
}
