//! The MPI half of `extract` across ranks (`cluster/mesh.rs` has the plan): each rank
//! sends its share to rank 0, which receives from every rank in rank order and joins.
//!
//! A rank that fails sends its message instead of its mesh; rank 0 receives from every rank,
//! then tells every rank whether the whole succeeded (a broadcast), so that all ranks stop
//! together and only rank 0 reports the first failure, in one line.

use std::sync::Arc;
use std::time::Instant;

use mpi::collective::Root;
use mpi::point_to_point::{Destination, Source};
use mpi::topology::Communicator;

use super::World;
use crate::cluster::mesh::extract_share;
use crate::cluster::{Extracted, Points};
use crate::mesh::window::{self, Joiner, SlabMesh};
use crate::mesh::{MeshBudget, Request};
use crate::scene::Scene;

/// Words per message: MPI counts are `int`, and a bounded message keeps buffers modest.
const CHUNK: usize = 1 << 26;

impl World {
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
        let (n, rank) = (self.size(), self.rank());
        let layers = window::cell_layers(x.algo, grid.lattice().dims);
        let cells = window::share(layers, n, rank);
        let started = Instant::now();
        let mine = extract_share(grid, x, cells);
        let own = started.elapsed();
        if rank != 0 {
            let root = self.comm.process_at_rank(0);
            let failed = mine.is_err();
            let (status, words) = match mine {
                Ok(part) => (1, part.to_words()),
                Err(e) => (0, e.bytes().map(u32::from).collect()),
            };
            send(&root, status, &words);
            let mut whole_ok = 0u32;
            root.broadcast_into(&mut whole_ok);
            return Ok(match (failed, whole_ok) {
                (false, 1) => Extracted::Sent,
                _ => Extracted::FailedElsewhere,
            });
        }
        let started = Instant::now();
        let mut first_error = None;
        let mut join = Joiner::with_budget(budget.clone());
        let mut take = |r: usize, part: Result<SlabMesh, String>| match part {
            Ok(p) if first_error.is_none() => {
                if let Err(e) = join.push(p) {
                    first_error = Some(e.to_string());
                }
            }
            Ok(_) => {}
            Err(e) => {
                first_error.get_or_insert(if r == 0 { e } else { format!("rank {r}: {e}") });
            }
        };
        take(0, mine);
        for r in 1..n {
            let (status, words) = receive(&self.comm.process_at_rank(r as i32));
            let part = match status {
                1 => SlabMesh::from_words(&words)
                    .ok_or_else(|| "a malformed mesh part arrived".to_string()),
                _ => Err(String::from_utf8_lossy(
                    &words.iter().map(|&b| b as u8).collect::<Vec<_>>(),
                )
                .into_owned()),
            };
            take(r, part);
        }
        let mesh = match first_error {
            Some(e) => Err(e),
            None => join.finish(x.keeps_quads()).map_err(|e| e.to_string()),
        };
        let mut whole_ok = u32::from(mesh.is_ok());
        self.comm.process_at_rank(0).broadcast_into(&mut whole_ok);
        Ok(Extracted::Whole(Box::new(mesh?), own, started.elapsed()))
    }

    /// What `extract` cannot split across ranks in `scene` (None: it can); `gpu`: the GPU
    /// extraction was asked for.
    pub fn refuses_extract(&self, scene: &Scene, gpu: bool) -> Option<String> {
        let n = self.size();
        let (algo, sharp) = (scene.render.mesh, &scene.render.sharp);
        if let Some(why) = window::not_in_slabs(algo, sharp) {
            return Some(format!(
                "render.mesh = \"{}\" is not split across MPI ranks ({n} ranks): {why}; run it without mpirun",
                algo.name()
            ));
        }
        if scene.render.mesh_refine > 1 {
            return Some(format!(
                "render.mesh_refine = {} meshes a lattice held whole, not split across MPI ranks \
                 ({n} ranks); run it without mpirun",
                scene.render.mesh_refine
            ));
        }
        gpu.then(|| {
            format!(
                "--device: the GPU extraction is not split across MPI ranks ({n} ranks); extract under MPI runs on the CPU: use --device cpu or auto"
            )
        })
    }
}

/// Sends `[status, length]` and then `words` in chunks of at most [`CHUNK`].
fn send(to: &impl Destination, status: u32, words: &[u32]) {
    let len = words.len() as u64;
    to.send(&[status, len as u32, (len >> 32) as u32][..]);
    for c in words.chunks(CHUNK) {
        to.send(c);
    }
}

/// Receives what [`send`] sent.
fn receive(from: &impl Source) -> (u32, Vec<u32>) {
    let (head, _) = from.receive_vec::<u32>();
    let (status, len) = (head[0], (head[1] as usize) | ((head[2] as usize) << 32));
    let mut words = Vec::with_capacity(len);
    while words.len() < len {
        let (c, _) = from.receive_vec::<u32>();
        words.extend_from_slice(&c);
    }
    (status, words)
}
