//! The min/max grid of empty-space skipping (`shaders/bricks.comp`): the grid's cells in bricks
//! of [`BRICK`]³, and for each brick the smallest and largest value at its (`BRICK` + 1)³ grid
//! points. The trilinear field in a brick's cells stays within that range, so the analytic walk
//! can cross a brick that is clearly on one side of the isovalue without looking at its cells
//! (`shaders/analytic.comp` says how that keeps images identical).
//!
//! A second, coarser level makes long empty stretches one jump: superbricks of [`SUPER`]³
//! bricks, each with the smallest and largest of its bricks' ranges (`shaders/superbricks.comp`).
//!
//! The tricubic interpolants' walk (`shaders/tricubic.comp`) skips with ranges of its own
//! ([`Bound`]): over the points its cells' 4×4×4 stencils read (one point below a brick's cells
//! and two above), which bound the cubic B-spline (a convex combination of them); Catmull-Rom
//! overshoots them, by at most `KAPPA` (37/54) times their spread on each side
//! (`field::interpolant::cubic`'s "Bounds"), so its ranges are widened by that. The nearest
//! interpolant's voxel walk reads [`Bound::Corners`]' grid (`shaders/voxels.comp` says why it
//! covers a voxel brick's samples).
//!
//! Layout: one `vec2 (min, max)` per brick, x fastest, `ceil(cells / BRICK)` bricks per axis
//! (the last brick along an axis may be partial), then one per superbrick, x fastest,
//! `ceil(bricks / SUPER)` per axis ([`levels`]). The tricubic grids then have a finer level,
//! fine bricks of [`FINE`]³ cells, x fastest, `ceil(cells / FINE)` per axis, with the same
//! bound as their bricks: the walk's test of a cell in a brick that is not empty, one range
//! read instead of its 64 samples (`shaders/tricubic.comp`). Built once per uploaded grid, on the GPU, from
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

/// Cells per fine brick edge (the tricubic grids' finer level).
pub const FINE: usize = shaders::consts::FINE as usize;

// bricks.comp reads each brick's stencil with build.rs's numbers; they must be Rust's.
const _: () = assert!(
    shaders::consts::STENCIL_BELOW as usize == crate::field::interpolant::STENCIL.below
        && shaders::consts::STENCIL_ABOVE as usize == crate::field::interpolant::STENCIL.above
);

// The cubic variants of bricks.comp read the tricubic stencil, and widen by Catmull-Rom's bound.
const _: () = {
    use crate::field::interpolant::{cubic, Kernel};
    let s = <cubic::BSpline as Kernel>::STENCIL;
    assert!(
        shaders::consts::CUBIC_STENCIL_BELOW as usize == s.below
            && shaders::consts::CUBIC_STENCIL_ABOVE as usize == s.above
    );
};

/// What a brick's range bounds: the samples it covers and how far the interpolant may leave
/// their range.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Bound {
    /// The (BRICK + 1)³ corners of the brick's cells: trilinear's walk, and nearest's voxel walk.
    Corners,
    /// The (BRICK + 3)³ points of the brick's cells' 4×4×4 stencils: the cubic B-spline.
    Cubic,
    /// Those, widened by Catmull-Rom's overshoot bound ([`kappa`]).
    CatmullRom,
}

impl Bound {
    /// The stencil the ranges cover.
    pub fn stencil(self) -> crate::field::interpolant::Stencil {
        use crate::field::interpolant::{cubic, Kernel};
        match self {
            Bound::Corners => crate::field::interpolant::STENCIL,
            Bound::Cubic | Bound::CatmullRom => <cubic::BSpline as Kernel>::STENCIL,
        }
    }

    /// The widening factor in units of the range's width: 0, or [`kappa`].
    pub fn widening(self) -> f32 {
        match self {
            Bound::Corners | Bound::Cubic => 0.0,
            Bound::CatmullRom => kappa(),
        }
    }

    /// Its build of `bricks.comp` and the pass's name.
    fn shader(self) -> (&'static str, &'static [u8]) {
        match self {
            Bound::Corners => ("bricks", shaders::BRICKS),
            Bound::Cubic => ("bricks (cubic stencil)", shaders::BRICKS_CUBIC),
            Bound::CatmullRom => ("bricks (catmull-rom, widened)", shaders::BRICKS_CATMULL_ROM),
        }
    }
}

