//! VTK XML image data (`.vti`, <https://docs.vtk.org/en/latest/design_documents/VTKFileFormats.html>),
//! read by hand with roxmltree: `vtkio` fails on raw appended data, and its defaults pull in C.
//!
//! One `Piece` covering `WholeExtent`; `Origin`, `Spacing`, `Direction` (9 numbers, row-major:
//! column k is the direction of axis k); the point data array named by `PointData Scalars`, else
//! the first one-component array. Arrays may be `ascii`, `binary` (base64 inline) or `appended`
//! (`raw` or `base64`), uncompressed or `vtkZLibDataCompressor` blocks, `header_type` UInt32 or
//! UInt64, either `byte_order`. The grid starts at `Origin + Direction * (extent start * Spacing)`.

use glam::{DMat3, DVec3};

use super::payload;
use super::{base64, Located, ReadOptions, Volume};
use crate::field::samples::{Endian, SampleType};
use crate::field::FieldError;

pub fn read(err: &Located, opts: &ReadOptions) -> Result<Volume, FieldError> {
    let len = std::fs::metadata(err.path).map_err(|e| err.io(&e))?.len();
    // Compressed data is smaller than the grid, base64 a third larger: 16x the cap is no grid.
    if len > opts.limits.max_bytes.saturating_mul(16).saturating_add(1 << 20) {
        return Err(err.over_limit(format!(
            "the file has {len} bytes, more than any grid under the memory cap needs"
        )));
    }
    // The declared extent against the cap before the whole file is read (it is checked again,
    // with the rest of the XML, below).
    if let Some(dims) = peek_extent(&super::peek(err)?) {
        err.limits_check(&opts.limits, dims)?;
    }
    let mut bytes = Vec::new();
    err.access
        .open(err.path)
        .and_then(|mut f| std::io::Read::read_to_end(&mut f, &mut bytes))
        .map_err(|e| err.io(&e))?;
    // Raw appended data is binary: parse the XML before it, and find the data after its `_`.
    let (xml, appended) = match find(&bytes, b"<AppendedData") {
        None => (bytes.as_slice(), None),
        Some(at) => {
            let tag_end = at
                + find(&bytes[at..], b">")
                    .ok_or_else(|| err.bad("the AppendedData tag is not closed"))?;
            let tag = String::from_utf8_lossy(&bytes[at..tag_end]).to_string();
            let under = find(&bytes[tag_end..], b"_")
                .ok_or_else(|| err.bad("AppendedData has no '_' before its data"))?;
            let raw = !tag.contains("encoding=\"base64\"");
            (&bytes[..at], Some((raw, &bytes[tag_end + under + 1..])))
        }
    };
    let mut text = std::str::from_utf8(xml)
        .map_err(|e| err.bad(format!("the XML is not UTF-8 (byte {})", e.valid_up_to())))?
        .to_string();
    if appended.is_some() {
        text.push_str("</VTKFile>");
    }
    // roxmltree parses nested elements by recursion, and checks each attribute against the
    // element's others (quadratic): refuse deep nesting and crowded elements before it starts.
    if let Some(over) = over_limits(&text) {
        let (line, column) = (over.line, over.column);
        return Err(err.over_limit(match over.attributes {
            None => format!(
                "line {line}, column {column}: the XML nests deeper than {MAX_XML_DEPTH} elements"
            ),
            Some(n) => format!(
                "line {line}, column {column}: an element has {n} attributes, over the \
                 {MAX_XML_ATTRIBUTES} isoview reads"
            ),
        }));
    }
    let doc =
        roxmltree::Document::parse(&text).map_err(|e| err.bad(format!("malformed XML: {e}")))?;
    let root = doc.root_element();
    if root.tag_name().name() != "VTKFile" || root.attribute("type") != Some("ImageData") {
        return Err(err.bad("not a VTKFile of type ImageData"));
    }
    let endian = match root.attribute("byte_order") {
        Some("BigEndian") => Endian::Big,
        _ => Endian::Little,
    };
    let word = match root.attribute("header_type") {
        None | Some("UInt32") => 4,
        Some("UInt64") => 8,
        Some(t) => return Err(err.bad(format!("header_type {t} (UInt32 or UInt64)"))),
    };
    let zlib = match root.attribute("compressor") {
        None | Some("") => false,
        Some("vtkZLibDataCompressor") => true,
        Some(c) => {
            return Err(
                err.bad(format!("compressor {c} is not supported (vtkZLibDataCompressor or none)"))
            )
        }
    };
    let image = child(root, "ImageData").ok_or_else(|| err.bad("no ImageData element"))?;
    let numbers =
        |node: roxmltree::Node, name: &str, n: usize| -> Result<Option<Vec<f64>>, FieldError> {
            match node.attribute(name) {
                None => Ok(None),
                Some(s) => super::text::numbers(s)
                    .filter(|v| v.len() == n)
                    .map(Some)
                    .ok_or_else(|| err.bad(format!("{name}=\"{s}\": expected {n} numbers"))),
            }
        };
    let whole =
        numbers(image, "WholeExtent", 6)?.ok_or_else(|| err.bad("ImageData has no WholeExtent"))?;
    let pieces: Vec<_> = image.children().filter(|n| n.has_tag_name("Piece")).collect();
    let [piece] = pieces.as_slice() else {
        return Err(
            err.bad(format!("{} pieces: isoview reads image data in one piece", pieces.len()))
        );
    };
    if numbers(*piece, "Extent", 6)?.is_some_and(|e| e != whole) {
        return Err(err.bad("the piece's Extent is not the WholeExtent"));
    }
    // VTK's extents are C ints: a number outside them, or not whole, is no extent (and 1e300
    // cast to an integer and subtracted overflowed, issue 29).
    let int = (i32::MIN as f64)..=(i32::MAX as f64);
    if let Some(&e) = whole.iter().find(|e| e.fract() != 0.0 || !int.contains(e)) {
        return Err(err.bad(format!(
            "WholeExtent: {} is not a whole number from {} to {} (VTK extents are 32-bit ints)",
            super::num(e),
            i32::MIN,
            i32::MAX
        )));
    }
    let ext: Vec<i64> = whole.iter().map(|&e| e as i64).collect();
    // Within ±2^31 each, so the difference and the count fit an i64.
    let declared = [0, 1, 2].map(|k| (ext[2 * k + 1] - ext[2 * k] + 1).max(0) as u64);
    let dims = payload::grid(err, declared, &opts.limits)?;

    let point_data =
        child(*piece, "PointData").ok_or_else(|| err.bad("the piece has no PointData"))?;
    let arrays: Vec<_> = point_data.children().filter(|n| n.has_tag_name("DataArray")).collect();
    let one = |a: &roxmltree::Node| a.attribute("NumberOfComponents").map_or(true, |c| c == "1");
    let array = match point_data.attribute("Scalars") {
        Some(name) => arrays.iter().find(|a| a.attribute("Name") == Some(name)),
        None => arrays.iter().find(|a| one(a)),
    }
    .ok_or_else(|| err.bad("no one-component point data array"))?;
    if !one(array) {
        return Err(err.bad("the Scalars array has several components; isoview reads one"));
    }
    let ty_name = array.attribute("type").unwrap_or("");
    let ty = sample_type(ty_name)
        .ok_or_else(|| err.bad(format!("DataArray type {ty_name:?} is not one isoview reads")))?;
    let block = Block { err, word, endian, zlib, ty, dims };
    let values = match array.attribute("format") {
        Some("ascii") => payload::ascii(err, array.text().unwrap_or(""), dims)?,
        Some("binary") => block.base64(array.text().unwrap_or("").as_bytes())?,
        Some("appended") => {
            let Some((raw, data)) = appended else {
                return Err(err.bad("an appended array but no AppendedData"));
            };
            let offset: usize = array
                .attribute("offset")
                .and_then(|o| o.parse().ok())
                .ok_or_else(|| err.bad("an appended array without a valid offset"))?;
            let data = data
                .get(offset..)
                .ok_or_else(|| err.bad(format!("offset {offset} is past the appended data")))?;
            if raw {
                block.raw(data)?
            } else {
                block.base64(data)?
            }
        }
        f => return Err(err.bad(format!("DataArray format {f:?} (ascii, binary or appended)"))),
    };

    let origin = numbers(image, "Origin", 3)?.map_or(DVec3::ZERO, |v| DVec3::from_slice(&v));
    let spacing = numbers(image, "Spacing", 3)?.map_or(DVec3::ONE, |v| DVec3::from_slice(&v));
    // Checked before the Direction multiplies it (0 * inf would hide which number is wrong);
    // a negative spacing runs its axis backwards.
    if let Some(k) = (0..3).find(|&k| !super::usable_step(spacing[k].abs())) {
        return Err(err.bad(format!(
            "Spacing {}: axis {} spacing {}; {}",
            super::point(spacing),
            "xyz".as_bytes()[k] as char,
            super::num(spacing[k]),
            super::STEP_RULE
        )));
    }
    let d = numbers(image, "Direction", 9)?
        .map_or(DMat3::IDENTITY, |m| DMat3::from_cols_slice(&m).transpose());
    let start = DVec3::new(ext[0] as f64, ext[2] as f64, ext[4] as f64) * spacing;
    let mut v = Volume {
        dims,
        values,
        origin: err.finite("Origin", origin)? + d * start,
        spacing: DVec3::ONE,
        axes: [DVec3::X, DVec3::Y, DVec3::Z],
        dtype: format!("{ty_name} ({})", array.attribute("Name").unwrap_or("unnamed")),
        data_file: None,
        sparse: None,
    };
    let cols = [d.x_axis * spacing.x, d.y_axis * spacing.y, d.z_axis * spacing.z];
    v.set_axes(cols, "Spacing and Direction", err)?;
    Ok(v)
}

