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
//! ([`super::exr_blocks`], behind [`write_frame`], [`encode_frame`] and [`write_channels`])
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

use std::io::Cursor;
use std::path::{Path, PathBuf};

use exr::image::{AnyChannel, AnyChannels, Blocks, Encoding, FlatSamples, Image, Layer};
use exr::math::Vec2;
use exr::meta::attribute::{AttributeValue, Chromaticities, Compression, LineOrder, Text};
use exr::meta::header::LayerAttributes;
use exr::meta::MetaData;
use exr::prelude::traits::*;
use exr::prelude::SmallVec;
use glam::DVec3;

use super::OutputError;
use crate::frame::{Channel, Frame, FrameInfo, Pixel, Written};

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
/// through the streaming writer ([`super::exr_stream::ExrStream`]; its bytes are
/// [`encode_frame`]'s).
pub fn write_frame(path: &Path, frame: &Frame) -> Result<(), OutputError> {
    check_size(path, frame)?;
    let channels = written_channels(frame);
    let mut stream = super::exr_stream::ExrStream::create(
        path,
        frame.width,
        frame.height,
        &channels,
        &frame.info,
    )?;
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
    let mut stream = super::exr_stream::ExrStream::in_memory(
        path,
        frame.width,
        frame.height,
        &channels,
        &frame.info,
    )?;
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
/// header): the streaming writer of named planes ([`super::exr_planes::PlaneStream`]) given
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
    let mut stream =
        super::exr_planes::PlaneStream::create(path, width, height, &names, text_attributes)?;
    let planes: Vec<&[f32]> = channels.iter().map(|(_, values)| values.as_slice()).collect();
    stream.push_rows(&planes)?;
    stream.finish()
}

/// The layer attributes of [`write_channels`]: `software` and the text attributes.
fn text_layer_attributes(
    path: &Path,
    text_attributes: &[(String, String)],
) -> Result<LayerAttributes, OutputError> {
    let mut attributes = LayerAttributes {
        software_name: Some(text(&format!("isoview {}", crate::VERSION))),
        ..LayerAttributes::default()
    };
    for (name, value) in text_attributes {
        check_name(path, name)?;
        attributes.other.insert(text(name), AttributeValue::Text(text(value)));
    }
    Ok(attributes)
}

/// The header [`write_channels`] would write for these channel names and attributes (for
/// the streaming writer of named channels, which writes the samples itself).
pub(super) fn named_channel_headers(
    path: &Path,
    width: usize,
    height: usize,
    names: &[String],
    text_attributes: &[(String, String)],
) -> Result<exr::meta::Headers, OutputError> {
    if width == 0 || height == 0 || names.is_empty() {
        return Err(OutputError::invalid(
            path,
            format!("cannot write an empty {width}x{height} image with {} channels", names.len()),
        ));
    }
    let mut list = Vec::with_capacity(names.len());
    for name in names {
        check_name(path, name)?;
        list.push(AnyChannel::new(text(name), FlatSamples::F32(Vec::new())));
    }
    let attributes = text_layer_attributes(path, text_attributes)?;
    let image = layer_image(path, width, height, list, attributes)?;
    Ok(image.write().non_parallel().infer_meta_data())
}

/// Rejects a channel or attribute name OpenEXR cannot store.
fn check_name(path: &Path, name: &str) -> Result<(), OutputError> {
    if name.is_empty() || name.contains('\0') || name.len() > 255 {
        return Err(OutputError::invalid(
            path,
            format!("name {name:?} is empty, longer than 255 bytes or has a NUL"),
        ));
    }
    Ok(())
}

