//! The min/max grid of empty-space skipping (`shaders/bricks.comp`): the grid's cells in bricks
//! of [`BRICK`]³, and for each brick the smallest and largest value at its (`BRICK` + 1)³ grid
//! points. The trilinear field in a brick's cells stays within that range, so the analytic walk
//! can cross a brick that is clearly on one side of the isovalue without looking at its cells
//! (`shaders/analytic.comp` says how that keeps images identical).
//!
//! A second, coarser level makes long empty stretches one jump: superbricks of [`SUPER`]³
//! bricks, each with the smallest and largest of its bricks' ranges (`shaders/superbricks.comp`).
//!
//! Layout: one `vec2 (min, max)` per brick, x fastest, `ceil(cells / BRICK)` bricks per axis
//! (the last brick along an axis may be partial), then one per superbrick, x fastest,
//! `ceil(bricks / SUPER)` per axis ([`levels`]). Built once per uploaded grid, on the GPU, from
//! the grid image itself; for an MPI block or a brick pool, on the CPU from the brick ranges.

use std::sync::Arc;

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::field::interpolant::widen;
use crate::gpu::{
    grid_groups, Binding, Buffer, ComputePipeline, Context, GpuError, Image3d, MemoryLocation,
    Resource, Timer, Tracker,
};
use crate::shaders;

/// Cells per brick edge.
pub const BRICK: usize = shaders::consts::BRICK as usize;

/// Bricks per superbrick edge.
pub const SUPER: usize = shaders::consts::SUPER as usize;

// bricks.comp reads each brick's stencil with build.rs's numbers; they must be Rust's.
const _: () = assert!(
    shaders::consts::STENCIL_BELOW as usize == crate::field::interpolant::STENCIL.below
        && shaders::consts::STENCIL_ABOVE as usize == crate::field::interpolant::STENCIL.above
);

/// Workgroup size of `bricks.comp` along each axis.
const GROUP: u32 = shaders::consts::BRICKS_GROUP;

/// Push constants of `bricks.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Shape {
    /// xyz: grid points per axis.
    pub points: [i32; 4],
    /// xyz: bricks per axis, w: [`BRICK`].
    pub bricks: [i32; 4],
}

/// Push constants of `superbricks.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SuperShape {
    /// xyz: superbricks per axis, w: [`SUPER`].
    pub supers: [i32; 4],
    /// xyz: bricks per axis.
    pub bricks: [i32; 4],
}

/// Bricks per axis of a grid with `dims` points.
pub fn brick_counts(dims: [usize; 3]) -> [usize; 3] {
    dims.map(|n| n.saturating_sub(1).max(1).div_ceil(BRICK))
}

/// Superbricks per axis of a grid with `dims` points.
pub fn super_counts(dims: [usize; 3]) -> [usize; 3] {
    brick_counts(dims).map(|n| n.div_ceil(SUPER))
}

/// Both levels in the buffer's layout from the bricks' ranges (`bricks`, of a grid of `dims`
/// points): the bricks, then each superbrick's range, the smallest minimum and the largest
/// maximum of its bricks. The CPU twin of `superbricks.comp` (for MPI blocks and brick pools,
/// whose brick ranges come from the CPU) and its test reference.
pub fn levels(dims: [usize; 3], bricks: &[[f32; 2]]) -> Vec<[f32; 2]> {
    let counts = brick_counts(dims);
    let supers = super_counts(dims);
    let mut out = bricks.to_vec();
    for sz in 0..supers[2] {
        for sy in 0..supers[1] {
            for sx in 0..supers[0] {
                let mut mm = [f32::INFINITY, f32::NEG_INFINITY];
                for bz in sz * SUPER..((sz + 1) * SUPER).min(counts[2]) {
                    for by in sy * SUPER..((sy + 1) * SUPER).min(counts[1]) {
                        for bx in sx * SUPER..((sx + 1) * SUPER).min(counts[0]) {
                            let b = bricks[(bz * counts[1] + by) * counts[0] + bx];
                            mm = [mm[0].min(b[0]), mm[1].max(b[1])];
                        }
                    }
                }
                out.push(mm);
            }
        }
    }
    out
}

/// The bricks' min/max grid computed on the CPU, in the buffer's layout (without the
/// superbricks: [`levels`] adds them): the test reference of `bricks.comp`.
pub fn reference(grid: &crate::field::Grid) -> Vec<[f32; 2]> {
    let counts = brick_counts(grid.dims);
    let mut out = Vec::with_capacity(counts.iter().product());
    for bz in 0..counts[2] {
        for by in 0..counts[1] {
            for bx in 0..counts[0] {
                let lo = [bx, by, bz].map(|b| b * BRICK);
                let hi: Vec<usize> =
                    (0..3).map(|a| (lo[a] + BRICK).min(grid.dims[a] - 1)).collect();
                let mut mm = [f32::INFINITY, f32::NEG_INFINITY];
                for k in lo[2]..=hi[2] {
                    for j in lo[1]..=hi[1] {
                        for i in lo[0]..=hi[0] {
                            widen(&mut mm, grid.at(i, j, k));
                        }
                    }
                }
                out.push(mm);
            }
        }
    }
    out
}

/// The two passes that build the levels.
pub struct Pipelines {
    bricks: ComputePipeline,
    supers: ComputePipeline,
}

