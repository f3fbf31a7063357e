//! Binary samples shared by `npy` and `raw`: element types, byte order, and streaming decode
//! into the grid's `f32` layout (x fastest).

use std::io::Read;
use std::path::Path;

use super::{FieldError, NanPolicy};

/// Element type of a binary volume.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleType {
    /// One byte, 0 or 1 (npy `b1`).
    Bool,
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    U64,
    I64,
    /// IEEE half precision.
    F16,
    F32,
    F64,
}

impl SampleType {
    /// Every type, in the order their names are listed in messages.
    pub const ALL: [SampleType; 12] = [
        SampleType::U8,
        SampleType::I8,
        SampleType::U16,
        SampleType::I16,
        SampleType::U32,
        SampleType::I32,
        SampleType::U64,
        SampleType::I64,
        SampleType::F16,
        SampleType::F32,
        SampleType::F64,
        SampleType::Bool,
    ];

    /// Bytes per sample.
    pub fn size(self) -> usize {
        match self {
            SampleType::Bool | SampleType::U8 | SampleType::I8 => 1,
            SampleType::U16 | SampleType::I16 | SampleType::F16 => 2,
            SampleType::U32 | SampleType::I32 | SampleType::F32 => 4,
            SampleType::U64 | SampleType::I64 | SampleType::F64 => 8,
        }
    }

    /// The name used by `dtype` in scene files (`u8`, `i16`, `f32`, ...).
    pub fn name(self) -> &'static str {
        match self {
            SampleType::Bool => "bool",
            SampleType::U8 => "u8",
            SampleType::I8 => "i8",
            SampleType::U16 => "u16",
            SampleType::I16 => "i16",
            SampleType::U32 => "u32",
            SampleType::I32 => "i32",
            SampleType::U64 => "u64",
            SampleType::I64 => "i64",
            SampleType::F16 => "f16",
            SampleType::F32 => "f32",
            SampleType::F64 => "f64",
        }
    }
}

/// Byte order of multi-byte samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Endian {
    Little,
    Big,
}

impl Endian {
    /// The name used by `endian` in scene files.
    pub fn name(self) -> &'static str {
        match self {
            Endian::Little => "little",
            Endian::Big => "big",
        }
    }
}

/// Order in which a file stores the samples of a `[nx, ny, nz]` grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StorageOrder {
    /// x varies fastest (raw files, npy Fortran order): storage index = grid index.
    XFastest,
    /// z varies fastest (npy C order of an `(nx, ny, nz)` array).
    ZFastest,
}

/// Converts IEEE half-precision bits to `f32` (exact: every f16 is an f32).
pub(crate) fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0f32 } else { 1.0 };
    let exp = (h >> 10) & 0x1f;
    let man = (h & 0x3ff) as u32;
    match exp {
        0 => sign * man as f32 * (2.0f32).powi(-24),
        31 => {
            let bits = ((h as u32 & 0x8000) << 16) | 0x7f80_0000 | (man << 13);
            f32::from_bits(bits)
        }
        _ => {
            let bits = ((h as u32 & 0x8000) << 16) | ((exp as u32 + 112) << 23) | (man << 13);
            f32::from_bits(bits)
        }
    }
}

/// The one conversion of an f64 sample to the grid's f32. A finite value beyond f32's range
/// would become ±inf there, which `field.nan` takes for missing data (or, under "error", for
/// a non-finite sample the file does not hold): it is refused instead, `Err(value)`, and the
/// caller names its grid point ([`FieldError::OutOfRange`]). NaN and ±inf stay as they are.
pub(crate) fn narrow(v: f64) -> Result<f32, f64> {
    let x = v as f32;
    if x.is_infinite() && v.is_finite() {
        Err(v)
    } else {
        Ok(x)
    }
}

/// A finite sample too large for f32 ([`narrow`]): its place in the data and its value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Overflow {
    /// The sample's index in the order the data holds the samples.
    pub at: usize,
    pub value: f64,
}

