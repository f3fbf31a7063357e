//! The field sources, registered in one place.
//!
//! Each kind of `[field] source` is one module here that holds everything about it, next to
//! its implementation (pbrt-v4 style): its keys and what it supports ([`Info`]), how it parses
//! them (through [`Params`], which the scene implements), how it samples the grid, how it is
//! described in output headers, and, where it can, how to evaluate it at any point
//! ([`PointField`]). This file registers them: the [`FieldSource`] variants and
//! [`SourceKind`]s, and one exhaustive `match` per operation, with no catch-all arm, so a new
//! variant does not compile until every operation handles it.
//!
//! ```text
//!   kind      keys (besides source, bounds)                      grid size from      point  time
//!   sdf       shape, center, resolution, + the shape's parameters  resolution          yes
//!   corners   values (8 numbers, v000 v100 v010 v110 v001 ...)     2x2x2               yes
//!   npy       path                                                 the array's shape
//!   raw       path, dims, dtype, endian                            dims
//!   expr      expression, resolution                               resolution          yes    yes
//!   mesh      path, resolution (points on the longest axis)         the mesh's box + 5% yes
//!   file      path, format, spacing (TIFF)                         the header's dims
//!   (grid)    samples already in memory (scenes built in code)     the grid's dims
//! ```
//!
//! "point": the source can be evaluated anywhere, not only at grid points (slices use it for
//! `ambiguity = "sample"` and to refine contours on the source). "time": it may depend on `t`.
//!
//! # Adding a source
//!
//! 1. `source/NAME.rs`: `INFO` (name, keys, own box, supports), `parse` (through [`Params`]),
//!    `sample`, `describe`, and `point` if it can be evaluated anywhere.
//! 2. Here: `mod NAME;`, the kind in `source_kinds!` and its [`FieldSource`] variant; the
//!    compiler then names every `match` below that lacks an arm for them.
//! 3. `tests/it/field/sources.rs`: its keys, errors and samples, and its row in
//!    `each_source_kind_says_what_it_supports` (which fails until the kind is listed there).
//!
//! A key of a type no source reads yet needs a [`Params`] method (and the scene's
//! implementation of it in `scene/field.rs`).

mod corners;
mod expr;
mod file;
mod grid;
mod mesh;
mod npy;
mod params;
mod raw;
mod sdf;

use std::sync::Arc;

use glam::DVec3;

pub use params::{Need, Params, Rule};

use super::formats::FileSource;
use super::{
    samples, ExprSource, FieldError, Grid, GridLimits, MeshSource, NanPolicy, NpySource, RawSource,
};
use crate::vocab::{Bounds, Placement, SdfShape};

/// Declares [`SourceKind`] and its `ALL` from one list, so a kind cannot be left out of `ALL`.
macro_rules! source_kinds {
    ($($(#[$doc:meta])* $kind:ident,)*) => {
        /// The kinds of `[field] source` a scene file can name.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum SourceKind {
            $($(#[$doc])* $kind,)*
        }

        impl SourceKind {
            /// Every kind, in the order the contract lists them.
            pub const ALL: &'static [SourceKind] = &[$(SourceKind::$kind),*];
        }
    };
}

source_kinds! {
    /// A signed-distance shape (`sdf.rs`).
    Sdf,
    /// One cell's 8 corner values (`corners.rs`).
    Corners,
    /// A `.npy` file (`npy.rs`).
    Npy,
    /// A headerless binary file (`raw.rs`).
    Raw,
    /// An expression over x, y, z and t (`expr.rs`).
    Expr,
    /// The signed distance to a triangle mesh (`mesh.rs`).
    Mesh,
    /// A volume file: NRRD, NIfTI, MRC, MetaImage, VTK or TIFF (`file.rs`).
    File,
}

/// What a source can do besides filling the grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Supports {
    /// It can be evaluated at any point ([`FieldSource::point`]): slices may decide ambiguous
    /// cells by it (`ambiguity = "sample"`) and refine contours on it (`max_depth > 0`).
    pub point: bool,
    /// Its values may depend on the time `t`.
    pub time: bool,
}

/// The static facts about a kind, one `const` in each source's module.
pub(super) struct Info {
    /// The name in scene files.
    pub name: &'static str,
    /// Keys besides `source` (and `bounds`, unless `own_box`), in the order error messages list
    /// them.
    pub keys: &'static [&'static str],
    /// `Some(why)` when the source sets its own box and takes no `bounds` key.
    pub own_box: Option<&'static str>,
    pub supports: Supports,
}

impl SourceKind {
    fn info(self) -> &'static Info {
        match self {
            SourceKind::Sdf => &sdf::INFO,
            SourceKind::Corners => &corners::INFO,
            SourceKind::Npy => &npy::INFO,
            SourceKind::Raw => &raw::INFO,
            SourceKind::Expr => &expr::INFO,
            SourceKind::Mesh => &mesh::INFO,
            SourceKind::File => &file::INFO,
        }
    }

    /// The name as written in scene files.
    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// Its keys besides `source` and `bounds`.
    pub fn keys(self) -> &'static [&'static str] {
        self.info().keys
    }

    /// `Some(why)` when the kind takes no `bounds` (it sets its own box).
    pub fn own_box(self) -> Option<&'static str> {
        self.info().own_box
    }

    pub fn supports(self) -> Supports {
        self.info().supports
    }

    /// Reads the kind's keys (already checked to be among [`SourceKind::keys`]).
    pub fn parse<P: Params>(self, p: &P) -> Result<Parsed, P::Error> {
        match self {
            SourceKind::Sdf => sdf::parse(p),
            SourceKind::Corners => corners::parse(p),
            SourceKind::Npy => npy::parse(p),
            SourceKind::Raw => raw::parse(p),
            SourceKind::Expr => expr::parse(p),
            SourceKind::Mesh => mesh::parse(p),
            SourceKind::File => file::parse(p),
        }
    }

    /// The names of the kinds for which `pred` holds, as `sdf, corners, expr or mesh`.
    pub fn names_where(pred: impl Fn(SourceKind) -> bool) -> String {
        let names: Vec<&str> =
            SourceKind::ALL.iter().filter(|k| pred(**k)).map(|k| k.name()).collect();
        match names.split_last() {
            Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
            _ => names.join(""),
        }
    }
}

