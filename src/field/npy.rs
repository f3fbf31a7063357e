//! `.npy` volumes (NumPy's array format, versions 1 to 3).
//!
//! The array must be 3-D with shape `(nx, ny, nz)`: element `[i, j, k]` is the value at grid
//! point `(x_i, y_j, z_k)` (the convention of scikit-image, PyMCubes and GEL). C order stores
//! `k` fastest, Fortran order `i` fastest; both are read into the grid's x-fastest layout.
//! Any boolean, integer or real dtype of either byte order is accepted; complex, structured,
//! string, object and 128-bit float dtypes are refused.
//!
//! [`NpySource::open`] reads only the header and the file's length, so a file whose grid would
//! exceed the memory cap, or whose data is truncated, is refused before any sample is read.

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use npyz::{DType, Endianness, NpyHeader, Order, TypeChar};

use super::error::one_line;
use super::samples::{self, Endian, SampleType, StorageOrder};
use super::{DataAccess, FieldError, GridLimits};

/// Largest header accepted (NumPy itself refuses headers over 10 000 bytes by default).
const MAX_HEADER_BYTES: usize = 1 << 20;

/// Most brackets a header may nest: a plain array's header nests 2 (`{'shape': (2, 3, 4)}`).
const MAX_HEADER_NESTING: usize = 16;

