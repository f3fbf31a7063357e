//! Exact ray tracing of the isosurface of a trilinearly interpolated grid, in `f64`: the CPU
//! reference, and the definition, of `render.method = "analytic"`.
//!
//! The GPU shader mirrors this module step for step in `f32`, so the per-ray core is a fixed
//! sequence of simple steps: no recursion, no allocation (the trace is optional and off the hot
//! path), every loop bounded.
//!
//! # What is a hit
//!
//! Along the ray `r(t) = origin + t dir`, the field `f` is defined on the closed grid box and is
//! the trilinear interpolant of a cell's 8 corners inside that cell. The inside predicate is
//! `Inside::contains(f, iso)`: strictly below (or above) the isovalue is inside, a value equal
//! to the isovalue is **outside**. A *crossing* is a change of that predicate along the part of
//! the ray inside the box, `[t_lo, t_hi]` with `t_lo = max(t_enter, 0)`. The hit is the first
//! crossing with `t > 0` (or the k-th, [`AnalyticOptions::crossing`]); its `t` is the boundary
//! point of the inside set, i.e. the root of `f(r(t)) = iso` where the predicate changes.
//!
//! Consequences of the contract's rule, stated once:
//!
//! - **Touch from outside** (the field reaches the isovalue at one point and turns back, on the
//!   outside side): the predicate never changes, so it is **not a hit** and not counted.
//! - **Touch from inside** (inside on both sides, exactly on the surface at one point `t*`): the
//!   predicate does change, at `t*` and back at `t*`, so it counts as **two crossings at the same
//!   `t`**, and the first of them is a hit. (This needs `f(t*) == iso` exactly, e.g. a corner
//!   equal to the isovalue on the ray or an exact double root; with the mirrored field and
//!   `inside` flipped the same geometry is a touch from outside. That asymmetry is the contract's
//!   "equal is outside".)
//! - **Surface at a point of evaluation** (a corner or face value equal to the isovalue, a
//!   segment end exactly on the surface): that point is outside, and a crossing next to it is
//!   located exactly there, without refinement.
//! - **Ray starting on the surface** (`f(origin) == iso` with the origin in the box): the change
//!   at `t = 0` is not counted (hits need `t > 0`).
//! - **Box faces** are not surface: there is no field outside the box, so entering the box while
//!   inside is no crossing. A face point exactly on the surface is an ordinary point of the
//!   segment: entering at a value equal to the isovalue and then going inside *is* a crossing at
//!   the face (`t = t_lo > 0`), as is reaching the isovalue exactly at the exit face from inside.
//! - **Regions where `f == iso`** (a plateau of corners equal to the isovalue, a ray lying in a
//!   level plane): outside, like any value equal to the isovalue.
//!
//! # The walk
//!
//! ```text
//!            t_lo                                          t_hi
//!   origin ---*--------+-----------+------x----+-----------*---->  dir
//!             | cell A |  cell B   |  cell C   |  cell D   |
//!             g0       g1          g2  r   ^   g3          g4
//!                                      |   root: first predicate change, refined
//!                                      derivative root of C's cubic: split point
//! ```
//!
//! Work happens in index space (`(p - grid.min) / spacing`, grid points at integers), where the
//! ray keeps its `t`. The DDA visits the cells the ray passes through; in each it builds the
//! cubic `g(u) = f(q_in + u (q_out - q_in)) - iso`, `u` in `[0, 1]`, in cell-local coordinates
//! (origin at the cell's corner 000, unit cell; `q_in`, `q_out` the segment's ends), splits
//! `[0, 1]` at the roots of `g'` so that `g` is monotone on each piece, and looks for a change of
//! the inside predicate between consecutive split points. The values `g0, g1, ...` at cell
//! boundaries are computed **once** and carried from one cell to the next, so the predicate
//! along the whole ray is evaluated on one sequence of points
//! (`t_lo`, the derivative roots and cell boundaries in order, `t_hi`): every change of the
//! predicate between two consecutive points is one crossing, found in the cell that holds both
//! points. Nothing can slip through a face, whatever the rounding.
//!
//! # Per-ray algorithm (port this to GLSL as written)
//!
//! 1. **Index space.** `h = (max - min) / (dims - 1)`; `o = (origin - min) / h`, `d = dir / h`,
//!    `N = dims - 1`. A zero or non-finite `h`, origin or direction, or `dir == 0`: miss.
//! 2. **Slab clip.** For each axis `a`: if `d[a] == 0`, the ray misses unless
//!    `0 <= o[a] <= N[a]` (a ray in a face plane is in the box), and the slab adds no bound;
//!    else `t0 = (0 - o[a]) / d[a]`, `t1 = (N[a] - o[a]) / d[a]`, near/far by the sign of `d[a]`.
//!    `t_enter` = max of the nears (remember its axis), `t_exit` = min of the fars. Miss unless
//!    `t_enter <= t_exit` and `0 < t_exit < inf` (the last rules out a direction that
//!    underflowed to 0 in index space). `t_lo = max(t_enter, 0)`, `t_hi = t_exit`.
//! 3. **Entry point.** `p = o + t_lo d`; if `t_lo == t_enter`, set the entry axis coordinate
//!    to exactly `0` (d > 0) or `N` (d < 0); clamp `p` to `[0, N]`.
//! 4. **First cell.** Per axis: `floor(p)` if `d >= 0`, `ceil(p) - 1` if `d < 0` (a ray starting
//!    on a grid plane goes into the cell it heads into), clamped to `[0, N - 1]`. Entry local
//!    point `q_in = clamp(p - cell, 0, 1)`; `g_in = trilerp(corners, q_in) - iso`.
//! 5. **Next planes.** `tmax[a] = (cell[a] + 1 - o[a]) / d[a]` if `d[a] > 0`,
//!    `(cell[a] - o[a]) / d[a]` if `d[a] < 0`, `+inf` if `d[a] == 0`. Always computed from the
//!    plane index, never accumulated, so the last cell's `tmax` is exactly the slab's far `t`.
//! 6. **Loop**, at most `Nx + Ny + Nz` times (each pass steps at least one axis):
//!    1. `t_out = max(min(tmax.x, tmax.y, tmax.z, t_hi), t_in)`; the segment is the last if
//!       `t_out >= t_hi`. An axis is *crossed* when `tmax[a] <= t_out`.
//!    2. Exit point: crossed axes are set to exactly `1` (d > 0) or `0` (d < 0); the others are
//!       `clamp(o[a] + t_out d[a] - cell[a], 0, 1)`. `g_out = trilerp(corners, q_out) - iso`,
//!       except for a zero-length segment (`t_out == t_in`), which keeps `g_out = g_in`: one
//!       point, one value.
//!    3. Cubic coefficients (see [`cubic::Cubic::along_segment`]), with `D = q_out - q_in`:
//!       `c0 = g_in`, `c1 = grad f(q_in) . D`,
//!       `c2 = Dx Dy f_xy(q_in) + Dx Dz f_xz(q_in) + Dy Dz f_yz(q_in)`, `c3 = axyz Dx Dy Dz`.
//!    4. Roots of `g'(u) = 3 c3 u^2 + 2 c2 u + c1` strictly inside `(0, 1)`
//!       ([`cubic::Cubic::derivative_roots`]: linear when `c3 == 0`, nothing when `c3 == c2 == 0`,
//!       cancellation-free quadratic formula otherwise). Split points:
//!       `0, r1, r2, 1` with values `g_in, g(r1), g(r2), g_out` (Horner for the interior ones).
//!    5. For each piece `[ua, ub]` in order, with `pa = inside(ga)`, `pb = inside(gb)`:
//!       if `pa == pb`, no crossing. Else one crossing, at
//!       `ua` if `ga == 0`, at `ub` if `gb == 0` (a point exactly on the surface: exact, no
//!       refinement), otherwise at the root refined in `[ua, ub]` by [`cubic::refine`]
//!       (secant start; up to `newton_steps` Newton steps, the bracket shrunk by the inside
//!       predicate at each iterate, a step that leaves the bracket replaced by a bisection, or
//!       ending the refinement when it is no longer than [`cubic::CONVERGED`]; stop on `g == 0`
//!       or a step that changes nothing).
//!       `t = t_in + u (t_out - t_in)`, capped at `t_out` and exactly `t_out` at `u = 1` (so `t`
//!       never decreases along the ray). A crossing at exactly `t = 0` (ray starting on the
//!       surface) is dropped. Otherwise count it; if it is the k-th, it is the hit (a shader
//!       stops here; the reference walks on to count every crossing).
//!    6. If last, stop. Else step every crossed axis (`cell[a] += sign(d[a])`, recompute
//!       `tmax[a]`; ties step together, so a ray through an edge or corner goes diagonally) and
//!       set the new `q_in` to `q_out` with each crossed coordinate flipped (1 -> 0 or 0 -> 1),
//!       `g_in = g_out`, `t_in = t_out`. (A stepped index outside `[0, N - 1]` also stops: a
//!       guard, unreachable since the last cell's `tmax` equals the slab's far `t`.)
//! 7. **Hit attributes.** Cell-local point `q = lerp(q_in, q_out, u)`; world gradient
//!    `grad f(q) / h` in the hit cell; normal `+grad` for `Below`, `-grad` for `Above`,
//!    normalised (inside to outside); where the gradient is zero or not finite (a saddle
//!    point, or a touch at a critical point), the normal is `-normalize(dir)`. Position
//!    `origin + t dir`.
//!
//! **Missing data** (`field.nan = "empty"`): a missing cell
//! ([`crate::field::interpolant::cell_missing`]) is walked (it counts in `cells_total`) but holds
//! no crossing: steps 6.2–6.5 are skipped, and the next cell's `g_in` is evaluated from its own
//! corners at its entry point (by face exactness, what a finite neighbour would have carried).
//!
//! A crossing exactly on a cell face belongs to the cell on the face's inside side: the face
//! point is outside, so the change is detected in the piece that contains inside values.
//!
//! # Face consistency
//!
//! Two independent guarantees:
//!
//! - The walk carries the face value (step 6.6), so adjacent cells agree by construction.
//! - [`trilerp`] is exact at local 0 and 1 (see `trilinear`), so a cell evaluating a face
//!   point on its own gets the same bits as its neighbour. A GPU port that evaluates each cell
//!   independently keeps the guarantee as long as it snaps the crossed coordinate and keeps the
//!   x-y-z lerp order.
//!
//! Interior points (derivative roots, refinement iterates) are evaluated with the cell's cubic.
//! Rounding can move them, which only matters at near-tangencies: two crossings a rounding error
//! apart may appear or vanish together. That includes kinks: the field is only C0 across cell
//! faces, so its slope along the ray can change sign at a face, and a face value within
//! rounding of the isovalue there is a near-touch too. Counts therefore agree with exact
//! arithmetic except near tangencies, and the first hit agrees except where a near-tangency
//! comes first.
//!
//! # Notes for the `f32` port
//!
//! - Decide the predicate on `g = f - iso` exactly as here (`g < 0` for `Below`, `g > 0` for
//!   `Above`); in `f64` that equals `Inside::contains(f, iso)` because IEEE subtraction keeps
//!   the sign and gives 0 only for equal operands. A GPU that flushes denormals can turn a tiny
//!   difference into 0 (outside): harmless, but it is a difference from this reference at the
//!   level of rounding.
//! - `CONVERGED` becomes `4 * FLT_EPSILON`; everything else is free of tolerances.
//! - Ties in step 6.1 need exact float equality of `tmax` values; they happen for rays through
//!   grid edges and corners with exactly representable directions, and a near-tie only costs
//!   a zero- or tiny-length segment, never a crack.
//!
//! # Other interpolants
//!
//! The walk is generic over the interpolant's part of it, [`RayCell`] (steps 4, 6.2–6.5 and 7:
//! gather the cell's samples, evaluate, cut the segment into pieces, refine, the gradient).
//! Everything above is trilinear's `RayCell`; the walk itself (steps 1–3, 5, 6.1, 6.6), the
//! predicate, the crossing rule, the tie rules and the missing-data rule are the same for all.
//! The tricubic interpolants (`cubic-bspline`, `catmull-rom`) cut a segment at the leaves of a
//! Bernstein root isolation of their degree-9 segment polynomial, whose ends are the walk's face
//! values (`tricubic`); their near-tangency clause is wider, `2^-16` of a segment. They are
//! reached through [`trace_interpolated`].
//!
//! # Cost figures
//!
//! `cells_total` counts every cell the walk processes (including zero-length segments where the
//! ray passes within rounding of an edge); `cells_visited` counts those up to and including the
//! hit cell (what a shader that stops at the hit visits), or all of them on a miss.