/// The `exr` crate's description of the files isoview writes (one part, ZIP16 scan lines in
/// increasing order, Rec.709 chromaticities; the channels sorted by name): the header the
/// streaming writers ([`super::exr_blocks`]) encode.
fn layer_image(
    path: &Path,
    width: usize,
    height: usize,
    channels: Vec<AnyChannel<FlatSamples>>,
    attributes: LayerAttributes,
) -> Result<Image<Layer<AnyChannels<FlatSamples>>>, OutputError> {
    let mut sorted: Vec<&str> = Vec::new();
    for c in &channels {
        let name = std::str::from_utf8(c.name.bytes()).unwrap_or("");
        if sorted.contains(&name) {
            return Err(OutputError::invalid(path, format!("channel {name:?} given twice")));
        }
        sorted.push(name);
    }
    let channels = AnyChannels::sort(SmallVec::from_vec(channels));
    let encoding = Encoding {
        compression: Compression::ZIP16,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    let mut image = Image::from_layer(Layer::new((width, height), attributes, encoding, channels));
    image.attributes.chromaticities = Some(rec709());
    Ok(image)
}

/// The header [`encode_frame`] would write for a `width` × `height` frame of `channels` made
/// as `info` says (for the streaming writer, which writes the pixels itself).
pub(super) fn channel_image_headers(
    path: &Path,
    width: usize,
    height: usize,
    channels: &[Channel],
    info: &FrameInfo,
) -> Result<exr::meta::Headers, OutputError> {
    if width == 0 || height == 0 || channels.is_empty() {
        return Err(OutputError::invalid(
            path,
            format!("cannot write an empty {width}x{height} image of {} channels", channels.len()),
        ));
    }
    // No samples: the header depends only on the channels' names and sample type.
    let list =
        channels.iter().map(|c| AnyChannel::new(c.name(), FlatSamples::F32(Vec::new()))).collect();
    let attributes = layer_attributes(path, info, width, height)?;
    let image = layer_image(path, width, height, list, attributes)?;
    Ok(image.write().non_parallel().infer_meta_data())
}

/// Rec.709 / sRGB primaries with a D65 white point.
fn rec709() -> Chromaticities {
    Chromaticities {
        red: Vec2(0.64, 0.33),
        green: Vec2(0.30, 0.60),
        blue: Vec2(0.15, 0.06),
        white: Vec2(0.3127, 0.3290),
    }
}

/// Text attribute holding the UTF-8 bytes of `s`.
fn text(s: &str) -> Text {
    Text::from_slice_unchecked(s.as_bytes())
}

fn v3f(v: DVec3) -> AttributeValue {
    AttributeValue::FloatVec3((v.x as f32, v.y as f32, v.z as f32))
}

fn layer_attributes(
    path: &Path,
    info: &FrameInfo,
    width: usize,
    height: usize,
) -> Result<LayerAttributes, OutputError> {
    let mut a = LayerAttributes {
        software_name: Some(text(&format!("isoview {}", crate::VERSION))),
        ..LayerAttributes::default()
    };
    if let Some((to_camera, to_ndc)) = camera_matrices(info, width, height) {
        a.world_to_camera = Some(to_camera);
        a.world_to_normalized_device = Some(to_ndc);
    }
    let mut put = |name: &str, value: AttributeValue| {
        a.other.insert(text(name), value);
    };
    put(attr::VERSION, AttributeValue::Text(text(crate::VERSION)));
    put(attr::SCENE, AttributeValue::Text(text(&info.scene)));
    put(attr::EYE, v3f(info.eye));
    put(attr::TARGET, v3f(info.target));
    put(attr::UP, v3f(info.up));
    put(attr::FOV_Y, AttributeValue::F64(info.fov_y_deg));
    put(attr::ISOVALUE, AttributeValue::F64(info.isovalue));
    put(attr::METHOD, AttributeValue::Text(text(&info.method)));
    put(attr::TIME, AttributeValue::F64(info.time));
    put(attr::DEVICE, AttributeValue::Text(text(&info.device)));
    put(attr::DRIVER, AttributeValue::Text(text(&info.driver)));
    for (key, value) in &info.extra {
        let name = format!("{}{key}", attr::EXTRA_PREFIX);
        if key.is_empty() {
            return Err(OutputError::invalid(path, "an extra header attribute has no key"));
        }
        check_name(path, &name)?;
        put(&name, AttributeValue::Text(text(value)));
    }
    Ok(a)
}

/// OpenEXR's `worldToCamera` and `worldToNDC` for the contract's pinhole camera, as Imath
/// row-vector matrices (`p' = p * M`, translation in the last row), or `None` for a
/// degenerate camera (eye at the target, or `up` along the view direction).
///
/// Camera space: x = right, y = up', z = forward (left-handed, as OpenEXR specifies).
/// NDC: x = (px + 0.5) / width at the centre of pixel column px, y likewise downwards; the
/// NDC z is 1 / camera z (perspective) or camera z (orthographic).
pub fn camera_matrices(
    info: &FrameInfo,
    width: usize,
    height: usize,
) -> Option<([f32; 16], [f32; 16])> {
    let forward = (info.target - info.eye).try_normalize()?;
    let right = forward.cross(info.up).try_normalize()?;
    let up = right.cross(forward);
    let h = match info.ortho_height {
        Some(height) => 0.5 * height,
        None => (info.fov_y_deg.to_radians() * 0.5).tan(),
    };
    if !(h.is_finite() && h > 0.0) || width == 0 || height == 0 {
        return None;
    }
    let aspect = width as f64 / height as f64;
    let e = info.eye;
    let view = [
        [right.x, up.x, forward.x, 0.0],
        [right.y, up.y, forward.y, 0.0],
        [right.z, up.z, forward.z, 0.0],
        [-right.dot(e), -up.dot(e), -forward.dot(e), 1.0],
    ];
    let (sx, sy) = (0.5 / (h * aspect), 0.5 / h);
    let proj = match info.ortho_height {
        // Row vectors: x' = sx x + 0.5 z, y' = -sy y + 0.5 z, w' = z, z' = 1.
        None => {
            [[sx, 0.0, 0.0, 0.0], [0.0, -sy, 0.0, 0.0], [0.5, 0.5, 0.0, 1.0], [0.0, 0.0, 1.0, 0.0]]
        }
        // x' = sx x + 0.5, y' = -sy y + 0.5, z' = z, w' = 1.
        Some(_) => {
            [[sx, 0.0, 0.0, 0.0], [0.0, -sy, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.5, 0.5, 0.0, 1.0]]
        }
    };
    let mut to_camera = [0f32; 16];
    let mut to_ndc = [0f32; 16];
    for i in 0..4 {
        for j in 0..4 {
            to_camera[i * 4 + j] = view[i][j] as f32;
            to_ndc[i * 4 + j] = (0..4).map(|k| view[i][k] * proj[k][j]).sum::<f64>() as f32;
        }
    }
    Some((to_camera, to_ndc))
}

/// Sorts the attributes of a single-part EXR header by name, in place.
pub(super) fn sort_header_attributes(bytes: &mut [u8]) -> Result<(), String> {
    const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
    if bytes.len() < 8 || bytes[..4] != MAGIC {
        return Err("encoder output is not an EXR".into());
    }
    let flags = u32::from_le_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]);
    if flags & (1 << 12) != 0 {
        return Err("encoder wrote a multi-part file".into());
    }
    let start = 8;
    let mut at = start;
    let mut spans: Vec<(usize, usize, usize)> = Vec::new(); // (start, name end, end)
    let nul = |from: usize, b: &[u8]| -> Result<usize, String> {
        b[from..]
            .iter()
            .position(|&c| c == 0)
            .map(|i| from + i)
            .ok_or_else(|| "unterminated header".to_string())
    };
    loop {
        match bytes.get(at) {
            None => return Err("truncated header".into()),
            Some(0) => break,
            Some(_) => {}
        }
        let name_end = nul(at, bytes)?;
        let type_end = nul(name_end + 1, bytes)?;
        let size_at = type_end + 1;
        let size_bytes: [u8; 4] = bytes
            .get(size_at..size_at + 4)
            .and_then(|s| s.try_into().ok())
            .ok_or("truncated attribute size")?;
        let size = usize::try_from(i32::from_le_bytes(size_bytes))
            .map_err(|_| "negative attribute size".to_string())?;
        let end = size_at + 4 + size;
        if end > bytes.len() {
            return Err("attribute runs past the end".into());
        }
        spans.push((at, name_end, end));
        at = end;
    }
    let header = bytes[start..at].to_vec();
    spans.sort_by(|a, b| header[a.0 - start..a.1 - start].cmp(&header[b.0 - start..b.1 - start]));
    let mut out = start;
    for (s, _, e) in spans {
        bytes[out..out + (e - s)].copy_from_slice(&header[s - start..e - start]);
        out += e - s;
    }
    debug_assert_eq!(out, at);
    Ok(())
}

