//! Scalar fields sampled on a regular grid.
//!
//! A [`Grid`] holds `f32` samples at the points of a regular lattice over an axis-aligned box.
//! Inside each cell the field is the trilinear interpolant of the cell's 8 corner values; outside
//! the box there is no field. Every source (`sdf`, `corners`, `npy`, `raw`, `expr`, `mesh`,
//! `file`: one module each under `source/`, registered in `source/mod.rs`) produces a `Grid`;
//! the renderer, the CPU references and the mesh extractors only ever see a `Grid`.
//!
//! Conventions (the contract in `docs/methods.md` "Conventions"):
//!
//! ```text
//!   point (i, j, k) = min + (i, j, k) * (max - min) / (dims - 1)      world space
//!   values[i + nx * (j + ny * k)]                                     x varies fastest
//!
//!          v011 o-----------o v111          corner order of `corners` and Grid::corners:
//!              /|          /|                 v000 v100 v010 v110 v001 v101 v011 v111
//!       v010  o-----------o | v110            (vXYZ = value at x = X, y = Y, z = Z)
//!             | |         | |
//!             | o---------|-o v101          y
//!             |/ v001     |/                |  z
//!       v000  o-----------o v100            | /
//!                                           +---- x
//! ```
//!
//! - `npy`: element `[i, j, k]` of an `(nx, ny, nz)` array is the value at point `(i, j, k)`,
//!   whatever the file's order (C or Fortran) or byte order.
//! - `raw`: `nx * ny * nz` samples, x fastest.
//! - `expr`: evaluated at the world position of each point and the time `t`.
//! - `mesh`: the signed distance to a triangle mesh file, negative inside ([`mesh_sdf`]).
//! - `file`: a volume in a format users have ([`formats`]: NRRD, NIfTI-1, MRC, MetaImage, VTK,
//!   TIFF), its box and orientation from the header.
//! - Samples must be finite: the first NaN or infinity is reported with its `[i, j, k]`.
//! - Memory: a grid whose `f32` samples would exceed [`GridLimits::max_bytes`] (default
//!   1024 MiB, `ISOVIEW_MAX_GRID_MIB` overrides) is refused before anything is allocated or any
//!   sample is read.

mod access;
mod error;
pub(crate) use error::{mib, shown};
mod expr;
pub mod formats;
mod grid;
pub mod interpolant;
mod limits;
pub mod mapped;
pub mod mesh_sdf;
mod npy;
pub mod parts;
mod raw;
mod samples;
mod source;
pub mod sparse;
mod spec;
pub mod stats;

pub use access::{open_data, DataAccess};
pub use error::FieldError;
pub use expr::ExprSource;
pub use grid::Grid;
pub use limits::{GridLimits, GRID_CAP_ENV};
pub use mesh_sdf::{MeshSdf, MeshSource, TriangleMesh};
pub use npy::{sample_type_of_descr, NpySource};
pub use raw::RawSource;
pub use samples::{from_memory, Endian, SampleType, StorageOrder};
pub use source::{FieldSource, Need, Params, Parsed, PointField, Rule, SourceKind, Supports};
pub use spec::{FieldSpec, NanPolicy, Residency, COMMON_KEYS};
