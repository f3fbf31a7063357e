//! Rendering a scene: upload the grid as a 3D image, run the method's ray pass over bands of
//! rows ([`crate::passes::Bands`]), read the pixels back into a [`Frame`]. The analytic pass
//! also reads the grid's brick min/max grid (empty-space skipping), built on the GPU the first
//! time an analytic render uses an uploaded grid and kept with it.

pub mod block;
pub mod color;
pub mod mesh;
pub mod params;
pub mod pool;
pub mod sink;

use std::sync::Arc;

use ash::vk;

use crate::field::Grid;
use crate::frame::{Channel, Frame, FrameInfo, Pixel};
use crate::gpu::{Buffer, ComputePipeline, Context, GpuError, Image3d};
use crate::passes::mesh_render::MeshPipelines;
use crate::passes::raymarch::{GridInput, RayInputs, RayPass};
use crate::passes::Bands;
use crate::passes::{analytic, bricks, raymarch};
use crate::scene::{Method, Normals, Projection, Scene};
use params::RenderParams;
pub use sink::{Collect, FrameSink};

pub use crate::passes::band::{band_rows, MAX_BAND_PIXELS};

#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("render.method = \"{0}\" is not available in this build")]
    Unsupported(&'static str),
    #[error("render.method = \"mesh\": {0}")]
    Mesh(#[from] crate::mesh::MeshError),
    /// `[field2]` could not be sampled.
    #[error("[field2]: {0}")]
    Field2(#[from] crate::field::FieldError),
    /// [`Progressive::after_band`] said stop (a newer state made this frame stale).
    #[error("the render was abandoned between bands")]
    Cancelled,
    /// A [`FrameSink`] could not write a band on (a streaming output file).
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
}

/// How [`Renderer::render_progressive`] draws a frame: which pixels, in what bands, and
/// whether to go on after each band.
pub struct Progressive<'a> {
    /// Draw every `stride`-th pixel of every `stride`-th row (1: the whole image). Pixel (i, j)
    /// of the frame is pixel (stride i, stride j) of the whole image, bit for bit (same ray).
    pub stride: u32,
    /// Rows of the drawn picture per band, at most (smaller bands: earlier stops).
    pub band_rows: u32,
    /// Called with each finished band (rows of the drawn picture, its records as the frame
    /// will hold them, placed in world space); false abandons the frame with
    /// [`RenderError::Cancelled`].
    pub after_band: &'a mut dyn FnMut(crate::passes::Band, &[Pixel]) -> bool,
}

impl Progressive<'_> {
    /// The picture drawn for a `width` × `height` image: ceil(width / stride) × ceil(height /
    /// stride).
    pub fn picture_size(stride: u32, width: u32, height: u32) -> (u32, u32) {
        let s = stride.max(1);
        (width.div_ceil(s), height.div_ceil(s))
    }
}

impl From<crate::passes::extract::GpuMeshError> for RenderError {
    fn from(e: crate::passes::extract::GpuMeshError) -> Self {
        use crate::passes::extract::GpuMeshError;
        match e {
            GpuMeshError::Gpu(g) => RenderError::Gpu(g),
            GpuMeshError::Mesh(m) => RenderError::Mesh(m),
            GpuMeshError::Unsupported(what) | GpuMeshError::CpuOnly(what) => {
                RenderError::Unsupported(what)
            }
        }
    }
}

/// A grid uploaded to the device: the whole grid, one process's block of it, or the bricks
/// of it an isovalue needs ([`pool`]).
pub struct GpuGrid {
    storage: Storage,
    /// Points per axis of the uploaded image (of the whole grid, for a pool).
    pub dims: [usize; 3],
    /// The brick min/max grid ([`bricks`]), built by the first analytic render (given, for a
    /// pool or a block).
    bricks: std::cell::OnceCell<Buffer>,
    /// A host copy of its superbricks' ranges, set with `bricks` (the choice of levels).
    supers: std::cell::OnceCell<Vec<[f32; 2]>>,
    /// The image's points in a storage buffer, copied on the device by the first analytic
    /// render of a whole grid (its `GRID_BUFFER` variant): a second copy of the grid on the
    /// device, read by llvmpipe far faster than the image (docs/methods.md "Exact ray tracing").
    points: std::cell::OnceCell<Buffer>,
    /// The block of a larger grid the image holds (None: the whole grid).
    block: Option<block::Block>,
}

