//! Readers for the volume formats users have: NRRD, NIfTI-1, MRC/CCP4, MetaImage, VTK image
//! data (XML `.vti` and legacy `.vtk`), TIFF stacks, OpenVDB (`.vdb`, through the OpenVDB
//! library) and NanoVDB (`.nvdb`, natively). Each reader returns a [`Volume`]: the
//! samples as `f32`, x fastest, and the grid's geometry from the header, decomposed into an
//! origin, a spacing per axis and unit axis directions:
//!
//! ```text
//!   world(i, j, k) = origin + i * spacing.x * dir[0] + j * spacing.y * dir[1] + k * spacing.z * dir[2]
//! ```
//!
//! Coordinates stay in the file's own space and units (NIfTI RAS+ mm, NRRD and MetaImage their
//! stated space, MRC in Å): nothing is converted between LPS and RAS.
//!
//! Every reader checks the declared grid against the memory cap before allocating, and the
//! data's length against the header before decoding; a malformed or truncated file is one
//! [`FieldError::Format`] line naming the file, never a panic.

mod base64;
mod metaimage;
mod mrc;
mod nifti;
mod nrrd;
mod nvdb;
mod payload;
mod text;
mod tiff;
mod vdb;
mod vti;
mod vtk_legacy;

use std::path::Path;

use glam::DVec3;

use super::{DataAccess, FieldError, GridLimits};

/// How many pages of a TIFF stack over the cap are counted for its refusal.
pub use tiff::MAX_PAGES_COUNTED as MAX_TIFF_PAGES_COUNTED;

/// The formats `source = "file"` reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Nrrd,
    Nifti,
    Mrc,
    MetaImage,
    Vti,
    Vtk,
    Tiff,
    Vdb,
    Nvdb,
}

impl Format {
    pub const ALL: [Format; 9] = [
        Format::Nrrd,
        Format::Nifti,
        Format::Mrc,
        Format::MetaImage,
        Format::Vti,
        Format::Vtk,
        Format::Tiff,
        Format::Vdb,
        Format::Nvdb,
    ];

