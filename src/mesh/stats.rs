//! Mesh statistics: size, area, enclosed volume, topology defects and triangle quality.
//!
//! Topology is combinatorial (by vertex index, not position): an undirected edge used by one
//! triangle is a boundary edge, by more than two a non-manifold edge, and by exactly two that
//! traverse it in the same direction an orientation-inconsistent edge. A closed, consistently
//! oriented 2-manifold has none of the three.
//!
//! The edges are counted in passes over the triangles, each pass holding the half-edges whose
//! lower vertex lies in one range of vertex ids, sorted, 8 bytes each ([`pass_size`]: an
//! eighth of them, or [`MIN_EDGE_PASS`] for small meshes): about an eighth of the mesh's own
//! bytes, where a table of every edge took about three times the mesh (`extract --stats` of 53
//! million triangles held 3 GB more than `extract`). The counts do not depend on the passes.

use std::fmt;
use std::io::{self, BufReader, Read, Seek, SeekFrom, Write};

use glam::DVec3;
use rayon::slice::ParallelSliceMut;

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

/// Half-edges one pass of the edge count may hold however small the mesh: 8 MiB of keys.
pub const MIN_EDGE_PASS: usize = 1 << 20;

/// Half-edges a pass of the edge count holds for a mesh of `indices` triangle indices: an
/// eighth of them (eight passes; about an eighth of the mesh's bytes), at least
/// [`MIN_EDGE_PASS`].
pub fn pass_size(indices: usize) -> usize {
    (indices / 8).max(MIN_EDGE_PASS)
}

/// A mesh's triangles in order, as many times as asked: what the statistics read besides the
/// positions (the edge count reads them once per pass).
pub trait Triangles {
    /// Calls `f` with every triangle, in order.
    fn each(&mut self, f: &mut dyn FnMut([u32; 3])) -> io::Result<()>;
}

/// The triangles of an index list (`Mesh::indices`).
impl Triangles for &[u32] {
    fn each(&mut self, f: &mut dyn FnMut([u32; 3])) -> io::Result<()> {
        self.chunks_exact(3).for_each(|t| f([t[0], t[1], t[2]]));
        Ok(())
    }
}

/// Triangles stored as little-endian `u32` triples ([`write_triangles`]) in a file or any
/// reader that can go back to its start: a streamed mesh's, read again for each pass.
pub struct TriangleFile<R: Read + Seek>(pub R);

impl<R: Read + Seek> Triangles for TriangleFile<R> {
    fn each(&mut self, f: &mut dyn FnMut([u32; 3])) -> io::Result<()> {
        self.0.seek(SeekFrom::Start(0))?;
        let mut r = BufReader::with_capacity(1 << 20, &mut self.0);
        let mut t = [0u8; 12];
        loop {
            match r.read_exact(&mut t) {
                Ok(()) => {}
                Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => return Ok(()),
                Err(e) => return Err(e),
            }
            let word =
                |i: usize| u32::from_le_bytes([t[4 * i], t[4 * i + 1], t[4 * i + 2], t[4 * i + 3]]);
            f([word(0), word(1), word(2)]);
        }
    }
}

/// Appends `indices` (whole triangles) to `w` as [`TriangleFile`] reads them.
pub fn write_triangles(w: &mut impl Write, indices: &[u32]) -> io::Result<()> {
    let bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    w.write_all(&bytes)
}

/// Computes the statistics of `mesh`'s triangles (its quads, if any, are not looked at).
pub fn compute(mesh: &Mesh) -> MeshStats {
    compute_in_passes(mesh, pass_size(mesh.indices.len()))
}

/// [`compute`] holding at most `max_half_edges` half-edges per pass of the edge count (about;
/// at least one block of vertex ids, [`EdgeCount::plan`]).
pub fn compute_in_passes(mesh: &Mesh, max_half_edges: usize) -> MeshStats {
    compute_from(&mesh.positions, &mut mesh.indices.as_slice(), max_half_edges)
        .expect("an index list is read without I/O")
}

