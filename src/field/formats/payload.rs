//! The data part of a volume file, shared by the readers: raw bytes at an offset, a gzip or
//! zlib stream, or ASCII numbers; decoded into `f32`, x fastest (every format here stores the
//! first axis fastest). Lengths are checked before decoding, and a compressed stream is never
//! inflated past the bytes the header promises, so a hostile header cannot make a reader
//! allocate more than the memory cap.

use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use flate2::read::{MultiGzDecoder, ZlibDecoder};

use super::Located;
use crate::field::samples::{self, Endian, SampleType, StorageOrder};
use crate::field::{FieldError, GridLimits};

/// How the samples are stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    Raw,
    Gzip,
    Zlib,
    Ascii,
}

/// Where the data starts in its file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// This many bytes from the beginning (of the decompressed stream when compressed).
    At(u64),
    /// The data is the file's last bytes (NRRD `byte skip: -1`, MetaImage `HeaderSize = -1`).
    FromEnd,
}

/// Checks `dims` (as declared: maybe huge or zero) against the memory cap; returns them.
pub fn grid(err: &Located, dims: [u64; 3], limits: &GridLimits) -> Result<[usize; 3], FieldError> {
    if dims.iter().any(|&d| d < 2) {
        return Err(err.bad(format!(
            "every axis needs at least 2 points, got {}x{}x{}",
            dims[0], dims[1], dims[2]
        )));
    }
    limits.check(dims, &err.path.display().to_string())?;
    Ok(dims.map(|d| d as usize))
}

/// Samples of `ty` in `path` (a whole file), decoded. `dims` has passed [`grid`].
pub fn from_file(
    err: &Located,
    path: &Path,
    encoding: Encoding,
    start: Start,
    ty: SampleType,
    endian: Endian,
    dims: [usize; 3],
) -> Result<Vec<f32>, FieldError> {
    let at = err.at(path);
    let mut file = err.access.open(path).map_err(|e| match path == err.path {
        true => at.io(&e),
        // A detached header's data file: name the header too.
        false => err.bad(format!("data file {}", FieldError::io(path, &e))),
    })?;
    let len = file.metadata().map_err(|e| at.io(&e))?.len();
    let bytes = byte_count(dims, ty);
    match encoding {
        Encoding::Raw => {
            let offset = match start {
                Start::At(n) => n,
                Start::FromEnd => len.saturating_sub(bytes),
            };
            if len.saturating_sub(offset) < bytes {
                return Err(FieldError::Truncated {
                    path: path.to_path_buf(),
                    expected: bytes,
                    actual: len.saturating_sub(offset),
                    layout: samples::layout(dims, ty),
                });
            }
            file.seek(SeekFrom::Start(offset)).map_err(|e| at.io(&e))?;
            let mut r = BufReader::new(file);
            samples::read_samples(&mut r, path, ty, endian, dims, StorageOrder::XFastest)
        }
        Encoding::Ascii => {
            let Start::At(skip) = start else {
                return Err(at.bad("byte skip -1 is only allowed for raw data"));
            };
            file.seek(SeekFrom::Start(skip)).map_err(|e| at.io(&e))?;
            // ASCII needs at least 2 bytes a sample: more than 64 a sample is not a volume.
            let most = byte_count(dims, SampleType::U8).saturating_mul(64).saturating_add(4096);
            ascii_stream(&at, BufReader::new(file), dims, most)
        }
        Encoding::Gzip | Encoding::Zlib => {
            let Start::At(skip) = start else {
                return Err(at.bad("byte skip -1 is only allowed for raw data"));
            };
            compressed(&at, BufReader::new(file), encoding, skip, ty, endian, dims)
        }
    }
}

/// Inflates a gzip or zlib stream, skips `skip` bytes of it, and decodes the samples. Fails if
/// the stream holds fewer or more bytes than promised.
pub fn compressed(
    err: &Located,
    reader: impl Read,
    encoding: Encoding,
    skip: u64,
    ty: SampleType,
    endian: Endian,
    dims: [usize; 3],
) -> Result<Vec<f32>, FieldError> {
    let inflate: Box<dyn Read> = match encoding {
        Encoding::Zlib => Box::new(ZlibDecoder::new(reader)),
        _ => Box::new(MultiGzDecoder::new(reader)),
    };
    inflated(err, inflate, skip, ty, endian, dims)
}

/// Skips `skip` bytes of an inflating `reader` and decodes the samples after them, reading at
/// most one byte more than promised (to tell a stream that is too long).
pub fn inflated(
    err: &Located,
    reader: impl Read,
    skip: u64,
    ty: SampleType,
    endian: Endian,
    dims: [usize; 3],
) -> Result<Vec<f32>, FieldError> {
    let bytes = byte_count(dims, ty);
    let corrupt = |e: std::io::Error| {
        let why = crate::field::error::one_line(&e.to_string());
        err.bad(format!("the compressed data is corrupt ({why})"))
    };
    let mut reader = reader;
    let skipped =
        std::io::copy(&mut (&mut reader).take(skip), &mut std::io::sink()).map_err(corrupt)?;
    if skipped < skip {
        return Err(err.bad(format!("the data ends within the {skip} bytes before the samples")));
    }
    let mut data = Vec::with_capacity(bytes as usize);
    reader.take(bytes + 1).read_to_end(&mut data).map_err(corrupt)?;
    if data.len() as u64 > bytes {
        // Only one byte past them was inflated: how much more the stream holds is not known.
        return Err(err.bad(format!(
            "the compressed data holds more than the {bytes} bytes of samples the header \
             declares ({}); isoview inflates no further",
            samples::layout(dims, ty)
        )));
    }
    exact(err, data, ty, endian, dims)
}

