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

use super::field::Field;
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
}

impl<'f, 'g> EdgeLayers<'f, 'g> {
    pub fn new(f: &'f Field<'g>, families: &'static [u8]) -> Self {
        let n = f.dims[0] * f.dims[1] * families.len();
        EdgeLayers { f, families, ids: [vec![u32::MAX; n], vec![u32::MAX; n]] }
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
        let ids = &mut self.ids[k % 2];
        for j in 0..ny {
            for i in 0..nx {
                let va = f.value(i, j, k);
                let ina = f.inside.contains(va, f.iso);
                for (fam, &bits) in self.families.iter().enumerate() {
                    let slot = nf * (i + nx * j) + fam;
                    ids[slot] = u32::MAX;
                    let d = offset(bits);
                    let (ib, jb, kb) = (i + d[0], j + d[1], k + d[2]);
                    if ib >= nx || jb >= ny || kb >= nz {
                        continue;
                    }
                    let vb = f.value(ib, jb, kb);
                    if f.inside.contains(vb, f.iso) == ina {
                        continue;
                    }
                    let s = f.crossing(va, vb);
                    let dv = DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64);
                    let u = DVec3::new(i as f64, j as f64, k as f64) + s * dv;
                    let out_dir = if ina { dv } else { -dv };
                    ids[slot] = vertex(u, out_dir)?;
                }
            }
        }
        Ok(())
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