mod bernstein;
pub mod cubic;
mod tricubic;

#[cfg(test)]
mod tests;

use glam::DVec3;

use crate::field::interpolant::{
    cell_missing, BSpline, CatmullRom, Interpolant, Interpolated, Kernel, Trilinear,
};
use crate::field::Grid;
use crate::frame::Pixel;
use crate::reference::shade::{nearest_surface, render_with_interp, RayHit};
use crate::reference::skipping::Skipping;
use crate::reference::trilinear::{cell_corners, lerp3, trilerp};
use crate::scene::{Inside, Scene};
use crate::vocab::Clip;

use cubic::{inside_g, refine, Cubic};

/// Knobs of the analytic tracer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnalyticOptions {
    /// Newton-Raphson iterations per refined root (`render.newton_steps`); each is replaced by a
    /// bisection when it would leave the bracket. 0 returns the secant estimate.
    pub newton_steps: u32,
    /// Which crossing to report, counting from 1 (the first hit). 0 is read as 1.
    pub crossing: u32,
    /// Clip planes, in the frame of the ray (`render`'s: the grid's).
    pub clip: Clip,
}

impl Default for AnalyticOptions {
    fn default() -> Self {
        AnalyticOptions { newton_steps: 10, crossing: 1, clip: Clip::NONE }
    }
}

