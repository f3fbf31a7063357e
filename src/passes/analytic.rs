//! Exact ray tracing (`shaders/analytic.comp`): one invocation per pixel of a band of rows,
//! writing one `Pixel` each. The algorithm is `reference::analytic`'s (its module doc is the
//! specification), ported to f32 step for step; the shader's header lists where f32 needs care.
//!
//! Bindings: the ray passes' four ([`RAY_BINDINGS`](super::raymarch::RAY_BINDINGS)), then the
//! brick min/max grid of empty-space skipping ([`super::bricks`]). Push constants: the band.
//! Three builds of the shader: the grid as a storage buffer ([`buffer_pipeline`], a whole grid:
//! the default), as the grid image ([`pipeline`], an MPI rank's block or a grid over the
//! device's storage buffer range), as a brick pool ([`pool_pipeline`]). Each is specialized for
//! one [`Walk`] (the shader's specialization constants): the renderer builds the ones its
//! renders need.

use std::sync::Arc;

use crate::gpu::{Binding, ComputePipeline, Context, GpuError};
use crate::shaders;

/// Params, grid, pixels (written), colormap, bricks.
pub const BINDINGS: [Binding; 5] =
    [Binding::Uniform, Binding::Sampled, Binding::Write, Binding::Read, Binding::Read];

pub fn pipeline(ctx: &Arc<Context>, walk: Walk) -> Result<ComputePipeline, GpuError> {
    build(ctx, "analytic (image)", shaders::ANALYTIC, &BINDINGS, walk)
}

/// What the analytic shader is specialized for: its specialization constants, folded in by the
/// driver, so that the walk's loop carries no code for what a render does not use (llvmpipe pays
/// for code in a loop body whether it runs or not: docs/methods.md "How the walk is laid out for speed").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Walk {
    /// `BRICK_LEVELS`: the levels of the min/max grid the walk jumps with, 1 (bricks) or 2 (and
    /// superbricks).
    pub levels: u32,
    /// `SURFACE_COUNT`: the surfaces (isovalues), 1 to `SURFACES`; `RenderParams.surfaces`.
    pub surfaces: u32,
}

/// One build of the shader, specialized for `walk` (the other interpolants' walks too, which
/// include the same brick helpers: `voxels`, `tricubic`).
pub(super) fn build(
    ctx: &Arc<Context>,
    name: &str,
    spirv: &[u8],
    bindings: &[Binding],
    walk: Walk,
) -> Result<ComputePipeline, GpuError> {
    ComputePipeline::with_constants(
        ctx,
        name,
        spirv,
        bindings,
        std::mem::size_of::<super::Band>() as u32,
        &[walk.levels, walk.surfaces],
    )
}

/// The `GRID_POOL` variant (`field.residency = "active"`; bindings
/// [`POOL_BINDINGS`](super::raymarch::POOL_BINDINGS)).
pub fn pool_pipeline(ctx: &Arc<Context>, walk: Walk) -> Result<ComputePipeline, GpuError> {
    build(
        ctx,
        "analytic (brick pool)",
        shaders::ANALYTIC_POOL,
        &super::raymarch::POOL_BINDINGS,
        walk,
    )
}

/// Bindings of the `GRID_BUFFER` variant: as [`BINDINGS`] with the grid as a storage buffer.
pub const BUFFER_BINDINGS: [Binding; 5] =
    [Binding::Uniform, Binding::Read, Binding::Write, Binding::Read, Binding::Read];

/// The `GRID_BUFFER` variant, the default for a whole grid: the grid's points in a storage
/// buffer (a device copy of its image), which llvmpipe reads with far fewer instructions than
/// a texelFetch (docs/benchmarks.md).
pub fn buffer_pipeline(ctx: &Arc<Context>, walk: Walk) -> Result<ComputePipeline, GpuError> {
    build(ctx, "analytic", shaders::ANALYTIC_BUFFER, &BUFFER_BINDINGS, walk)
}

/// Bindings of the `OCCUPANCY` variant: [`BUFFER_BINDINGS`], then the occupancy structure's
/// distances and masks ([`super::occupancy`]).
pub const OCCUPANCY_BINDINGS: [Binding; 7] = extended(BUFFER_BINDINGS, Binding::Read);

/// The `GRID_BUFFER` variant walking with the occupancy structure ([`super::occupancy`]) in one
/// pass (on a device without subgroup ballots; else [`occupancy_pipelines`]).
pub fn occupancy_pipeline(ctx: &Arc<Context>, walk: Walk) -> Result<ComputePipeline, GpuError> {
    build(ctx, "analytic (occupancy)", shaders::ANALYTIC_OCCUPANCY, &OCCUPANCY_BINDINGS, walk)
}

/// Bindings of the two-pass variants: [`OCCUPANCY_BINDINGS`], then the listed rays and their
/// count ([`super::listed::Listed`]).
pub const LISTED_BINDINGS: [Binding; 9] = extended(OCCUPANCY_BINDINGS, Binding::ReadWrite);

/// `bindings` and then `M - N` more bindings, each `more`.
const fn extended<const N: usize, const M: usize>(
    bindings: [Binding; N],
    more: Binding,
) -> [Binding; M] {
    let mut out = [more; M];
    let mut i = 0;
    while i < N {
        out[i] = bindings[i];
        i += 1;
    }
    out
}

/// The walk with the occupancy structure in two passes (`OCC_SKIP`, then `OCC_RESUME`: every
/// pixel's empty bricks from its ray's start, then the walk of the rays that met a brick that
/// may hold a surface, dispatched indirectly; analytic.comp says why): the first.
pub fn skip_pipeline(ctx: &Arc<Context>, walk: Walk) -> Result<ComputePipeline, GpuError> {
    build(ctx, "analytic (empty bricks)", shaders::ANALYTIC_OCCUPANCY_SKIP, &SKIP_BINDINGS, walk)
}

/// The first pass's bindings: [`LISTED_BINDINGS`] with Params as a storage buffer (it is
/// compiled once: analytic.comp says why).
pub const SKIP_BINDINGS: [Binding; 9] = {
    let mut b = LISTED_BINDINGS;
    b[0] = Binding::Read;
    b
};

/// The second pass of the two ([`skip_pipeline`]).
pub fn resume_pipeline(ctx: &Arc<Context>, walk: Walk) -> Result<ComputePipeline, GpuError> {
    build(ctx, "analytic (occupancy)", shaders::ANALYTIC_OCCUPANCY_RESUME, &LISTED_BINDINGS, walk)
}
