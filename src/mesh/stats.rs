//! Mesh statistics: size, area, enclosed volume, topology defects and triangle quality.
//!
//! Topology is combinatorial (by vertex index, not position): an undirected edge used by one
//! triangle is a boundary edge, by more than two a non-manifold edge, and by exactly two that
//! traverse it in the same direction an orientation-inconsistent edge. A closed, consistently
//! oriented 2-manifold has none of the three.

use std::collections::HashMap;
use std::fmt;

use glam::DVec3;

use super::Mesh;

/// Number of 10° bins of [`MeshStats::min_angle_histogram`] (a triangle's smallest angle is at
/// most 60°).
pub const ANGLE_BINS: usize = 6;

#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshStats {
    pub vertices: usize,
    pub triangles: usize,
    /// Vertices no triangle uses.
    pub unreferenced_vertices: usize,
    /// Distinct undirected edges.
    pub edges: usize,
    /// Total area, world units squared.
    pub area: f64,
    /// Signed enclosed volume by the divergence theorem, world units cubed: positive for a
    /// closed mesh wound counter-clockwise seen from outside; meaningless for an open one.
    pub volume: f64,
    /// Edges used by exactly one triangle.
    pub boundary_edges: usize,
    /// Edges used by more than two triangles.
    pub non_manifold_edges: usize,
    /// Edges used by exactly two triangles that traverse it in the same direction.
    pub inconsistent_edges: usize,
    /// Triangles whose area is exactly zero (in f64 from the f32 positions), including those
    /// with a repeated vertex index.
    pub zero_area_triangles: usize,
    /// `V - E + F` over the referenced vertices: 2 per sphere-like closed component, 0 per torus.
    pub euler_characteristic: i64,
    /// Triangles by their smallest angle in 10° bins: `[0°, 10°), [10°, 20°), …, [50°, 60°]`.
    pub min_angle_histogram: [usize; ANGLE_BINS],
}

impl MeshStats {
    /// True when every edge is shared by exactly two consistently oriented triangles.
    pub fn is_closed_manifold(&self) -> bool {
        self.boundary_edges == 0 && self.non_manifold_edges == 0 && self.inconsistent_edges == 0
    }
}

fn pos(mesh: &Mesh, v: u32) -> DVec3 {
    let p = mesh.positions[v as usize];
    DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))
}

/// Smallest interior angle of a triangle, degrees (0 for a degenerate one).
fn min_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let angle = |p: DVec3, q: DVec3, r: DVec3| {
        let (u, v) = (q - p, r - p);
        let d = u.length() * v.length();
        if d > 0.0 {
            (u.dot(v) / d).clamp(-1.0, 1.0).acos().to_degrees()
        } else {
            0.0
        }
    };
    angle(a, b, c).min(angle(b, c, a)).min(angle(c, a, b))
}

/// Computes the statistics of `mesh`'s triangles (its quads, if any, are not looked at).
pub fn compute(mesh: &Mesh) -> MeshStats {
    let mut s = MeshStats {
        vertices: mesh.vertex_count(),
        triangles: mesh.triangle_count(),
        ..Default::default()
    };
    let mut used = vec![false; mesh.vertex_count()];
    // Undirected edge (lo, hi) -> (uses, uses in the lo -> hi direction).
    let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::with_capacity(mesh.indices.len());
    let (lo, hi) =
        mesh.positions.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            let p = DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
            (lo.min(p), hi.max(p))
        });
    let origin = if lo.is_finite() { 0.5 * (lo + hi) } else { DVec3::ZERO };
    for t in 0..mesh.triangle_count() {
        let tri = mesh.triangle(t);
        for &v in &tri {
            used[v as usize] = true;
        }
        let [a, b, c] = tri.map(|v| pos(mesh, v));
        let cross = (b - a).cross(c - a);
        let area2 = cross.length();
        s.area += 0.5 * area2;
        s.volume += (a - origin).dot((b - origin).cross(c - origin)) / 6.0;
        let degenerate = area2 == 0.0 || tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0];
        if degenerate {
            s.zero_area_triangles += 1;
        }
        let angle = if degenerate { 0.0 } else { min_angle(a, b, c) };
        let bin = ((angle / 10.0) as usize).min(ANGLE_BINS - 1);
        s.min_angle_histogram[bin] += 1;
        for e in 0..3 {
            let (p, q) = (tri[e], tri[(e + 1) % 3]);
            if p == q {
                continue;
            }
            let entry = edges.entry((p.min(q), p.max(q))).or_insert((0, 0));
            entry.0 += 1;
            if p < q {
                entry.1 += 1;
            }
        }
    }
    s.edges = edges.len();
    for &(uses, forward) in edges.values() {
        match uses {
            1 => s.boundary_edges += 1,
            2 if forward != 1 => s.inconsistent_edges += 1,
            2 => {}
            _ => s.non_manifold_edges += 1,
        }
    }
    let referenced = used.iter().filter(|&&u| u).count();
    s.unreferenced_vertices = s.vertices - referenced;
    s.euler_characteristic = referenced as i64 - s.edges as i64 + s.triangles as i64;
    s
}

impl fmt::Display for MeshStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "vertices: {}", self.vertices)?;
        writeln!(f, "triangles: {}", self.triangles)?;
        writeln!(f, "unreferenced vertices: {}", self.unreferenced_vertices)?;
        writeln!(f, "edges: {}", self.edges)?;
        writeln!(f, "area: {}", self.area)?;
        writeln!(f, "volume: {}", self.volume)?;
        writeln!(f, "boundary edges: {}", self.boundary_edges)?;
        writeln!(f, "non-manifold edges: {}", self.non_manifold_edges)?;
        writeln!(f, "orientation-inconsistent edges: {}", self.inconsistent_edges)?;
        writeln!(f, "zero-area triangles: {}", self.zero_area_triangles)?;
        writeln!(f, "euler characteristic: {}", self.euler_characteristic)?;
        write!(f, "min-angle histogram:")?;
        for (b, n) in self.min_angle_histogram.iter().enumerate() {
            write!(f, " [{}-{}°): {}", 10 * b, 10 * (b + 1), n)?;
        }
        Ok(())
    }
}
