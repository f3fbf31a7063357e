//! Legacy VTK files (`.vtk`, <https://docs.vtk.org/en/latest/design_documents/VTKFileFormats.html>)
//! holding `DATASET STRUCTURED_POINTS`: `DIMENSIONS`, `SPACING` (or `ASPECT_RATIO`), `ORIGIN`,
//! then `POINT_DATA n` and the first one-component `SCALARS name type` array, ASCII or binary
//! (big-endian, as the format specifies). Other datasets, cell data only, and multi-component
//! arrays are refused.

use std::io::Read;

use glam::DVec3;

use super::payload;
use super::{Located, ReadOptions, Volume};
use crate::field::samples::{Endian, SampleType};
use crate::field::FieldError;

pub fn read(err: &Located, opts: &ReadOptions) -> Result<Volume, FieldError> {
    let file = err.access.open(err.path).map_err(|e| err.io(&e))?;
    let len = file.metadata().map_err(|e| err.io(&e))?.len();
    let mut r = Cursor { bytes: Vec::new(), at: 0, line: 0 };
    // The whole file: the header is text lines, and its size is bounded by the cap below
    // before any sample is decoded (a file far larger than its grid is refused unread).
    let most = opts.limits.max_bytes.saturating_mul(16).saturating_add(1 << 20);
    if len > most {
        return Err(err.over_limit(format!(
            "the file has {len} bytes, more than any grid under the memory cap needs"
        )));
    }
    // The declared DIMENSIONS against the cap before the whole file is read (checked again
    // after the header is parsed).
    let head = super::peek(err)?;
    let dims_line = head
        .split(|&b| b == b'\n')
        .take_while(|l| !l.starts_with(b"POINT_DATA") && !l.starts_with(b"CELL_DATA"))
        .find(|l| l.len() > 10 && l[..10].eq_ignore_ascii_case(b"DIMENSIONS"));
    let declared = dims_line
        .and_then(|l| std::str::from_utf8(&l[10..]).ok())
        .and_then(super::text::sizes)
        .filter(|d| d.len() == 3);
    if let Some(d) = declared {
        err.limits_check(&opts.limits, [d[0], d[1], d[2]])?;
    }
    file.take(most).read_to_end(&mut r.bytes).map_err(|e| err.io(&e))?;

    let magic = r.line(err)?;
    if !magic.starts_with("# vtk DataFile") {
        return Err(err.bad("it does not start with \"# vtk DataFile Version\""));
    }
    let _title = r.line(err)?;
    let binary = match r.line(err)?.trim().to_ascii_uppercase().as_str() {
        "ASCII" => false,
        "BINARY" => true,
        other => return Err(r.bad(err, format!("expected ASCII or BINARY, got {other:?}"))),
    };
    let dataset = r.line(err)?;
    let words: Vec<&str> = dataset.split_ascii_whitespace().collect();
    match words.as_slice() {
        [d, kind] if d.eq_ignore_ascii_case("DATASET") => {
            if !kind.eq_ignore_ascii_case("STRUCTURED_POINTS") {
                return Err(r.bad(err, format!("DATASET {kind}: isoview reads STRUCTURED_POINTS")));
            }
        }
        _ => return Err(r.bad(err, format!("expected DATASET STRUCTURED_POINTS, got {dataset:?}"))),
    }
    let (mut dims3, mut spacing, mut origin) = (None, DVec3::ONE, DVec3::ZERO);
    // Which attribute section we are in: cell data is skipped, the first one-component point
    // array (SCALARS or a FIELD array) is the field.
    let mut section: Option<(bool, u64)> = None;
    let (count, name, ty) = loop {
        let line = r.line(err)?;
        let w: Vec<&str> = line.split_ascii_whitespace().collect();
        let Some(key) = w.first().map(|k| k.to_ascii_uppercase()) else { continue };
        let three = |w: &[&str]| -> Option<DVec3> { super::text::three(&w[1..].join(" ")) };
        let count = |w: &[&str], r: &Cursor| -> Result<u64, FieldError> {
            w.get(1)
                .and_then(|n| n.parse().ok())
                .ok_or_else(|| r.bad(err, format!("{}: expected a count", w[0])))
        };
        let ty_of = |t: &str, r: &Cursor| {
            sample_type(t).ok_or_else(|| r.bad(err, format!("type {t:?} is not one isoview reads")))
        };
        let in_section = |r: &Cursor| {
            section.ok_or_else(|| r.bad(err, format!("{key} before POINT_DATA or CELL_DATA")))
        };
        match key.as_str() {
            "DIMENSIONS" => {
                let d = super::text::sizes(&w[1..].join(" ")).filter(|d| d.len() == 3);
                dims3 =
                    Some(d.ok_or_else(|| {
                        r.bad(err, "DIMENSIONS: expected 3 whole numbers".into())
                    })?);
            }
            "SPACING" | "ASPECT_RATIO" => {
                spacing =
                    three(&w).ok_or_else(|| r.bad(err, "SPACING: expected 3 numbers".into()))?
            }
            "ORIGIN" => {
                origin = three(&w).ok_or_else(|| r.bad(err, "ORIGIN: expected 3 numbers".into()))?
            }
            "CELL_DATA" => section = Some((false, count(&w, &r)?)),
            "POINT_DATA" => section = Some((true, count(&w, &r)?)),
            "SCALARS" => {
                let (point, n) = in_section(&r)?;
                if w.len() < 3 {
                    return Err(r.bad(err, format!("expected SCALARS name type, got {line:?}")));
                }
                let comps: u64 = w
                    .get(3)
                    .map_or(Some(1), |c| c.parse().ok())
                    .ok_or_else(|| r.bad(err, "SCALARS: bad component count".into()))?;
                let ty = ty_of(w[2], &r)?;
                let lut_at = (r.at, r.line);
                let next = r.line(err)?;
                if !next.trim_start().to_ascii_uppercase().starts_with("LOOKUP_TABLE") {
                    (r.at, r.line) = lut_at; // LOOKUP_TABLE is optional
                }
                if point && comps == 1 {
                    break (n, w[1].to_string(), ty);
                }
                r.skip(err, n.saturating_mul(comps), ty, binary)?;
            }
            "FIELD" => {
                let (point, _) = in_section(&r)?;
                let arrays: u64 = w.get(2).and_then(|n| n.parse().ok()).ok_or_else(|| {
                    r.bad(err, "FIELD: expected a name and an array count".into())
                })?;
                let mut found = None;
                for _ in 0..arrays {
                    let a = r.line(err)?;
                    let f: Vec<&str> = a.split_ascii_whitespace().collect();
                    let [name, comps, tuples, t] = f.as_slice() else {
                        return Err(r.bad(
                            err,
                            format!(
                                "expected a FIELD array \"name components tuples type\", got {a:?}"
                            ),
                        ));
                    };
                    let (comps, tuples): (u64, u64) = match (comps.parse(), tuples.parse()) {
                        (Ok(c), Ok(t)) => (c, t),
                        _ => return Err(r.bad(err, format!("FIELD array {name}: bad counts"))),
                    };
                    let ty = ty_of(t, &r)?;
                    if point && comps == 1 {
                        found = Some((tuples, name.to_string(), ty));
                        break;
                    }
                    r.skip(err, comps.saturating_mul(tuples), ty, binary)?;
                }
                if let Some(f) = found {
                    break f;
                }
            }
            "VECTORS" | "NORMALS" | "TENSORS" => {
                let (_, n) = in_section(&r)?;
                let ty = ty_of(w.get(2).copied().unwrap_or(""), &r)?;
                let per = if key == "TENSORS" { 9 } else { 3 };
                r.skip(err, n.saturating_mul(per), ty, binary)?;
            }
            _ if section.is_some() => {
                return Err(r.bad(
                    err,
                    format!("{key}: an attribute isoview cannot skip before the point scalars"),
                ))
            }
            _ => {} // other geometry keywords of other writers: not needed
        }
    };
    let Some(d) = dims3 else { return Err(err.bad("no DIMENSIONS before POINT_DATA")) };
    let dims = payload::grid(err, [d[0], d[1], d[2]], &opts.limits)?;
    let points: u64 = dims.iter().map(|&d| d as u64).product();
    if count != points {
        return Err(err.bad(format!(
            "POINT_DATA {count} does not match DIMENSIONS {}x{}x{}",
            dims[0], dims[1], dims[2]
        )));
    }
    let rest = &r.bytes[r.at..];
    let values = if binary {
        let bytes = payload::byte_count(dims, ty) as usize;
        let data = rest[..bytes.min(rest.len())].to_vec();
        payload::exact(err, data, ty, Endian::Big, dims)?
    } else {
        let text = std::str::from_utf8(rest).map_err(|_| err.bad("the ASCII data is not text"))?;
        // Only the array's own words: the `count` after the header, and after them at most a
        // keyword (another array); every one of them must then be a number, so a bad word
        // (`abc`) is named where it stands rather than read as the end of the data.
        payload::ascii(err, &text[..ascii_end(text, count)], dims)?
    };
    if !spacing.to_array().into_iter().all(super::usable_step) {
        return Err(err.bad(format!(
            "SPACING {} {} {}: {}",
            super::num(spacing.x),
            super::num(spacing.y),
            super::num(spacing.z),
            super::STEP_RULE
        )));
    }
    let origin = err.finite("ORIGIN", origin)?;
    Ok(Volume {
        dims,
        values,
        origin,
        spacing,
        axes: [DVec3::X, DVec3::Y, DVec3::Z],
        dtype: format!("{} ({name})", type_name(ty)),
        data_file: None,
        sparse: None,
    })
}