/// Decodes exactly `dims` samples from `data`, or says how many bytes were missing or extra.
pub fn exact(
    err: &Located,
    data: Vec<u8>,
    ty: SampleType,
    endian: Endian,
    dims: [usize; 3],
) -> Result<Vec<f32>, FieldError> {
    let bytes = byte_count(dims, ty);
    let actual = data.len() as u64;
    if actual != bytes {
        let (path, layout) = (err.path.to_path_buf(), samples::layout(dims, ty));
        return Err(if actual < bytes {
            FieldError::Truncated { path, expected: bytes, actual, layout }
        } else {
            FieldError::SizeMismatch { path, expected: bytes, actual, layout }
        });
    }
    let mut out = Vec::with_capacity(dims.iter().product());
    // Every format here stores x fastest: the sample's index is its grid index.
    samples::decode(ty, endian, &data, &mut out)
        .map_err(|o| o.error(crate::field::npy::path_str(err.path), dims, String::new()))?;
    Ok(out)
}

/// Whitespace-separated numbers, exactly one per grid point (anything after them is refused).
pub fn ascii(err: &Located, text: &str, dims: [usize; 3]) -> Result<Vec<f32>, FieldError> {
    let mut values = AsciiValues::new(err, dims);
    for word in text.split(is_separator).filter(|w| !w.is_empty()) {
        values.push(word)?;
    }
    values.finish()
}

/// [`ascii`] read from `reader` a block at a time, at most `most` bytes of it: the memory is
/// the grid's samples and one block of text, not the whole text (which may be many times the
/// samples' size).
pub fn ascii_stream(
    err: &Located,
    reader: impl Read,
    dims: [usize; 3],
    most: u64,
) -> Result<Vec<f32>, FieldError> {
    let mut reader = reader.take(most);
    let mut values = AsciiValues::new(err, dims);
    let mut block = vec![0u8; 1 << 16];
    // The bytes of a word cut by the end of the last block.
    let mut partial = Vec::new();
    loop {
        let n = reader.read(&mut block).map_err(|e| err.io(&e))?;
        let done = n == 0;
        let mut start = 0;
        for (i, &b) in block[..n].iter().enumerate() {
            if is_separator(b as char) {
                partial.extend_from_slice(&block[start..i]);
                start = i + 1;
                if !partial.is_empty() {
                    values.push_bytes(&partial)?;
                    partial.clear();
                }
            }
        }
        partial.extend_from_slice(&block[start..n]);
        if done {
            if !partial.is_empty() {
                values.push_bytes(&partial)?;
            }
            // Cut by the bound, not by the file's end: "truncated" would be untrue.
            if reader.limit() == 0 && values.out.len() < values.count {
                return Err(err.bad(format!(
                    "the ASCII data takes more than {most} bytes before its {} values end \
                     (isoview reads at most 64 bytes a value)",
                    values.count
                )));
            }
            return values.finish();
        }
    }
}

/// What separates ASCII values: whitespace or a comma.
fn is_separator(c: char) -> bool {
    c.is_ascii_whitespace() || c == ','
}

/// ASCII values being read: exactly one per grid point, each a number.
struct AsciiValues<'a, 'p> {
    err: &'a Located<'p>,
    dims: [usize; 3],
    count: usize,
    out: Vec<f32>,
}

impl<'a, 'p> AsciiValues<'a, 'p> {
    fn new(err: &'a Located<'p>, dims: [usize; 3]) -> Self {
        let count = dims.iter().product();
        AsciiValues { err, dims, count, out: Vec::with_capacity(count) }
    }

    fn push_bytes(&mut self, word: &[u8]) -> Result<(), FieldError> {
        let word =
            std::str::from_utf8(word).map_err(|_| self.err.bad("the ASCII data is not text"))?;
        self.push(word)
    }

    fn push(&mut self, word: &str) -> Result<(), FieldError> {
        if self.out.len() == self.count {
            return Err(self.err.bad(format!(
                "the ASCII data holds more than the {} values the header declares",
                self.count
            )));
        }
        let v: f64 = word.parse().map_err(|_| {
            self.err.bad(format!("ASCII value {} is not a number: {word:?}", self.out.len()))
        })?;
        let at = self.out.len();
        let v = samples::narrow(v).map_err(|value| {
            samples::Overflow { at, value }.error(
                crate::field::npy::path_str(self.err.path),
                self.dims,
                String::new(),
            )
        })?;
        self.out.push(v);
        Ok(())
    }

    fn finish(self) -> Result<Vec<f32>, FieldError> {
        if self.out.len() < self.count {
            return Err(self.err.bad(format!(
                "truncated data: the ASCII data holds {} of the {} values the header declares",
                self.out.len(),
                self.count
            )));
        }
        Ok(self.out)
    }
}

/// Bytes of `dims` samples of `ty` (dims have passed the cap, so this cannot overflow).
pub fn byte_count(dims: [usize; 3], ty: SampleType) -> u64 {
    dims.iter().fold(ty.size() as u64, |n, &d| n.saturating_mul(d as u64))
}
