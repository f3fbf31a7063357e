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

    /// The stencil reaching `r` more points on each side (smooth normals: [`SMOOTH_NORMAL_REACH`]).
    pub const fn widened(self, r: usize) -> Stencil {
        Stencil { below: self.below + r, above: self.above + r }
    }

    /// The point indices that cells `cells` read along an axis of `n` points, clamped to the
    /// grid (a stencil reaching past the boundary reads the boundary point again). For an
    /// empty range `c..c`, the points around the plane `c` (`below` under it, `above` from it).
    pub fn points(self, cells: Range<usize>, n: usize) -> Range<usize> {
        let lo = cells.start.saturating_sub(self.below);
        let hi = (cells.end + self.above).min(n);
        lo.min(hi)..hi
    }

    /// The points brick `b` of `size` cells reads along an axis of `n` points (its cells
    /// `b size .. min((b + 1) size, n - 1)`): the min/max grid's range of a brick is over these
    /// (`passes::bricks`, `shaders/bricks.comp`, `field::mapped`, `render::block`).
    pub fn brick_points(self, b: usize, size: usize, n: usize) -> Range<usize> {
        let cells = n.saturating_sub(1);
        self.points((b * size).min(cells)..((b + 1) * size).min(cells), n)
    }

    /// The bricks of `size` cells, `count` of them along the axis, whose points
    /// ([`Stencil::brick_points`]) include point `p`.
    pub fn bricks_holding(self, p: usize, size: usize, count: usize) -> Range<usize> {
        // Brick b reads points b size - below ..< (b + 1) size + above.
        let first = (p + 1).saturating_sub(self.above).div_ceil(size).saturating_sub(1);
        let last = ((p + self.below) / size).min(count.saturating_sub(1));
        first..last + 1
    }
}

/// The stencil the grid is read with today: the trilinear interpolant's. Brick ranges, the
/// pool's apron, the MPI ghost planes, the z-range windows and the GPU extraction's slabs are
/// sized from it (the GLSL side: `STENCIL_BELOW` / `STENCIL_ABOVE`, build.rs).
pub const STENCIL: Stencil = Trilinear::STENCIL;

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
    fn trilinear_sizes_are_the_old_formulas() {
        // The sizes were written for 2 points per axis before they were read from the stencil;
        // these are those formulas, which the trilinear stencil must reproduce exactly.
        for n in 2..40usize {
            for size in [1usize, 2, 3, 8] {
                let count = (n - 1).div_ceil(size);
                for b in 0..count {
                    // bricks.comp, field::mapped: b size ..= min(b size + size, n - 1).
                    assert_eq!(
                        STENCIL.brick_points(b, size, n),
                        b * size..(b * size + size).min(n - 1) + 1
                    );
                }
                for p in 0..n {
                    // render::block: a point on a brick boundary belongs to both bricks.
                    let b = p / size;
                    let old: Vec<usize> = (p % size == 0 && b > 0)
                        .then(|| b - 1)
                        .into_iter()
                        .chain((b < count).then_some(b))
                        .collect();
                    let new: Vec<usize> = STENCIL.bricks_holding(p, size, count).collect();
                    assert_eq!(new, old, "n {n} size {size} p {p}");
                }
            }
            for lo in 0..n {
                for hi in lo..n {
                    // render::block's ghost planes: lo - 1 ..= min(hi + 1, n - 1).
                    let p = STENCIL.widened(SMOOTH_NORMAL_REACH).points(lo..hi, n);
                    assert_eq!((p.start, p.end - 1), (lo.saturating_sub(1), (hi + 1).min(n - 1)));
                }
            }
        }
    }

    #[test]
    fn a_cubic_stencil_widens_the_brick_ranges() {
        let cubic = Stencil { below: 1, above: 2 };
        assert_eq!(cubic.brick_points(1, 8, 30), 7..18);
        assert_eq!(cubic.brick_points(0, 8, 30), 0..10);
        assert_eq!(cubic.brick_points(3, 8, 30), 23..30);
        for p in 0..30 {
            for b in 0..4 {
                assert_eq!(
                    cubic.bricks_holding(p, 8, 4).contains(&b),
                    cubic.brick_points(b, 8, 30).contains(&p),
                    "p {p} b {b}"
                );
            }
        }
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
