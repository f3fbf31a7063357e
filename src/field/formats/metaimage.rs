//! MetaImage (ITK's `.mha` with the data after the header, `.mhd` naming a data file;
//! <https://itk.org/Wiki/ITK/MetaIO/Documentation>). Header lines `Key = Value`, ending with
//! `ElementDataFile` (`LOCAL`: the data follows that line). Read: `NDims = 3`, `DimSize`,
//! `ElementType` (MET_CHAR .. MET_DOUBLE), `ElementNumberOfChannels = 1`, `ElementSpacing`
//! (or `ElementSize`), `Offset` (or `Position`, `Origin`), `TransformMatrix` (or `Rotation`,
//! `Orientation`: 9 numbers, the i-th three the direction of axis i, as ITK reads them),
//! `CompressedData` (zlib), `BinaryDataByteOrderMSB` / `ElementByteOrderMSB`, `HeaderSize`
//! (-1: the data is the file's last bytes). Coordinates stay in the file's space (ITK: LPS).

use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use glam::DVec3;

use super::payload::{self, Encoding, Start};
use super::text::{self, MAX_HEADER_BYTES};
use super::{Located, ReadOptions, Volume};
use crate::field::samples::{Endian, SampleType};
use crate::field::FieldError;

pub fn read(err: &Located, opts: &ReadOptions) -> Result<Volume, FieldError> {
    let file = err.access.open(err.path).map_err(|e| err.io(&e))?;
    let mut r = BufReader::new(file).take(MAX_HEADER_BYTES);
    let mut fields: Vec<(usize, String, String)> = Vec::new();
    let mut offset = 0u64;
    let mut line = Vec::new();
    let mut n = 0;
    loop {
        line.clear();
        let got = r.read_until(b'\n', &mut line).map_err(|e| err.io(&e))?;
        if got == 0 {
            return Err(err.bad("the header ends without an ElementDataFile line"));
        }
        n += 1;
        offset += got as u64;
        let text = std::str::from_utf8(&line)
            .map_err(|_| err.bad(format!("line {n}: the header is not text")))?
            .trim();
        if text.is_empty() {
            continue;
        }
        let Some((key, value)) = text.split_once('=') else {
            return Err(err.bad(format!("line {n}: expected \"Key = Value\", got {text:?}")));
        };
        let key = key.trim().to_string();
        let done = key == "ElementDataFile";
        fields.push((n, key, value.trim().to_string()));
        if done {
            break;
        }
    }
    let get = |names: &[&str]| {
        fields
            .iter()
            .find(|(_, k, _)| names.contains(&k.as_str()))
            .map(|(n, _, v)| (*n, v.as_str()))
    };
    let line_err = |n: usize, what: String| err.bad(format!("line {n}: {what}"));
    let yes = |names: &[&str]| -> Result<bool, FieldError> {
        match get(names) {
            None => Ok(false),
            Some((n, v)) => match v.to_ascii_lowercase().as_str() {
                "true" | "1" => Ok(true),
                "false" | "0" => Ok(false),
                _ => Err(line_err(n, format!("{} = {v:?}: expected True or False", names[0]))),
            },
        }
    };
    let vec3 = |names: &[&str]| -> Result<Option<DVec3>, FieldError> {
        match get(names) {
            None => Ok(None),
            Some((n, v)) => text::three(v)
                .map(Some)
                .ok_or_else(|| line_err(n, format!("{} = {v:?}: expected 3 numbers", names[0]))),
        }
    };

    if let Some((n, d)) = get(&["NDims"]) {
        if d != "3" {
            return Err(line_err(n, format!("NDims = {d}: isoview reads 3-D volumes")));
        }
    }
    let (n, ds) = get(&["DimSize"]).ok_or_else(|| err.bad("the header has no DimSize"))?;
    let dims = match text::sizes(ds).as_deref() {
        Some([x, y, z]) => payload::grid(err, [*x, *y, *z], &opts.limits)?,
        _ => return Err(line_err(n, format!("DimSize = {ds:?}: expected 3 whole numbers"))),
    };
    if let Some((n, c)) = get(&["ElementNumberOfChannels"]) {
        if c != "1" {
            return Err(line_err(
                n,
                format!("ElementNumberOfChannels = {c}: isoview reads one scalar per voxel"),
            ));
        }
    }
    let (n, et) = get(&["ElementType"]).ok_or_else(|| err.bad("the header has no ElementType"))?;
    let ty = match et {
        "MET_CHAR" => SampleType::I8,
        "MET_UCHAR" => SampleType::U8,
        "MET_SHORT" => SampleType::I16,
        "MET_USHORT" => SampleType::U16,
        "MET_INT" | "MET_LONG" => SampleType::I32,
        "MET_UINT" | "MET_ULONG" => SampleType::U32,
        "MET_LONG_LONG" => SampleType::I64,
        "MET_ULONG_LONG" => SampleType::U64,
        "MET_FLOAT" => SampleType::F32,
        "MET_DOUBLE" => SampleType::F64,
        _ => {
            return Err(line_err(
                n,
                format!("ElementType = {et} is not a scalar type isoview reads"),
            ))
        }
    };
    let endian = if yes(&["BinaryDataByteOrderMSB", "ElementByteOrderMSB"])? {
        Endian::Big
    } else {
        Endian::Little
    };
    let compressed = yes(&["CompressedData"])?;
    let (header_line, header_size) = match get(&["HeaderSize"]) {
        None => (0, 0),
        Some((n, v)) => (
            n,
            v.parse::<i64>()
                .map_err(|_| line_err(n, format!("HeaderSize = {v:?} is not a whole number")))?,
        ),
    };
    let (n, data_file) =
        get(&["ElementDataFile"]).ok_or_else(|| err.bad("the header has no ElementDataFile"))?;
    let (path, base) = if data_file == "LOCAL" {
        (err.path.to_path_buf(), offset)
    } else if data_file.starts_with("LIST") || data_file.split_ascii_whitespace().count() > 1 {
        return Err(line_err(
            n,
            format!("ElementDataFile = {data_file}: only LOCAL or a single file is supported"),
        ));
    } else {
        let named = err.path.parent().unwrap_or(Path::new("")).join(data_file);
        (err.detached("ElementDataFile", &named, &opts.access)?, 0)
    };
    let start = match header_size {
        -1 if !compressed => Start::FromEnd,
        h if h < 0 => return Err(err.bad(format!("HeaderSize = {h} is not allowed here"))),
        h => {
            // Bytes skipped past the data file's end leave nothing to read; said here, as a
            // seek that far fails with the system's "Invalid argument" naming no key.
            // A file that cannot be opened is reported below, by the read that names it.
            let len = err.access.open(&path).and_then(|f| f.metadata()).map(|m| m.len());
            if let Some(len) = len.ok().filter(|&len| base.saturating_add(h as u64) > len) {
                let file = if path == err.path { "the file" } else { "its data file" };
                let what = format!(
                    "HeaderSize = {h} puts the data at byte {} of {file}, past its end ({len} \
                     bytes)",
                    base as u128 + h as u128
                );
                return Err(line_err(header_line, what));
            }
            Start::At(h as u64)
        }
    };
    let values = if compressed {
        let at = err.at(&path);
        let mut f = at.access.open(&path).map_err(|e| at.io(&e))?;
        let Start::At(h) = start else { unreachable!("FromEnd is refused when compressed") };
        std::io::Seek::seek(&mut f, std::io::SeekFrom::Start(base + h)).map_err(|e| at.io(&e))?;
        payload::compressed(&at, BufReader::new(f), Encoding::Zlib, 0, ty, endian, dims)?
    } else {
        let start = match start {
            Start::At(h) => Start::At(base + h),
            s => s,
        };
        payload::from_file(err, &path, Encoding::Raw, start, ty, endian, dims)?
    };

    let mut v = Volume {
        dims,
        values,
        origin: err
            .finite("Offset", vec3(&["Offset", "Position", "Origin"])?.unwrap_or(DVec3::ZERO))?,
        spacing: DVec3::ONE,
        axes: [DVec3::X, DVec3::Y, DVec3::Z],
        dtype: et.to_string(),
        data_file: (path != err.path).then(|| path.clone()),
        sparse: None,
    };
    let spacing = vec3(&["ElementSpacing", "ElementSize"])?.unwrap_or(DVec3::ONE);
    let axes = match get(&["TransformMatrix", "Rotation", "Orientation"]) {
        None => [DVec3::X, DVec3::Y, DVec3::Z],
        Some((n, m)) => match text::numbers(m).as_deref() {
            Some(&[a, b, c, d, e, f, g, h, i]) => {
                [DVec3::new(a, b, c), DVec3::new(d, e, f), DVec3::new(g, h, i)]
            }
            _ => return Err(line_err(n, format!("TransformMatrix = {m:?}: expected 9 numbers"))),
        },
    };
    v.set_axes([0, 1, 2].map(|k| axes[k] * spacing[k]), "ElementSpacing and TransformMatrix", err)?;
    Ok(v)
}