/// How a channel was stored in the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleKind {
    F16,
    F32,
    U32,
}

/// One channel of an [`ExrImage`], converted to `f32`, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct ExrChannel {
    /// Full name as in the file (`R`, `N.X`, `depth.Z`), or `<part>.<name>` for later parts
    /// of a multi-part file.
    pub name: String,
    /// Sample type in the file.
    pub kind: SampleKind,
    pub values: Vec<f32>,
}

/// An EXR read by [`read`]: the display window's pixels of every channel, and the header.
#[derive(Clone, Debug, PartialEq)]
pub struct ExrImage {
    /// The file it came from (for messages).
    pub path: PathBuf,
    pub width: usize,
    pub height: usize,
    /// In file order (sorted by name within each part).
    pub channels: Vec<ExrChannel>,
    /// Every header attribute of the first part, as text, in file order. Numbers use Rust's
    /// shortest round-trip form, vectors and matrices `[a, b, c]`, boxes `(x0 y0) - (x1 y1)`.
    pub attributes: Vec<(String, String)>,
    /// Part names (empty for an unnamed part); one entry for a single-part file.
    pub parts: Vec<String>,
}

impl ExrImage {
    /// The channel named `name`.
    pub fn channel(&self, name: &str) -> Option<&ExrChannel> {
        self.channels.iter().find(|c| c.name == name)
    }

