//! NIfTI-1 (`.nii`, `.nii.gz`; <https://nifti.nimh.nih.gov/nifti-1>), read by hand: the
//! `nifti` crate pulls in ndarray and num machinery for a 348-byte header.
//!
//! - Byte order: `sizeof_hdr` reads 348 in the file's order.
//! - `dim[0]` is 3, or more with every extra dimension 1 (one 3-D volume; a time series is
//!   refused with its length).
//! - Datatypes: uint8, int8, int16, uint16, int32, uint32, int64, uint64, float32, float64.
//! - Values: `scl_slope * v + scl_inter` when `scl_slope` is finite and non-zero (nibabel's rule).
//! - Geometry (method 3, 2 or 1 of the standard): the sform rows when `sform_code > 0`, else the
//!   qform quaternion (`quatern_b, c, d`, `qoffset`, `pixdim[1..3]`, `qfac = pixdim[0]`, -1 or
//!   else 1) when `qform_code > 0`, else `pixdim[1..3]` from the origin, axes along the world's.
//!   Coordinates stay in NIfTI's RAS+ millimetres. (nibabel falls back to an Analyze affine,
//!   centred and flipped in x, when both codes are 0; isoview takes the standard's method 1.)

use std::io::{BufReader, Read};

use flate2::read::MultiGzDecoder;
use glam::{DMat3, DQuat, DVec3};

use super::payload::{self, Encoding, Start};
use super::{Located, ReadOptions, Volume};
use crate::field::samples::{Endian, SampleType};
use crate::field::FieldError;

const HEADER: usize = 348;

