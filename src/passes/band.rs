//! Bands of image rows: every ray, mesh and slice pass writes one record per pixel of a band,
//! and [`Bands`] runs a picture's passes band by band. Bands keep the pixel buffer under the
//! device's `maxStorageBufferRange` (128 MiB on lavapipe) and each dispatch under
//! [`MAX_BAND_PIXELS`] pixels, so pictures of any size are drawn in pieces.
//!
//! Per band, one submission: the passes that write the band's pixels to the start of
//! [`Bands::out`] (timed with GPU timestamps where the device has them), the copy of the band
//! into a host-visible buffer, then the host reads it. Barriers come from the passes'
//! bindings (`gpu::Binding`, `gpu::Recorder`).

use std::sync::Arc;

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::gpu::{Buffer, Context, GpuError, MemoryLocation, Recorder, Timer, Tracker};

/// Most pixels in one dispatch (bounds the time of one submission on real GPUs too).
pub const MAX_BAND_PIXELS: u64 = 1 << 20;

/// Push constants of the ray passes: the band of rows being rendered.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Band {
    pub row_offset: u32,
    pub rows: u32,
}

/// Rows per band for an image `width` × `height` whose pixels take `pixel_bytes` each: as many as
/// fit one storage-buffer binding and [`MAX_BAND_PIXELS`], at least one.
pub fn band_rows(ctx: &Context, width: u32, height: u32, pixel_bytes: u64) -> u32 {
    let row_bytes = width as u64 * pixel_bytes;
    let rows_by_range = ctx.info.max_storage_buffer_range / row_bytes;
    let rows_by_count = MAX_BAND_PIXELS / width as u64;
    rows_by_range.min(rows_by_count).clamp(1, height as u64) as u32
}

/// A picture's records, row 0 first, and the summed GPU time of its passes in milliseconds
/// (None without timestamps).
pub type Drawn<P> = (Vec<P>, Option<f64>);

/// A picture of `width` × `height` records of type `P`, drawn band by band into [`Bands::out`].
pub struct Bands<P> {
    pub width: u32,
    pub height: u32,
    /// Rows of the largest band.
    pub rows: u32,
    /// The band's records, row 0 of the band first (storage, copy source).
    pub out: Buffer,
    readback: Buffer,
    ctx: Arc<Context>,
    _pixel: std::marker::PhantomData<P>,
}

impl<P: Pod> Bands<P> {
    /// The band buffers of a picture; `name` names the pixel buffer ("pixels").
    pub fn new(ctx: &Arc<Context>, name: &str, width: u32, height: u32) -> Result<Self, GpuError> {
        Self::with_max_rows(ctx, name, width, height, u32::MAX)
    }

