//! The interpolant: how the field is evaluated between its samples, one home per side (Rust
//! here; GLSL: `shaders/include/interpolant.glsl`). [`Interpolant`] names one and says what it
//! reads ([`Stencil`]) and what the methods may rely on ([`Caps`]); [`Kernel`] is its arithmetic
//! on one cell, statically dispatched in the hot loops, and [`Interpolated`] is a grid read with
//! a chosen one (the dispatch, one exhaustive `match`). The kernels: [`trilinear`] (the one
//! every method uses today), [`cubic`] (the uniform cubic B-spline and Catmull-Rom) and
//! [`nearest`]; `device` (the GPU's texture filtering) has none on the CPU. A scene chooses one
//! with `[field] interpolation`; [`Interpolant::refusal`] is the one table of which readers
//! (methods, verbs, the brick pool) take which; docs/contributing.md says what adding one
//! touches.
//!
//! Every kernel reads its stencil with the contract's edge clamp: a sample index outside the
//! grid reads the nearest edge point ([`Kernel::gather`]).
//!
//! The missing-data rule below does not depend on the interpolant: a cell is missing when the
//! samples its interpolant reads (its stencil: the trilinear interpolant's 8 corners, the
//! cubic ones' 64 samples) hold one.

use std::ops::Range;

use glam::DVec3;

use crate::field::Grid;
use crate::shaders::consts;
use crate::vocab::Inside;

pub mod cubic;
pub mod nearest;
pub mod trilinear;

pub use cubic::{BSpline, CatmullRom};
pub use nearest::Nearest;
pub use trilinear::Trilinear;

/// An interpolant of the sampled field (the values of `[field] interpolation`). The
/// definitions are the contract's (docs/scene.md "Interpolation"): cells as always, point `i`
/// at `min + i (max - min) / (n - 1)`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Interpolant {
    /// The 8 corners of the cell, linear along each axis ([`Trilinear`]): the default.
    #[default]
    Trilinear,
    /// The uniform cubic B-spline of the 4×4×4 samples around the cell (approximating, C²;
    /// [`BSpline`]).
    CubicBspline,
    /// The Catmull-Rom spline of the same samples (interpolating, C¹; [`CatmullRom`]).
    CatmullRom,
    /// The value of the nearest point, half up ([`Nearest`]).
    Nearest,
    /// Whatever the device's texture unit returns for a linear-filtered lookup: only sampled,
    /// on the GPU (fixed-step), so it has no [`Kernel`].
    Device,
}

impl Interpolant {
    pub const ALL: [Interpolant; 5] = [
        Interpolant::Trilinear,
        Interpolant::CubicBspline,
        Interpolant::CatmullRom,
        Interpolant::Nearest,
        Interpolant::Device,
    ];

    /// The names a scene gives them, in [`Interpolant::ALL`]'s order.
    pub const NAMES: [&'static str; 5] =
        ["trilinear", "cubic-bspline", "catmull-rom", "nearest", "device"];

    /// The name a scene gives it.
    pub fn name(self) -> &'static str {
        match self {
            Interpolant::Trilinear => Self::NAMES[0],
            Interpolant::CubicBspline => Self::NAMES[1],
            Interpolant::CatmullRom => Self::NAMES[2],
            Interpolant::Nearest => Self::NAMES[3],
            Interpolant::Device => Self::NAMES[4],
        }
    }

    /// Its code in the shaders (`INTERPOLANT_*`, shared by build.rs): one arm per variant, so a
    /// new interpolant does not compile without one.
    pub const fn code(self) -> u32 {
        match self {
            Interpolant::Trilinear => consts::INTERPOLANT_TRILINEAR,
            Interpolant::CubicBspline => consts::INTERPOLANT_CUBIC_BSPLINE,
            Interpolant::CatmullRom => consts::INTERPOLANT_CATMULL_ROM,
            Interpolant::Nearest => consts::INTERPOLANT_NEAREST,
            Interpolant::Device => consts::INTERPOLANT_DEVICE,
        }
    }

