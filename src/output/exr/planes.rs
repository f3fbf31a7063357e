//! Streaming EXR writer for arbitrary named float channels: the file of
//! [`super::write_channels`], byte for byte, written a few rows at a time (for
//! `compare --diff` on images of any size). Memory: one block of scan lines.
//!
//! The file is written by [`super::blocks::BlockFile`], as [`super::stream`]'s (a
//! render's [`crate::frame::Pixel`]s by the channel table); this writer fills each block's
//! lines from the planes it holds.

use std::path::Path;

use super::blocks::BlockFile;
use super::header::named_channel_headers;
use crate::output::OutputError;

/// An EXR of named float channels being written row by row (see the module docs).
pub struct PlaneStream {
    file: BlockFile,
    /// For each channel of the file (sorted by name), its index in the caller's order.
    order: Vec<usize>,
    width: usize,
    /// Rows of the block being filled, per channel in the caller's order.
    pending: Vec<Vec<f32>>,
    rows_in: usize,
}

impl PlaneStream {
    /// Starts `path` (a temporary file beside it): `width` × `height`, the channels `names`
    /// (each once), the text attributes as [`super::write_channels`] writes them.
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
        let file = BlockFile::create(path, headers, height)?;
        Ok(PlaneStream {
            pending: vec![Vec::with_capacity(file.block_rows * width); names.len()],
            file,
            order,
            width,
            rows_in: 0,
        })
    }

    /// The next whole rows of every channel (in the order of `names` at
    /// [`PlaneStream::create`]), row-major, in order from row 0.
    pub fn push_rows(&mut self, planes: &[&[f32]]) -> Result<(), OutputError> {
        let len = planes.first().map_or(0, |p| p.len());
        if planes.len() != self.pending.len()
            || planes.iter().any(|p| p.len() != len)
            || len % self.width != 0
            || self.rows_in + len / self.width > self.file.height
        {
            return Err(OutputError::invalid(
                self.file.path(),
                format!(
                    "{} planes of {len} values after {} of {} rows are not whole rows of {} \
                     channels within the image",
                    planes.len(),
                    self.rows_in,
                    self.file.height,
                    self.pending.len()
                ),
            ));
        }
        for row in 0..len / self.width {
            for (pending, plane) in self.pending.iter_mut().zip(planes) {
                pending.extend_from_slice(&plane[row * self.width..(row + 1) * self.width]);
            }
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

    /// Compresses rows `y0 .. y0 + rows` (all pending) into one chunk and writes it.
    fn write_block(&mut self, y0: usize, rows: usize) -> Result<(), OutputError> {
        let (pending, order, width) = (&self.pending, &self.order, self.width);
        self.file.write_block(y0, rows, width, |line| {
            let plane = &pending[order[line.location.channel]];
            let row = line.location.position.y() - y0;
            line.write_samples_from_slice(&plane[row * width..][..width])
        })?;
        self.pending.iter_mut().for_each(Vec::clear);
        Ok(())
    }
}