/// What a kind's parser returns.
#[derive(Clone, Debug)]
pub struct Parsed {
    pub source: FieldSource,
    /// Grid points along x, y, z.
    pub resolution: [usize; 3],
    /// The box, for a kind that sets its own ([`SourceKind::own_box`]); else `bounds` or the
    /// index space. With a [`Parsed::placement`], the box in the grid's own frame.
    pub bounds: Option<Bounds>,
    /// Where the grid's axes point in world space, for a file whose header says so (None:
    /// the world's axes). A `bounds` key in the scene overrides both.
    pub placement: Option<Placement>,
}

/// Where a field's values come from, after validation.
#[derive(Clone, Debug)]
pub enum FieldSource {
    /// A signed-distance shape sampled at the grid points; `center` is subtracted first.
    Sdf { shape: SdfShape, center: DVec3 },
    /// One cell: `v000, v100, v010, v110, v001, v101, v011, v111` (vXYZ: the corner at x = X,
    /// y = Y, z = Z of the box). On a grid finer than 2x2x2 the points sample the trilinear
    /// interpolant of these values, which describes the same field.
    Corners([f64; 8]),
    /// A `.npy` file whose header and size were checked at load time.
    Npy(NpySource),
    /// A headerless binary file whose size was checked at load time.
    Raw(RawSource),
    /// An expression over `x`, `y`, `z` (world coordinates) and `t`.
    Expr(ExprSource),
    /// Samples already in memory (scenes built in code, not from a file); the spec's
    /// resolution and bounds are the grid's.
    Grid(Arc<Grid>),
    /// The signed distance to a triangle mesh read at load time (negative inside).
    Mesh(MeshSource),
    /// A volume file read at load time.
    File(FileSource),
}

/// A source as a function of world position (see [`Supports::point`]).
pub struct PointField<'a> {
    pub eval: Box<dyn Fn(DVec3) -> f64 + Sync + 'a>,
    /// An upper bound of the gradient's length (world units), if known.
    pub lipschitz: Option<f64>,
}

impl<'a> PointField<'a> {
    /// The source of `spec` at `time`, None when it cannot be evaluated off the grid.
    pub fn from_spec(spec: &'a super::FieldSpec, time: f64) -> Option<PointField<'a>> {
        spec.source.point(&spec.bounds, time)
    }
}

impl FieldSource {
    /// The scene kind, None for a grid built in code.
    pub fn kind(&self) -> Option<SourceKind> {
        match self {
            FieldSource::Sdf { .. } => Some(SourceKind::Sdf),
            FieldSource::Corners(_) => Some(SourceKind::Corners),
            FieldSource::Npy(_) => Some(SourceKind::Npy),
            FieldSource::Raw(_) => Some(SourceKind::Raw),
            FieldSource::Expr(_) => Some(SourceKind::Expr),
            FieldSource::Grid(_) => None,
            FieldSource::Mesh(_) => Some(SourceKind::Mesh),
            FieldSource::File(_) => Some(SourceKind::File),
        }
    }

