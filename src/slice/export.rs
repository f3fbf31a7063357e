//! Writing a slice: the picture as EXR (`R`, `G`, `B`, `A`, `value`, `contour`) and PNG, the
//! contours as JSON and SVG. Every file is written atomically.
//!
//! JSON (world coordinates, through the grid's placement when a file's header orients it; a
//! closed contour does not repeat its first point):
//!
//! ```text
//!   {"axis": "z", "at": 0.1, "isovalue": 0.0, "contours": [
//!     {"closed": true, "points": [[x, y, z], ...]},
//!     ...
//!   ]}
//! ```
//!
//! SVG: one `<path>` per contour (`class="closed"` ending in `Z`, or `class="open"`) in the
//! plane's `(u, v)` coordinates (the grid's own frame: world for an unplaced grid) under a transform that puts `u` right and `v` up over a
//! `width x height` canvas, so the SVG lies exactly over the PNG; the grid box's cross-section
//! as a `<rect>`.

use std::io::Write;
use std::path::Path;

use super::contour::{world_points, Contour};
use super::image::SliceImage;
use super::plane::PlaneGrid;
use crate::output::{atomic, exr, png, OutputError};
use crate::vocab::Placement;

/// The JSON text of the contours (one contour per line), points placed in world space.
pub fn json(
    plane: &PlaneGrid,
    placement: &Placement,
    isovalue: f64,
    contours: &[Contour],
) -> String {
    #[derive(serde::Serialize)]
    struct Item {
        closed: bool,
        points: Vec<[f64; 3]>,
    }
    let num = |x: f64| serde_json::to_string(&x).unwrap_or_else(|_| "null".into());
    let mut s = format!(
        "{{\"axis\": \"{}\", \"at\": {}, \"isovalue\": {}, \"contours\": [",
        plane.axis.name(),
        num(plane.at),
        num(isovalue)
    );
    for (n, c) in contours.iter().enumerate() {
        let item = Item {
            closed: c.closed,
            points: world_points(plane, c)
                .iter()
                .map(|&p| placement.point_to_world(p).to_array())
                .collect(),
        };
        s += if n == 0 { "\n  " } else { ",\n  " };
        s += &serde_json::to_string(&item).unwrap_or_default();
    }
    s += if contours.is_empty() { "]}\n" } else { "\n]}\n" };
    s
}

pub fn write_json(
    path: &Path,
    plane: &PlaneGrid,
    placement: &Placement,
    isovalue: f64,
    contours: &[Contour],
) -> Result<(), OutputError> {
    let text = json(plane, placement, isovalue, contours);
    atomic::write_bytes(path, text.as_bytes())
}

/// Several isovalues' contours: `{"isovalues": [..], "surfaces": [<json of each>, ...]}`, each
/// surface as [`json`] writes one.
pub fn write_json_surfaces(
    path: &Path,
    plane: &PlaneGrid,
    placement: &Placement,
    surfaces: &[(f64, &[Contour])],
) -> Result<(), OutputError> {
    let isos: Vec<String> =
        surfaces.iter().map(|(iso, _)| serde_json::to_string(iso).unwrap_or_default()).collect();
    let parts: Vec<String> = surfaces
        .iter()
        .map(|(iso, c)| json(plane, placement, *iso, c).trim_end().to_string())
        .collect();
    let text = format!(
        "{{\"isovalues\": [{}], \"surfaces\": [\n{}\n]}}\n",
        isos.join(", "),
        parts.join(",\n")
    );
    atomic::write_bytes(path, text.as_bytes())
}

/// Escapes text for XML.
fn xml(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The SVG text: `title` as its `<title>`, a `width x height` canvas.
pub fn svg(
    plane: &PlaneGrid,
    contours: &[Contour],
    width: u32,
    height: u32,
    title: &str,
) -> String {
    let size = plane.max - plane.min;
    let (sx, sy) = (width as f64 / size.x, height as f64 / size.y);
    let names = ["x", "y", "z"];
    let mut s = String::new();
    s += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
    s += &format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" \
         viewBox=\"0 0 {width} {height}\">\n"
    );
    s += &format!("<title>{}</title>\n", xml(title));
    s += &format!(
        "<desc>Contours in world ({u}, {v}) coordinates, {u} right and {v} up; the inside is on \
         the left of every path (closed paths around inside regions run counterclockwise).</desc>\n",
        u = names[plane.axes.0],
        v = names[plane.axes.1]
    );
    s += "<style>path, rect { fill: none; vector-effect: non-scaling-stroke; } \
          rect { stroke: #888; stroke-width: 1; } \
          path { stroke-width: 1.5; stroke-linejoin: round; } \
          .closed { stroke: #000; } .open { stroke: #b2182b; }</style>\n";
    s += &format!(
        "<g transform=\"translate(0 {height}) scale({sx} {}) translate({} {})\">\n",
        -sy, -plane.min.x, -plane.min.y
    );
    s += &format!(
        "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\"/>\n",
        plane.min.x, plane.min.y, size.x, size.y
    );
    for c in contours {
        let mut d = String::new();
        for (n, &q) in c.points.iter().enumerate() {
            let uv = plane.to_uv(q);
            d += &format!("{}{} {}", if n == 0 { "M" } else { " L" }, uv.x, uv.y);
        }
        if c.closed {
            d += " Z";
        }
        s += &format!("<path class=\"{}\" d=\"{d}\"/>\n", if c.closed { "closed" } else { "open" });
    }
    s += "</g>\n</svg>\n";
    s
}

pub fn write_svg(
    path: &Path,
    plane: &PlaneGrid,
    contours: &[Contour],
    width: u32,
    height: u32,
    title: &str,
) -> Result<(), OutputError> {
    let text = svg(plane, contours, width, height, title);
    atomic::write_with(path, |w| w.write_all(text.as_bytes()))
}

/// Writes the picture as a 32-bit float EXR: `R`, `G`, `B`, `A`, `value`, `contour`.
pub fn write_exr(
    path: &Path,
    image: &SliceImage,
    attributes: &[(String, String)],
) -> Result<(), OutputError> {
    let n = image.pixels.len();
    let mut planes: Vec<Vec<f32>> = (0..6).map(|_| Vec::with_capacity(n)).collect();
    for p in &image.pixels {
        for (plane, v) in
            planes.iter_mut().zip([p.rgba[0], p.rgba[1], p.rgba[2], p.rgba[3], p.value, p.contour])
        {
            plane.push(v);
        }
    }
    let names = ["R", "G", "B", "A", "value", "contour"];
    let channels = names.iter().map(|s| s.to_string()).zip(planes).collect();
    exr::write_channels(path, image.width as usize, image.height as usize, channels, attributes)
}

/// Writes the picture's colour as an 8-bit sRGB PNG.
pub fn write_png(path: &Path, image: &SliceImage) -> Result<(), OutputError> {
    png::write_rgba8(path, image.width, image.height, &rgba8(image))
}

/// The PNG bytes [`write_png`] writes (`path` only names the file in errors).
pub fn encode_png(path: &Path, image: &SliceImage) -> Result<Vec<u8>, OutputError> {
    png::encode_rgba8(path, image.width, image.height, &rgba8(image))
}

fn rgba8(image: &SliceImage) -> Vec<u8> {
    image.pixels.iter().flat_map(|p| png::to_srgb8(p.rgba)).collect()
}
