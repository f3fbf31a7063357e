//! Vertices on lattice edges, numbered in edge-id order, two point layers at a time.
//!
//! A lattice edge starts at grid point `p` and goes to `p + d` for an offset `d` from a fixed
//! list of *families* (x, y, z for marching cubes; the 7 families of marching tetrahedra). Its
//! id is `families.len() * p + f` for family `f`. Each crossed edge owns one vertex, and vertices
//! are numbered in increasing edge id: a GPU reproduces this with one flag per edge and an
//! exclusive prefix sum over edge ids. The extractor sweeps the grid in z: it numbers the
//! edges starting in point layer `k + 1` before it emits the triangles of cell layer `k`,
//! keeping two layers of ids, so memory is `O(nx * ny)`.

use std::ops::Range;

use glam::DVec3;

use super::field::{Field, MISSING};
use super::{to_u32, MeshError};

/// Vertex positions and normals under construction.
#[derive(Default)]
pub(crate) struct Vertices {
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
}

impl Vertices {
    /// Appends a vertex at index-space `u` with the field normal there, returning its id.
    pub fn push(&mut self, f: &Field, u: DVec3, fallback: DVec3) -> Result<u32, MeshError> {
        let id = to_u32(self.positions.len(), "vertices")?;
        self.positions.push(f.world(u));
        self.normals.push(f.normal(u, fallback));
        Ok(id)
    }

    /// Appends a vertex at index-space `u` with the field normal at `at`, returning its id.
    pub fn push_normal_at(
        &mut self,
        f: &Field,
        u: DVec3,
        at: DVec3,
        fallback: DVec3,
    ) -> Result<u32, MeshError> {
        let id = to_u32(self.positions.len(), "vertices")?;
        self.positions.push(f.world(u));
        self.normals.push(f.normal(at, fallback));
        Ok(id)
    }

    /// Appends the position of a vertex that belongs to the next slab, without a normal,
    /// returning its id: the dual methods' quad split reads it. [`Vertices::drop_borrowed`]
    /// removes these before the slab's vertices are joined.
    pub fn push_borrowed(&mut self, f: &Field, u: DVec3) -> Result<u32, MeshError> {
        let id = to_u32(self.positions.len(), "vertices")?;
        self.positions.push(f.world(u));
        Ok(id)
    }

    /// Drops the positions appended by [`Vertices::push_borrowed`] (they follow every vertex
    /// with a normal).
    pub fn drop_borrowed(&mut self) {
        self.positions.truncate(self.normals.len());
    }
}

/// Offset of an edge family given as corner bits (x = 1, y = 2, z = 4).
pub(crate) fn offset(bits: u8) -> [usize; 3] {
    [usize::from(bits & 1), usize::from((bits >> 1) & 1), usize::from((bits >> 2) & 1)]
}

pub(crate) struct EdgeLayers<'f, 'g> {
    f: &'f Field<'g>,
    /// Offset bits of each family.
    families: &'static [u8],
    /// Vertex id of each edge starting in point layers `k` (slot `k % 2`), `u32::MAX` if the
    /// edge is not crossed.
    ids: [Vec<u32>; 2],
    /// The inside rule at each point of point layer `k` (slot `k % 2`), 1 or 0: the crossing
    /// tests and the cells' corner masks read these instead of testing samples again.
    inside: [Vec<u8>; 2],
    /// The inside rule at each point of the layer above the last one built (its families
    /// that climb in z end there).
    above: Vec<u8>,
    /// Scratch of [`EdgeLayers::layer`]: nonzero at the points of a layer with a crossed edge.
    any: Vec<u8>,
}

impl<'f, 'g> EdgeLayers<'f, 'g> {
    pub fn new(f: &'f Field<'g>, families: &'static [u8]) -> Self {
        let layer = f.dims[0] * f.dims[1];
        let n = layer * families.len();
        EdgeLayers {
            f,
            families,
            ids: [vec![u32::MAX; n], vec![u32::MAX; n]],
            inside: [vec![0; layer], vec![0; layer]],
            above: vec![0; layer],
            any: Vec::new(),
        }
    }

    /// Creates the vertices of the crossed edges that start in point layer `k`, in edge-id
    /// order.
    pub fn build(&mut self, k: usize, verts: &mut Vertices) -> Result<(), MeshError> {
        let f = self.f;
        self.layer(k, |u, out_dir| verts.push(f, u, out_dir))
    }

