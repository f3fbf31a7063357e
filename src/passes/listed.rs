//! Rays one pass lists for a later pass to go on from: the two-pass analytic walk's (analytic.comp's
//! `OCC_SKIP` lists the rays that meet a brick that may hold a surface, `OCC_RESUME` walks
//! them, dispatched indirectly).

use std::sync::Arc;

use ash::vk;

use crate::gpu::{Buffer, Context, GpuError, MemoryLocation};

/// The rays the two-pass walk lists per band (analytic.comp's `OCC_SKIP`): two `uvec4` each,
/// then their count and the resuming pass's indirect dispatch.
pub struct Listed {
    /// Pixels of the largest band it has room for.
    pub band_pixels: u64,
    pub rays: Buffer,
    /// `count`, then the resuming pass's `VkDispatchIndirectCommand` at [`Listed::ARGS`].
    pub count: Buffer,
}

impl Listed {
    /// Where the resuming pass's workgroup counts are in [`Listed::count`].
    pub const ARGS: u64 = 4;

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
                16,
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::INDIRECT_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuOnly,
            )?,
        })
    }

    /// Records the reset before a band: no ray listed, no workgroup (x = 0; y = z = 1).
    pub fn reset(&self, rec: &mut crate::gpu::Recorder) {
        rec.fill(&self.count, 0, 8, 0);
        rec.fill(&self.count, 8, 8, 1);
    }
}
