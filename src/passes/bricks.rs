//! The min/max grid of empty-space skipping (`shaders/bricks.comp`): the grid's cells in bricks
//! of [`BRICK`]³, and for each brick the smallest and largest value at its (`BRICK` + 1)³ grid
//! points. The trilinear field in a brick's cells stays within that range, so the analytic walk
//! can cross a brick that is clearly on one side of the isovalue without looking at its cells
//! (`shaders/analytic.comp` says how that keeps images identical).
//!
//! Layout: one `vec2 (min, max)` per brick, x fastest, `ceil(cells / BRICK)` bricks per axis
//! (the last brick along an axis may be partial). Built once per uploaded grid, on the GPU,
//! from the grid image itself.

use std::sync::Arc;

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::gpu::{
    grid_groups, Buffer, Compute, ComputePipeline, Context, GpuError, Image3d, MemoryLocation,
    Resource, Timer, Tracker,
};
use crate::shaders;

/// Cells per brick edge.
pub const BRICK: usize = shaders::consts::BRICK as usize;

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

/// Bricks per axis of a grid with `dims` points.
pub fn brick_counts(dims: [usize; 3]) -> [usize; 3] {
    dims.map(|n| n.saturating_sub(1).max(1).div_ceil(BRICK))
}

/// The min/max grid computed on the CPU, in the buffer's layout: the test reference of
/// `bricks.comp`.
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
                            let v = grid.at(i, j, k);
                            mm = [mm[0].min(v), mm[1].max(v)];
                        }
                    }
                }
                out.push(mm);
            }
        }
    }
    out
}

pub fn pipeline(ctx: &Arc<Context>) -> Result<ComputePipeline, GpuError> {
    ComputePipeline::new(
        ctx,
        "bricks",
        shaders::BRICKS,
        &[vk::DescriptorType::COMBINED_IMAGE_SAMPLER, vk::DescriptorType::STORAGE_BUFFER],
        std::mem::size_of::<Shape>() as u32,
    )
}

/// Builds the min/max grid of `image` (a grid of `dims` points) into a new device buffer.
/// Returns the buffer and the GPU time of the pass in milliseconds, when timestamps exist.
pub fn build(
    ctx: &Arc<Context>,
    pipeline: &ComputePipeline,
    image: &Image3d,
    dims: [usize; 3],
) -> Result<(Buffer, Option<f64>), GpuError> {
    let counts = brick_counts(dims);
    let bricks = Buffer::new(
        ctx,
        "bricks",
        (counts.iter().product::<usize>() * 8) as u64,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::GpuOnly,
    )?;
    let set = pipeline.bind(&[Resource::Sampled(image), Resource::Storage(&bricks)])?;
    let shape = Shape {
        points: [dims[0] as i32, dims[1] as i32, dims[2] as i32, 0],
        bricks: [counts[0] as i32, counts[1] as i32, counts[2] as i32, BRICK as i32],
    };
    let timer = Timer::new(ctx)?;
    ctx.record(&pipeline.name, &mut Tracker::default(), |rec| {
        if let Some(t) = &timer {
            t.begin(rec.cmd());
        }
        // One invocation per brick, GROUP³ bricks per workgroup.
        let counts = counts.map(|c| c as u32);
        rec.dispatch(&Compute {
            pipeline,
            set: &set,
            push: bytemuck::bytes_of(&shape),
            groups: grid_groups(counts, [GROUP; 3]),
            reads: &[],
            writes: &[&bricks],
        });
        if let Some(t) = &timer {
            t.end(rec.cmd());
        }
        // The ray passes of later submissions read the bricks.
        rec.release();
        Ok(())
    })?;
    let ms = timer.as_ref().map(Timer::elapsed_ms).transpose()?;
    Ok((bricks, ms))
}
