//! The ray methods (`fixed-step`, `analytic`): the shader for the method and for how the grid
//! is on the device ([`RayShader`], each built on its first use), the analytic walk's brick
//! levels, then the ray pass over bands of rows, each band placed in world space and handed to
//! the sink.

use std::sync::Arc;

use ash::vk;

use super::grid::Storage;
use super::params::RenderParams;
use super::sink::{placed_band, FrameSink};
use super::{Accel, GpuGrid, Progressive, RenderError, Renderer};
use crate::field::interpolant::{Interpolant, Reader};
use crate::field::Grid;
use crate::frame::Pixel;
use crate::gpu::{Buffer, ComputePipeline, Context, GpuError};
use crate::passes::raymarch::{GridInput, RayInputs, RayPass};
use crate::passes::{analytic, bricks, listed, occupancy, raymarch, tricubic, voxels, Bands};
use crate::scene::{Method, Scene};

/// The ray passes' shaders: method and how the grid is on the device; the analytic builds
/// carry what they are specialized for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum RayShader {
    /// The grid image, marched through the scene's interpolant. The marches carry what they
    /// are specialized for.
    FixedStep(Interpolant, raymarch::March),
    /// The trilinear march over the whole grid's points in a storage buffer.
    FixedStepBuffer(raymarch::March),
    FixedStepPool(raymarch::March),
    /// The grid image (an MPI rank's block, or a grid over the device's storage buffer range).
    Analytic(analytic::Walk),
    /// The whole grid in a storage buffer.
    AnalyticBuffer(analytic::Walk),
    /// That walk with the occupancy structure ([`occupancy`]): the default where it applies.
    AnalyticOccupancy(analytic::Walk),
    /// The same in two passes (a device with subgroup ballots): the empty bricks from every
    /// ray's start, listing the rays that go on ...
    AnalyticSkip(analytic::Walk),
    /// ... and their walk.
    AnalyticResume(analytic::Walk),
    AnalyticPool(analytic::Walk),
    /// `interpolation = "nearest"`'s exact trace, the voxel walk, on the grid image.
    Voxels(analytic::Walk),
    /// The tricubic interpolants' exact trace, the Bernstein walk: on the grid image, or
    /// (`true`) on the whole grid's points in a storage buffer, as `AnalyticBuffer` ...
    Tricubic(Interpolant, analytic::Walk, bool),
    /// ... and its rounds over the rays llvmpipe's loop cap cut short ([`tricubic::Resume`]).
    TricubicResume(Interpolant, analytic::Walk, bool),
}

impl RayShader {
    fn pipeline(self, ctx: &Arc<Context>) -> Result<ComputePipeline, GpuError> {
        match self {
            RayShader::FixedStep(interp, march) => {
                raymarch::interpolant_pipeline(ctx, interp, march)
            }
            RayShader::FixedStepPool(march) => raymarch::pool_pipeline(ctx, march),
            RayShader::FixedStepBuffer(march) => raymarch::buffer_pipeline(ctx, march),
            RayShader::Analytic(walk) => analytic::pipeline(ctx, walk),
            RayShader::AnalyticBuffer(walk) => analytic::buffer_pipeline(ctx, walk),
            RayShader::AnalyticOccupancy(walk) => analytic::occupancy_pipeline(ctx, walk),
            RayShader::AnalyticSkip(walk) => analytic::skip_pipeline(ctx, walk),
            RayShader::AnalyticResume(walk) => analytic::resume_pipeline(ctx, walk),
            RayShader::AnalyticPool(walk) => analytic::pool_pipeline(ctx, walk),
            RayShader::Voxels(walk) => voxels::pipeline(ctx, walk),
            RayShader::Tricubic(interp, walk, buffer) => {
                tricubic::pipeline(ctx, interp, walk, buffer, false)
            }
            RayShader::TricubicResume(interp, walk, buffer) => {
                tricubic::pipeline(ctx, interp, walk, buffer, true)
            }
        }
    }
}