/// The offset of the first bracket (`(`, `[`, `{`) that opens deeper than `max`, outside
/// Python string literals; found without recursion.
fn nests_deeper(text: &[u8], max: usize) -> Option<usize> {
    let (mut depth, mut quote, mut escaped) = (0usize, None, false);
    for (i, &c) in text.iter().enumerate() {
        match (quote, c) {
            (Some(_), _) if escaped => escaped = false,
            (Some(_), b'\\') => escaped = true,
            (Some(q), c) if c == q => quote = None,
            (Some(_), _) => {}
            (None, b'\'' | b'"') => quote = Some(c),
            (None, b'(' | b'[' | b'{') => {
                depth += 1;
                if depth > max {
                    return Some(i);
                }
            }
            (None, b')' | b']' | b'}') => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    None
}

/// A checked `.npy` file: its header has been parsed and its size matches the header.
#[derive(Clone, Debug, PartialEq)]
pub struct NpySource {
    /// The file, as resolved against the scene file's folder.
    pub path: PathBuf,
    /// Grid points along x, y, z (the array's shape).
    pub dims: [usize; 3],
    pub dtype: SampleType,
    pub endian: Endian,
    pub order: StorageOrder,
    /// NumPy's spelling of the dtype (`<f4`), for descriptions.
    pub descr: String,
    /// Byte offset of the first sample.
    pub data_offset: u64,
    /// How `path` is opened: `serve`'s page may only read within its folders.
    pub access: DataAccess,
}

impl NpySource {
    /// Parses the header of `path` and checks the grid against `limits` and the file's length,
    /// reading no samples.
    pub fn open(
        path: &Path,
        limits: &GridLimits,
        access: &DataAccess,
    ) -> Result<NpySource, FieldError> {
        let not_npy = |reason: &str| FieldError::NotNpy {
            path: path.to_path_buf(),
            reason: reason.to_string(),
        };
        let mut file = access.open(path).map_err(|e| FieldError::io(path, &e))?;
        let file_len = file.metadata().map_err(|e| FieldError::io(path, &e))?.len();

        // Magic, version and header length, read here so a corrupt length cannot make the
        // header parser allocate gigabytes.
        let mut pre = [0u8; 12];
        let got = read_up_to(&mut file, &mut pre[..10]).map_err(|e| FieldError::io(path, &e))?;
        if got < 10 || &pre[..6] != b"\x93NUMPY" {
            return Err(not_npy("it does not start with the \\x93NUMPY magic"));
        }
        let (header_len, prefix) = match pre[6] {
            1 => (u16::from_le_bytes([pre[8], pre[9]]) as usize, 10),
            2 | 3 => {
                file.read_exact(&mut pre[10..12])
                    .map_err(|_| not_npy("the header is cut short"))?;
                (u32::from_le_bytes([pre[8], pre[9], pre[10], pre[11]]) as usize, 12)
            }
            v => return Err(not_npy(&format!("unsupported format version {v}.{}", pre[7]))),
        };
        if header_len > MAX_HEADER_BYTES || (prefix + header_len) as u64 > file_len {
            return Err(not_npy(&format!(
                "the header claims {header_len} bytes, the file has {file_len}"
            )));
        }
        let mut bytes = pre[..prefix].to_vec();
        bytes.resize(prefix + header_len, 0);
        file.read_exact(&mut bytes[prefix..]).map_err(|e| FieldError::io(path, &e))?;
        let data_offset = bytes.len() as u64;

        // The dims are checked against the cap before npyz sees the header (it multiplies the
        // shape in u64, which a hostile header could overflow).
        if let Some(shape) = shape_of(&bytes[prefix..]) {
            if shape.len() == 3 && shape.iter().all(|&d| d <= u64::MAX as u128) {
                limits
                    .check([shape[0] as u64, shape[1] as u64, shape[2] as u64], &path_str(path))?;
            }
        }
        // npyz parses the header's Python literal by recursive descent: deep nesting would
        // overflow the stack, so it is refused before npyz sees it. A reader's limit, told in
        // numbers only: `serve` shows it to the page (as the deep `.vti`'s).
        if let Some(at) = nests_deeper(&bytes[prefix..], MAX_HEADER_NESTING) {
            return Err(FieldError::ReaderLimit {
                path: path.to_path_buf(),
                format: "NumPy .npy",
                message: format!(
                    "the header nests brackets deeper than {MAX_HEADER_NESTING} (at header byte \
                     {at})"
                ),
            });
        }
        let header = NpyHeader::from_reader(bytes.as_slice())
            .map_err(|e| not_npy(&one_line(&e.to_string())))?;

        let shape = header.shape();
        if shape.len() != 3 {
            return Err(FieldError::BadShape {
                path: path.to_path_buf(),
                message: format!(
                    "expected a 3-D array of shape (nx, ny, nz), got shape ({})",
                    shape.iter().map(u64::to_string).collect::<Vec<_>>().join(", ")
                ),
            });
        }
        let dims3 = [shape[0], shape[1], shape[2]];
        limits.check(dims3, &path_str(path))?;
        let dims = [dims3[0] as usize, dims3[1] as usize, dims3[2] as usize];
        if dims.iter().any(|&d| d < 2) {
            return Err(FieldError::BadShape {
                path: path.to_path_buf(),
                message: format!(
                    "every axis needs at least 2 points, got shape ({}, {}, {})",
                    dims[0], dims[1], dims[2]
                ),
            });
        }

        let dtype = header.dtype();
        let (ty, endian) = sample_type(path, &dtype)?;
        let order = match header.order() {
            Order::C => StorageOrder::ZFastest,
            Order::Fortran => StorageOrder::XFastest,
        };
        samples::check_file_size(path, file_len, data_offset, dims, ty)?;
        Ok(NpySource {
            path: path.to_path_buf(),
            dims,
            dtype: ty,
            endian,
            order,
            descr: descr(&dtype),
            data_offset,
            access: access.clone(),
        })
    }

    /// Reads the samples, x fastest. Re-checks the cap and the file's length, since the file
    /// may have changed since [`NpySource::open`].
    pub fn read(&self, limits: &GridLimits) -> Result<Vec<f32>, FieldError> {
        let d = self.dims;
        limits.check([d[0] as u64, d[1] as u64, d[2] as u64], &path_str(&self.path))?;
        let mut file = self.access.open(&self.path).map_err(|e| FieldError::io(&self.path, &e))?;
        let len = file.metadata().map_err(|e| FieldError::io(&self.path, &e))?.len();
        samples::check_file_size(&self.path, len, self.data_offset, d, self.dtype)?;
        file.seek(SeekFrom::Start(self.data_offset)).map_err(|e| FieldError::io(&self.path, &e))?;
        let mut reader = BufReader::new(file);
        samples::read_samples(&mut reader, &self.path, self.dtype, self.endian, d, self.order)
    }
}

pub(crate) fn path_str(path: &Path) -> String {
    path.display().to_string()
}

/// Reads until `buf` is full or the file ends.
fn read_up_to(file: &mut File, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match file.read(&mut buf[got..])? {
            0 => break,
            n => got += n,
        }
    }
    Ok(got)
}

/// The integers of the header's `'shape': (...)` entry, parsed without overflow; `None` when the
/// entry cannot be found (npyz then reports what is wrong).
fn shape_of(header: &[u8]) -> Option<Vec<u128>> {
    let text = std::str::from_utf8(header).ok()?;
    let at = text.find("'shape'").or_else(|| text.find("\"shape\""))?;
    let rest = text[at + 7..].trim_start().strip_prefix(':')?.trim_start();
    let close = match rest.chars().next()? {
        '(' => ')',
        '[' => ']',
        _ => return None,
    };
    let inner = &rest[1..rest.find(close)?];
    inner
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.trim_end_matches('L').parse::<u128>().ok())
        .collect()
}

