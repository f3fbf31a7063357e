//! Slices: the field on an axis-aligned plane through the grid box, its isovalue contours by
//! marching squares, and 2D root finding on the plane.
//!
//! ```text
//!   Grid ──PlaneGrid::new(axis, at)──> plane values (the trilinear field restricted to the
//!     │                                plane: bilinear per cross-section cell)
//!     │                                   │
//!     │                        contour::extract (quadtree, marching squares, ambiguity rule,
//!     │                                   │      stitching)  ──> loops and polylines
//!     │                                   │                        ├─> export::json / svg
//!     └──GpuGrid──> image::SliceRenderer (shaders/slice.comp) <───┘  (drawn over the colour)
//!                      value, colormap, contour lines  ──> export::exr / png
//! ```
//!
//! The picture of `--axis A --at C` covers the box's cross-section: `u` (right) and `v` (up)
//! are the other two axes in xyz order (`x`: y right, z up; `y`: x right, z up; `z`: x right,
//! y up), and pixel `(px, py)` of a `W x H` picture is the point
//! `u = min.u + (px + 0.5) / W (max.u - min.u)`, `v = max.v - (py + 0.5) / H (max.v - min.v)`.
//! "Inside on the left" and "counterclockwise" refer to that view.
//!
//! Module map: [`plane`] (geometry and the plane's values), [`squares`] (the case table and the
//! ambiguity rule), [`contour`] (refinement and stitching), [`roots`] (edge and segment root
//! finding), [`image`] (the GPU picture), [`reference`] (its f64 mirror), [`export`] (files).

pub mod contour;
pub mod export;
pub mod image;
pub mod plane;
pub mod reference;
pub mod roots;
pub mod squares;

pub use contour::{extract, Contour, ContourOptions, ContourSet, ContourStats, SourceField};
pub use image::{SliceImage, SliceRenderer, SliceStyle};
pub use plane::{picture_size, Axis, PlaneGrid};
pub use roots::{probe_segment, RootKind, SegmentProbe};

use crate::scene::Scene;
use crate::vocab::echo_number;

/// What can go wrong in a slice before the GPU or the output files are involved.
#[derive(Debug, thiserror::Error)]
pub enum SliceError {
    /// The plane misses the box; [`SliceError::located`] names the option it came from.
    #[error(
        "the plane {axis} = {} misses the grid box ({axis} from {} to {})",
        echo_number(*at), echo_number(*min), echo_number(*max)
    )]
    OutsideBox { axis: &'static str, at: f64, min: f64, max: f64 },
    #[error("{0}")]
    Input(String),
}

impl SliceError {
    /// The message, a plane outside the box led by the option that placed it, as the user
    /// gave it (`--at 1.5` for `slice`, `--slice x=1.5` for `probe`).
    pub fn located(&self, option: &str) -> String {
        match self {
            SliceError::OutsideBox { .. } => format!("{option}: {self}"),
            SliceError::Input(_) => self.to_string(),
        }
    }
}

/// Contour options from a scene's `[surface]` and `[slice]`.
pub fn contour_options(scene: &Scene) -> ContourOptions {
    ContourOptions {
        isovalue: scene.surface.isovalue,
        inside: scene.surface.inside,
        ambiguity: scene.slice.ambiguity,
        max_depth: scene.slice.max_depth,
    }
}

/// The contours of `plane` by the scene's settings, with the scene's source (at `time`) for
/// `ambiguity = "sample"` and refinement.
///
/// Through another interpolant the contours are that interpolant's (`plane` from
/// [`PlaneGrid::through`] of `grid`): the cubic ones' corners and crossings come from the
/// interpolant itself, as a source of world points ([`interpolant_source`]); nearest's are its
/// voxels' edges ([`contour`]'s module docs).
pub fn scene_contours(
    scene: &Scene,
    grid: &crate::field::Grid,
    plane: &PlaneGrid,
    time: f64,
) -> Result<ContourSet, SliceError> {
    let source = match plane.interp {
        crate::field::interpolant::Interpolant::Trilinear => {
            SourceField::from_spec(&scene.field, time)
        }
        interp => Some(interpolant_source(grid, interp)),
    };
    extract(plane, source.as_ref(), &contour_options(scene))
}

/// `grid` read with `interp` as a function of world points (the grid's own frame): NaN where
/// the interpolant is missing. No Lipschitz bound: refinement takes the plane's steepest slope.
pub fn interpolant_source(
    grid: &crate::field::Grid,
    interp: crate::field::interpolant::Interpolant,
) -> SourceField<'_> {
    let field = crate::field::interpolant::Interpolated::new(grid, interp);
    let (min, spacing) = (grid.min, grid.spacing());
    SourceField {
        eval: Box::new(move |p| {
            let u = (p - min) / spacing;
            if field.missing_at(u) {
                f64::NAN
            } else {
                field.value_at(u)
            }
        }),
        lipschitz: None,
    }
}

