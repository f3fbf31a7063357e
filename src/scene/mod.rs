//! Scene files: TOML → parsed → `--set` overrides applied → validated → an immutable
//! [`Scene`].
//!
//! The keys, their defaults and their meaning are the interface contract (`docs/scene.md`,
//! "Scene format"; the defaults live in the `Default` impls in `types.rs`). The pipeline:
//!
//! ```text
//!   text ──toml::de::DeTable──> tree of values with origins (file:line:col or --set N)
//!        ──apply --set KEY=VALUE, in order──> same tree
//!        ──validate (unknown keys, types, ranges, cross-key checks, data headers)──> Scene
//! ```
//!
//! Invariants of a [`Scene`]: every number is finite; image sides are in 1..=16384; the camera
//! has `eye != target`, `0 < fov_y_deg < 180` and `up` not parallel to the view; the field has
//! at least 2 points per axis, `bounds.min < bounds.max` on every axis, fits the memory cap,
//! and its data file (if any) has a readable header and exactly the bytes the header promises.
//!
//! Every error is one line, `FILE:LINE:COL: KEY.PATH: what is wrong` (or `--set KEY=VALUE:
//! KEY.PATH: ...` when an override is at fault). Unknown keys are errors, also for keys that
//! belong to another field source or shape. Relative data paths are resolved against the scene
//! file's folder (also when they come from `--set`).

mod error;
mod field;
mod read;
mod tree;
mod types;
mod validate;

use std::path::Path;

pub use error::{SceneError, SceneErrorKind};
pub use tree::{MAX_KEY_SEGMENTS, MAX_SCENE_BYTES};
pub use types::*;
pub use validate::{
    PickIsovalue, Unpicked, DEFAULT_MAX_PIXELS, MAX_IMAGE_SIDE, MAX_NEWTON_STEPS, MAX_SLICE_DEPTH,
    MAX_STEPS,
};

use crate::field::{DataAccess, GridLimits, GRID_CAP_ENV};
use tree::Source;

/// Loads the scene file at `path`, applies `overrides` (`KEY=VALUE`, VALUE in TOML syntax or a
/// plain string), and validates it, under the grid memory cap of `ISOVIEW_MAX_GRID_MIB`.
pub fn load(path: &Path, overrides: &[String]) -> Result<Scene, SceneError> {
    load_with(path, overrides, &env_limits()?)
}

/// [`load`] under an explicit memory cap.
pub fn load_with(
    path: &Path,
    overrides: &[String],
    limits: &GridLimits,
) -> Result<Scene, SceneError> {
    Ok(load_from(path, overrides, limits, &DataAccess::Any, PickIsovalue::OnLoad)?.0)
}

/// [`load`], reading only the data files `access` admits (a refused `path` key is a
/// [`SceneErrorKind::Value`] error at that key).
pub fn load_confined(
    path: &Path,
    overrides: &[String],
    access: &DataAccess,
) -> Result<Scene, SceneError> {
    Ok(load_confined_picking(path, overrides, access, PickIsovalue::OnLoad)?.0)
}

/// [`load_confined`], with an isovalue picked from the samples picked `when` asked: with
/// [`PickIsovalue::WhenSampled`] the rule to pick it by comes back beside the scene, whose
/// `surface.isovalue` is not picked yet.
pub fn load_confined_picking(
    path: &Path,
    overrides: &[String],
    access: &DataAccess,
    when: PickIsovalue,
) -> Result<(Scene, Option<Unpicked>), SceneError> {
    load_from(path, overrides, &env_limits()?, access, when)
}

fn load_from(
    path: &Path,
    overrides: &[String],
    limits: &GridLimits,
    access: &DataAccess,
    when: PickIsovalue,
) -> Result<(Scene, Option<Unpicked>), SceneError> {
    let name = path.display().to_string();
    let text = tree::read_scene(path, &name)?;
    let base_dir = path.parent().unwrap_or(Path::new(""));
    let (mut scene, unpicked) =
        from_str_confined(&text, &name, base_dir, overrides, limits, access, when)?;
    scene.path = Some(path.to_path_buf());
    Ok((scene, unpicked))
}

/// The text of the scene file at `path`, read as [`load`] reads it: a regular file of at
/// most [`MAX_SCENE_BYTES`], opened without waiting (a FIFO or `/dev/zero` is refused).
pub fn read_text(path: &Path) -> Result<String, SceneError> {
    tree::read_scene(path, &path.display().to_string())
}

/// Parses and validates scene text. `origin` names it in errors (usually the file name);
/// relative data paths are resolved against `base_dir`. The scene's `path` is `None`.
pub fn from_str(
    text: &str,
    origin: &str,
    base_dir: &Path,
    overrides: &[String],
) -> Result<Scene, SceneError> {
    from_str_with(text, origin, base_dir, overrides, &env_limits()?)
}

/// [`from_str`] under an explicit memory cap.
pub fn from_str_with(
    text: &str,
    origin: &str,
    base_dir: &Path,
    overrides: &[String],
    limits: &GridLimits,
) -> Result<Scene, SceneError> {
    let when = PickIsovalue::OnLoad;
    Ok(from_str_confined(text, origin, base_dir, overrides, limits, &DataAccess::Any, when)?.0)
}

/// A scene whose field is `grid`, samples already in memory (an array handed over by a
/// binding): `text` and `overrides` as for [`from_str`], except that `[field]` has no
/// `source` and takes only the keys every source takes (`bounds`, `nan`, `interpolation`);
/// without `bounds` the box is the grid's index space, as for a `.npy` file. `grid`'s own box
/// is not used (the scene's field holds `grid` itself, not a copy). The samples are checked as a file's are (`field.nan`), and an isovalue picked
/// from the data is picked from them.
pub fn from_str_with_grid(
    text: &str,
    origin: &str,
    base_dir: &Path,
    overrides: &[String],
    grid: &std::sync::Arc<crate::field::Grid>,
) -> Result<Scene, SceneError> {
    let limits = env_limits()?;
    let src = Source::new(origin, text, overrides);
    let mut root = src.parse()?;
    for i in 0..overrides.len() {
        src.apply_override(&mut root, i)?;
    }
    let when = PickIsovalue::OnLoad;
    Ok(validate::scene(&src, &root, base_dir, &limits, &DataAccess::Any, Some(grid), when)?.0)
}

fn from_str_confined(
    text: &str,
    origin: &str,
    base_dir: &Path,
    overrides: &[String],
    limits: &GridLimits,
    access: &DataAccess,
    when: PickIsovalue,
) -> Result<(Scene, Option<Unpicked>), SceneError> {
    let src = Source::new(origin, text, overrides);
    let mut root = src.parse()?;
    for i in 0..overrides.len() {
        src.apply_override(&mut root, i)?;
    }
    validate::scene(&src, &root, base_dir, limits, access, None, when)
}

/// The memory cap from the environment, as a scene error if the variable is malformed:
/// `ISOVIEW_MAX_GRID_MIB="lots": expected a positive whole number of MiB`.
fn env_limits() -> Result<GridLimits, SceneError> {
    GridLimits::from_env().map_err(|e| {
        let text = e.to_string();
        let (location, message) = text.split_once(": ").unwrap_or((GRID_CAP_ENV, &text));
        let mut err = SceneError::new(SceneErrorKind::Data, location, None, message);
        err.field_error = Some(Box::new(e));
        err
    })
}
