//! The grid memory cap ([`GridLimits`]): checked before anything is allocated or read.

use super::FieldError;

/// Environment variable that sets the grid memory cap, in MiB.
pub const GRID_CAP_ENV: &str = "ISOVIEW_MAX_GRID_MIB";

/// Caps on what a field may allocate.
///
/// A grid whose `f32` samples would take more than `max_bytes` is refused before anything is
/// allocated or read (for files, after reading only the header / file size).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridLimits {
    /// Most bytes of `f32` samples one grid may hold.
    pub max_bytes: u64,
}

impl Default for GridLimits {
    /// 1024 MiB.
    fn default() -> Self {
        GridLimits { max_bytes: Self::DEFAULT_MAX_BYTES }
    }
}

impl GridLimits {
    /// The default cap: 1024 MiB of samples (a 645³ grid).
    pub const DEFAULT_MAX_BYTES: u64 = 1024 << 20;

    /// The cap from `ISOVIEW_MAX_GRID_MIB` (a positive whole number of MiB), or the default when
    /// the variable is unset or empty.
    pub fn from_env() -> Result<GridLimits, FieldError> {
        match std::env::var(GRID_CAP_ENV) {
            Err(std::env::VarError::NotPresent) => Ok(GridLimits::default()),
            Err(std::env::VarError::NotUnicode(v)) => {
                Err(FieldError::BadLimit { value: v.to_string_lossy().into_owned() })
            }
            Ok(v) if v.trim().is_empty() => Ok(GridLimits::default()),
            Ok(v) => Self::from_mib_str(&v),
        }
    }

    /// Parses a cap written in MiB (as in `ISOVIEW_MAX_GRID_MIB`).
    pub fn from_mib_str(text: &str) -> Result<GridLimits, FieldError> {
        text.trim()
            .parse::<u64>()
            .ok()
            .filter(|&m| m > 0)
            .and_then(|m| m.checked_mul(1 << 20))
            .map(|max_bytes| GridLimits { max_bytes })
            .ok_or_else(|| FieldError::BadLimit { value: text.to_string() })
    }

    /// Checks that a grid of `dims` points fits under the cap; returns its number of points.
    /// `what` names the grid in the error (a file path, or "field.resolution").
    pub fn check(&self, dims: [u64; 3], what: &str) -> Result<usize, FieldError> {
        let points = dims.iter().fold(1u128, |n, &d| n.saturating_mul(d as u128));
        let bytes = points.saturating_mul(4);
        if bytes > self.max_bytes as u128 {
            return Err(FieldError::TooLarge {
                what: what.to_string(),
                dims,
                bytes,
                cap: self.max_bytes,
                hint: "",
            });
        }
        // Under a u64 cap, so the count fits a u64; usize is 64-bit on every supported target.
        usize::try_from(points).map_err(|_| FieldError::TooLarge {
            what: what.to_string(),
            dims,
            bytes,
            cap: self.max_bytes,
            hint: "",
        })
    }
}

/// `e` with [`super::error::RESIDENCY_HINT`] added when it is [`FieldError::TooLarge`] (for
/// the npy and raw sources, which `field.residency` can read in parts).
pub(crate) fn with_residency_hint(e: FieldError) -> FieldError {
    with_hint(e, super::error::RESIDENCY_HINT)
}

/// `e` with `hint` as what else the source allows, when it is [`FieldError::TooLarge`].
pub(crate) fn with_hint(e: FieldError, hint: &'static str) -> FieldError {
    match e {
        FieldError::TooLarge { what, dims, bytes, cap, .. } => {
            FieldError::TooLarge { what, dims, bytes, cap, hint }
        }
        other => other,
    }
}
