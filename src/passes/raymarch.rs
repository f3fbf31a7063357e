//! Fixed-step ray marching (`shaders/raymarch.comp`): one invocation per pixel of a band of
//! rows, writing one `Pixel` each. The algorithm is documented in the shader and mirrored by
//! `reference::fixed_step`. [`RayPass`] records this pass and the analytic one (same workgroups,
//! push constants and outputs).

use std::sync::Arc;

use super::Band;
use crate::field::interpolant::Interpolant;
use crate::gpu::{
    grid_groups, Binding, Buffer, ComputePipeline, Context, Dispatch, GpuError, Image3d, Recorder,
    Resource,
};
use crate::shaders;

/// Workgroup size of the ray shaders (`local_size_x/y`).
pub const GROUP: u32 = shaders::consts::RAY_GROUP;

/// Bindings shared by the ray passes: params, grid, pixels (written), colormap.
pub const RAY_BINDINGS: [Binding; 4] =
    [Binding::Uniform, Binding::Sampled, Binding::Write, Binding::Read];

/// The most samples a ray's march takes in one loop (a back-edge each). llvmpipe (lavapipe)
/// ends all loops of an invocation after 65,535 back-edges (gallivm's
/// LP_MAX_TGSI_LOOP_ITERATIONS), silently: a longer march lost its surface. Marches of more
/// steps than this are built with `LONG_MARCH` (raymarch.comp), MARCH_UNROLL samples a
/// back-edge; the rest of the shader's loops (a crossing's bisections) fit in what is left.
pub const LOOP_STEPS: u32 = 60_000;

/// What the march is specialized for (its specialization constants, folded in by the driver,
/// as the analytic walk's [`Walk`](super::analytic::Walk)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct March {
    /// `LONG_MARCH`: more than [`LOOP_STEPS`] samples.
    pub long: bool,
    /// `SURFACE_COUNT`: the surfaces (isovalues), 1 to `SURFACES`; `RenderParams.surfaces`.
    /// Their test (field.glsl's inside_mask) is then unrolled: no back-edge a sample.
    pub surfaces: u32,
}

impl March {
    /// The march of `steps` samples against `surfaces` isovalues.
    pub fn new(steps: u32, surfaces: u32) -> Self {
        March { long: steps > LOOP_STEPS, surfaces }
    }
}

pub fn pipeline(ctx: &Arc<Context>) -> Result<ComputePipeline, GpuError> {
    interpolant_pipeline(ctx, Interpolant::Trilinear, March::new(2, 1))
}

/// One build of `raymarch.comp`'s variant `spirv`, specialized for `march`.
fn build(
    ctx: &Arc<Context>,
    name: &str,
    spirv: &[u8],
    bindings: &[Binding],
    march: March,
) -> Result<ComputePipeline, GpuError> {
    let push = std::mem::size_of::<super::Band>() as u32;
    let constants = [march.long as u32, march.surfaces];
    ComputePipeline::with_constants(ctx, name, spirv, bindings, push, &constants)
}

/// The pass marching the field of `interp` (its variant of `raymarch.comp`, build.rs), on the
/// grid as a 3D image: `device` binds it through its linear sampler ([`GridInput::Filtered`]).
pub fn interpolant_pipeline(
    ctx: &Arc<Context>,
    interp: Interpolant,
    march: March,
) -> Result<ComputePipeline, GpuError> {
    let (name, spirv) = interp.march_shader();
    build(ctx, name, spirv, &RAY_BINDINGS, march)
}

/// Bindings of the `GRID_BUFFER` variant: as [`RAY_BINDINGS`] with the grid as a storage buffer.
pub const BUFFER_BINDINGS: [Binding; 4] =
    [Binding::Uniform, Binding::Read, Binding::Write, Binding::Read];

/// The trilinear march reading a whole grid's points from a storage buffer (the `GRID_BUFFER`
/// variant, its default where the grid fits one): the same samples as the image's, which
/// llvmpipe reads with far fewer instructions than a texelFetch.
pub fn buffer_pipeline(ctx: &Arc<Context>, march: March) -> Result<ComputePipeline, GpuError> {
    build(ctx, "raymarch", shaders::RAYMARCH_BUFFER, &BUFFER_BINDINGS, march)
}

/// Bindings of the `GRID_POOL` variants of both ray passes (`field.residency = "active"`):
/// params, pool, pixels (written), colormap, bricks, page table.
pub const POOL_BINDINGS: [Binding; 6] =
    [Binding::Uniform, Binding::Read, Binding::Write, Binding::Read, Binding::Read, Binding::Read];

