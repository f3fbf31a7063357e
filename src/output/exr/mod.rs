//! OpenEXR: writing a [`Frame`] the way the interface contract says, and reading any EXR.
//!
//! # Writing ([`write_frame`])
//!
//! One part, scan lines, ZIP (16 lines per block), increasing line order, every channel a
//! 32-bit float, `dataWindow == displayWindow == (0,0)-(w-1,h-1)`, row 0 at the top. The
//! channels are the rows of the channel table, [`crate::frame::Channel`]:
//!
//! | channel | meaning | on a miss |
//! | --- | --- | --- |
//! | `R`, `G`, `B`, `A` | shaded colour, linear Rec.709; A = coverage | background |
//! | `Z` | distance along the ray from the eye to the hit | +inf |
//! | `N.X`, `N.Y`, `N.Z` | world-space unit normal, inside to outside | 0 |
//! | `P.X`, `P.Y`, `P.Z` | world-space hit position | 0 |
//! | `steps` | samples (fixed-step) or cells (analytic) the ray visited | counted anyway |
//! | `cell.X`, `cell.Y`, `cell.Z` | integer index of the grid cell hit (as a float) | -1 |
//! | `crossings` | isovalue crossings along the ray; only written when some pixel has one counted (≥ 0) | -1 |
//!
//! Header attributes (names in [`attr`]; OpenEXR type in brackets):
//!
//! | attribute | value |
//! | --- | --- |
//! | `isoview/version` (string) | [`crate::VERSION`] |
//! | `isoview/scene` (string) | the scene file as given on the command line |
//! | `isoview/eye`, `isoview/target`, `isoview/up` (v3f) | the camera, world space |
//! | `isoview/fovY` (double) | full vertical field of view, degrees |
//! | `isoview/isovalue` (double) | the isovalue |
//! | `isoview/method` (string) | `analytic`, `fixed-step` or `mesh` |
//! | `isoview/time` (double) | the field's time (`--time`) |
//! | `isoview/device`, `isoview/driver` (string) | the Vulkan device and driver |
//! | `isoview/extra/<key>` (string) | each `FrameInfo::extra` pair |
//! | `software` (string) | `isoview <version>` |
//! | `chromaticities` | Rec.709 primaries, D65 white |
//! | `worldToCamera`, `worldToNDC` (m44f) | the standard OpenEXR camera matrices (row-vector convention, camera space x right, y up, z forward; NDC (0,0) top-left, (1,1) bottom-right); omitted for a degenerate camera |
//!
//! Strings are stored as UTF-8 bytes.
//!
//! ## Deterministic bytes
//!
//! The `exr` crate keeps custom attributes in a `HashMap`, so their order in the header
//! changes from process to process. After encoding the header, the writer
//! ([`blocks`], behind [`write_frame`], [`encode_frame`] and [`write_channels`])
//! therefore sorts its attributes by name (the order OpenEXR's own library writes them in).
//! Reordering keeps the header's length, so the chunk offset table after it stays valid. With
//! scan lines in increasing order and one block compressed at a time, equal frames give equal
//! bytes.
//!
//! # Reading ([`read`])
//!
//! Any compression the `exr` crate decodes (none, RLE, ZIPS, ZIP, PIZ, PXR24, B44, B44A,
//! DWAA/DWAB), scan lines or tiles (largest mip level), half/float/uint channels (converted to
//! `f32`; uint above 2^24 loses precision). The image is the *display window*: pixels outside
//! it are dropped and display-window pixels outside the data window read as 0. Channel names
//! are kept as written (`depth.Z` stays `depth.Z`). Multi-part files are merged: every
//! channel is renamed `<part name>.<channel>` (unless it already starts with that prefix),
//! all parts must have the same size, and the header attributes are those of the first part.
//! Deep data is not supported.
//!
//! # Where each part lives
//!
//! | file | what |
//! | --- | --- |
//! | this one | the contract above, [`attr`], and the whole-image writers: [`write_frame`], [`encode_frame`], [`write_channels`] (the streaming writers given every row) |
//! | [`header`] | the header: channels, attributes, camera matrices ([`camera_matrices`]), the attribute sort |
//! | [`blocks`] | a scan-line file written block by block (to a temporary file or memory), shared by both streams |
//! | [`stream`] | [`ExrStream`]: a render's records, band by band |
//! | [`planes`] | [`PlaneStream`]: named float planes, row by row (`compare --diff`) |
//! | [`read`](mod@read) | [`read()`]: any EXR, into an [`ExrImage`] |

mod blocks;
mod header;
mod planes;
mod read;
mod stream;

use std::path::Path;

pub use header::camera_matrices;
pub use planes::PlaneStream;
pub use read::{attribute_text, read, ExrChannel, ExrImage, SampleKind};
pub use stream::ExrStream;

use super::OutputError;
use crate::frame::{Channel, Frame, Written};

/// Names of the header attributes isoview writes.
pub mod attr {
    pub const VERSION: &str = "isoview/version";
    pub const SCENE: &str = "isoview/scene";
    pub const EYE: &str = "isoview/eye";
    pub const TARGET: &str = "isoview/target";
    pub const UP: &str = "isoview/up";
    pub const FOV_Y: &str = "isoview/fovY";
    pub const ISOVALUE: &str = "isoview/isovalue";
    pub const METHOD: &str = "isoview/method";
    pub const TIME: &str = "isoview/time";
    pub const DEVICE: &str = "isoview/device";
    pub const DRIVER: &str = "isoview/driver";
    /// Prefix of the `FrameInfo::extra` pairs: `isoview/extra/<key>`.
    pub const EXTRA_PREFIX: &str = "isoview/extra/";
}

