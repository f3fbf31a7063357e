//! The header of every EXR isoview writes: the `exr` crate's description of the file (one
//! part, ZIP16 scan lines, Rec.709, channels sorted by name) with a render's attributes
//! ([`super::attr`]) or a caller's text attributes, the OpenEXR camera matrices, and the sort
//! of the encoded header's attributes by name that makes the bytes deterministic (see
//! [`super`], "Deterministic bytes").

use exr::image::{AnyChannel, AnyChannels, Blocks, Encoding, FlatSamples, Image, Layer};
use exr::math::Vec2;
use exr::meta::attribute::{AttributeValue, Chromaticities, Compression, LineOrder, Text};
use exr::meta::header::LayerAttributes;
use exr::prelude::traits::*;
use exr::prelude::SmallVec;
use glam::DVec3;
use std::path::Path;

use super::attr;
use crate::frame::{Channel, FrameInfo};
use crate::output::OutputError;

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
/// streaming writers ([`super::blocks`]) encode.
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

#[cfg(test)]
mod tests {
    use std::io::Cursor;
    use std::path::Path;

    use exr::meta::MetaData;

    use super::*;
    use crate::output::exr::encode_frame;
    use crate::output::exr::tests::{frame, info};

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
}
