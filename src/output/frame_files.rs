//! The files of one rendered frame, written band by band as it is drawn: the float EXR
//! ([`super::exr::ExrStream`]), optionally the PNG preview ([`super::png::PngStream`]), and
//! optionally the frame shown in tev as it fills in ([`super::tev::TevImage`]). No band is
//! kept, so memory stays at one band whatever the image's size.
//!
//! ```text
//!   new(exr, png, channels) [.with_header(k, v)] [.show_in_tev(address, w, h)]
//!   begin(w, h, info)    the EXR and PNG started as temporary files beside their names
//!   band(row, pixels)*   each band to the EXR, the PNG and tev, in order from row 0
//!   finish()             the EXR and PNG moved into place (a failed render leaves neither)
//! ```
//!
//! tev is only a view: once sending to it fails it is dropped, the files are still written,
//! and the failure waits in [`FrameFiles::take_tev_error`] for the caller to report.
//! `render::FrameSink` is implemented for it in `render/sink.rs` (this module knows no
//! renderer), so `isoview render` and a binding hand it to the renderer as it is.

use std::path::{Path, PathBuf};

use super::exr::ExrStream;
use super::png::PngStream;
use super::tev::{TevError, TevImage};
use super::OutputError;
use crate::frame::{Channel, FrameInfo, Pixel};

/// One frame's EXR, PNG preview and tev view (module docs).
pub struct FrameFiles {
    exr_path: PathBuf,
    png_path: Option<PathBuf>,
    /// The EXR's channels, declared up front (`render::scene_channels`); tev shows the same.
    channels: Vec<Channel>,
    /// Header attributes added to the frame's own (`FrameInfo::extra`).
    header: Vec<(String, String)>,
    exr: Option<ExrStream>,
    png: Option<PngStream>,
    tev: Option<TevImage>,
    tev_error: Option<TevError>,
    size: (u32, u32),
}

impl FrameFiles {
    /// The frame's EXR at `exr` with `channels`, and its PNG preview at `png`; nothing is
    /// written before [`FrameFiles::begin`].
    pub fn new(exr: &Path, png: Option<&Path>, channels: Vec<Channel>) -> Self {
        FrameFiles {
            exr_path: exr.to_path_buf(),
            png_path: png.map(Path::to_path_buf),
            channels,
            header: Vec::new(),
            exr: None,
            png: None,
            tev: None,
            tev_error: None,
            size: (0, 0),
        }
    }

    /// Adds `isoview/extra/KEY` = `value` to the EXR header (a [`FrameInfo::extra`] pair,
    /// after the frame's own).
    pub fn with_header(mut self, key: &str, value: &str) -> Self {
        self.header.push((key.to_string(), value.to_string()));
        self
    }

    /// Also shows the frame in tev at `address` as it is drawn: connects now and creates the
    /// image, `width` × `height`, named as the EXR file, with the EXR's channels.
    pub fn show_in_tev(&mut self, address: &str, width: u32, height: u32) -> Result<(), TevError> {
        let name = self.exr_path.display().to_string();
        let image = TevImage::open(address, &name, width, height, self.channels.clone())?;
        self.tev = Some(image);
        Ok(())
    }

    /// Starts the files of a `width` × `height` frame with the header of `info`.
    pub fn begin(&mut self, width: u32, height: u32, info: &FrameInfo) -> Result<(), OutputError> {
        let mut info = info.clone();
        info.extra.extend(self.header.iter().cloned());
        self.size = (width, height);
        self.exr = Some(ExrStream::create(&self.exr_path, width, height, &self.channels, &info)?);
        if let Some(png) = &self.png_path {
            self.png = Some(PngStream::create(png, width, height, info.legend.as_ref())?);
        }
        Ok(())
    }

    /// The next band: whole rows from row `row_offset` on, in order from row 0. A failure to
    /// send to tev drops tev and is kept for [`FrameFiles::take_tev_error`]; the files go on.
    pub fn band(&mut self, row_offset: u32, pixels: &[Pixel]) -> Result<(), OutputError> {
        if let Some(exr) = &mut self.exr {
            exr.push_rows(pixels)?;
        }
        if let Some(png) = &mut self.png {
            png.push_rows(pixels)?;
        }
        if let Some(image) = &mut self.tev {
            if let Err(e) = image.send_rows(row_offset, pixels) {
                self.tev_error = Some(e);
                self.tev = None;
            }
        }
        Ok(())
    }

    /// The frame's size as [`FrameFiles::begin`] was told it ((0, 0) before).
    pub fn size(&self) -> (u32, u32) {
        self.size
    }

    /// Why tev stopped showing the frame, once (None: it did not, or was not asked).
    pub fn take_tev_error(&mut self) -> Option<TevError> {
        self.tev_error.take()
    }

    /// Moves the finished EXR and PNG into place.
    pub fn finish(self) -> Result<(), OutputError> {
        if let Some(exr) = self.exr {
            exr.finish()?;
        }
        if let Some(png) = self.png {
            png.finish()?;
        }
        Ok(())
    }
}
