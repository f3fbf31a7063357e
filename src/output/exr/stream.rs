//! Streaming EXR writer: the file of [`super::write_frame`], byte for byte, written band
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
//! does) and then sorted by [`super::header`]'s attribute sort. Each block of
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

use std::path::Path;

use super::blocks::BlockFile;
use super::header::channel_image_headers;
use crate::frame::{Channel, FrameInfo, Pixel, Written};
use crate::output::OutputError;

/// An EXR being written band by band (see the module docs).
pub struct ExrStream {
    file: BlockFile,
    /// The declared channels in the file's order (by name), one per channel of the header.
    order: Vec<Channel>,
    width: usize,
    /// Rows of the block being filled.
    pending: Vec<Pixel>,
    /// Rows written or pending so far.
    rows_in: usize,
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
        Self::start(path, width, height, channels, info, false)
    }

    /// [`ExrStream::create`] into memory (`path` only names the file in messages): the bytes
    /// come from [`ExrStream::finish_bytes`].
    pub fn in_memory(
        path: &Path,
        width: u32,
        height: u32,
        channels: &[Channel],
        info: &FrameInfo,
    ) -> Result<Self, OutputError> {
        Self::start(path, width, height, channels, info, true)
    }

    fn start(
        path: &Path,
        width: u32,
        height: u32,
        channels: &[Channel],
        info: &FrameInfo,
        memory: bool,
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
        let file = if memory {
            BlockFile::in_memory(path, headers, h)?
        } else {
            BlockFile::create(path, headers, h)?
        };
        let declared = |c: &Channel| channels.contains(c);
        let counted_channels =
            Channel::ALL.into_iter().filter(|c| c.written() == Written::WhereCounted);
        Ok(ExrStream {
            pending: Vec::with_capacity(file.block_rows * w),
            file,
            order,
            width: w,
            rows_in: 0,
            uncounted: counted_channels.filter(|c| !declared(c)).collect(),
        })
    }

    /// The next whole rows of the image, row-major, in order from row 0.
    pub fn push_rows(&mut self, pixels: &[Pixel]) -> Result<(), OutputError> {
        if pixels.len() % self.width != 0
            || self.rows_in + pixels.len() / self.width > self.file.height
        {
            return Err(self.invalid(format!(
                "{} records after {} of {} rows are not whole rows of {} pixels within the image",
                pixels.len(),
                self.rows_in,
                self.file.height,
                self.width
            )));
        }
        self.check_counts(pixels)?;
        for row in pixels.chunks_exact(self.width) {
            self.pending.extend_from_slice(row);
            self.rows_in += 1;
            if let Some((y0, rows)) = self.file.block_done(self.rows_in) {
                self.write_block(y0, rows)?;
            }
        }
        Ok(())
    }

    /// Writes the offset table and moves the file into place; every row must have arrived.
    pub fn finish(self) -> Result<(), OutputError> {
        self.file.finish(self.rows_in)
    }

    /// The file's bytes, from [`ExrStream::in_memory`]; every row must have arrived.
    pub fn finish_bytes(self) -> Result<Vec<u8>, OutputError> {
        self.file.finish_bytes(self.rows_in)
    }

    /// Compresses rows `y0 .. y0 + rows` (all pending) into one chunk and writes it.
    fn write_block(&mut self, y0: usize, rows: usize) -> Result<(), OutputError> {
        let (pending, order, width) = (&self.pending, &self.order, self.width);
        self.file.write_block(y0, rows, width, |line| {
            let (c, row) = (order[line.location.channel], line.location.position.y() - y0);
            let samples = &pending[row * width..(row + 1) * width];
            line.write_samples(|x| c.get(&samples[x]))
        })?;
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
        OutputError::invalid(self.file.path(), reason)
    }
}
