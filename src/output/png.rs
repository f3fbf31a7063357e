//! 8-bit PNG previews.
//!
//! The beauty's linear RGB is clamped to [0, 1] and encoded with the sRGB transfer function;
//! alpha is clamped and stored linearly (PNG alpha is never gamma-encoded). Values are written
//! as they are, not un-premultiplied: on a hit A = 1, and a transparent background is black.
//! NaN is written as 0. Files are written atomically.

use std::path::Path;

use std::io::Write;

use super::{atomic, OutputError};
use crate::frame::{Frame, Pixel};

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
    let bytes = SharedBytes::default();
    let mut writer = stream_encoder(path, bytes.clone(), width, height)?;
    writer.write_all(rgba).map_err(|e| OutputError::io(path, "encode PNG", e))?;
    writer.finish().map_err(|e| png_error(path, e))?;
    Ok(bytes.0.take())
}

/// A `Vec<u8>` the encoder writes into and the caller keeps (the encoder owns its writer).
#[derive(Clone, Default)]
struct SharedBytes(std::rc::Rc<std::cell::RefCell<Vec<u8>>>);

impl std::io::Write for SharedBytes {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.borrow_mut().extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// The one PNG encoder every isoview PNG goes through (whole images and [`PngStream`]s, so
/// their bytes agree): RGBA8, adaptive filters, zlib at the default level, rows filtered and
/// deflated as they are written, IDAT chunks of 1 MiB.
fn stream_encoder<W: std::io::Write>(
    path: &Path,
    out: W,
    width: u32,
    height: u32,
) -> Result<png::StreamWriter<'static, W>, OutputError> {
    let mut encoder = png::Encoder::new(out, width, height);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::Balanced);
    encoder.set_filter(png::Filter::Adaptive);
    encoder
        .write_header()
        .and_then(|w| w.into_stream_writer_with_size(1 << 20))
        .map_err(|e| png_error(path, e))
}

fn png_error(path: &Path, e: png::EncodingError) -> OutputError {
    OutputError::io(path, "encode PNG", std::io::Error::other(e))
}

/// An RGBA8 PNG written a few rows at a time (`compare --png` on images of any size): the
/// bytes of [`write_rgba8`], memory one band.
pub struct Rgba8Stream {
    temp: atomic::TempFile,
    writer: Option<png::StreamWriter<'static, std::fs::File>>,
    row_bytes: usize,
    rows_left: usize,
}

impl Rgba8Stream {
    /// Starts `path` (a temporary file beside it) for a `width` × `height` RGBA8 image.
    pub fn create(path: &Path, width: u32, height: u32) -> Result<Self, OutputError> {
        if width == 0 || height == 0 {
            return Err(OutputError::invalid(
                path,
                format!("cannot write an empty {width}x{height} image"),
            ));
        }
        let temp = atomic::TempFile::create(path)?;
        let file = temp.file().try_clone().map_err(|e| temp.error("write", e))?;
        let writer = stream_encoder(path, file, width, height)?;
        Ok(Rgba8Stream {
            temp,
            writer: Some(writer),
            row_bytes: width as usize * 4,
            rows_left: height as usize,
        })
    }

    /// The next whole rows (RGBA8, row-major), in order from row 0.
    pub fn push_rows(&mut self, rgba: &[u8]) -> Result<(), OutputError> {
        let rows = rgba.len() / self.row_bytes;
        if rgba.len() % self.row_bytes != 0 || rows > self.rows_left {
            return Err(OutputError::invalid(
                self.temp.path(),
                format!("{} bytes are not whole RGBA8 rows within the image", rgba.len()),
            ));
        }
        let writer = self.writer.as_mut().ok_or_else(|| {
            OutputError::invalid(self.temp.path(), "internal: rows after a failed write")
        })?;
        if let Err(e) = writer.write_all(rgba) {
            self.writer = None;
            return Err(self.temp.error("write", e));
        }
        self.rows_left -= rows;
        Ok(())
    }

    /// Ends the PNG and moves it into place; every row must have arrived.
    pub fn finish(mut self) -> Result<(), OutputError> {
        if self.rows_left != 0 {
            let reason = format!("{} rows were never written", self.rows_left);
            return Err(OutputError::invalid(self.temp.path(), reason));
        }
        let writer = self.writer.take().ok_or_else(|| {
            OutputError::invalid(self.temp.path(), "internal: finish after a failed write")
        })?;
        writer.finish().map_err(|e| self.temp.error("write", std::io::Error::other(e)))?;
        self.temp.commit()
    }
}

/// A preview PNG written band by band as a render draws it: the rows are filtered and
/// deflated as they arrive (the encoder of [`encode_rgba8`]), so memory stays at one band and
/// the bytes are [`write_preview`]'s.
pub struct PngStream {
    temp: atomic::TempFile,
    writer: Option<png::StreamWriter<'static, std::fs::File>>,
    width: usize,
    rows_left: usize,
    /// The colour bar's rows, written under the picture at the end ([`super::legend`]).
    legend: Vec<u8>,
}

impl PngStream {
    /// Starts `path` (a temporary file beside it) for a `width` × `height` preview, with the
    /// colour bar of `legend` under it (as [`write_preview`]).
    pub fn create(
        path: &Path,
        width: u32,
        height: u32,
        legend: Option<&crate::frame::Legend>,
    ) -> Result<Self, OutputError> {
        if width == 0 || height == 0 {
            return Err(OutputError::invalid(
                path,
                format!("cannot write an empty {width}x{height} image"),
            ));
        }
        let legend = legend.map(|l| super::legend::rows(l, width)).unwrap_or_default();
        let bar_rows = if legend.is_empty() { 0 } else { super::legend::ROWS };
        let temp = atomic::TempFile::create(path)?;
        let file = temp.file().try_clone().map_err(|e| temp.error("write", e))?;
        let writer = stream_encoder(path, file, width, height + bar_rows)?;
        Ok(PngStream {
            temp,
            writer: Some(writer),
            width: width as usize,
            rows_left: height as usize,
            legend,
        })
    }

    /// The next whole rows of the frame, in order from row 0.
    pub fn push_rows(&mut self, pixels: &[Pixel]) -> Result<(), OutputError> {
        let rows = pixels.len() / self.width;
        if pixels.len() % self.width != 0 || rows > self.rows_left {
            return Err(OutputError::invalid(
                self.temp.path(),
                format!("{} records are not whole rows within the image", pixels.len()),
            ));
        }
        let bytes: Vec<u8> = pixels.iter().flat_map(|p| to_srgb8(p.rgba)).collect();
        let writer = self.writer.as_mut().ok_or_else(|| {
            OutputError::invalid(self.temp.path(), "internal: rows after a failed write")
        })?;
        if let Err(e) = writer.write_all(&bytes) {
            self.writer = None;
            return Err(self.temp.error("write", e));
        }
        self.rows_left -= rows;
        Ok(())
    }

    /// Ends the PNG and moves it into place; every row must have arrived.
    pub fn finish(mut self) -> Result<(), OutputError> {
        if self.rows_left != 0 {
            let reason = format!("{} rows were never drawn", self.rows_left);
            return Err(OutputError::invalid(self.temp.path(), reason));
        }
        let mut writer = self.writer.take().ok_or_else(|| {
            OutputError::invalid(self.temp.path(), "internal: finish after a failed write")
        })?;
        writer.write_all(&self.legend).map_err(|e| self.temp.error("write", e))?;
        writer.finish().map_err(|e| self.temp.error("write", std::io::Error::other(e)))?;
        self.temp.commit()
    }
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