/// Encodes `frame` as described in the module docs and writes it atomically to `path`,
/// through the streaming writer ([`ExrStream`]; its bytes are
/// [`encode_frame`]'s).
pub fn write_frame(path: &Path, frame: &Frame) -> Result<(), OutputError> {
    check_size(path, frame)?;
    let channels = written_channels(frame);
    let mut stream = ExrStream::create(path, frame.width, frame.height, &channels, &frame.info)?;
    stream.push_rows(&frame.pixels)?;
    stream.finish()
}

/// Refuses an empty frame or one whose pixels do not fill `width` × `height`.
fn check_size(path: &Path, frame: &Frame) -> Result<(), OutputError> {
    let (w, h) = (frame.width as usize, frame.height as usize);
    if w == 0 || h == 0 {
        return Err(OutputError::invalid(path, format!("cannot write an empty {w}x{h} image")));
    }
    if frame.pixels.len() != w * h {
        return Err(OutputError::invalid(
            path,
            format!("frame has {} pixels, expected {w}x{h} = {}", frame.pixels.len(), w * h),
        ));
    }
    Ok(())
}

/// The bytes [`write_frame`] writes (`path` only names the file in errors): the same
/// streaming writer, into memory.
pub fn encode_frame(path: &Path, frame: &Frame) -> Result<Vec<u8>, OutputError> {
    check_size(path, frame)?;
    let channels = written_channels(frame);
    let mut stream = ExrStream::in_memory(path, frame.width, frame.height, &channels, &frame.info)?;
    stream.push_rows(&frame.pixels)?;
    stream.finish_bytes()
}

/// The channels [`write_frame`] writes for `frame`, in table order: every [`Written::Always`]
/// channel, each [`Written::WhereCounted`] one where some pixel holds a count (>= 0), and each
/// [`Written::WhereFinite`] one where some pixel holds a finite value.
pub fn written_channels(frame: &Frame) -> Vec<Channel> {
    Channel::ALL
        .into_iter()
        .filter(|c| match c.written() {
            Written::Always => true,
            Written::WhereCounted => frame.pixels.iter().any(|p| c.get(p) >= 0.0),
            Written::WhereFinite => frame.pixels.iter().any(|p| c.get(p).is_finite()),
        })
        .collect()
}

/// Writes arbitrary 32-bit float channels (each `width * height` values, row 0 at the top)
/// with text attributes, atomically, encoded like [`write_frame`] (one part, ZIP, sorted
/// header): the streaming writer of named planes ([`PlaneStream`]) given
/// every row at once. Used by modules that need an EXR of their own channels.
pub fn write_channels(
    path: &Path,
    width: usize,
    height: usize,
    channels: Vec<(String, Vec<f32>)>,
    text_attributes: &[(String, String)],
) -> Result<(), OutputError> {
    if width == 0 || height == 0 || channels.is_empty() {
        return Err(OutputError::invalid(
            path,
            format!(
                "cannot write an empty {width}x{height} image with {} channels",
                channels.len()
            ),
        ));
    }
    for (name, values) in &channels {
        if values.len() != width * height {
            return Err(OutputError::invalid(
                path,
                format!("channel {name:?} has {} values, expected {width}x{height}", values.len()),
            ));
        }
    }
    let names: Vec<String> = channels.iter().map(|(name, _)| name.clone()).collect();
    let mut stream = PlaneStream::create(path, width, height, &names, text_attributes)?;
    let planes: Vec<&[f32]> = channels.iter().map(|(_, values)| values.as_slice()).collect();
    stream.push_rows(&planes)?;
    stream.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{FrameInfo, Pixel};
    use glam::DVec3;

    pub(super) fn info() -> FrameInfo {
        FrameInfo {
            scene: "scenes/torus.toml".into(),
            eye: DVec3::new(2.2, 1.6, 2.4),
            target: DVec3::ZERO,
            up: DVec3::Y,
            fov_y_deg: 40.0,
            ortho_height: None,
            isovalue: 0.25,
            method: "analytic".into(),
            time: 0.5,
            device: "llvmpipe".into(),
            driver: "Mesa".into(),
            extra: vec![("b".into(), "2".into()), ("a".into(), "1".into())],
            legend: None,
        }
    }

    pub(super) fn frame(w: u32, h: u32) -> Frame {
        let pixels = (0..w * h)
            .map(|i| Pixel {
                rgba: [i as f32, 0.5, 0.25, 1.0],
                normal: [0.0, 1.0, 0.0],
                depth: 1.0 + i as f32,
                position: [1.0, 2.0, 3.0],
                steps: 7.0,
                cell: [1, 2, 3],
                crossings: -1,
                surface: -1,
                value: f32::NAN,
                pad: [0; 2],
            })
            .collect();
        Frame { width: w, height: h, pixels, info: info() }
    }

    #[test]
    fn rejects_a_frame_whose_pixel_count_is_wrong() {
        let mut f = frame(3, 2);
        f.pixels.pop();
        let msg = encode_frame(Path::new("bad.exr"), &f).unwrap_err().to_string();
        assert!(msg.contains("bad.exr") && msg.contains("5 pixels"), "{msg}");
    }
}
