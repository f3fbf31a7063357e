//! What every streamed scan-line EXR shares ([`super::stream`]: a render's records;
//! [`super::planes`]: named float planes): the header of the in-memory writer's `exr`
//! description with its attributes sorted, a zeroed offset table, each block of scan lines
//! compressed and written as soon as its rows are in (increasing y), the offset table filled
//! in at the end, and the temporary file renamed over the destination ([`crate::output::atomic`]).
//! The writers differ only in how a block's lines are filled from the rows they hold.
//!
//! The same blocks can go to memory instead of a file ([`BlockFile::in_memory`]): the bytes
//! of an EXR sent elsewhere (`serve`'s frames), so that every EXR isoview writes, streamed or
//! whole, comes from this one encoder.

use std::fs::File;
use std::io::{BufWriter, Cursor, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use exr::block::lines::LineRefMut;
use exr::block::{BlockIndex, UncompressedBlock};
use exr::math::Vec2;
use exr::meta::header::Header;
use exr::meta::{magic_number, Headers, MetaData};

use super::header::sort_header_attributes;
use crate::output::atomic::TempFile;
use crate::output::OutputError;

/// Where the blocks go: a temporary file renamed into place at the end, or memory.
enum Sink {
    File(TempFile, BufWriter<File>),
    Memory(Cursor<Vec<u8>>),
}

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self {
            Sink::File(_, w) => w.write(buf),
            Sink::Memory(c) => c.write(buf),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            Sink::File(_, w) => w.flush(),
            Sink::Memory(c) => c.flush(),
        }
    }
}

impl Seek for Sink {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        match self {
            Sink::File(_, w) => w.seek(pos),
            Sink::Memory(c) => c.seek(pos),
        }
    }
}

/// A scan-line EXR being written block by block into a temporary file (or memory).
pub(crate) struct BlockFile {
    /// The destination, for messages.
    path: PathBuf,
    out: Counting<Sink>,
    pub headers: Headers,
    /// Scan lines per block (the compression's).
    pub block_rows: usize,
    pub height: usize,
    offsets: Vec<u64>,
    table_at: u64,
}

impl BlockFile {
    /// Writes the header of `headers` (one part, `height` scan lines) and a zeroed offset table
    /// to a temporary file beside `path`.
    pub fn create(path: &Path, headers: Headers, height: usize) -> Result<Self, OutputError> {
        Self::start(path, headers, height, || {
            let temp = TempFile::create(path)?;
            let file = temp.file().try_clone().map_err(|e| temp.error("write", e))?;
            Ok(Sink::File(temp, BufWriter::with_capacity(1 << 20, file)))
        })
    }

    /// [`BlockFile::create`] into memory (`path` only names the file in messages); the bytes
    /// come from [`BlockFile::finish_bytes`].
    pub fn in_memory(path: &Path, headers: Headers, height: usize) -> Result<Self, OutputError> {
        Self::start(path, headers, height, || Ok(Sink::Memory(Cursor::new(Vec::new()))))
    }

    /// The header checked and encoded first, then `open` gives where it goes.
    fn start(
        path: &Path,
        headers: Headers,
        height: usize,
        open: impl FnOnce() -> Result<Sink, OutputError>,
    ) -> Result<Self, OutputError> {
        let header = headers.first().ok_or_else(|| OutputError::invalid(path, "no header"))?;
        let block_rows = header.max_block_pixel_size().height();
        let chunk_count = header.chunk_count;
        let exr_error = |source| OutputError::Exr {
            path: path.to_path_buf(),
            action: "cannot encode EXR header",
            source,
        };
        let mut head = Vec::new();
        let requirements = MetaData::validate(&headers, true).map_err(exr_error)?;
        magic_number::write(&mut head).map_err(exr_error)?;
        requirements.write(&mut head).map_err(exr_error)?;
        Header::write_all(&headers, &mut head, requirements.has_multiple_layers)
            .map_err(exr_error)?;
        sort_header_attributes(&mut head)
            .map_err(|reason| OutputError::invalid(path, format!("internal: {reason}")))?;

        let write_error = |e| OutputError::io(path, "write", e);
        let mut out = Counting { inner: open()?, written: 0 };
        out.write_all(&head).map_err(write_error)?;
        let table_at = out.written;
        // The offset table, zeros until `finish` knows where the blocks went.
        out.write_all(&vec![0u8; chunk_count * 8]).map_err(write_error)?;
        Ok(BlockFile {
            path: path.to_path_buf(),
            out,
            headers,
            block_rows,
            height,
            offsets: Vec::with_capacity(chunk_count),
            table_at,
        })
    }

