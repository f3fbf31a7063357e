//! The occupancy structure: the analytic walk's acceleration structure over the cells that may
//! hold a surface (`shaders/occupancy/`), built on the GPU per grid and set of isovalues, kept
//! with the uploaded grid until the isovalues change.
//!
//! The plain walk pays per cell it crosses: a brick range read and 8 corner reads for every
//! cell of a brick that may hold a surface, and one jump per empty brick. This structure keeps
//! two things in the layout of the brick min/max grid ([`super::bricks`], bricks of
//! [`BRICK`]³ cells), the same shape as OpenVDB's leaf nodes with their value masks:
//!
//! ```text
//!   reach[brick]   0: the brick may hold a surface (its range is not clear of every isovalue)
//!                  r: empty, and so is every brick up to r - 1 away on each axis (L-infinity,
//!                     capped at REACH_CAP + 1): the walk crosses that cube of bricks in one jump
//!   masks[brick]   MASK_WORDS words, one bit per cell (x + BRICK (y + BRICK z)): the cell is a
//!                  candidate (not missing, not clear of every isovalue), read only where
//!                  reach = 0
//!
//!    . . . . . . .        reach of a row of bricks around two that may hold a surface (#):
//!    3 2 1 # 1 1 # 1 2    the walk in brick "3" jumps over 5 bricks at once
//! ```
//!
//! `shaders/analytic.comp` (`OCCUPANCY`) walks with it: a cell is evaluated when its bit is set,
//! which is exactly the plain walk's test on the same corners (the mask pass calls the walk's own
//! functions), and a jump lands where the cell-by-cell walk is when it leaves the cube
//! (`bricks.glsl`'s `leave_block`). So the image is the plain walk's bit for bit; only `steps`
//! counts the work this walk does (cells walked and jumps made).
//!
//! The build: one pass of masks (one invocation per mask word, 32 cells) and three of distances
//! (one per axis, a windowed minimum whose composition is the L-infinity distance), all device
//! work, timed and counted in the render that builds it.

use std::sync::Arc;

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::analytic::Walk;
use super::bricks::{brick_counts, BRICK};
use crate::gpu::{
    spread_groups, Binding, Buffer, ComputePipeline, Context, GpuError, MemoryLocation, Resource,
    Timer, Tracker,
};
use crate::shaders;

/// Invocations per workgroup of the passes.
pub const GROUP: u32 = shaders::consts::OCCUPANCY_GROUP;

/// Words of a brick's cell mask.
pub const MASK_WORDS: usize = shaders::consts::MASK_WORDS as usize;

/// The largest distance the structure resolves, in bricks.
pub const REACH_CAP: u32 = shaders::consts::REACH_CAP;

const _: () = assert!(MASK_WORDS * 32 == BRICK * BRICK * BRICK && 32 % BRICK == 0);

/// The distance passes' push constants.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
struct Axis {
    axis: i32,
}

/// The passes, for one surface count (their `range_is_empty` and cell tests loop over
/// `SURFACE_COUNT`, a specialization constant as in the walk).
pub struct Pipelines {
    reach: ComputePipeline,
    masks: ComputePipeline,
}

impl Pipelines {
    pub fn new(ctx: &Arc<Context>, walk: Walk) -> Result<Self, GpuError> {
        let constants = [1, walk.surfaces];
        Ok(Pipelines {
            reach: ComputePipeline::with_constants(
                ctx,
                "occupancy distances",
                shaders::OCCUPANCY_REACH,
                // Params, brick ranges, the previous axis's distances, this axis's.
                &[Binding::Uniform, Binding::Read, Binding::Read, Binding::Write],
                std::mem::size_of::<Axis>() as u32,
                &constants,
            )?,
            masks: ComputePipeline::with_constants(
                ctx,
                "occupancy masks",
                shaders::OCCUPANCY_MASKS,
                // Params, grid points, brick ranges, masks.
                &[Binding::Uniform, Binding::Read, Binding::Read, Binding::Write],
                0,
                &constants,
            )?,
        })
    }
}

/// The structure on the device, for the isovalues of [`Occupancy::key`].
pub struct Occupancy {
    /// Per brick, its distance (u32).
    pub reach: Buffer,
    /// Per brick, [`MASK_WORDS`] words.
    pub masks: Buffer,
    /// What it was built for: the surfaces' thresholds as the shader gets them (bits).
    pub key: Vec<u32>,
    /// GPU time of the build in milliseconds, when timestamps exist.
    pub ms: Option<f64>,
}

/// The key of a structure for `thresholds` (the surfaces' inside thresholds, f32).
pub fn key(thresholds: &[f32]) -> Vec<u32> {
    thresholds.iter().map(|t| t.to_bits()).collect()
}

/// Builds the structure of the grid of `dims` points (`points`: its values, x fastest; `bricks`:
/// its brick min/max grid) for the isovalues of `params` (RenderParams, uniform), keyed `key`.
pub fn build(
    ctx: &Arc<Context>,
    pipelines: &Pipelines,
    params: &Buffer,
    points: &Buffer,
    bricks: &Buffer,
    dims: [usize; 3],
    key: Vec<u32>,
) -> Result<Occupancy, GpuError> {
    let n_bricks = brick_counts(dims).iter().product::<usize>() as u64;
    let buffer = |name: &str, bytes: u64| {
        Buffer::new(ctx, name, bytes, vk::BufferUsageFlags::STORAGE_BUFFER, MemoryLocation::GpuOnly)
    };
    let reach = buffer("occupancy distances", n_bricks * 4)?;
    let scratch = buffer("occupancy distances (axis)", n_bricks * 4)?;
    let masks = buffer("occupancy masks", n_bricks * MASK_WORDS as u64 * 4)?;
    // Axis 0 reads the ranges (its `src` is bound but not read), 1 reads 0's, 2 reads 1's:
    // reach -> scratch -> reach.
    let bind_axis = |src: &Buffer, dst: &Buffer| {
        pipelines.reach.bind(&[
            Resource::Uniform(params),
            Resource::Storage(bricks),
            Resource::Storage(src),
            Resource::Storage(dst),
        ])
    };
    let axes =
        [bind_axis(&scratch, &reach)?, bind_axis(&reach, &scratch)?, bind_axis(&scratch, &reach)?];
    let mask_set = pipelines.masks.bind(&[
        Resource::Uniform(params),
        Resource::Storage(points),
        Resource::Storage(bricks),
        Resource::Storage(&masks),
    ])?;
    let timer = Timer::new(ctx)?;
    ctx.record("occupancy", &mut Tracker::default(), |rec| {
        rec.timed(timer.as_ref(), |rec| {
            let groups = spread_groups((n_bricks * MASK_WORDS as u64).div_ceil(GROUP as u64))?;
            rec.dispatch(&pipelines.masks, &mask_set, &[], groups);
            let groups = spread_groups(n_bricks.div_ceil(GROUP as u64))?;
            for (axis, set) in axes.iter().enumerate() {
                let push = Axis { axis: axis as i32 };
                rec.dispatch(&pipelines.reach, set, bytemuck::bytes_of(&push), groups);
            }
            Ok(())
        })?;
        // The ray passes of later submissions read it.
        rec.release();
        Ok(())
    })?;
    let ms = timer.as_ref().map(Timer::elapsed_ms).transpose()?;
    Ok(Occupancy { reach, masks, key, ms })
}

/// The rays the two-pass walk lists per band (analytic.comp's `OCC_SKIP`): two `uvec4` each,
/// then their count and the resuming pass's indirect dispatch.
pub struct Listed {
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