    /// The fixed-step march's build for it: its variant of `raymarch.comp` (build.rs's
    /// `VARIANTS`) and the pass's name.
    pub fn march_shader(self) -> (&'static str, &'static [u8]) {
        use crate::shaders;
        match self {
            Interpolant::Trilinear => ("raymarch", shaders::RAYMARCH),
            Interpolant::CubicBspline => ("raymarch (cubic-bspline)", shaders::RAYMARCH_BSPLINE),
            Interpolant::CatmullRom => ("raymarch (catmull-rom)", shaders::RAYMARCH_CATMULL_ROM),
            Interpolant::Nearest => ("raymarch (nearest)", shaders::RAYMARCH_NEAREST),
            Interpolant::Device => ("raymarch (device)", shaders::RAYMARCH_DEVICE),
        }
    }

    /// The slice picture's build for it: its variant of `slice.comp` and the pass's name;
    /// None for `device` (only sampled by the march).
    pub fn slice_shader(self) -> Option<(&'static str, &'static [u8])> {
        use crate::shaders;
        match self {
            Interpolant::Trilinear => Some(("slice", shaders::SLICE)),
            Interpolant::CubicBspline => Some(("slice (cubic-bspline)", shaders::SLICE_BSPLINE)),
            Interpolant::CatmullRom => Some(("slice (catmull-rom)", shaders::SLICE_CATMULL_ROM)),
            Interpolant::Nearest => Some(("slice (nearest)", shaders::SLICE_NEAREST)),
            Interpolant::Device => None,
        }
    }

    /// The samples a cell reads.
    pub fn stencil(self) -> Stencil {
        match self {
            Interpolant::Trilinear => Trilinear::STENCIL,
            Interpolant::CubicBspline => BSpline::STENCIL,
            Interpolant::CatmullRom => CatmullRom::STENCIL,
            Interpolant::Nearest => Nearest::STENCIL,
            // The texture unit's linear filter reads the cell's 8 corners, as trilinear does.
            Interpolant::Device => Stencil { below: 0, above: 1 },
        }
    }

    /// What the methods may rely on.
    pub fn caps(self) -> Caps {
        match self {
            Interpolant::Trilinear => Caps {
                traced: Traced::Cubic,
                edges: Edges::Linear,
                mc33: true,
                bilinear_planes: true,
                gradient: true,
                hull: Hull::Convex,
            },
            // The B-spline weights and their blossoms are >= 0 (`cubic`'s tests), so both the
            // value and a segment's Bernstein coefficients stay in the samples' range.
            Interpolant::CubicBspline => Caps {
                traced: Traced::Bernstein,
                edges: Edges::Polynomial,
                mc33: false,
                bilinear_planes: false,
                gradient: true,
                hull: Hull::Convex,
            },
            Interpolant::CatmullRom => Caps {
                traced: Traced::Bernstein,
                edges: Edges::Polynomial,
                mc33: false,
                bilinear_planes: false,
                gradient: true,
                hull: Hull::Net,
            },
            // A voxel's value is one sample: within the range of the cell's 8 corners.
            Interpolant::Nearest => Caps {
                traced: Traced::Voxels,
                edges: Edges::Faces,
                mc33: false,
                bilinear_planes: false,
                gradient: false,
                hull: Hull::Convex,
            },
            // The filter's weights are in [0, 1] and sum to 1 (in the device's precision).
            Interpolant::Device => Caps {
                traced: Traced::None,
                edges: Edges::None,
                mc33: false,
                bilinear_planes: false,
                gradient: false,
                hull: Hull::Convex,
            },
        }
    }
}