/// How the grid's points are on the device.
enum Storage {
    /// Every point (of the grid or the block), as a 3D image.
    Image(Image3d),
    /// The resident bricks' slots and the page table.
    Pool(Box<pool::Pool>),
}

impl GpuGrid {
    pub fn upload(ctx: &Arc<Context>, grid: &Grid) -> Result<Self, GpuError> {
        let extent = grid.dims.map(|d| d as u32);
        Ok(GpuGrid {
            storage: Storage::Image(Image3d::upload(ctx, "grid", extent, &grid.values)?),
            dims: grid.dims,
            bricks: std::cell::OnceCell::new(),
            supers: std::cell::OnceCell::new(),
            points: std::cell::OnceCell::new(),
            block: None,
        })
    }

    /// Uploads one process's `block` of a larger grid of `dims` points (`values`: the block's
    /// points, x fastest) with the whole grid's brick min/max grid (`bricks`, combined over
    /// every block; its superbricks are added here), for the analytic method, which then traces
    /// only the block's cells.
    pub fn upload_block(
        ctx: &Arc<Context>,
        dims: [usize; 3],
        block: block::Block,
        values: &[f32],
        bricks: &[[f32; 2]],
    ) -> Result<Self, GpuError> {
        let extent = block.extent.map(|d| d as u32);
        let grid = GpuGrid {
            storage: Storage::Image(Image3d::upload(ctx, "grid block", extent, values)?),
            dims: block.extent,
            bricks: std::cell::OnceCell::new(),
            supers: std::cell::OnceCell::new(),
            points: std::cell::OnceCell::new(),
            block: Some(block),
        };
        grid.set_bricks(ctx, bricks::levels(dims, bricks))?;
        Ok(grid)
    }

    /// Uploads the bricks of a grid read from its file (`field.residency`) that `residency` names into a brick pool
    /// ([`pool`]), with the grid's brick min/max grid (`ranges`, from
    /// [`MappedGrid::brick_ranges`](crate::field::mapped::MappedGrid::brick_ranges); its
    /// superbricks are added here).
    pub fn upload_pool(
        ctx: &Arc<Context>,
        grid: &crate::field::mapped::MappedGrid,
        ranges: &[[f32; 2]],
        residency: pool::Residency,
    ) -> Result<Self, pool::PoolError> {
        let pool = pool::Pool::upload(ctx, grid, residency)?;
        let gpu = GpuGrid {
            storage: Storage::Pool(Box::new(pool)),
            dims: grid.dims,
            bricks: std::cell::OnceCell::new(),
            supers: std::cell::OnceCell::new(),
            points: std::cell::OnceCell::new(),
            block: None,
        };
        gpu.set_bricks(ctx, bricks::levels(grid.dims, ranges))?;
        Ok(gpu)
    }

    /// Uploads the min/max grid computed on the CPU (`levels`: [`bricks::levels`]' layout).
    fn set_bricks(&self, ctx: &Arc<Context>, levels: Vec<[f32; 2]>) -> Result<(), GpuError> {
        let buffer = Buffer::upload(ctx, "bricks", &levels, vk::BufferUsageFlags::STORAGE_BUFFER)?;
        let n_bricks = bricks::brick_counts(self.dims).iter().product::<usize>();
        let _ = self.supers.set(levels[n_bricks..].to_vec());
        let _ = self.bricks.set(buffer);
        Ok(())
    }