/// A ray's hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter: the hit is at `origin + t dir` (distance when `dir` is a unit vector).
    pub t: f64,
    /// World-space position, `origin + t dir`.
    pub position: DVec3,
    /// World-space unit normal, inside to outside (see the module doc for the zero-gradient
    /// fallback).
    pub normal: DVec3,
    /// Index of the cell whose segment holds the crossing.
    pub cell: [i32; 3],
    /// Cell-local coordinates of the hit in that cell.
    pub local: DVec3,
    /// True when the ray goes from outside to inside here.
    pub entering: bool,
    /// Which crossing this is along the ray (1 = first).
    pub crossing: u32,
}

/// Everything a ray found.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AnalyticHit {
    /// The requested crossing, if the ray has that many.
    pub hit: Option<Hit>,
    /// `[t_lo, t_hi]`, the part of the ray inside the box with `t >= 0`; `None` when the ray
    /// misses the box.
    pub span: Option<(f64, f64)>,
    /// Whether the ray is inside at `t_lo` (false when it misses the box).
    pub inside_at_start: bool,
    /// Cells walked up to and including the hit cell; all of them when there is no hit.
    pub cells_visited: u32,
    /// Cells walked over the whole span.
    pub cells_total: u32,
    /// Crossings with `t > 0` over the whole span.
    pub crossings: u32,
}

/// A point where the walk evaluated the predicate inside one cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitPoint {
    /// Segment parameter in `[0, 1]`.
    pub u: f64,
    /// `f - iso` there (carried face value at `u = 0` and `u = 1`, the cubic inside).
    pub g: f64,
    /// The inside predicate there.
    pub inside: bool,
}