/// What reads a field through its interpolant, each asked of [`Interpolant::refusal`] where it
/// reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reader {
    /// `render.method = "analytic"`: the exact trace.
    Analytic,
    /// `render.method = "fixed-step"`: samples along the ray.
    FixedStep,
    /// Meshes: `extract` and `render.method = "mesh"`.
    Mesh,
    /// `slice`: the value image and the contours on a plane.
    Slice,
    /// `probe --slice --segment`: a segment's roots through each plane cell's bilinear
    /// quadratic.
    SegmentProbe,
    /// `probe`: the exact trace and fixed-step's march of one pixel, in f64.
    Probe,
    /// The ray methods' brick pool (`field.residency` with a grid over the memory cap).
    BrickPool,
    /// MPI: the grid split into blocks across ranks (`mpirun ... isoview render | extract`).
    Ranks,
    /// `[field2]`, sampled for `[color] by = "field2"`.
    Colour,
}

impl Interpolant {
    /// Why `reader` does not read a field through this interpolant, as the end of a line that
    /// names `field.interpolation`; `None` where it does. The one table of what is built:
    /// trilinear everywhere; every interpolant by fixed-step, nearest also by the analytic
    /// method (its voxel walk), and `probe` every one but `device` (its f64 references);
    /// `device` only by fixed-step (the
    /// contract: it is what the texture unit returns, which exists only on the GPU's lookups
    /// of a whole-grid image). The cubic interpolants and nearest have their exact f64
    /// references (`reference::analytic`, `reference::voxels`), not yet the GPU passes and
    /// verbs marked "not yet" here (docs/limitations.md).
    pub fn refusal(self, reader: Reader) -> Option<String> {
        let name = self.name();
        match (self, reader) {
            (Interpolant::Trilinear, _) | (_, Reader::FixedStep) => None,
            // The voxel walk (`shaders/voxels.comp`, `reference::voxels`) and the tricubic
            // Bernstein walk (`shaders/tricubic.comp`, `reference::analytic::tricubic`).
            (Interpolant::Nearest | Interpolant::CubicBspline | Interpolant::CatmullRom, Reader::Analytic) => None,
            // The probe runs the f64 references, which every kernel has.
            (Interpolant::CubicBspline | Interpolant::CatmullRom | Interpolant::Nearest, Reader::Probe) => None,
            // The refined lattice with the interpolant's own crossings (`mesh::refine`), and
            // nearest's voxel faces (`mesh::voxel_faces`).
            (Interpolant::CubicBspline | Interpolant::CatmullRom | Interpolant::Nearest, Reader::Mesh) => None,
            (_, Reader::Colour) => Some(
                "[field2] is sampled trilinearly for its colours; interpolation is a key of [field]"
                    .into(),
            ),
            (Interpolant::Device, Reader::BrickPool) => Some(
                "\"device\" is the texture unit's filtering of the whole grid as one 3D image, \
                 which the brick pool does not hold; raise the memory cap so the grid fits"
                    .into(),
            ),
            (Interpolant::Device, _) => Some(
                "\"device\" is what the GPU's texture unit returns, only sampled: it needs \
                 render.method = \"fixed-step\" (and no verb that reads the field on the CPU)"
                    .into(),
            ),
            // The contract lets the pool refuse the cubic interpolants: its apron and ranges
            // would have to hold their 4x4x4 stencils.
            // The pool serves field.residency = "active" at any size, and "auto" over the cap
            // (a .vdb/.nvdb tree too): the line names both, and how to read the grid whole.
            (_, Reader::BrickPool) => Some(format!(
                "the brick pool (field.residency = \"active\", or a grid over the memory cap) \
                 holds trilinear cells only, not \"{name}\" ones; read the grid whole: under the \
                 memory cap (ISOVIEW_MAX_GRID_MIB) with field.residency = \"auto\" (the default) \
                 or \"whole\""
            )),
            (_, Reader::Ranks) => Some(format!(
                "MPI splits trilinear fields only (the blocks' ghost planes and walks are \
                 trilinear's), not \"{name}\" ones: run it without mpirun"
            )),
            // The interpolant's value image and its own contours (`slice::PlaneGrid::through`).
            (Interpolant::CubicBspline | Interpolant::CatmullRom | Interpolant::Nearest, Reader::Slice) => None,
            (_, Reader::SegmentProbe) => Some(format!(
                "probe --slice reports each plane cell's bilinear quadratic, which \"{name}\" \
                 fields do not have; probe --pixel traces them, slice draws their contours"
            )),
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
    /// How the analytic method finds a ray's crossings in a cell.
    pub traced: Traced,
    /// What the field is along a lattice edge (the extractors' crossings).
    pub edges: Edges,
    /// MC33's topology tests hold (asymptotic decider, interior test).
    pub mc33: bool,
    /// Bilinear on axis-aligned planes (slice contours).
    pub bilinear_planes: bool,
    /// Has a gradient that is the surface's normal ([`Kernel::gradient`]); without one, normals
    /// come from elsewhere (voxel faces, the device's differences).
    pub gradient: bool,
    /// What bounds the values in a cell (brick and cell skipping).
    pub hull: Hull,
}

/// How the analytic method traces a cell ([`Caps::traced`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Traced {
    /// Along a ray segment inside a cell the value is a cubic in the ray parameter (the
    /// monomial root finder, `reference::analytic::cubic`).
    Cubic,
    /// A polynomial of degree <= 9 along a segment, isolated in Bernstein form.
    Bernstein,
    /// Piecewise constant: the ray's crossings are voxel faces (a voxel walk).
    Voxels,
    /// Only sampled (fixed-step).
    None,
}

/// The field along a lattice edge ([`Caps::edges`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Edges {
    /// Linear: the extractors' crossing `(iso - a) / (b - a)` is exact.
    Linear,
    /// A polynomial (a cubic along axis edges): crossings are its roots.
    Polynomial,
    /// Piecewise constant: the surface is voxel faces, not crossings on edges.
    Faces,
    /// Not known on the CPU.
    None,
}