/// Catmull-Rom's overshoot bound as the shaders have it (`CATMULL_ROM_KAPPA_BITS`): 37/54
/// rounded up to f32, so never below `cubic::CatmullRomWeights::KAPPA`.
pub fn kappa() -> f32 {
    f32::from_bits(shaders::consts::CATMULL_ROM_KAPPA_BITS)
}

/// `[m, M]` widened by `k (M - m)` on each side in f32, as `bricks.comp`'s BRICKS_WIDEN
/// (`precise`) computes it; `[inf, -inf]` stays itself.
pub fn widen_range([lo, hi]: [f32; 2], k: f32) -> [f32; 2] {
    if k == 0.0 {
        return [lo, hi];
    }
    let spread = k * (hi - lo);
    [lo - spread, hi + spread]
}

/// Workgroup size of `bricks.comp` along each axis.
const GROUP: u32 = shaders::consts::BRICKS_GROUP;

/// Push constants of `bricks.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Shape {
    /// xyz: grid points per axis, w: the index of the level's first range in the buffer.
    pub points: [i32; 4],
    /// xyz: bricks per axis, w: cells per brick edge ([`BRICK`], or [`FINE`]).
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
    counts_of(dims, BRICK)
}

/// Fine bricks per axis of a grid with `dims` points.
pub fn fine_counts(dims: [usize; 3]) -> [usize; 3] {
    counts_of(dims, FINE)
}

/// Blocks of `size`³ cells per axis of a grid with `dims` points.
fn counts_of(dims: [usize; 3], size: usize) -> [usize; 3] {
    dims.map(|n| n.saturating_sub(1).max(1).div_ceil(size))
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
    reference_for(grid, Bound::Corners)
}

/// The bricks' ranges of [`Bound::Corners`] ([`reference`]'s, bit for bit), computed on all
/// `rayon` threads a slab of bricks at a time, each point row's minimum and maximum per brick
/// taken once: what a render on a CPU device (lavapipe) builds instead of running
/// `bricks.comp` (about 10× faster there: llvmpipe reads each of a brick's (BRICK + 1)³ points
/// through a gather). Missing samples are left out ([`widen`]).
pub fn ranges_threaded(grid: &crate::field::Grid) -> Vec<[f32; 2]> {
    use rayon::prelude::*;
    let counts = brick_counts(grid.dims);
    let [nx, ny, nz] = grid.dims;
    // The bricks whose points include index i along an axis of n points: i / BRICK, and the
    // one before when i is on a brick boundary (its last point), within the bricks.
    let owners = |i: usize, count: usize| {
        let b = (i / BRICK).min(count - 1);
        let before = (i % BRICK == 0 && i > 0 && i / BRICK <= count).then(|| i / BRICK - 1);
        std::iter::once(b).chain(before.filter(|&p| p != b))
    };
    let slabs: Vec<Vec<[f32; 2]>> = (0..counts[2])
        .into_par_iter()
        .map(|bz| {
            let mut slab = vec![[f32::INFINITY, f32::NEG_INFINITY]; counts[0] * counts[1]];
            let mut row_ranges = vec![[f32::INFINITY, f32::NEG_INFINITY]; counts[0]];
            let z0 = bz * BRICK;
            for k in z0..=(z0 + BRICK).min(nz - 1) {
                for j in 0..ny {
                    let row = &grid.values[(k * ny + j) * nx..][..nx];
                    for (bx, mm) in row_ranges.iter_mut().enumerate() {
                        let x0 = bx * BRICK;
                        *mm = [f32::INFINITY, f32::NEG_INFINITY];
                        for &v in &row[x0..=(x0 + BRICK).min(nx - 1)] {
                            widen(mm, v);
                        }
                    }
                    for by in owners(j, counts[1]) {
                        let line = &mut slab[by * counts[0]..][..counts[0]];
                        for (mm, r) in line.iter_mut().zip(&row_ranges) {
                            *mm = [mm[0].min(r[0]), mm[1].max(r[1])];
                        }
                    }
                }
            }
            slab
        })
        .collect();
    slabs.concat()
}

/// [`reference`] for any [`Bound`]: the CPU twin of each build of `bricks.comp`, bit for bit
/// (the reference walks count `steps` with it: `reference::skipping`).
pub fn reference_for(grid: &crate::field::Grid, bound: Bound) -> Vec<[f32; 2]> {
    reference_sized(grid, bound, BRICK)
}

/// The fine level of a tricubic grid ([`FINE`]) computed on the CPU, in its layout: the CPU
/// twin of the build's last pass.
pub fn fine_reference_for(grid: &crate::field::Grid, bound: Bound) -> Vec<[f32; 2]> {
    reference_sized(grid, bound, FINE)
}

