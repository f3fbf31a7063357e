//! The mesh render (`render.method = "mesh"`): a triangle mesh drawn with the scene's camera
//! into the same [`Pixel`](crate::frame::Pixel) channels as the ray passes, in two compute
//! passes per band of rows:
//!
//! ```text
//!   mesh_raster.comp   one invocation per triangle: screen box -> exact ray-triangle test per
//!                      pixel centre -> atomicMin(vis[pixel], t bits << 32 | triangle id),
//!                      atomicAdd(tested), atomicAdd(hits)
//!   mesh_resolve.comp  one invocation per pixel: winning triangle -> Z, P, N (interpolated
//!                      vertex normals), cell, steps = tested, crossings = hits, shade()
//! ```
//!
//! The visibility key needs 64-bit buffer atomics (`shaderBufferInt64Atomics`; lavapipe and the
//! desktop drivers have them). Mesh buffers have the layout of the GPU extraction's output
//! (`GpuMesh`): positions and normals as one `vec4` per vertex, indices as three `u32` per
//! triangle, counter-clockwise seen from outside. [`upload`] puts a CPU
//! [`Mesh`] into that layout. The f64 mirror is `reference::mesh`. [`MeshPass`] records both
//! passes of a band.

use std::sync::Arc;

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::Band;
use crate::gpu::{
    grid_groups, spread_groups, Binding, Buffer, ComputePipeline, Context, Dispatch, GpuError,
    Image3d, MemoryLocation, Recorder, Resource,
};
use crate::mesh::Mesh;
use crate::passes::extract::GpuMesh;
use crate::shaders;

/// Invocations per workgroup of the raster pass.
pub const RASTER_GROUP: u32 = shaders::consts::RASTER_GROUP;
/// Workgroup side of the resolve pass (8 x 8 pixels, as the ray passes).
pub const RESOLVE_GROUP: u32 = shaders::consts::RAY_GROUP;
/// Bytes per pixel of the visibility buffer (one u64 key).
pub const VIS_BYTES: u64 = 8;
/// Bytes per pixel of the counts buffer (tested, hits: two u32).
pub const COUNT_BYTES: u64 = 8;
/// Bytes of the "no hit" key word: the visibility buffer is filled with this 32-bit word.
pub const NO_HIT_WORD: u32 = u32::MAX;

/// Push constants of `mesh_raster.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RasterPush {
    pub row_offset: u32,
    pub rows: u32,
    pub triangle_count: u32,
    /// Invocations per row of the 2D dispatch (`groups_x * RASTER_GROUP`).
    pub threads_x: u32,
}

const STORAGE: vk::BufferUsageFlags = vk::BufferUsageFlags::STORAGE_BUFFER;

/// Uploads a CPU mesh (through staging buffers) into device-local storage buffers in the layout
/// of the GPU extraction's output.
pub fn upload(ctx: &Arc<Context>, mesh: &Mesh) -> Result<GpuMesh, GpuError> {
    let too_large = |what: &str| GpuError::TooLarge {
        what: format!("the number of the mesh's {what}"),
        limit: "32-bit indices".into(),
    };
    let vertex_count = u32::try_from(mesh.vertex_count()).map_err(|_| too_large("vertices"))?;
    let triangle_count =
        u32::try_from(mesh.triangle_count()).map_err(|_| too_large("triangles"))?;
    let four = |v: &[f32; 3], w: f32| [v[0], v[1], v[2], w];
    let positions: Vec<[f32; 4]> = mesh.positions.iter().map(|p| four(p, 1.0)).collect();
    let normals: Vec<[f32; 4]> = mesh.normals.iter().map(|n| four(n, 0.0)).collect();
    let limit = ctx.info.max_storage_buffer_range;
    if (positions.len() * 16) as u64 > limit || (mesh.indices.len() * 4) as u64 > limit {
        return Err(GpuError::TooLarge {
            what: format!("the mesh ({vertex_count} vertices, {triangle_count} triangles)"),
            limit: format!("the device's largest storage buffer ({} MiB)", limit >> 20),
        });
    }
    Ok(GpuMesh::from_buffers(
        ctx,
        Buffer::upload(ctx, "mesh positions", &positions, STORAGE)?,
        Buffer::upload(ctx, "mesh normals", &normals, STORAGE)?,
        Buffer::upload(ctx, "mesh indices", &mesh.indices, STORAGE)?,
        vertex_count,
        triangle_count,
    ))
}

/// The two pipelines of the mesh render.
pub struct MeshPipelines {
    pub raster: ComputePipeline,
    pub resolve: ComputePipeline,
}

