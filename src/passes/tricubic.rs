//! Exact ray tracing of `field.interpolation = "cubic-bspline" | "catmull-rom"`
//! (`shaders/tricubic.comp`): the cell walk of `reference::analytic` over the tricubic
//! interpolants (the degree-9 Bernstein polynomial of each segment, its root isolation and
//! Newton refinement; `reference::analytic::tricubic` and `bernstein` are the specification)
//! in f32, one invocation per pixel of a band of rows. Bound and recorded as the analytic pass
//! ([`super::analytic::BUFFER_BINDINGS`]: the whole grid as a storage buffer, the default, or
//! [`super::analytic::BINDINGS`]: the grid image; then the interpolant's own brick min/max
//! grid, [`super::bricks::Bound`], whose empty bricks it jumps over) and specialized the same
//! way ([`Walk`]).

use std::sync::Arc;

use super::analytic::{Walk, BINDINGS, BUFFER_BINDINGS};
use crate::field::interpolant::Interpolant;
use crate::gpu::{ComputePipeline, Context, GpuError};
use crate::shaders;

/// The walk of `interp`, one of the tricubic interpolants (an error for another), reading the
/// grid image or, with `buffer`, the whole grid's points from a storage buffer (the
/// `GRID_BUFFER` variants, bindings [`BUFFER_BINDINGS`]: llvmpipe reads a point far faster).
pub fn pipeline(
    ctx: &Arc<Context>,
    interp: Interpolant,
    walk: Walk,
    buffer: bool,
) -> Result<ComputePipeline, GpuError> {
    let (name, spirv) = match (interp, buffer) {
        (Interpolant::CubicBspline, false) => {
            ("tricubic (cubic-bspline, image)", shaders::TRICUBIC)
        }
        (Interpolant::CatmullRom, false) => {
            ("tricubic (catmull-rom, image)", shaders::TRICUBIC_CATMULL_ROM)
        }
        (Interpolant::CubicBspline, true) => ("tricubic (cubic-bspline)", shaders::TRICUBIC_BUFFER),
        (Interpolant::CatmullRom, true) => {
            ("tricubic (catmull-rom)", shaders::TRICUBIC_CATMULL_ROM_BUFFER)
        }
        (other, _) => {
            return Err(GpuError::Bug(format!(
                "the tricubic walk traces no {} field",
                other.name()
            )))
        }
    };
    let bindings = if buffer { &BUFFER_BINDINGS } else { &BINDINGS };
    super::analytic::build(ctx, name, spirv, bindings, walk)
}
