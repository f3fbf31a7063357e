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
/// Triangles the raster's first stage lists for its second per band (mesh_raster.comp).
pub const LARGE_CAPACITY: u32 = shaders::consts::LARGE_CAPACITY;
/// Loop passes one raster invocation may make: under llvmpipe's 65,535 per invocation
/// (mesh_raster.comp's header).
pub const RASTER_PASSES: u32 = 60_000;
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
    /// Most pixels one invocation tests ([`MeshPass::chunk_pixels`]).
    pub chunk_pixels: u32,
    /// 0: every triangle, the large ones listed; 1: the listed ones, a chunk per invocation.
    pub stage: u32,
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
            // ... and the listed large triangles, their count and second-stage dispatch.
            &[Uniform, Read, Read, ReadWrite, ReadWrite, ReadWrite, ReadWrite],
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
    /// The large triangles listed (kept: the raster's set binds it), then their count and the
    /// indirect dispatch.
    _large: Buffer,
    large_count: Buffer,
    large_readback: Buffer,
    chunk_pixels: u32,
    /// Chunks of the largest box a band holds.
    max_chunks: u32,
    raster: Dispatch,
    resolve: Dispatch,
}

impl<'a> MeshPass<'a> {
    pub fn new(
        ctx: &Arc<Context>,
        pipes: &'a MeshPipelines,
        inputs: MeshInputs<'a>,
        band_pixels: u64,
        clip_planes: u32,
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
        let large = scratch("mesh large triangles", u64::from(LARGE_CAPACITY) * 4)?;
        let large_count = Buffer::new(
            ctx,
            "mesh large triangles count",
            32,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::INDIRECT_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        let large_readback = Buffer::new(
            ctx,
            "mesh large triangles count readback",
            32,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        // A pixel costs the loop's pass and the clip planes' loop (its passes and its end).
        let chunk_pixels = RASTER_PASSES / (2 + clip_planes);
        let max_chunks = u32::try_from(band_pixels.div_ceil(u64::from(chunk_pixels)))
            .map_err(|_| GpuError::Bug(format!("a band of {band_pixels} pixels")))?;
        let i = &inputs;
        let raster = pipes.raster.bind(&[
            Resource::Uniform(i.params),
            Resource::Storage(&i.mesh.positions),
            Resource::Storage(&i.mesh.indices),
            Resource::Storage(&vis),
            Resource::Storage(&counts),
            Resource::Storage(&large),
            Resource::Storage(&large_count),
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
        Ok(MeshPass {
            pipes,
            inputs,
            vis,
            counts,
            _large: large,
            large_count,
            large_readback,
            chunk_pixels,
            max_chunks,
            raster,
            resolve,
        })
    }

    /// Records the band: clear the scratch (no hit, nothing counted, no triangle listed),
    /// raster (one invocation per triangle, none without triangles, then one per chunk of each
    /// listed large triangle), resolve (one per pixel, [`RESOLVE_GROUP`]² per workgroup).
    pub fn record(&self, rec: &mut Recorder, width: u32, band: Band) -> Result<(), GpuError> {
        let mesh = self.inputs.mesh;
        rec.fill(&self.vis, 0, self.vis.size, NO_HIT_WORD);
        rec.fill(&self.counts, 0, self.counts.size, 0);
        if mesh.triangle_count > 0 {
            // No triangle listed; the second stage's x: every chunk a box may have; y: none.
            rec.fill(&self.large_count, 0, 32, 0);
            rec.fill(&self.large_count, 4, 4, self.max_chunks.div_ceil(RASTER_GROUP));
            rec.fill(&self.large_count, 12, 4, 1);
            let (groups, threads_x) = MeshPipelines::raster_groups(mesh.triangle_count)?;
            let mut push = RasterPush {
                row_offset: band.row_offset,
                rows: band.rows,
                triangle_count: mesh.triangle_count,
                threads_x,
                chunk_pixels: self.chunk_pixels,
                stage: 0,
            };
            rec.dispatch(&self.pipes.raster, &self.raster, bytemuck::bytes_of(&push), groups);
            push.stage = 1;
            let push = bytemuck::bytes_of(&push);
            rec.dispatch_indirect(&self.pipes.raster, &self.raster, push, &self.large_count, 4);
            rec.readback(&self.large_count, &self.large_readback, 32);
        }
        let groups = grid_groups([width, band.rows, 1], [RESOLVE_GROUP, RESOLVE_GROUP, 1]);
        rec.dispatch(&self.pipes.resolve, &self.resolve, bytemuck::bytes_of(&band), groups);
        Ok(())
    }

    /// After a band's submission: an error if the first stage listed more large triangles than
    /// it holds (their pixels would be missing).
    pub fn check_band(&self) -> Result<(), GpuError> {
        if self.inputs.mesh.triangle_count == 0 {
            return Ok(());
        }
        let words = self.large_readback.read::<u32>(5)?;
        match words[4] {
            0 => Ok(()),
            over => Err(GpuError::TooLarge {
                what: format!(
                    "the mesh render's band of rows ({} triangles each over {} of its pixels)",
                    u64::from(LARGE_CAPACITY) + u64::from(over),
                    self.chunk_pixels
                ),
                limit: format!(
                    "{LARGE_CAPACITY} such triangles per band; a smaller image or fewer clip \
                     planes draws it"
                ),
            }),
        }
    }
}
