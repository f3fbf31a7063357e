//! NRRD (Teem's "nearly raw raster data", <https://teem.sourceforge.net/nrrd/format.html>):
//! `.nrrd` with the data attached after an empty line, or a detached `.nhdr` naming its
//! `data file`. Read: every scalar `type`, `encoding` raw, gzip and ascii, `endian`,
//! `byte skip` (-1: the data is the file's last bytes), `line skip`, `sizes` (3 axes, the
//! first fastest), and the geometry from `space directions` + `space origin` (a world space)
//! or else `spacings` + `axis mins`. bzip2, hex and `data file: LIST` / multi-file patterns
//! are refused with a message.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

use glam::DVec3;

use super::payload::{self, Encoding, Start};
use super::text::{self, nrrd_vector, nrrd_vectors};
use super::{Located, ReadOptions, Volume};
use crate::field::samples::{Endian, SampleType};
use crate::field::FieldError;

/// Reads an NRRD file (attached or detached data).
pub fn read(err: &Located, opts: &ReadOptions) -> Result<Volume, FieldError> {
    let file = err.access.open(err.path).map_err(|e| err.io(&e))?;
    let (head, data_offset) = text::header_until_blank_line(err, file, true)?;
    let h = Header::parse(err, &head)?;
    let dims = payload::grid(err, h.sizes, &opts.limits)?;

    // Attached data follows the header's empty line; a detached file starts at its line skip.
    let (data_path, base) = match &h.data_file {
        Some(name) => (err.detached("data file", name, &opts.access)?, 0),
        None => (err.path.to_path_buf(), data_offset),
    };
    let line_start = skip_lines(err, &data_path, base, h.line_skip)?;
    let start = match h.byte_skip {
        -1 if h.encoding == Encoding::Raw => Start::FromEnd,
        -1 => return Err(err.bad("byte skip: -1 is only allowed with encoding: raw")),
        n if n < 0 => return Err(err.bad(format!("byte skip: {n} is negative"))),
        n => Start::At(n as u64),
    };
    // Byte skip counts raw bytes after the line skip; for compressed data, decompressed bytes.
    let (start, compressed_from) = match (h.encoding, start) {
        (Encoding::Raw | Encoding::Ascii, Start::At(n)) => (Start::At(line_start + n), 0),
        (Encoding::Raw, Start::FromEnd) => (Start::FromEnd, 0),
        (_, s) => (s, line_start),
    };
    let values = if compressed_from > 0 {
        let at = err.at(&data_path);
        let mut f = at.access.open(&data_path).map_err(|e| at.io(&e))?;
        std::io::Seek::seek(&mut f, std::io::SeekFrom::Start(compressed_from))
            .map_err(|e| at.io(&e))?;
        let Start::At(skip) = start else { unreachable!("FromEnd is refused unless raw") };
        payload::compressed(&at, BufReader::new(f), h.encoding, skip, h.ty, h.endian, dims)?
    } else {
        payload::from_file(err, &data_path, h.encoding, start, h.ty, h.endian, dims)?
    };

    let mut v = Volume {
        dims,
        values,
        origin: DVec3::ZERO,
        spacing: DVec3::ONE,
        axes: [DVec3::X, DVec3::Y, DVec3::Z],
        dtype: h.type_name.clone(),
        data_file: (data_path != err.path).then(|| data_path.clone()),
        sparse: None,
    };
    match &h.directions {
        Some(dirs) => {
            v.set_axes(*dirs, "space directions", err)?;
            v.origin = err.finite("space origin", h.origin.unwrap_or(DVec3::ZERO))?;
        }
        None => {
            for k in 0..3 {
                // `nan` spacings and mins mean "unknown" (the NRRD format's own rule): 1 and 0;
                // other values were checked in the header.
                if let Some(s) = h.spacings.map(|s| s[k]).filter(|s| !s.is_nan()) {
                    v.spacing[k] = s.abs();
                    if s < 0.0 {
                        v.axes[k] = -v.axes[k];
                    }
                }
                if let Some(m) = h.axis_mins.map(|m| m[k]).filter(|m| !m.is_nan()) {
                    v.origin[k] = m;
                }
            }
        }
    }
    Ok(v)
}

/// The fields isoview uses, checked.
struct Header {
    sizes: [u64; 3],
    ty: SampleType,
    type_name: String,
    encoding: Encoding,
    endian: Endian,
    data_file: Option<PathBuf>,
    line_skip: u64,
    byte_skip: i64,
    directions: Option<[DVec3; 3]>,
    origin: Option<DVec3>,
    spacings: Option<[f64; 3]>,
    axis_mins: Option<[f64; 3]>,
}