/// One crossing found in a cell, as the probe shows it.
#[derive(Clone, Debug, PartialEq)]
pub struct RootTrace {
    /// Its number along the ray (1 = first); 0 when dropped for lying at `t = 0`.
    pub crossing: u32,
    /// Segment parameter of the root.
    pub u: f64,
    /// Ray parameter of the root.
    pub t: f64,
    /// Outside to inside.
    pub entering: bool,
    /// The bracket was closed by a point exactly on the surface: `u` is that point, unrefined.
    pub exact: bool,
    /// The bracket `[ua, ub]` that held the root.
    pub bracket: (f64, f64),
    /// Refinement iterates, starting with the secant guess (empty when `exact`).
    pub iterates: Vec<f64>,
}

/// One cell of a ray's walk, in full, for `isoview probe`.
#[derive(Clone, Debug, PartialEq)]
pub struct CellVisit {
    pub cell: [i32; 3],
    /// The samples the interpolant reads (not minus the isovalue): trilinear's 8 corners in
    /// corner order `v000, v100, ..., v111`; the tricubic interpolants' 64, `a + 4 b + 16 c`.
    pub samples: Vec<f64>,
    /// Ray parameters of the segment's ends.
    pub t_in: f64,
    pub t_out: f64,
    /// Cell-local ends of the segment.
    pub q_in: DVec3,
    pub q_out: DVec3,
    /// `g(u) = f - iso` on the segment.
    pub coefficients: Polynomial,
    /// Roots of `g'` strictly inside `(0, 1)` (trilinear; empty for the tricubic interpolants,
    /// whose pieces are [`CellVisit::leaves`]).
    pub derivative_roots: Vec<f64>,
    /// The points where the predicate was decided, with their values and predicates: segment
    /// ends and derivative roots (trilinear), or segment ends and leaf ends (tricubic).
    pub splits: Vec<SplitPoint>,
    /// The isolation's leaves in `u` order (tricubic; empty for trilinear).
    pub leaves: Vec<LeafTrace>,
    /// Crossings in this cell, in order (all of them refined, whichever the hit is).
    pub roots: Vec<RootTrace>,
    /// The cell is missing (a sample is NaN or infinite): no surface, nothing evaluated (the
    /// coefficients are NaN or empty, the lists empty).
    pub missing: bool,
}

/// A segment's polynomial `g(u) = f - iso`, `u` in `[0, 1]`.
#[derive(Clone, Debug, PartialEq)]
pub enum Polynomial {
    /// `[c0, c1, c2, c3]`, `g = c0 + c1 u + c2 u^2 + c3 u^3` (trilinear).
    Monomial([f64; 4]),
    /// Bernstein coefficients `b_0 ..= b_9` on `[0, 1]` (tricubic; `b_0` and `b_9` are the
    /// walk's face values).
    Bernstein(Vec<f64>),
}

impl Polynomial {
    /// The coefficients in their basis.
    pub fn coefficients(&self) -> &[f64] {
        match self {
            Polynomial::Monomial(c) => c,
            Polynomial::Bernstein(b) => b,
        }
    }

    /// The trilinear cubic's `[c0, c1, c2, c3]`; `None` for a Bernstein polynomial.
    pub fn monomial(&self) -> Option<[f64; 4]> {
        match self {
            Polynomial::Monomial(c) => Some(*c),
            Polynomial::Bernstein(_) => None,
        }
    }
}

/// One leaf of a tricubic segment's root isolation (`bernstein`'s walk).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafTrace {
    /// The leaf's interval of the segment, `[k 2^-l, (k + 1) 2^-l]`.
    pub u: (f64, f64),
    /// Sign variations of its coefficients.
    pub variations: u32,
    /// Whether Descartes' rule settled it (false: the depth or node cap did; a crossing there is
    /// counted when its ends differ, the near-tangency clause).
    pub resolved: bool,
}

/// Traces one ray: the requested crossing, the cell counts and the number of crossings.
/// `origin` and `dir` are world space; `dir` need not be normalised (`t` is in its units).
pub fn trace(
    grid: &Grid,
    isovalue: f64,
    inside: Inside,
    origin: DVec3,
    dir: DVec3,
    opts: &AnalyticOptions,
) -> AnalyticHit {
    walk::<Trilinear>(grid, isovalue, inside, origin, dir, opts, None)
}

/// [`trace`], plus every visited cell in full. The hit is identical to [`trace`]'s.
pub fn trace_detailed(
    grid: &Grid,
    isovalue: f64,
    inside: Inside,
    origin: DVec3,
    dir: DVec3,
    opts: &AnalyticOptions,
) -> (AnalyticHit, Vec<CellVisit>) {
    let mut visits = Vec::new();
    let hit = walk::<Trilinear>(grid, isovalue, inside, origin, dir, opts, Some(&mut visits));
    (hit, visits)
}

