//! Isosurface meshes: CPU reference extraction (f64 arithmetic), statistics and export.
//!
//! Every algorithm here is the definition that the GPU extraction passes mirror: the same inside
//! rule, the same edge and cell numbering, the same vertex order, the same winding. A GPU pass
//! reproduces the output of [`reference`] index for index with the usual
//! classify → prefix sum → emit pipeline, because every vertex is owned by one lattice edge (or
//! one cell) and vertices are numbered in increasing edge (or cell) id.
//!
//! # Conventions
//!
//! Grid point `(i, j, k)` has linear index `p = i + nx * (j + ny * k)` (x fastest) and sits in
//! *index space* at `u = (i, j, k)`; world space is `min + u * spacing` ([`Grid::point`]).
//! Cell `(i, j, k)` spans `[i, i+1] × [j, j+1] × [k, k+1]` in index space and has the same linear
//! numbering over `(nx-1, ny-1, nz-1)` cells. Its corners are numbered by their offset bits
//! (`n = x + 2y + 4z`, the order of [`Grid::corners`]):
//!
//! ```text
//!            6 ─────────── 7          z
//!           ╱│            ╱│          │  y
//!          ╱ │           ╱ │          │ ╱
//!         4 ─────────── 5  │          │╱
//!         │  2 ─────────│─ 3          └───── x
//!         │ ╱           │ ╱
//!         │╱            │╱
//!         0 ─────────── 1
//! ```
//!
//! * **Inside** is [`Inside::contains`]: strictly below (or above) the isovalue; a sample equal
//!   to the isovalue is outside. A lattice edge is *crossed* iff the predicate differs at its two
//!   ends.
//! * **Crossing point**: on the edge from its start point `a` (the lower-index end) to its end
//!   `b`, at `s = (iso - f(a)) / (f(b) - f(a))`, computed in f64 from the f32 samples and clamped
//!   to `[0, 1]` (a NaN `s`, from NaN samples, becomes 0.5). With the strict rule, `s` can be
//!   exactly 0 or 1 when an end equals the isovalue; the vertex then sits on a grid point and
//!   zero-area triangles can appear ([`stats::MeshStats::zero_area_triangles`] counts them).
//! * **Normals** point from inside to outside: the normalised gradient of the trilinear
//!   interpolant at the vertex, negated for `inside = "above"`. Where the vertex lies on a cell
//!   face, edge or corner (every edge vertex does), the gradient is the mean of the gradients of
//!   all cells that contain it. Where that gradient vanishes the normal falls back to the
//!   inside → outside direction of the crossed edge(s) (and to +z if those cancel too).
//! * **Winding**: every triangle is counter-clockwise seen from outside, so its geometric normal
//!   `(b - a) × (c - a)` points from inside to outside and the enclosed volume is positive.
//!
//! # Algorithms
//!
//! | name | vertices | faces | module |
//! | --- | --- | --- | --- |
//! | `marching-cubes` | one per crossed x/y/z lattice edge | Bourke's 256-case table | `mc` |
//! | `marching-tetrahedra` | one per crossed edge of the 7 edge families | 6 tetrahedra per cell | `mt` |
//! | `surface-nets` | one per active cell, mean of its crossings | one quad per crossed interior edge | `dual` (threaded: `nets`, the same mesh) |
//! | `dual-contouring` | as surface nets, on a grid closed at its boundary (GEL) | one quad per crossed edge | `dual` |
//! | `mc33` | as marching cubes | the trilinear interpolant's topology per cell (Chernyaev's MC33 cases) | `mc33` |
//! | `dual-contouring-qef` | as dual contouring, at the minimiser of the cell's QEF (Hermite data) | as dual contouring | `dcqef`, `qef`, `hermite` |
//! | `dual-contouring-qef` with `mesh_error` | one per leaf of an octree collapsed where the QEF stays under ε | Ju et al.'s cell/face/edge procedure | `octree` |
//! | `extended-mc` | as marching cubes, plus one per feature piece of a cell at its QEF minimiser | marching cubes', feature pieces fanned, edges flipped onto features | `emc`, `qef`, `hermite` |
//!
//! Each module's documentation states its exact rules.
//!
//! What to extract is a [`Request`]. [`reference`] is the single-threaded reference;
//! [`extract`] runs the same per-cell code on slabs of cell layers on all `rayon` threads and joins them into the same mesh, bit
//! for bit (`slabs`).

