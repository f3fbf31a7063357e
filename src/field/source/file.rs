//! `source = "file"`: a volume in one of the formats users have (NRRD, NIfTI-1, MRC/CCP4,
//! MetaImage, VTK image data, TIFF stacks, OpenVDB and NanoVDB; readers in `field/formats/`). `path` (relative to
//! the scene file) and, when the extension does not say, `format`; `spacing` gives a TIFF
//! stack its voxel size, `grid` picks one grid of a `.vdb` or `.nvdb` file holding several. The grid's dims, box and orientation come from the header: the box
//! is `origin .. origin + spacing * (dims - 1)` in the grid's own frame, and axis directions
//! other than the world's become the field's placement. A `bounds` key overrides both.
//!
//! The file is read whole at load time (compressed formats cannot be checked otherwise), under
//! the memory cap, and kept: sampling hands out a copy. `.vdb` and `.nvdb` grids are kept as
//! their sparse trees (the cap applies to the tree); sampling densifies them under the cap,
//! and the paths that read a grid in parts read the tree (`field::parts`).

use std::sync::Arc;

use glam::DVec3;

use super::params::{self, Need, Params, Rule};
use super::{check_file_dims, FieldSource, Info, Parsed, Supports};
use crate::field::formats::{self, FileSource, Format, ReadOptions};
use crate::field::{FieldError, Grid};
use crate::vocab::{Bounds, Placement};

pub(super) const INFO: Info = Info {
    name: "file",
    keys: &["path", "format", "spacing", "grid"],
    own_box: None,
    supports: Supports { point: false, time: false },
};

pub(super) fn parse<P: Params>(p: &P) -> Result<Parsed, P::Error> {
    let (named, path) = params::data_path_named(p)?;
    let names = Format::ALL.map(|f| (f.name(), Some(f)));
    let format = match p.choice("format", Need::Or(None), &names)? {
        Some(f) => f,
        None => Format::from_path(&named).ok_or_else(|| {
            p.value_error(
                "path",
                format!(
                    "cannot tell the format from the file name (known extensions: {}); add \
                     format = \"nrrd\", \"nifti\", \"mrc\", \"metaimage\", \"vti\", \"vtk\", \"tiff\", \
                     \"vdb\" or \"nvdb\"",
                    Format::all_extensions()
                ),
            )
        })?,
    };
    let positive = Rule { ok: &|v: DVec3| v.min_element() > 0.0, message: "must be positive" };
    // NaN (never a valid value) stands for "absent": the rule only sees written values.
    let spacing = p.vec3("spacing", Need::Or(DVec3::NAN), Some(positive))?;
    let spacing = match (spacing.is_nan(), format) {
        (true, _) => None,
        (false, Format::Tiff) => Some(spacing),
        (false, f) => {
            return Err(p.value_error(
                "spacing",
                format!("only TIFF stacks take a spacing; the {} header gives its own", f.title()),
            ))
        }
    };
    let grid = match p.has("grid") {
        false => None,
        true if matches!(format, Format::Vdb | Format::Nvdb) => {
            let g = p.string("grid", Need::Required("the name of one grid of the file"))?;
            if g.is_empty() {
                return Err(p.value_error("grid", "must not be empty".into()));
            }
            Some(g)
        }
        true => {
            return Err(p.value_error(
                "grid",
                format!(
                    "only .vdb and .nvdb files hold named grids; a {} file has one",
                    format.title()
                ),
            ))
        }
    };
    let has_bounds = p.has("bounds");
    let opts =
        ReadOptions { limits: *p.limits(), spacing, access: p.access().clone(), grid, has_bounds };
    let volume = formats::read(&path, format, &opts).map_err(|e| p.data_error("path", e))?;
    let max =
        volume.origin + volume.spacing * DVec3::from_array(volume.dims.map(|d| (d - 1) as f64));
    let bounds = Bounds { min: volume.origin, max };
    // With `bounds` the header's orientation is not used, so sheared axes do not matter.
    let placement = if volume.axes == [DVec3::X, DVec3::Y, DVec3::Z] || p.has("bounds") {
        None
    } else {
        let placed = Placement::from_axes(volume.origin, volume.axes).map_err(|m| {
            p.data_error(
                "path",
                FieldError::Format { path: path.clone(), format: format.title(), message: m },
            )
        })?;
        Some(placed)
    };
    let resolution = volume.dims;
    let source = FileSource { path, format, volume: Arc::new(volume) };
    Ok(Parsed { source: FieldSource::File(source), resolution, bounds: Some(bounds), placement })
}

pub(super) fn sample(f: &FileSource, grid: &Grid) -> Result<Vec<f32>, FieldError> {
    check_file_dims(f.volume.dims, grid)?;
    // A sparse tree is densified here, for the paths that need the grid whole (the cap was
    // checked against the box's dims before).
    Ok(f.volume.samples().into_owned())
}

pub(super) fn describe(f: &FileSource) -> String {
    format!("file {} {} {}", f.format.name(), crate::field::raw::file_name(&f.path), f.volume.dtype)
}