/// A slice ready to draw: the plane's grid, its contours and the picture's style.
pub struct Planned {
    pub plane: PlaneGrid,
    pub set: ContourSet,
    pub style: SliceStyle,
}

/// The plane `axis = at` of `grid` (sampled from `scene`'s field at `time`), its contours by
/// the scene's settings, and the picture's size (`[slice]`, else the image width) and colours:
/// what `isoview slice` draws.
pub fn plan(
    scene: &Scene,
    grid: &crate::field::Grid,
    axis: Axis,
    at: f64,
    time: f64,
) -> Result<Planned, SliceError> {
    if let Some(why) = scene.interpolation_refusal(crate::field::interpolant::Reader::Slice) {
        return Err(SliceError::Input(why));
    }
    let plane = PlaneGrid::through(grid, axis, at, scene.field.interpolation)?;
    let set = scene_contours(scene, grid, &plane, time)?;
    let (width, height) = picture_size(
        &plane,
        scene.slice.width,
        scene.slice.height,
        scene.image.width,
        crate::scene::MAX_IMAGE_SIDE as u32,
    );
    let iso = scene.surface.isovalue;
    let style = SliceStyle {
        width,
        height,
        isovalue: iso,
        inside: scene.surface.inside,
        half_range: image::colormap_half_range(&plane, iso),
        line_width: 1.5,
        line_color: [0.0, 0.0, 0.0, 1.0],
    };
    Ok(Planned { plane, set, style })
}

/// Refuses a picture of `style`'s size over `max_pixels` (`--max-pixels`), before anything
/// is drawn: the picture is held whole in memory, and a side derived from a thin plane's
/// aspect ratio can reach 16384 x 16384 (8 GiB of records; it aborted `slice` and took
/// `serve` to 9.6 GB). `verb` names the command whose cap it is; the keys named are those
/// the size came from. `isoview slice` and the page's slice panel share this rule.
pub fn check_picture(
    scene: &Scene,
    style: &SliceStyle,
    max_pixels: u64,
    verb: &str,
) -> Result<(), SliceError> {
    let (w, h) = (style.width as u64, style.height as u64);
    if w * h <= max_pixels {
        return Ok(());
    }
    let derived = |given: &str, other: &str| {
        format!("{given}, and the {other} from the cross-section's aspect ratio")
    };
    let from = match (scene.slice.width, scene.slice.height) {
        (Some(_), Some(_)) => "slice.width, slice.height".to_string(),
        (Some(_), None) => derived("slice.width", "height"),
        (None, Some(_)) => derived("slice.height", "width"),
        (None, None) => derived("image.width", "height"),
    };
    Err(SliceError::Input(format!(
        "the slice picture: {w}x{h} = {} pixels ({from}), over isoview {verb}'s cap of \
         {max_pixels} pixels; raise it with --max-pixels",
        w * h
    )))
}

/// The title of a slice's SVG.
pub fn svg_title(plane: &PlaneGrid, scene_name: &str, isovalue: f64) -> String {
    format!(
        "isoview slice {} = {} of {scene_name}, isovalue {}",
        plane.axis.name(),
        crate::vocab::echo_number(plane.at),
        crate::vocab::echo_number(isovalue)
    )
}

/// The EXR header attributes of a slice (names under `isoview/`).
pub fn attributes(
    scene: &Scene,
    plane: &PlaneGrid,
    style: &SliceStyle,
    device: (&str, &str),
    time: f64,
) -> Vec<(String, String)> {
    let names = ["x", "y", "z"];
    let (u, v) = (names[plane.axes.0], names[plane.axes.1]);
    let sign = match scene.surface.inside {
        crate::scene::Inside::Below => -1.0,
        crate::scene::Inside::Above => 1.0,
    };
    let iso = style.isovalue;
    let a = |k: &str, v: String| (format!("isoview/{k}"), v);
    vec![
        a("version", crate::VERSION.to_string()),
        a("scene", scene.path.as_ref().map(|p| p.display().to_string()).unwrap_or_default()),
        a("method", "slice".into()),
        a("field", scene.field.describe()),
        a("isovalue", iso.to_string()),
        a("inside", scene.surface.inside.name().into()),
        a("time", time.to_string()),
        a("device", device.0.to_string()),
        a("driver", device.1.to_string()),
        a("slice/axis", plane.axis.name().into()),
        a("slice/at", plane.at.to_string()),
        a(
            "slice/window",
            format!(
                "{u} right from {} to {}, {v} up from {} to {}",
                plane.min.x, plane.max.x, plane.min.y, plane.max.y
            ),
        ),
        a("slice/ambiguity", scene.slice.ambiguity.name().into()),
        a("slice/max_depth", scene.slice.max_depth.to_string()),
        a("slice/colormap", image::COLORMAP_NAME.into()),
        // The values at the colormap's red (inside) and blue (outside) ends.
        a("slice/colormap_red", (iso + sign * style.half_range).to_string()),
        a("slice/colormap_blue", (iso - sign * style.half_range).to_string()),
    ]
}
