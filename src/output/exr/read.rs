//! Reading any EXR ([`read`]): see [`super`], "Reading", for what is supported and how
//! multi-part files and data windows are turned into one image.

use std::io::Cursor;
use std::path::{Path, PathBuf};

use exr::image::FlatSamples;
use exr::meta::attribute::AttributeValue;
use exr::meta::MetaData;
use exr::prelude::traits::*;

use crate::frame::{Channel, Pixel, Written};
use crate::output::OutputError;

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
    let mut bytes = Vec::new();
    crate::vocab::open_regular(path, "an EXR file")
        .and_then(|mut f| std::io::Read::read_to_end(&mut f, &mut bytes))
        .map_err(|e| OutputError::io(path, "read", e))?;
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

    #[test]
    fn display_window_placement() {
        // 2x2 data at (1,1) inside a 3x3 display window at (0,0).
        let out = to_display_window(vec![1.0, 2.0, 3.0, 4.0], (1, 1), (2, 2), (0, 0), (3, 3));
        assert_eq!(out, vec![0.0, 0.0, 0.0, 0.0, 1.0, 2.0, 0.0, 3.0, 4.0]);
    }
}
