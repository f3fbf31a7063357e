//! Streaming EXR writer: the file of [`super::exr::write_frame`], byte for byte, written band
//! by band as a render draws it, so memory stays at one block of scan lines whatever the
//! image's size.
//!
//! ```text
//!   create:  magic, version, header (attributes sorted) | offset table (zeros) |
//!   push_rows:                                                                 | block 0 | block 1 | ...
//!   finish:  seek back, fill the offset table, fsync, rename over the destination
//! ```
//!
//! The header comes from the same `exr::Image` description as the in-memory writer (its
//! `infer_meta_data`), written with the `exr` crate's own steps (`MetaData::validate`,
//! `magic_number::write`, `Requirements::write`, `Header::write_all`: what its block writer
//! does) and then sorted by [`super::exr`]'s attribute sort. Each block of
//! `header.max_block_pixel_size().y` scan lines (16 for ZIP) is compressed with
//! `UncompressedBlock::compress_to_chunk` as soon as its rows have arrived, and its chunk
//! written at once; the offset table is filled in at the end, as the `exr` crate does. Blocks
//! go out in increasing y, the file's line order, so the bytes equal the in-memory writer's.
//!
//! Channels are declared up front (a caller knows them from the scene: see
//! `render::scene_channels`). The in-memory writer decides the channels written only where
//! some pixel has a value ([`Written::WhereCounted`], [`Written::WhereFinite`]) from the
//! pixels instead, so the stream refuses a value in an undeclared channel (the in-memory
//! writer would have written it). A declared channel that no pixel gives a value (a picture
//! where nothing was hit) is written all "no value": there the two writers differ, as the
//! header is out before the pixels.

use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::Path;

use exr::block::chunk::Chunk;
use exr::block::{BlockIndex, UncompressedBlock};
use exr::math::Vec2;
use exr::meta::header::Header;
use exr::meta::{magic_number, MetaData};

use super::atomic::TempFile;
use super::exr::{channel_image_headers, sort_header_attributes};
use super::OutputError;
use crate::frame::{Channel, FrameInfo, Pixel, Written};

/// An EXR being written band by band (see the module docs).
pub struct ExrStream {
    temp: TempFile,
    out: Counting<BufWriter<File>>,
    headers: exr::meta::Headers,
    /// The declared channels in the file's order (by name), one per channel of the header.
    order: Vec<Channel>,
    width: usize,
    height: usize,
    /// Scan lines per block (16 for ZIP).
    block_rows: usize,
    /// Rows of the block being filled.
    pending: Vec<Pixel>,
    /// Rows written or pending so far.
    rows_in: usize,
    /// File position of each block written, in increasing y.
    offsets: Vec<u64>,
    /// Where the offset table starts.
    table_at: u64,
    /// Undeclared channels written only where they hold a value (every pixel must say "none").
    uncounted: Vec<Channel>,
}

impl ExrStream {
    /// Starts `path` (a temporary file beside it): a `width` × `height` image of `channels`
    /// (in any order; each at most once) with the header of `info`.
    pub fn create(
        path: &Path,
        width: u32,
        height: u32,
        channels: &[Channel],
        info: &FrameInfo,
    ) -> Result<Self, OutputError> {
        let (w, h) = (width as usize, height as usize);
        let headers = channel_image_headers(path, w, h, channels, info)?;
        let header = headers.first().ok_or_else(|| OutputError::invalid(path, "no header"))?;
        let order = header
            .channels
            .list
            .iter()
            .map(|d| {
                let name = std::str::from_utf8(d.name.bytes()).unwrap_or("");
                Channel::from_name(name).ok_or_else(|| {
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
        let mut out = Counting { inner: BufWriter::with_capacity(1 << 20, file), written: 0 };
        out.write_all(&head).map_err(|e| temp.error("write", e))?;
        let table_at = out.written;
        // The offset table, zeros until `finish` knows where the blocks went.
        out.write_all(&vec![0u8; chunk_count * 8]).map_err(|e| temp.error("write", e))?;

        let declared = |c: &Channel| channels.contains(c);
        let counted_channels =
            Channel::ALL.into_iter().filter(|c| c.written() == Written::WhereCounted);
        Ok(ExrStream {
            temp,
            out,
            headers,
            order,
            width: w,
            height: h,
            block_rows,
            pending: Vec::with_capacity(block_rows * w),
            rows_in: 0,
            offsets: Vec::with_capacity(chunk_count),
            table_at,
            uncounted: counted_channels.filter(|c| !declared(c)).collect(),
        })
    }

    /// The next whole rows of the image, row-major, in order from row 0.
    pub fn push_rows(&mut self, pixels: &[Pixel]) -> Result<(), OutputError> {
        if pixels.len() % self.width != 0 || self.rows_in + pixels.len() / self.width > self.height
        {
            return Err(self.invalid(format!(
                "{} records after {} of {} rows are not whole rows of {} pixels within the image",
                pixels.len(),
                self.rows_in,
                self.height,
                self.width
            )));
        }
        self.check_counts(pixels)?;
        for row in pixels.chunks_exact(self.width) {
            self.pending.extend_from_slice(row);
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
            return Err(
                self.invalid(format!("only {} of {} rows were drawn", self.rows_in, self.height))
            );
        }
        let table: Vec<u8> = self.offsets.iter().flat_map(|o| o.to_le_bytes()).collect();
        let at = self.table_at;
        let out = &mut self.out.inner;
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
        let header = &self.headers[0];
        let (pending, order, width) = (&self.pending, &self.order, self.width);
        let mut failed = None;
        let data =
            UncompressedBlock::collect_block_data_from_lines(&header.channels, index, |line| {
                let (c, row) = (order[line.location.channel], line.location.position.y() - y0);
                let samples = &pending[row * width..(row + 1) * width];
                if let Err(e) = line.write_samples(|x| c.get(&samples[x])) {
                    failed.get_or_insert(e);
                }
            });
        let exr_error = |source| OutputError::Exr {
            path: self.temp.path().to_path_buf(),
            action: "cannot encode EXR",
            source,
        };
        if let Some(e) = failed {
            return Err(exr_error(e));
        }
        let chunk: Chunk = UncompressedBlock { index, data }
            .compress_to_chunk(&self.headers)
            .map_err(exr_error)?;
        self.offsets.push(self.out.written);
        if let Err(e) = chunk.write(&mut self.out, 1) {
            return Err(exr_error(e));
        }
        self.pending.clear();
        Ok(())
    }

    /// Refuses values in undeclared channels (the in-memory writer would have written those
    /// channels; `output::exr::written_channels` is the rule).
    fn check_counts(&mut self, pixels: &[Pixel]) -> Result<(), OutputError> {
        let holds = |c: &Channel, p: &Pixel| match c.written() {
            Written::Always => true,
            Written::WhereCounted => c.get(p) >= 0.0,
            Written::WhereFinite => c.get(p).is_finite(),
        };
        if let Some(c) = self.uncounted.iter().find(|c| pixels.iter().any(|p| holds(c, p))) {
            let reason = format!("internal: channel {} has counts but was not declared", c.name());
            return Err(self.invalid(reason));
        }
        Ok(())
    }

    fn invalid(&self, reason: String) -> OutputError {
        OutputError::invalid(self.temp.path(), reason)
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
