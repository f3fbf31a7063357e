//! Exact ray tracing of `field.interpolation = "cubic-bspline" | "catmull-rom"`
//! (`shaders/tricubic.comp`): the cell walk of `reference::analytic` over the tricubic
//! interpolants (the degree-9 Bernstein polynomial of each segment, its root isolation and
//! Newton refinement; `reference::analytic::tricubic` and `bernstein` are the specification)
//! in f32, one invocation per pixel of a band of rows. Bound and recorded as the analytic pass
//! ([`super::analytic::BINDINGS`]: the grid as an image, then the interpolant's own brick
//! min/max grid, [`super::bricks::Bound`], whose empty bricks it jumps over) and specialized
//! the same way ([`Walk`]).

use std::sync::Arc;

use super::analytic::{Walk, BINDINGS};
use crate::field::interpolant::Interpolant;
use crate::gpu::{ComputePipeline, Context, GpuError};
use crate::shaders;

/// The walk of `interp`, one of the tricubic interpolants (an error for another).
pub fn pipeline(
    ctx: &Arc<Context>,
    interp: Interpolant,
    walk: Walk,
) -> Result<ComputePipeline, GpuError> {
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
    super::analytic::build(ctx, name, spirv, &BINDINGS, walk)
}