/// What bounds the values of a cell ([`Caps::hull`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hull {
    /// The value, and every Bernstein coefficient of a ray segment, stays within the range of
    /// the samples the cell reads: min/max of the stencil's finite samples is a bound.
    Convex,
    /// Not within the samples' range (Catmull-Rom overshoots): within the cell's Bézier net
    /// ([`Kernel::hull`]), and within the samples' range widened by `KAPPA` (max - min) on
    /// each side ([`cubic::Weights::KAPPA`]).
    Net,
}

/// One interpolant's arithmetic on one cell.
pub trait Kernel {
    /// The samples a cell reads.
    const STENCIL: Stencil;
    /// The samples a cell reads, gathered (trilinear: the 8 corners, in corner order).
    type Cell: Copy;
    /// The samples of cell `cell` (index of its lower corner) of a grid of `dims` points,
    /// `read` giving the sample at a grid point. Each index is clamped to the grid (the
    /// contract's edge clamp: a stencil reaching past the border reads the border point), so
    /// `read` only sees points of the grid.
    fn gather(read: impl Fn([usize; 3]) -> f64, cell: [usize; 3], dims: [usize; 3]) -> Self::Cell;
    /// The value at cell-local `q` in `[0, 1]³`.
    fn value(c: &Self::Cell, q: DVec3) -> f64;
    /// The gradient at cell-local `q`, in value per cell (index space).
    fn gradient(c: &Self::Cell, q: DVec3) -> DVec3;
    /// `[min, max]` bounding the value over the cell, of finite values only (`[inf, -inf]`
    /// when none is), as the brick ranges are ([`widen`]): trilinear's corners, a cubic
    /// interpolant's Bézier net.
    fn hull(c: &Self::Cell) -> [f64; 2];
    /// Whether the cell is missing ([`is_missing`] over its stencil).
    fn missing(c: &Self::Cell) -> bool;
    /// Whether the value at cell-local `q` is missing: the cell's [`Kernel::missing`] unless
    /// the kernel reads fewer samples at a point (nearest reads one).
    fn missing_at(c: &Self::Cell, q: DVec3) -> bool {
        let _ = q;
        Self::missing(c)
    }
}