mod clip;
mod dcqef;
mod dual;
mod edges;
mod emc;
pub mod export;
mod field;
mod hermite;
mod lanes;
pub mod limits;
pub mod mapped;
mod mc;
mod mc33;
pub mod method;
mod mt;
mod nets;
mod octree;
mod qef;
pub mod refine;
mod slabs;
pub mod stats;
pub mod tables;
#[cfg(test)]
mod tests;
mod voxel_faces;
pub mod window;

pub use limits::{MeshBudget, MeshLimits, MESH_CAP_ENV};
pub use method::MeshAlgorithm;

use crate::field::interpolant::Interpolant;
use crate::field::{Grid, PointField};
use crate::vocab::{Inside, SharpSettings};

/// An indexed triangle mesh in world space.
///
/// Vertices are welded: each is owned by exactly one lattice edge or cell (see the module
/// documentation), and no two vertices come from the same owner.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// World-space vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Unit normals, inside → outside, one per vertex.
    pub normals: Vec<[f32; 3]>,
    /// Triangles, three vertex indices each, counter-clockwise seen from outside.
    pub indices: Vec<u32>,
    /// The quads that `indices` triangulates, four vertex indices each, counter-clockwise seen
    /// from outside; only for `surface-nets` and `dual-contouring` with
    /// [`ExtractOptions::keep_quads`]. Quad `q` is triangles `2q` and `2q + 1`.
    pub quads: Option<Vec<u32>>,
}

/// Several surfaces' meshes as one: their vertices and faces one after the other (surface 0
/// first), and each vertex's surface (`surface.isovalues` index), the PLY's `surface` property.
pub fn merge(meshes: &[Mesh]) -> (Mesh, Vec<u32>) {
    let mut out = Mesh::default();
    let mut labels = Vec::new();
    let quads = meshes.iter().all(|m| m.quads.is_some()) && !meshes.is_empty();
    let mut all_quads = Vec::new();
    for (k, m) in meshes.iter().enumerate() {
        let base = out.positions.len() as u32;
        out.positions.extend_from_slice(&m.positions);
        out.normals.extend_from_slice(&m.normals);
        out.indices.extend(m.indices.iter().map(|i| i + base));
        if let (true, Some(q)) = (quads, &m.quads) {
            all_quads.extend(q.iter().map(|i| i + base));
        }
        labels.resize(labels.len() + m.positions.len(), k as u32);
    }
    out.quads = quads.then_some(all_quads);
    (out, labels)
}

impl Mesh {
    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Triangle `t` as three vertex indices.
    pub fn triangle(&self, t: usize) -> [u32; 3] {
        [self.indices[3 * t], self.indices[3 * t + 1], self.indices[3 * t + 2]]
    }

    /// Moves a mesh extracted in the grid's own frame to world space: positions and normals
    /// through the placement, and, when it mirrors, every triangle's and quad's winding
    /// reversed so they stay counter-clockwise seen from outside. The identity changes nothing.
    pub fn place(&mut self, placement: &crate::vocab::Placement) {
        if placement.is_identity() {
            return;
        }
        let f = |v: &[f32; 3]| glam::DVec3::from(v.map(f64::from));
        for p in &mut self.positions {
            *p = placement.point_to_world(f(p)).as_vec3().to_array();
        }
        for n in &mut self.normals {
            *n = placement.vector_to_world(f(n)).as_vec3().to_array();
        }
        if placement.mirrors() {
            self.indices.chunks_exact_mut(3).for_each(|t| t.swap(1, 2));
            if let Some(q) = self.quads.as_mut() {
                // (q0, q1, q2, q3) -> (q0, q3, q2, q1): triangles 2q and 2q + 1 are still its halves.
                q.chunks_exact_mut(4).for_each(|q| q.swap(1, 3));
            }
        }
    }
}

/// How the dual methods split a quad `(q0, q1, q2, q3)` into two triangles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum QuadSplit {
    /// Along the shorter diagonal (GEL's `SHORTEST_EDGE`, fast-surface-nets): `q0–q2` when
    /// `|q2 - q0|² <= |q3 - q1|²` (squared lengths in f64 of the f32 positions), else `q1–q3`.
    #[default]
    Shorter,
    /// Always along `q0–q2`: `(q0, q1, q2), (q0, q2, q3)`. Needs no arithmetic, so a GPU
    /// reproduces it bit for bit.
    Fixed,
}

