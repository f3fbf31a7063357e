//! Fixed-step ray marching (`shaders/raymarch.comp`): one invocation per pixel of a band of
//! rows, writing one `Pixel` each. The algorithm is documented in the shader and mirrored by
//! `reference::fixed_step`.

use std::sync::Arc;

use ash::vk;

use crate::gpu::{ComputePipeline, Context, GpuError};
use crate::shaders;

/// Workgroup size of the ray shaders (`local_size_x/y`).
pub const GROUP: u32 = shaders::consts::RAY_GROUP;

/// Bindings shared by the ray passes: params (uniform), grid (3D image), pixels (storage),
/// colormap (storage).
pub const RAY_BINDINGS: [vk::DescriptorType; 4] = [
    vk::DescriptorType::UNIFORM_BUFFER,
    vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
];

pub fn pipeline(ctx: &Arc<Context>) -> Result<ComputePipeline, GpuError> {
    ComputePipeline::new(
        ctx,
        "raymarch",
        shaders::RAYMARCH,
        &RAY_BINDINGS,
        std::mem::size_of::<super::Band>() as u32,
    )
}