/// Where the ASCII array at the start of `text` ends: after its `count` words, unless the word
/// after them is a number too (more values than declared: kept, for the reader to refuse).
fn ascii_end(text: &str, count: u64) -> usize {
    let mut words = text
        .char_indices()
        .filter(|&(i, c)| {
            !c.is_ascii_whitespace() && (i == 0 || text.as_bytes()[i - 1].is_ascii_whitespace())
        })
        .map(|(i, _)| i)
        .skip(usize::try_from(count).unwrap_or(usize::MAX));
    match words.next() {
        Some(at) if !text[at..].starts_with(|c: char| c.is_ascii_alphabetic()) => text.len(),
        Some(at) => at,
        None => text.len(),
    }
}

/// The file's bytes and a line cursor over its text header.
struct Cursor {
    bytes: Vec<u8>,
    at: usize,
    line: usize,
}

impl Cursor {
    fn line(&mut self, err: &Located) -> Result<String, FieldError> {
        if self.at >= self.bytes.len() {
            return Err(err.bad(format!("the header ends after line {}", self.line)));
        }
        let rest = &self.bytes[self.at..];
        let end = rest.iter().position(|&b| b == b'\n').map_or(rest.len(), |p| p + 1);
        self.at += end;
        self.line += 1;
        std::str::from_utf8(&rest[..end])
            .map(|s| s.trim_end().to_string())
            .map_err(|_| err.bad(format!("line {}: the header is not text", self.line)))
    }

