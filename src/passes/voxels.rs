//! Exact ray tracing of `field.interpolation = "nearest"` (`shaders/voxels.comp`): the voxel
//! walk of `reference::voxels` (its module doc is the specification) in f32, one invocation per
//! pixel of a band of rows, writing one `Pixel` each. Bound and recorded as the analytic pass
//! ([`super::analytic::BINDINGS`]: the grid as an image, then the brick min/max grid, whose
//! bricks of empty voxels it jumps over) and specialized the same way ([`Walk`]).

use std::sync::Arc;

use super::analytic::{Walk, BINDINGS};
use crate::gpu::{ComputePipeline, Context, GpuError};
use crate::shaders;

pub fn pipeline(ctx: &Arc<Context>, walk: Walk) -> Result<ComputePipeline, GpuError> {
    super::analytic::build(ctx, "voxels", shaders::VOXELS, &BINDINGS, walk)
}
