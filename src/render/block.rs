//! A block of the grid: the cells one process traces when the grid is split across processes
//! (MPI ranks, `cluster`), the points it uploads, and its part of the brick min/max grid.
//!
//! ```text
//!   cells   0   1   2 | 3   4   5 | 6   7        split along cell boundaries: rank 0 owns
//!   points 0   1   2   3   4   5   6   7   8     cells 0..3, rank 1 cells 3..6, rank 2 6..8;
//!          [ rank 0 ....(3)]                      neighbours share one plane of points (3, 6),
//!                  [(2) rank 1 ....(7)]           plus one ghost plane each side (2, 7) for the
//!                              [(5) rank 2  ]     central differences of smooth normals
//! ```
//!
//! Every rank walks every ray through the whole grid (global ray parameters, global brick
//! jumps) and evaluates only the cells it owns, so a hit is found with the same bits as by
//! one process; `cluster::composite` then picks the nearest hit per pixel.

use crate::field::interpolant::{SMOOTH_NORMAL_REACH, STENCIL};
use crate::field::Grid;
use crate::passes::bricks::{brick_counts, BRICK};

/// One process's share of a grid of `dims` points.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Block {
    /// The first cell it traces, per axis.
    pub cells_lo: [usize; 3],
    /// One past the last cell it traces (equal to `cells_lo` on an axis where it has none).
    pub cells_hi: [usize; 3],
    /// The first grid point it holds (uploads).
    pub origin: [usize; 3],
    /// How many points it holds per axis (at least 1).
    pub extent: [usize; 3],
}

impl Block {
    /// The whole grid, as one process traces it.
    pub fn whole(dims: [usize; 3]) -> Self {
        Block { cells_lo: [0; 3], cells_hi: dims.map(|d| d - 1), origin: [0; 3], extent: dims }
    }

    /// Whether it owns no cell.
    pub fn is_empty(&self) -> bool {
        (0..3).any(|a| self.cells_lo[a] >= self.cells_hi[a])
    }

    /// The block of rank `rank` of `ranks` over a grid of `dims` points: the cells split into
    /// a `parts` lattice ([`lattice`]), rank r at lattice position (x fastest), each axis's
    /// cells divided as evenly as integers allow.
    pub fn of_rank(dims: [usize; 3], ranks: usize, rank: usize) -> Self {
        let cells = dims.map(|d| d - 1);
        let parts = lattice(cells, ranks);
        let at = [rank % parts[0], (rank / parts[0]) % parts[1], rank / (parts[0] * parts[1])];
        let mut b = Block::whole(dims);
        for a in 0..3 {
            b.cells_lo[a] = cells[a] * at[a] / parts[a];
            b.cells_hi[a] = cells[a] * (at[a] + 1) / parts[a];
            // The points its cells read, and the ghost planes the central differences of smooth
            // normals read around them (trilinear: one each side), inside the grid.
            let points =
                STENCIL.widened(SMOOTH_NORMAL_REACH).points(b.cells_lo[a]..b.cells_hi[a], dims[a]);
            b.origin[a] = points.start;
            b.extent[a] = points.len();
        }
        b
    }

    /// Its points' values, x fastest, cut out of the whole grid.
    pub fn values(&self, grid: &Grid) -> Vec<f32> {
        let [nx, ny, _] = grid.dims;
        let [ex, ey, ez] = self.extent;
        let [ox, oy, oz] = self.origin;
        let mut v = Vec::with_capacity(ex * ey * ez);
        for k in oz..oz + ez {
            for j in oy..oy + ey {
                let row = (k * ny + j) * nx + ox;
                v.extend_from_slice(&grid.values[row..row + ex]);
            }
        }
        v
    }

    /// Its part of the brick min/max grid of the whole grid (`passes::bricks`' layout and
    /// definition: brick b covers the points its cells read, `Stencil::brick_points`):
    /// min and max over the points of its own cells in each brick (missing samples left out:
    /// `field::interpolant::widen`), (+inf, -inf) where it has none. The element-wise min of the
    /// mins and max of the maxes over all ranks is the whole grid's brick grid, since the
    /// ranks' cells cover every point.
    pub fn bricks(&self, dims: [usize; 3], values: &[f32]) -> Vec<[f32; 2]> {
        let counts = brick_counts(dims);
        let mut out = vec![[f32::INFINITY, f32::NEG_INFINITY]; counts.iter().product()];
        if self.is_empty() {
            return out;
        }
        let [ex, ey, _] = self.extent;
        for k in self.cells_lo[2]..=self.cells_hi[2] {
            for j in self.cells_lo[1]..=self.cells_hi[1] {
                for i in self.cells_lo[0]..=self.cells_hi[0] {
                    let local = ((k - self.origin[2]) * ey + (j - self.origin[1])) * ex
                        + (i - self.origin[0]);
                    let v = values[local];
                    // A point on a brick boundary belongs to both bricks.
                    for bk in bricks_of(k, counts[2]) {
                        for bj in bricks_of(j, counts[1]) {
                            for bi in bricks_of(i, counts[0]) {
                                let m = &mut out[(bk * counts[1] + bj) * counts[0] + bi];
                                crate::field::interpolant::widen(m, v);
                            }
                        }
                    }
                }
            }
        }
        out
    }
}

