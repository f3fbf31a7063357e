//! `render.method = "mesh"`: extract the isosurface with `render.mesh`, put it on the device and
//! draw it with the mesh passes (`passes::mesh_render`), band by band, into the same `Pixel`
//! records as the ray passes.

use ash::vk;

use super::params::RenderParams;
use super::sink::placed_band;
use super::{Collect, FrameSink, GpuGrid, RenderError, Renderer};
use crate::field::Grid;
use crate::frame::{Frame, Pixel};
use crate::gpu::Buffer;
use crate::mesh::{self, Mesh, MeshBudget, MeshLimits};
use crate::passes::extract::{Extractor, GpuExtractOptions, GpuMesh};
use crate::passes::mesh_render::{self, MeshInputs, MeshPass, MeshPipelines};
use crate::passes::Bands;
use crate::scene::Scene;

/// The mesh of `scene`'s surface over `grid`, extracted on the CPU (the reference of what
/// `render.method = "mesh"` draws) at time 0.
pub fn scene_mesh(scene: &Scene, grid: &Grid) -> Result<Mesh, RenderError> {
    scene_mesh_at(scene, grid, 0.0)
}

/// [`scene_mesh`] of the grid sampled at `time` (`render.hermite = "source"` evaluates the
/// source at that time). The mesh is held under the cap of `ISOVIEW_MAX_MESH_MIB`
/// ([`MeshLimits::from_env`]): extracted in slabs on all threads (the reference's mesh, bit
/// for bit), each counted as it is done, so a mesh past the cap stops there.
pub fn scene_mesh_at(scene: &Scene, grid: &Grid, time: f64) -> Result<Mesh, RenderError> {
    let source = crate::field::PointField::from_spec(&scene.field, time);
    let x = scene.mesh_request(0, source.as_ref());
    Ok(mesh::extract(grid, &x, &MeshBudget::new(MeshLimits::from_env()?))?)
}

impl Renderer {
    /// Extracts the scene's mesh from the uploaded grid on the GPU (the mesh stays on the
    /// device) and draws it. Where the method's GPU passes do not run it
    /// (`mesh::method::Method::cpu_instead`: none for it, or mc33 on a device without
    /// `shaderFloat64`) it is extracted on the CPU and uploaded. The picture goes to `sink`
    /// band by band.
    pub(super) fn render_scene_mesh(
        &mut self,
        scene: &Scene,
        grid: &Grid,
        gpu_grid: &GpuGrid,
        time: f64,
        sink: &mut dyn FrameSink,
    ) -> Result<(), RenderError> {
        if scene.surface.several() {
            // One mesh per surface, each drawn alone, composited: what one draw of the merged
            // meshes gives (its nearest triangle; ties to the lower surface, whose triangles
            // come first; every triangle tested), without a merged mesh on the device. The
            // layers are whole pictures, so this case is not streamed band by band.
            let mut layers = Vec::with_capacity(scene.surface.count);
            let mut info = None;
            for k in 0..scene.surface.count {
                let mut layer = Collect::default();
                self.render_scene_mesh(&scene.single_surface(k), grid, gpu_grid, time, &mut layer)?;
                let frame = layer.into_frame()?;
                layers.push(frame.pixels);
                info.get_or_insert(frame.info);
            }
            let (width, height) = (scene.image.width, scene.image.height);
            let mut info = info.expect("at least two surfaces");
            info.extra = self.frame_info(scene, grid, time).extra;
            let pixels = crate::frame::composite_surfaces(&layers);
            sink.begin(width, height, &info)?;
            return sink.band(crate::passes::Band { row_offset: 0, rows: height }, &pixels);
        }
        let method = scene.render.mesh.method();
        let cpu = method.cpu_instead(&scene.render.sharp, self.ctx.info.float64).is_some()
            || !scene.mesh_request(0, None).on_grid();
        let mesh = if cpu {
            mesh_render::upload(&self.ctx, &scene_mesh_at(scene, grid, time)?)?
        } else {
            // The device's mesh lies in device memory (an allocation over it fails as a GPU
            // error); the same cap as the CPU's mesh is checked on its counts before drawing.
            let limits = MeshLimits::from_env()?;
            if self.extractor.is_none() {
                self.extractor = Some(Extractor::new(&self.ctx)?);
            }
            let extractor = self.extractor.as_mut().expect("created above");
            let mesh = extractor.extract(
                grid,
                gpu_grid.image("render.method = \"mesh\" with field.residency = \"active\"")?,
                scene.surface.isovalue,
                scene.surface.inside,
                scene.render.mesh,
                &GpuExtractOptions { sharp: Some(scene.render.sharp), ..Default::default() },
            )?;
            let (vertices, triangles) = (mesh.vertex_count as usize, mesh.triangle_count as usize);
            MeshBudget::new(limits).add(vertices, triangles, 0)?;
            mesh
        };
        self.render_mesh_to(scene, grid, gpu_grid, &mesh, time, sink)
    }

    /// Draws `mesh` with `scene`'s camera and shading. `grid` (uploaded as `gpu_grid`) gives the
    /// box and cells that the `cell` channel, `cells` shading and `depth` shading refer to; the
    /// mesh need not come from it.
    pub fn render_mesh(
        &mut self,
        scene: &Scene,
        grid: &Grid,
        gpu_grid: &GpuGrid,
        mesh: &GpuMesh,
        time: f64,
    ) -> Result<Frame, RenderError> {
        let mut frame = Collect::default();
        self.render_mesh_to(scene, grid, gpu_grid, mesh, time, &mut frame)?;
        frame.into_frame()
    }

    /// [`Renderer::render_mesh`] into `sink`, band by band.
    pub fn render_mesh_to(
        &mut self,
        scene: &Scene,
        grid: &Grid,
        gpu_grid: &GpuGrid,
        mesh: &GpuMesh,
        time: f64,
        sink: &mut dyn FrameSink,
    ) -> Result<(), RenderError> {
        if self.mesh.is_none() {
            self.mesh = Some(MeshPipelines::new(&self.ctx)?);
        }
        let pipes = self.mesh.as_ref().expect("created above");
        let ctx = &self.ctx;
        let (width, height) = (scene.image.width, scene.image.height);
        let params = RenderParams::new(scene, grid);
        let params_buf = Buffer::upload(
            ctx,
            "params",
            std::slice::from_ref(&params),
            vk::BufferUsageFlags::UNIFORM_BUFFER,
        )?;
        let bands = Bands::<Pixel>::new(ctx, "pixels", width, height)?;
        let inputs = MeshInputs {
            params: &params_buf,
            grid: gpu_grid.image("render.method = \"mesh\" with field.residency = \"active\"")?,
            mesh,
            colormap: &self.colormap,
            pixels: &bands.out,
        };
        let pass = MeshPass::new(ctx, pipes, inputs, bands.band_pixels(), params.clip_count)?;
        let mut info = self.frame_info(scene, grid, time);
        info.extra.push(("mesh_triangles".into(), mesh.triangle_count.to_string()));
        info.extra.push(("mesh_vertices".into(), mesh.vertex_count.to_string()));
        sink.begin(width, height, &info)?;
        let placement = scene.field.placement;
        let gpu_ms = bands.for_each_band(
            "mesh_raster + mesh_resolve",
            |band, records| {
                pass.check_band()?;
                placed_band(sink, &placement, band, records)
            },
            |rec, band| pass.record(rec, width, band),
        )?;
        self.last_gpu_ms = gpu_ms;
        Ok(())
    }
}