impl Header {
    fn parse(err: &Located, head: &str) -> Result<Header, FieldError> {
        let mut lines = head.lines().enumerate();
        match lines.next() {
            Some((_, magic)) if magic.starts_with("NRRD000") => {}
            _ => return Err(err.bad("it does not start with the NRRD000X magic")),
        }
        let mut fields: Vec<(usize, String, String)> = Vec::new();
        for (n, line) in lines {
            let line = line.trim_end_matches('\r');
            if line.starts_with('#') || line.trim().is_empty() || line.contains(":=") {
                continue; // comments and key/value pairs
            }
            let Some((name, value)) = line.split_once(": ") else {
                return Err(
                    err.bad(format!("line {}: expected \"field: value\", got {line:?}", n + 1))
                );
            };
            fields.push((n + 1, name.trim().to_ascii_lowercase(), value.trim().to_string()));
        }
        let get = |names: &[&str]| {
            fields
                .iter()
                .rev()
                .find(|(_, f, _)| names.contains(&f.as_str()))
                .map(|(n, _, v)| (*n, v.as_str()))
        };
        let line_err = |n: usize, what: String| err.bad(format!("line {n}: {what}"));

        let (n, dim) =
            get(&["dimension"]).ok_or_else(|| err.bad("the header has no dimension field"))?;
        if dim != "3" {
            return Err(line_err(n, format!("dimension {dim}: isoview reads 3-D volumes")));
        }
        let (n, s) = get(&["sizes"]).ok_or_else(|| err.bad("the header has no sizes field"))?;
        let sizes = match text::sizes(s).as_deref() {
            Some([x, y, z]) => [*x, *y, *z],
            _ => return Err(line_err(n, format!("sizes {s:?}: expected 3 whole numbers"))),
        };
        let (n, t) = get(&["type"]).ok_or_else(|| err.bad("the header has no type field"))?;
        let ty = sample_type(t)
            .ok_or_else(|| line_err(n, format!("type {t:?} is not a scalar type isoview reads")))?;
        let encoding = match get(&["encoding"]) {
            None => return Err(err.bad("the header has no encoding field")),
            Some((n, e)) => match e.to_ascii_lowercase().as_str() {
                "raw" => Encoding::Raw,
                "gz" | "gzip" => Encoding::Gzip,
                "txt" | "text" | "ascii" => Encoding::Ascii,
                other => {
                    return Err(line_err(
                        n,
                        format!("encoding {other:?} is not supported (raw, gzip or ascii)"),
                    ))
                }
            },
        };
        let endian = match get(&["endian"]) {
            Some((_, "little")) => Endian::Little,
            Some((_, "big")) => Endian::Big,
            Some((n, e)) => {
                return Err(line_err(n, format!("endian {e:?}: expected little or big")))
            }
            None if ty.size() == 1 || encoding == Encoding::Ascii => Endian::Little,
            None => return Err(err.bad(format!("the header has no endian field (needed for {t})"))),
        };
        let data_file = match get(&["data file", "datafile"]) {
            None => None,
            Some((n, f)) => {
                if f.starts_with("LIST") || f.split_ascii_whitespace().count() > 1 {
                    return Err(line_err(
                        n,
                        format!("data file {f:?}: only a single data file is supported"),
                    ));
                }
                let dir = err.path.parent().unwrap_or(Path::new(""));
                Some(dir.join(f))
            }
        };
        let int = |names: &[&str]| -> Result<Option<i64>, FieldError> {
            match get(names) {
                None => Ok(None),
                Some((n, v)) => v
                    .parse()
                    .map(Some)
                    .map_err(|_| line_err(n, format!("{} {v:?} is not a whole number", names[0]))),
            }
        };
        let line_skip = int(&["line skip", "lineskip"])?.unwrap_or(0);
        if line_skip < 0 {
            return Err(err.bad(format!("line skip {line_skip} is negative")));
        }
        let byte_skip = int(&["byte skip", "byteskip"])?.unwrap_or(0);

        let space_dim = match (get(&["space"]), get(&["space dimension"])) {
            (Some((n, s)), _) => Some(
                space_dimension(s)
                    .ok_or_else(|| line_err(n, format!("space {s:?} is not a 3-D space")))?,
            ),
            (None, Some((n, d))) => Some(
                d.parse::<usize>()
                    .map_err(|_| line_err(n, format!("space dimension {d:?}")))
                    .and_then(|d| {
                        if d == 3 {
                            Ok(3)
                        } else {
                            Err(line_err(
                                n,
                                format!("space dimension {d}: isoview places grids in 3-D space"),
                            ))
                        }
                    })?,
            ),
            (None, None) => None,
        };
        let directions = match get(&["space directions"]) {
            None => None,
            Some((n, s)) => {
                let vs = nrrd_vectors(s).ok_or_else(|| {
                    line_err(n, format!("space directions {s:?}: expected 3 vectors like (1,0,0)"))
                })?;
                if space_dim.is_none() {
                    return Err(line_err(
                        n,
                        "space directions without a space or space dimension field".into(),
                    ));
                }
                let mut cols = [DVec3::ZERO; 3];
                if vs.len() != 3 {
                    return Err(line_err(
                        n,
                        format!("space directions: {} vectors for 3 axes", vs.len()),
                    ));
                }
                for (k, v) in vs.iter().enumerate() {
                    match v.as_deref() {
                        Some([x, y, z]) => cols[k] = DVec3::new(*x, *y, *z),
                        Some(_) => {
                            return Err(line_err(
                                n,
                                "space directions: each vector needs 3 components".into(),
                            ))
                        }
                        None => {
                            return Err(line_err(
                                n,
                                format!("space directions: axis {k} is not spatial (none)"),
                            ))
                        }
                    }
                }
                Some(cols)
            }
        };
        let origin = match get(&["space origin"]) {
            None => None,
            Some((n, s)) => match nrrd_vector(s).as_deref() {
                Some([x, y, z]) => Some(DVec3::new(*x, *y, *z)),
                _ => return Err(line_err(n, format!("space origin {s:?}: expected (x,y,z)"))),
            },
        };
        let per_axis = |names: &[&str]| -> Result<Option<[f64; 3]>, FieldError> {
            match get(names) {
                None => Ok(None),
                Some((n, s)) => {
                    let v: Option<Vec<f64>> =
                        s.split_ascii_whitespace().map(|w| w.parse::<f64>().ok()).collect();
                    match v.as_deref() {
                        Some([a, b, c]) => Ok(Some([*a, *b, *c])),
                        _ => Err(line_err(n, format!("{} {s:?}: expected 3 numbers", names[0]))),
                    }
                }
            }
        };
        // `nan` means "unknown"; anything else must be a usable spacing (negative: the axis
        // runs backwards) or a finite minimum.
        let spacings = per_axis(&["spacings"])?;
        if let (Some(s), Some((n, text))) = (spacings, get(&["spacings"])) {
            if let Some(k) = (0..3).find(|&k| !(s[k].is_nan() || super::usable_step(s[k].abs()))) {
                return Err(line_err(
                    n,
                    format!(
                        "spacings {text:?}: axis {k} spacing {}; {}",
                        super::num(s[k]),
                        super::STEP_RULE
                    ),
                ));
            }
        }
        let axis_mins = per_axis(&["axis mins", "axismins"])?;
        if let (Some(m), Some((n, text))) = (axis_mins, get(&["axis mins", "axismins"])) {
            if let Some(k) = (0..3).find(|&k| m[k].is_infinite()) {
                return Err(line_err(
                    n,
                    format!(
                        "axis mins {text:?}: axis {k} minimum {} is not finite",
                        super::num(m[k])
                    ),
                ));
            }
        }
        Ok(Header {
            sizes,
            ty,
            type_name: t.to_string(),
            encoding,
            endian,
            data_file,
            line_skip: line_skip as u64,
            byte_skip,
            directions,
            origin,
            spacings,
            axis_mins,
        })
    }
}