/// Options of a [`Request`]; `Default` gives what `isoview extract` uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ExtractOptions {
    /// Quad split of `surface-nets` and `dual-contouring`.
    pub split: QuadSplit,
    /// Also return the quads of `surface-nets` and `dual-contouring` in [`Mesh::quads`].
    pub keep_quads: bool,
}

/// Why an extraction failed.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("isovalue {0} is not a finite number")]
    BadIsovalue(f64),
    #[error("grid has {got} samples, but its dimensions {dims:?} need {want}")]
    BadGrid { dims: [usize; 3], got: usize, want: usize },
    #[error("the mesh would have more than 2^32 - 1 {what}; use a coarser grid")]
    TooLarge { what: &'static str },
    #[error("{0} is not extracted in z-ranges")]
    NotInSlabs(&'static str),
    #[error("bad window: {0}")]
    BadWindow(String),
    /// The mesh being extracted passed the memory cap ([`MeshLimits`]); the counts are the
    /// totals when it did.
    #[error(
        "the mesh passed {triangles} triangles and {vertices} vertices ({} of vertices and \
         indices) while it was extracted, over the cap of {}; raise the cap with \
         {MESH_CAP_ENV}=<MiB> (or MeshLimits::max_bytes) or use a coarser grid",
        limits::mib(*bytes), limits::mib(*cap)
    )]
    OverCap { vertices: u64, triangles: u64, bytes: u64, cap: u64 },
    /// A method not cut into slabs would hold more than the memory cap while it works (its
    /// tables besides the mesh: `extended-mc`'s edge table, Hermite data and edge-flip
    /// table); refused before it allocates them.
    #[error(
        "render.mesh = \"{method}\" would hold {} while it works on this grid ({what}), over \
         the cap of {}; raise the cap with {MESH_CAP_ENV}=<MiB> (or MeshLimits::max_bytes) or \
         use a coarser grid",
        limits::mib(*bytes), limits::mib(*cap)
    )]
    WorkOverCap { method: &'static str, what: &'static str, bytes: u64, cap: u64 },
    /// `ISOVIEW_MAX_MESH_MIB` is set to something that is not a positive whole number.
    #[error("{MESH_CAP_ENV}={value:?}: expected a positive whole number of MiB")]
    BadLimit { value: String },
    /// The samples could not be used (`field.nan = "error"` and a non-finite one), or a grid
    /// read from its file as it is extracted (`mesh::mapped`) could not be read.
    #[error(transparent)]
    Field(#[from] crate::field::FieldError),
    /// A method that reads trilinear cells only, asked for another interpolant or a refined
    /// lattice.
    #[error(
        "render.mesh = \"{method}\" meshes trilinear cells at render.mesh_refine = 1 only, not \
         field.interpolation = \"{interp}\" at render.mesh_refine = {k}; use {}",
        method::Method::names_where(|m| m.lattice_edges)
    )]
    NotLattice { method: &'static str, interp: &'static str, k: usize },
    /// The interpolant has no mesh (`Interpolant::refusal`).
    #[error("{0}")]
    Refused(String),
    #[error(
        "hermite = \"source\" needs a source that can be evaluated off the grid (sdf, expr, \
         corners, mesh); use hermite = \"trilinear\""
    )]
    NoPointSource,
}

/// What to extract: the surface, the method and its settings; the one input of every
/// extraction ([`reference`], [`extract`], [`extract_streamed`], [`window::extract_window`],
/// [`mapped::extract_mapped`]). [`Request::new`] gives the defaults of the rest.
#[derive(Clone, Copy)]
pub struct Request<'a> {
    pub iso: f64,
    pub inside: Inside,
    pub algo: MeshAlgorithm,
    pub opts: ExtractOptions,
    /// The sharp-feature meshes' settings; the other methods ignore them.
    pub sharp: SharpSettings,
    /// The field's source as a function of world position, which `hermite = "source"` needs
    /// (else [`MeshError::NoPointSource`]).
    pub source: Option<&'a PointField<'a>>,
    /// Cell layers per slab of [`extract`] (tests); None: about 8 slabs per thread, at least 4
    /// layers. The dual methods count the padded cell layers of `dual-contouring` (one more
    /// at each end).
    pub slab_depth: Option<usize>,
    /// The field's interpolant (`field.interpolation`); not trilinear: the lattice of
    /// [`refine`], or `nearest`'s voxel faces.
    pub interp: Interpolant,
    /// Sub-cells per cell along each axis (`render.mesh_refine`, 1..=[`refine::MAX_REFINE`]).
    pub refine: usize,
}