/// How an array's binary block is laid out.
struct Block<'a> {
    err: &'a Located<'a>,
    /// Bytes of a header integer.
    word: usize,
    endian: Endian,
    zlib: bool,
    ty: SampleType,
    dims: [usize; 3],
}

impl Block<'_> {
    fn uint(&self, b: &[u8]) -> u64 {
        let mut a = [0u8; 8];
        match self.endian {
            Endian::Little => a[..self.word].copy_from_slice(b),
            Endian::Big => a[8 - self.word..].copy_from_slice(b),
        }
        match self.endian {
            Endian::Little => u64::from_le_bytes(a),
            Endian::Big => u64::from_be_bytes(a),
        }
    }

    /// Header integers needed before the data: 1 (a byte count), or 3 + blocks when compressed.
    fn header_len(&self, first: &[u8]) -> Result<usize, FieldError> {
        if !self.zlib {
            return Ok(self.word);
        }
        let blocks = self.uint(&first[..self.word]);
        let most = payload::byte_count(self.dims, self.ty) + 1;
        if blocks > most {
            return Err(self.err.bad(format!("{blocks} compressed blocks for {most} bytes")));
        }
        Ok((3 + blocks as usize) * self.word)
    }

    /// A block stored as bytes (raw appended data).
    fn raw(&self, data: &[u8]) -> Result<Vec<f32>, FieldError> {
        let short = || self.err.bad("the appended data ends inside an array's header");
        let first = data.get(..3 * self.word).or(data.get(..self.word)).ok_or_else(short)?;
        let h = self.header_len(first)?;
        let header = data.get(..h).ok_or_else(short)?;
        self.decode(header, &data[h..])
    }

    /// A block stored as base64 text: the header and the data encoded separately (VTK's way) or
    /// as one string.
    fn base64(&self, text: &[u8]) -> Result<Vec<f32>, FieldError> {
        let text: Vec<u8> = text.iter().copied().filter(|c| !c.is_ascii_whitespace()).collect();
        let bad = || self.err.bad("the base64 data is malformed");
        let chars = |bytes: usize| bytes.div_ceil(3) * 4;
        let first =
            base64::decode(text.get(..chars(3 * self.word).min(text.len())).ok_or_else(bad)?)
                .ok_or_else(bad)?;
        let h = self.header_len(first.get(..self.word).ok_or_else(bad)?)?;
        let hc = chars(h);
        let head = base64::decode(text.get(..hc).ok_or_else(bad)?).ok_or_else(bad)?;
        // The data ends at the end of its base64 string (the next array may follow in appended data).
        let rest = &text[hc..];
        let end = rest
            .iter()
            .position(|&c| !(c.is_ascii_alphanumeric() || c == b'+' || c == b'/' || c == b'='))
            .unwrap_or(rest.len());
        if h % 3 == 0 || text[hc - 1] == b'=' {
            let data = base64::decode(&rest[..end]).ok_or_else(bad)?;
            self.decode(&head[..h], &data)
        } else {
            let all = base64::decode(&text[..hc + end]).ok_or_else(bad)?;
            self.decode(&all[..h], &all[h..])
        }
    }

    /// The samples from a block's header and the bytes after it.
    fn decode(&self, header: &[u8], data: &[u8]) -> Result<Vec<f32>, FieldError> {
        let expected = payload::byte_count(self.dims, self.ty);
        let w = self.word;
        if !self.zlib {
            let n = self.uint(&header[..w]);
            if n != expected {
                return Err(self
                    .err
                    .bad(format!("the array holds {n} bytes, the extent needs {expected}")));
            }
            let bytes = data.get(..n as usize).unwrap_or(data).to_vec();
            return payload::exact(self.err, bytes, self.ty, self.endian, self.dims);
        }
        let blocks = (header.len() / w) - 3;
        let (size, last) = (self.uint(&header[w..2 * w]), self.uint(&header[2 * w..3 * w]));
        let last = if last == 0 { size } else { last };
        let total = if blocks == 0 {
            0
        } else {
            size.saturating_mul(blocks as u64 - 1).saturating_add(last)
        };
        if total != expected {
            return Err(self.err.bad(format!(
                "the compressed blocks hold {total} bytes, the extent needs {expected}"
            )));
        }
        let mut out = Vec::with_capacity(expected as usize);
        let mut at = 0usize;
        for b in 0..blocks {
            let c = self.uint(&header[(3 + b) * w..(4 + b) * w]) as usize;
            let chunk = data
                .get(at..at.saturating_add(c))
                .ok_or_else(|| self.err.bad(format!("compressed block {b} is cut short")))?;
            at += c;
            let want = if b + 1 == blocks { last } else { size };
            let mut z = flate2::read::ZlibDecoder::new(chunk);
            let before = out.len();
            std::io::Read::read_to_end(&mut std::io::Read::take(&mut z, want + 1), &mut out)
                .map_err(|e| self.err.bad(format!("compressed block {b} is corrupt ({e})")))?;
            let got = (out.len() - before) as u64;
            // One byte past `want` is all that was inflated: the block may hold far more.
            if got > want {
                return Err(self
                    .err
                    .bad(format!("compressed block {b} inflates to more than its {want} bytes")));
            }
            if got < want {
                return Err(self
                    .err
                    .bad(format!("compressed block {b} inflates to {got} bytes, not {want}")));
            }
        }
        payload::exact(self.err, out, self.ty, self.endian, self.dims)
    }
}

