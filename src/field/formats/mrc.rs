//! MRC/CCP4 maps (MRC2014, <https://www.ccpem.ac.uk/mrc_format/mrc2014.php>): a 1024-byte
//! header of 4-byte words, `NSYMBT` bytes of extended header (skipped), then the samples,
//! columns fastest, then rows, then sections.
//!
//! - Modes: 0 (int8), 1 (int16), 2 (float32), 6 (uint16), 12 (float16). Byte order from the
//!   machine stamp (`0x11` first: big-endian; otherwise little-endian, as mrcfile assumes).
//! - Axis order: `MAPC`, `MAPR`, `MAPS` say which of x, y, z the columns, rows and sections
//!   run along; the samples are rearranged so x varies fastest.
//! - Voxel size: cell dimensions / `MX, MY, MZ` per axis x, y, z (mrcfile's `voxel_size`), in Å.
//! - Origin: the `ORIGIN` words (x, y, z) when any is non-zero, else the start indices
//!   (`NCSTART, NRSTART, NSSTART`, mapped to x, y, z by the axis order) times the voxel size,
//!   the rule ChimeraX uses: EMDB maps mostly set one of the two.

use std::io::Read;

use glam::DVec3;

use super::payload::{self, Encoding, Start};
use super::{Located, ReadOptions, Volume};
use crate::field::samples::{Endian, SampleType};
use crate::field::FieldError;

const HEADER: u64 = 1024;