    /// The file this source reads (`field.path`), None for sources that read none.
    pub fn data_path(&self) -> Option<&std::path::Path> {
        match self {
            FieldSource::Npy(n) => Some(&n.path),
            FieldSource::Raw(r) => Some(&r.path),
            FieldSource::Mesh(m) => Some(&m.path),
            FieldSource::File(f) => Some(&f.path),
            FieldSource::Sdf { .. }
            | FieldSource::Corners(_)
            | FieldSource::Expr(_)
            | FieldSource::Grid(_) => None,
        }
    }

    /// What this source supports.
    pub fn supports(&self) -> Supports {
        self.kind().map_or(grid::SUPPORTS, SourceKind::supports)
    }

    /// The source as a function of world position over `bounds` at `time`, None when it
    /// cannot be evaluated off the grid (exactly when `supports().point` is false).
    pub fn point(&self, bounds: &Bounds, time: f64) -> Option<PointField<'_>> {
        match self {
            FieldSource::Sdf { shape, center } => Some(sdf::point(shape, *center)),
            FieldSource::Corners(v) => Some(corners::point(v, bounds)),
            FieldSource::Npy(_)
            | FieldSource::Raw(_)
            | FieldSource::Grid(_)
            | FieldSource::File(_) => None,
            FieldSource::Expr(e) => Some(expr::point(e, time)),
            FieldSource::Mesh(m) => Some(mesh::point(m)),
        }
    }

    /// Whether the samples depend on the time.
    pub fn is_time_varying(&self) -> bool {
        match self {
            FieldSource::Expr(e) => e.uses_time(),
            FieldSource::Sdf { .. }
            | FieldSource::Corners(_)
            | FieldSource::Npy(_)
            | FieldSource::Raw(_)
            | FieldSource::Grid(_)
            | FieldSource::Mesh(_)
            | FieldSource::File(_) => false,
        }
    }

    /// What the memory cap and the finiteness check name: the data file, or
    /// `field.resolution`.
    pub(super) fn label(&self) -> String {
        match self {
            FieldSource::Npy(n) => super::npy::path_str(&n.path),
            FieldSource::Raw(r) => super::npy::path_str(&r.path),
            FieldSource::Mesh(m) => super::npy::path_str(&m.path),
            FieldSource::File(f) => super::npy::path_str(&f.path),
            // The corner values are what a refused sample comes from, not the lattice.
            FieldSource::Corners(_) => "field.values".to_string(),
            FieldSource::Sdf { .. } | FieldSource::Expr(_) | FieldSource::Grid(_) => {
                "field.resolution".to_string()
            }
        }
    }

    /// The samples at the points of `grid` (its dims and box; values empty), checked finite
    /// under `field.nan` (`nan`).
    pub(super) fn sample(
        &self,
        grid: &Grid,
        time: f64,
        limits: &GridLimits,
        nan: NanPolicy,
    ) -> Result<Vec<f32>, FieldError> {
        let finite = |values: Vec<f32>| finite(grid, values, self, nan);
        let over = |o: samples::Overflow| o.error(self.label(), grid.dims, String::new());
        match self {
            FieldSource::Sdf { shape, center } => {
                finite(sdf::sample(shape, *center, grid).map_err(over)?)
            }
            FieldSource::Corners(v) => finite(corners::sample(v, grid).map_err(over)?),
            FieldSource::Npy(n) => finite(npy::sample(n, grid, limits)?),
            FieldSource::Raw(r) => finite(raw::sample(r, grid, limits)?),
            FieldSource::Expr(e) => expr::sample(e, grid, time, nan),
            FieldSource::Grid(g) => finite(g.values.clone()),
            FieldSource::Mesh(m) => finite(mesh::sample(m, grid).map_err(over)?),
            FieldSource::File(f) => finite(file::sample(f, grid)?),
        }
    }

    /// The type of the samples as the source stores them (`int16`, `<f4`), for `stats`.
    pub fn dtype(&self) -> String {
        match self {
            FieldSource::Npy(n) => n.descr.clone(),
            FieldSource::Raw(r) => r.dtype.name().to_string(),
            FieldSource::File(f) => f.volume.dtype.clone(),
            FieldSource::Sdf { .. }
            | FieldSource::Corners(_)
            | FieldSource::Expr(_)
            | FieldSource::Grid(_)
            | FieldSource::Mesh(_) => "f32 (computed)".to_string(),
        }
    }