/// The bricks (of `count` along the axis) whose points include point `p`.
fn bricks_of(p: usize, count: usize) -> impl Iterator<Item = usize> {
    STENCIL.bricks_holding(p, BRICK, count)
}

/// How many blocks along each axis for `ranks` blocks of `cells`: the factorisation of
/// `ranks` into three factors that are as equal as possible (MPI_Dims_create's rule), the
/// largest factor on the axis with the most cells.
pub fn lattice(cells: [usize; 3], ranks: usize) -> [usize; 3] {
    let ranks = ranks.max(1);
    let mut best = [ranks, 1, 1];
    for a in 1..=ranks {
        if ranks % a != 0 {
            continue;
        }
        for b in 1..=ranks / a {
            if (ranks / a) % b != 0 {
                continue;
            }
            let c = ranks / a / b;
            let mut f = [a, b, c];
            f.sort_unstable_by(|x, y| y.cmp(x));
            let mut cur = best;
            cur.sort_unstable_by(|x, y| y.cmp(x));
            if f[0] - f[2] < cur[0] - cur[2] {
                best = f;
            }
        }
    }
    best.sort_unstable_by(|x, y| y.cmp(x));
    // Largest factor on the axis with the most cells (ties: x first).
    let mut axes = [0, 1, 2];
    axes.sort_by(|&x, &y| cells[y].cmp(&cells[x]));
    let mut parts = [1; 3];
    for (i, &a) in axes.iter().enumerate() {
        parts[a] = best[i];
    }
    parts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_partition_the_cells_and_hold_their_points() {
        for dims in [[2, 2, 2], [9, 5, 17], [33, 2, 4], [3, 3, 40]] {
            for ranks in 1..=7 {
                let cells = dims.map(|d| d - 1);
                let mut owner = vec![0usize; cells.iter().product()];
                for r in 0..ranks {
                    let b = Block::of_rank(dims, ranks, r);
                    for (a, &n) in dims.iter().enumerate() {
                        assert!(b.origin[a] + b.extent[a] <= n);
                        if b.cells_lo[a] < b.cells_hi[a] {
                            assert!(b.origin[a] <= b.cells_lo[a]);
                            assert!(b.origin[a] + b.extent[a] > b.cells_hi[a]);
                        }
                    }
                    for k in b.cells_lo[2]..b.cells_hi[2] {
                        for j in b.cells_lo[1]..b.cells_hi[1] {
                            for i in b.cells_lo[0]..b.cells_hi[0] {
                                owner[(k * cells[1] + j) * cells[0] + i] += 1;
                            }
                        }
                    }
                }
                assert!(owner.iter().all(|&n| n == 1), "{dims:?} over {ranks} ranks");
            }
        }
        assert_eq!(lattice([10, 10, 10], 4), [2, 2, 1]);
        assert_eq!(lattice([5, 50, 10], 6), [1, 3, 2]);
        assert_eq!(lattice([5, 5, 5], 7), [7, 1, 1]);
    }

    #[test]
    fn block_bricks_combine_into_the_whole_grids() {
        let dims = [19, 10, 27];
        let n = dims.iter().product::<usize>();
        let values: Vec<f32> = (0..n).map(|i| ((i * 7919) % 1000) as f32 - 500.0).collect();
        let grid = Grid { dims, min: glam::DVec3::ZERO, max: glam::DVec3::ONE, values };
        let whole = Block::whole(dims).bricks(dims, &grid.values);
        for ranks in 2..=5 {
            let mut acc = vec![[f32::INFINITY, f32::NEG_INFINITY]; whole.len()];
            for r in 0..ranks {
                let b = Block::of_rank(dims, ranks, r);
                for (m, p) in acc.iter_mut().zip(b.bricks(dims, &b.values(&grid))) {
                    m[0] = m[0].min(p[0]);
                    m[1] = m[1].max(p[1]);
                }
            }
            assert_eq!(acc, whole, "{ranks} ranks");
        }
        assert_eq!(whole, crate::passes::bricks::reference(&grid));
    }
}