    /// The name of `format = "..."` in scene files.
    pub fn name(self) -> &'static str {
        match self {
            Format::Nrrd => "nrrd",
            Format::Nifti => "nifti",
            Format::Mrc => "mrc",
            Format::MetaImage => "metaimage",
            Format::Vti => "vti",
            Format::Vtk => "vtk",
            Format::Tiff => "tiff",
            Format::Vdb => "vdb",
            Format::Nvdb => "nvdb",
        }
    }

    /// How messages name the format.
    pub fn title(self) -> &'static str {
        match self {
            Format::Nrrd => "NRRD",
            Format::Nifti => "NIfTI-1",
            Format::Mrc => "MRC",
            Format::MetaImage => "MetaImage",
            Format::Vti => "VTK XML image data",
            Format::Vtk => "legacy VTK",
            Format::Tiff => "TIFF",
            Format::Vdb => "OpenVDB",
            Format::Nvdb => "NanoVDB",
        }
    }

    /// The header fields that place the grid, for messages about its box.
    pub fn geometry_fields(self) -> &'static str {
        match self {
            Format::Nrrd => "space origin, space directions, spacings, axis mins",
            Format::Nifti => "srow_x/y/z or qoffset_x/y/z and pixdim",
            Format::Mrc => "ORIGIN, cell dimensions and MX, MY, MZ",
            Format::MetaImage => "Offset, ElementSpacing, TransformMatrix",
            Format::Vti => "Origin, Spacing, Direction, WholeExtent",
            Format::Vtk => "ORIGIN, SPACING",
            Format::Tiff => "field.spacing",
            Format::Vdb | Format::Nvdb => "the grid's transform and active-voxel bounding box",
        }
    }

    /// The extensions that select the format (lower case, without the dot).
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            Format::Nrrd => &["nrrd", "nhdr"],
            Format::Nifti => &["nii", "nii.gz"],
            Format::Mrc => &["mrc", "map", "ccp4"],
            Format::MetaImage => &["mha", "mhd"],
            Format::Vti => &["vti"],
            Format::Vtk => &["vtk"],
            Format::Tiff => &["tif", "tiff"],
            Format::Vdb => &["vdb"],
            Format::Nvdb => &["nvdb"],
        }
    }

    /// The format a file name's extension selects (case-insensitive).
    pub fn from_path(path: &Path) -> Option<Format> {
        let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
        Format::ALL.into_iter().find(|f| {
            f.extensions().iter().any(|ext| {
                name.len() > ext.len() + 1
                    && name.ends_with(ext)
                    && name.as_bytes()[name.len() - ext.len() - 1] == b'.'
            })
        })
    }

    /// Every extension, as `.nrrd .nhdr ...`, for messages.
    pub fn all_extensions() -> String {
        Format::ALL
            .iter()
            .flat_map(|f| f.extensions())
            .map(|e| format!(".{e}"))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// What a reader needs besides the file.
#[derive(Clone, Debug)]
pub struct ReadOptions {
    pub limits: GridLimits,
    /// Voxel size for formats whose header has none (TIFF stacks); `None`: 1 per axis.
    pub spacing: Option<DVec3>,
    /// Which files a detached header's data file may be (NRRD `data file`, MetaImage
    /// `ElementDataFile`): the rule of the scene's own `path` keys, so a header inside the
    /// folders `serve` reads cannot lead it out of them.
    pub access: DataAccess,
    /// Which grid of a file holding several (`.vdb`, `.nvdb`): `[field] grid`.
    pub grid: Option<String>,
    /// Whether `[field] bounds` places the grid (a `.vdb` transform isoview cannot represent
    /// is then not needed).
    pub has_bounds: bool,
}

/// A volume read from a file: samples and geometry.
#[derive(Clone, Debug, PartialEq)]
pub struct Volume {
    /// Grid points along x, y, z (each at least 2).
    pub dims: [usize; 3],
    /// `dims[0] * dims[1] * dims[2]` finite samples, x fastest; empty for a sparse grid.
    pub values: Vec<f32>,
    /// World position of grid point (0, 0, 0).
    pub origin: DVec3,
    /// Distance between neighbouring points along each grid axis (positive).
    pub spacing: DVec3,
    /// Unit world directions of the grid's x, y and z axes.
    pub axes: [DVec3; 3],
    /// The file's sample type, in the format's own words (`int16`, `MET_FLOAT`, `mode 2 (float32)`).
    pub dtype: String,
    /// The detached data file the samples were read from (NRRD `data file`, MetaImage
    /// `ElementDataFile`); None when they are in the file itself. An input like the header:
    /// no output of the run may replace it (`cli::scene_inputs`).
    pub data_file: Option<std::path::PathBuf>,
    /// A `.vdb` or `.nvdb` grid's tree, held sparse ([`crate::field::sparse`]): `values` is
    /// then empty and [`Volume::samples`] densifies it for the paths that need it whole.
    pub sparse: Option<crate::field::sparse::SparseTree>,
}

impl Volume {
    /// Every sample, x fastest: `values`, or the sparse tree densified.
    pub fn samples(&self) -> std::borrow::Cow<'_, [f32]> {
        match &self.sparse {
            Some(tree) => std::borrow::Cow::Owned(tree.dense()),
            None => std::borrow::Cow::Borrowed(&self.values),
        }
    }

    /// Splits a world-from-index matrix (columns: the index axes' steps) into spacing (column
    /// lengths) and unit directions; fails on a zero or non-finite column, naming the header
    /// `field` it came from.
    pub(crate) fn set_axes(
        &mut self,
        columns: [DVec3; 3],
        field: &str,
        err: &Located,
    ) -> Result<(), FieldError> {
        for (k, c) in columns.iter().enumerate() {
            // An axis-aligned column keeps its spacing exact (no square root of a square).
            let aligned = c.to_array().iter().filter(|v| **v != 0.0).count() == 1;
            let len = if aligned { c.abs().max_element() } else { c.length() };
            if !usable_step(len) {
                return Err(err.bad(format!(
                    "{field}: axis {} steps by {}; {STEP_RULE}",
                    "xyz".as_bytes()[k] as char,
                    point(*c)
                )));
            }
            self.spacing[k] = len;
            self.axes[k] = *c / len;
        }
        Ok(())
    }
}

/// What every grid step must be, for messages: the one rule [`usable_step`] checks.
pub(crate) const STEP_RULE: &str = "a spacing must be a finite number over 0";