pub fn pipelines(ctx: &Arc<Context>) -> Result<Pipelines, GpuError> {
    Ok(Pipelines {
        bricks: ComputePipeline::new(
            ctx,
            "bricks",
            shaders::BRICKS,
            &[Binding::Sampled, Binding::Write],
            std::mem::size_of::<Shape>() as u32,
        )?,
        supers: ComputePipeline::new(
            ctx,
            "superbricks",
            shaders::SUPERBRICKS,
            // Reads the bricks' ranges, writes the superbricks' (one buffer).
            &[Binding::ReadWrite],
            std::mem::size_of::<SuperShape>() as u32,
        )?,
    })
}

/// The min/max grid on the device, with a host copy of its superbricks' ranges (a few KiB) for
/// the renderer's choice of levels ([`levels_for`]).
pub struct Built {
    pub buffer: Buffer,
    pub supers: Vec<[f32; 2]>,
    /// GPU time of the passes in milliseconds, when timestamps exist.
    pub ms: Option<f64>,
}

/// Builds both levels of the min/max grid of `image` (a grid of `dims` points) into a new
/// device buffer.
pub fn build(
    ctx: &Arc<Context>,
    pipelines: &Pipelines,
    image: &Image3d,
    dims: [usize; 3],
) -> Result<Built, GpuError> {
    let counts = brick_counts(dims);
    let supers = super_counts(dims);
    let n_bricks = counts.iter().product::<usize>();
    let n_supers = supers.iter().product::<usize>();
    let entries = n_bricks + n_supers;
    let host = Buffer::new(
        ctx,
        "superbricks readback",
        (n_supers * 8) as u64,
        vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuToCpu,
    )?;
    let bricks = Buffer::new(
        ctx,
        "bricks",
        (entries * 8) as u64,
        // TRANSFER_SRC: the superbricks' ranges are copied back to the host.
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
    )?;
    let pipeline = &pipelines.bricks;
    let set = pipeline.bind(&[Resource::Sampled(image), Resource::Storage(&bricks)])?;
    let super_set = pipelines.supers.bind(&[Resource::Storage(&bricks)])?;
    let i = |v: [usize; 3], w: usize| [v[0] as i32, v[1] as i32, v[2] as i32, w as i32];
    let shape = Shape { points: i(dims, 0), bricks: i(counts, BRICK) };
    let super_shape = SuperShape { supers: i(supers, SUPER), bricks: i(counts, 0) };
    let timer = Timer::new(ctx)?;
    ctx.record(&pipeline.name, &mut Tracker::default(), |rec| {
        rec.timed(timer.as_ref(), |rec| {
            // One invocation per brick, GROUP³ bricks per workgroup.
            let groups = grid_groups(counts.map(|c| c as u32), [GROUP; 3]);
            rec.dispatch(pipeline, &set, bytemuck::bytes_of(&shape), groups);
            // Then one per superbrick, reading the bricks' ranges the first pass wrote.
            let groups = grid_groups(supers.map(|c| c as u32), [GROUP; 3]);
            rec.dispatch(&pipelines.supers, &super_set, bytemuck::bytes_of(&super_shape), groups);
            Ok(())
        })?;
        rec.copy(&bricks, (n_bricks * 8) as u64, &host, 0, (n_supers * 8) as u64);
        rec.host_read(&host);
        // The ray passes of later submissions read the bricks.
        rec.release();
        Ok(())
    })?;
    let ms = timer.as_ref().map(Timer::elapsed_ms).transpose()?;
    Ok(Built { supers: host.read(n_supers)?, buffer: bricks, ms })
}

/// The levels of the min/max grid the analytic walk should jump with for `thresholds` (the
/// surfaces' thresholds as the shader gets them), given the superbricks' ranges: 2 when at least
/// one superbrick in [`SPARSE`] is empty (the shader's `range_is_empty`, same f32 arithmetic),
/// else 1. Only a matter of speed, never of the image: the superbrick jump costs llvmpipe about
/// 15% on grids with no empty superbrick (its code in the walk's loop, even unused: docs/methods.md
/// "Exact ray tracing"), and saves up to 40% where most are empty.
pub fn levels_for(supers: &[[f32; 2]], thresholds: &[f32]) -> u32 {
    let empty = supers.iter().filter(|mm| range_is_empty(**mm, thresholds)).count();
    if !supers.is_empty() && empty * SPARSE >= supers.len() {
        2
    } else {
        1
    }
}

/// One superbrick in this many empty makes the second level worth its cost (docs/methods.md "Exact ray tracing").
pub const SPARSE: usize = 8;

/// The analytic walk's skipping margin (`SKIP_MARGIN` in `shaders/include/bricks.glsl`, which says
/// why 2^-10): a range is clear of an isovalue by this, relative to the magnitudes involved.
pub const SKIP_MARGIN: f32 = 1.0 / 1024.0;

/// Whether every value in `mm` is clearly on one side of threshold `iso`: by `margin` times
/// the magnitudes involved, in the shader's f32 arithmetic.
pub fn clear_by(mm: [f32; 2], iso: f32, margin: f32) -> bool {
    let tol = margin * (mm[0].abs().max(mm[1].abs()) + iso.abs());
    mm[0] - iso > tol || iso - mm[1] > tol
}

/// The shader's `range_is_empty`: whether `mm` is clear of every threshold.
fn range_is_empty(mm: [f32; 2], thresholds: &[f32]) -> bool {
    thresholds.iter().all(|&iso| clear_by(mm, iso, SKIP_MARGIN))
}
