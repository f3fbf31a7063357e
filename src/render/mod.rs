//! Rendering a scene: upload the grid as a 3D image, run the method's ray pass over bands of
//! rows ([`crate::passes::Bands`]), read the pixels back into a [`Frame`]. The analytic pass
//! also reads the grid's brick min/max grid (empty-space skipping), built on the GPU the first
//! time an analytic render uses an uploaded grid and kept with it.
//!
//! | file | what |
//! | --- | --- |
//! | this one | [`Renderer`]: its pipelines and the entry points ([`Renderer::render`], `render_uploaded`, `render_progressive`, `render_to`), [`Progressive`], [`RenderError`] |
//! | [`grid`] | [`GpuGrid`]: the grid on the device (whole, one MPI block, or a brick pool) and its brick min/max grid |
//! | [`rays`] | the ray methods (fixed-step, analytic): which shader, its inputs, the bands |
//! | [`mesh`] | the mesh method: extract, upload, draw |
//! | [`info`] | what a frame says about itself: [`scene_channels`] and its `FrameInfo` |
//! | [`sink`] | where the bands go ([`FrameSink`], [`Collect`]) |
//! | [`color`] | `[color] by`, and the colormaps the shaders read |
//! | [`params`] | `RenderParams`, the ray and mesh passes' uniform |
//! | [`block`], [`pool`] | a process's block of a larger grid (MPI); the bricks an isovalue needs |

pub mod block;
pub mod color;
pub mod grid;
mod info;
pub mod mesh;
pub mod params;
pub mod pool;
mod rays;
pub mod sink;

use std::sync::Arc;

use ash::vk;

use crate::field::Grid;
use crate::frame::{Frame, Pixel};
use crate::gpu::{Buffer, ComputePipeline, Context, GpuError};
use crate::passes::bricks;
use crate::passes::mesh_render::MeshPipelines;
use crate::scene::{Method, Scene};
pub use color::{colormap, linear_colormap};
pub use grid::GpuGrid;
pub use info::{scene_channels, scene_files};
use rays::RayShader;
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
    /// The scene's interpolant is not read by its method or the grid's storage
    /// (`Interpolant::refusal`), one line naming `field.interpolation`.
    #[error("{0}")]
    Refused(String),
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

/// How the analytic walk crosses empty space where it may use the occupancy structure (a whole
/// grid with `render.skip` on; MPI blocks and brick pools walk [`Accel::Plain`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Accel {
    /// Jumps over empty bricks (and superbricks), every cell of the others read.
    Plain,
    /// The occupancy structure ([`crate::passes::occupancy`]) in one pass.
    Occupancy,
    /// The same in two passes: every ray's empty bricks from its start, then the walk of the
    /// rays that met a brick that may hold a surface (needs subgroup ballots; else one pass).
    TwoPass,
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
    /// How the analytic walk over a whole grid with skipping on crosses empty space: the
    /// occupancy structure in two passes where the device has subgroup ballots, else in one
    /// ([`Accel`]). Images are the same bit for bit every way but `steps` (the work each walk
    /// does); tests and benchmarks choose to compare.
    pub accel: Accel,
    /// Whether the ray passes over a whole grid read it from a storage buffer where it fits
    /// one (the default; the same samples as the image's, far fewer instructions on llvmpipe)
    /// or from the grid image; tests compare the two.
    pub grid_buffer: bool,
    /// Wall time of making the brick min/max grid on the CPU during the last frame (a CPU
    /// device's way), in milliseconds (None when the frame did not make it there).
    pub last_bricks_cpu_ms: Option<f64>,
    /// GPU time of building the occupancy structure during the last frame, in milliseconds
    /// (None when the frame did not build it, or without timestamps).
    pub last_occupancy_ms: Option<f64>,
    /// Whether the last frame built the occupancy structure (for new isovalues or a new grid).
    pub built_occupancy: bool,
    /// The two-pass walk's list of rays, kept between renders (`passes::listed::Listed`).
    listed: Option<crate::passes::listed::Listed>,
    /// The occupancy structure's passes, per surface count, built on first use.
    occupancy_pipelines: std::collections::HashMap<u32, crate::passes::occupancy::Pipelines>,
}

impl Renderer {
    /// Drops the ray and mesh-render pipelines; the next frame builds the ones it uses again.
    /// Called between the frames of a long run: lavapipe (Mesa 22) compiles a variant of a
    /// pipeline for each dispatch whose uniforms it can inline (the band's push constants,
    /// the loop bounds in `Params`) and frees the variants only with the pipeline, so a
    /// pipeline kept for the whole of `render --frames` grew memory by about 1 MiB a frame.
    pub fn release_pipelines(&mut self) {
        self.ray_pipelines.clear();
        self.occupancy_pipelines.clear();
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
            accel: match ctx.info.subgroup_ballot {
                true => Accel::TwoPass,
                false => Accel::Occupancy,
            },
            grid_buffer: true,
            last_bricks_cpu_ms: None,
            last_occupancy_ms: None,
            built_occupancy: false,
            occupancy_pipelines: Default::default(),
            listed: None,
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
        self.occupancy_pipelines.clear();
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
        refuse_interpolant(scene)?;
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
        refuse_interpolant(scene)?;
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
}

/// The scene's method must read its interpolant (the CLI and `serve` refuse such a scene before
/// it reaches the device; this keeps every other caller of the library to the same table).
fn refuse_interpolant(scene: &Scene) -> Result<(), RenderError> {
    match scene.interpolation_refusal(scene.render_reader()) {
        Some(why) => Err(RenderError::Refused(why)),
        None => Ok(()),
    }
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