/// The dimension of a named NRRD space (3 for the 3-D ones).
fn space_dimension(s: &str) -> Option<usize> {
    match s.to_ascii_lowercase().as_str() {
        "right-anterior-superior"
        | "ras"
        | "left-anterior-superior"
        | "las"
        | "left-posterior-superior"
        | "lps"
        | "scanner-xyz"
        | "3d-right-handed"
        | "3d-left-handed" => Some(3),
        _ => None,
    }
}

/// NRRD's type names (Teem accepts each C spelling).
fn sample_type(t: &str) -> Option<SampleType> {
    Some(match t {
        "signed char" | "int8" | "int8_t" => SampleType::I8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => SampleType::U8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            SampleType::I16
        }
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => {
            SampleType::U16
        }
        "int" | "signed int" | "int32" | "int32_t" => SampleType::I32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => SampleType::U32,
        "longlong"
        | "long long"
        | "long long int"
        | "signed long long"
        | "signed long long int"
        | "int64"
        | "int64_t" => SampleType::I64,
        "ulonglong" | "unsigned long long" | "unsigned long long int" | "uint64" | "uint64_t" => {
            SampleType::U64
        }
        "float" => SampleType::F32,
        "double" => SampleType::F64,
        _ => return None,
    })
}

/// The offset after `lines` newlines, counted from `from` in `path`.
fn skip_lines(err: &Located, path: &Path, from: u64, lines: u64) -> Result<u64, FieldError> {
    if lines == 0 {
        return Ok(from);
    }
    let at = err.at(path);
    let mut f = at.access.open(path).map_err(|e| at.io(&e))?;
    std::io::Seek::seek(&mut f, std::io::SeekFrom::Start(from)).map_err(|e| at.io(&e))?;
    let mut r = BufReader::new(f);
    let mut pos = from;
    let mut buf = Vec::new();
    for n in 0..lines {
        buf.clear();
        let got = r.read_until(b'\n', &mut buf).map_err(|e| at.io(&e))?;
        if got == 0 {
            return Err(at.bad(format!("line skip {lines}: the file ends after {n} lines")));
        }
        pos += got as u64;
    }
    Ok(pos)
}