pub fn read(err: &Located, opts: &ReadOptions) -> Result<Volume, FieldError> {
    let mut file = err.access.open(err.path).map_err(|e| err.io(&e))?;
    let len = file.metadata().map_err(|e| err.io(&e))?.len();
    if len < HEADER {
        return Err(err.bad(format!("the file has {len} bytes, less than the 1024-byte header")));
    }
    let mut h = [0u8; HEADER as usize];
    file.read_exact(&mut h).map_err(|e| err.io(&e))?;
    let endian = if h[212] == 0x11 { Endian::Big } else { Endian::Little };
    let word = |i: usize| {
        let b = [h[4 * i], h[4 * i + 1], h[4 * i + 2], h[4 * i + 3]];
        match endian {
            Endian::Little => i32::from_le_bytes(b),
            Endian::Big => i32::from_be_bytes(b),
        }
    };
    let real = |i: usize| f32::from_bits(word(i) as u32) as f64;

    let n = [word(0), word(1), word(2)]; // columns, rows, sections
    if n.iter().any(|&v| v < 1) {
        return Err(err.bad(format!(
            "NX, NY, NZ = {}, {}, {} are not positive (or not an MRC file)",
            n[0], n[1], n[2]
        )));
    }
    let mode = word(3);
    let (ty, dtype) = match mode {
        0 => (SampleType::I8, "mode 0 (int8)"),
        1 => (SampleType::I16, "mode 1 (int16)"),
        2 => (SampleType::F32, "mode 2 (float32)"),
        6 => (SampleType::U16, "mode 6 (uint16)"),
        12 => (SampleType::F16, "mode 12 (float16)"),
        3 | 4 => {
            return Err(err.bad(format!(
                "mode {mode} holds complex samples; isoview reads real maps (modes 0, 1, 2, 6, 12)"
            )))
        }
        m => return Err(err.bad(format!("mode {m} is not supported (modes 0, 1, 2, 6, 12)"))),
    };
    let map = [word(16), word(17), word(18)];
    let mut sorted = map;
    sorted.sort();
    if sorted != [1, 2, 3] {
        return Err(err.bad(format!(
            "MAPC, MAPR, MAPS = {}, {}, {} is not an order of the axes 1, 2, 3",
            map[0], map[1], map[2]
        )));
    }
    let axis = map.map(|a| (a - 1) as usize); // storage axis s runs along world axis axis[s]
    let mut dims_xyz = [0u64; 3];
    for s in 0..3 {
        dims_xyz[axis[s]] = n[s] as u64;
    }
    let dims = payload::grid(err, dims_xyz, &opts.limits)?;
    let nsymbt = word(23);
    if nsymbt < 0 {
        return Err(err.bad(format!("NSYMBT (extended header bytes) {nsymbt} is negative")));
    }
    let stored_dims = n.map(|v| v as usize);
    let stored = payload::from_file(
        err,
        err.path,
        Encoding::Raw,
        Start::At(HEADER + nsymbt as u64),
        ty,
        endian,
        stored_dims,
    )?;
    let expected = HEADER + nsymbt as u64 + payload::byte_count(stored_dims, ty);
    if len > expected {
        return Err(FieldError::SizeMismatch {
            path: err.path.to_path_buf(),
            expected: expected - HEADER - nsymbt as u64,
            actual: len - HEADER - nsymbt as u64,
            layout: crate::field::samples::layout(stored_dims, ty),
        });
    }
    let values = if axis == [0, 1, 2] { stored } else { reorder(&stored, stored_dims, axis, dims) };

    // Voxel size from the cell, per world axis: both must be positive (a zero cell would put
    // every point at the origin, a NaN one nowhere).
    let cell = [real(10), real(11), real(12)];
    let sampling = [word(7), word(8), word(9)];
    let mut spacing = DVec3::ONE;
    for k in 0..3 {
        spacing[k] = cell[k] / sampling[k] as f64;
        if !(sampling[k] > 0 && super::usable_step(spacing[k])) {
            return Err(err.bad(format!(
                "cell dimensions (CELLA) {} {} {} over MX, MY, MZ = {} {} {}: axis {} has voxel \
                 size {}; {}",
                super::num(cell[0]),
                super::num(cell[1]),
                super::num(cell[2]),
                sampling[0],
                sampling[1],
                sampling[2],
                "xyz".as_bytes()[k] as char,
                super::num(spacing[k]),
                super::STEP_RULE
            )));
        }
    }
    let origin_words = err.finite("ORIGIN", DVec3::new(real(49), real(50), real(51)))?;
    let origin = if origin_words != DVec3::ZERO {
        origin_words
    } else {
        let mut start = DVec3::ZERO;
        for s in 0..3 {
            start[axis[s]] = word(4 + s) as f64;
        }
        start * spacing
    };
    Ok(Volume {
        dims,
        values,
        origin,
        spacing,
        axes: [DVec3::X, DVec3::Y, DVec3::Z],
        dtype: dtype.into(),
        data_file: None,
        sparse: None,
    })
}

/// Rearranges samples stored along permuted axes (storage axis s along world axis `axis[s]`)
/// into x-fastest order.
fn reorder(stored: &[f32], n: [usize; 3], axis: [usize; 3], dims: [usize; 3]) -> Vec<f32> {
    let mut out = vec![0.0f32; stored.len()];
    let stride = [1, dims[0], dims[0] * dims[1]];
    let (sc, sr, ss) = (stride[axis[0]], stride[axis[1]], stride[axis[2]]);
    let mut at = 0;
    for sec in 0..n[2] {
        for row in 0..n[1] {
            let base = sec * ss + row * sr;
            for col in 0..n[0] {
                out[base + col * sc] = stored[at];
                at += 1;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn reorder_puts_columns_on_their_axis() {
        // Columns along z, rows along x, sections along y (MAPC, MAPR, MAPS = 3, 1, 2).
        let n = [4, 2, 3];
        let dims = [2, 3, 4];
        let stored: Vec<f32> = (0..24).map(|v| v as f32).collect();
        let out = super::reorder(&stored, n, [2, 0, 1], dims);
        for sec in 0..3 {
            for row in 0..2 {
                for col in 0..4 {
                    let (x, y, z) = (row, sec, col);
                    assert_eq!(out[x + 2 * (y + 3 * z)], (col + 4 * (row + 2 * sec)) as f32);
                }
            }
        }
    }
}