    /// The value of the header attribute `name`, as text.
    pub fn attribute(&self, name: &str) -> Option<&str> {
        self.attributes.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_str())
    }

    /// Channel names, in file order.
    pub fn channel_names(&self) -> impl Iterator<Item = &str> {
        self.channels.iter().map(|c| c.name.as_str())
    }

    /// The pixels of an EXR that isoview wrote, read back through the channel table: every
    /// [`Written::Always`] channel must be there; a missing [`Written::WhereCounted`] one
    /// reads as -1 (not counted), a missing [`Written::WhereFinite`] one as NaN. Errors name the file and the missing channel.
    pub fn frame_pixels(&self) -> Result<Vec<Pixel>, OutputError> {
        let n = self.width * self.height;
        let mut pixels = vec![Pixel::default(); n];
        for c in Channel::ALL {
            match (self.channel(c.name()), c.written()) {
                (Some(ch), _) => {
                    for (p, &v) in pixels.iter_mut().zip(&ch.values) {
                        c.set(p, v);
                    }
                }
                (None, Written::WhereCounted) => pixels.iter_mut().for_each(|p| c.set(p, -1.0)),
                (None, Written::WhereFinite) => pixels.iter_mut().for_each(|p| c.set(p, f32::NAN)),
                (None, Written::Always) => {
                    return Err(OutputError::invalid(
                        &self.path,
                        format!("not an isoview render: no channel {:?}", c.name()),
                    ))
                }
            }
        }
        Ok(pixels)
    }
}

