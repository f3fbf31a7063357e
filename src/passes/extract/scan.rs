//! The multi-level exclusive prefix sum of the extraction ([`Scan`]): `scan.comp` over blocks
//! of [`SCAN_BLOCK`] elements, the block sums scanned the same way level by level, then
//! `scan_add.comp` back down. The pipelines are [`ExtractPasses`]'; a [`Scan`] holds a
//! buffer's block-sum buffers and descriptor sets.

use std::sync::Arc;

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::pass::ExtractPasses;
use crate::gpu::{
    spread_groups, Buffer, ComputePipeline, Context, Dispatch, GpuError, MemoryLocation, Recorder,
    Resource,
};
use crate::shaders;

/// Elements scanned by one workgroup of `scan.comp` (64 invocations × 16).
pub const SCAN_BLOCK: u64 = shaders::consts::SCAN_BLOCK as u64;

/// Push constants of the scan passes (`Push` in `scan.comp` and `scan_add.comp`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ScanPush {
    pub groups_x: u32,
    pub count: u32,
}

/// An exclusive prefix sum, in place, over up to `capacity` u32 of one buffer: `scan.comp` on
/// blocks of [`SCAN_BLOCK`], the block sums scanned the same way level by level until one block
/// remains, then `scan add` back down. Holds the block-sum buffers and descriptor sets.
pub struct Scan {
    /// Block-sum buffers, level 1 up: held for the sets, which bind them.
    _levels: Vec<Buffer>,
    /// Per level: (scan set, add set) over (level l, level l + 1).
    sets: Vec<(Dispatch, Dispatch)>,
    capacity: u64,
}

impl Scan {
    pub fn new(
        ctx: &Arc<Context>,
        passes: &ExtractPasses,
        name: &str,
        data: &Buffer,
        capacity: u64,
    ) -> Result<Self, GpuError> {
        let mut levels = Vec::new();
        for len in level_lengths(capacity).into_iter().skip(1) {
            levels.push(Buffer::new(
                ctx,
                &format!("{name} block sums {}", levels.len() + 1),
                len * 4,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::GpuOnly,
            )?);
        }
        let mut sets = Vec::new();
        for l in 0..levels.len() {
            let lower = if l == 0 { data } else { &levels[l - 1] };
            let upper = &levels[l];
            let bind = [Resource::Storage(lower), Resource::Storage(upper)];
            sets.push((passes.scan.bind(&bind)?, passes.scan_add.bind(&bind)?));
        }
        Ok(Scan { _levels: levels, sets, capacity })
    }

    /// Records the scan of the first `len` elements (`len <= capacity`) of the buffer the scan
    /// was made for.
    pub fn record(
        &self,
        rec: &mut Recorder,
        passes: &ExtractPasses,
        len: u64,
    ) -> Result<(), GpuError> {
        if len > self.capacity {
            return Err(GpuError::Bug(format!(
                "scan of {len} elements exceeds its capacity {}",
                self.capacity
            )));
        }
        if len == 0 {
            return Ok(());
        }
        let lens = level_lengths(len);
        // Up: scan each level with more than one element, writing block sums one level up.
        for (l, &n) in lens[..lens.len() - 1].iter().enumerate() {
            Self::dispatch(rec, &passes.scan, &self.sets[l].0, n)?;
        }
        // Down: add the scanned sums of level l + 1 to level l (a single block's offset is 0).
        for l in (0..lens.len().saturating_sub(2)).rev() {
            Self::dispatch(rec, &passes.scan_add, &self.sets[l].1, lens[l])?;
        }
        Ok(())
    }

    /// One level: [`SCAN_BLOCK`] elements per workgroup, spread over x and y.
    fn dispatch(
        rec: &mut Recorder,
        pipeline: &ComputePipeline,
        set: &Dispatch,
        len: u64,
    ) -> Result<(), GpuError> {
        let groups = spread_groups(len.div_ceil(SCAN_BLOCK))?;
        let count = u32::try_from(len).map_err(|_| GpuError::TooLarge {
            what: format!("a scan of {len} elements"),
            limit: "32-bit counts".into(),
        })?;
        let push = ScanPush { groups_x: groups[0], count };
        let push = bytemuck::bytes_of(&push);
        rec.dispatch(pipeline, set, push, groups);
        Ok(())
    }
}

/// Element counts per scan level: `len`, then `ceil(previous / SCAN_BLOCK)` down to a single
/// element (always at least two levels, so even one element is scanned).
fn level_lengths(len: u64) -> Vec<u64> {
    let mut lens = vec![len];
    loop {
        let next = lens[lens.len() - 1].div_ceil(SCAN_BLOCK).max(1);
        lens.push(next);
        if next == 1 {
            return lens;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scan_levels_end_in_one_block() {
        assert_eq!(level_lengths(1), [1, 1]);
        assert_eq!(level_lengths(1024), [1024, 1]);
        assert_eq!(level_lengths(1025), [1025, 2, 1]);
        assert_eq!(level_lengths(1 << 30), [1 << 30, 1 << 20, 1 << 10, 1]);
    }
}
