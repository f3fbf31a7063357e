//! isoview's bridge to the OpenVDB library: `.vdb` files read by OpenVDB itself (Debian's
//! `libopenvdb-dev`, 10.0), so every compression (zip, blosc), half floats and every grid class
//! are read as OpenVDB reads them.
//!
//! The C++ side (`cpp/bridge.cpp`) is a small C ABI: open a file (delayed loading off, so
//! OpenVDB reads through a stream, never a mapping a truncation could turn into SIGBUS), list
//! its grids, read one float or double grid and export its tree's nodes. Every C++ exception is
//! caught there and comes back as an [`Error`] holding its message (at most 400 bytes).
//!
//! OpenVDB trusts its input (a flipped length byte made it allocate 17 GB), so callers read
//! through [`isolated`]: a forked child under limits of memory and time.
//!
//! Nothing here knows isoview's types: the caller (isoview's `field::formats::vdb`) turns a
//! [`Grid`] into its field.

mod isolate;

pub use isolate::{isolated, Limits, Reply};

/// Runs OpenVDB's one-time set-up in this process (idempotent). Call it before
/// [`isolated`] forks a reader: the set-up registers exit handlers, and a child forked while
/// another thread held the C library's atexit lock would wait on it for ever.
pub fn initialize() {
    // SAFETY: no arguments; the bridge runs openvdb::initialize once (std::call_once).
    unsafe { ivdb_initialize() }
}

use std::ffi::{c_char, CStr, CString};
use std::path::Path;

/// What OpenVDB said (an exception's message), or why the bridge refused.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error(pub String);

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Error {}

#[repr(C)]
struct RawFile {
    _private: [u8; 0],
}

#[repr(C)]
struct RawGrid {
    _private: [u8; 0],
}

#[repr(C)]
struct RawInfo {
    linear: i32,
    map_type: [c_char; 64],
    mat: [f64; 16],
    bbox_min: [i32; 3],
    bbox_max: [i32; 3],
    background: f64,
    grid_class: i32,
    bits: i32,
    half: i32,
    active_voxels: u64,
    leaf_count: u64,
}

extern "C" {
    fn ivdb_initialize();
    fn ivdb_open(path: *const c_char, err: *mut c_char, cap: usize) -> *mut RawFile;
    fn ivdb_close(f: *mut RawFile);
    fn ivdb_grid_count(f: *const RawFile) -> usize;
    fn ivdb_grid_name(f: *const RawFile, i: usize) -> *const c_char;
    fn ivdb_grid_type(f: *const RawFile, i: usize) -> *const c_char;
    fn ivdb_grid_class(f: *const RawFile, i: usize) -> *const c_char;
    fn ivdb_read(
        f: *mut RawFile,
        i: usize,
        info: *mut RawInfo,
        err: *mut c_char,
        cap: usize,
    ) -> *mut RawGrid;
    fn ivdb_grid_free(g: *mut RawGrid);
    fn ivdb_tree_counts(g: *const RawGrid, counts: *mut u64, err: *mut c_char, cap: usize) -> i32;
    fn ivdb_tree_export(
        g: *const RawGrid,
        counts: *const u64,
        out: *mut u8,
        len: usize,
        err: *mut c_char,
        cap: usize,
    ) -> i32;
}

/// Room for an exception's message (the C++ side cuts it at 400 bytes).
const ERR_CAP: usize = 512;

fn message(buf: &[c_char; ERR_CAP]) -> Error {
    // SAFETY: the buffer is zeroed and the C++ side writes at most ERR_CAP - 1 bytes and a NUL.
    let s = unsafe { CStr::from_ptr(buf.as_ptr()) };
    Error(explained(&s.to_string_lossy()))
}

/// An exception's message as isoview shows it. OpenVDB throws some with no text, only the
/// type (`KeyError:` for a file cut short after its header, whose message quoted a name read
/// from bytes that were not there): alone, that says nothing of what is wrong.
pub fn explained(what: &str) -> String {
    let what = what.trim();
    let kind = what.trim_end_matches(':');
    if what.is_empty() {
        "OpenVDB failed without a message".into()
    } else if !kind.contains(char::is_whitespace) {
        format!("{kind} (OpenVDB gave no reason: the file may be cut short or corrupt)")
    } else {
        what.into()
    }
}

fn owned(p: *const c_char) -> String {
    if p.is_null() {
        return String::new();
    }
    // SAFETY: a NUL-terminated string owned by the open file, copied before it is closed.
    unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
}