impl Overflow {
    /// The error naming the sample's grid point, `dims` x fastest (`at` a grid index).
    pub fn error(self, what: String, dims: [usize; 3], detail: String) -> FieldError {
        FieldError::OutOfRange { what, index: grid_index(self.at, dims), value: self.value, detail }
    }
}

/// `[i, j, k]` of the sample at `n` of an x-fastest grid of `dims`.
pub(crate) fn grid_index(n: usize, dims: [usize; 3]) -> [usize; 3] {
    [n % dims[0], (n / dims[0]) % dims[1], n / (dims[0] * dims[1])]
}

/// Decodes `n` samples of `ty` from `bytes` (exactly `n * ty.size()` long) into `out`; fails
/// on the first f64 sample beyond f32's range ([`narrow`]), `at` counted from `bytes`' start.
pub(crate) fn decode(
    ty: SampleType,
    endian: Endian,
    bytes: &[u8],
    out: &mut Vec<f32>,
) -> Result<(), Overflow> {
    macro_rules! each {
        ($n:literal, $conv:expr) => {
            out.extend(bytes.chunks_exact($n).map(|c| {
                let mut a = [0u8; $n];
                a.copy_from_slice(c);
                if endian == Endian::Big {
                    a.reverse();
                }
                #[allow(clippy::redundant_closure_call)]
                ($conv)(a)
            }))
        };
    }
    match ty {
        SampleType::Bool => out.extend(bytes.iter().map(|&b| if b != 0 { 1.0 } else { 0.0 })),
        SampleType::U8 => out.extend(bytes.iter().map(|&b| b as f32)),
        SampleType::I8 => out.extend(bytes.iter().map(|&b| b as i8 as f32)),
        SampleType::U16 => each!(2, |a| u16::from_le_bytes(a) as f32),
        SampleType::I16 => each!(2, |a| i16::from_le_bytes(a) as f32),
        SampleType::F16 => each!(2, |a| f16_to_f32(u16::from_le_bytes(a))),
        SampleType::U32 => each!(4, |a| u32::from_le_bytes(a) as f32),
        SampleType::I32 => each!(4, |a| i32::from_le_bytes(a) as f32),
        SampleType::F32 => each!(4, f32::from_le_bytes),
        SampleType::U64 => each!(8, |a| u64::from_le_bytes(a) as f32),
        SampleType::I64 => each!(8, |a| i64::from_le_bytes(a) as f32),
        SampleType::F64 => {
            // The only type whose finite values can pass f32's range (u64's largest is 1.8e19).
            for (at, c) in bytes.chunks_exact(8).enumerate() {
                let mut a = [0u8; 8];
                a.copy_from_slice(c);
                if endian == Endian::Big {
                    a.reverse();
                }
                out.push(narrow(f64::from_le_bytes(a)).map_err(|value| Overflow { at, value })?);
            }
        }
    }
    Ok(())
}

/// Describes a layout for messages: `[32, 32, 32] x u16`.
pub(crate) fn layout(dims: [usize; 3], ty: SampleType) -> String {
    format!("[{}, {}, {}] x {}", dims[0], dims[1], dims[2], ty.name())
}

/// The samples of an array already in memory (`bytes`: `dims` samples of `ty` in `order`,
/// exactly `nx * ny * nz * ty.size()` bytes), x fastest: the conversion a `.npy` file's
/// samples go through ([`read_samples`]), so an array and the same array saved as `.npy` give
/// the same grid bit for bit. `what` names the array in errors (a sample past f32's range).
pub fn from_memory(
    bytes: &[u8],
    what: &Path,
    ty: SampleType,
    endian: Endian,
    dims: [usize; 3],
    order: StorageOrder,
) -> Result<Vec<f32>, FieldError> {
    let count = dims.iter().try_fold(1usize, |n, &d| n.checked_mul(d));
    if count.and_then(|n| n.checked_mul(ty.size())) != Some(bytes.len()) {
        return Err(FieldError::SizeMismatch {
            path: what.to_path_buf(),
            expected: count.map_or(u64::MAX, |n| (n as u64).saturating_mul(ty.size() as u64)),
            actual: bytes.len() as u64,
            layout: layout(dims, ty),
        });
    }
    read_samples(&mut &bytes[..], what, ty, endian, dims, order)
}