    /// The 3D image of every point; an error for a brick pool, which only the ray methods read.
    pub fn image(&self, what: &'static str) -> Result<&Image3d, RenderError> {
        match &self.storage {
            Storage::Image(image) => Ok(image),
            Storage::Pool(_) => Err(RenderError::Unsupported(what)),
        }
    }

    /// Which bricks are on the device, for a brick pool.
    pub fn residency(&self) -> Option<&pool::Residency> {
        match &self.storage {
            Storage::Image(_) => None,
            Storage::Pool(p) => Some(&p.residency),
        }
    }

    /// The brick min/max grid with its superbricks, once an analytic render has built it
    /// (layout: [`bricks`]).
    pub fn bricks(&self) -> Option<&Buffer> {
        self.bricks.get()
    }
}

/// The channels a render of `scene` writes (what `output::exr::written_channels` finds in its
/// frame, known before rendering): every always-written one, `crossings` where the method
/// counts them, `iso_index` with several isovalues, `color.value` with `[color] by`.
pub fn scene_channels(scene: &Scene) -> Vec<Channel> {
    let counted = scene.render.method != Method::FixedStep && scene.render.count_crossings;
    Channel::ALL
        .into_iter()
        .filter(|c| match c {
            Channel::Crossings => counted,
            Channel::Surface => scene.surface.several(),
            Channel::ColorValue => scene.color.by != crate::scene::ColorBy::Surface,
            _ => c.written() == crate::frame::Written::Always,
        })
        .collect()
}

/// The ray passes' shaders: method and how the grid is on the device; the analytic builds
/// carry what they are specialized for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum RayShader {
    FixedStep,
    FixedStepPool,
    /// The grid image (an MPI rank's block, or a grid over the device's storage buffer range).
    Analytic(analytic::Walk),
    /// The whole grid in a storage buffer: the default.
    AnalyticBuffer(analytic::Walk),
    AnalyticPool(analytic::Walk),
}

impl RayShader {
    fn pipeline(self, ctx: &Arc<Context>) -> Result<ComputePipeline, GpuError> {
        match self {
            RayShader::FixedStep => raymarch::pipeline(ctx),
            RayShader::FixedStepPool => raymarch::pool_pipeline(ctx),
            RayShader::Analytic(walk) => analytic::pipeline(ctx, walk),
            RayShader::AnalyticBuffer(walk) => analytic::buffer_pipeline(ctx, walk),
            RayShader::AnalyticPool(walk) => analytic::pool_pipeline(ctx, walk),
        }
    }
}

/// Owns the pipelines and constant resources; renders any number of frames.
pub struct Renderer {
    ctx: Arc<Context>,
    /// The ray passes' pipelines, each built on its first use (a render runs one of them;
    /// llvmpipe takes a good part of a second to compile one when Mesa's shader cache is cold).
    ray_pipelines: std::collections::HashMap<RayShader, ComputePipeline>,
    bricks: bricks::Pipelines,
    colormap: Buffer,
    /// The mesh render's pipelines, built on the first mesh render (they need 64-bit atomics).
    mesh: Option<MeshPipelines>,
    /// The GPU mesh extraction, built on the first mesh render.
    extractor: Option<crate::passes::extract::Extractor>,
    /// GPU time of the last frame's ray passes, in milliseconds (None without timestamps).
    pub last_gpu_ms: Option<f64>,
    /// GPU time of building the brick min/max grid during the last frame, in milliseconds
    /// (None when the frame did not build it: not analytic, already built, or no timestamps).
    pub last_bricks_ms: Option<f64>,
    /// The levels of the min/max grid the analytic walk jumps with when `render.skip` is on:
    /// 1 (bricks) or 2 (and superbricks); None (the default): chosen per render from the
    /// grid's empty superbricks ([`bricks::levels_for`]). Images are the same bit for bit
    /// either way, `steps` included; tests and benchmarks set it to compare the two.
    pub brick_levels: Option<u32>,
    /// The levels the last analytic frame's walk used.
    pub last_brick_levels: Option<u32>,
}