pub fn read(err: &Located, opts: &ReadOptions) -> Result<Volume, FieldError> {
    let file = err.access.open(err.path).map_err(|e| err.io(&e))?;
    let gz = err.path.to_string_lossy().to_ascii_lowercase().ends_with(".gz");
    let mut reader: Box<dyn Read> = if gz {
        Box::new(MultiGzDecoder::new(BufReader::new(file)))
    } else {
        Box::new(BufReader::new(file))
    };
    let mut h = [0u8; HEADER];
    read_full(&mut reader, &mut h).map_err(|got| match got {
        Ok(n) => err.bad(format!("the file holds {n} bytes, less than the 348-byte header")),
        Err(e) => {
            err.bad(format!("cannot decompress: {}", crate::field::error::one_line(&e.to_string())))
        }
    })?;
    let endian = match (
        i32::from_le_bytes([h[0], h[1], h[2], h[3]]),
        i32::from_be_bytes([h[0], h[1], h[2], h[3]]),
    ) {
        (348, _) => Endian::Little,
        (_, 348) => Endian::Big,
        _ => {
            return Err(
                err.bad("sizeof_hdr is not 348 (not a NIfTI-1 file; NIfTI-2 is not supported)")
            )
        }
    };
    let i16_at = |o: usize| {
        let b = [h[o], h[o + 1]];
        if endian == Endian::Little {
            i16::from_le_bytes(b)
        } else {
            i16::from_be_bytes(b)
        }
    };
    let f32_at = |o: usize| {
        let b = [h[o], h[o + 1], h[o + 2], h[o + 3]];
        let bits =
            if endian == Endian::Little { u32::from_le_bytes(b) } else { u32::from_be_bytes(b) };
        f32::from_bits(bits) as f64
    };
    let magic = &h[344..348];
    if magic == b"ni1\0" {
        return Err(err.bad("a .hdr/.img pair (magic ni1); isoview reads single-file .nii"));
    }
    if magic != b"n+1\0" {
        return Err(err.bad("the magic is not n+1 (not a NIfTI-1 file)"));
    }

    let dim: Vec<i64> = (0..8).map(|k| i16_at(40 + 2 * k) as i64).collect();
    if !(3..=7).contains(&dim[0]) {
        return Err(err.bad(format!("dim[0] = {}: isoview reads 3-D volumes", dim[0])));
    }
    let extra: i64 = (4..=dim[0] as usize).map(|k| dim[k].max(1)).product();
    if extra > 1 {
        return Err(err.bad(format!(
            "a {}-D image holding {extra} volumes; isoview reads one 3-D volume",
            dim[0]
        )));
    }
    if dim[1..4].iter().any(|&d| d < 1) {
        return Err(err.bad(format!("dim {}x{}x{} is not positive", dim[1], dim[2], dim[3])));
    }
    let datatype = i16_at(70);
    let (ty, name) = match datatype {
        2 => (SampleType::U8, "uint8"),
        4 => (SampleType::I16, "int16"),
        8 => (SampleType::I32, "int32"),
        16 => (SampleType::F32, "float32"),
        64 => (SampleType::F64, "float64"),
        256 => (SampleType::I8, "int8"),
        512 => (SampleType::U16, "uint16"),
        768 => (SampleType::U32, "uint32"),
        1024 => (SampleType::I64, "int64"),
        1280 => (SampleType::U64, "uint64"),
        t => return Err(err.bad(format!("datatype {t} is not a real scalar type isoview reads"))),
    };
    let dims = payload::grid(err, [dim[1] as u64, dim[2] as u64, dim[3] as u64], &opts.limits)?;
    let vox_offset = f32_at(108);
    if !(vox_offset.is_finite() && vox_offset >= HEADER as f64 && vox_offset.fract() == 0.0) {
        return Err(err.bad(format!(
            "vox_offset {vox_offset} is not a whole number of bytes past the header"
        )));
    }
    let skip = vox_offset as u64 - HEADER as u64;
    let mut values = if gz {
        payload::inflated(err, reader, skip, ty, endian, dims)?
    } else {
        let v = payload::from_file(
            err,
            err.path,
            Encoding::Raw,
            Start::At(vox_offset as u64),
            ty,
            endian,
            dims,
        )?;
        check_no_trailing(err, vox_offset as u64 + payload::byte_count(dims, ty), ty, dims)?;
        v
    };
    let (slope, inter) = (f32_at(112), f32_at(116));
    if slope.is_finite() && slope != 0.0 && !(slope == 1.0 && inter == 0.0) {
        let inter = if inter.is_finite() { inter } else { 0.0 };
        // scl_slope and scl_inter can carry an f32 sample past f32's range.
        for (at, v) in values.iter_mut().enumerate() {
            *v = crate::field::samples::narrow(*v as f64 * slope + inter).map_err(|value| {
                let what = format!("{} (after scl_slope and scl_inter)", err.path.display());
                crate::field::samples::Overflow { at, value }.error(what, dims, String::new())
            })?;
        }
    }

    let pixdim: Vec<f64> = (0..8).map(|k| f32_at(76 + 4 * k)).collect();
    let (qform_code, sform_code) = (i16_at(252), i16_at(254));
    let mut v = Volume {
        dims,
        values,
        origin: DVec3::ZERO,
        spacing: DVec3::ONE,
        axes: [DVec3::X, DVec3::Y, DVec3::Z],
        dtype: name.into(),
        data_file: None,
        sparse: None,
    };
    if sform_code > 0 {
        let row = |o: usize| [f32_at(o), f32_at(o + 4), f32_at(o + 8), f32_at(o + 12)];
        let (x, y, z) = (row(280), row(296), row(312));
        let cols = [0, 1, 2].map(|c| DVec3::new(x[c], y[c], z[c]));
        v.set_axes(cols, "srow_x/y/z", err)?;
        v.origin = err.finite("srow_x/y/z offsets", DVec3::new(x[3], y[3], z[3]))?;
    } else if qform_code > 0 {
        let (b, c, d) = (f32_at(256), f32_at(260), f32_at(264));
        err.finite("quatern_b/c/d", DVec3::new(b, c, d))?;
        let a2 = 1.0 - (b * b + c * c + d * d);
        // nibabel's tolerance: a slightly negative a² (rounding of stored f32s) is 0.
        let a = if a2 < -1e-6 {
            return Err(err.bad(format!("the qform quaternion ({b}, {c}, {d}) has length over 1")));
        } else {
            a2.max(0.0).sqrt()
        };
        let r = DMat3::from_quat(DQuat::from_xyzw(b, c, d, a).normalize());
        let qfac = if pixdim[0] == -1.0 { -1.0 } else { 1.0 };
        let zooms = DVec3::new(pixdim[1], pixdim[2], pixdim[3] * qfac);
        let cols = [r.x_axis * zooms.x, r.y_axis * zooms.y, r.z_axis * zooms.z];
        v.set_axes(cols, "pixdim[1..3]", err)?;
        v.origin =
            err.finite("qoffset_x/y/z", DVec3::new(f32_at(268), f32_at(272), f32_at(276)))?;
    } else {
        let zooms = DVec3::new(pixdim[1], pixdim[2], pixdim[3]);
        let cols = [DVec3::X * zooms.x, DVec3::Y * zooms.y, DVec3::Z * zooms.z];
        v.set_axes(cols, "pixdim[1..3]", err)?;
    }
    Ok(v)
}

/// Fills `buf`; on a short read, the bytes read (Ok) or the error.
fn read_full(r: &mut impl Read, buf: &mut [u8]) -> Result<(), Result<usize, std::io::Error>> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) => return Err(Ok(got)),
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(Err(e)),
        }
    }
    Ok(())
}

/// Refuses a `.nii` longer than its header, extensions and samples.
fn check_no_trailing(
    err: &Located,
    end: u64,
    ty: SampleType,
    dims: [usize; 3],
) -> Result<(), FieldError> {
    let len = std::fs::metadata(err.path).map_err(|e| err.io(&e))?.len();
    if len > end {
        let bytes = payload::byte_count(dims, ty);
        return Err(FieldError::SizeMismatch {
            path: err.path.to_path_buf(),
            expected: bytes,
            actual: bytes + (len - end),
            layout: crate::field::samples::layout(dims, ty),
        });
    }
    Ok(())
}