/// Point `c + o - below` along an axis of `n` points, clamped to the grid ([`Kernel::gather`]).
#[inline]
pub(crate) fn clamped(c: usize, o: usize, below: usize, n: usize) -> usize {
    (c + o).saturating_sub(below).min(n - 1)
}

/// `[min, max]` of the finite `values` (`[inf, -inf]` when none is): a [`Kernel::hull`].
pub(crate) fn finite_range(values: impl IntoIterator<Item = f64>) -> [f64; 2] {
    values
        .into_iter()
        .filter(|&v| !is_missing(v))
        .fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], v| [lo.min(v), hi.max(v)])
}

/// The field of `grid` between its samples, read with `interp`: the one place that turns an
/// [`Interpolant`] into its [`Kernel`]. Coordinates are the grid's index space (`u`, point
/// `(i, j, k)` at `(i, j, k)`); a point goes to the cell [`Grid::cell_of`] picks (the last
/// plane belongs to the last cell), at local `u - cell`.
#[derive(Clone, Copy, Debug)]
pub struct Interpolated<'g> {
    pub grid: &'g Grid,
    pub interp: Interpolant,
}

/// The samples a cell reads ([`Interpolated::cell_data`]).
#[derive(Clone, Debug, PartialEq)]
pub enum CellData {
    /// Trilinear and nearest: the 8 corners, in corner order.
    Corners([f64; 8]),
    /// The cubic interpolants: the 4×4×4 samples, offsets `-1..=2`, index `a + 4b + 16c`.
    Samples(Box<[f64; 64]>),
}

/// `interpolation = "device"` has no f64 kernel: the device's filtering exists only on the
/// GPU. No scene can choose it yet (the `[field] interpolation` key does not exist), so nothing
/// reaches this; the key's commit gives `device` its CPU model or a refusal on each path.
#[cold]
fn device_has_no_kernel() -> ! {
    unreachable!("interpolation = \"device\" has no CPU kernel, and no scene can choose it yet")
}

/// `$body` with the type `$k` bound to `$interp`'s [`Kernel`]: the one `match` over the
/// interpolants that [`Interpolated`] dispatches through (no catch-all arm: a new variant
/// must be given its kernel here).
macro_rules! with_kernel {
    ($interp:expr, $k:ident => $body:expr) => {
        match $interp {
            Interpolant::Trilinear => {
                type $k = Trilinear;
                $body
            }
            Interpolant::CubicBspline => {
                type $k = BSpline;
                $body
            }
            Interpolant::CatmullRom => {
                type $k = CatmullRom;
                $body
            }
            Interpolant::Nearest => {
                type $k = Nearest;
                $body
            }
            Interpolant::Device => device_has_no_kernel(),
        }
    };
}

impl<'g> Interpolated<'g> {
    pub fn new(grid: &'g Grid, interp: Interpolant) -> Self {
        Interpolated { grid, interp }
    }

    /// The samples kernel `K` reads for cell `cell`, widened to f64.
    fn gather<K: Kernel>(&self, cell: [usize; 3]) -> K::Cell {
        K::gather(|[i, j, k]| f64::from(self.grid.at(i, j, k)), cell, self.grid.dims)
    }