impl MeshPipelines {
    /// Builds both pipelines; fails with a clear message on a device without 64-bit buffer
    /// atomics.
    pub fn new(ctx: &Arc<Context>) -> Result<Self, GpuError> {
        if !ctx.info.int64_atomics {
            return Err(GpuError::Unsupported {
                what: "render.method = \"mesh\"".into(),
                feature: "64-bit buffer atomics (shaderInt64 and shaderBufferInt64Atomics)".into(),
                device: ctx.info.name.clone(),
                instead: "use another device (--device) or method".into(),
            });
        }
        use Binding::{Read, ReadWrite, Uniform};
        // params, positions, indices; the visibility and count buffers (atomics).
        let raster = ComputePipeline::new(
            ctx,
            "mesh_raster",
            shaders::MESH_RASTER,
            &[Uniform, Read, Read, ReadWrite, ReadWrite],
            std::mem::size_of::<RasterPush>() as u32,
        )?;
        // The ray passes' bindings, then positions, normals, indices, visibility and counts.
        let mut resolve_bindings = crate::passes::raymarch::RAY_BINDINGS.to_vec();
        resolve_bindings.extend([Read; 5]);
        let resolve = ComputePipeline::new(
            ctx,
            "mesh_resolve",
            shaders::MESH_RESOLVE,
            &resolve_bindings,
            std::mem::size_of::<super::Band>() as u32,
        )?;
        Ok(MeshPipelines { raster, resolve })
    }

    /// Workgroups of the raster pass for `triangles` (2D: at most 65535 groups per row) and the
    /// invocations per row.
    pub fn raster_groups(triangles: u32) -> Result<([u32; 3], u32), GpuError> {
        let groups = spread_groups(u64::from(triangles.div_ceil(RASTER_GROUP)))?;
        Ok((groups, groups[0] * RASTER_GROUP))
    }
}

/// What the mesh render reads for one picture, and the band of pixels it writes.
pub struct MeshInputs<'a> {
    /// `RenderParams` (uniform).
    pub params: &'a Buffer,
    pub grid: &'a Image3d,
    pub mesh: &'a GpuMesh,
    pub colormap: &'a Buffer,
    /// The band's `Pixel`s, written.
    pub pixels: &'a Buffer,
}

/// The two mesh passes bound to their inputs, with their per-pixel scratch (visibility keys and
/// counts) for bands of up to `band_pixels` pixels; records one band at a time.
pub struct MeshPass<'a> {
    pipes: &'a MeshPipelines,
    inputs: MeshInputs<'a>,
    vis: Buffer,
    counts: Buffer,
    raster: Dispatch,
    resolve: Dispatch,
}

impl<'a> MeshPass<'a> {
    pub fn new(
        ctx: &Arc<Context>,
        pipes: &'a MeshPipelines,
        inputs: MeshInputs<'a>,
        band_pixels: u64,
    ) -> Result<Self, GpuError> {
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
        let i = &inputs;
        let raster = pipes.raster.bind(&[
            Resource::Uniform(i.params),
            Resource::Storage(&i.mesh.positions),
            Resource::Storage(&i.mesh.indices),
            Resource::Storage(&vis),
            Resource::Storage(&counts),
        ])?;
        let resolve = pipes.resolve.bind(&[
            Resource::Uniform(i.params),
            Resource::Sampled(i.grid),
            Resource::Storage(i.pixels),
            Resource::Storage(i.colormap),
            Resource::Storage(&i.mesh.positions),
            Resource::Storage(&i.mesh.normals),
            Resource::Storage(&i.mesh.indices),
            Resource::Storage(&vis),
            Resource::Storage(&counts),
        ])?;
        Ok(MeshPass { pipes, inputs, vis, counts, raster, resolve })
    }

    /// Records the band: clear the scratch (no hit, nothing counted), raster (one invocation
    /// per triangle, none without triangles), resolve (one per pixel, [`RESOLVE_GROUP`]² per
    /// workgroup).
    pub fn record(&self, rec: &mut Recorder, width: u32, band: Band) -> Result<(), GpuError> {
        let mesh = self.inputs.mesh;
        rec.fill(&self.vis, 0, self.vis.size, NO_HIT_WORD);
        rec.fill(&self.counts, 0, self.counts.size, 0);
        if mesh.triangle_count > 0 {
            let (groups, threads_x) = MeshPipelines::raster_groups(mesh.triangle_count)?;
            let push = RasterPush {
                row_offset: band.row_offset,
                rows: band.rows,
                triangle_count: mesh.triangle_count,
                threads_x,
            };
            rec.dispatch(&self.pipes.raster, &self.raster, bytemuck::bytes_of(&push), groups);
        }
        let groups = grid_groups([width, band.rows, 1], [RESOLVE_GROUP, RESOLVE_GROUP, 1]);
        rec.dispatch(&self.pipes.resolve, &self.resolve, bytemuck::bytes_of(&band), groups);
        Ok(())
    }
}
