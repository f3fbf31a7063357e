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
//!   masks[brick]   MASK_WORDS words, one bit per cell (in Morton order: [`mask_cell`]): the
//!                  cell is a candidate (not missing, not clear of every isovalue), read only
//!                  where reach = 0; a 2³ or 4³ block of cells with no bit set is one jump
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

// The masks' Morton order and its 2³ and 4³ blocks are for bricks of 8³ cells.
const _: () = assert!(MASK_WORDS * 32 == BRICK * BRICK * BRICK && BRICK == 8);

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
                // Params, brick ranges, the previous axis's distances, this axis's, the axis.
                // Params is a storage buffer here (reach.comp says why).
                &[Binding::Read, Binding::Read, Binding::Read, Binding::Write, Binding::Read],
                0,
                &constants,
            )?,
            masks: ComputePipeline::with_constants(
                ctx,
                "occupancy masks",
                shaders::OCCUPANCY_MASKS,
                // Params (a storage buffer: reach.comp says why), grid points, brick ranges,
                // masks.
                &[Binding::Read, Binding::Read, Binding::Read, Binding::Write],
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
/// its brick min/max grid) for the isovalues of `params` (RenderParams, bound here as a storage
/// buffer: it needs `STORAGE_BUFFER` usage too), keyed `key`.
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
        // TRANSFER_SRC: tests read it back.
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
        Buffer::new(ctx, name, bytes, usage, MemoryLocation::GpuOnly)
    };
    let reach = buffer("occupancy distances", n_bricks * 4)?;
    let scratch = buffer("occupancy distances (axis)", n_bricks * 4)?;
    let masks = buffer("occupancy masks", n_bricks * MASK_WORDS as u64 * 4)?;
    // Axis 0 reads the ranges (its `src` is bound but not read), 1 reads 0's, 2 reads 1's:
    // reach -> scratch -> reach.
    let axis = Buffer::new(
        ctx,
        "occupancy axis",
        4,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuOnly,
    )?;
    let bind_axis = |src: &Buffer, dst: &Buffer| {
        pipelines.reach.bind(&[
            Resource::Storage(params),
            Resource::Storage(bricks),
            Resource::Storage(src),
            Resource::Storage(dst),
            Resource::Storage(&axis),
        ])
    };
    let axes =
        [bind_axis(&scratch, &reach)?, bind_axis(&reach, &scratch)?, bind_axis(&scratch, &reach)?];
    let mask_set = pipelines.masks.bind(&[
        Resource::Storage(params),
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
            for (a, set) in axes.iter().enumerate() {
                rec.fill(&axis, 0, 4, a as u32);
                rec.dispatch(&pipelines.reach, set, &[], groups);
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

/// The structure computed on the CPU for `grid` and `thresholds` (the surfaces' thresholds as
/// the shader gets them): every brick's distance and every mask word, in the device's layout,
/// with the masks of bricks clear of every isovalue left 0 (the device writes none for them).
/// The CPU twin of the build, bit for bit: the same f32 tests on the same brick ranges
/// ([`super::bricks::reference`]) and corners.
pub fn reference(grid: &crate::field::Grid, thresholds: &[f32]) -> (Vec<u32>, Vec<u32>) {
    use super::bricks::{clear_by, SKIP_MARGIN};
    let nb = brick_counts(grid.dims);
    let index = |b: [usize; 3]| (b[2] * nb[1] + b[1]) * nb[0] + b[0];
    let clear = |mm: [f32; 2]| thresholds.iter().all(|&iso| clear_by(mm, iso, SKIP_MARGIN));
    let ranges = super::bricks::reference(grid);
    let occupied: Vec<bool> = ranges.iter().map(|&mm| !clear(mm)).collect();
    let cells = grid.dims.map(|n| n - 1);
    let mut masks = vec![0u32; ranges.len() * MASK_WORDS];
    let mut reach = vec![0u32; ranges.len()];
    let r = REACH_CAP as i64;
    for bz in 0..nb[2] {
        for by in 0..nb[1] {
            for bx in 0..nb[0] {
                let i = index([bx, by, bz]);
                // The L-infinity distance to the nearest occupied brick, capped.
                let mut best = REACH_CAP + 1;
                for dz in -r..=r {
                    for dy in -r..=r {
                        for dx in -r..=r {
                            let n = [bx as i64 + dx, by as i64 + dy, bz as i64 + dz];
                            let inside = (0..3).all(|a| n[a] >= 0 && n[a] < nb[a] as i64);
                            if inside && occupied[index(n.map(|c| c as usize))] {
                                best = best.min(dx.abs().max(dy.abs()).max(dz.abs()) as u32);
                            }
                        }
                    }
                }
                reach[i] = best;
                if !occupied[i] {
                    continue;
                }
                for bit in 0..BRICK * BRICK * BRICK {
                    let l = mask_cell(bit);
                    let c = [bx * BRICK + l[0], by * BRICK + l[1], bz * BRICK + l[2]];
                    if (0..3).any(|a| c[a] >= cells[a]) {
                        continue;
                    }
                    let mut mm = [f32::INFINITY, f32::NEG_INFINITY];
                    let mut missing = false;
                    for k in 0..8 {
                        let v = grid.at(c[0] + (k & 1), c[1] + (k >> 1 & 1), c[2] + (k >> 2));
                        missing |= !v.is_finite();
                        mm = [mm[0].min(v), mm[1].max(v)];
                    }
                    if !missing && !clear(mm) {
                        masks[i * MASK_WORDS + bit / 32] |= 1 << (bit % 32);
                    }
                }
            }
        }
    }
    (reach, masks)
}

/// The cell (in its brick) of bit `m` of a brick's mask: the Morton order of its coordinates
/// (x0 y0 z0 x1 y1 z1 x2 y2 z2, lowest first), so that each 2³ block of cells is 8 consecutive
/// bits and each 4³ block two words, which the walk jumps when they are 0 (bricks.glsl's
/// `mask_bit`, `mask_cell`).
pub fn mask_cell(m: usize) -> [usize; 3] {
    let mut l = [0; 3];
    for k in 0..3 {
        for (a, c) in l.iter_mut().enumerate() {
            *c |= (m >> (3 * k + a) & 1) << k;
        }
    }
    l
}