    /// The cell holding `u` and `u`'s local coordinates in it.
    fn locate(&self, u: DVec3) -> ([usize; 3], DVec3) {
        let c = self.grid.cell_of(u);
        (c, u - DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64))
    }

    /// The value at grid coordinates `u`.
    pub fn value_at(&self, u: DVec3) -> f64 {
        let (c, q) = self.locate(u);
        with_kernel!(self.interp, K => K::value(&self.gather::<K>(c), q))
    }

    /// The gradient at grid coordinates `u`, in world units (value per world unit).
    pub fn gradient_at(&self, u: DVec3) -> DVec3 {
        let (c, q) = self.locate(u);
        with_kernel!(self.interp, K => K::gradient(&self.gather::<K>(c), q)) / self.grid.spacing()
    }

    /// Whether the value at grid coordinates `u` is missing ([`Kernel::missing_at`]).
    pub fn missing_at(&self, u: DVec3) -> bool {
        let (c, q) = self.locate(u);
        with_kernel!(self.interp, K => K::missing_at(&self.gather::<K>(c), q))
    }

    /// [`Interpolated::value_at`] (None where [`Interpolated::missing_at`]) of points visited in
    /// runs that stay in one cell (the rows of `mesh::refine`'s lattice): a cell's samples
    /// are gathered once a run, not once a point. The same values, bit for bit.
    pub fn reader(&self) -> Box<dyn FnMut(DVec3) -> Option<f64> + '_> {
        with_kernel!(self.interp, K => {
            let mut held: Option<([usize; 3], <K as Kernel>::Cell)> = None;
            Box::new(move |u: DVec3| {
                let (c, q) = self.locate(u);
                let cell = match held {
                    Some((at, cell)) if at == c => cell,
                    _ => {
                        let cell = self.gather::<K>(c);
                        held = Some((c, cell));
                        cell
                    }
                };
                (!K::missing_at(&cell, q)).then(|| K::value(&cell, q))
            })
        })
    }

    /// Where the segment from `a` to `b` (grid coordinates, inside one cell: a lattice edge
    /// of the cells split `render.mesh_refine` ways, `mesh::refine`) first leaves the side of
    /// the isosurface `a` is on, by the inside rule `inside`: the segment's parameter in
    /// `[0, 1]`, or None when the rule does not change along it. The cell is gathered once
    /// (the cell holding the midpoint; the interpolants are continuous across cell faces).
    /// The first change is found among [`SEGMENT_PIECES`] equal pieces and refined inside
    /// its piece by the Illinois method on the rule's bracket ([`first_change`]), to f64
    /// precision: the interpolant's own crossing, not the line through the end values.
    pub fn first_crossing(&self, a: DVec3, b: DVec3, iso: f64, inside: Inside) -> Option<f64> {
        let (c, _) = self.locate(0.5 * (a + b));
        let lo = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
        with_kernel!(self.interp, K => {
            let cell = self.gather::<K>(c);
            first_change(|s| K::value(&cell, a + (b - a) * s - lo), iso, inside)
        })
    }

    /// The samples cell `cell` reads.
    pub fn cell_data(&self, cell: [usize; 3]) -> CellData {
        match self.interp {
            Interpolant::Trilinear => CellData::Corners(self.gather::<Trilinear>(cell)),
            Interpolant::Nearest => CellData::Corners(self.gather::<Nearest>(cell)),
            Interpolant::CubicBspline => CellData::Samples(Box::new(self.gather::<BSpline>(cell))),
            Interpolant::CatmullRom => CellData::Samples(Box::new(self.gather::<CatmullRom>(cell))),
            Interpolant::Device => device_has_no_kernel(),
        }
    }
}

/// The equal pieces [`Interpolated::first_crossing`] tests a segment in before refining: a
/// crossing pair closer than an eighth of a (sub-)edge is not seen, as on any lattice edge
/// whose ends are on one side; `render.mesh_refine` splits the edges finer.
pub const SEGMENT_PIECES: usize = 8;