/// 256 linear RGBA entries of a colorous gradient (its sRGB colours decoded), for shaders.
pub fn linear_colormap(gradient: colorous::Gradient) -> Vec<[f32; 4]> {
    let linear = |u: u8| crate::scene::srgb_to_linear(u as f32 / 255.0);
    (0..256)
        .map(|i| {
            let c = gradient.eval_continuous(i as f64 / 255.0);
            [linear(c.r), linear(c.g), linear(c.b), 1.0]
        })
        .collect()
}

/// The `steps` heat map: colorous's inferno.
pub fn colormap() -> Vec<[f32; 4]> {
    linear_colormap(colorous::INFERNO)
}

impl Renderer {
    /// Drops the ray and mesh-render pipelines; the next frame builds the ones it uses again.
    /// Called between the frames of a long run: lavapipe (Mesa 22) compiles a variant of a
    /// pipeline for each dispatch whose uniforms it can inline (the band's push constants,
    /// the loop bounds in `Params`) and frees the variants only with the pipeline, so a
    /// pipeline kept for the whole of `render --frames` grew memory by about 1 MiB a frame.
    pub fn release_pipelines(&mut self) {
        self.ray_pipelines.clear();
        self.mesh = None;
    }

    pub fn new(ctx: &Arc<Context>) -> Result<Self, RenderError> {
        let bricks = bricks::pipelines(ctx)?;
        let colormap =
            Buffer::upload(ctx, "colormap", &colormap(), vk::BufferUsageFlags::STORAGE_BUFFER)?;
        Ok(Renderer {
            ctx: ctx.clone(),
            ray_pipelines: Default::default(),
            bricks,
            colormap,
            mesh: None,
            extractor: None,
            last_gpu_ms: None,
            last_bricks_ms: None,
            brick_levels: None,
            last_brick_levels: None,
        })
    }

    pub fn context(&self) -> &Arc<Context> {
        &self.ctx
    }

    /// Destroys the ray passes' pipelines (rebuilt on their next use), and with them what the
    /// driver keeps per pipeline: lavapipe (Mesa 22) compiles a variant of the shader for the
    /// push constants of each dispatch and frees the variants only with the pipeline (about
    /// 1 MiB each). A long-running caller (`serve`) calls this every few dispatches.
    pub fn release_ray_pipelines(&mut self) {
        self.ray_pipelines.clear();
    }

    /// Renders `scene` over `grid` (sampled at `time`).
    pub fn render(&mut self, scene: &Scene, grid: &Grid, time: f64) -> Result<Frame, RenderError> {
        let gpu_grid = GpuGrid::upload(&self.ctx, grid)?;
        self.render_uploaded(scene, grid, &gpu_grid, time)
    }

    /// Renders with a grid already on the device (`grid` gives its geometry and values for the
    /// constants; it must be the grid that `gpu_grid` was uploaded from).
    pub fn render_uploaded(
        &mut self,
        scene: &Scene,
        grid: &Grid,
        gpu_grid: &GpuGrid,
        time: f64,
    ) -> Result<Frame, RenderError> {
        let mut go_on = |_: crate::passes::Band, _: &[Pixel]| true;
        let whole = Progressive { stride: 1, band_rows: u32::MAX, after_band: &mut go_on };
        self.render_progressive(scene, grid, gpu_grid, time, whole)
    }