/// [`trace`] through the chosen interpolant: trilinear is [`trace`] itself, the tricubic
/// interpolants trace their exact surface by Bernstein isolation (`tricubic`). Used by tests
/// until `field.interpolation` can be chosen (PLAN26 C6).
pub fn trace_interpolated(
    field: &Interpolated,
    isovalue: f64,
    inside: Inside,
    origin: DVec3,
    dir: DVec3,
    opts: &AnalyticOptions,
) -> AnalyticHit {
    let grid = field.grid;
    match field.interp {
        Interpolant::Trilinear => {
            walk::<Trilinear>(grid, isovalue, inside, origin, dir, opts, None)
        }
        Interpolant::CubicBspline => {
            walk::<BSpline>(grid, isovalue, inside, origin, dir, opts, None)
        }
        Interpolant::CatmullRom => {
            walk::<CatmullRom>(grid, isovalue, inside, origin, dir, opts, None)
        }
        other => not_traced_here(other),
    }
}

/// [`trace_interpolated`], plus every visited cell in full.
pub fn trace_detailed_interpolated(
    field: &Interpolated,
    isovalue: f64,
    inside: Inside,
    origin: DVec3,
    dir: DVec3,
    opts: &AnalyticOptions,
) -> (AnalyticHit, Vec<CellVisit>) {
    let (grid, mut visits) = (field.grid, Vec::new());
    let v = Some(&mut visits);
    let hit = match field.interp {
        Interpolant::Trilinear => walk::<Trilinear>(grid, isovalue, inside, origin, dir, opts, v),
        Interpolant::CubicBspline => walk::<BSpline>(grid, isovalue, inside, origin, dir, opts, v),
        Interpolant::CatmullRom => walk::<CatmullRom>(grid, isovalue, inside, origin, dir, opts, v),
        other => not_traced_here(other),
    };
    (hit, visits)
}

/// Nearest's surface is traced by its voxel-face walk and device's not at all (fixed-step only);
/// no scene can send either here (`Caps::traced`).
#[cold]
fn not_traced_here(interp: Interpolant) -> ! {
    unreachable!("the analytic reference traces no {} field", interp.name())
}

/// The options a scene asks for (`render.newton_steps`, `render.crossing`).
pub fn options(scene: &Scene) -> AnalyticOptions {
    AnalyticOptions {
        newton_steps: scene.render.newton_steps,
        crossing: scene.render.crossing,
        clip: scene.clip.in_grid_frame(&scene.field.placement),
    }
}

/// The whole image, as the GPU's analytic pass produces it: `steps` is
/// [`AnalyticHit::cells_visited`], `crossings` is [`AnalyticHit::crossings`] with
/// `render.count_crossings` and -1 without (the GPU then stops at the hit). (With
/// `render.skip` on, the GPU's trilinear `steps` counts less work; every other channel is the
/// same.) Through the scene's `field.interpolation`: the tricubic ones by their Bernstein walk,
/// whose `steps` with `render.skip` are counted as `shaders/tricubic.comp` counts its brick
/// jumps ([`Skipping`]), nearest by its voxel walk (`reference::voxels::render`); `device` is
/// only sampled (scenes refuse it here).
pub fn render(scene: &Scene, grid: &Grid) -> Vec<Pixel> {
    let interp = scene.field.interpolation;
    if interp == Interpolant::Nearest {
        return crate::reference::voxels::render(scene, grid);
    }
    let (isos, inside, opts) = (scene.surface.isovalues(), scene.surface.inside, options(scene));
    let count = scene.render.count_crossings;
    let field = Interpolated::new(grid, interp);
    let skipping = Skipping::for_scene(scene, grid);
    render_with_interp(scene, grid, interp, |o, d| {
        nearest_surface(
            isos.iter()
                .map(|&iso| trace_one(&field, iso, inside, o, d, &opts, count, skipping.as_ref())),
        )
    })
}

/// One surface's (hit, steps, crossings) for [`render`]: steps are the cells visited, or with
/// `skipping` those counted as the GPU's brick jumps count them.
#[allow(clippy::too_many_arguments)]
fn trace_one(
    field: &Interpolated,
    iso: f64,
    inside: Inside,
    o: DVec3,
    d: DVec3,
    opts: &AnalyticOptions,
    count_crossings: bool,
    skipping: Option<&Skipping>,
) -> (Option<RayHit>, u32, i32) {
    {
        let (a, steps) = match skipping {
            None => {
                let a = trace_interpolated(field, iso, inside, o, d, opts);
                (a, a.cells_visited)
            }
            Some(s) => {
                let (a, visits) = trace_detailed_interpolated(field, iso, inside, o, d, opts);
                let counted = visits.iter().take(a.cells_visited as usize);
                let cells = counted.map(|v| (v.cell.map(|c| c as usize), v.t_in, v.t_out));
                (a, s.steps(field.grid, o, d, &opts.clip, cells))
            }
        };
        let hit = a.hit.map(|h| RayHit {
            t: h.t,
            position: h.position,
            normal: h.normal,
            grid_coords: DVec3::new(h.cell[0] as f64, h.cell[1] as f64, h.cell[2] as f64) + h.local,
            cell: h.cell.map(|c| c as usize),
            surface: 0,
        });
        let crossings = if count_crossings { a.crossings as i32 } else { -1 };
        (hit, steps, crossings)
    }
}

/// Ray parameter of segment parameter `u`: `t_in + u (t_out - t_in)`, at most `t_out`, and
/// exactly `t_out` at `u = 1`. Monotone in `u`, so crossings stay in order across cells.
#[inline]
fn segment_t(t_in: f64, t_out: f64, u: f64) -> f64 {
    if u >= 1.0 {
        t_out
    } else {
        (t_in + u * (t_out - t_in)).min(t_out)
    }
}