/// Reads `dims` samples of `ty` from `reader` (positioned at the first sample) and returns them
/// x fastest. The caller has already checked the memory cap and the file size.
pub(crate) fn read_samples(
    reader: &mut impl Read,
    path: &Path,
    ty: SampleType,
    endian: Endian,
    dims: [usize; 3],
    order: StorageOrder,
) -> Result<Vec<f32>, FieldError> {
    let count = dims[0] * dims[1] * dims[2];
    let size = ty.size();
    let chunk_samples = 1 << 16;
    let mut buf = vec![0u8; chunk_samples * size];
    let mut stored = Vec::with_capacity(count);
    let mut done = 0usize;
    while done < count {
        let n = chunk_samples.min(count - done);
        let want = &mut buf[..n * size];
        let got = fill(reader, want).map_err(|e| FieldError::io(path, &e))?;
        if got < want.len() {
            return Err(FieldError::Truncated {
                path: path.to_path_buf(),
                expected: (count * size) as u64,
                actual: (done * size + got) as u64,
                layout: layout(dims, ty),
            });
        }
        decode(ty, endian, want, &mut stored).map_err(|o| {
            // `at` in file order: the grid point of a z-fastest file is found by its index.
            let at = done + o.at;
            let index = match order {
                StorageOrder::XFastest => grid_index(at, dims),
                StorageOrder::ZFastest => {
                    let [_, ny, nz] = dims;
                    [at / (ny * nz), (at / nz) % ny, at % nz]
                }
            };
            let what = super::npy::path_str(path);
            FieldError::OutOfRange { what, index, value: o.value, detail: String::new() }
        })?;
        done += n;
    }
    Ok(match order {
        StorageOrder::XFastest => stored,
        StorageOrder::ZFastest => z_fastest_to_x_fastest(&stored, dims),
    })
}

/// The samples of a z-fastest file (storage index `(i * ny + j) * nz + k`) in grid order
/// (`i + nx * (j + ny * k)`), on all rayon threads.
///
/// A transpose whose reads or writes stride by a whole layer or row misses the cache on
/// every sample (256³ f32: 0.3 s, most of an extraction's load). Here each task fills `T`
/// whole output layers a tile at a time: `T` runs of `T` consecutive samples (`T` values of
/// i, for one j, `T` values of k each) read into a local tile, then written out as `T` runs
/// along i. Going through the tile matters: the runs on either side lie a whole layer (or
/// row of rows) apart, a power of two for power-of-two grids, so they map to one cache set,
/// and touching them element by element thrashes it.
fn z_fastest_to_x_fastest(stored: &[f32], dims: [usize; 3]) -> Vec<f32> {
    use rayon::prelude::*;
    const T: usize = 16;
    let [nx, ny, nz] = dims;
    let layer = nx * ny;
    let mut out = vec![0.0f32; stored.len()];
    if layer == 0 {
        return out;
    }
    out.par_chunks_mut(layer * T).enumerate().for_each(|(b, layers)| {
        let k0 = b * T;
        let kn = layers.len() / layer;
        let mut tile = [[0.0f32; T]; T];
        for j in 0..ny {
            for i0 in (0..nx).step_by(T) {
                let n = T.min(nx - i0);
                for (di, run) in tile[..n].iter_mut().enumerate() {
                    let from = ((i0 + di) * ny + j) * nz + k0;
                    run[..kn].copy_from_slice(&stored[from..from + kn]);
                }
                for dk in 0..kn {
                    let to = &mut layers[i0 + nx * (j + ny * dk)..][..n];
                    for (di, v) in to.iter_mut().enumerate() {
                        *v = tile[di][dk];
                    }
                }
            }
        }
    });
    out
}

