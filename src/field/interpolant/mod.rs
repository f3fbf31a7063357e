//! The interpolant: how the field is evaluated between its samples, one home per side (Rust
//! here; GLSL: `shaders/include/interpolant.glsl`). [`Interpolant`] names one and says what it
//! reads ([`Stencil`]) and what the methods may rely on ([`Caps`]); [`Kernel`] is its arithmetic
//! on one cell, statically dispatched in the hot loops. Only the trilinear interpolant exists
//! today ([`trilinear`], [`Trilinear`]); docs/contributing.md says what adding one touches.
//!
//! The missing-data rule below does not depend on the interpolant: a cell is missing when the
//! samples its interpolant reads (its stencil: the trilinear interpolant's 8 corners) hold one.

use std::ops::Range;

use glam::DVec3;

pub mod trilinear;

pub use trilinear::Trilinear;

/// An interpolant of the sampled field (the next issue's `[field] interpolation` key).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolant {
    Trilinear,
}

impl Interpolant {
    pub const ALL: [Interpolant; 1] = [Interpolant::Trilinear];

    /// The name a scene gives it.
    pub fn name(self) -> &'static str {
        match self {
            Interpolant::Trilinear => "trilinear",
        }
    }

    /// The samples a cell reads.
    pub fn stencil(self) -> Stencil {
        match self {
            Interpolant::Trilinear => Trilinear::STENCIL,
        }
    }

    /// What the methods may rely on.
    pub fn caps(self) -> Caps {
        match self {
            Interpolant::Trilinear => Caps {
                ray_cubic: true,
                linear_edges: true,
                mc33: true,
                bilinear_planes: true,
                convex: true,
            },
        }
    }
}

/// The points a cell reads along each axis: from `below` points before its lower corner to
/// `above` points after it (trilinear: its own 2, `{ below: 0, above: 1 }`; a cubic B-spline
/// or Catmull-Rom reads 4, offsets -1..=2, `{ below: 1, above: 2 }`). Brick ranges, the pool's
/// apron, the MPI ghost planes and the z-range windows are this wide, plus what smooth normals
/// add ([`SMOOTH_NORMAL_REACH`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stencil {
    pub below: usize,
    pub above: usize,
}

impl Stencil {
    /// Points per axis.
    pub const fn width(self) -> usize {
        self.below + self.above + 1
    }

    /// The point indices that cells `cells` read along an axis of `n` points, clamped to the
    /// grid (a stencil reaching past the boundary reads the boundary point again).
    pub fn points(self, cells: Range<usize>, n: usize) -> Range<usize> {
        let lo = cells.start.saturating_sub(self.below);
        let hi = (cells.end.saturating_sub(1) + self.above + 1).min(n);
        lo.min(hi)..hi
    }
}

/// What the shaders' smooth normals add to the stencil on each side: central differences of
/// the point gradients read one point further.
pub const SMOOTH_NORMAL_REACH: usize = 1;

/// What an interpolant guarantees, which the methods that rely on it check.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Caps {
    /// Along a ray segment inside a cell the value is a cubic in the ray parameter (the
    /// analytic method's root finder).
    pub ray_cubic: bool,
    /// Linear along lattice edges: the extractors' crossing `(iso - a) / (b - a)` is exact.
    pub linear_edges: bool,
    /// MC33's topology tests hold (asymptotic decider, interior test).
    pub mc33: bool,
    /// Bilinear on axis-aligned planes (slice contours).
    pub bilinear_planes: bool,
    /// Stays within the range of the samples it reads (brick and cell skipping use min/max).
    pub convex: bool,
}

/// One interpolant's arithmetic on one cell.
pub trait Kernel {
    /// The samples a cell reads.
    const STENCIL: Stencil;
    /// The samples a cell reads, gathered (trilinear: the 8 corners, in corner order).
    type Cell: Copy;
    /// The samples of cell `cell` (index of its lower corner), `read` giving the sample at a
    /// grid point.
    fn gather(read: impl Fn([usize; 3]) -> f64, cell: [usize; 3]) -> Self::Cell;
    /// The value at cell-local `q` in `[0, 1]³`.
    fn value(c: &Self::Cell, q: DVec3) -> f64;
    /// The gradient at cell-local `q`, in value per cell (index space).
    fn gradient(c: &Self::Cell, q: DVec3) -> DVec3;
    /// Whether the cell is missing ([`is_missing`] over its stencil).
    fn missing(c: &Self::Cell) -> bool;
}

/// THE missing-data rule (`field.nan = "empty"`, the default; GPU: `shaders/include/missing.glsl`):
/// a sample that is NaN or infinite is missing data. Every method asks [`cell_missing`]; the
/// brick ranges leave such samples out ([`widen`]).
#[inline]
pub fn is_missing(v: f64) -> bool {
    !v.is_finite()
}

/// A cell whose trilinear stencil, its 8 corners (any order), holds a missing sample
/// ([`is_missing`]) is *missing*: it holds no surface, for every method. The analytic walk
/// steps over it as over a cell clear of the isovalues; the fixed-step march reports no
/// crossing on a step with an end in it; the extractors give it no triangle and no dual
/// vertex, and a lattice edge with a missing end no vertex (an edge between finite points keeps
/// its vertex: a finite cell holds it); slice contours skip it and probe says so.
#[inline]
pub fn cell_missing(corners: &[f64; 8]) -> bool {
    corners.iter().any(|&v| is_missing(v))
}

/// Widens the range `mm` by the sample `v`, unless `v` is missing data (NaN or ±inf,
/// [`is_missing`]): a brick's range (`passes::bricks`) holds its finite samples only, so its
/// test against the isovalues is about the cells that can hold a surface (GLSL's `min`/`max`
/// are undefined with NaN; `bricks.comp` skips the same samples). A brick with no finite
/// sample keeps `[inf, -inf]`, which no range test calls clear. With every sample finite,
/// the plain min/max.
#[inline]
pub fn widen(mm: &mut [f32; 2], v: f32) {
    if !is_missing(f64::from(v)) {
        *mm = [mm[0].min(v), mm[1].max(v)];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stencil_points_cover_the_cells_and_stay_in_the_grid() {
        let tri = Interpolant::Trilinear.stencil();
        assert_eq!(tri.width(), 2);
        // Cells 3..7 of 10 points read points 3..=7; the last cell (8) reads 8 and 9.
        assert_eq!(tri.points(3..7, 10), 3..8);
        assert_eq!(tri.points(0..9, 10), 0..10);
        let cubic = Stencil { below: 1, above: 2 };
        assert_eq!(cubic.width(), 4);
        assert_eq!(cubic.points(3..7, 20), 2..9);
        assert_eq!(cubic.points(0..9, 10), 0..10, "clamped at both ends");
    }

    #[test]
    fn every_interpolant_has_a_unique_name_and_its_kernels_stencil() {
        for (k, a) in Interpolant::ALL.iter().enumerate() {
            assert!(Interpolant::ALL[..k].iter().all(|b| b.name() != a.name()));
        }
        assert_eq!(Interpolant::Trilinear.stencil(), Trilinear::STENCIL);
        assert_eq!(Interpolant::Trilinear.name(), "trilinear");
    }
}