    /// [`Renderer::render_uploaded`] of every `how.stride`-th pixel, band by band, asking
    /// `how.after_band` after each band whether to go on. The mesh method with a stride draws
    /// the whole image and then keeps every stride-th pixel (one band).
    pub fn render_progressive(
        &mut self,
        scene: &Scene,
        grid: &Grid,
        gpu_grid: &GpuGrid,
        time: f64,
        how: Progressive<'_>,
    ) -> Result<Frame, RenderError> {
        let stride = how.stride.max(1);
        let colorer = color::Colorer::new(scene, grid, time)?;
        if scene.render.method == Method::Mesh && stride > 1 {
            let mut whole = sink::Colored::new(colorer.as_ref(), 1, Collect::default());
            self.render_scene_mesh(scene, grid, gpu_grid, time, &mut whole)?;
            let frame = subsample(whole.inner.into_frame()?, stride);
            let band = crate::passes::Band { row_offset: 0, rows: frame.height };
            return match (how.after_band)(band, &frame.pixels) {
                true => Ok(frame),
                false => Err(RenderError::Cancelled),
            };
        }
        let hooked = sink::Hooked { after_band: how.after_band, inner: Collect::default() };
        let mut sink = sink::Colored::new(colorer.as_ref(), stride, hooked);
        match scene.render.method {
            Method::Mesh => self.render_scene_mesh(scene, grid, gpu_grid, time, &mut sink)?,
            _ => self.draw_rays(scene, grid, gpu_grid, time, stride, how.band_rows, &mut sink)?,
        }
        sink.inner.inner.into_frame()
    }

    /// Renders the whole image into `sink`, band by band, keeping no band once the sink has
    /// it: memory stays at one band of records whatever the image's size.
    pub fn render_to(
        &mut self,
        scene: &Scene,
        grid: &Grid,
        gpu_grid: &GpuGrid,
        time: f64,
        sink: &mut dyn FrameSink,
    ) -> Result<(), RenderError> {
        let colorer = color::Colorer::new(scene, grid, time)?;
        let mut sink = sink::Colored::new(colorer.as_ref(), 1, sink);
        match scene.render.method {
            Method::Mesh if gpu_grid.block.is_some() => {
                Err(RenderError::Unsupported("mesh (on a block of the grid)"))
            }
            Method::Mesh => self.render_scene_mesh(scene, grid, gpu_grid, time, &mut sink),
            _ => self.draw_rays(scene, grid, gpu_grid, time, 1, u32::MAX, &mut sink),
        }
    }