/// One interpolant's part of the walk in one cell (steps 4, 6.2–6.5 and 7): gather its
/// samples, evaluate, and cut a segment into pieces on which the predicate changes at most once
/// (up to the near-tangency clause). Trilinear's pieces are the cubic's monotone pieces between
/// derivative roots (the code this walk always had, moved); the tricubic interpolants' are the
/// leaves of the Bernstein isolation (`tricubic`).
pub(crate) trait RayCell {
    /// The cell's samples.
    type Cell;
    /// A segment's polynomial, ready to be cut.
    type Segment;
    /// What a piece needs to be refined, beyond its ends.
    type Local: Copy;
    fn gather(grid: &Grid, cell: [usize; 3]) -> Self::Cell;
    fn missing(c: &Self::Cell) -> bool;
    /// `f` at cell-local `q`, exact at faces (the same bits from both cells).
    fn value(c: &Self::Cell, q: DVec3) -> f64;
    /// The index-space gradient at cell-local `q`.
    fn gradient(c: &Self::Cell, q: DVec3) -> DVec3;
    /// `g = f - iso` on the segment `q_in -> q_out`, with the walk's face values `g_in`, `g_out`
    /// as its values at `u = 0` and `u = 1`.
    fn segment(
        c: &Self::Cell,
        q_in: DVec3,
        q_out: DVec3,
        iso: f64,
        g_ends: (f64, f64),
        inside: Inside,
    ) -> Self::Segment;
    /// The pieces in `u` order; consecutive pieces share their end point, the first starts at
    /// `(0, g_in)` and the last ends at `(1, g_out)`.
    fn pieces(seg: &Self::Segment, inside: Inside) -> impl Iterator<Item = Piece<Self::Local>>;
    /// The root of a piece whose end predicates differ and whose ends are nonzero.
    fn refine(
        seg: &Self::Segment,
        piece: &Piece<Self::Local>,
        inside: Inside,
        steps: u32,
        iterates: Option<&mut Vec<f64>>,
    ) -> f64;
    /// For the detailed trace: the samples, the polynomial and the derivative roots.
    fn describe(c: &Self::Cell, seg: Option<&Self::Segment>) -> (Vec<f64>, Polynomial, Vec<f64>);
}

/// A piece `[a.u, b.u]` of a segment.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Piece<L> {
    pub a: SplitPoint,
    pub b: SplitPoint,
    pub local: L,
    pub leaf: Option<LeafTrace>,
}

/// Trilinear's segment: the cubic, its derivative roots in `(0, 1)` and the split points
/// `0, roots..., 1` (steps 6.3–6.4).
pub(crate) struct MonotonePieces {
    cubic: Cubic,
    droots: [f64; 2],
    /// How many of `droots` there are; `splits[..count + 2]` are the split points.
    count: usize,
    splits: [SplitPoint; 4],
}

/// Trilinear: the cubic and its monotone pieces (module doc, steps 6.3–6.5).
impl RayCell for Trilinear {
    type Cell = [f64; 8];
    type Segment = MonotonePieces;
    type Local = ();

    fn gather(grid: &Grid, cell: [usize; 3]) -> [f64; 8] {
        cell_corners(grid, cell)
    }

    fn missing(c: &[f64; 8]) -> bool {
        cell_missing(c)
    }

    fn value(c: &[f64; 8], q: DVec3) -> f64 {
        trilerp(c, q)
    }

    fn gradient(c: &[f64; 8], q: DVec3) -> DVec3 {
        <Trilinear as Kernel>::gradient(c, q)
    }

    fn segment(
        c: &[f64; 8],
        q_in: DVec3,
        q_out: DVec3,
        _iso: f64,
        (g_in, g_out): (f64, f64),
        inside: Inside,
    ) -> Self::Segment {
        // 6.3 Cubic; 6.4 split points.
        let cubic = Cubic::along_segment(c, q_in, q_out, g_in);
        let (droots, nd) = cubic.derivative_roots();
        let mut splits = [SplitPoint { u: 0.0, g: g_in, inside: inside_g(inside, g_in) }; 4];
        for (s, &r) in droots[..nd].iter().enumerate() {
            let g = cubic.eval(r);
            splits[s + 1] = SplitPoint { u: r, g, inside: inside_g(inside, g) };
        }
        splits[nd + 1] = SplitPoint { u: 1.0, g: g_out, inside: inside_g(inside, g_out) };
        MonotonePieces { cubic, droots, count: nd, splits }
    }

    fn pieces(seg: &Self::Segment, _inside: Inside) -> impl Iterator<Item = Piece<()>> {
        let splits = seg.splits;
        (0..=seg.count).map(move |s| Piece {
            a: splits[s],
            b: splits[s + 1],
            local: (),
            leaf: None,
        })
    }

    fn refine(
        seg: &Self::Segment,
        piece: &Piece<()>,
        inside: Inside,
        steps: u32,
        iterates: Option<&mut Vec<f64>>,
    ) -> f64 {
        let (a, b) = (piece.a, piece.b);
        refine(&seg.cubic, inside, (a.u, b.u), (a.g, b.g), steps, iterates)
    }