/// A header number for messages, short at any magnitude: `1e308` rather than 309 digits.
pub(crate) fn num(v: f64) -> String {
    let a = v.abs();
    if a.is_finite() && a != 0.0 && !(1e-5..1e16).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Three header numbers for messages: `(1, 0, 1e308)`.
pub(crate) fn point(v: DVec3) -> String {
    format!("({}, {}, {})", num(v.x), num(v.y), num(v.z))
}

/// Whether `s` can be the distance between neighbouring grid points.
pub(crate) fn usable_step(s: f64) -> bool {
    s.is_finite() && s > 0.0
}

/// Reads `path` as `format`.
pub fn read(path: &Path, format: Format, opts: &ReadOptions) -> Result<Volume, FieldError> {
    let err = Located { path, format, access: &opts.access };
    let v = match format {
        Format::Nrrd => nrrd::read(&err, opts)?,
        Format::Nifti => nifti::read(&err, opts)?,
        Format::Mrc => mrc::read(&err, opts)?,
        Format::MetaImage => metaimage::read(&err, opts)?,
        Format::Vti => vti::read(&err, opts)?,
        Format::Vtk => vtk_legacy::read(&err, opts)?,
        Format::Tiff => tiff::read(&err, opts)?,
        Format::Vdb => vdb::read(&err, opts)?,
        Format::Nvdb => nvdb::read(&err, opts)?,
    };
    check(&err, &v)?;
    Ok(v)
}

/// The invariants every reader promises, checked once here: at least 2 points per axis, and
/// a box whose every corner is a finite point (each reader has already named a bad header
/// field; this catches what only the sum overflows, e.g. a spacing of 1e308 times the points).
fn check(err: &Located, v: &Volume) -> Result<(), FieldError> {
    debug_assert!(
        v.sparse.is_some() || v.values.len() == v.dims.iter().product::<usize>(),
        "a dense volume holds every sample"
    );
    if v.dims.iter().any(|&d| d < 2) {
        return Err(err.bad(format!(
            "every axis needs at least 2 points, got {}x{}x{}",
            v.dims[0], v.dims[1], v.dims[2]
        )));
    }
    let far = (0..3).fold(v.origin, |p, k| p + v.axes[k] * (v.spacing[k] * (v.dims[k] - 1) as f64));
    let steps_ok = v.spacing.to_array().into_iter().all(usable_step);
    if !(v.origin.is_finite() && steps_ok && far.is_finite()) {
        return Err(err.bad(format!(
            "{}: origin {} and spacing {} over {}x{}x{} points put the grid's box out of range \
             (every coordinate must be a finite number)",
            err.format.geometry_fields(),
            point(v.origin),
            point(v.spacing),
            v.dims[0],
            v.dims[1],
            v.dims[2]
        )));
    }
    Ok(())
}

/// The bytes a reader looks at for its dims before it reads a whole file into memory.
const PEEK_BYTES: u64 = 64 << 10;

/// The first [`PEEK_BYTES`] of a file that is read whole (VTI, legacy VTK): the readers find
/// the declared dims there and check them against the cap before reading the rest, so a
/// header over the cap is refused without reading gigabytes first.
pub(crate) fn peek(err: &Located) -> Result<Vec<u8>, FieldError> {
    use std::io::Read;
    let file = err.access.open(err.path).map_err(|e| err.io(&e))?;
    let mut head = Vec::new();
    file.take(PEEK_BYTES).read_to_end(&mut head).map_err(|e| err.io(&e))?;
    Ok(head)
}

/// A file being read as a format: builds its errors.
pub(crate) struct Located<'a> {
    pub path: &'a Path,
    pub format: Format,
    /// How the files it names are opened ([`DataAccess::open`]).
    pub access: &'a DataAccess,
}

impl Located<'_> {
    /// `PATH: not a valid FORMAT file (WHY)`.
    pub fn bad(&self, why: impl Into<String>) -> FieldError {
        FieldError::Format {
            path: self.path.to_path_buf(),
            format: self.format.title(),
            message: super::error::one_line(&why.into()),
        }
    }

    /// `PATH: FORMAT: WHY` for a file over one of the reader's limits; `why` must not quote
    /// the file (see [`FieldError::ReaderLimit`]).
    pub fn over_limit(&self, why: String) -> FieldError {
        FieldError::ReaderLimit {
            path: self.path.to_path_buf(),
            format: self.format.title(),
            message: why,
        }
    }

    /// The memory cap for a grid of `dims`, named by this file.
    pub fn limits_check(&self, limits: &GridLimits, dims: [u64; 3]) -> Result<(), FieldError> {
        limits.check(dims, &self.path.display().to_string()).map(|_| ())
    }

    /// `v` when each of its numbers is finite, else the error naming the header `field`.
    pub fn finite(&self, field: &str, v: DVec3) -> Result<DVec3, FieldError> {
        match v.is_finite() {
            true => Ok(v),
            false => Err(self.bad(format!("{field} {} is not a finite point", point(v)))),
        }
    }

    pub fn io(&self, e: &std::io::Error) -> FieldError {
        FieldError::io(self.path, e)
    }

    /// The data file this detached header names under `key` (resolved against the header's
    /// folder), as [`DataAccess::admit`] lets it be read. The refusal names the header and
    /// the key but not the path: the path is the header's text.
    pub fn detached(
        &self,
        key: &'static str,
        data: &Path,
        access: &DataAccess,
    ) -> Result<std::path::PathBuf, FieldError> {
        access.admit(data).map_err(|_| FieldError::Outside { path: self.path.to_path_buf(), key })
    }

    /// The same error about another file (a detached header's data file).
    pub fn at<'b>(&'b self, path: &'b Path) -> Located<'b> {
        Located { path, format: self.format, access: self.access }
    }
}

/// A volume file read at load time (`source = "file"`).
#[derive(Clone, Debug)]
pub struct FileSource {
    /// The file, as resolved against the scene file's folder.
    pub path: std::path::PathBuf,
    pub format: Format,
    pub volume: std::sync::Arc<Volume>,
}