impl Renderer {
    /// The ray methods (fixed-step, analytic): every `stride`-th pixel, bands of at most
    /// `band_rows` rows, each band placed in world space and handed to `sink`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn draw_rays(
        &mut self,
        scene: &Scene,
        grid: &Grid,
        gpu_grid: &GpuGrid,
        time: f64,
        stride: u32,
        band_rows: u32,
        sink: &mut dyn FrameSink,
    ) -> Result<(), RenderError> {
        let mut params = RenderParams::new(scene, grid);
        let interp = scene.field.interpolation;
        self.last_bricks_ms = None;
        self.last_bricks_cpu_ms = None;
        self.last_occupancy_ms = None;
        self.built_occupancy = false;
        self.last_brick_levels = None;
        let analytic = scene.render.method == Method::Analytic;
        if let (Storage::Pool(_), Some(why)) =
            (&gpu_grid.storage, scene.interpolation_refusal(Reader::BrickPool))
        {
            return Err(RenderError::Refused(why));
        }
        if let Some(why) =
            super::grid::sample_bound_refusal(gpu_grid.largest, scene.path.as_deref())
        {
            return Err(RenderError::Refused(why));
        }
        if interp == Interpolant::Device && !self.ctx.info.r32f_linear_filter {
            return Err(RenderError::Gpu(GpuError::Unsupported {
                what: "field.interpolation = \"device\"".into(),
                feature: "linear filtering of 32-bit float 3D images (R32_SFLOAT's \
                          SAMPLED_IMAGE_FILTER_LINEAR)"
                    .into(),
                device: self.ctx.info.name.clone(),
                instead: "use \"trilinear\", the exact filter, or another device (--device)".into(),
            }));
        }
        if gpu_grid.block.is_some() {
            if let Some(why) = scene.interpolation_refusal(Reader::Ranks) {
                return Err(RenderError::Refused(why));
            }
        }
        // The analytic walks skip empty space with a min/max grid over the samples their cells
        // read (`bricks::Bound`): trilinear's and nearest's one, or a tricubic one's own, each
        // built on the device the first time it is needed (given, for a pool or a block).
        let bound = match interp {
            Interpolant::CubicBspline => bricks::Bound::Cubic,
            Interpolant::CatmullRom => bricks::Bound::CatmullRom,
            Interpolant::Trilinear | Interpolant::Nearest | Interpolant::Device => {
                bricks::Bound::Corners
            }
        };
        let levels_cell = gpu_grid.cubic_levels(bound);
        if analytic {
            let unbuilt = match levels_cell {
                None => gpu_grid.bricks.get().is_none(),
                Some(cell) => cell.get().is_none(),
            };
            // On a CPU device (lavapipe) trilinear's ranges are made by the CPU's threads from
            // the grid itself: the same numbers (bricks::ranges_threaded), a tenth of the time.
            let on_cpu = self.ctx.info.device_type.starts_with("CPU")
                && levels_cell.is_none()
                && gpu_grid.block.is_none()
                && grid.values.len() == grid.dims.iter().product::<usize>();
            if unbuilt && on_cpu {
                let started = std::time::Instant::now();
                let ranges = bricks::ranges_threaded(grid);
                gpu_grid.set_bricks(&self.ctx, bricks::levels(grid.dims, &ranges))?;
                self.last_bricks_cpu_ms = Some(started.elapsed().as_secs_f64() * 1e3);
            } else if unbuilt {
                let image = gpu_grid.image("the brick min/max grid of a brick pool")?;
                let built = bricks::build(&self.ctx, &self.bricks, image, gpu_grid.dims, bound)?;
                self.last_bricks_ms = built.ms;
                match levels_cell {
                    None => {
                        let _ = gpu_grid.supers.set(built.supers);
                        let _ = gpu_grid.bricks.set(built.buffer);
                    }
                    Some(cell) => {
                        let _ = cell.set(built);
                    }
                }
            }
        }
        let (brick_buffer, supers) = match levels_cell {
            None => (gpu_grid.bricks.get(), gpu_grid.supers.get().map_or(&[][..], |s| &s[..])),
            Some(cell) => cell.get().map_or((None, &[][..]), |b| (Some(&b.buffer), &b.supers[..])),
        };
        let mut walk = || {
            let surfaces = params.surfaces;
            let thresholds = params.surface_thresholds();
            let chosen =
                self.brick_levels.unwrap_or_else(|| bricks::levels_for(supers, &thresholds));
            let levels = if scene.render.skip { chosen.clamp(1, 2) } else { 1 };
            self.last_brick_levels = Some(levels);
            analytic::Walk { levels, surfaces }
        };
        // The whole grid from a storage buffer where it fits: llvmpipe reads a point with a
        // fraction of a texelFetch's instructions. Copied from the image on first use.
        let points = |image: &crate::gpu::Image3d| -> Result<bool, RenderError> {
            let bytes = image.extent.iter().map(|&e| e as u64).product::<u64>() * 4;
            let buffer = self.grid_buffer
                && gpu_grid.block.is_none()
                && bytes <= self.ctx.info.max_storage_buffer_range;
            if buffer && gpu_grid.points.get().is_none() {
                let _ = gpu_grid.points.set(image.copy_to_buffer("grid points")?);
            }
            Ok(buffer)
        };
        let march = raymarch::March::new(scene.render.steps, params.surfaces);
        let shader = match (scene.render.method, &gpu_grid.storage) {
            (Method::Mesh, _) => return Err(RenderError::Unsupported("mesh (as a ray pass)")),
            (Method::FixedStep, Storage::Pool(_)) => RayShader::FixedStepPool(march),
            (Method::FixedStep, Storage::Image(image))
                if interp == Interpolant::Trilinear && points(image)? =>
            {
                RayShader::FixedStepBuffer(march)
            }
            (Method::FixedStep, Storage::Image(_)) => RayShader::FixedStep(interp, march),
            (Method::Analytic, Storage::Image(_)) if interp == Interpolant::Nearest => {
                RayShader::Voxels(walk())
            }
            (Method::Analytic, Storage::Pool(_)) => RayShader::AnalyticPool(walk()),
            (Method::Analytic, Storage::Image(image)) => {
                let buffer = points(image)?;
                match (bound, buffer) {
                    (bricks::Bound::Corners, true) => RayShader::AnalyticBuffer(walk()),
                    (bricks::Bound::Corners, false) => RayShader::Analytic(walk()),
                    _ => RayShader::Tricubic(interp, walk(), buffer),
                }
            }
        };
        // The occupancy structure where it applies (a whole grid in a storage buffer, skipping
        // on) and is not turned off: the same image, less work. Its walk needs no superbricks.
        // A strided picture (serve's coarse frames while a key is dragged) uses it only when it
        // is built for these isovalues already: its build would cost more than the few rays
        // save, and a drag would pay it for every new isovalue.
        let current = || {
            let key = occupancy::key(&params.surface_thresholds());
            gpu_grid.occupancy.borrow().as_ref().is_some_and(|o| o.key == key)
        };
        let shader = match shader {
            RayShader::AnalyticBuffer(walk)
                if self.accel != Accel::Plain
                    && scene.render.skip
                    && scene.render.occupancy
                    && (stride == 1 || current()) =>
            {
                self.last_brick_levels = Some(1);
                let walk = analytic::Walk { levels: 1, ..walk };
                match self.accel == Accel::TwoPass && self.ctx.info.subgroup_ballot {
                    true => RayShader::AnalyticResume(walk),
                    false => RayShader::AnalyticOccupancy(walk),
                }
            }
            other => other,
        };
        // The two-pass walk's first pass.
        let first = match shader {
            RayShader::AnalyticResume(walk) => Some(RayShader::AnalyticSkip(walk)),
            _ => None,
        };
        // The tricubic walk's rounds after it.
        let then = match shader {
            RayShader::Tricubic(interp, walk, buffer) => {
                Some(RayShader::TricubicResume(interp, walk, buffer))
            }
            _ => None,
        };
        for s in first.iter().chain([&shader]).chain(then.iter()) {
            if !self.ray_pipelines.contains_key(s) {
                self.ray_pipelines.insert(*s, s.pipeline(&self.ctx)?);
            }
        }
        if !self.ray_pipelines.contains_key(&shader) {
            self.ray_pipelines.insert(shader, shader.pipeline(&self.ctx)?);
        }
        let pipeline = &self.ray_pipelines[&shader];
        let ctx = &self.ctx;
        let (width, height) =
            Progressive::picture_size(stride, scene.image.width, scene.image.height);
        params.stride = stride;
        params.picture_width = width;
        if let Some(b) = &gpu_grid.block {
            if scene.render.method != Method::Analytic {
                return Err(RenderError::Unsupported("fixed-step (on a block of the grid)"));
            }
            let i = |v: [usize; 3]| v.map(|c| c as i32);
            (params.block_lo, params.block_hi) = (i(b.cells_lo), i(b.cells_hi));
            params.block_origin = i(b.origin);
        }
        let params_buf = Buffer::upload(
            ctx,
            "params",
            std::slice::from_ref(&params),
            // STORAGE_BUFFER too: the passes that must not be compiled per dispatch read it as
            // a storage buffer (passes/occupancy.rs).
            vk::BufferUsageFlags::UNIFORM_BUFFER | vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        let bands = Bands::<Pixel>::with_max_rows(ctx, "pixels", width, height, band_rows)?;
        let bricks = if analytic { brick_buffer } else { None };
        if let RayShader::AnalyticOccupancy(walk) | RayShader::AnalyticResume(walk) = shader {
            // Built for these isovalues unless the grid has it already.
            let key = occupancy::key(&params.surface_thresholds());
            let stale = gpu_grid.occupancy.borrow().as_ref().map_or(true, |o| o.key != key);
            if stale {
                if let std::collections::hash_map::Entry::Vacant(e) =
                    self.occupancy_pipelines.entry(walk.surfaces)
                {
                    e.insert(occupancy::Pipelines::new(ctx, walk)?);
                }
                // The old one first: a grid keeps one structure on the device.
                gpu_grid.occupancy.replace(None);
                let missing =
                    |what: &str| GpuError::Bug(format!("the occupancy structure needs {what}"));
                let built = occupancy::build(
                    ctx,
                    &self.occupancy_pipelines[&walk.surfaces],
                    &params_buf,
                    gpu_grid.points.get().ok_or_else(|| missing("the grid's points"))?,
                    bricks.ok_or_else(|| missing("the brick grid"))?,
                    gpu_grid.dims,
                    key,
                )?;
                self.last_occupancy_ms = built.ms;
                self.built_occupancy = true;
                gpu_grid.occupancy.replace(Some(built));
            }
        }
        let occupied = gpu_grid.occupancy.borrow();
        let occupancy = match shader {
            RayShader::AnalyticOccupancy(_) | RayShader::AnalyticResume(_) => occupied.as_ref(),
            _ => None,
        };
        // Kept from the last render when it has room (no allocation per frame).
        let listing = first.is_some() || then.is_some();
        let listed = match (listing, self.listed.take()) {
            (false, kept) => {
                self.listed = kept;
                None
            }
            (true, Some(l)) if l.band_pixels >= bands.band_pixels() => Some(l),
            (true, _) => Some(listed::Listed::new(ctx, bands.band_pixels())?),
        };
        let grid_input = match (&gpu_grid.storage, shader) {
            (
                Storage::Image(_),
                RayShader::AnalyticBuffer(_)
                | RayShader::FixedStepBuffer(_)
                | RayShader::AnalyticOccupancy(_)
                | RayShader::AnalyticResume(_)
                | RayShader::Tricubic(_, _, true)
                | RayShader::TricubicResume(_, _, true),
            ) => GridInput::Points(
                gpu_grid
                    .points
                    .get()
                    .ok_or_else(|| GpuError::Bug("grid points not copied".into()))?,
            ),
            (Storage::Image(image), RayShader::FixedStep(Interpolant::Device, _)) => {
                GridInput::Filtered(image)
            }
            (Storage::Image(image), _) => GridInput::Image(image),
            (Storage::Pool(p), _) => GridInput::Pool {
                pool: &p.pool,
                pages: &p.pages,
                bricks: gpu_grid.bricks.get().ok_or_else(|| {
                    GpuError::Bug("a brick pool was uploaded without its brick grid".into())
                })?,
            },
        };
        // The same inputs for both passes of the two-pass walk.
        let inputs = || RayInputs {
            params: &params_buf,
            grid: grid_input,
            pixels: &bands.out,
            colormap: &self.colormap,
            bricks,
            occupancy,
            listed: listed.as_ref(),
        };
        let pass = RayPass::new(pipeline, inputs())?;
        let first_pass = match first {
            Some(s) => Some(RayPass::new(&self.ray_pipelines[&s], inputs())?),
            None => None,
        };
        let then_pass = match then {
            Some(s) => Some(RayPass::new(&self.ray_pipelines[&s], inputs())?),
            None => None,
        };
        let resume = match (&then_pass, &listed) {
            (Some(pass), Some(listed)) => Some(tricubic::Resume { pass, listed }),
            _ => None,
        };
        let mut info = self.frame_info(scene, grid, time);
        if analytic {
            // How the walk crossed empty space (what `steps` counts): the occupancy structure,
            // or brick by brick (MPI blocks, brick pools, `render.occupancy = false`).
            let occupancy =
                matches!(shader, RayShader::AnalyticOccupancy(_) | RayShader::AnalyticResume(_));
            info.extra.push(("occupancy".into(), occupancy.to_string()));
        }
        if stride > 1 {
            info.extra.push(("stride".into(), stride.to_string()));
        }
        sink.begin(width, height, &info)?;
        let placement = scene.field.placement;
        let gpu_ms = bands.for_each_band_in_rounds(
            pass.name(),
            |band, records| placed_band(sink, &placement, band, records),
            |rec, band| {
                match (&first_pass, &listed, &resume) {
                    (Some(first), Some(l), _) => {
                        l.reset(rec);
                        first.record(rec, width, band);
                        pass.record_indirect(rec, band, &l.count, listed::Listed::ARGS);
                    }
                    (_, _, Some(resume)) => resume.record_first(rec, &pass, width, band),
                    _ => pass.record(rec, width, band),
                }
                Ok(())
            },
            resume.as_ref().map(|r| r as &dyn crate::passes::Rounds),
        )?;
        drop((pass, first_pass, then_pass));
        self.listed = listed;
        // All device work of the render: the ray passes and the structures it built.
        let built = [self.last_bricks_ms, self.last_occupancy_ms];
        self.last_gpu_ms = gpu_ms.map(|ms| ms + built.iter().flatten().sum::<f64>());
        Ok(())
    }
}