/// The `GRID_POOL` variant of this pass.
pub fn pool_pipeline(ctx: &Arc<Context>, march: March) -> Result<ComputePipeline, GpuError> {
    build(ctx, "raymarch (brick pool)", shaders::RAYMARCH_POOL, &POOL_BINDINGS, march)
}

/// Where a ray pass reads the grid.
#[derive(Clone, Copy)]
pub enum GridInput<'a> {
    /// The whole grid (or an MPI rank's block) as a 3D image.
    Image(&'a Image3d),
    /// The whole grid as a 3D image the shader filters (`interpolation = "device"`).
    Filtered(&'a Image3d),
    /// The whole grid's points in a storage buffer (the `GRID_BUFFER` variants).
    Points(&'a Buffer),
    /// The brick pool, its page table and the brick min/max grid (`render::pool`).
    Pool { pool: &'a Buffer, pages: &'a Buffer, bricks: &'a Buffer },
}

/// What a ray pass (this one or [`super::analytic`]) reads and writes.
pub struct RayInputs<'a> {
    /// `RenderParams` (uniform).
    pub params: &'a Buffer,
    pub grid: GridInput<'a>,
    /// The band's `Pixel`s, written.
    pub pixels: &'a Buffer,
    pub colormap: &'a Buffer,
    /// The brick min/max grid ([`super::bricks`]): the analytic pass's fifth binding.
    pub bricks: Option<&'a Buffer>,
    /// The occupancy structure ([`super::occupancy`]): the `OCCUPANCY` walk's last two
    /// bindings.
    pub occupancy: Option<&'a super::occupancy::Occupancy>,
    /// The two-pass walk's listed rays ([`super::listed::Listed`]): its last two bindings.
    pub listed: Option<&'a super::listed::Listed>,
}

/// A ray pass bound to its inputs; records one band at a time.
pub struct RayPass<'a> {
    pipeline: &'a ComputePipeline,
    set: Dispatch,
    /// Keeps the bound buffers borrowed while the set refers to them.
    _inputs: RayInputs<'a>,
}

impl<'a> RayPass<'a> {
    pub fn new(pipeline: &'a ComputePipeline, inputs: RayInputs<'a>) -> Result<Self, GpuError> {
        // The grid's binding: the image, or its points in a storage buffer (same layout).
        let whole = match inputs.grid {
            GridInput::Image(image) => Some(Resource::Sampled(image)),
            GridInput::Filtered(image) => Some(Resource::Filtered(image)),
            GridInput::Points(points) => Some(Resource::Storage(points)),
            GridInput::Pool { .. } => None,
        };
        let resources = match inputs.grid {
            GridInput::Image(_) | GridInput::Filtered(_) | GridInput::Points(_) => {
                // Params as the pipeline takes it: uniform, or (a pass lavapipe must compile only
                // once) a storage buffer.
                let params = match pipeline.bindings().first() {
                    Some(Binding::Uniform) => Resource::Uniform(inputs.params),
                    _ => Resource::Storage(inputs.params),
                };
                let mut r = vec![params];
                r.extend(whole);
                r.extend([Resource::Storage(inputs.pixels), Resource::Storage(inputs.colormap)]);
                r.extend(inputs.bricks.map(Resource::Storage));
                if let Some(o) = inputs.occupancy {
                    r.extend([Resource::Storage(&o.reach), Resource::Storage(&o.masks)]);
                }
                if let Some(l) = inputs.listed {
                    r.extend([Resource::Storage(&l.rays), Resource::Storage(&l.count)]);
                }
                r
            }
            GridInput::Pool { pool, pages, bricks } => vec![
                Resource::Uniform(inputs.params),
                Resource::Storage(pool),
                Resource::Storage(inputs.pixels),
                Resource::Storage(inputs.colormap),
                Resource::Storage(bricks),
                Resource::Storage(pages),
            ],
        };
        let set = pipeline.bind(&resources)?;
        Ok(RayPass { pipeline, set, _inputs: inputs })
    }

    /// Records the pass over the rays an earlier pass listed: as many workgroups as it counted
    /// (`args` at `offset`), the band as push constants.
    pub fn record_indirect(&self, rec: &mut Recorder, band: Band, args: &Buffer, offset: u64) {
        rec.dispatch_indirect(self.pipeline, &self.set, bytemuck::bytes_of(&band), args, offset);
    }

    /// The pass's name (its pipeline's).
    pub fn name(&self) -> &str {
        &self.pipeline.name
    }

    /// Records the band: one invocation per pixel, [`GROUP`]² pixels per workgroup, the band as
    /// push constants.
    pub fn record(&self, rec: &mut Recorder, width: u32, band: Band) {
        let groups = grid_groups([width, band.rows, 1], [GROUP, GROUP, 1]);
        rec.dispatch(self.pipeline, &self.set, bytemuck::bytes_of(&band), groups);
    }
}
