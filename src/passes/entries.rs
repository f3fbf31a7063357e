//! The entry map: a per-render acceleration structure over the bricks that may hold a surface,
//! in screen space (`shaders/entries/`). The analytic walk pays for every brick and cell its ray
//! crosses, and llvmpipe pays for a shader's whole body for every group of 8 invocations, busy
//! or idle; so before the walk, per band:
//!
//! ```text
//!   fill      entries[pixel] = +inf, counts = 0
//!   list      the bricks that may hold a surface (range not clear of every isovalue)
//!                                                            (entries/list.comp)
//!   raster    per listed brick, per pixel of its widened footprint, the t where the ray
//!             enters the widened box -> atomicMin(entries[pixel])   (entries/raster.comp)
//!   compact   per pixel: no span in the box, or +inf -> the miss record, written here;
//!             else listed for the walk, with the walk's workgroup count  (entries/compact.comp)
//!   walk      analytic.comp (ENTRY_MAP), dispatched indirectly over the listed rays, each
//!             landing where the map says (bricks.glsl's land_at)
//! ```
//!
//! Nothing but the time changes: a ray the map leaves at +inf meets no brick that may hold a
//! surface, where the walk finds no crossing; a listed ray lands in exactly the state the walk
//! would have where it enters its first such brick (or a little before: the map is widened,
//! never late); and `steps` counts the passes from that brick on, with or without the map
//! (analytic.comp). The raster's cost is the sum of the footprints of the bricks that may hold a
//! surface, built per band and per isovalue (nothing is kept between renders).
//!
//! Used by the analytic trilinear walk over a whole grid with skipping on
//! ([`Renderer`](crate::render::Renderer)'s choice, `render/rays.rs`); an MPI block, a brick
//! pool, `render.skip = false` and the other interpolants keep the walk from the start.

use std::sync::Arc;

use ash::vk;

use super::analytic::Walk;
use super::Band;
use crate::gpu::{
    spread_groups, Binding, Buffer, ComputePipeline, Context, Dispatch, GpuError, MemoryLocation,
    Recorder, Resource,
};
use crate::shaders;

/// Whether the map applies to a render with these `params`: every ray's origin within 2^19
/// cells of the grid (the walk's jumps are exact within 2^20: bricks.glsl's `jumps_exact`) and
/// spacings far from f32's ends. Other cameras walk from the start.
pub fn applies(params: &crate::render::params::RenderParams) -> bool {
    let near = |v: f32| v.is_finite() && v.abs() < (1u32 << 19) as f32;
    let sane = |v: f32| v.is_finite() && (1e-12..=1e12).contains(&v);
    let cells = params.inv_spacing.iter().fold(0f32, |m, &v| m.max(v));
    let len = |v: [f32; 3]| v.iter().map(|c| c * c).sum::<f32>().sqrt();
    let reach = match params.orthographic {
        0 => 0.0,
        _ => (len(params.right) + len(params.up)) * cells,
    };
    params.eye_grid.iter().all(|&c| near(c) && near(c.abs() + reach))
        && params.inv_spacing.iter().all(|&v| sane(v))
}

/// Bricks per workgroup of the raster (`local_size_x`).
pub const GROUP: u32 = shaders::consts::ENTRIES_GROUP;

/// The list's bindings: params, bricks, the listed bricks, their count and the raster's
/// workgroups.
pub const LIST_BINDINGS: [Binding; 4] =
    [Binding::Uniform, Binding::Read, Binding::Write, Binding::ReadWrite];

/// The raster's bindings: params, bricks, the listed bricks, their count, entries (atomics).
pub const RASTER_BINDINGS: [Binding; 5] =
    [Binding::Uniform, Binding::Read, Binding::Read, Binding::Read, Binding::ReadWrite];

/// The sort's bindings: params, entries, pixels (miss records), the listed rays, their count.
pub const COMPACT_BINDINGS: [Binding; 5] =
    [Binding::Uniform, Binding::Read, Binding::Write, Binding::Write, Binding::ReadWrite];

/// The list, the raster and the sort, for one surface count (the list's `range_is_empty` loops
/// over `SURFACE_COUNT`, a specialization constant as in the walk).
pub struct Pipelines {
    list: ComputePipeline,
    raster: ComputePipeline,
    compact: ComputePipeline,
}

impl Pipelines {
    pub fn new(ctx: &Arc<Context>, walk: Walk) -> Result<Self, GpuError> {
        let push = std::mem::size_of::<Band>() as u32;
        let constants = [1, walk.surfaces];
        Ok(Pipelines {
            list: ComputePipeline::with_constants(
                ctx,
                "entry map bricks",
                shaders::ENTRIES_LIST,
                &LIST_BINDINGS,
                0,
                &constants,
            )?,
            raster: ComputePipeline::with_constants(
                ctx,
                "entry map raster",
                shaders::ENTRIES_RASTER,
                &RASTER_BINDINGS,
                push,
                &constants,
            )?,
            compact: ComputePipeline::with_constants(
                ctx,
                "entry map sort",
                shaders::ENTRIES_COMPACT,
                &COMPACT_BINDINGS,
                push,
                &constants,
            )?,
        })
    }
}