/// One grid of a file, as its descriptor names it (its tree is not read yet).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GridMeta {
    pub name: String,
    /// OpenVDB's value type name: `float`, `double`, `vec3s`, `int32`, `bool`, ...
    pub value_type: String,
    /// `level set`, `fog volume`, `staggered` or `unknown`.
    pub class: String,
}

impl GridMeta {
    /// Whether isoview can read the grid: a float or double grid.
    pub fn is_scalar(&self) -> bool {
        self.value_type == "float" || self.value_type == "double"
    }
}

/// An open `.vdb` file: its grids' descriptors are read, their trees are not.
pub struct File {
    raw: *mut RawFile,
    grids: Vec<GridMeta>,
}

// SAFETY: the handle is used by one thread at a time (&mut for reads); OpenVDB's io::File
// holds no thread-affine state.
unsafe impl Send for File {}

impl File {
    /// Opens `path` with delayed loading off and reads every grid's descriptor.
    pub fn open(path: &Path) -> Result<File, Error> {
        use std::os::unix::ffi::OsStrExt;
        let c = CString::new(path.as_os_str().as_bytes())
            .map_err(|_| Error("the path holds a NUL byte".into()))?;
        let mut err = [0 as c_char; ERR_CAP];
        // SAFETY: c is NUL-terminated; err has ERR_CAP bytes.
        let raw = unsafe { ivdb_open(c.as_ptr(), err.as_mut_ptr(), ERR_CAP) };
        if raw.is_null() {
            return Err(message(&err));
        }
        // SAFETY: raw is a valid handle until ivdb_close.
        let n = unsafe { ivdb_grid_count(raw) };
        let grids = (0..n)
            .map(|i| unsafe {
                GridMeta {
                    name: owned(ivdb_grid_name(raw, i)),
                    value_type: owned(ivdb_grid_type(raw, i)),
                    class: owned(ivdb_grid_class(raw, i)),
                }
            })
            .collect();
        Ok(File { raw, grids })
    }

    /// The file's grids, in file order.
    pub fn grids(&self) -> &[GridMeta] {
        &self.grids
    }

    /// Reads grid `index` (a float or double grid, see [`GridMeta::is_scalar`]) whole.
    pub fn read(&mut self, index: usize) -> Result<Grid, Error> {
        if index >= self.grids.len() {
            return Err(Error(format!("no grid {index}")));
        }
        // SAFETY: all fields of RawInfo are plain numbers; zero is a valid value for each.
        let mut info: RawInfo = unsafe { std::mem::zeroed() };
        let mut err = [0 as c_char; ERR_CAP];
        // SAFETY: raw is valid, index is in range, info and err are writable.
        let raw = unsafe { ivdb_read(self.raw, index, &mut info, err.as_mut_ptr(), ERR_CAP) };
        if raw.is_null() {
            return Err(message(&err));
        }
        // SAFETY: map_type is NUL-terminated by the C++ side (strncpy of at most 63 bytes into
        // a zeroed array).
        let map_type = unsafe { CStr::from_ptr(info.map_type.as_ptr()) }.to_string_lossy();
        let m = info.mat;
        let info = GridInfo {
            linear: info.linear != 0,
            map_type: map_type.into_owned(),
            rows: [
                [m[0], m[1], m[2], m[3]],
                [m[4], m[5], m[6], m[7]],
                [m[8], m[9], m[10], m[11]],
                [m[12], m[13], m[14], m[15]],
            ],
            bbox: (info.bbox_min, info.bbox_max),
            background: info.background,
            class: info.grid_class,
            double: info.bits == 64,
            half: info.half != 0,
            active_voxels: info.active_voxels,
            leaf_count: info.leaf_count,
        };
        Ok(Grid { raw, info })
    }
}

impl Drop for File {
    fn drop(&mut self) {
        // SAFETY: raw came from ivdb_open and is closed once.
        unsafe { ivdb_close(self.raw) }
    }
}

