//! Exact ray tracing (`shaders/analytic.comp`): one invocation per pixel of a band of rows,
//! writing one `Pixel` each. The algorithm is `reference::analytic`'s (its module doc is the
//! specification), ported to f32 step for step; the shader's header lists where f32 needs care.
//!
//! Bindings: the ray passes' four ([`RAY_BINDINGS`](super::raymarch::RAY_BINDINGS)), then the
//! brick min/max grid of empty-space skipping ([`super::bricks`]). Push constants: the band.

use std::sync::Arc;

use ash::vk;

use crate::gpu::{ComputePipeline, Context, GpuError};
use crate::shaders;

/// Params (uniform), grid (3D image), pixels (storage), colormap (storage), bricks (storage).
pub const BINDINGS: [vk::DescriptorType; 5] = [
    vk::DescriptorType::UNIFORM_BUFFER,
    vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
];

pub fn pipeline(ctx: &Arc<Context>) -> Result<ComputePipeline, GpuError> {
    ComputePipeline::new(
        ctx,
        "analytic",
        shaders::ANALYTIC,
        &BINDINGS,
        std::mem::size_of::<super::Band>() as u32,
    )
}

/// The `GRID_POOL` variant (`field.residency = "active"`; bindings
/// [`POOL_BINDINGS`](super::raymarch::POOL_BINDINGS)).
pub fn pool_pipeline(ctx: &Arc<Context>) -> Result<ComputePipeline, GpuError> {
    ComputePipeline::new(
        ctx,
        "analytic (brick pool)",
        shaders::ANALYTIC_POOL,
        &super::raymarch::POOL_BINDINGS,
        std::mem::size_of::<super::Band>() as u32,
    )
}
