//! `render.method = "mesh"`: extract the isosurface with `render.mesh`, put it on the device and
//! draw it with the mesh passes (`passes::mesh_render`), band by band, into the same `Pixel`
//! records as the ray passes.

use ash::vk;

use super::params::RenderParams;
use super::{run_bands, GpuGrid, RenderError, Renderer};
use crate::field::Grid;
use crate::frame::{Frame, Pixel};
use crate::gpu::{fill_buffer, memory_barrier, Buffer, MemoryLocation, Resource};
use crate::mesh::{self, ExtractOptions, Mesh};
use crate::passes::extract::{Extractor, GpuExtractOptions, GpuMesh};
use crate::passes::mesh_render::{
    self, MeshPipelines, RasterPush, COUNT_BYTES, NO_HIT_WORD, RESOLVE_GROUP, VIS_BYTES,
};
use crate::scene::{MeshAlgorithm, Scene};

/// The mesh of `scene`'s surface over `grid`, extracted on the CPU (the reference of what
/// `render.method = "mesh"` draws).
pub fn scene_mesh(scene: &Scene, grid: &Grid) -> Result<Mesh, RenderError> {
    Ok(mesh::extract(
        grid,
        scene.surface.isovalue,
        scene.surface.inside,
        scene.render.mesh,
        ExtractOptions::default(),
    )?)
}

impl Renderer {
    /// Extracts the scene's mesh from the uploaded grid on the GPU (the mesh stays on the
    /// device) and draws it. On a device without `shaderFloat64`, which the mc33 passes need,
    /// `mc33` is extracted on the CPU and uploaded.
    pub(super) fn render_scene_mesh(
        &mut self,
        scene: &Scene,
        grid: &Grid,
        gpu_grid: &GpuGrid,
        time: f64,
    ) -> Result<Frame, RenderError> {
        let mesh = if scene.render.mesh == MeshAlgorithm::Mc33 && !self.ctx.info.float64 {
            mesh_render::upload(&self.ctx, &scene_mesh(scene, grid)?)?
        } else {
            if self.extractor.is_none() {
                self.extractor = Some(Extractor::new(&self.ctx)?);
            }
            let extractor = self.extractor.as_mut().expect("created above");
            extractor.extract(
                grid,
                &gpu_grid.image,
                scene.surface.isovalue,
                scene.surface.inside,
                scene.render.mesh,
                &GpuExtractOptions::default(),
            )?
        };
        self.render_mesh(scene, grid, gpu_grid, &mesh, time)
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
        if self.mesh.is_none() {
            self.mesh = Some(MeshPipelines::new(&self.ctx)?);
        }
        let pipes = self.mesh.as_ref().expect("created above");
        let ctx = &self.ctx;
        let (width, height) = (scene.image.width, scene.image.height);
        let pixel_bytes = std::mem::size_of::<Pixel>() as u64;
        let band_rows = super::band_rows(ctx, width, height, pixel_bytes);
        let band_pixels = band_rows as u64 * width as u64;

        let params = RenderParams::new(scene, grid);
        let params_buf = Buffer::upload(
            ctx,
            "params",
            std::slice::from_ref(&params),
            vk::BufferUsageFlags::UNIFORM_BUFFER,
        )?;
        let scratch = |name: &str, bytes: u64| {
            Buffer::new(
                ctx,
                name,
                bytes,
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuOnly,
            )
        };
        let vis = scratch("mesh visibility", band_pixels * VIS_BYTES)?;
        let counts = scratch("mesh counts", band_pixels * COUNT_BYTES)?;
        let out = Buffer::new(
            ctx,
            "pixels",
            band_pixels * pixel_bytes,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        let readback = Buffer::new(
            ctx,
            "pixels readback",
            out.size,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        let raster_set = pipes.raster.bind(&MeshPipelines::raster_resources(
            &params_buf,
            mesh,
            &vis,
            &counts,
        ))?;
        let resolve_set = pipes.resolve.bind(&[
            Resource::Uniform(&params_buf),
            Resource::Sampled(&gpu_grid.image),
            Resource::Storage(&out),
            Resource::Storage(&self.colormap),
            Resource::Storage(&mesh.positions),
            Resource::Storage(&mesh.normals),
            Resource::Storage(&mesh.indices),
            Resource::Storage(&vis),
            Resource::Storage(&counts),
        ])?;

        let (raster_groups, threads_x) = MeshPipelines::raster_groups(mesh.triangle_count);
        let (pixels, gpu_ms) = run_bands(
            ctx,
            "mesh_raster + mesh_resolve",
            (width, height, band_rows),
            &out,
            &readback,
            |cmd, band| {
                let push = RasterPush {
                    row_offset: band.row_offset,
                    rows: band.rows,
                    triangle_count: mesh.triangle_count,
                    threads_x,
                };
                // Clear: no hit, nothing counted.
                fill_buffer(ctx, cmd, &vis, 0, vis.size, NO_HIT_WORD);
                fill_buffer(ctx, cmd, &counts, 0, counts.size, 0);
                memory_barrier(
                    ctx,
                    cmd,
                    (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_WRITE),
                    (
                        vk::PipelineStageFlags::COMPUTE_SHADER,
                        vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE,
                    ),
                );
                if mesh.triangle_count > 0 {
                    pipes.raster.record(cmd, &raster_set, bytemuck::bytes_of(&push), raster_groups);
                    memory_barrier(
                        ctx,
                        cmd,
                        (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_WRITE),
                        (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_READ),
                    );
                }
                pipes.resolve.record(
                    cmd,
                    &resolve_set,
                    bytemuck::bytes_of(&band),
                    [width.div_ceil(RESOLVE_GROUP), band.rows.div_ceil(RESOLVE_GROUP), 1],
                );
            },
        )?;
        self.last_gpu_ms = gpu_ms;
        let mut info = self.frame_info(scene, grid, time);
        info.extra.push(("mesh_triangles".into(), mesh.triangle_count.to_string()));
        info.extra.push(("mesh_vertices".into(), mesh.vertex_count.to_string()));
        Ok(Frame { width, height, pixels, info })
    }
}
