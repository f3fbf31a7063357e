//! The processes of a run ([`Ranks`]): one, or many through MPI. Every build has this module
//! and [`Ranks::Single`]; the MPI code itself (`mpi/`) is built only with `--features mpi`, so
//! the verbs (`cli`) ask [`Ranks`] and name no feature.
//!
//! Many processes through MPI (`--features mpi`): `mpirun -np N isoview render scene.toml -o
//! out.exr` splits the grid into N blocks, each rank uploads and traces only its block, and
//! the ranks composite every pixel on rank 0, which writes the files. `mpirun -np N isoview
//! extract scene.toml -o out.ply` splits the grid's cell layers along z into N ranges, each
//! rank meshes its range, and rank 0 joins them into the single-process CPU mesh (`mesh`
//! below, `mpi/mesh.rs`, and `mesh::window`).
//!
//! ```text
//!   rank r:  sample field -> Block::of_rank (cells + one shared plane + ghost plane)
//!            bricks of its points --all_reduce(min, max)--> the whole grid's brick grid
//!            analytic pass: every ray walked through the whole grid (global t, global brick
//!            jumps, global step count), only owned cells evaluated
//!            bands --> groups of GROUP_ROWS rows --gather--> rank 0
//!   rank 0:  composite (below) --> the streaming EXR / PNG of a single-process render
//! ```
//!
//! # Compositing, per channel ([`composite`])
//!
//! - The hit is the nearest one: the smallest `Z`; equal `Z` (a crossing exactly on a face two
//!   blocks share) goes to the smaller `steps`, the one earlier in the walk, which is the one a
//!   single process finds first; equal both (only misses: every rank walks the same ray and
//!   writes the same miss record) goes to the lower rank. R, G, B, A, N, P, cell and `steps`
//!   are the winner's. `steps` is the walk's pass count at the hit (or of the whole ray on a
//!   miss), counted by every rank over the whole walk, so it is the single process's value.
//! - `crossings` (whole ray) is the sum over ranks: each rank counts the crossings in the
//!   cells it owns, and every cell has one owner. -1 (not counted) stays -1.
//!
//! Every channel is thereby bit-identical to one process's render (tests/it/cluster/mpi.rs). Not
//! split (refused under more than one rank, with a message): fixed-step (a sample's
//! refinement needs the previous sample, which may lie in another block), the mesh method,
//! `render.crossing` > 1 (the k-th crossing needs the count of crossings in blocks before it
//! along the ray) and `--tev`.
//!
//! Reading: a raw or npy file is memory-mapped and each rank reads only its block (`render`)
//! or its window of point layers (`extract`, [`Points::Mapped`]); other sources are still
//! sampled whole by every rank, which cuts its part out.

mod mesh;
#[cfg(feature = "mpi")]
mod mpi;
mod ranks;

pub use mesh::{Extracted, Points};
#[cfg(feature = "mpi")]
pub use mpi::{Composite, World, GROUP_ROWS};
pub use ranks::{BlockError, Ranks};

use crate::frame::Pixel;

/// The record of one pixel from every rank's render (in rank order) combined as one process
/// renders it (module docs).
pub fn composite(parts: &[Pixel]) -> Pixel {
    let mut best = parts[0];
    for p in &parts[1..] {
        let nearer = p.depth.total_cmp(&best.depth).then(p.steps.total_cmp(&best.steps));
        if nearer.is_lt() {
            best = *p;
        }
    }
    best.crossings = match parts[0].crossings {
        c if c < 0 => c,
        _ => parts.iter().map(|p| p.crossings).sum(),
    };
    best
}