    /// The ray methods (fixed-step, analytic): every `stride`-th pixel, bands of at most
    /// `band_rows` rows, each band placed in world space and handed to `sink`.
    #[allow(clippy::too_many_arguments)]
    fn draw_rays(
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
        self.last_bricks_ms = None;
        self.last_brick_levels = None;
        if scene.render.method == Method::Analytic && gpu_grid.bricks.get().is_none() {
            let image = gpu_grid.image("the brick min/max grid of a brick pool")?;
            let built = bricks::build(&self.ctx, &self.bricks, image, gpu_grid.dims)?;
            let _ = gpu_grid.supers.set(built.supers);
            let _ = gpu_grid.bricks.set(built.buffer);
            self.last_bricks_ms = built.ms;
        }
        let mut walk = || {
            let surfaces = params.view[3];
            let thresholds = params.surface_thresholds();
            let supers = gpu_grid.supers.get().map_or(&[][..], |s| &s[..]);
            let chosen =
                self.brick_levels.unwrap_or_else(|| bricks::levels_for(supers, &thresholds));
            let levels = if scene.render.skip { chosen.clamp(1, 2) } else { 1 };
            self.last_brick_levels = Some(levels);
            analytic::Walk { levels, surfaces }
        };
        let shader = match (scene.render.method, &gpu_grid.storage) {
            (Method::Mesh, _) => return Err(RenderError::Unsupported("mesh (as a ray pass)")),
            (Method::FixedStep, Storage::Pool(_)) => RayShader::FixedStepPool,
            (Method::FixedStep, Storage::Image(_)) => RayShader::FixedStep,
            (Method::Analytic, Storage::Pool(_)) => RayShader::AnalyticPool(walk()),
            (Method::Analytic, Storage::Image(image)) => {
                let bytes = image.extent.iter().map(|&e| e as u64).product::<u64>() * 4;
                if gpu_grid.block.is_none() && bytes <= self.ctx.info.max_storage_buffer_range {
                    if gpu_grid.points.get().is_none() {
                        let _ = gpu_grid.points.set(image.copy_to_buffer("grid points")?);
                    }
                    RayShader::AnalyticBuffer(walk())
                } else {
                    RayShader::Analytic(walk())
                }
            }
        };
        if !self.ray_pipelines.contains_key(&shader) {
            self.ray_pipelines.insert(shader, shader.pipeline(&self.ctx)?);
        }
        let pipeline = &self.ray_pipelines[&shader];
        let ctx = &self.ctx;
        let (width, height) =
            Progressive::picture_size(stride, scene.image.width, scene.image.height);
        params.image[2] = stride;
        params.image[3] = width;
        if let Some(b) = &gpu_grid.block {
            if scene.render.method != Method::Analytic {
                return Err(RenderError::Unsupported("fixed-step (on a block of the grid)"));
            }
            let i = |v: [usize; 3]| [v[0] as i32, v[1] as i32, v[2] as i32, 0];
            (params.block_lo, params.block_hi) = (i(b.cells_lo), i(b.cells_hi));
            params.block_origin = i(b.origin);
        }
        let params_buf = Buffer::upload(
            ctx,
            "params",
            std::slice::from_ref(&params),
            vk::BufferUsageFlags::UNIFORM_BUFFER,
        )?;
        let bands = Bands::<Pixel>::with_max_rows(ctx, "pixels", width, height, band_rows)?;
        let bricks = match scene.render.method {
            Method::Analytic => gpu_grid.bricks.get(),
            _ => None,
        };
        let grid_input = match (&gpu_grid.storage, shader) {
            (Storage::Image(_), RayShader::AnalyticBuffer(_)) => GridInput::Points(
                gpu_grid
                    .points
                    .get()
                    .ok_or_else(|| GpuError::Bug("grid points not copied".into()))?,
            ),
            (Storage::Image(image), _) => GridInput::Image(image),
            (Storage::Pool(p), _) => GridInput::Pool {
                pool: &p.pool,
                pages: &p.pages,
                bricks: gpu_grid.bricks.get().ok_or_else(|| {
                    GpuError::Bug("a brick pool was uploaded without its brick grid".into())
                })?,
            },
        };
        let pass = RayPass::new(
            pipeline,
            RayInputs {
                params: &params_buf,
                grid: grid_input,
                pixels: &bands.out,
                colormap: &self.colormap,
                bricks,
            },
        )?;
        let mut info = self.frame_info(scene, grid, time);
        if stride > 1 {
            info.extra.push(("stride".into(), stride.to_string()));
        }
        sink.begin(width, height, &info)?;
        let placement = scene.field.placement;
        let gpu_ms = bands.for_each_band(
            pass.name(),
            |band, records| placed_band(sink, &placement, band, records),
            |rec, band| {
                pass.record(rec, width, band);
                Ok(())
            },
        )?;
        self.last_gpu_ms = gpu_ms;
        Ok(())
    }