impl<'a> Request<'a> {
    /// Surface `iso` with `inside` by `algo`, default options and sharp-feature settings, no
    /// source.
    pub fn new(iso: f64, inside: Inside, algo: MeshAlgorithm) -> Self {
        Request {
            iso,
            inside,
            algo,
            opts: ExtractOptions::default(),
            sharp: SharpSettings::default(),
            source: None,
            slab_depth: None,
            interp: Interpolant::Trilinear,
            refine: 1,
        }
    }

    /// The field read with `interp`, its cells split `refine` ways (`mesh::refine`).
    pub fn with_lattice(self, interp: Interpolant, refine: usize) -> Self {
        Request { interp, refine, ..self }
    }

    /// Whether it meshes the grid's own trilinear cells (else the lattice of [`refine`], or
    /// `nearest`'s voxel faces): the only requests the GPU passes, z-ranges (MPI ranks,
    /// mapped files) and streamed pieces take.
    pub fn on_grid(&self) -> bool {
        refine::on_grid(self.interp, self.refine)
    }

    pub fn with_opts(self, opts: ExtractOptions) -> Self {
        Request { opts, ..self }
    }

    pub fn with_sharp(self, sharp: SharpSettings) -> Self {
        Request { sharp, ..self }
    }

    pub fn with_source(self, source: Option<&'a PointField<'a>>) -> Self {
        Request { source, ..self }
    }

    pub fn with_slab_depth(self, slab_depth: Option<usize>) -> Self {
        Request { slab_depth, ..self }
    }

    /// The method's row.
    pub fn method(&self) -> &'static method::Method {
        self.algo.method()
    }

    /// Whether the mesh keeps its quads: `opts.keep_quads` for the methods that make quads
    /// (and `nearest`'s voxel faces).
    pub fn keeps_quads(&self) -> bool {
        self.opts.keep_quads && (self.method().quads || self.interp == Interpolant::Nearest)
    }
}

/// The single-threaded f64 reference: the isosurface `{x : f(x) = x.iso}` of `grid`'s
/// trilinear interpolant as an indexed triangle mesh.
pub fn reference(grid: &Grid, x: &Request) -> Result<Mesh, MeshError> {
    check(grid, x.iso)?;
    if !x.on_grid() {
        let unlimited = &MeshBudget::unlimited();
        return off_grid(grid, x, unlimited, |f| (x.method().reference)(f, x, unlimited));
    }
    let f = field::Field::new(grid, x.iso, x.inside);
    (x.method().reference)(&f, x, &MeshBudget::unlimited())
}

/// A request off the grid's trilinear cells ([`Request::on_grid`]): `nearest`'s voxel faces,
/// or `mesh` of the field of [`refine`]'s lattice (its memory under the grid cap). The sharp
/// methods and mc33 read trilinear cells only (`Method::lattice_edges`): refused.
fn off_grid(
    grid: &Grid,
    x: &Request,
    budget: &MeshBudget,
    mesh: impl FnOnce(&field::Field) -> Result<Mesh, MeshError>,
) -> Result<Mesh, MeshError> {
    if let Some(why) = x.interp.refusal(crate::field::interpolant::Reader::Mesh) {
        return Err(MeshError::Refused(why)); // "device": the scenes refuse it first
    }
    if x.interp == Interpolant::Nearest {
        return voxel_faces::extract(grid, x, budget);
    }
    if !x.method().lattice_edges {
        return Err(MeshError::NotLattice {
            method: x.method().name,
            interp: x.interp.name(),
            k: x.refine,
        });
    }
    let limits = crate::field::GridLimits::from_env()?;
    let r = refine::refine(grid, x.interp, x.refine, limits)?;
    let f = field::Field::refined(&r.lattice, &r.exact, x.iso, x.inside);
    mesh(&f)
}