/// Reads every channel and the header of the EXR at `path` (see the module docs).
pub fn read(path: &Path) -> Result<ExrImage, OutputError> {
    let bytes = std::fs::read(path).map_err(|e| OutputError::io(path, "read", e))?;
    let bad = |source| OutputError::Exr {
        path: path.to_path_buf(),
        action: "not a readable OpenEXR file",
        source,
    };
    let meta = MetaData::read_from_buffered(Cursor::new(&bytes), false).map_err(bad)?;
    if meta.headers.iter().any(|h| h.deep) {
        return Err(OutputError::invalid(path, "deep EXR data is not supported"));
    }
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_buffered(Cursor::new(&bytes))
        .map_err(bad)?;

    let display = image.attributes.display_window;
    let (width, height) = (display.size.x(), display.size.y());
    let multi = image.layer_data.len() > 1;
    let mut parts = Vec::new();
    let mut channels: Vec<ExrChannel> = Vec::new();
    for layer in image.layer_data.iter() {
        let part = layer
            .attributes
            .layer_name
            .as_ref()
            .map(|t| String::from_utf8_lossy(t.bytes()).into_owned())
            .unwrap_or_default();
        let origin = layer.attributes.layer_position;
        let size = layer.size;
        for ch in layer.channel_data.list.iter() {
            let mut name = String::from_utf8_lossy(ch.name.bytes()).into_owned();
            if multi && !part.is_empty() && !name.starts_with(&format!("{part}.")) {
                name = format!("{part}.{name}");
            }
            if channels.iter().any(|c| c.name == name) {
                return Err(OutputError::invalid(
                    path,
                    format!("channel {name:?} appears in more than one part"),
                ));
            }
            let (kind, data): (SampleKind, Vec<f32>) = match &ch.sample_data {
                FlatSamples::F16(v) => (SampleKind::F16, v.iter().map(|x| x.to_f32()).collect()),
                FlatSamples::F32(v) => (SampleKind::F32, v.clone()),
                FlatSamples::U32(v) => (SampleKind::U32, v.iter().map(|&x| x as f32).collect()),
            };
            let values = to_display_window(
                data,
                (origin.x(), origin.y()),
                (size.x(), size.y()),
                (display.position.x(), display.position.y()),
                (width, height),
            );
            channels.push(ExrChannel { name, kind, values });
        }
        parts.push(part);
    }

    let attributes = meta
        .headers
        .first()
        .map(|h| {
            h.all_named_attributes()
                .map(|(name, value)| {
                    (String::from_utf8_lossy(name).into_owned(), attribute_text(&value))
                })
                .collect()
        })
        .unwrap_or_default();

    Ok(ExrImage { path: path.to_path_buf(), width, height, channels, attributes, parts })
}

/// Places a data window's samples into the display window; uncovered pixels are 0.
fn to_display_window(
    data: Vec<f32>,
    origin: (i32, i32),
    size: (usize, usize),
    display_origin: (i32, i32),
    display_size: (usize, usize),
) -> Vec<f32> {
    if origin == display_origin && size == display_size {
        return data;
    }
    let (dw, dh) = display_size;
    let mut out = vec![0.0; dw * dh];
    for y in 0..dh {
        let sy = display_origin.1 as i64 + y as i64 - origin.1 as i64;
        if sy < 0 || sy >= size.1 as i64 {
            continue;
        }
        for x in 0..dw {
            let sx = display_origin.0 as i64 + x as i64 - origin.0 as i64;
            if sx >= 0 && sx < size.0 as i64 {
                out[y * dw + x] = data[sy as usize * size.0 + sx as usize];
            }
        }
    }
    out
}

fn list<T: std::fmt::Display>(items: impl IntoIterator<Item = T>) -> String {
    let items: Vec<String> = items.into_iter().map(|x| x.to_string()).collect();
    format!("[{}]", items.join(", "))
}

