//! 8-bit PNG previews.
//!
//! The beauty's linear RGB is clamped to [0, 1] and encoded with the sRGB transfer function;
//! alpha is clamped and stored linearly (PNG alpha is never gamma-encoded). Values are written
//! as they are, not un-premultiplied: on a hit A = 1, and a transparent background is black.
//! NaN is written as 0. Files are written atomically.

use std::path::Path;

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};

use super::{atomic, OutputError};
use crate::frame::Frame;

/// The sRGB transfer function (linear → encoded), for `c` in [0, 1].
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// `c` clamped to [0, 1] and quantised to 8 bits (NaN → 0).
fn quantise(c: f32) -> u8 {
    if c.is_nan() {
        return 0;
    }
    (c.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// A linear RGBA value as 8-bit sRGB RGBA (see the module docs).
pub fn to_srgb8(rgba: [f32; 4]) -> [u8; 4] {
    let enc = |c: f32| {
        if c.is_nan() {
            0
        } else {
            quantise(linear_to_srgb(c.clamp(0.0, 1.0)))
        }
    };
    [enc(rgba[0]), enc(rgba[1]), enc(rgba[2]), quantise(rgba[3])]
}

/// Writes the frame's beauty as an sRGB RGBA8 PNG, atomically; a `[color] by` render gets its
/// colour bar under the picture ([`super::legend`]).
pub fn write_preview(path: &Path, frame: &Frame) -> Result<(), OutputError> {
    let (w, h) = (frame.width as usize, frame.height as usize);
    if frame.pixels.len() != w * h {
        return Err(OutputError::invalid(
            path,
            format!("frame has {} pixels, expected {w}x{h} = {}", frame.pixels.len(), w * h),
        ));
    }
    let (height, rgba) = preview_rgba8(frame);
    write_rgba8(path, frame.width, height, &rgba)
}

/// The frame's beauty as 8-bit sRGB RGBA, row 0 at the top, with the colour bar's rows under
/// it when the frame has a legend (what [`write_preview`] encodes), and its height in rows.
pub fn preview_rgba8(frame: &Frame) -> (u32, Vec<u8>) {
    let mut rgba: Vec<u8> = frame.pixels.iter().flat_map(|p| to_srgb8(p.rgba)).collect();
    match &frame.info.legend {
        None => (frame.height, rgba),
        Some(legend) => {
            rgba.extend(super::legend::rows(legend, frame.width));
            (frame.height + super::legend::ROWS, rgba)
        }
    }
}

/// The PNG bytes [`write_preview`] writes (`path` only names the file in errors).
pub fn encode_preview(path: &Path, frame: &Frame) -> Result<Vec<u8>, OutputError> {
    let (height, rgba) = preview_rgba8(frame);
    encode_rgba8(path, frame.width, height, &rgba)
}

/// Writes 8-bit RGBA pixels (row-major, row 0 at the top) as a PNG, atomically.
pub fn write_rgba8(path: &Path, width: u32, height: u32, rgba: &[u8]) -> Result<(), OutputError> {
    if width == 0 || height == 0 || rgba.len() != width as usize * height as usize * 4 {
        return Err(OutputError::invalid(
            path,
            format!("{} bytes do not make a non-empty {width}x{height} RGBA8 image", rgba.len()),
        ));
    }
    let bytes = encode_rgba8(path, width, height, rgba)?;
    atomic::write_bytes(path, &bytes)
}

/// The PNG bytes [`write_rgba8`] writes (`path` only names the file in errors).
pub fn encode_rgba8(
    path: &Path,
    width: u32,
    height: u32,
    rgba: &[u8],
) -> Result<Vec<u8>, OutputError> {
    if width == 0 || height == 0 || rgba.len() != width as usize * height as usize * 4 {
        return Err(OutputError::invalid(
            path,
            format!("{} bytes do not make a non-empty {width}x{height} RGBA8 image", rgba.len()),
        ));
    }
    let mut bytes = Vec::new();
    PngEncoder::new(&mut bytes)
        .write_image(rgba, width, height, ExtendedColorType::Rgba8)
        .map_err(|source| OutputError::Png { path: path.to_path_buf(), source })?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transfer_function_endpoints_and_midpoint() {
        assert_eq!(to_srgb8([0.0, 1.0, 2.0, 0.5]), [0, 255, 255, 128]);
        assert_eq!(to_srgb8([-1.0, f32::NAN, f32::INFINITY, f32::NAN]), [0, 0, 255, 0]);
        // Linear 0.2159 is sRGB 0.5004 (128 of 255).
        assert_eq!(to_srgb8([0.2159, 0.0, 0.0, 1.0])[0], 128);
        assert!((linear_to_srgb(0.0031308) - 0.040_449_9).abs() < 1e-4);
    }
}