    pub(crate) fn frame_info(&self, scene: &Scene, grid: &Grid, time: f64) -> FrameInfo {
        let r = &scene.render;
        let mut extra = vec![
            ("shading".to_string(), r.shading.name().to_string()),
            ("inside".to_string(), format!("{:?}", scene.surface.inside).to_lowercase()),
            ("grid".to_string(), format!("{}x{}x{}", grid.dims[0], grid.dims[1], grid.dims[2])),
            ("steps_scale".to_string(), format!("{}", params::steps_scale(scene, grid))),
        ];
        match r.method {
            Method::FixedStep => extra.push(("steps".into(), r.steps.to_string())),
            Method::Analytic => {
                extra.push(("newton_steps".into(), r.newton_steps.to_string()));
                extra.push(("skip".into(), r.skip.to_string()));
                extra.push(("crossing".into(), r.crossing.to_string()));
            }
            Method::Mesh => extra.push(("mesh".into(), r.mesh.name().to_string())),
        }
        if scene.surface.several() {
            let isos: Vec<String> = scene.surface.isovalues().iter().map(f64::to_string).collect();
            extra.push(("isovalues".into(), format!("[{}]", isos.join(", "))));
            let colors: Vec<String> = (0..scene.surface.count)
                .map(|k| {
                    let [r, g, b] = scene.surface.color(k, r.color);
                    format!("[{r}, {g}, {b}]")
                })
                .collect();
            extra.push(("surface_colors".into(), colors.join("; ")));
        }
        if scene.color.by != crate::scene::ColorBy::Surface {
            extra.push(("color.by".into(), scene.color.by.name().into()));
            extra.push(("color.colormap".into(), scene.color.colormap_name().into()));
            if let Some([lo, hi]) = scene.color.range {
                extra.push(("color.range".into(), format!("[{lo}, {hi}]")));
            }
        }
        if scene.clip.count > 0 {
            let planes: Vec<String> = scene
                .clip
                .planes()
                .iter()
                .map(|(n, o)| format!("[{}, {}, {}] {}", n.x, n.y, n.z, o))
                .collect();
            extra.push(("clip".into(), planes.join("; ")));
        }
        if scene.render.normals != Normals::Trilinear {
            extra.push(("normals".into(), scene.render.normals.name().into()));
        }
        if scene.camera.projection == Projection::Orthographic {
            extra.push(("projection".into(), "orthographic".into()));
            extra.push(("ortho_height".into(), scene.camera.ortho_height.to_string()));
        }
        if let Some(p) = crate::output::describe_placement(&scene.field.placement) {
            extra.push(("placement".into(), p));
        }
        if r.method != Method::FixedStep {
            // Whether the `crossings` channel was counted (it is absent when not).
            extra.push(("count_crossings".into(), r.count_crossings.to_string()));
        }
        FrameInfo {
            scene: scene.path.as_ref().map(|p| p.display().to_string()).unwrap_or_default(),
            eye: scene.camera.eye,
            target: scene.camera.target,
            up: scene.camera.up,
            fov_y_deg: scene.camera.fov_y_deg,
            ortho_height: (scene.camera.projection == Projection::Orthographic)
                .then_some(scene.camera.ortho_height),
            isovalue: scene.surface.isovalue,
            method: r.method.name().to_string(),
            time,
            device: self.ctx.info.name.clone(),
            driver: self.ctx.info.driver_info.clone(),
            extra,
            legend: None,
        }
    }
}

/// Hands a band to `sink` as the frame holds it: placed in world space.
fn placed_band(
    sink: &mut dyn FrameSink,
    placement: &crate::vocab::Placement,
    band: crate::passes::Band,
    records: &[Pixel],
) -> Result<(), RenderError> {
    if placement.is_identity() {
        return sink.band(band, records);
    }
    let mut placed = records.to_vec();
    crate::frame::place_pixels(&mut placed, placement);
    sink.band(band, &placed)
}

/// Every `stride`-th pixel of every `stride`-th row of `frame` (the picture a strided ray
/// pass draws).
fn subsample(frame: Frame, stride: u32) -> Frame {
    if stride <= 1 {
        return frame;
    }
    let (width, height) = Progressive::picture_size(stride, frame.width, frame.height);
    let mut pixels = Vec::with_capacity(width as usize * height as usize);
    for j in 0..height {
        for i in 0..width {
            pixels.push(*frame.pixel(i * stride, j * stride));
        }
    }
    let mut info = frame.info;
    info.extra.push(("stride".into(), stride.to_string()));
    Frame { width, height, pixels, info }
}
