//! [`FieldError`]: why a field could not be sampled, as one line naming the file or expression.

use std::path::PathBuf;

use super::access::OUTSIDE;
use super::limits::GRID_CAP_ENV;

/// Appended to [`FieldError::TooLarge`] for the sources `field.residency` can read in parts.
pub const RESIDENCY_HINT: &str =
    ", or read only the bricks a render needs with field.residency = \"auto\"";

/// Appended to [`FieldError::TooLarge`] when an npy or raw grid that `field.residency` lets
/// be read in parts ("auto", "active") reaches a command that needs it whole.
/// What a `.vdb`/`.nvdb` grid over the cap can still do (the paths that read its tree).
pub const SPARSE_HINT: &str =
    "; this command needs the whole grid (a .vdb or .nvdb grid over the cap is read sparsely by \
     the ray methods of `render` and by `extract`, with trilinear cells at render.mesh_refine = 1)";

pub const WHOLE_GRID_HINT: &str =
    "; this command needs the whole grid (the ray methods of `render` and `extract` read one \
     over the cap in parts)";

/// Why a field could not be sampled: a data file that is missing, malformed or too large, or an
/// expression that does not parse or produces a non-finite value.
///
/// `Display` is one line that names the file (or expression) and what is wrong.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FieldError {
    /// The data file could not be opened or read.
    #[error("{}: {message}", shown(path))]
    Io { path: PathBuf, message: String },

    /// The file is not a valid `.npy` file.
    #[error("{}: not a valid .npy file ({reason})", shown(path))]
    NotNpy { path: PathBuf, reason: String },

    /// The samples' type is not one isoview reads.
    #[error("{}: unsupported dtype {dtype} ({hint})", shown(path))]
    UnsupportedDtype { path: PathBuf, dtype: String, hint: String },

    /// The array is not a 3-D grid of at least 2 points per axis.
    #[error("{}: {message}", shown(path))]
    BadShape { path: PathBuf, message: String },

    /// A mesh file (`source = "mesh"`) that cannot be used: not STL/OBJ/PLY, malformed, empty,
    /// out-of-range indices or non-finite vertices.
    #[error("{}: {message}", shown(path))]
    BadMesh { path: PathBuf, message: String },

    /// A volume file (`source = "file"`) whose header or data is malformed or unsupported;
    /// `format` names the format as the user knows it (`NRRD`, `MRC`).
    #[error("{}: {format}: {message}", shown(path))]
    Format { path: PathBuf, format: &'static str, message: String },

    /// A volume file over one of its reader's own limits (XML nesting, a file far larger
    /// than any grid under the cap). Unlike [`FieldError::Format`] the message holds only
    /// numbers and positions, never text from the file, so `serve` shows it to the page.
    #[error("{}: {format}: {message}", shown(path))]
    ReaderLimit { path: PathBuf, format: &'static str, message: String },

    /// A detached header (NRRD `data file`, MetaImage `ElementDataFile`) names a data file
    /// outside the folders `serve` may read. `path`: the header; the data file's name is the
    /// header's text, so it is not repeated.
    #[error("{}: {key}: the data file it names is {OUTSIDE}", shown(path))]
    Outside { path: PathBuf, key: &'static str },

    /// The file ends before all samples were read.
    #[error(
        "{}: truncated data: expected {expected} bytes of samples ({layout}), found {actual}",
        shown(path)
    )]
    Truncated { path: PathBuf, expected: u64, actual: u64, layout: String },

    /// The file holds more bytes than the declared dims and dtype account for.
    #[error(
        "{}: dims do not match the data: {layout} is {expected} bytes of samples, the file has {actual}",
        shown(path)
    )]
    SizeMismatch { path: PathBuf, expected: u64, actual: u64, layout: String },

    /// The grid's `f32` samples would exceed the memory cap; refused before any allocation.
    /// `hint`: what else the source allows (empty, or [`RESIDENCY_HINT`] for npy and raw).
    #[error(
        "{what}: a grid of {}x{}x{} points needs {} of f32 samples, over the cap of {}; \
         raise the cap with {GRID_CAP_ENV}={} (or GridLimits::max_bytes){hint}",
        dims[0], dims[1], dims[2], mib(*bytes), mib(*cap as u128), bytes.div_ceil(1 << 20)
    )]
    TooLarge { what: String, dims: [u64; 3], bytes: u128, cap: u64, hint: &'static str },

    /// The grid's `f32` samples would take more than 2^64 bytes: no cap or residency helps.
    #[error(
        "{what}: a grid of {}x{}x{} points needs {} of f32 samples, more than 64-bit memory can \
         address (16 EiB)",
        dims[0], dims[1], dims[2], mib(*bytes)
    )]
    Unaddressable { what: String, dims: [u64; 3], bytes: u128 },

    /// The grid's `f32` samples would take more than this machine's memory, under a cap the
    /// user raised past it: refused before the allocation would abort the process.
    #[error(
        "{what}: a grid of {}x{}x{} points needs {} of f32 samples, more than this machine's \
         {} of memory ({GRID_CAP_ENV} allows it); use a coarser grid, or field.residency = \
         \"active\" for a raw or npy file",
        dims[0], dims[1], dims[2], mib(*bytes), mib(*memory as u128)
    )]
    OverMemory { what: String, dims: [u64; 3], bytes: u128, memory: u64 },

    /// `field.residency = "active"`: the bricks the isovalues need, with the brick tables
    /// (min/max and page table: 12 bytes a brick), would exceed the memory cap.
    #[error(
        "{what}: the bricks the isovalues need ({resident} of {bricks} bricks of 8^3 cells) and \
         the brick tables take {} on the device, over the cap of {}; raise the cap with \
         {GRID_CAP_ENV}={} (or GridLimits::max_bytes)",
        mib(*bytes as u128), mib(*cap as u128), bytes.div_ceil(1 << 20)
    )]
    PoolTooLarge { what: String, resident: usize, bricks: usize, bytes: u64, cap: u64 },

    /// `field.residency = "active"`: the brick tables alone would exceed the memory cap
    /// (refused before the file is scanned).
    #[error(
        "{what}: a grid of {}x{}x{} points has {bricks} bricks of 8^3 cells, whose tables \
         (min/max and page table, 12 bytes a brick) take {} on the device, over the cap of {}; \
         raise the cap with {GRID_CAP_ENV}={} (or GridLimits::max_bytes)",
        dims[0], dims[1], dims[2], mib(*bytes as u128), mib(*cap as u128), bytes.div_ceil(1 << 20)
    )]
    TablesTooLarge { what: String, dims: [usize; 3], bricks: u64, bytes: u64, cap: u64 },

    /// A sparse tree's superbrick tables alone would exceed the memory cap (refused before the
    /// tree is scanned).
    #[error(
        "{what}: a grid of {}x{}x{} points has {supers} superbricks of 32^3 cells, whose tables \
         (range and block, 12 bytes each) take {} on the device, over the cap of {}; raise the \
         cap with {GRID_CAP_ENV}={} (or GridLimits::max_bytes)",
        dims[0], dims[1], dims[2], mib(*bytes as u128), mib(*cap as u128), bytes.div_ceil(1 << 20)
    )]
    SuperTablesTooLarge { what: String, dims: [usize; 3], supers: u64, bytes: u64, cap: u64 },

    /// The grid has more points along an axis than the device's 3D images hold (a grid uploaded
    /// whole is one image). `what`: the key or header that sets the dims.
    #[error(
        "{what} [{}, {}, {}]: {} points along {} are over this device's limit of {max} per axis \
         (its largest 3D image; `isoview info` shows it){hint}",
        dims[0], dims[1], dims[2], dims[*axis], ["x", "y", "z"][*axis]
    )]
    OverDevice { what: String, dims: [usize; 3], axis: usize, max: u32, hint: &'static str },

    /// A file read on demand (`field.residency`) came back short: another process truncated it
    /// after it was opened and checked. `len`: its size now, when it can still be read.
    #[error("{}: shrank to {} while being read", shown(path), len.map_or("fewer bytes".to_string(), |n| format!("{n} bytes")))]
    Shrank { path: PathBuf, len: Option<u64> },

    /// A sample is NaN or infinite; `index` is the first such grid point (x fastest).
    #[error("{what}: value {value} at grid point [{}, {}, {}]{detail} is not finite", index[0], index[1], index[2])]
    NonFinite { what: String, index: [usize; 3], value: f32, detail: String },

    /// A finite sample beyond f32's range (|v| > 3.4e38), which the grid's f32 would hold as
    /// ±inf: refused whatever `field.nan` says, as it is not missing data
    /// ([`super::samples::narrow`]).
    #[error(
        "{what}: value {} at grid point [{}, {}, {}]{detail} is beyond ±{:e}, the range of the \
         32-bit floats samples are kept in",
        crate::vocab::echo_number(*value), index[0], index[1], index[2], f32::MAX
    )]
    OutOfRange { what: String, index: [usize; 3], value: f64, detail: String },

    /// An expression that does not parse, or names something unknown.
    #[error("expression \"{}\": {message}", crate::vocab::echo(text))]
    Expr { text: String, message: String },

    /// `ISOVIEW_MAX_GRID_MIB` is set to something that is not a positive whole number.
    #[error("{GRID_CAP_ENV}={value:?}: expected a positive whole number of MiB")]
    BadLimit { value: String },
}

