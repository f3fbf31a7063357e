//! Exact ray tracing of `field.interpolation = "cubic-bspline" | "catmull-rom"`
//! (`shaders/tricubic.comp`): the cell walk of `reference::analytic` over the tricubic
//! interpolants (the degree-9 Bernstein polynomial of each segment, its root isolation and
//! Newton refinement; `reference::analytic::tricubic` and `bernstein` are the specification)
//! in f32, one invocation per pixel of a band of rows. Bound and recorded as the other ray
//! passes ([`super::raymarch::RayPass`], the grid as an image; no brick grid: the walk does not
//! skip yet).

use std::sync::Arc;

use super::raymarch::RAY_BINDINGS;
use crate::field::interpolant::Interpolant;
use crate::gpu::{ComputePipeline, Context, GpuError};
use crate::shaders;

/// The walk of `interp`, one of the tricubic interpolants (`None` for another).
pub fn pipeline(ctx: &Arc<Context>, interp: Interpolant) -> Result<ComputePipeline, GpuError> {
    let (name, spirv) = match interp {
        Interpolant::CubicBspline => ("tricubic (cubic-bspline)", shaders::TRICUBIC),
        Interpolant::CatmullRom => ("tricubic (catmull-rom)", shaders::TRICUBIC_CATMULL_ROM),
        other => {
            return Err(GpuError::Bug(format!(
                "the tricubic walk traces no {} field",
                other.name()
            )))
        }
    };
    ComputePipeline::new(ctx, name, spirv, &RAY_BINDINGS, std::mem::size_of::<super::Band>() as u32)
}