    /// The destination, for messages.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The next block's first row and row count when `rows_in` rows have arrived and they
    /// complete it; None while it is still filling.
    pub fn block_done(&self, rows_in: usize) -> Option<(usize, usize)> {
        let start = self.offsets.len() * self.block_rows;
        let end = (start + self.block_rows).min(self.height);
        (rows_in == end).then_some((start, end - start))
    }

    /// Compresses rows `y0 .. y0 + rows` of `width` pixels into one chunk, each line filled by
    /// `fill`, and writes it.
    pub fn write_block(
        &mut self,
        y0: usize,
        rows: usize,
        width: usize,
        mut fill: impl FnMut(LineRefMut<'_>) -> exr::error::UnitResult,
    ) -> Result<(), OutputError> {
        let index = BlockIndex {
            layer: 0,
            level: Vec2(0, 0),
            pixel_position: Vec2(0, y0),
            pixel_size: Vec2(width, rows),
        };
        let mut failed = None;
        let data = UncompressedBlock::collect_block_data_from_lines(
            &self.headers[0].channels,
            index,
            |line| {
                if let Err(e) = fill(line) {
                    failed.get_or_insert(e);
                }
            },
        );
        let exr_error = |source| OutputError::Exr {
            path: self.path.clone(),
            action: "cannot encode EXR",
            source,
        };
        if let Some(e) = failed {
            return Err(exr_error(e));
        }
        let chunk = UncompressedBlock { index, data }
            .compress_to_chunk(&self.headers)
            .map_err(exr_error)?;
        self.offsets.push(self.out.written);
        chunk.write(&mut self.out, 1).map_err(exr_error)
    }

    /// Writes the offset table and moves the file into place; `rows_in` rows must be every row.
    pub fn finish(self, rows_in: usize) -> Result<(), OutputError> {
        let path = self.path.clone();
        match self.close(rows_in)? {
            Sink::File(temp, out) => {
                drop(out);
                temp.commit()
            }
            Sink::Memory(_) => Err(OutputError::invalid(&path, "internal: written to memory")),
        }
    }

    /// The file's bytes, from [`BlockFile::in_memory`]; `rows_in` rows must be every row.
    pub fn finish_bytes(self, rows_in: usize) -> Result<Vec<u8>, OutputError> {
        let path = self.path.clone();
        match self.close(rows_in)? {
            Sink::Memory(bytes) => Ok(bytes.into_inner()),
            Sink::File(..) => Err(OutputError::invalid(&path, "internal: written to a file")),
        }
    }

    /// Writes the offset table and flushes; the sink, to be committed or read.
    fn close(mut self, rows_in: usize) -> Result<Sink, OutputError> {
        if rows_in != self.height {
            let reason = format!("only {rows_in} of {} rows were written", self.height);
            return Err(OutputError::invalid(&self.path, reason));
        }
        let table: Vec<u8> = self.offsets.iter().flat_map(|o| o.to_le_bytes()).collect();
        let at = self.table_at;
        let out = &mut self.out.inner;
        let written = out
            .seek(SeekFrom::Start(at))
            .and_then(|_| out.write_all(&table))
            .and_then(|_| out.flush());
        written.map_err(|e| OutputError::io(&self.path, "write", e))?;
        Ok(self.out.inner)
    }
}

/// A writer that counts the bytes written through it (the position of the next chunk).
struct Counting<W> {
    inner: W,
    written: u64,
}

impl<W: Write> Write for Counting<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.written += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}