/// A grid's transform and tree, as OpenVDB gives them.
#[derive(Clone, Debug, PartialEq)]
pub struct GridInfo {
    /// Whether the transform is a linear map (scale, rotation, translation, affine).
    pub linear: bool,
    /// OpenVDB's name of the map (`UniformScaleMap`, `AffineMap`, `NonlinearFrustumMap`, ...).
    pub map_type: String,
    /// For a linear map: world = `[i, j, k, 1] * rows` (OpenVDB's row vectors); zero otherwise.
    pub rows: [[f64; 4]; 4],
    /// The active-voxel index bounding box, inclusive (min > max: no active voxel).
    pub bbox: ([i32; 3], [i32; 3]),
    pub background: f64,
    /// OpenVDB's GridClass: 0 unknown, 1 level set, 2 fog volume, 3 staggered.
    pub class: i32,
    /// A double grid (rounded to f32 by [`Grid::export`]).
    pub double: bool,
    /// Saved as half floats.
    pub half: bool,
    pub active_voxels: u64,
    pub leaf_count: u64,
}

/// One float or double grid read into memory.
pub struct Grid {
    raw: *mut RawGrid,
    pub info: GridInfo,
}

// SAFETY: the grid is read-only after ivdb_read; the exports only read it.
unsafe impl Send for Grid {}
unsafe impl Sync for Grid {}

/// How many nodes of each kind a grid's tree holds (OpenVDB's 5-4-3 tree: a root table over
/// upper internal nodes of 32³ entries, lower ones of 16³, leaves of 8³ voxels).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TreeCounts {
    /// Tiles of the root's table (active or not); coordinates outside the table and every
    /// node are the background.
    pub root_tiles: u64,
    pub upper: u64,
    pub lower: u64,
    pub leaves: u64,
}

/// Bytes of one record of [`Grid::export`]: an origin (3 × i32) and the node's values.
pub const ROOT_TILE_RECORD: u64 = 16;
pub const UPPER_RECORD: u64 = 12 + 4 * 32768;
pub const LOWER_RECORD: u64 = 12 + 4 * 4096;
pub const LEAF_RECORD: u64 = 12 + 4 * 512;

impl TreeCounts {
    /// Bytes [`Grid::export`] writes for these counts (None past u64).
    pub fn export_bytes(&self) -> Option<u64> {
        let parts = [
            self.root_tiles.checked_mul(ROOT_TILE_RECORD)?,
            self.upper.checked_mul(UPPER_RECORD)?,
            self.lower.checked_mul(LOWER_RECORD)?,
            self.leaves.checked_mul(LEAF_RECORD)?,
        ];
        parts.iter().try_fold(0u64, |a, &b| a.checked_add(b))
    }
}

impl Grid {
    /// The counts of the tree's nodes.
    pub fn tree_counts(&self) -> Result<TreeCounts, Error> {
        let mut c = [0u64; 4];
        let mut err = [0 as c_char; ERR_CAP];
        // SAFETY: c holds 4 values, err is writable.
        let rc = unsafe { ivdb_tree_counts(self.raw, c.as_mut_ptr(), err.as_mut_ptr(), ERR_CAP) };
        match rc {
            0 => Ok(TreeCounts { root_tiles: c[0], upper: c[1], lower: c[2], leaves: c[3] }),
            _ => Err(message(&err)),
        }
    }

    /// The tree's nodes as records into `out` (exactly [`TreeCounts::export_bytes`] of
    /// `counts`), little-endian, in this order: root tiles (origin, value), upper nodes
    /// (origin, 32³ entry values: a tile's value, 0 where a child is), lower nodes (origin, 16³
    /// entry values), leaves (origin, 8³ values, active or not); entries in OpenVDB's offset
    /// order (x slowest, z fastest), doubles rounded to f32. The values are what OpenVDB's
    /// `getValue` gives: a voxel in a leaf its value, else the tile holding it, else the
    /// background.
    pub fn export(&self, counts: &TreeCounts, out: &mut [u8]) -> Result<(), Error> {
        if counts.export_bytes() != Some(out.len() as u64) {
            return Err(Error("the export's room does not match the tree's counts".into()));
        }
        let c = [counts.root_tiles, counts.upper, counts.lower, counts.leaves];
        let mut err = [0 as c_char; ERR_CAP];
        // SAFETY: c holds 4 values, out holds exactly the bytes they make (checked above and
        // again on the C++ side), err is writable.
        let rc = unsafe {
            ivdb_tree_export(
                self.raw,
                c.as_ptr(),
                out.as_mut_ptr(),
                out.len(),
                err.as_mut_ptr(),
                ERR_CAP,
            )
        };
        match rc {
            0 => Ok(()),
            _ => Err(message(&err)),
        }
    }
}

impl Drop for Grid {
    fn drop(&mut self) {
        // SAFETY: raw came from ivdb_read and is freed once.
        unsafe { ivdb_grid_free(self.raw) }
    }
}