    /// Skips `n` values of `ty` (binary: their bytes and the newline after them; ASCII: `n`
    /// words).
    fn skip(
        &mut self,
        err: &Located,
        n: u64,
        ty: SampleType,
        binary: bool,
    ) -> Result<(), FieldError> {
        let left = (self.bytes.len() - self.at) as u64;
        if binary {
            let bytes = n.saturating_mul(ty.size() as u64);
            if bytes > left {
                return Err(self.bad(err, format!("truncated data: an array of {n} values needs {bytes} bytes, {left} are left")));
            }
            self.at += bytes as usize;
            if self.bytes.get(self.at) == Some(&b'\n') {
                self.at += 1;
            }
        } else {
            for k in 0..n {
                while self.bytes.get(self.at).is_some_and(|b| b.is_ascii_whitespace()) {
                    self.at += 1;
                }
                if self.at >= self.bytes.len() {
                    return Err(self.bad(
                        err,
                        format!("truncated data: an array ends after {k} of {n} values"),
                    ));
                }
                while self.bytes.get(self.at).is_some_and(|b| !b.is_ascii_whitespace()) {
                    self.at += 1;
                }
            }
            if self.bytes.get(self.at) == Some(&b'\n') {
                self.at += 1;
            }
        }
        Ok(())
    }

    fn bad(&self, err: &Located, what: String) -> FieldError {
        err.bad(format!("line {}: {what}", self.line))
    }
}

fn sample_type(t: &str) -> Option<SampleType> {
    Some(match t.to_ascii_lowercase().as_str() {
        "unsigned_char" => SampleType::U8,
        "char" | "signed_char" => SampleType::I8,
        "unsigned_short" => SampleType::U16,
        "short" => SampleType::I16,
        "unsigned_int" => SampleType::U32,
        "int" => SampleType::I32,
        "unsigned_long" | "vtktypeuint64" => SampleType::U64,
        "long" | "vtktypeint64" => SampleType::I64,
        "float" => SampleType::F32,
        "double" => SampleType::F64,
        _ => return None,
    })
}

fn type_name(ty: SampleType) -> &'static str {
    match ty {
        SampleType::U8 => "unsigned_char",
        SampleType::I8 => "char",
        SampleType::U16 => "unsigned_short",
        SampleType::I16 => "short",
        SampleType::U32 => "unsigned_int",
        SampleType::I32 => "int",
        SampleType::U64 => "unsigned_long",
        SampleType::I64 => "long",
        SampleType::F32 => "float",
        _ => "double",
    }
}