/// The ranges of `bound` over blocks of `size`³ cells, x fastest.
fn reference_sized(grid: &crate::field::Grid, bound: Bound, size: usize) -> Vec<[f32; 2]> {
    let counts = counts_of(grid.dims, size);
    let stencil = bound.stencil();
    let mut out = Vec::with_capacity(counts.iter().product());
    for bz in 0..counts[2] {
        for by in 0..counts[1] {
            for bx in 0..counts[0] {
                let span = |a: usize, b: usize| stencil.brick_points(b, size, grid.dims[a]);
                let mut mm = [f32::INFINITY, f32::NEG_INFINITY];
                for k in span(2, bz) {
                    for j in span(1, by) {
                        for i in span(0, bx) {
                            widen(&mut mm, grid.at(i, j, k));
                        }
                    }
                }
                out.push(widen_range(mm, bound.widening()));
            }
        }
    }
    out
}

/// The passes that build the levels: each [`Bound`]'s bricks, then the superbricks.
pub struct Pipelines {
    bricks: ComputePipeline,
    cubic: ComputePipeline,
    catmull_rom: ComputePipeline,
    supers: ComputePipeline,
}

pub fn pipelines(ctx: &Arc<Context>) -> Result<Pipelines, GpuError> {
    let bricks = |bound: Bound| {
        let (name, spirv) = bound.shader();
        ComputePipeline::new(
            ctx,
            name,
            spirv,
            &[Binding::Sampled, Binding::Write],
            std::mem::size_of::<Shape>() as u32,
        )
    };
    Ok(Pipelines {
        bricks: bricks(Bound::Corners)?,
        cubic: bricks(Bound::Cubic)?,
        catmull_rom: bricks(Bound::CatmullRom)?,
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

/// Builds both levels of the min/max grid of `image` (a grid of `dims` points) with the
/// ranges of `bound` into a new device buffer.
pub fn build(
    ctx: &Arc<Context>,
    pipelines: &Pipelines,
    image: &Image3d,
    dims: [usize; 3],
    bound: Bound,
) -> Result<Built, GpuError> {
    let counts = brick_counts(dims);
    let supers = super_counts(dims);
    let fine = fine_counts(dims);
    let n_bricks = counts.iter().product::<usize>();
    let n_supers = supers.iter().product::<usize>();
    // Only the tricubic walks read a fine level.
    let n_fine = if bound == Bound::Corners { 0 } else { fine.iter().product::<usize>() };
    let entries = n_bricks + n_supers + n_fine;
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
    let pipeline = match bound {
        Bound::Corners => &pipelines.bricks,
        Bound::Cubic => &pipelines.cubic,
        Bound::CatmullRom => &pipelines.catmull_rom,
    };
    let set = pipeline.bind(&[Resource::Sampled(image), Resource::Storage(&bricks)])?;
    let super_set = pipelines.supers.bind(&[Resource::Storage(&bricks)])?;
    let i = |v: [usize; 3], w: usize| [v[0] as i32, v[1] as i32, v[2] as i32, w as i32];
    let shape = Shape { points: i(dims, 0), bricks: i(counts, BRICK) };
    let super_shape = SuperShape { supers: i(supers, SUPER), bricks: i(counts, 0) };
    let fine_shape = Shape { points: i(dims, n_bricks + n_supers), bricks: i(fine, FINE) };
    let timer = Timer::new(ctx)?;
    ctx.record(&pipeline.name, &mut Tracker::default(), |rec| {
        rec.timed(timer.as_ref(), |rec| {
            // One invocation per brick, GROUP³ bricks per workgroup.
            let groups = grid_groups(counts.map(|c| c as u32), [GROUP; 3]);
            rec.dispatch(pipeline, &set, bytemuck::bytes_of(&shape), groups);
            // Then one per superbrick, reading the bricks' ranges the first pass wrote.
            let groups = grid_groups(supers.map(|c| c as u32), [GROUP; 3]);
            rec.dispatch(&pipelines.supers, &super_set, bytemuck::bytes_of(&super_shape), groups);
            if n_fine > 0 {
                // Then the fine bricks, after the superbricks (the same pass, other blocks).
                let groups = grid_groups(fine.map(|c| c as u32), [GROUP; 3]);
                rec.dispatch(pipeline, &set, bytemuck::bytes_of(&fine_shape), groups);
            }
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