/// The points per axis of the first `WholeExtent="x0 x1 y0 y1 z0 z1"` in `head`, if it is there
/// and well formed.
fn peek_extent(head: &[u8]) -> Option<[u64; 3]> {
    let key = b"WholeExtent=";
    let at = find(head, key)? + key.len();
    let quote = *head.get(at)?;
    let len = head[at + 1..].iter().position(|&c| c == quote)?;
    let text = std::str::from_utf8(&head[at + 1..at + 1 + len]).ok()?;
    // Parsed as VTK's 32-bit ints: an extent past them is left to the full parse, which
    // names it (the cap's "needs 45776 MiB" would hide that the number is no extent at all).
    let e: Vec<i64> = text
        .split_ascii_whitespace()
        .map(|w| w.parse::<i32>().ok().map(i64::from))
        .collect::<Option<_>>()?;
    let [x0, x1, y0, y1, z0, z1] = e.as_slice() else { return None };
    let n = |a: i64, b: i64| u64::try_from(b.checked_sub(a)?.checked_add(1)?).ok();
    Some([n(*x0, *x1)?, n(*y0, *y1)?, n(*z0, *z1)?])
}

/// Most nested elements a `.vti` may have: VTK writes 5 or 6 (`VTKFile`, `ImageData`,
/// `Piece`, `PointData`, `DataArray`, `InformationKey`); the bound keeps roxmltree's recursive
/// descent far from the end of any thread's stack.
pub const MAX_XML_DEPTH: usize = 64;

