//! Exact ray tracing of `field.interpolation = "cubic-bspline" | "catmull-rom"`
//! (`shaders/tricubic.comp`): the cell walk of `reference::analytic` over the tricubic
//! interpolants (the degree-9 Bernstein polynomial of each segment, its root isolation and
//! Newton refinement; `reference::analytic::tricubic` and `bernstein` are the specification)
//! in f32, one invocation per pixel of a band of rows. Bound as the analytic pass
//! ([`super::analytic::BUFFER_BINDINGS`]: the whole grid as a storage buffer, the default, or
//! [`super::analytic::BINDINGS`]: the grid image; then the interpolant's own brick min/max
//! grid, [`super::bricks::Bound`], whose empty bricks it jumps over), the pixels read too, then
//! the listed rays ([`Listed`]); specialized as the analytic pass ([`Walk`]) and for the round.
//!
//! Rounds: llvmpipe ends an invocation's loops after 65,535 passes in all, so a walk through
//! thousands of candidate cells is cut short there; the walk notices, lists the ray with the
//! state it had at the top of its last whole iteration, and the resuming build goes on from it
//! ([`Resume`], a round per submission until no ray is left). tricubic.comp's `Count` says how.

use std::sync::Arc;

use super::analytic::Walk;
use super::band::{Band, Rounds};
use super::listed::Listed;
use super::raymarch::RayPass;
use crate::field::interpolant::Interpolant;
use crate::gpu::{Binding, ComputePipeline, Context, GpuError, Recorder};
use crate::shaders;

/// Params, grid image, pixels (read and written), colormap, bricks, listed rays, their count.
pub const BINDINGS: [Binding; 7] = [
    Binding::Uniform,
    Binding::Sampled,
    Binding::ReadWrite,
    Binding::Read,
    Binding::Read,
    Binding::ReadWrite,
    Binding::ReadWrite,
];

/// [`BINDINGS`] with the grid as a storage buffer (the `GRID_BUFFER` variants).
pub const BUFFER_BINDINGS: [Binding; 7] = {
    let mut b = BINDINGS;
    b[1] = Binding::Read;
    b
};

/// The walk of `interp`, one of the tricubic interpolants (an error for another), reading the
/// grid image or, with `buffer`, the whole grid's points from a storage buffer (the
/// `GRID_BUFFER` variants, bindings [`BUFFER_BINDINGS`]: llvmpipe reads a point far faster);
/// with `resumed`, the build that goes on from the listed rays (`RESUMED`).
pub fn pipeline(
    ctx: &Arc<Context>,
    interp: Interpolant,
    walk: Walk,
    buffer: bool,
    resumed: bool,
) -> Result<ComputePipeline, GpuError> {
    let spirv = match (interp, buffer) {
        (Interpolant::CubicBspline, false) => shaders::TRICUBIC,
        (Interpolant::CatmullRom, false) => shaders::TRICUBIC_CATMULL_ROM,
        (Interpolant::CubicBspline, true) => shaders::TRICUBIC_BUFFER,
        (Interpolant::CatmullRom, true) => shaders::TRICUBIC_CATMULL_ROM_BUFFER,
        (other, _) => {
            return Err(GpuError::Bug(format!(
                "the tricubic walk traces no {} field",
                other.name()
            )))
        }
    };
    // "tricubic (catmull-rom, image, resumed)": the interpolant, then what differs.
    let name = format!(
        "tricubic ({}{}{})",
        interp.name(),
        if buffer { "" } else { ", image" },
        if resumed { ", resumed" } else { "" }
    );
    let bindings = if buffer { &BUFFER_BINDINGS } else { &BINDINGS };
    ComputePipeline::with_constants(
        ctx,
        &name,
        spirv,
        bindings,
        std::mem::size_of::<Band>() as u32,
        &[walk.levels, walk.surfaces, u32::from(resumed)],
    )
}

/// The rounds after a band's first pass ([`Rounds`]): the resuming build over the rays listed,
/// until none goes on. A round that lost a ray (its walk could not take one iteration within
/// the cap) ends the picture with an error rather than a wrong pixel.
pub struct Resume<'a> {
    /// The `RESUMED` build, bound to the same inputs as the first pass.
    pub pass: &'a RayPass<'a>,
    pub listed: &'a Listed,
}

impl Resume<'_> {
    /// Records a band's first pass, `first`, with the reset before it and the counts after.
    pub fn record_first(&self, rec: &mut Recorder, first: &RayPass, width: u32, band: Band) {
        self.listed.reset(rec);
        first.record(rec, width, band);
        self.listed.read_counts(rec);
    }
}

impl Rounds for Resume<'_> {
    fn pending(&self) -> Result<bool, GpuError> {
        let counts = self.listed.counts()?;
        if counts.lost > 0 {
            return Err(GpuError::TooLarge {
                what: format!(
                    "one step of the tricubic walk ({} of its rays: a cell's root isolation and \
                     the cells stepped over before it)",
                    counts.lost
                ),
                limit: "the device's loop limit (llvmpipe: 65,535 loop passes per invocation); \
                        render.method = \"fixed-step\" traces such a field"
                    .into(),
            });
        }
        Ok(counts.live > 0)
    }

    fn record(&self, rec: &mut Recorder, band: Band) -> Result<(), GpuError> {
        self.listed.next_round(rec);
        self.pass.record_indirect(rec, band, &self.listed.count, Listed::ARGS);
        self.listed.read_counts(rec);
        Ok(())
    }
}