    fn describe(c: &[f64; 8], seg: Option<&Self::Segment>) -> (Vec<f64>, Polynomial, Vec<f64>) {
        match seg {
            Some(seg) => {
                (c.to_vec(), Polynomial::Monomial(seg.cubic.c), seg.droots[..seg.count].to_vec())
            }
            None => (c.to_vec(), Polynomial::Monomial([f64::NAN; 4]), Vec::new()),
        }
    }
}

/// Steps 1-3 of a walk (the module doc's; `reference::voxels` takes the same): the ray in
/// index space, its span inside the box and the clip planes, and its entry point.
pub(crate) struct Span {
    /// Origin and direction in index space.
    pub o: DVec3,
    pub d: DVec3,
    /// Cells per axis.
    pub n: DVec3,
    /// The grid's spacing.
    pub h: DVec3,
    /// `[t_lo, t_hi]`, `t_lo >= 0`.
    pub t_lo: f64,
    pub t_hi: f64,
    /// The entry point at `t_lo`, on the entry face when the ray enters through it, in `[0, n]`.
    pub p: DVec3,
}

/// [`Span`] of the ray `origin + t dir`; None when it has none (it misses the box, the clip
/// planes remove it, or it cannot be walked).
pub(crate) fn span(grid: &Grid, origin: DVec3, dir: DVec3, clip: &Clip) -> Option<Span> {
    // 1. Index space.
    let cells = grid.cells();
    let n = DVec3::new(cells[0] as f64, cells[1] as f64, cells[2] as f64);
    let h = grid.spacing();
    let usable = h.is_finite()
        && h.min_element() > 0.0
        && origin.is_finite()
        && dir.is_finite()
        && dir != DVec3::ZERO;
    if !usable {
        return None;
    }
    let o = (origin - grid.min) / h;
    let d = dir / h;

    // 2. Slab clip.
    let mut t_enter = f64::NEG_INFINITY;
    let mut t_exit = f64::INFINITY;
    let mut enter_axis = None;
    for a in 0..3 {
        if d[a] == 0.0 {
            if !(o[a] >= 0.0 && o[a] <= n[a]) {
                return None;
            }
            continue;
        }
        let t0 = (0.0 - o[a]) / d[a];
        let t1 = (n[a] - o[a]) / d[a];
        let (near, far) = if d[a] > 0.0 { (t0, t1) } else { (t1, t0) };
        if near > t_enter {
            t_enter = near;
            enter_axis = Some(a);
        }
        if far < t_exit {
            t_exit = far;
        }
    }
    // 2b. Clip planes: a later entry enters through a plane, not a box face.
    let (c_lo, c_hi) = clip.interval(origin, dir)?;
    if c_lo > t_enter {
        t_enter = c_lo;
        enter_axis = None;
    }
    t_exit = t_exit.min(c_hi);
    if !(t_enter <= t_exit && t_exit > 0.0 && t_exit < f64::INFINITY) {
        return None;
    }
    let t_lo = t_enter.max(0.0);
    let t_hi = t_exit;

    // 3. Entry point.
    let mut p = o + d * t_lo;
    if t_lo == t_enter {
        if let Some(a) = enter_axis {
            p[a] = if d[a] > 0.0 { 0.0 } else { n[a] };
        }
    }
    Some(Span { o, d, n, h, t_lo, t_hi, p: p.clamp(DVec3::ZERO, n) })
}