/// The statistics of the mesh of `positions` and `triangles` (see [`compute_in_passes`]); the
/// positions are all a mesh must hold, the triangles are read `2 +` (number of passes) times.
pub fn compute_from(
    positions: &[[f32; 3]],
    triangles: &mut dyn Triangles,
    max_half_edges: usize,
) -> io::Result<MeshStats> {
    let mut s = MeshStats { vertices: positions.len(), ..Default::default() };
    let mut used = vec![false; positions.len()];
    let (lo, hi) = positions.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
        let p = DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
        (lo.min(p), hi.max(p))
    });
    let origin = if lo.is_finite() { 0.5 * (lo + hi) } else { DVec3::ZERO };
    let pos = |v: u32| DVec3::from(positions[v as usize].map(f64::from));
    triangles.each(&mut |tri| {
        s.triangles += 1;
        for &v in &tri {
            used[v as usize] = true;
        }
        let [a, b, c] = tri.map(pos);
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
    })?;
    let edges = EdgeCount::of(positions.len(), triangles, max_half_edges)?;
    s.edges = edges.edges;
    s.boundary_edges = edges.boundary;
    s.non_manifold_edges = edges.non_manifold;
    s.inconsistent_edges = edges.inconsistent;
    let referenced = used.iter().filter(|&&u| u).count();
    s.unreferenced_vertices = s.vertices - referenced;
    s.euler_characteristic = referenced as i64 - s.edges as i64 + s.triangles as i64;
    Ok(s)
}

/// The undirected edges of a mesh's triangles by how they are used.
#[derive(Debug, Default, PartialEq)]
struct EdgeCount {
    edges: usize,
    /// Used by one triangle.
    boundary: usize,
    /// Used by more than two.
    non_manifold: usize,
    /// Used by two that traverse it in the same direction.
    inconsistent: usize,
}

/// Blocks of vertex ids that [`EdgeCount::plan`] groups into passes: fine enough that a pass
/// rarely overshoots its bound by much, coarse enough that the histogram is tiny.
const BLOCKS: usize = 4096;

/// Vertex ids one pass may span: the id less the pass's first takes 31 bits of a key.
const PASS_SPAN: usize = 1 << 31;