/// NumPy's spelling of a dtype, without the quotes of a plain one (`<f4`).
fn descr(dtype: &DType) -> String {
    dtype.descr().trim_matches('\'').to_string()
}

/// The sample type and byte order of an in-memory array whose NumPy dtype string is `descr`
/// (`<f4`, `|b1`, `>i2`: `numpy.dtype.str`), by the rule `.npy` files are read with (the same
/// types accepted, the same refusals); `what` names the array in the error, as a path names a
/// file.
pub fn sample_type_of_descr(what: &Path, descr: &str) -> Result<(SampleType, Endian), FieldError> {
    match descr.parse::<npyz::TypeStr>() {
        Ok(ts) => sample_type(what, &DType::Plain(ts)),
        Err(_) => Err(FieldError::UnsupportedDtype {
            path: what.to_path_buf(),
            dtype: crate::vocab::echo(descr),
            hint: "expected a boolean, integer or real dtype".to_string(),
        }),
    }
}

/// Maps a NumPy dtype onto a sample type and byte order, or says why it cannot be read.
fn sample_type(path: &Path, dtype: &DType) -> Result<(SampleType, Endian), FieldError> {
    let unsupported = |hint: &str| FieldError::UnsupportedDtype {
        path: path.to_path_buf(),
        dtype: descr(dtype),
        hint: hint.to_string(),
    };
    let DType::Plain(ts) = dtype else {
        return Err(unsupported("structured arrays are not supported; save one real field"));
    };
    let size = ts.size_field();
    let ty = match (ts.type_char(), size) {
        (TypeChar::Bool, 1) => SampleType::Bool,
        (TypeChar::Uint, 1) => SampleType::U8,
        (TypeChar::Int, 1) => SampleType::I8,
        (TypeChar::Uint, 2) => SampleType::U16,
        (TypeChar::Int, 2) => SampleType::I16,
        (TypeChar::Uint, 4) => SampleType::U32,
        (TypeChar::Int, 4) => SampleType::I32,
        (TypeChar::Uint, 8) => SampleType::U64,
        (TypeChar::Int, 8) => SampleType::I64,
        (TypeChar::Float, 2) => SampleType::F16,
        (TypeChar::Float, 4) => SampleType::F32,
        (TypeChar::Float, 8) => SampleType::F64,
        (TypeChar::Float, _) => {
            return Err(unsupported("extended-precision floats are not supported; use float64"))
        }
        (TypeChar::Complex, _) => {
            return Err(unsupported(
                "complex samples are not supported; save the real part or the magnitude",
            ))
        }
        _ => return Err(unsupported("expected a boolean, integer or real dtype")),
    };
    let endian = match ts.endianness() {
        Endianness::Big => Endian::Big,
        Endianness::Little | Endianness::Irrelevant => Endian::Little,
    };
    Ok((ty, endian))
}

#[cfg(test)]
mod tests {
    use super::shape_of;

    #[test]
    fn shape_is_found_without_overflow() {
        let h =
            b"{'descr': '<f4', 'fortran_order': False, 'shape': (18446744073709551615, 3, 4), }";
        assert_eq!(shape_of(h), Some(vec![u64::MAX as u128, 3, 4]));
        assert_eq!(shape_of(b"{'shape': (), 'descr': '<f4'}"), Some(vec![]));
        assert_eq!(shape_of(b"{'descr': '<f4'}"), None);
    }
}
