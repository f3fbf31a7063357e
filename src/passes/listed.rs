//! Rays one pass lists for a later pass to go on from: the two-pass analytic walk's (analytic.comp's
//! `OCC_SKIP` lists the rays that meet a brick that may hold a surface, `OCC_RESUME` walks
//! them, dispatched indirectly), and the tricubic walk's cut short by llvmpipe's loop cap
//! (tricubic.comp lists them, its `RESUMED` build goes on from there in rounds:
//! [`super::tricubic::Resume`]).

use std::sync::Arc;

use ash::vk;

use crate::gpu::{Buffer, Context, GpuError, MemoryLocation};

/// The rays a pass lists per band: two `uvec4` each (what they are is the passes' own), then
/// their count, the resuming pass's indirect dispatch and the rounds' counts ([`Counts`]).
pub struct Listed {
    /// Pixels of the largest band it has room for.
    pub band_pixels: u64,
    pub rays: Buffer,
    /// `count`, the resuming pass's `VkDispatchIndirectCommand` at [`Listed::ARGS`], then
    /// `live`, `lost` and `probe` (tricubic.comp's `Count`).
    pub count: Buffer,
    /// The host's copy of `count` ([`Listed::read_counts`]).
    readback: Buffer,
}

/// What a band's last round left ([`Listed::counts`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Counts {
    /// Rays listed.
    pub listed: u32,
    /// Rays that go on in another round.
    pub live: u32,
    /// Rays a round could not take one step further.
    pub lost: u32,
}

impl Listed {
    /// Where the resuming pass's workgroup counts are in [`Listed::count`].
    pub const ARGS: u64 = 4;
    /// Bytes of [`Listed::count`]: eight words.
    const COUNT_BYTES: u64 = 32;
    /// Where `live` is in [`Listed::count`].
    const LIVE: u64 = 16;

    /// Room for bands of at most `band_pixels` pixels.
    pub fn new(ctx: &Arc<Context>, band_pixels: u64) -> Result<Self, GpuError> {
        Ok(Listed {
            band_pixels,
            rays: Buffer::new(
                ctx,
                "listed rays",
                band_pixels * 32,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::GpuOnly,
            )?,
            count: Buffer::new(
                ctx,
                "listed rays count",
                Self::COUNT_BYTES,
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::INDIRECT_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST
                    | vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::GpuOnly,
            )?,
            readback: Buffer::new(
                ctx,
                "listed rays count readback",
                Self::COUNT_BYTES,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?,
        })
    }

    /// Records the reset before a band: no ray listed, no workgroup (x = 0; y = z = 1), no ray
    /// live or lost, the probe's 2 (tricubic.comp's `Count`).
    pub fn reset(&self, rec: &mut crate::gpu::Recorder) {
        rec.fill(&self.count, 0, 8, 0);
        rec.fill(&self.count, 8, 8, 1);
        rec.fill(&self.count, Self::LIVE, 8, 0);
        rec.fill(&self.count, 24, 4, 2);
        rec.fill(&self.count, 28, 4, 0);
    }

    /// Records the start of a resuming round: no ray live yet.
    pub fn next_round(&self, rec: &mut crate::gpu::Recorder) {
        rec.fill(&self.count, Self::LIVE, 4, 0);
    }

    /// Records the copy of the counts for the host: [`Listed::counts`] once the submission is done.
    pub fn read_counts(&self, rec: &mut crate::gpu::Recorder) {
        rec.readback(&self.count, &self.readback, Self::COUNT_BYTES);
    }

    /// The counts [`Listed::read_counts`] copied.
    pub fn counts(&self) -> Result<Counts, GpuError> {
        let w = self.readback.read::<u32>(6)?;
        Ok(Counts { listed: w[0], live: w[4], lost: w[5] })
    }
}