/// The first `s` in `[0, 1]` where `inside.contains(value(s), iso)` differs from its value at
/// 0, as [`Interpolated::first_crossing`] documents; None when no piece end differs.
fn first_change(value: impl Fn(f64) -> f64, iso: f64, inside: Inside) -> Option<f64> {
    let start = inside.contains(value(0.0), iso);
    let mut x0 = 0.0;
    let mut f0 = value(0.0) - iso;
    let (mut x1, mut f1) = (1..=SEGMENT_PIECES).find_map(|i| {
        let s = i as f64 / SEGMENT_PIECES as f64;
        let v = value(s);
        if inside.contains(v, iso) != start {
            return Some((s, v - iso));
        }
        (x0, f0) = (s, v - iso);
        None
    })?;
    // Illinois: regula falsi on the rule's bracket [x0, x1] (x0 on `start`'s side), halving
    // the kept end's value when the same end is kept twice, so both ends close in.
    let mut last = 0i8; // -1: the last step moved x0; 1: it moved x1
    for _ in 0..200 {
        let mut x = (x0 * f1 - x1 * f0) / (f1 - f0);
        if !(x > x0 && x < x1) {
            x = 0.5 * (x0 + x1);
        }
        if x <= x0 || x >= x1 {
            break; // no f64 between the ends
        }
        let v = value(x);
        if inside.contains(v, iso) == start {
            (x0, f0) = (x, v - iso);
            if last == -1 {
                f1 *= 0.5;
            }
            last = -1;
        } else {
            (x1, f1) = (x, v - iso);
            if last == 1 {
                f0 *= 0.5;
            }
            last = 1;
        }
    }
    Some(0.5 * (x0 + x1))
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
    use super::cubic::Weights;
    use super::*;

    /// `Interpolated::reader` (a cell gathered once a run) gives `value_at`'s bits and
    /// `missing_at`'s answer at every point of a refined lattice, NaN samples included, for
    /// each kernel.
    #[test]
    fn the_reader_is_value_at() {
        let dims = [5, 4, 6];
        let n = dims.iter().product::<usize>();
        let values: Vec<f32> = (0..n)
            .map(|i| if i % 17 == 3 { f32::NAN } else { ((i * 7919) % 101) as f32 * 0.1 - 5.0 })
            .collect();
        let grid = Grid { dims, min: DVec3::ZERO, max: DVec3::new(4.0, 3.0, 5.0), values };
        for interp in [
            Interpolant::Trilinear,
            Interpolant::CubicBspline,
            Interpolant::CatmullRom,
            Interpolant::Nearest,
        ] {
            let f = Interpolated::new(&grid, interp);
            let mut read = f.reader();
            let k = 3.0;
            for z in 0..=15 {
                for y in 0..=9 {
                    for x in 0..=12 {
                        let u = DVec3::new(x as f64, y as f64, z as f64) / k;
                        let want = (!f.missing_at(u)).then(|| f.value_at(u).to_bits());
                        assert_eq!(read(u).map(f64::to_bits), want, "{} at {u}", interp.name());
                    }
                }
            }
        }
    }

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
            assert_eq!(a.name(), Interpolant::NAMES[k]);
        }
        assert_eq!(Interpolant::Trilinear.stencil(), Trilinear::STENCIL);
        assert_eq!(Interpolant::Trilinear.name(), "trilinear");
        assert_eq!(Interpolant::CubicBspline.name(), cubic::BSplineWeights::NAME);
        assert_eq!(Interpolant::CatmullRom.name(), cubic::CatmullRomWeights::NAME);
        let cubic = Stencil { below: 1, above: 2 };
        assert_eq!(Interpolant::CubicBspline.stencil(), cubic);
        assert_eq!(Interpolant::CatmullRom.stencil(), cubic);
        assert_eq!(Interpolant::Nearest.stencil(), Trilinear::STENCIL);
        assert_eq!(Interpolant::Device.stencil(), Trilinear::STENCIL);
        // Today's stencil is trilinear's, whatever the other interpolants read.
        assert_eq!(STENCIL, Trilinear::STENCIL);
    }

    #[test]
    fn every_interpolant_has_a_distinct_shader_code() {
        // The shaders tell the interpolants apart by these codes only.
        for (k, a) in Interpolant::ALL.iter().enumerate() {
            for b in &Interpolant::ALL[..k] {
                assert_ne!(a.code(), b.code(), "{} and {} share a code", a.name(), b.name());
            }
        }
    }

    #[test]
    fn the_caps_say_which_hull_bounds_the_cell() {
        // A convex hull is the plain sample range; only Catmull-Rom overshoots it.
        for i in Interpolant::ALL {
            let kappa = match i {
                Interpolant::CatmullRom => cubic::CatmullRomWeights::KAPPA,
                Interpolant::CubicBspline => cubic::BSplineWeights::KAPPA,
                Interpolant::Trilinear | Interpolant::Nearest | Interpolant::Device => 0.0,
            };
            assert_eq!(i.caps().hull == Hull::Convex, kappa == 0.0, "{}", i.name());
        }
        let t = Interpolant::Trilinear.caps();
        assert_eq!(
            (t.traced, t.edges, t.mc33, t.bilinear_planes),
            (Traced::Cubic, Edges::Linear, true, true)
        );
        assert!(!Interpolant::Nearest.caps().gradient && !Interpolant::Device.caps().gradient);
    }

    fn grid(dims: [usize; 3], seed: u64) -> Grid {
        let mut s = seed;
        let values = (0..dims.iter().product())
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s >> 40) as f32 / (1u32 << 24) as f32 - 0.5
            })
            .collect();
        Grid { dims, min: DVec3::new(-1.0, 0.0, 2.0), max: DVec3::new(1.0, 3.0, 2.5), values }
    }

    /// Trilinear through [`Interpolated`] is the functions the references call, bit for bit.
    #[test]
    fn interpolated_trilinear_is_the_trilinear_functions_bit_for_bit() {
        let g = grid([5, 4, 6], 9);
        let f = Interpolated::new(&g, Interpolant::Trilinear);
        for n in 0..500 {
            let u = DVec3::new(
                (n % 17) as f64 * 0.25,
                (n % 13) as f64 * 0.25,
                (n % 21) as f64 * 0.25 + 0.125,
            )
            .min(DVec3::new(4.0, 3.0, 5.0));
            let c = g.cell_of(u);
            let q = u - DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
            let corners = g.corners(c[0], c[1], c[2]).map(f64::from);
            assert_eq!(f.value_at(u).to_bits(), trilinear::trilerp(&corners, q).to_bits());
            let grad = trilinear::gradient(&corners, q.x, q.y, q.z) / g.spacing();
            assert_eq!(f.gradient_at(u), grad);
            assert_eq!(f.cell_data(c), CellData::Corners(corners));
            assert!(!f.missing_at(u));
        }
    }

    #[test]
    fn interpolated_reads_each_kernels_cell() {
        let mut g = grid([5, 4, 6], 10);
        let cubic = Interpolated::new(&g, Interpolant::CatmullRom);
        let CellData::Samples(s) = cubic.cell_data([0, 2, 4]) else { panic!("64 samples") };
        // Offsets -1..=2 clamped: sample (0, 0, 0) is point (0, 1, 3); (3, 3, 3) is (2, 3, 5).
        assert_eq!(s[0], f64::from(g.at(0, 1, 3)));
        assert_eq!(s[63], f64::from(g.at(2, 3, 5)));
        let u = DVec3::new(0.3, 2.6, 4.2);
        let q = u - DVec3::new(0.0, 2.0, 4.0);
        assert_eq!(cubic.value_at(u), CatmullRom::value(&s, q));
        // A missing sample in the stencil but outside the 8 corners: missing for the cubic
        // interpolants only.
        let i = g.index(2, 1, 3);
        g.values[i] = f32::NAN;
        for (interp, missing) in [
            (Interpolant::Trilinear, false),
            (Interpolant::Nearest, false),
            (Interpolant::CubicBspline, true),
            (Interpolant::CatmullRom, true),
        ] {
            assert_eq!(Interpolated::new(&g, interp).missing_at(u), missing, "{}", interp.name());
        }
    }
}
