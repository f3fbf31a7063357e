//! A grid on the device ([`GpuGrid`]): every point as a 3D image (the whole grid, or one
//! process's block of a larger one, [`super::block`]), or the bricks an isovalue needs in a
//! brick pool ([`super::pool`]); with the brick min/max grid the analytic walk skips empty
//! space with, and (for the analytic method over a whole grid) a copy of the points in a
//! storage buffer.

use std::sync::Arc;

use ash::vk;

use super::{block, pool, RenderError};
use crate::field::Grid;
use crate::gpu::{Buffer, Context, GpuError, Image3d};
use crate::passes::bricks;

/// A grid uploaded to the device: the whole grid, one process's block of it, or the bricks
/// of it an isovalue needs ([`pool`]).
pub struct GpuGrid {
    pub(super) storage: Storage,
    /// Points per axis of the uploaded image (of the whole grid, for a pool).
    pub dims: [usize; 3],
    /// The brick min/max grid ([`bricks`]), built by the first analytic render (given, for a
    /// pool or a block).
    pub(super) bricks: std::cell::OnceCell<Buffer>,
    /// A host copy of its superbricks' ranges, set with `bricks` (the choice of levels).
    pub(super) supers: std::cell::OnceCell<Vec<[f32; 2]>>,
    /// The tricubic walks' min/max grids over their stencils (`bricks::Bound::Cubic`, then
    /// `CatmullRom`), each built by the first analytic render through that interpolant.
    pub(super) cubic_bricks: [std::cell::OnceCell<bricks::Built>; 2],
    /// The image's points in a storage buffer, copied on the device by the first analytic
    /// render of a whole grid (its `GRID_BUFFER` variant): a second copy of the grid on the
    /// device, read by llvmpipe far faster than the image (docs/methods.md "Exact ray tracing").
    pub(super) points: std::cell::OnceCell<Buffer>,
    /// The analytic walk's occupancy structure for the isovalues of the last render that used
    /// it ([`crate::passes::occupancy`]), rebuilt when they change.
    pub(super) occupancy: std::cell::RefCell<Option<crate::passes::occupancy::Occupancy>>,
    /// The block of a larger grid the image holds (None: the whole grid).
    pub(super) block: Option<block::Block>,
    /// The largest magnitude of the finite samples it holds (of the whole grid for a block or
    /// a pool, from the brick ranges): the ray methods refuse a grid past
    /// [`GPU_SAMPLE_BOUND`].
    pub(super) largest: f32,
}

/// The largest sample magnitude the ray methods trace: their f32 arithmetic (a trilinear
/// cell's cubic along the ray and its derivative's roots, the tricubic segment's sums of 64
/// weighted samples in Bernstein form) overflows near 1e36 (the cubic interpolants) to 1e37
/// (trilinear), and the image then loses or invents surface; 1e30 keeps every intermediate
/// finite with room to spare (`tests/it/render/interpolants.rs` checks the bound), and is the
/// bound of coordinates too. The CPU paths (probe, slice's contours, extract) read in f64.
pub const GPU_SAMPLE_BOUND: f32 = 1e30;

/// The ray methods' refusal of a grid whose finite samples reach `largest` past
/// [`GPU_SAMPLE_BOUND`] (None: traced), naming the scene's data file (`path`). One home for
/// the line: the render checks it on every grid, the brick pool before it prints its summary
/// or uploads a brick (one line on stderr, not a pool summary and then a refusal).
pub(crate) fn sample_bound_refusal(largest: f32, path: Option<&std::path::Path>) -> Option<String> {
    (largest > GPU_SAMPLE_BOUND).then(|| {
        let file = path.map(|p| crate::vocab::echo(&p.display().to_string()));
        format!(
            "{}samples reach ±{}, beyond the ±{:e} the ray methods' 32-bit arithmetic keeps \
             finite (the images would lose or invent surface); scale the field, or read it in 64 \
             bits with probe, slice or extract",
            file.map_or(String::new(), |f| format!("{f}: ")),
            crate::vocab::echo_number(largest),
            GPU_SAMPLE_BOUND
        )
    })
}

