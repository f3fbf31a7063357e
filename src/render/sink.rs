//! Where a frame goes as it is drawn.
//!
//! A render draws its picture band by band (`passes::Bands`); a [`FrameSink`] is told the
//! frame's size and facts once ([`FrameSink::begin`], before the first band) and then gets
//! each band's records, row 0 first, in world space ([`FrameSink::band`]). A sink that writes
//! each band on (the streaming EXR and PNG writers, tev) keeps memory at one band whatever
//! the image's size; [`Collect`] keeps them all and gives back the [`Frame`].

use super::RenderError;
use crate::frame::{Frame, FrameInfo, Pixel};
use crate::passes::Band;

/// Receives a frame band by band (see the module docs).
pub trait FrameSink {
    /// The frame's size and facts, before the first band.
    fn begin(&mut self, width: u32, height: u32, info: &FrameInfo) -> Result<(), RenderError>;
    /// One band's records, `band.rows` whole rows, the bands in order from row 0. An error
    /// (or [`RenderError::Cancelled`]) stops the render.
    fn band(&mut self, band: Band, pixels: &[Pixel]) -> Result<(), RenderError>;
}

/// A frame's EXR, PNG preview and tev view, each band written as it arrives (`output` knows no
/// renderer, so the sink is implemented here).
impl FrameSink for crate::output::frame_files::FrameFiles {
    fn begin(&mut self, width: u32, height: u32, info: &FrameInfo) -> Result<(), RenderError> {
        Ok(crate::output::frame_files::FrameFiles::begin(self, width, height, info)?)
    }

    fn band(&mut self, band: Band, pixels: &[Pixel]) -> Result<(), RenderError> {
        Ok(crate::output::frame_files::FrameFiles::band(self, band.row_offset, pixels)?)
    }
}

impl<S: FrameSink + ?Sized> FrameSink for &mut S {
    fn begin(&mut self, width: u32, height: u32, info: &FrameInfo) -> Result<(), RenderError> {
        (**self).begin(width, height, info)
    }

    fn band(&mut self, band: Band, pixels: &[Pixel]) -> Result<(), RenderError> {
        (**self).band(band, pixels)
    }
}

/// Keeps every band: the whole [`Frame`], for callers that need it in memory.
#[derive(Default)]
pub struct Collect {
    frame: Option<Frame>,
}

impl Collect {
    /// The frame collected, once the render has ended without error.
    pub fn into_frame(self) -> Result<Frame, RenderError> {
        self.frame.ok_or_else(|| {
            RenderError::Gpu(crate::gpu::GpuError::Bug("the render sent no frame".into()))
        })
    }
}

impl FrameSink for Collect {
    fn begin(&mut self, width: u32, height: u32, info: &FrameInfo) -> Result<(), RenderError> {
        let pixels = Vec::with_capacity(width as usize * height as usize);
        self.frame = Some(Frame { width, height, pixels, info: info.clone() });
        Ok(())
    }

    fn band(&mut self, _: Band, pixels: &[Pixel]) -> Result<(), RenderError> {
        match &mut self.frame {
            Some(frame) => {
                frame.pixels.extend_from_slice(pixels);
                Ok(())
            }
            None => Err(RenderError::Gpu(crate::gpu::GpuError::Bug(
                "a band arrived before the frame began".into(),
            ))),
        }
    }
}

/// A sink that hands each band to `after_band` first (the progressive hook: false stops the
/// render with [`RenderError::Cancelled`]) and then to `inner`.
pub struct Hooked<'a, S> {
    pub after_band: &'a mut dyn FnMut(Band, &[Pixel]) -> bool,
    pub inner: S,
}

impl<S: FrameSink> FrameSink for Hooked<'_, S> {
    fn begin(&mut self, width: u32, height: u32, info: &FrameInfo) -> Result<(), RenderError> {
        self.inner.begin(width, height, info)
    }

    fn band(&mut self, band: Band, pixels: &[Pixel]) -> Result<(), RenderError> {
        if !(self.after_band)(band, pixels) {
            return Err(RenderError::Cancelled);
        }
        self.inner.band(band, pixels)
    }
}

/// A sink that colours each band by `[color]` (`render::color`, after placement, as the frame
/// holds it) before `inner` gets it, and gives the frame its legend. Without a colorer it
/// passes the bands on as they are.
pub struct Colored<'a, S> {
    colorer: Option<&'a super::color::Colorer>,
    stride: u32,
    width: u32,
    pub inner: S,
}

impl<'a, S> Colored<'a, S> {
    /// `stride`: the picture's pixel (i, j) is the image's (stride i, stride j).
    pub fn new(colorer: Option<&'a super::color::Colorer>, stride: u32, inner: S) -> Self {
        Colored { colorer, stride, width: 0, inner }
    }
}

impl<S: FrameSink> FrameSink for Colored<'_, S> {
    fn begin(&mut self, width: u32, height: u32, info: &FrameInfo) -> Result<(), RenderError> {
        self.width = width;
        match self.colorer {
            Some(c) => {
                let mut info = info.clone();
                info.legend = Some(c.legend.clone());
                self.inner.begin(width, height, &info)
            }
            None => self.inner.begin(width, height, info),
        }
    }

    fn band(&mut self, band: Band, pixels: &[Pixel]) -> Result<(), RenderError> {
        match self.colorer {
            Some(c) => {
                let mut coloured = pixels.to_vec();
                c.apply(&mut coloured, self.width, band.row_offset, self.stride);
                self.inner.band(band, &coloured)
            }
            None => self.inner.band(band, pixels),
        }
    }
}

/// Hands a band to `sink` as the frame holds it: placed in world space.
pub(super) fn placed_band(
    sink: &mut dyn FrameSink,
    placement: &crate::vocab::Placement,
    band: crate::passes::Band,
    records: &[Pixel],
) -> Result<(), RenderError> {
    if placement.is_identity() {
        return sink.band(band, records);
    }
    let mut placed = records.to_vec();
    crate::frame::place_pixels(&mut placed, placement);
    sink.band(band, &placed)
}
