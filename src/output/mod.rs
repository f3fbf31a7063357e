//! Everything isoview writes to disk, and the EXR reader that `compare` and the tests use.
//!
//! - [`atomic`]: every output file is written whole or not at all (temporary file in the same
//!   folder, fsync, rename). Other modules (meshes, JSON, SVG) use [`atomic::write_with`] too.
//! - [`exr`]: a [`Frame`](crate::frame::Frame) as a one-part, 32-bit float, ZIP-compressed
//!   OpenEXR file with the channels and header attributes of the interface contract, written
//!   byte-deterministically; and a general reader ([`exr::read()`]) for EXRs from any writer.
//!   The file is written band by band as a render draws it ([`exr::ExrStream`], memory: one
//!   block of scan lines), or as named float channels row by row ([`exr::PlaneStream`],
//!   `compare --diff`); [`exr::write_frame`], [`exr::encode_frame`] and
//!   [`exr::write_channels`] are those streams given every row.
//! - [`png`]: an 8-bit sRGB preview of the beauty (RGBA).
//! - [`frame_files`]: a rendered frame's EXR, PNG preview and tev view, each band written as it
//!   is drawn (what `isoview render` writes for each frame).
//! - [`guard`]: the one rule for which paths a verb may write (never one of its inputs, never
//!   a device, FIFO or socket), checked before writing.
//! - [`tev`]: a frame sent to the tev HDR viewer over TCP (its remote-control protocol).

pub mod atomic;
pub mod exr;
pub mod frame_files;
pub mod guard;
pub mod legend;
pub mod png;
pub mod tev;

use std::path::{Path, PathBuf};

use crate::vocab::Placement;

/// How an output's header records a grid's [`Placement`] (None for the identity, which is
/// not recorded, so unplaced outputs are unchanged): the pivot and the world directions of
/// the grid's x, y, z axes, as `pivot [x, y, z] axes [a, b, c] [d, e, f] [g, h, i]`.
pub fn describe_placement(p: &Placement) -> Option<String> {
    if p.is_identity() {
        return None;
    }
    let v = |d: glam::DVec3| format!("[{}, {}, {}]", d.x, d.y, d.z);
    Some(format!(
        "pivot {} axes {} {} {}",
        v(p.pivot),
        v(p.axes.x_axis),
        v(p.axes.y_axis),
        v(p.axes.z_axis)
    ))
}

/// Why an output file could not be written, or an input EXR could not be read.
///
/// Every variant names the file; `Display` is one line.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// A filesystem operation failed (`action` says which: "create", "write", "rename", "read").
    #[error("{}: cannot {action}: {source}", path.display())]
    Io {
        path: PathBuf,
        action: &'static str,
        #[source]
        source: std::io::Error,
    },
    /// The `exr` crate could not encode or decode the file.
    #[error("{}: {action}: {source}", path.display())]
    Exr {
        path: PathBuf,
        action: &'static str,
        #[source]
        source: ::exr::error::Error,
    },
    /// The data to write, or the file read, is not what it should be (the reason says how).
    #[error("{}: {reason}", path.display())]
    Invalid { path: PathBuf, reason: String },
    /// The output given as `flag` may not be written ([`guard::check`]: an input, another
    /// output of the run, or not a regular file).
    #[error("{flag} {}: {reason}", path.display())]
    Refused { flag: String, path: PathBuf, reason: String },
}

impl OutputError {
    pub(crate) fn io(path: &Path, action: &'static str, source: std::io::Error) -> Self {
        OutputError::Io { path: path.to_path_buf(), action, source }
    }

    pub(crate) fn invalid(path: &Path, reason: impl Into<String>) -> Self {
        OutputError::Invalid { path: path.to_path_buf(), reason: reason.into() }
    }
}