/// An attribute's value as text (see [`ExrImage::attributes`]).
pub fn attribute_text(value: &AttributeValue) -> String {
    use AttributeValue as V;
    match value {
        V::Text(t) => String::from_utf8_lossy(t.bytes()).into_owned(),
        V::TextVector(v) => list(v.iter().map(|t| String::from_utf8_lossy(t.bytes()).into_owned())),
        V::F32(x) => x.to_string(),
        V::F64(x) => x.to_string(),
        V::I32(x) => x.to_string(),
        V::FloatVec2(v) => list([v.x(), v.y()]),
        V::FloatVec3((x, y, z)) => list([x, y, z]),
        V::IntVec2(v) => list([v.x(), v.y()]),
        V::IntVec3((x, y, z)) => list([x, y, z]),
        V::Matrix3x3(m) => list(m.iter()),
        V::Matrix4x4(m) => list(m.iter()),
        V::IntegerBounds(b) => {
            let max = b.max();
            format!("({} {}) - ({} {})", b.position.x(), b.position.y(), max.x(), max.y())
        }
        V::FloatRect(r) => format!("({} {}) - ({} {})", r.min.x(), r.min.y(), r.max.x(), r.max.y()),
        V::ChannelList(c) => {
            list(c.list.iter().map(|d| String::from_utf8_lossy(d.name.bytes()).into_owned()))
        }
        V::Chromaticities(c) => format!(
            "red [{}, {}] green [{}, {}] blue [{}, {}] white [{}, {}]",
            c.red.x(),
            c.red.y(),
            c.green.x(),
            c.green.y(),
            c.blue.x(),
            c.blue.y(),
            c.white.x(),
            c.white.y()
        ),
        V::Compression(c) => format!("{c:?}"),
        V::LineOrder(o) => format!("{o:?}"),
        V::BlockType(t) => format!("{t:?}"),
        V::TileDescription(t) => format!("{t:?}"),
        V::TimeCode(t) => format!("{t:?}"),
        V::Rational(r) => format!("{}/{}", r.0, r.1),
        other => format!("{other:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::Pixel;

    fn info() -> FrameInfo {
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

    fn frame(w: u32, h: u32) -> Frame {
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
    fn header_attributes_come_out_sorted() {
        let bytes = encode_frame(Path::new("x.exr"), &frame(3, 2)).unwrap();
        let meta = MetaData::read_from_buffered(Cursor::new(&bytes), true).unwrap();
        assert_eq!(meta.headers.len(), 1);
        // Walk the header again and check the names are in order.
        let mut names = Vec::new();
        let mut at = 8;
        while bytes[at] != 0 {
            let n = bytes[at..].iter().position(|&c| c == 0).unwrap();
            names.push(bytes[at..at + n].to_vec());
            let t = bytes[at + n + 1..].iter().position(|&c| c == 0).unwrap();
            let s = at + n + 1 + t + 1;
            let size = i32::from_le_bytes(bytes[s..s + 4].try_into().unwrap()) as usize;
            at = s + 4 + size;
        }
        let mut sorted = names.clone();
        sorted.sort();
        assert_eq!(names, sorted);
        assert!(names.iter().any(|n| n == b"isoview/extra/a"));
    }

    #[test]
    fn rejects_a_frame_whose_pixel_count_is_wrong() {
        let mut f = frame(3, 2);
        f.pixels.pop();
        let msg = encode_frame(Path::new("bad.exr"), &f).unwrap_err().to_string();
        assert!(msg.contains("bad.exr") && msg.contains("5 pixels"), "{msg}");
    }

    #[test]
    fn camera_matrices_project_pixel_centres() {
        let info = info();
        let (w, h) = (8usize, 6usize);
        let (_, ndc) = camera_matrices(&info, w, h).unwrap();
        // The contract's ray through pixel (px, py), a point 3 units along it.
        let forward = (info.target - info.eye).normalize();
        let right = forward.cross(info.up).normalize();
        let up = right.cross(forward);
        let t = (info.fov_y_deg.to_radians() / 2.0).tan();
        let a = w as f64 / h as f64;
        for (px, py) in [(0.0, 0.0), (5.0, 2.0), (7.0, 5.0)] {
            let dir = (forward
                + ((2.0 * (px + 0.5) / w as f64 - 1.0) * t * a) * right
                + ((1.0 - 2.0 * (py + 0.5) / h as f64) * t) * up)
                .normalize();
            let p = info.eye + 3.0 * dir;
            let v = [p.x, p.y, p.z, 1.0];
            let col = |j: usize| (0..4).map(|i| v[i] * ndc[i * 4 + j] as f64).sum::<f64>();
            let (x, y, wc) = (col(0), col(1), col(3));
            assert!((x / wc - (px + 0.5) / w as f64).abs() < 1e-5);
            assert!((y / wc - (py + 0.5) / h as f64).abs() < 1e-5);
        }
    }

    #[test]
    fn degenerate_camera_has_no_matrices() {
        let mut i = info();
        i.up = i.target - i.eye;
        assert!(camera_matrices(&i, 4, 4).is_none());
        assert!(camera_matrices(&FrameInfo::default(), 4, 4).is_none());
    }

    #[test]
    fn display_window_placement() {
        // 2x2 data at (1,1) inside a 3x3 display window at (0,0).
        let out = to_display_window(vec![1.0, 2.0, 3.0, 4.0], (1, 1), (2, 2), (0, 0), (3, 3));
        assert_eq!(out, vec![0.0, 0.0, 0.0, 0.0, 1.0, 2.0, 0.0, 3.0, 4.0]);
    }
}
