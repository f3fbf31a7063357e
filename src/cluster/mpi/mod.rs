//! The MPI side of [`super::Ranks`] (`--features mpi` only): MPI's initialisation, the
//! block upload with the brick grid all-reduced, the gather and composite on rank 0
//! ([`Composite`]) and, in `mesh.rs`, the mesh shares sent to rank 0. The plan is in the
//! module docs of `cluster`.

mod mesh;

use mpi::collective::SystemOperation;
use mpi::environment::Universe;
use mpi::topology::{Communicator, SimpleCommunicator};
use mpi::traits::*;

use super::composite;
use crate::field::Grid;
use crate::frame::{FrameInfo, Pixel};
use crate::gpu::Context;
use crate::passes::Band;
use crate::render::block::Block;
use crate::render::{FrameSink, GpuGrid, RenderError};
use crate::scene::{Method, Scene};

/// Rows of the picture gathered on rank 0 at a time (memory there: ranks × GROUP_ROWS rows).
pub const GROUP_ROWS: usize = 16;

/// The MPI processes of this run, when it was started by an MPI launcher with more than one.
pub struct World {
    _universe: Universe,
    comm: SimpleCommunicator,
}

/// Initialises MPI when an MPI launcher (`mpirun`, `srun` with PMI) started this process with
/// more than one rank; None otherwise (a plain run, or `mpirun -np 1`: the single-process
/// path, untouched).
pub(super) fn world() -> Option<World> {
    let launched = ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE", "SLURM_NTASKS"]
        .iter()
        .filter_map(|k| std::env::var(k).ok())
        .filter_map(|v| v.parse::<usize>().ok())
        .any(|n| n > 1);
    if !launched {
        return None;
    }
    let universe = mpi::initialize()?;
    let comm = universe.world();
    if comm.size() < 2 {
        return None;
    }
    Some(World { _universe: universe, comm })
}

impl World {
    pub fn rank(&self) -> usize {
        self.comm.rank() as usize
    }

    pub fn size(&self) -> usize {
        self.comm.size() as usize
    }

    /// Ends every rank with `code` (after this rank printed why): a rank that fails alone
    /// would otherwise leave the others waiting in a collective.
    pub fn abort(&self, code: i32) -> ! {
        self.comm.abort(code)
    }

    /// Waits until every rank is here.
    pub fn barrier(&self) {
        self.comm.barrier();
    }

    /// What cannot be split across ranks in `scene` (None: the render can).
    pub fn refuses(&self, scene: &Scene) -> Option<String> {
        if let Some(why) = scene.interpolation_refusal(crate::field::interpolant::Reader::Ranks) {
            return Some(why);
        }
        let n = self.size();
        if scene.render.method != Method::Analytic {
            return Some(format!(
                "render.method = \"{}\" is not split across MPI ranks ({n} ranks); only \"analytic\" is: run it without mpirun",
                scene.render.method.name()
            ));
        }
        if scene.render.crossing > 1 {
            return Some(format!(
                "render.crossing = {} is not split across MPI ranks ({n} ranks): the k-th crossing needs the crossings of every block before it",
                scene.render.crossing
            ));
        }
        None
    }

    /// Uploads this rank's block of `grid` with the whole grid's brick min/max grid (the
    /// ranks' parts combined by all-reduce).
    pub fn upload(
        &self,
        ctx: &std::sync::Arc<Context>,
        grid: &Grid,
    ) -> Result<GpuGrid, crate::gpu::GpuError> {
        let block = self.block(grid.dims);
        let values = block.values(grid);
        self.upload_block(ctx, grid.dims, block, values)
    }

    /// This rank's block of a grid of `dims` points.
    pub fn block(&self, dims: [usize; 3]) -> Block {
        Block::of_rank(dims, self.size(), self.rank())
    }

