//! A grid already in memory (`FieldSpec::from_grid`, for scenes built in code): no scene kind,
//! no keys; its samples are the grid's.

use super::Supports;

/// Known only at its grid points.
pub(super) const SUPPORTS: Supports = Supports { point: false, time: false };

pub(super) fn describe() -> String {
    "grid in memory".to_string()
}