    /// [`Bands::new`] with at most `max_rows` rows per band (at least one): smaller bands let
    /// a caller stop between them sooner ([`Bands::run_until`]).
    pub fn with_max_rows(
        ctx: &Arc<Context>,
        name: &str,
        width: u32,
        height: u32,
        max_rows: u32,
    ) -> Result<Self, GpuError> {
        let pixel_bytes = std::mem::size_of::<P>() as u64;
        let rows = band_rows(ctx, width, height, pixel_bytes).min(max_rows.max(1));
        let out = Buffer::new(
            ctx,
            name,
            rows as u64 * width as u64 * pixel_bytes,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        let readback = Buffer::new(
            ctx,
            &format!("{name} readback"),
            out.size,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        let ctx = ctx.clone();
        Ok(Bands { width, height, rows, out, readback, ctx, _pixel: std::marker::PhantomData })
    }

    /// Pixels of the largest band (what per-pixel scratch buffers must hold).
    pub fn band_pixels(&self) -> u64 {
        self.rows as u64 * self.width as u64
    }

    /// Runs `record` for each band (it records the passes that write the band's records to the
    /// start of [`Bands::out`]), submission `pass` per band. Returns the picture's records, row 0
    /// first, and the summed GPU time of the passes in milliseconds (None without timestamps).
    pub fn run(
        &self,
        pass: &str,
        record: impl FnMut(&mut Recorder, Band) -> Result<(), GpuError>,
    ) -> Result<Drawn<P>, GpuError> {
        // Never None: the hook always goes on.
        let picture = self.run_until(pass, |_, _| true, record)?;
        Ok(picture.unwrap_or_default())
    }

    /// [`Bands::run`] that hands each finished band's records to `after_band` and stops, with
    /// `None`, as soon as it answers false (the bands already drawn are dropped): stale work
    /// is abandoned at a band boundary, and finished bands can be shown or sent on.
    pub fn run_until(
        &self,
        pass: &str,
        mut after_band: impl FnMut(Band, &[P]) -> bool,
        record: impl FnMut(&mut Recorder, Band) -> Result<(), GpuError>,
    ) -> Result<Option<Drawn<P>>, GpuError> {
        let mut pixels = Vec::with_capacity(self.width as usize * self.height as usize);
        let keep = |band: Band, records: &[P]| {
            pixels.extend_from_slice(records);
            match after_band(band, records) {
                true => Ok(()),
                false => Err(Halt::Stop),
            }
        };
        match self.for_each_band(pass, keep, record) {
            Ok(gpu_ms) => Ok(Some((pixels, gpu_ms))),
            Err(Halt::Stop) => Ok(None),
            Err(Halt::Gpu(e)) => Err(e),
        }
    }

    /// Draws the picture band by band and hands each finished band's records to `after_band`,
    /// keeping none of them: memory stays at one band whatever the picture's size (what
    /// streaming outputs need). The first error, the GPU's or `after_band`'s, stops the
    /// picture. Returns the summed GPU time of the passes in milliseconds (None without
    /// timestamps).
    pub fn for_each_band<E: From<GpuError>>(
        &self,
        pass: &str,
        after_band: impl FnMut(Band, &[P]) -> Result<(), E>,
        record: impl FnMut(&mut Recorder, Band) -> Result<(), GpuError>,
    ) -> Result<Option<f64>, E> {
        self.for_each_band_in_rounds(pass, after_band, record, None)
    }

    /// [`Bands::for_each_band`] with further `rounds` of each band's passes after its first
    /// submission, while they say work is pending; the band's records are read after the last.
    pub fn for_each_band_in_rounds<E: From<GpuError>>(
        &self,
        pass: &str,
        mut after_band: impl FnMut(Band, &[P]) -> Result<(), E>,
        mut record: impl FnMut(&mut Recorder, Band) -> Result<(), GpuError>,
        rounds: Option<&dyn Rounds>,
    ) -> Result<Option<f64>, E> {
        let ctx = &self.ctx;
        let timer = Timer::new(ctx)?;
        let mut gpu_ms = timer.as_ref().map(|_| 0.0);
        let add_time = |gpu_ms: &mut Option<f64>| -> Result<(), GpuError> {
            if let (Some(t), Some(ms)) = (&timer, gpu_ms.as_mut()) {
                *ms += t.elapsed_ms()?;
            }
            Ok(())
        };
        let mut row = 0;
        while row < self.height {
            let rows = self.rows.min(self.height - row);
            let band = Band { row_offset: row, rows };
            let count = (rows * self.width) as usize;
            let bytes = count as u64 * std::mem::size_of::<P>() as u64;
            ctx.record(pass, &mut Tracker::default(), |rec| {
                rec.timed(timer.as_ref(), |rec| record(rec, band))?;
                rec.readback(&self.out, &self.readback, bytes);
                Ok(())
            })?;
            add_time(&mut gpu_ms)?;
            if let Some(rounds) = rounds {
                let mut more = false;
                while rounds.pending()? {
                    ctx.record(pass, &mut Tracker::default(), |rec| {
                        rec.timed(timer.as_ref(), |rec| rounds.record(rec, band))
                    })?;
                    add_time(&mut gpu_ms)?;
                    more = true;
                }
                if more {
                    ctx.record(pass, &mut Tracker::default(), |rec| {
                        rec.readback(&self.out, &self.readback, bytes);
                        Ok(())
                    })?;
                }
            }
            after_band(band, &self.readback.read::<P>(count)?)?;
            row += rows;
        }
        Ok(gpu_ms)
    }
}

/// More rounds of a band's passes ([`Bands::for_each_band_in_rounds`]): work one submission
/// left, such as the tricubic walk's rays cut short by llvmpipe's loop cap
/// ([`super::tricubic::Resume`]).
pub trait Rounds {
    /// After a submission of the band: whether another round is needed (an error stops the
    /// picture).
    fn pending(&self) -> Result<bool, GpuError>;
    /// Records the next round.
    fn record(&self, rec: &mut Recorder, band: Band) -> Result<(), GpuError>;
}

/// Why [`Bands::run_until`] stopped early: the hook said so, or the GPU failed.
enum Halt {
    Stop,
    Gpu(GpuError),
}

impl From<GpuError> for Halt {
    fn from(e: GpuError) -> Self {
        Halt::Gpu(e)
    }
}