/// Most attributes one element may have: VTK writes at most 8 or so (`DataArray`'s type,
/// Name, format, offset, range and components); 60,000 took roxmltree 4.8 s, since it checks
/// each against the ones before it.
pub const MAX_XML_ATTRIBUTES: usize = 256;

/// Where an element passes one of the scan's bounds.
#[derive(Debug, PartialEq, Eq)]
pub struct OverLimit {
    /// 1-based, of the element's `<`.
    pub line: usize,
    pub column: usize,
    /// None: it opens deeper than [`MAX_XML_DEPTH`]; Some(n): it has n attributes, more than
    /// [`MAX_XML_ATTRIBUTES`].
    pub attributes: Option<usize>,
}

/// The first element that opens deeper than [`MAX_XML_DEPTH`] elements or has more than
/// [`MAX_XML_ATTRIBUTES`] attributes, found in one pass without recursion; None when every
/// element stays within both. Counts start tags that are not self-closing, minus end tags,
/// skipping comments, CDATA, processing instructions, declarations and quoted attribute
/// values; an element's attributes are its quoted values. Malformed markup may be counted
/// deeper (or more crowded) than it is but never less than roxmltree gets before it fails
/// on it.
pub fn over_limits(xml: &str) -> Option<OverLimit> {
    let b = xml.as_bytes();
    let (mut depth, mut at) = (0usize, 0usize);
    // The index just past `end` from `from`, or the end of the text.
    let past = |from: usize, end: &[u8]| {
        find(&b[from.min(b.len())..], end).map_or(b.len(), |p| from + p + end.len())
    };
    let place = |open: usize, attributes: Option<usize>| {
        let line_start = b[..open].iter().rposition(|&c| c == b'\n').map_or(0, |n| n + 1);
        let line = 1 + b[..open].iter().filter(|&&c| c == b'\n').count();
        let column = 1 + xml[line_start..open].chars().count();
        OverLimit { line, column, attributes }
    };
    while let Some(p) = b[at..].iter().position(|&c| c == b'<') {
        let open = at + p;
        let rest = &b[open..];
        at = if rest.starts_with(b"<!--") {
            past(open + 4, b"-->")
        } else if rest.starts_with(b"<![CDATA[") {
            past(open + 9, b"]]>")
        } else if rest.starts_with(b"<?") {
            past(open + 2, b"?>")
        } else if rest.starts_with(b"<!") {
            past(open + 2, b">")
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            past(open + 2, b">")
        } else {
            // A start tag: to its `>`, past quoted attribute values (which may hold `>`).
            let mut i = open + 1;
            let mut quote = None;
            let mut attributes = 0usize;
            while i < b.len() {
                match (quote, b[i]) {
                    (None, b'"' | b'\'') => {
                        quote = Some(b[i]);
                        attributes += 1;
                    }
                    (Some(q), c) if c == q => quote = None,
                    (None, b'>') => break,
                    _ => {}
                }
                i += 1;
            }
            if attributes > MAX_XML_ATTRIBUTES {
                return Some(place(open, Some(attributes)));
            }
            if b.get(i.wrapping_sub(1)) != Some(&b'/') {
                depth += 1;
                if depth > MAX_XML_DEPTH {
                    return Some(place(open, None));
                }
            }
            i + 1
        };
        if at >= b.len() {
            break;
        }
    }
    None
}

fn child<'a, 'i>(n: roxmltree::Node<'a, 'i>, name: &str) -> Option<roxmltree::Node<'a, 'i>> {
    n.children().find(|c| c.has_tag_name(name))
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

fn sample_type(t: &str) -> Option<SampleType> {
    Some(match t {
        "Int8" => SampleType::I8,
        "UInt8" => SampleType::U8,
        "Int16" => SampleType::I16,
        "UInt16" => SampleType::U16,
        "Int32" => SampleType::I32,
        "UInt32" => SampleType::U32,
        "Int64" => SampleType::I64,
        "UInt64" => SampleType::U64,
        "Float32" => SampleType::F32,
        "Float64" => SampleType::F64,
        _ => return None,
    })
}
