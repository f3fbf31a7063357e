//! Headerless binary volumes: `dims = [nx, ny, nz]` samples of one `dtype`, x varying fastest,
//! in the given byte order. The file must hold exactly `nx * ny * nz * size` bytes.

use std::io::BufReader;
use std::path::{Path, PathBuf};

use super::npy::path_str;
use super::samples::{self, Endian, SampleType, StorageOrder};
use super::{DataAccess, FieldError, GridLimits};

/// A `.raw` file and how to read it.
#[derive(Clone, Debug, PartialEq)]
pub struct RawSource {
    /// The file, as resolved against the scene file's folder.
    pub path: PathBuf,
    /// Grid points along x, y, z.
    pub dims: [usize; 3],
    pub dtype: SampleType,
    pub endian: Endian,
    /// How `path` is opened: `serve`'s page may only read within its folders.
    pub access: DataAccess,
}

impl RawSource {
    /// Checks the grid against `limits`, then the file's length against `dims` and `dtype`,
    /// reading no samples. `Ok` means [`RawSource::read`] will find exactly the right bytes
    /// (unless the file changes in between).
    pub fn check(&self, limits: &GridLimits) -> Result<(), FieldError> {
        let d = self.dims;
        limits.check([d[0] as u64, d[1] as u64, d[2] as u64], &path_str(&self.path))?;
        // Opened to be judged: a folder, FIFO or device is refused by what it is, not by a
        // length of 0 ("truncated").
        let meta = self
            .access
            .open(&self.path)
            .and_then(|f| f.metadata())
            .map_err(|e| FieldError::io(&self.path, &e))?;
        samples::check_file_size(&self.path, meta.len(), 0, d, self.dtype)
    }

    /// Reads the samples, x fastest.
    pub fn read(&self, limits: &GridLimits) -> Result<Vec<f32>, FieldError> {
        self.check(limits)?;
        let file = self.access.open(&self.path).map_err(|e| FieldError::io(&self.path, &e))?;
        samples::read_samples(
            &mut BufReader::new(file),
            &self.path,
            self.dtype,
            self.endian,
            self.dims,
            StorageOrder::XFastest,
        )
    }

    /// The file name for descriptions.
    pub(crate) fn file_name(&self) -> String {
        file_name(&self.path)
    }
}

/// The last component of `path` (the whole path if it has none).
pub(crate) fn file_name(path: &Path) -> String {
    path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| path_str(path))
}