impl EdgeCount {
    /// The half-edges `(p, q)` of a triangle, `p != q` (a repeated index makes no edge).
    fn half_edges(t: [u32; 3]) -> impl Iterator<Item = (u32, u32)> {
        [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])].into_iter().filter(|(p, q)| p != q)
    }

    /// Counts the edges of `triangles` over `vertices` vertices in passes of at most about
    /// `max_half_edges` half-edges.
    fn of(
        vertices: usize,
        triangles: &mut dyn Triangles,
        max_half_edges: usize,
    ) -> io::Result<EdgeCount> {
        let mut count = EdgeCount::default();
        let passes = Self::plan(vertices, triangles, max_half_edges)?;
        // Allocated once at the largest pass's size: grown by doubling it could reach twice that.
        let mut keys = Vec::with_capacity(passes.iter().map(|p| p.1).max().unwrap_or(0));
        for (ids, _) in passes {
            keys.clear();
            // The undirected edge (lo, hi) as (lo - first) << 33 | hi << 1, the low bit set
            // for a use in the lo -> hi direction: sorted, an edge's uses are one run.
            triangles.each(&mut |t| {
                for (p, q) in Self::half_edges(t) {
                    let lo = p.min(q) as usize;
                    if ids.contains(&lo) {
                        let key = ((lo - ids.start) as u64) << 33 | u64::from(p.max(q)) << 1;
                        keys.push(key | u64::from(p < q));
                    }
                }
            })?;
            keys.par_sort_unstable();
            for run in keys.chunk_by(|a, b| a >> 1 == b >> 1) {
                count.edges += 1;
                let forward = run.iter().filter(|&&k| k & 1 == 1).count();
                match run.len() {
                    1 => count.boundary += 1,
                    2 if forward != 1 => count.inconsistent += 1,
                    2 => {}
                    _ => count.non_manifold += 1,
                }
            }
        }
        Ok(count)
    }

    /// The ranges of lower-vertex ids of the passes and their half-edges: consecutive blocks
    /// of ids grouped while their half-edges stay within `max_half_edges` (a block alone may
    /// pass it) and their ids within [`PASS_SPAN`].
    #[allow(clippy::type_complexity)]
    fn plan(
        vertices: usize,
        triangles: &mut dyn Triangles,
        max_half_edges: usize,
    ) -> io::Result<Vec<(std::ops::Range<usize>, usize)>> {
        let nv = vertices;
        let block = nv.div_ceil(BLOCKS).max(1);
        let mut per_block = vec![0usize; nv.div_ceil(block)];
        triangles.each(&mut |t| {
            for (p, q) in Self::half_edges(t) {
                per_block[p.min(q) as usize / block] += 1;
            }
        })?;
        let mut passes: Vec<(std::ops::Range<usize>, usize)> = Vec::new();
        for (b, &n) in per_block.iter().enumerate() {
            let ids = b * block..((b + 1) * block).min(nv);
            match passes.last_mut() {
                Some((last, held))
                    if *held + n <= max_half_edges && ids.end - last.start <= PASS_SPAN =>
                {
                    last.end = ids.end;
                    *held += n;
                }
                _ => passes.push((ids, n)),
            }
        }
        Ok(passes)
    }
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

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::*;

    /// The edge count as a table of every edge: the definition the passes must agree with.
    fn by_table(mesh: &Mesh) -> EdgeCount {
        // Undirected edge (lo, hi) -> (uses, uses in the lo -> hi direction).
        let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
        for t in mesh.indices.chunks_exact(3) {
            for (p, q) in EdgeCount::half_edges([t[0], t[1], t[2]]) {
                let entry = edges.entry((p.min(q), p.max(q))).or_insert((0, 0));
                entry.0 += 1;
                entry.1 += u32::from(p < q);
            }
        }
        let mut c = EdgeCount { edges: edges.len(), ..Default::default() };
        for &(uses, forward) in edges.values() {
            match uses {
                1 => c.boundary += 1,
                2 if forward != 1 => c.inconsistent += 1,
                2 => {}
                _ => c.non_manifold += 1,
            }
        }
        c
    }

    /// A mesh of `nv` vertices and `nt` triangles whose corners are drawn (a linear
    /// congruential generator) from a window of nearby ids, so that edges repeat: boundary,
    /// manifold, inconsistent and non-manifold edges and repeated indices all occur.
    fn scrambled(nv: usize, nt: usize, seed: u64) -> Mesh {
        let mut state = seed;
        let mut next = |n: usize| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 33) as usize % n
        };
        let mut indices = Vec::with_capacity(3 * nt);
        for _ in 0..nt {
            let base = next(nv);
            for _ in 0..3 {
                indices.push(((base + next(5)) % nv) as u32);
            }
        }
        let positions = (0..nv).map(|i| [i as f32, (i * i % 7) as f32, (i % 3) as f32]).collect();
        Mesh { positions, normals: vec![[0.0, 0.0, 1.0]; nv], indices, quads: None }
    }

    #[test]
    fn edge_passes_count_what_a_table_of_every_edge_counts() {
        for (nv, nt, seed) in [(1, 1, 1), (5, 3, 2), (40, 200, 3), (9000, 30000, 4)] {
            let mesh = scrambled(nv, nt, seed);
            let want = by_table(&mesh);
            if nt > 100 {
                let every_kind = [want.boundary, want.non_manifold, want.inconsistent];
                assert!(every_kind.iter().all(|&n| n > 0), "{want:?}");
            }
            for max in [1, 2, 7, 100, 5000, MIN_EDGE_PASS] {
                let nv = mesh.vertex_count();
                let passes = EdgeCount::plan(nv, &mut mesh.indices.as_slice(), max).unwrap();
                let got = EdgeCount::of(nv, &mut mesh.indices.as_slice(), max).unwrap();
                assert_eq!(got, want, "{nv} vertices, {nt} triangles, {max} per pass");
                if max == 1 && nv > BLOCKS {
                    assert!(passes.len() > 1000, "{}", passes.len());
                }
                // The passes cover every id once, in order.
                let ids: Vec<usize> = passes.into_iter().flat_map(|p| p.0).collect();
                assert_eq!(ids, (0..nv).collect::<Vec<_>>());
            }
            let whole = compute(&mesh);
            assert_eq!(compute_in_passes(&mesh, 1), whole);
            // From a file of the triangles, as a streamed mesh's are read back.
            let mut file = Vec::new();
            write_triangles(&mut file, &mesh.indices).unwrap();
            let mut read = TriangleFile(std::io::Cursor::new(file));
            assert_eq!(compute_from(&mesh.positions, &mut read, 7).unwrap(), whole);
            assert_eq!(
                (whole.edges, whole.boundary_edges, whole.non_manifold_edges),
                (want.edges, want.boundary, want.non_manifold)
            );
            assert_eq!(whole.inconsistent_edges, want.inconsistent);
        }
        assert_eq!(EdgeCount::of(0, &mut [].as_slice(), 1).unwrap(), EdgeCount::default());
    }
}