/// The whole per-ray algorithm (numbered as in the module doc).
fn walk<K: RayCell>(
    grid: &Grid,
    iso: f64,
    inside: Inside,
    origin: DVec3,
    dir: DVec3,
    opts: &AnalyticOptions,
    mut trace: Option<&mut Vec<CellVisit>>,
) -> AnalyticHit {
    let mut result = AnalyticHit::default();
    let wanted = opts.crossing.max(1);

    // 1.-3. Index space, the span, the entry point.
    let Some(Span { o, d, n, h, t_lo, t_hi, p }) = span(grid, origin, dir, &opts.clip) else {
        return result;
    };
    let cells = grid.cells();
    result.span = Some((t_lo, t_hi));

    // 4. First cell.
    let mut cell = [0i64; 3];
    let mut q_in = DVec3::ZERO;
    for a in 0..3 {
        let c = if d[a] < 0.0 { p[a].ceil() - 1.0 } else { p[a].floor() };
        let c = c.clamp(0.0, n[a] - 1.0);
        cell[a] = c as i64;
        q_in[a] = (p[a] - c).clamp(0.0, 1.0);
    }
    let mut corners = K::gather(grid, cell.map(|c| c as usize));
    let mut g_in = K::value(&corners, q_in) - iso;
    result.inside_at_start = inside_g(inside, g_in);

    // 5. Next planes.
    let tmax_of = |a: usize, c: i64| -> f64 {
        if d[a] > 0.0 {
            ((c + 1) as f64 - o[a]) / d[a]
        } else if d[a] < 0.0 {
            (c as f64 - o[a]) / d[a]
        } else {
            f64::INFINITY
        }
    };
    let mut tmax = DVec3::new(tmax_of(0, cell[0]), tmax_of(1, cell[1]), tmax_of(2, cell[2]));
    let mut t_in = t_lo;

    // 6. Loop.
    let max_passes = cells[0] + cells[1] + cells[2];
    for _ in 0..max_passes {
        result.cells_total += 1;
        let missing = K::missing(&corners);

        // 6.1 Segment end.
        let t_out = tmax.min_element().min(t_hi).max(t_in);
        let last = t_out >= t_hi;
        let crossed = [tmax.x <= t_out, tmax.y <= t_out, tmax.z <= t_out];

        // 6.2 Exit point and value.
        let mut q_out = DVec3::ZERO;
        for a in 0..3 {
            q_out[a] = if crossed[a] {
                if d[a] > 0.0 {
                    1.0
                } else {
                    0.0
                }
            } else if t_out == t_in {
                q_in[a]
            } else {
                (o[a] + t_out * d[a] - cell[a] as f64).clamp(0.0, 1.0)
            };
        }
        let g_out = if t_out == t_in { g_in } else { K::value(&corners, q_out) - iso };

        // A missing cell holds no crossing (see the module doc).
        if missing {
            if let Some(list) = trace.as_deref_mut() {
                let (samples, coefficients, _) = K::describe(&corners, None);
                list.push(CellVisit {
                    cell: cell.map(|c| c as i32),
                    samples,
                    t_in,
                    t_out,
                    q_in,
                    q_out,
                    coefficients,
                    derivative_roots: Vec::new(),
                    splits: Vec::new(),
                    leaves: Vec::new(),
                    roots: Vec::new(),
                    missing: true,
                });
            }
        } else {
            // 6.3 The segment's polynomial; 6.4 its pieces.
            let seg = K::segment(&corners, q_in, q_out, iso, (g_in, g_out), inside);

            let mut visit = trace.as_ref().map(|_| {
                let (samples, coefficients, derivative_roots) = K::describe(&corners, Some(&seg));
                CellVisit {
                    cell: cell.map(|c| c as i32),
                    samples,
                    t_in,
                    t_out,
                    q_in,
                    q_out,
                    coefficients,
                    derivative_roots,
                    splits: Vec::new(),
                    leaves: Vec::new(),
                    roots: Vec::new(),
                    missing: false,
                }
            });

            // 6.5 Crossings, piece by piece.
            for piece in K::pieces(&seg, inside) {
                let (a, b) = (piece.a, piece.b);
                if let Some(v) = visit.as_mut() {
                    if v.splits.is_empty() {
                        v.splits.push(a);
                    }
                    v.splits.push(b);
                    v.leaves.extend(piece.leaf);
                }
                if a.inside == b.inside {
                    continue;
                }
                let exact = if a.g == 0.0 {
                    Some(a.u)
                } else if b.g == 0.0 {
                    Some(b.u)
                } else {
                    None
                };
                let dropped = exact.is_some_and(|u| segment_t(t_in, t_out, u) <= 0.0);
                let number = if dropped {
                    0
                } else {
                    result.crossings += 1;
                    result.crossings
                };
                let is_hit = number == wanted;
                if !is_hit && visit.is_none() {
                    continue;
                }
                let mut iterates = Vec::new();
                let u = match exact {
                    Some(u) => u,
                    None => K::refine(
                        &seg,
                        &piece,
                        inside,
                        opts.newton_steps,
                        visit.as_ref().map(|_| &mut iterates),
                    ),
                };
                let t = segment_t(t_in, t_out, u);
                if is_hit {
                    let q = lerp3(q_in, q_out, u);
                    let grad = K::gradient(&corners, q) / h;
                    let oriented = match inside {
                        Inside::Below => grad,
                        Inside::Above => -grad,
                    };
                    let len = oriented.length();
                    let normal = if len > 0.0 && len.is_finite() {
                        oriented / len
                    } else {
                        -dir.normalize()
                    };
                    result.hit = Some(Hit {
                        t,
                        position: origin + dir * t,
                        normal,
                        cell: cell.map(|c| c as i32),
                        local: q,
                        entering: b.inside,
                        crossing: number,
                    });
                    result.cells_visited = result.cells_total;
                }
                if let Some(v) = visit.as_mut() {
                    v.roots.push(RootTrace {
                        crossing: number,
                        u,
                        t,
                        entering: b.inside,
                        exact: exact.is_some(),
                        bracket: (a.u, b.u),
                        iterates,
                    });
                }
            }
            if let (Some(list), Some(v)) = (trace.as_deref_mut(), visit) {
                list.push(v);
            }
        }

        // 6.6 Advance.
        if last {
            break;
        }
        let mut left_box = false;
        for a in 0..3 {
            if crossed[a] {
                let step = if d[a] > 0.0 { 1 } else { -1 };
                cell[a] += step;
                left_box |= cell[a] < 0 || cell[a] as f64 > n[a] - 1.0;
                q_in[a] = 1.0 - q_out[a];
                tmax[a] = tmax_of(a, cell[a]);
            } else {
                q_in[a] = q_out[a];
            }
        }
        if left_box {
            break;
        }
        corners = K::gather(grid, cell.map(|c| c as usize));
        // After a missing cell, from the new cell's own corners (its g_out is not a value).
        g_in = if missing { K::value(&corners, q_in) - iso } else { g_out };
        t_in = t_out;
    }
    if result.hit.is_none() {
        result.cells_visited = result.cells_total;
    }
    result
}
