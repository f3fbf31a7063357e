//! Streaming EXR writer for arbitrary named float channels: the file of
//! [`super::exr::write_channels`], byte for byte, written a few rows at a time (for
//! `compare --diff` on images of any size). Memory: one block of scan lines.
//!
//! The same steps as [`super::exr_stream`] (which writes a render's [`crate::frame::Pixel`]s
//! by the channel table): the header of the in-memory writer's `exr::Image` description,
//! sorted; a zero offset table; each block of 16 scan lines (ZIP) compressed and written as
//! soon as its rows have arrived, in increasing y; the offset table filled in at the end; the
//! temporary file renamed over the destination ([`super::atomic`]).

use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::Path;

use exr::block::{BlockIndex, UncompressedBlock};
use exr::math::Vec2;
use exr::meta::header::Header;
use exr::meta::{magic_number, MetaData};

use super::atomic::TempFile;
use super::exr::{named_channel_headers, sort_header_attributes};
use super::OutputError;

/// An EXR of named float channels being written row by row (see the module docs).
pub struct PlaneStream {
    temp: TempFile,
    out: BufWriter<File>,
    written: u64,
    headers: exr::meta::Headers,
    /// For each channel of the file (sorted by name), its index in the caller's order.
    order: Vec<usize>,
    width: usize,
    height: usize,
    block_rows: usize,
    /// Rows of the block being filled, per channel in the caller's order.
    pending: Vec<Vec<f32>>,
    rows_in: usize,
    offsets: Vec<u64>,
    table_at: u64,
}

impl PlaneStream {
    /// Starts `path` (a temporary file beside it): `width` × `height`, the channels `names`
    /// (each once), the text attributes as [`super::exr::write_channels`] writes them.
    pub fn create(
        path: &Path,
        width: usize,
        height: usize,
        names: &[String],
        text_attributes: &[(String, String)],
    ) -> Result<Self, OutputError> {
        let headers = named_channel_headers(path, width, height, names, text_attributes)?;
        let header = headers.first().ok_or_else(|| OutputError::invalid(path, "no header"))?;
        let order = header
            .channels
            .list
            .iter()
            .map(|d| {
                let name = std::str::from_utf8(d.name.bytes()).unwrap_or("");
                names.iter().position(|n| n == name).ok_or_else(|| {
                    OutputError::invalid(path, format!("internal: unknown channel {name:?}"))
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
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

        let temp = TempFile::create(path)?;
        let file = temp.file().try_clone().map_err(|e| temp.error("write", e))?;
        let mut out = BufWriter::with_capacity(1 << 20, file);
        out.write_all(&head).map_err(|e| temp.error("write", e))?;
        let table_at = head.len() as u64;
        out.write_all(&vec![0u8; chunk_count * 8]).map_err(|e| temp.error("write", e))?;
        Ok(PlaneStream {
            temp,
            out,
            written: table_at + chunk_count as u64 * 8,
            headers,
            order,
            width,
            height,
            block_rows,
            pending: vec![Vec::with_capacity(block_rows * width); names.len()],
            rows_in: 0,
            offsets: Vec::with_capacity(chunk_count),
            table_at,
        })
    }

    /// The next whole rows of every channel (in the order of `names` at
    /// [`PlaneStream::create`]), row-major, in order from row 0.
    pub fn push_rows(&mut self, planes: &[&[f32]]) -> Result<(), OutputError> {
        let len = planes.first().map_or(0, |p| p.len());
        if planes.len() != self.pending.len()
            || planes.iter().any(|p| p.len() != len)
            || len % self.width != 0
            || self.rows_in + len / self.width > self.height
        {
            return Err(OutputError::invalid(
                self.temp.path(),
                format!(
                    "{} planes of {len} values after {} of {} rows are not whole rows of {} \
                     channels within the image",
                    planes.len(),
                    self.rows_in,
                    self.height,
                    self.pending.len()
                ),
            ));
        }
        for row in 0..len / self.width {
            for (pending, plane) in self.pending.iter_mut().zip(planes) {
                pending.extend_from_slice(&plane[row * self.width..(row + 1) * self.width]);
            }
            self.rows_in += 1;
            let block_start = self.offsets.len() * self.block_rows;
            let block_end = (block_start + self.block_rows).min(self.height);
            if self.rows_in == block_end {
                self.write_block(block_start, block_end - block_start)?;
            }
        }
        Ok(())
    }

    /// Writes the offset table and moves the file into place; every row must have arrived.
    pub fn finish(mut self) -> Result<(), OutputError> {
        if self.rows_in != self.height {
            let reason = format!("only {} of {} rows were written", self.rows_in, self.height);
            return Err(OutputError::invalid(self.temp.path(), reason));
        }
        let table: Vec<u8> = self.offsets.iter().flat_map(|o| o.to_le_bytes()).collect();
        let at = self.table_at;
        let out = &mut self.out;
        let written = out
            .seek(SeekFrom::Start(at))
            .and_then(|_| out.write_all(&table))
            .and_then(|_| out.flush());
        written.map_err(|e| self.temp.error("write", e))?;
        let Self { temp, out, .. } = self;
        drop(out);
        temp.commit()
    }

    /// Compresses rows `y0 .. y0 + rows` (all pending) into one chunk and writes it.
    fn write_block(&mut self, y0: usize, rows: usize) -> Result<(), OutputError> {
        let index = BlockIndex {
            layer: 0,
            level: Vec2(0, 0),
            pixel_position: Vec2(0, y0),
            pixel_size: Vec2(self.width, rows),
        };
        let (pending, order, width) = (&self.pending, &self.order, self.width);
        let mut failed = None;
        let data = UncompressedBlock::collect_block_data_from_lines(
            &self.headers[0].channels,
            index,
            |line| {
                let plane = &pending[order[line.location.channel]];
                let row = line.location.position.y() - y0;
                if let Err(e) = line.write_samples_from_slice(&plane[row * width..][..width]) {
                    failed.get_or_insert(e);
                }
            },
        );
        let exr_error = |source| OutputError::Exr {
            path: self.temp.path().to_path_buf(),
            action: "cannot encode EXR",
            source,
        };
        if let Some(e) = failed {
            return Err(exr_error(e));
        }
        let chunk = UncompressedBlock { index, data }
            .compress_to_chunk(&self.headers)
            .map_err(exr_error)?;
        self.offsets.push(self.written);
        let mut counting = Counting { inner: &mut self.out, written: 0 };
        let result = chunk.write(&mut counting, 1);
        self.written += counting.written;
        result.map_err(exr_error)?;
        self.pending.iter_mut().for_each(Vec::clear);
        Ok(())
    }
}

/// Counts the bytes written through it.
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
