//! Exact ray tracing of `field.interpolation = "nearest"` (`shaders/voxels.comp`): the voxel
//! walk of `reference::voxels` (its module doc is the specification) in f32, one invocation per
//! pixel of a band of rows, writing one `Pixel` each. Bound and recorded as the other ray
//! passes ([`super::raymarch::RayPass`], the grid as an image; no brick grid: the walk does not
//! skip yet).

use std::sync::Arc;

use super::raymarch::RAY_BINDINGS;
use crate::gpu::{ComputePipeline, Context, GpuError};
use crate::shaders;

pub fn pipeline(ctx: &Arc<Context>) -> Result<ComputePipeline, GpuError> {
    ComputePipeline::new(
        ctx,
        "voxels",
        shaders::VOXELS,
        &RAY_BINDINGS,
        std::mem::size_of::<super::Band>() as u32,
    )
}
