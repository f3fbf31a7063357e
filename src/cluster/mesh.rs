//! `extract` across ranks: the grid's cell layers split along z into one range per rank
//! (`mesh::window::share`), each rank extracts its range from a window of the point layers it
//! needs (`mesh::window`), and rank 0 joins the ranges in rank order, which is the whole
//! mesh's vertex numbering by global owner id: the mesh, and the file, of one process's CPU
//! extraction, byte for byte.
//!
//! ```text
//!   rank r:  read point_layers(share r) (from the mapped raw/npy file, or cut from the
//!            sampled field) -> extract_window -> SlabMesh
//!            -> [status, words] --send--> rank 0                           (mpi/mesh.rs)
//!   rank 0:  its own SlabMesh, then rank 1's, 2's, ... pushed into a Joiner (prefix-summed
//!            offsets, MC33 placeholders) -> Mesh -> written by the CLI as one process does
//! ```
//!
//! One process ([`Ranks::Single`]) is the case of one rank: its share is every cell layer.

use std::sync::Arc;
use std::time::{Duration, Instant};

use super::Ranks;
use crate::field::mapped::MappedGrid;
use crate::field::parts::Parts;
use crate::field::Grid;
use crate::mesh::window::{self, Joiner, Lattice, SlabMesh};
use crate::mesh::{Mesh, MeshBudget, Request};

/// How a rank's share of an extraction ended.
pub enum Extracted {
    /// Rank 0: the whole mesh, the time it spent on its own share, and the time it spent
    /// receiving and joining the others' parts (waiting for the slowest rank included).
    Whole(Box<Mesh>, Duration, Duration),
    /// Another rank: its part went to rank 0.
    Sent,
    /// Another rank failed and rank 0 reports it; this rank exits quietly.
    FailedElsewhere,
}

impl Ranks {
    /// Extracts this rank's share of `grid`'s cell layers and joins the shares on rank 0,
    /// which adds the ranges to `budget` as it joins them and refuses a mesh past its cap
    /// ([`crate::mesh::MeshError::OverCap`]).
    /// Err: the one-line message that this rank (rank 0) reports.
    pub fn extract(
        &self,
        grid: Points,
        x: &Request,
        budget: &Arc<MeshBudget>,
    ) -> Result<Extracted, String> {
        match self {
            Ranks::Single => {
                let cells = window::share(window::cell_layers(x.algo, grid.lattice().dims), 1, 0);
                let started = Instant::now();
                let mine = extract_share(grid, x, cells)?;
                let own = started.elapsed();
                let started = Instant::now();
                let mut join = Joiner::with_budget(budget.clone());
                join.push(mine).map_err(|e| e.to_string())?;
                let mesh = join.finish(x.keeps_quads()).map_err(|e| e.to_string())?;
                Ok(Extracted::Whole(Box::new(mesh), own, started.elapsed()))
            }
            #[cfg(feature = "mpi")]
            Ranks::Mpi(w) => w.extract(grid, x, budget),
        }
    }
}

/// Where a rank reads the grid's points.
#[derive(Clone, Copy)]
pub enum Points<'a> {
    /// A grid every rank sampled whole (computed and parsed sources).
    Sampled(&'a Grid),
    /// A raw or npy file every rank maps, reading only its window's layers.
    Mapped(&'a MappedGrid),
}

impl Points<'_> {
    /// The whole grid's dims and box.
    pub fn lattice(&self) -> Lattice {
        match self {
            Points::Sampled(g) => Lattice::of(g),
            Points::Mapped(m) => Lattice { dims: m.dims, min: m.min, max: m.max },
        }
    }

    /// Point layers `layers` of the whole grid (x fastest); a mapped file's checked finite.
    fn layers(&self, layers: std::ops::Range<usize>) -> Result<Vec<f32>, String> {
        match self {
            Points::Sampled(g) => {
                let plane = g.dims[0] * g.dims[1];
                Ok(g.values[plane * layers.start..plane * layers.end].to_vec())
            }
            Points::Mapped(m) => {
                let n = [m.dims[0], m.dims[1], layers.len()];
                m.read_finite([0, 0, layers.start], n).map_err(|e| e.to_string())
            }
        }
    }
}

/// The mesh of cell layers `cells` of the grid, extracted from only the point layers they
/// need: a mapped file's read from the map (so a rank holds its window only), a sampled
/// grid's copied out of it.
pub(super) fn extract_share(
    grid: Points,
    x: &Request,
    cells: std::ops::Range<usize>,
) -> Result<SlabMesh, String> {
    let lattice = grid.lattice();
    let need = window::point_layers(x.algo, lattice.dims, cells.clone());
    let values = grid.layers(need.clone())?;
    let dims = [lattice.dims[0], lattice.dims[1], need.len()];
    let held = Grid { dims, min: lattice.min, max: lattice.max, values };
    window::extract_window(&held, need.start, &lattice, x, cells).map_err(|e| e.to_string())
}