/// A byte count for messages: `32768 MiB`, `4.3 KiB`, `12 bytes`.
/// A size for messages, one rounding everywhere (a refusal and the pool's summary of the same
/// grid print the same number): whole MiB/KiB when exact, else to 3 significant digits or the
/// nearest whole unit.
pub(crate) fn mib(bytes: u128) -> String {
    let (unit, name) = if bytes >= 1 << 20 {
        (1u128 << 20, "MiB")
    } else if bytes >= 1 << 10 {
        (1 << 10, "KiB")
    } else {
        return format!("{bytes} bytes");
    };
    if bytes % unit == 0 {
        format!("{} {name}", bytes / unit)
    } else if bytes / unit >= 100 {
        format!("{:.0} {name}", bytes as f64 / unit as f64)
    } else {
        format!("{:.1} {name}", bytes as f64 / unit as f64)
    }
}

impl FieldError {
    /// An I/O error on `path`, worded for a user ("file not found" rather than "os error 2").
    pub(crate) fn io(path: &std::path::Path, err: &std::io::Error) -> FieldError {
        use std::io::ErrorKind;
        let refused = err.get_ref().and_then(|e| e.downcast_ref::<crate::vocab::NotRegular>());
        if let Some(refused) = refused {
            return FieldError::Io { path: path.to_path_buf(), message: refused.to_string() };
        }
        if let Some(escaped) =
            err.get_ref().and_then(|e| e.downcast_ref::<super::access::Escaped>())
        {
            return FieldError::Io { path: path.to_path_buf(), message: escaped.to_string() };
        }
        let message = match err.kind() {
            ErrorKind::NotFound => "file not found".to_string(),
            ErrorKind::PermissionDenied => "permission denied".to_string(),
            ErrorKind::IsADirectory => "is a directory, not a file".to_string(),
            _ => format!("cannot read: {}", one_line(&err.to_string())),
        };
        FieldError::Io { path: path.to_path_buf(), message }
    }
}

/// Collapses a message onto one line.
pub(crate) fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// A path as messages show it: control characters escaped (a newline in a file name reads
/// `\n`, not a line break, nor a space once the message is kept on one line).
pub(crate) fn shown(path: &std::path::Path) -> String {
    crate::vocab::escape_unprintable(&path.display().to_string()).into_owned()
}