/// [`reference`]'s mesh, bit for bit (same vertex numbering, positions, normals, triangles
/// and quads), on all threads of the current `rayon` pool: the grid is cut into slabs of cell
/// layers along z ([`Request::slab_depth`]), extracted in parallel by the reference's own
/// per-cell code and joined in order. Every slab is counted into `budget` as it is done, so
/// an extraction past the cap stops with [`MeshError::OverCap`] before the whole mesh is
/// held; the methods that are not cut into slabs (`extended-mc`, `dual-contouring-qef` with
/// `mesh_error`) run the reference and are counted once they are done (`extended-mc` checks
/// its working tables against the cap as it goes, [`MeshBudget::check_working`]).
pub fn extract(grid: &Grid, x: &Request, budget: &MeshBudget) -> Result<Mesh, MeshError> {
    check(grid, x.iso)?;
    if (x.method().not_in_slabs)(&x.sharp).is_some() && x.on_grid() {
        // Not cut into slabs (see `emc`, `octree`): the reference itself.
        let f = field::Field::new(grid, x.iso, x.inside);
        let mesh = (x.method().reference)(&f, x, budget)?;
        budget.add_mesh(&mesh)?;
        return Ok(mesh);
    }
    let whole = |f: &field::Field| {
        let layers = window::cell_layers(x.algo, f.dims);
        let depth = x.slab_depth.unwrap_or_else(|| slabs::default_depth(layers));
        slabs::finish(window::extract_part(f, x, 0..layers, depth, budget)?, x.keeps_quads())
    };
    if !x.on_grid() {
        return off_grid(grid, x, budget, whole);
    }
    whole(&field::Field::new(grid, x.iso, x.inside))
}

/// Slab depth of [`extract_streamed`]: the least of [`slabs::default_depth`], so that a batch
/// of one slab per thread holds few layers.
const STREAM_DEPTH: usize = 4;

/// Why `x` cannot be extracted piece by piece ([`extract_streamed`]); None when it can.
pub fn not_streamed(x: &Request) -> Option<&'static str> {
    let m = x.method();
    if !x.on_grid() {
        return Some("the lattice of field.interpolation and render.mesh_refine (held whole)");
    }
    m.not_streamed.or_else(|| (m.not_in_slabs)(&x.sharp))
}

/// [`extract`] of `x`, handed to `sink` piece by piece instead of joined: a
/// piece is the mesh of a slab of cell layers, slabs in order, one slab per thread at a time,
/// so memory holds a few slabs' meshes, never the whole. Each piece's `positions` and
/// `normals` are the next vertices of the whole mesh, its `indices` (and `quads` when kept)
/// the next faces, numbered in the whole mesh: the pieces concatenated are
/// [`extract`]'s mesh, bit for bit. [`MeshError::NotInSlabs`] for what
/// [`not_streamed`] names.
pub fn extract_streamed<E: From<MeshError>>(
    grid: &Grid,
    x: &Request,
    mut sink: impl FnMut(Mesh) -> Result<(), E>,
) -> Result<(), E> {
    if let Some(why) = not_streamed(x) {
        return Err(MeshError::NotInSlabs(why).into());
    }
    check(grid, x.iso)?;
    let f = field::Field::new(grid, x.iso, x.inside);
    let layers = window::cell_layers(x.algo, grid.dims);
    let batch = rayon::current_num_threads().max(1);
    let keep_quads = x.keeps_quads();
    window::with_slab(&f, x, |slab| {
        slabs::stream_parts(0..layers, STREAM_DEPTH, batch, slab, |p: slabs::Part| {
            sink(Mesh {
                positions: p.verts.positions,
                normals: p.verts.normals,
                indices: p.indices,
                quads: keep_quads.then_some(p.quads),
            })
        })
    })
}

/// Rejects a non-finite isovalue and a grid whose samples do not match its dimensions.
fn check(grid: &Grid, iso: f64) -> Result<(), MeshError> {
    if !iso.is_finite() {
        return Err(MeshError::BadIsovalue(iso));
    }
    let want = grid.dims.iter().product::<usize>();
    if grid.dims.iter().any(|&n| n < 2) || grid.values.len() != want {
        return Err(MeshError::BadGrid { dims: grid.dims, got: grid.values.len(), want });
    }
    Ok(())
}

/// Converts a vertex or index count to `u32`, or fails.
fn to_u32(n: usize, what: &'static str) -> Result<u32, MeshError> {
    u32::try_from(n).ok().filter(|&v| v != u32::MAX).ok_or(MeshError::TooLarge { what })
}
