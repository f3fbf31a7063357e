//! The processes of a run as a verb sees them: one ([`Ranks::Single`], every build) or the
//! ranks of an MPI launch ([`Ranks::Mpi`], `--features mpi`). A verb asks `Ranks` who it is
//! (rank, size, root), what the ranks cannot split, and has it upload, render and extract; the
//! answers for one process are the ones that leave the single-process path as it always was
//! (rank 0 of 1, nothing refused, the whole grid uploaded, the frame drawn straight into the
//! sink), so the verbs hold no `cfg(feature = "mpi")` and a binding can reuse them.

use std::sync::Arc;
use std::time::Duration;

use crate::field::{FieldError, FieldSpec, Grid};
use crate::gpu::{Context, GpuError};
use crate::render::{FrameSink, GpuGrid, RenderError, Renderer};
use crate::scene::Scene;

#[cfg(feature = "mpi")]
use super::World;

/// The processes of this run (module docs).
pub enum Ranks {
    /// One process: rank 0 of 1.
    Single,
    /// Two or more MPI ranks, this process one of them.
    #[cfg(feature = "mpi")]
    Mpi(World),
}

/// Why [`Ranks::upload_mapped_block`] failed, by who meets it.
#[derive(Debug, thiserror::Error)]
pub enum BlockError {
    /// The file could not be mapped: every rank meets it alike.
    #[error(transparent)]
    Open(FieldError),
    /// This rank's block could not be read (a read error, a non-finite sample in it): this
    /// rank alone, while the others may wait for it in a collective.
    #[error(transparent)]
    Read(FieldError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

impl Ranks {
    /// The ranks of an MPI launch (`mpirun`, `srun` with PMI) with more than one, in a build
    /// with `--features mpi`; else [`Ranks::Single`] (a plain run, `mpirun -np 1`, or a build
    /// without the feature).
    pub fn from_launcher() -> Ranks {
        #[cfg(feature = "mpi")]
        if let Some(w) = super::mpi::world() {
            return Ranks::Mpi(w);
        }
        Ranks::Single
    }

    /// This process's rank, 0 to [`Ranks::size`] - 1.
    pub fn rank(&self) -> usize {
        match self {
            Ranks::Single => 0,
            #[cfg(feature = "mpi")]
            Ranks::Mpi(w) => w.rank(),
        }
    }

    /// How many processes the run has.
    pub fn size(&self) -> usize {
        match self {
            Ranks::Single => 1,
            #[cfg(feature = "mpi")]
            Ranks::Mpi(w) => w.size(),
        }
    }

    /// Whether this process is rank 0, the one that writes the files and says what happened.
    pub fn is_root(&self) -> bool {
        self.rank() == 0
    }

    /// Whether the run is one process (the grid is not split).
    pub fn is_single(&self) -> bool {
        matches!(self, Ranks::Single)
    }

    /// Waits until every rank is here (one process: at once).
    pub fn barrier(&self) {
        match self {
            Ranks::Single => {}
            #[cfg(feature = "mpi")]
            Ranks::Mpi(w) => w.barrier(),
        }
    }

    /// Ends every rank with `code` (after this rank printed why): a rank that fails alone
    /// would otherwise leave the others waiting in a collective. One process exits.
    pub fn abort(&self, code: i32) -> ! {
        match self {
            Ranks::Single => std::process::exit(code),
            #[cfg(feature = "mpi")]
            Ranks::Mpi(w) => w.abort(code),
        }
    }

    /// What `render` cannot split across the ranks in `scene` (None: it can, or one process).
    // Without the feature only `Single` is left, and its answer reads no argument.
    #[cfg_attr(not(feature = "mpi"), allow(unused_variables))]
    pub fn refuses(&self, scene: &Scene) -> Option<String> {
        match self {
            Ranks::Single => None,
            #[cfg(feature = "mpi")]
            Ranks::Mpi(w) => w.refuses(scene),
        }
    }

    /// What `extract` cannot split across the ranks in `scene` (None: it can, or one
    /// process); `gpu`: the GPU extraction was asked for.
    // Without the feature only `Single` is left, and its answer reads no argument.
    #[cfg_attr(not(feature = "mpi"), allow(unused_variables))]
    pub fn refuses_extract(&self, scene: &Scene, gpu: bool) -> Option<String> {
        match self {
            Ranks::Single => None,
            #[cfg(feature = "mpi")]
            Ranks::Mpi(w) => w.refuses_extract(scene, gpu),
        }
    }

    /// Uploads this rank's part of `grid`: one process the whole grid, a rank its block with
    /// the whole grid's brick min/max grid (the ranks' parts combined).
    pub fn upload(&self, ctx: &Arc<Context>, grid: &Grid) -> Result<GpuGrid, GpuError> {
        match self {
            Ranks::Single => GpuGrid::upload(ctx, grid),
            #[cfg(feature = "mpi")]
            Ranks::Mpi(w) => w.upload(ctx, grid),
        }
    }

    /// Under MPI, when `field` is a raw or npy file: the file mapped, this rank's block read
    /// from it alone and uploaded (with the whole grid's brick grid), and the grid's shape
    /// (no samples). None: one process (it samples the field, or pools its bricks:
    /// `render::pool`), or a source that is not a mapped file.
    // Without the feature only `Single` is left, and its answer reads no argument.
    #[cfg_attr(not(feature = "mpi"), allow(unused_variables))]
    pub fn upload_mapped_block(
        &self,
        ctx: &Arc<Context>,
        field: &FieldSpec,
    ) -> Result<Option<(Grid, GpuGrid)>, BlockError> {
        match self {
            Ranks::Single => Ok(None),
            #[cfg(feature = "mpi")]
            Ranks::Mpi(w) => {
                use crate::field::parts::Parts;
                let Some(m) =
                    crate::field::mapped::MappedGrid::open(field).map_err(BlockError::Open)?
                else {
                    return Ok(None);
                };
                let block = w.block(m.dims);
                let values = m.read_finite(block.origin, block.extent).map_err(BlockError::Read)?;
                Ok(Some((m.shape(), w.upload_block(ctx, m.dims, block, values)?)))
            }
        }
    }

    /// Draws `scene` at `time` from this rank's upload: one process straight into `sink`;
    /// under MPI every rank draws its block and rank 0 gathers, composites and hands the
    /// bands to `sink` (the other ranks' `sink` gets nothing). Some(the time rank 0 spent
    /// gathering and compositing) under MPI.
    pub fn render_to<S: FrameSink>(
        &self,
        renderer: &mut Renderer,
        scene: &Scene,
        (grid, gpu_grid): (&Grid, &GpuGrid),
        time: f64,
        sink: &mut S,
    ) -> Result<Option<Duration>, RenderError> {
        match self {
            Ranks::Single => renderer.render_to(scene, grid, gpu_grid, time, sink).map(|()| None),
            #[cfg(feature = "mpi")]
            Ranks::Mpi(w) => {
                let mut gather = super::Composite::new(w, self.is_root().then_some(sink));
                renderer.render_to(scene, grid, gpu_grid, time, &mut gather)?;
                Ok(Some(gather.compositing))
            }
        }
    }
}