/// The map's buffers for the bands of one picture: what the walk's `ENTRY_MAP` bindings read.
pub struct Buffers {
    /// Per pixel of a band, the entry t's bits (+inf: none).
    pub entries: Buffer,
    /// The listed rays' pixel indices in the band.
    pub active: Buffer,
    /// `listed`, then the walk's indirect dispatch (x, y, z) at [`Buffers::ARGS`].
    pub listed: Buffer,
    /// The bricks that may hold a surface (their indices), for the raster.
    pub bricks: Buffer,
    /// Their count, then the raster's indirect dispatch at [`Buffers::ARGS`].
    pub brick_count: Buffer,
}

impl Buffers {
    /// Where the walk's `VkDispatchIndirectCommand` is in [`Buffers::listed`].
    pub const ARGS: u64 = 4;

    /// Buffers for bands of at most `band_pixels` pixels over a grid of `bricks` bricks.
    pub fn new(ctx: &Arc<Context>, band_pixels: u64, bricks: u64) -> Result<Self, GpuError> {
        let counts = |name: &str| {
            Buffer::new(
                ctx,
                name,
                16,
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::INDIRECT_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuOnly,
            )
        };
        let per_pixel = |name: &str, extra: vk::BufferUsageFlags| {
            Buffer::new(
                ctx,
                name,
                band_pixels * 4,
                vk::BufferUsageFlags::STORAGE_BUFFER | extra,
                MemoryLocation::GpuOnly,
            )
        };
        Ok(Buffers {
            entries: per_pixel("entry map", vk::BufferUsageFlags::TRANSFER_DST)?,
            active: per_pixel("entry map rays", vk::BufferUsageFlags::empty())?,
            listed: counts("entry map count")?,
            bricks: Buffer::new(
                ctx,
                "entry map bricks",
                bricks * 4,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::GpuOnly,
            )?,
            brick_count: counts("entry map brick count")?,
        })
    }
}

/// The raster and the sort bound to a picture's inputs; records the passes before the walk of
/// each band.
pub struct EntryPass<'a> {
    pipelines: &'a Pipelines,
    list: Dispatch,
    raster: Dispatch,
    compact: Dispatch,
    buffers: &'a Buffers,
    /// Bricks of the grid (the raster's invocations).
    bricks: u64,
    width: u32,
}

impl<'a> EntryPass<'a> {
    /// Binds the passes: `params` (RenderParams), the brick ranges of the grid of `dims` points,
    /// the band's `pixels` (the sort writes the misses), the map's `buffers`; pictures `width`
    /// pixels wide.
    pub fn new(
        pipelines: &'a Pipelines,
        params: &Buffer,
        bricks: &Buffer,
        dims: [usize; 3],
        pixels: &Buffer,
        buffers: &'a Buffers,
        width: u32,
    ) -> Result<Self, GpuError> {
        let list = pipelines.list.bind(&[
            Resource::Uniform(params),
            Resource::Storage(bricks),
            Resource::Storage(&buffers.bricks),
            Resource::Storage(&buffers.brick_count),
        ])?;
        let raster = pipelines.raster.bind(&[
            Resource::Uniform(params),
            Resource::Storage(bricks),
            Resource::Storage(&buffers.bricks),
            Resource::Storage(&buffers.brick_count),
            Resource::Storage(&buffers.entries),
        ])?;
        let compact = pipelines.compact.bind(&[
            Resource::Uniform(params),
            Resource::Storage(&buffers.entries),
            Resource::Storage(pixels),
            Resource::Storage(&buffers.active),
            Resource::Storage(&buffers.listed),
        ])?;
        let counts = super::bricks::brick_counts(dims);
        let bricks = counts.iter().map(|&c| c as u64).product();
        Ok(EntryPass { pipelines, list, raster, compact, buffers, bricks, width })
    }

    /// Records the fill, the raster and the sort of `band`; the walk follows with
    /// [`Recorder::dispatch_indirect`] on [`Buffers::listed`] at [`Buffers::ARGS`].
    pub fn record(&self, rec: &mut Recorder, band: Band) -> Result<(), GpuError> {
        let pixels = band.rows as u64 * self.width as u64;
        let b = &self.buffers;
        rec.fill(&b.entries, 0, pixels * 4, f32::INFINITY.to_bits());
        // Counts 0, x = 0 (counted up with them), y = z = 1.
        for counts in [&b.listed, &b.brick_count] {
            rec.fill(counts, 0, 8, 0);
            rec.fill(counts, 8, 8, 1);
        }
        let push = bytemuck::bytes_of(&band);
        let groups = spread_groups(self.bricks.div_ceil(GROUP as u64))?;
        rec.dispatch(&self.pipelines.list, &self.list, &[], groups);
        rec.dispatch_indirect(
            &self.pipelines.raster,
            &self.raster,
            push,
            &b.brick_count,
            Buffers::ARGS,
        );
        let g = super::raymarch::GROUP;
        let groups = crate::gpu::grid_groups([self.width, band.rows, 1], [g, g, 1]);
        rec.dispatch(&self.pipelines.compact, &self.compact, push, groups);
        Ok(())
    }
}