    /// Numbers the crossed edges that start in point layer `k` from `first` on, in edge-id
    /// order, without creating their vertices: the layer belongs to the next slab, whose own
    /// numbering of it starts where this slab's vertices end (see `slabs`).
    pub fn number(&mut self, k: usize, first: usize) -> Result<(), MeshError> {
        let mut next = first;
        self.layer(k, |_, _| {
            let id = to_u32(next, "vertices")?;
            next += 1;
            Ok(id)
        })
    }

    /// Readies the edges of cell layer `k` of the slab of cell layers `cells` (point layer
    /// `cells.start` already built): point layer `k + 1` is built when the slab owns it (inside
    /// the slab, or the grid's top layer), else only numbered after this slab's vertices, as
    /// the next slab, which owns it, numbers it (see `slabs`).
    pub fn enter_cell_layer(
        &mut self,
        k: usize,
        cells: &Range<usize>,
        verts: &mut Vertices,
    ) -> Result<(), MeshError> {
        if k + 1 < cells.end || cells.end == self.f.dims[2] - 1 {
            self.build(k + 1, verts)
        } else {
            self.number(k + 1, verts.positions.len())
        }
    }

    /// Gives each crossed edge starting in point layer `k`, in edge-id order, the id that
    /// `vertex(u, out_dir)` returns for its crossing point `u` (index space) and its inside →
    /// outside direction.
    fn layer(
        &mut self,
        k: usize,
        mut vertex: impl FnMut(DVec3, DVec3) -> Result<u32, MeshError>,
    ) -> Result<(), MeshError> {
        let f = self.f;
        let [nx, ny, nz] = f.dims;
        let nf = self.families.len();
        let here = f.layer(k);
        f.inside_flags(here, &mut self.inside[k % 2]);
        let there = if k + 1 < nz { f.layer(k + 1) } else { &[] };
        f.inside_flags(there, &mut self.above);
        let (ins, above) = (&self.inside[k % 2], &self.above);
        // Points with a crossed edge of any family, found with whole-row passes that the
        // compiler vectorises: most points have none, and the loop below skips them.
        let any = &mut self.any;
        any.clear();
        any.resize(nx * ny, 0);
        for &bits in self.families {
            let d = offset(bits);
            if k + d[2] >= nz || d[0] >= nx || d[1] >= ny {
                continue;
            }
            let flags = if d[2] == 0 { ins } else { above };
            let shift = d[0] + nx * d[1];
            for j in 0..ny - d[1] {
                let row = nx * j..nx * j + nx - d[0];
                let (a, b) = (&ins[row.clone()], &flags[row.start + shift..row.end + shift]);
                for ((x, &a), &b) in any[row].iter_mut().zip(a).zip(b) {
                    *x |= a ^ b;
                }
            }
        }
        let ids = &mut self.ids[k % 2];
        ids.fill(u32::MAX);
        for (p, _) in any.iter().enumerate().filter(|(_, &x)| x != 0) {
            let (i, j) = (p % nx, p / nx);
            let ina = ins[p];
            for (fam, &bits) in self.families.iter().enumerate() {
                let d = offset(bits);
                let (ib, jb) = (i + d[0], j + d[1]);
                if ib >= nx || jb >= ny || k + d[2] >= nz {
                    continue;
                }
                let (flags, values) = if d[2] == 0 { (ins, here) } else { (above, there) };
                let q = ib + nx * jb;
                // Not crossed: both ends on one side, or an end missing (no finite cell holds
                // the edge, so it has no vertex).
                if flags[q] == ina || (flags[q] | ina) & MISSING != 0 {
                    continue;
                }
                let s = f.crossing_on([i, j, k], d, f64::from(here[p]), f64::from(values[q]));
                let dv = DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64);
                let u = DVec3::new(i as f64, j as f64, k as f64) + s * dv;
                let out_dir = if ina == 1 { dv } else { -dv };
                ids[nf * p + fam] = vertex(u, out_dir)?;
            }
        }
        Ok(())
    }

    /// Nonzero for each cell of row `j` of cell layer `k` (into `out`, `nx - 1` long) that
    /// has corners on both sides (or some missing, some not: [`EdgeLayers::cell_missing`]
    /// tells), from the flags of point layers `k` and `k + 1` (see
    /// [`EdgeLayers::corner_mask`]).
    pub fn active_cells(&self, j: usize, k: usize, out: &mut [u8]) {
        let nx = self.f.dims[0];
        cell_row_differs(&self.inside[k % 2], &self.inside[(k + 1) % 2], nx * j, nx, out);
    }

    /// Whether cell `(i, j, k)` is missing (a corner's flag is [`MISSING`]): it has no
    /// triangle. From the flags of point layers `k` and `k + 1`, as [`EdgeLayers::corner_mask`].
    #[inline]
    pub fn cell_missing(&self, i: usize, j: usize, k: usize) -> bool {
        let nx = self.f.dims[0];
        let (lo, hi) = (&self.inside[k % 2], &self.inside[(k + 1) % 2]);
        let p = i + nx * j;
        let (a, b) = (p + nx, p + 1);
        (lo[p] | lo[b] | lo[a] | lo[a + 1] | hi[p] | hi[b] | hi[a] | hi[a + 1]) & MISSING != 0
    }

    /// Bitmask of the inside corners of cell `(i, j, k)` (bit `n` for corner `n`, as
    /// [`Field::corner_mask`]), from the flags of point layers `k` and `k + 1`, both of which
    /// must have been built or numbered last; the cell must not be missing
    /// ([`EdgeLayers::cell_missing`]).
    #[inline]
    pub fn corner_mask(&self, i: usize, j: usize, k: usize) -> u8 {
        let nx = self.f.dims[0];
        let (lo, hi) = (&self.inside[k % 2], &self.inside[(k + 1) % 2]);
        let p = i + nx * j;
        let (a, b) = (p + nx, p + 1);
        lo[p]
            | lo[b] << 1
            | lo[a] << 2
            | lo[a + 1] << 3
            | hi[p] << 4
            | hi[b] << 5
            | hi[a] << 6
            | hi[a + 1] << 7
    }

    /// Vertex id of the edge of family `fam` starting at point `(i, j, k)`, which must lie in
    /// one of the two layers held and be crossed.
    pub fn id(&self, i: usize, j: usize, k: usize, fam: usize) -> u32 {
        let nf = self.families.len();
        let id = self.ids[k % 2][nf * (i + self.f.dims[0] * j) + fam];
        debug_assert_ne!(id, u32::MAX, "edge ({i},{j},{k}) family {fam} is not crossed");
        id
    }

    /// Vertex id of the lattice edge from corner `a` to corner `b` of cell `(i, j, k)`, where
    /// `b`'s offset bits include `a`'s (the edge runs from `a` in a positive direction).
    pub fn corner_edge(&self, cell: [usize; 3], a: u8, b: u8) -> u32 {
        let (lo, hi) = if a & b == a { (a, b) } else { (b, a) };
        debug_assert_eq!(lo & hi, lo, "corners {a} and {b} are not on a positive lattice edge");
        let bits = lo ^ hi;
        let fam = self.families.iter().position(|&x| x == bits).expect("edge family in use");
        let o = offset(lo);
        self.id(cell[0] + o[0], cell[1] + o[1], cell[2] + o[2], fam)
    }
}

/// For the cells of one row (corner 0 at point `r + cx` of the lower point layer `lo`, the
/// upper `hi`, rows `nx` points long): nonzero iff the cell's corners are not all on one side.
pub(crate) fn cell_row_differs(lo: &[u8], hi: &[u8], r: usize, nx: usize, out: &mut [u8]) {
    let n = out.len();
    let (a, b, c, d) =
        (&lo[r..r + n], &lo[r + 1..r + 1 + n], &lo[r + nx..][..n], &lo[r + nx + 1..][..n]);
    let (e, g, h, k) =
        (&hi[r..r + n], &hi[r + 1..r + 1 + n], &hi[r + nx..][..n], &hi[r + nx + 1..][..n]);
    for x in 0..n {
        let v = a[x];
        out[x] = (v ^ b[x])
            | (v ^ c[x])
            | (v ^ d[x])
            | (v ^ e[x])
            | (v ^ g[x])
            | (v ^ h[x])
            | (v ^ k[x]);
    }
}
