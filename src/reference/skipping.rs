//! `steps` of the exact walks of the other interpolants with empty-space skipping
//! (`render.skip`), counted as the GPU's walks count them (`shaders/voxels.comp`,
//! `shaders/tricubic.comp`, laid out as `shaders/analytic.comp`): one pass per cell (or voxel)
//! tested, and one per brick crossed in a jump. Skipping changes no other channel, so the
//! references keep their walks and only count differently: from the walk's visits up to the
//! hit (all of them on a miss), a visit in a brick the GPU jumps over starts a run that counts
//! one, and the rest of the run in that brick counts nothing:
//!
//! ```text
//!   visits  c c | c c c c | c c        bricks: clear  clear(empty)  not clear
//!   counted 1 1 | 1 . . . | 1 1        (the first visit of an empty brick and its jump: one)
//! ```
//!
//! A brick is empty when its min/max range (`passes::bricks`, the same f32 bits as the GPU's)
//! is clear of every surface's threshold by the shaders' margin (`bricks::clear_by`,
//! `SKIP_MARGIN`, in the same f32 arithmetic), so the GPU and the reference agree on it. The GPU
//! jumps only from a visit of positive length (a zero-length visit is stepped over and counts
//! one) and only on rays whose planes' t it computes strictly increasing (`may_jump`); a
//! superbrick jump counts the bricks it crosses, which is this count too. Cells map to bricks of
//! `BRICK`³ cells; voxels to voxel bricks of `BRICK`³ voxels, whose range is trilinear brick
//! `min(b, last)`'s (`voxels.comp` says why it covers them). The f64 walk and the f32 one can
//! only disagree on which brick a visit lies in where a ray passes within rounding of a brick
//! face, where their visits already may differ.

use glam::DVec3;

use crate::field::interpolant::Interpolant;
use crate::field::Grid;
use crate::passes::bricks::{self, brick_counts, clear_by, Bound, BRICK, SKIP_MARGIN};
use crate::render::params::RenderParams;
use crate::scene::Scene;

/// Which bricks of a scene's walk are empty, and how its visits map to them.
pub struct Skipping {
    /// Per brick (x fastest), whether the walk jumps over it.
    empty: Vec<bool>,
    counts: [usize; 3],
    /// Visits are voxels (nearest) rather than cells.
    voxels: bool,
}

impl Skipping {
    /// The bricks of `scene`'s analytic walk over `grid`; `None` when it does not skip
    /// (`render.skip = false`) or its interpolant is not one of these walks'.
    pub fn for_scene(scene: &Scene, grid: &Grid) -> Option<Skipping> {
        let bound = match scene.field.interpolation {
            Interpolant::Nearest => Bound::Corners,
            Interpolant::CubicBspline => Bound::Cubic,
            Interpolant::CatmullRom => Bound::CatmullRom,
            Interpolant::Trilinear | Interpolant::Device => return None,
        };
        if !scene.render.skip {
            return None;
        }
        let thresholds = RenderParams::new(scene, grid).surface_thresholds();
        let empty = bricks::reference_for(grid, bound)
            .into_iter()
            .map(|mm| thresholds.iter().all(|&iso| clear_by(mm, iso, SKIP_MARGIN)))
            .collect();
        Some(Skipping { empty, counts: brick_counts(grid.dims), voxels: bound == Bound::Corners })
    }

    /// The brick of cell (or voxel) `c` (what the GPU jumps across) and the index of the range
    /// it skips by: the same for cells; for voxels the voxel brick, whose range is trilinear
    /// brick `min(b, last)`'s (the extra voxel brick of a grid with a multiple of `BRICK`
    /// cells is one of its own, with the last brick's range).
    fn brick(&self, c: [usize; 3]) -> ([usize; 3], usize) {
        let b: [usize; 3] = std::array::from_fn(|a| c[a] / BRICK);
        let r: [usize; 3] = std::array::from_fn(|a| b[a].min(self.counts[a] - 1));
        debug_assert!(self.voxels || b == r);
        (b, (r[2] * self.counts[1] + r[1]) * self.counts[0] + r[0])
    }

    /// `steps` of a walk along the world-space ray `origin + t dir` over `grid` (clipped by
    /// `clip`) whose counted visits (up to and including the hit's) are `visits`: (cell or
    /// voxel, t_in, t_out) each.
    pub fn steps(
        &self,
        grid: &Grid,
        origin: DVec3,
        dir: DVec3,
        clip: &crate::vocab::Clip,
        visits: impl IntoIterator<Item = ([usize; 3], f64, f64)>,
    ) -> u32 {
        let Some(span) = crate::reference::analytic::span(grid, origin, dir, clip) else {
            return 0;
        };
        let (o, d) = (span.o, span.d);
        // `may_jump` of the shaders, on the f64 ray (the f32 one differs by rounding).
        // (The shaders' bounds, 2^-90 and 2^90 give or take: quotients of plane numerators
        // below 2^20 by them stay finite and normal.)
        let normal =
            |m: f64| m == 0.0 || (m > 8.077_935_669_463_161e-28 && m < 1.237_940_039_285_380_3e27);
        let may_jump = o.abs().max_element() < 1048576.0 && (0..3).all(|a| normal(d[a].abs()));
        let mut steps = 0;
        let mut run = None;
        for (c, t_in, t_out) in visits {
            let (b, range) = self.brick(c);
            if run == Some(b) {
                continue;
            }
            steps += 1;
            run = (may_jump && self.empty[range] && t_out > t_in).then_some(b);
        }
        steps
    }
}