/// The largest magnitude among finite values.
pub(super) fn largest_finite(values: impl IntoIterator<Item = f32>) -> f32 {
    values.into_iter().filter(|v| v.is_finite()).fold(0.0, |m, v| m.max(v.abs()))
}

/// How the grid's points are on the device.
pub(super) enum Storage {
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
            cubic_bricks: Default::default(),
            points: std::cell::OnceCell::new(),
            occupancy: Default::default(),
            block: None,
            largest: largest_finite(grid.values.iter().copied()),
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
            cubic_bricks: Default::default(),
            points: std::cell::OnceCell::new(),
            occupancy: Default::default(),
            block: Some(block),
            largest: largest_finite(bricks.iter().flatten().copied()),
        };
        grid.set_bricks(ctx, bricks::levels(dims, bricks))?;
        Ok(grid)
    }

    /// Uploads the bricks of a grid read in parts that `residency` names into a brick pool
    /// ([`pool`]), with its hierarchical tables (`residency.ranges`); `supers`: every
    /// superbrick's range (the walk's choice of levels, the largest magnitude).
    pub fn upload_pool(
        ctx: &Arc<Context>,
        grid: &dyn crate::field::parts::Parts,
        supers: Vec<[f32; 2]>,
        mut residency: pool::Residency,
    ) -> Result<Self, pool::PoolError> {
        let buffer =
            Buffer::upload(ctx, "bricks", &residency.ranges, vk::BufferUsageFlags::STORAGE_BUFFER)?;
        // On the device now; the host keeps the page table (`Residency::page`) only.
        residency.ranges = Vec::new();
        let pool = pool::Pool::upload(ctx, grid, residency)?;
        let gpu = GpuGrid {
            storage: Storage::Pool(Box::new(pool)),
            dims: grid.dims(),
            bricks: std::cell::OnceCell::new(),
            supers: std::cell::OnceCell::new(),
            cubic_bricks: Default::default(),
            points: std::cell::OnceCell::new(),
            occupancy: Default::default(),
            block: None,
            largest: largest_finite(supers.iter().flatten().copied()),
        };
        let _ = gpu.supers.set(supers);
        let _ = gpu.bricks.set(buffer);
        Ok(gpu)
    }

    /// Uploads the min/max grid computed on the CPU (`levels`: [`bricks::levels`]' layout).
    pub(super) fn set_bricks(
        &self,
        ctx: &Arc<Context>,
        levels: Vec<[f32; 2]>,
    ) -> Result<(), GpuError> {
        // TRANSFER_SRC: tests read it back.
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
        let buffer = Buffer::upload(ctx, "bricks", &levels, usage)?;
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

    /// The analytic walk's occupancy structure, once an analytic render built it for its
    /// isovalues: `f` gets it (None before).
    pub fn with_occupancy<R>(
        &self,
        f: impl FnOnce(Option<&crate::passes::occupancy::Occupancy>) -> R,
    ) -> R {
        f(self.occupancy.borrow().as_ref())
    }

    /// A tricubic walk's min/max grid (`bound`: `Cubic` or `CatmullRom`), once an analytic
    /// render through that interpolant has built it.
    pub fn cubic_bricks(&self, bound: bricks::Bound) -> Option<&Buffer> {
        self.cubic_levels(bound)?.get().map(|b| &b.buffer)
    }

    /// Where a tricubic walk's min/max grid is kept (None for `Corners`: `bricks`, `supers`).
    pub(super) fn cubic_levels(
        &self,
        bound: bricks::Bound,
    ) -> Option<&std::cell::OnceCell<bricks::Built>> {
        match bound {
            bricks::Bound::Corners => None,
            bricks::Bound::Cubic => Some(&self.cubic_bricks[0]),
            bricks::Bound::CatmullRom => Some(&self.cubic_bricks[1]),
        }
    }
}
