//! An EXR read a few rows at a time, for the band-by-band comparison: memory holds the rows
//! asked for plus at most one block row per part, whatever the image's size.
//!
//! The values are those of [`crate::output::exr::read`], pixel for pixel: the display window,
//! display pixels outside a part's data window 0, half and uint samples converted to `f32`
//! the same way, tiles at their largest resolution level, and multi-part files merged with
//! channels renamed `<part>.<channel>`. Blocks are found through the file's offset tables
//! (`exr::block`'s `filter_chunks`): one block row (the scan-line blocks or the row of tiles
//! holding a given data row) at a time, so any line order and any tile size work, each block
//! decompressed once per pass. Channels with x/y subsampling are refused (isoview never
//! writes them; the whole-image reader's handling of them is the `exr` crate's).

use std::fs::File;
use std::io::{BufReader, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use exr::block::reader::ChunksReader;
use exr::math::Vec2;
use exr::meta::attribute::SampleType;
use exr::prelude::f16;

use crate::output::exr::SampleKind;
use crate::output::OutputError;

/// One part of the file: where its data window lies in the display window, and its channels.
struct Part {
    /// Data window origin relative to the display window origin.
    x0: i64,
    y0: i64,
    width: usize,
    height: usize,
    /// Scan lines per block, or tile height.
    block_rows: usize,
    /// Index into [`ExrRows::channels`] of each of the part's channels, in the part's order.
    channels: Vec<usize>,
    kinds: Vec<SampleType>,
    /// Display rows `lo .. ready` of this part's channels are loaded.
    ready: usize,
}

/// Rows of an EXR's channels, loaded on demand (see the module docs).
pub struct ExrRows {
    pub path: PathBuf,
    file: File,
    pub width: usize,
    pub height: usize,
    /// Every channel: its full name and sample type, in the whole-image reader's order.
    pub channels: Vec<(String, SampleKind)>,
    parts: Vec<Part>,
    /// Which channels are loaded.
    kept: Vec<bool>,
    /// First display row held.
    lo: usize,
    /// Per channel, rows `lo ..` of the display window (only kept channels hold any).
    rows: Vec<Vec<f32>>,
}

impl ExrRows {
    /// Opens `path` and reads its header (no pixels yet).
    pub fn open(path: &Path) -> Result<ExrRows, OutputError> {
        let file = crate::vocab::open_regular(path, "an EXR file")
            .map_err(|e| OutputError::io(path, "read", e))?;
        let meta = exr::block::read(BufReader::new(&file), false)
            .map_err(|source| unreadable(path, source))?
            .into_meta_data();
        if meta.headers.iter().any(|h| h.deep) {
            return Err(OutputError::invalid(path, "deep EXR data is not supported"));
        }
        let first = meta.headers.first().ok_or_else(|| OutputError::invalid(path, "no part"))?;
        let display = first.shared_attributes.display_window;
        let (width, height) = (display.size.x(), display.size.y());
        let multi = meta.headers.len() > 1;
        let mut channels: Vec<(String, SampleKind)> = Vec::new();
        let mut parts = Vec::new();
        for h in &meta.headers {
            let part = h
                .own_attributes
                .layer_name
                .as_ref()
                .map(|t| String::from_utf8_lossy(t.bytes()).into_owned())
                .unwrap_or_default();
            let mut indices = Vec::new();
            let mut kinds = Vec::new();
            for c in h.channels.list.iter() {
                let mut name = String::from_utf8_lossy(c.name.bytes()).into_owned();
                if c.sampling != Vec2(1, 1) {
                    return Err(OutputError::invalid(
                        path,
                        format!("channel {name:?} is subsampled, which compare does not read"),
                    ));
                }
                if multi && !part.is_empty() && !name.starts_with(&format!("{part}.")) {
                    name = format!("{part}.{name}");
                }
                if channels.iter().any(|(n, _)| *n == name) {
                    return Err(OutputError::invalid(
                        path,
                        format!("channel {name:?} appears in more than one part"),
                    ));
                }
                let kind = match c.sample_type {
                    SampleType::F16 => SampleKind::F16,
                    SampleType::F32 => SampleKind::F32,
                    SampleType::U32 => SampleKind::U32,
                };
                indices.push(channels.len());
                kinds.push(c.sample_type);
                channels.push((name, kind));
            }
            let origin = h.own_attributes.layer_position;
            parts.push(Part {
                x0: i64::from(origin.x()) - i64::from(display.position.x()),
                y0: i64::from(origin.y()) - i64::from(display.position.y()),
                width: h.layer_size.x(),
                height: h.layer_size.y(),
                block_rows: h.max_block_pixel_size().y().max(1),
                channels: indices,
                kinds,
                ready: 0,
            });
        }
        let n = channels.len();
        Ok(ExrRows {
            path: path.to_path_buf(),
            file,
            width,
            height,
            channels,
            parts,
            kept: vec![false; n],
            lo: 0,
            rows: vec![Vec::new(); n],
        })
    }

    /// The index of the channel named `name`.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.channels.iter().position(|(n, _)| n == name)
    }

    /// The most rows one block row of a part holds (scan lines per block, or tile height):
    /// [`ExrRows::load`] reads whole block rows, so it may hold this many rows past those asked.
    pub fn block_rows(&self) -> usize {
        self.parts.iter().map(|p| p.block_rows.min(p.height)).max().unwrap_or(1)
    }

    /// An upper bound of the bytes one block read holds decoded: every channel of its part
    /// (kept or not, as the block stores them) at 4 bytes a sample, for its part's width.
    pub fn block_bytes(&self) -> u64 {
        let part =
            |p: &Part| (p.block_rows.min(p.height) * p.width) as u64 * p.channels.len() as u64 * 4;
        self.parts.iter().map(part).max().unwrap_or(0)
    }

    /// Loads only these channels from now on, and starts again at row 0.
    pub fn keep(&mut self, channels: &[usize]) {
        self.kept = (0..self.channels.len()).map(|i| channels.contains(&i)).collect();
        self.rewind();
    }

    /// Forgets every row: the next [`ExrRows::load`] reads from the top again (a new pass).
    pub fn rewind(&mut self) {
        self.lo = 0;
        self.rows.iter_mut().for_each(Vec::clear);
        self.parts.iter_mut().for_each(|p| p.ready = 0);
    }

    /// Holds display rows `lo .. hi` (clamped to the image) of every kept channel, dropping
    /// rows above `lo`. Rows are asked for top to bottom: `lo` and `hi` never decrease.
    pub fn load(&mut self, lo: usize, hi: usize) -> Result<(), OutputError> {
        let hi = hi.min(self.height);
        let lo = lo.min(hi);
        if lo > self.lo {
            let drop = lo - self.lo;
            for c in 0..self.rows.len() {
                let n = (drop * self.width).min(self.rows[c].len());
                self.rows[c].drain(..n);
            }
            self.lo = lo;
        }
        for p in 0..self.parts.len() {
            if !self.parts[p].channels.iter().any(|&c| self.kept[c]) {
                continue;
            }
            self.parts[p].ready = self.parts[p].ready.max(self.lo);
            while self.parts[p].ready < hi {
                self.load_part_rows(p, hi)?;
            }
        }
        Ok(())
    }

    /// Rows `y0 .. y1` of channel `c`, row-major; they must be loaded.
    pub fn rows(&self, c: usize, y0: usize, y1: usize) -> &[f32] {
        &self.rows[c][(y0 - self.lo) * self.width..(y1 - self.lo) * self.width]
    }

    /// Loads the next rows of part `p`: zeros outside its data window, else the rest of the
    /// block row holding its next display row.
    fn load_part_rows(&mut self, p: usize, hi: usize) -> Result<(), OutputError> {
        let w = self.width;
        let part = &self.parts[p];
        let y = part.ready;
        let data_y = y as i64 - part.y0;
        let zeros_until = if data_y < 0 {
            Some((part.y0 as usize).min(hi))
        } else if data_y >= part.height as i64 {
            Some(hi)
        } else {
            None
        };
        if let Some(end) = zeros_until {
            let end = end.min(self.height);
            for &c in &part.channels {
                if self.kept[c] {
                    let len = self.rows[c].len();
                    self.rows[c].resize(len + (end - y) * w, 0.0);
                }
            }
            self.parts[p].ready = end;
            return Ok(());
        }
        let data_y = data_y as usize;
        let start = data_y / part.block_rows * part.block_rows;
        let rows = part.block_rows.min(part.height - start);
        let block = self.read_block_row(p, start, rows)?;
        let part = &self.parts[p];
        // Display rows y .. end come from data rows data_y .. start + rows.
        let end = ((start + rows) as i64 + part.y0).min(self.height as i64) as usize;
        for (k, &c) in part.channels.iter().enumerate() {
            if !self.kept[c] {
                continue;
            }
            let src = &block[k];
            let out = &mut self.rows[c];
            for dy in y..end {
                let sy = (dy as i64 - part.y0) as usize - start;
                let line = &src[sy * part.width..(sy + 1) * part.width];
                if part.x0 == 0 && part.width == w {
                    out.extend_from_slice(line);
                } else {
                    out.extend((0..w).map(|x| {
                        let sx = x as i64 - part.x0;
                        if sx >= 0 && sx < part.width as i64 {
                            line[sx as usize]
                        } else {
                            0.0
                        }
                    }));
                }
            }
        }
        self.parts[p].ready = end;
        Ok(())
    }

    /// Data rows `start .. start + rows` of part `p`, full data width, per channel of the part
    /// (kept ones only; others stay empty).
    fn read_block_row(
        &mut self,
        p: usize,
        start: usize,
        rows: usize,
    ) -> Result<Vec<Vec<f32>>, OutputError> {
        let path = self.path.clone();
        let bad = |source| unreadable(&path, source);
        let part = &self.parts[p];
        let width = part.width;
        let mut out: Vec<Vec<f32>> = part
            .channels
            .iter()
            .map(|&c| if self.kept[c] { vec![0.0; width * rows] } else { Vec::new() })
            .collect();
        let mut file = &self.file;
        file.seek(SeekFrom::Start(0)).map_err(|e| OutputError::io(&path, "read", e))?;
        let reader = exr::block::read(BufReader::new(file), false).map_err(bad)?;
        let header = reader.headers()[p].clone();
        let chunks = reader
            .filter_chunks(false, |_, _, b| {
                b.layer == p && b.level == Vec2(0, 0) && b.pixel_position.y() == start
            })
            .map_err(bad)?;
        let mut blocks = chunks.sequential_decompressor(false);
        let mut covered = 0usize;
        while let Some(block) = blocks.decompress_next_block() {
            let block = block.map_err(bad)?;
            covered += block.index.pixel_size.x() * block.index.pixel_size.y();
            for line in block.lines(&header.channels) {
                let k = line.location.channel;
                if out[k].is_empty() {
                    continue;
                }
                let (x, y) = (line.location.position.x(), line.location.position.y());
                if y < start || y >= start + rows || x + line.location.sample_count > width {
                    return Err(OutputError::invalid(&path, "a block lies outside its part"));
                }
                let dst = &mut out[k][(y - start) * width + x..][..line.location.sample_count];
                match part.kinds[k] {
                    SampleType::F32 => line.read_samples_into_slice(dst).map_err(bad)?,
                    SampleType::F16 => {
                        for (d, s) in dst.iter_mut().zip(line.read_samples::<f16>()) {
                            *d = s.map_err(bad)?.to_f32();
                        }
                    }
                    SampleType::U32 => {
                        for (d, s) in dst.iter_mut().zip(line.read_samples::<u32>()) {
                            *d = s.map_err(bad)? as f32;
                        }
                    }
                }
            }
        }
        if covered != width * rows {
            return Err(OutputError::invalid(
                &path,
                format!("rows {start}..{} of a part are missing or repeated", start + rows),
            ));
        }
        Ok(out)
    }
}

fn unreadable(path: &Path, source: exr::error::Error) -> OutputError {
    OutputError::Exr { path: path.to_path_buf(), action: "not a readable OpenEXR file", source }
}