    /// Uploads this rank's `block` (its points `values`, x fastest, read by the rank alone:
    /// from a mapped file, or cut from a sampled grid) with the whole grid's brick min/max grid.
    pub fn upload_block(
        &self,
        ctx: &std::sync::Arc<Context>,
        dims: [usize; 3],
        block: Block,
        values: Vec<f32>,
    ) -> Result<GpuGrid, crate::gpu::GpuError> {
        let local = block.bricks(dims, &values);
        let mins: Vec<f32> = local.iter().map(|m| m[0]).collect();
        let maxs: Vec<f32> = local.iter().map(|m| m[1]).collect();
        let mut min_all = vec![0f32; mins.len()];
        let mut max_all = vec![0f32; maxs.len()];
        self.comm.all_reduce_into(&mins[..], &mut min_all[..], SystemOperation::min());
        self.comm.all_reduce_into(&maxs[..], &mut max_all[..], SystemOperation::max());
        let bricks: Vec<[f32; 2]> = min_all.into_iter().zip(max_all).map(|(a, b)| [a, b]).collect();
        GpuGrid::upload_block(ctx, dims, block, &values, &bricks)
    }
}

/// Gathers each rank's bands on rank 0 in groups of [`GROUP_ROWS`] rows, composites them and
/// hands them to `inner` (rank 0's outputs; None on the other ranks).
pub struct Composite<'a, S> {
    pub world: &'a World,
    pub inner: Option<S>,
    pending: Vec<Pixel>,
    width: usize,
    height: usize,
    sent_rows: usize,
    /// Time spent gathering and compositing (this frame), for the run's report.
    pub compositing: std::time::Duration,
}

impl<'a, S: FrameSink> Composite<'a, S> {
    pub fn new(world: &'a World, inner: Option<S>) -> Self {
        Composite {
            world,
            inner,
            pending: Vec::new(),
            width: 0,
            height: 0,
            sent_rows: 0,
            compositing: std::time::Duration::ZERO,
        }
    }

    /// Gathers and composites the first `rows` pending rows.
    fn flush(&mut self, rows: usize) -> Result<(), RenderError> {
        let n = rows * self.width;
        let started = std::time::Instant::now();
        let send: &[u32] = bytemuck::cast_slice(&self.pending[..n]);
        let root = self.world.comm.process_at_rank(0);
        if let Some(inner) = &mut self.inner {
            let ranks = self.world.size();
            let mut all = vec![Pixel::default(); n * ranks];
            root.gather_into_root(send, bytemuck::cast_slice_mut::<Pixel, u32>(&mut all));
            let mut parts = Vec::with_capacity(ranks);
            let pixels: Vec<Pixel> = (0..n)
                .map(|i| {
                    parts.clear();
                    parts.extend((0..ranks).map(|r| all[r * n + i]));
                    composite(&parts)
                })
                .collect();
            self.compositing += started.elapsed();
            let band = Band { row_offset: self.sent_rows as u32, rows: rows as u32 };
            inner.band(band, &pixels)?;
        } else {
            root.gather_into(send);
            self.compositing += started.elapsed();
        }
        self.pending.drain(..n);
        self.sent_rows += rows;
        Ok(())
    }
}

impl<S: FrameSink> FrameSink for Composite<'_, S> {
    fn begin(&mut self, width: u32, height: u32, info: &FrameInfo) -> Result<(), RenderError> {
        (self.width, self.height, self.sent_rows) = (width as usize, height as usize, 0);
        self.pending.clear();
        match &mut self.inner {
            Some(inner) => inner.begin(width, height, info),
            None => Ok(()),
        }
    }

    fn band(&mut self, _: Band, pixels: &[Pixel]) -> Result<(), RenderError> {
        self.pending.extend_from_slice(pixels);
        // Every rank's picture has the same rows, so the groups line up whatever each rank's
        // device chose as its bands.
        while self.pending.len() >= GROUP_ROWS * self.width {
            self.flush(GROUP_ROWS)?;
        }
        let rest = self.height - self.sent_rows;
        if rest > 0 && self.pending.len() == rest * self.width {
            self.flush(rest)?;
        }
        Ok(())
    }
}
