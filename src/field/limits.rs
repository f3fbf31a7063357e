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
        if bytes > u64::MAX as u128 {
            // No cap could be raised this far, and no residency reads it in parts: say so
            // rather than suggest either.
            return Err(FieldError::Unaddressable { what: what.to_string(), dims, bytes });
        }
        if bytes > self.max_bytes as u128 {
            return Err(FieldError::TooLarge {
                what: what.to_string(),
                dims,
                bytes,
                cap: self.max_bytes,
                hint: "",
            });
        }
        // A cap raised past the machine's memory would let the allocation fail, which aborts
        // the process (Rust's allocation is infallible): refused with a line instead. The
        // unlimited cap (u64::MAX, which ISOVIEW_MAX_GRID_MIB cannot reach) is the readers'
        // of grids read in parts (`field.residency`): they allocate no whole grid.
        let allocates = self.max_bytes != u64::MAX;
        if let Some(memory) = physical_memory().filter(|&m| allocates && bytes > m as u128) {
            return Err(FieldError::OverMemory { what: what.to_string(), dims, bytes, memory });
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

/// This machine's physical memory in bytes (Linux's `sysconf`), None where it cannot say.
fn physical_memory() -> Option<u64> {
    // SAFETY: sysconf reads two system constants and has no preconditions.
    let (pages, size) =
        unsafe { (libc::sysconf(libc::_SC_PHYS_PAGES), libc::sysconf(libc::_SC_PAGESIZE)) };
    (pages > 0 && size > 0).then(|| (pages as u64).saturating_mul(size as u64))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fifth attack pass M4: a (2^32)^3 `.npy` under the default residency was told to raise
    /// the cap to 302231454903657293676544 MiB (no such setting exists) or to set the
    /// residency it already had. Past 2^64 bytes neither helps, and the line says so.
    #[test]
    fn a_grid_past_64_bit_memory_suggests_nothing() {
        let unlimited = GridLimits { max_bytes: u64::MAX };
        let e = unlimited.check([1 << 32; 3], "huge.npy").unwrap_err();
        assert_eq!(
            e.to_string(),
            "huge.npy: a grid of 4294967296x4294967296x4294967296 points needs \
             302231454903657293676544 MiB of f32 samples, more than 64-bit memory can address \
             (16 EiB)"
        );
        // Just under 2^64 bytes: the cap can still be raised that far, so it is suggested.
        let e = GridLimits::default().check([1 << 20, 1 << 20, (1 << 22) - 1], "big.npy");
        let e = e.unwrap_err().to_string();
        assert!(e.contains("raise the cap with ISOVIEW_MAX_GRID_MIB="), "{e}");
        let mib = e.split("ISOVIEW_MAX_GRID_MIB=").nth(1).unwrap().split(' ').next().unwrap();
        let raised = GridLimits::from_mib_str(mib).expect("the suggested cap can be set");
        // The cap admits it; a machine with less memory than that then refuses it as such.
        match raised.check([1 << 20, 1 << 20, (1 << 22) - 1], "big.npy") {
            Ok(_) | Err(FieldError::OverMemory { .. }) => {}
            Err(e) => panic!("the raised cap still refuses it: {e}"),
        }
    }
}