    /// One line for output headers, without the lattice (`sdf torus R=0.6 r=0.25`).
    pub(super) fn describe(&self) -> String {
        match self {
            FieldSource::Sdf { shape, center } => sdf::describe(shape, *center),
            FieldSource::Corners(v) => corners::describe(v),
            FieldSource::Npy(n) => npy::describe(n),
            FieldSource::Raw(r) => raw::describe(r),
            FieldSource::Expr(e) => expr::describe(e),
            FieldSource::Grid(_) => grid::describe(),
            FieldSource::Mesh(m) => mesh::describe(m),
            FieldSource::File(f) => file::describe(f),
        }
    }
}

/// `values` unless `nan` refuses one that is not finite (the error names the first).
fn finite(
    grid: &Grid,
    values: Vec<f32>,
    source: &FieldSource,
    nan: NanPolicy,
) -> Result<Vec<f32>, FieldError> {
    samples::check_finite(&values, grid.dims, nan, || source.label(), |_| String::new())?;
    Ok(values)
}

/// Fails unless a data file's dims are the spec's resolution.
fn check_file_dims(file: [usize; 3], grid: &Grid) -> Result<(), FieldError> {
    if file == grid.dims {
        Ok(())
    } else {
        Err(FieldError::BadShape {
            path: "field".into(),
            message: format!(
                "resolution {:?} does not match the file's dims {:?}",
                grid.dims, file
            ),
        })
    }
}

/// `[x, y, z]` with shortest round-trip formatting.
pub(super) fn show3(v: DVec3) -> String {
    // Short numbers: a bound of 1e-300 printed 302 characters into the field line.
    let n = crate::vocab::echo_number::<f64>;
    format!("[{}, {}, {}]", n(v.x), n(v.y), n(v.z))
}

/// Points below which sampling stays on the calling thread.
const PARALLEL_MIN_POINTS: usize = 1 << 15;

/// Evaluates `f` at every grid point (world space, the same arithmetic as [`Grid::point`]),
/// x fastest, splitting z-slabs over the available cores for large grids; fails on the
/// first value beyond f32's range ([`samples::narrow`]; `at`: its grid index).
fn fill(grid: &Grid, f: impl Fn(DVec3) -> f64 + Sync) -> Result<Vec<f32>, samples::Overflow> {
    let (min, spacing) = (grid.min, grid.spacing());
    fill_indexed(grid, |i, j, k| f(min + spacing * DVec3::new(i as f64, j as f64, k as f64)))
}

/// [`fill`] with `f` given the grid index (i, j, k) rather than the point, for sources that
/// tabulate what depends on one axis only (the gyroid's sines and cosines).
fn fill_indexed(
    grid: &Grid,
    f: impl Fn(usize, usize, usize) -> f64 + Sync,
) -> Result<Vec<f32>, samples::Overflow> {
    let [nx, ny, nz] = grid.dims;
    let slab = nx * ny;
    let mut values = vec![0.0f32; slab * nz];
    let fill_slabs = |first_k: usize, out: &mut [f32]| -> Result<(), samples::Overflow> {
        for (dk, slab_out) in out.chunks_mut(slab).enumerate() {
            let k = first_k + dk;
            for j in 0..ny {
                for i in 0..nx {
                    slab_out[i + nx * j] = samples::narrow(f(i, j, k))
                        .map_err(|value| samples::Overflow { at: i + nx * (j + ny * k), value })?;
                }
            }
        }
        Ok(())
    };
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(nz);
    if values.len() < PARALLEL_MIN_POINTS || threads < 2 {
        fill_slabs(0, &mut values)?;
    } else {
        let slabs_per_thread = nz.div_ceil(threads);
        // The chunks in order: the first failing one holds the first such point.
        std::thread::scope(|s| {
            let handles: Vec<_> = values
                .chunks_mut(slabs_per_thread * slab)
                .enumerate()
                .map(|(n, chunk)| {
                    let fill_slabs = &fill_slabs;
                    s.spawn(move || fill_slabs(n * slabs_per_thread, chunk))
                })
                .collect();
            handles.into_iter().try_for_each(|h| h.join().expect("a fill thread panicked"))
        })?;
    }
    Ok(values)
}