/// Reads until `buf` is full or the reader ends; returns the bytes read.
fn fill(reader: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match reader.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(got)
}

/// With `field.nan = "error"`, fails on the first NaN or infinity (x-fastest order), naming
/// its grid point; with `"empty"` they are missing data and pass. `what` names the data (a path
/// or an expression) and `detail` is inserted after the index.
pub(crate) fn check_finite(
    values: &[f32],
    dims: [usize; 3],
    nan: NanPolicy,
    what: impl FnOnce() -> String,
    detail: impl FnOnce([usize; 3]) -> String,
) -> Result<(), FieldError> {
    if nan == NanPolicy::Empty {
        return Ok(());
    }
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(n) => {
            let index = grid_index(n, dims);
            Err(FieldError::NonFinite {
                what: what(),
                index,
                value: values[n],
                detail: detail(index),
            })
        }
    }
}

/// Checks that a file holds exactly `header + dims x ty` bytes, without reading it.
pub(crate) fn check_file_size(
    path: &Path,
    file_len: u64,
    header: u64,
    dims: [usize; 3],
    ty: SampleType,
) -> Result<(), FieldError> {
    // Saturating: callers check the memory cap first, but a hostile header must not panic.
    let expected = dims.iter().fold(ty.size() as u64, |n, &d| n.saturating_mul(d as u64));
    let actual = file_len.saturating_sub(header);
    if actual < expected {
        Err(FieldError::Truncated {
            path: path.to_path_buf(),
            expected,
            actual,
            layout: layout(dims, ty),
        })
    } else if actual > expected {
        Err(FieldError::SizeMismatch {
            path: path.to_path_buf(),
            expected,
            actual,
            layout: layout(dims, ty),
        })
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f16_decodes_normals_subnormals_and_specials() {
        assert_eq!(f16_to_f32(0x3c00), 1.0);
        assert_eq!(f16_to_f32(0xc000), -2.0);
        assert_eq!(f16_to_f32(0x3555), 0.333_251_95);
        assert_eq!(f16_to_f32(0x0001), 2.0f32.powi(-24));
        assert_eq!(f16_to_f32(0x8000), -0.0);
        assert_eq!(f16_to_f32(0x7bff), 65504.0);
        assert_eq!(f16_to_f32(0x7c00), f32::INFINITY);
        assert!(f16_to_f32(0x7e00).is_nan());
    }

    #[test]
    fn c_order_is_transposed_to_x_fastest() {
        // (nx, ny, nz) = (2, 3, 4), C order: element [i, j, k] stored at (i*3 + j)*4 + k.
        let dims = [2, 3, 4];
        let mut bytes = Vec::new();
        for i in 0..2u8 {
            for j in 0..3u8 {
                for k in 0..4u8 {
                    bytes.push(100 * i + 10 * j + k);
                }
            }
        }
        let v = read_samples(
            &mut bytes.as_slice(),
            Path::new("t"),
            SampleType::U8,
            Endian::Little,
            dims,
            StorageOrder::ZFastest,
        )
        .unwrap();
        for k in 0..4 {
            for j in 0..3 {
                for i in 0..2 {
                    assert_eq!(v[i + 2 * (j + 3 * k)], (100 * i + 10 * j + k) as f32);
                }
            }
        }
    }

    #[test]
    fn c_order_transpose_covers_partial_blocks_of_layers() {
        // nz = 37: two whole blocks of 16 output layers and a partial one.
        let dims = [3, 5, 37];
        let stored: Vec<f32> = (0..3 * 5 * 37).map(|s| s as f32).collect();
        let v = z_fastest_to_x_fastest(&stored, dims);
        for k in 0..37 {
            for j in 0..5 {
                for i in 0..3 {
                    assert_eq!(v[i + 3 * (j + 5 * k)], ((i * 5 + j) * 37 + k) as f32);
                }
            }
        }
    }
}
