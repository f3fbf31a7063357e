//! Exact ray tracing of the nearest-point interpolant's surface, in `f64`: the CPU reference,
//! and the definition, of `render.method = "analytic"` with `interpolation = "nearest"` (GPU:
//! `shaders/voxels.comp`, step for step).
//!
//! # What is a hit
//!
//! The field is constant on each point's voxel: in index space the voxel of point `i` spans
//! `[i - ½, i + ½] ∩ [0, n - 1]` per axis, the planes `i + ½` (for `i` in `0..n - 1`) are
//! shared by two voxels, rounding half up ([`voxel_of`]): the last plane of the box belongs to
//! the last point. The inside predicate is the one every method follows
//! (`Inside::contains`: equal to the isovalue is outside). A *crossing* is a change of the
//! predicate between two consecutive voxels along the ray, **both finite**: a missing voxel
//! (`field.nan = "empty"`, [`is_missing`]) has no inside state, so no face borders it, as in
//! fixed-step. Box faces are not surface, and neither is a clip plane. The hit is the first
//! crossing with `t > 0` (or the k-th, [`AnalyticOptions::crossing`]), at the `t` of the face
//! plane, exactly: no root to refine.
//!
//! # Per-ray algorithm (port this to GLSL as written)
//!
//! 1. **Index space** and 2. **slab clip** (with the clip planes), exactly as the trilinear
//!    walk's steps 1–2 (`reference::analytic`): `o`, `d`, `N = dims - 1`, `[t_lo, t_hi]`.
//! 3. **Entry point** `p = o + t_lo d`, the entry axis snapped to `0` or `N`, clamped to
//!    `[0, N]` (analytic step 3).
//! 4. **First voxel**, per axis: the nearest kernel's choice, `c = clamp(floor(p), 0, N - 1)`
//!    and `c + (p - c >= ½)`, except exactly on a plane (`p - c == ½`) with `d < 0`, where the
//!    ray heads into voxel `c`.
//! 5. **Next planes.** `tmax[a] = (v[a] + ½ - o[a]) / d[a]` if `d[a] > 0` and `v[a] < N[a]`,
//!    `(v[a] - ½ - o[a]) / d[a]` if `d[a] < 0` and `v[a] > 0`, else `+inf` (no face beyond the
//!    first and last points). From the plane index, never accumulated.
//! 6. **Loop**, at most `Nx + Ny + Nz + 1` voxels:
//!    1. Read the voxel's sample `s`; its state is `inside(s)`, none when missing.
//!    2. If the ray stepped into this voxel and the previous voxel's state and this one's are
//!       both known and differ, that is a crossing at `t_in`, on the face of the axis stepped
//!       (the lowest, when several axes stepped together). A crossing at `t_in <= 0` (the eye
//!       on a face, through a zero-length first visit) is dropped; otherwise count it, and the
//!       k-th is the hit (a shader stops here).
//!    3. `t_out = max(min(tmax, t_hi), t_in)`; stop if `t_out >= t_hi` (a face exactly at
//!       `t_hi` is not crossed: the voxel beyond is not on the span). Else step every axis with
//!       `tmax[a] <= t_out` (ties step together: a ray through an edge goes diagonally),
//!       recompute their `tmax`, `t_in = t_out`.
//! 7. **Hit attributes.** `t` = the face's `t`; position `origin + t dir`; normal `±e_a` of the
//!    face's axis, pointing from the inside voxel to the outside one; `cell.*` the inside
//!    voxel's point; grid coordinates `o + t d` with each stepped axis exactly on its plane.
//!    `steps` = voxels visited up to and including the one entered at the hit (all of them on a
//!    miss); with `render.skip`, counted as the GPU's brick jumps count them
//!    (`reference::skipping`: a run of voxels in a brick it jumps over counts one).
//!
//! Near-ties: a ray within rounding of a voxel edge may step its axes one after the other with
//! a zero-length visit between them (a diagonal neighbour seen for no length), and a start
//! point within rounding of a plane may start in the neighbouring voxel; both change at most
//! crossings a rounding error apart.

use glam::DVec3;

use crate::field::interpolant::is_missing;
use crate::field::interpolant::nearest::voxel_of;
use crate::field::interpolant::Interpolant;
use crate::field::Grid;
use crate::frame::Pixel;
use crate::reference::analytic::{options, span, AnalyticOptions, Span};
use crate::reference::shade::{nearest_surface, render_with_interp, RayHit};
use crate::reference::skipping::Skipping;
use crate::scene::{Inside, Scene};

/// A ray's hit on a voxel face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceHit {
    /// Ray parameter of the face plane (distance when `dir` is a unit vector).
    pub t: f64,
    /// World-space position, `origin + t dir`.
    pub position: DVec3,
    /// `±e_a`: from the inside voxel to the outside one.
    pub normal: DVec3,
    /// The face's axis (the lowest of those stepped together).
    pub axis: usize,
    /// Grid coordinates of the hit, on the face's plane.
    pub grid_coords: DVec3,
    /// The point of the inside voxel.
    pub voxel: [usize; 3],
    /// True when the ray goes from outside to inside here.
    pub entering: bool,
    /// Which crossing this is along the ray (1 = first).
    pub crossing: u32,
}

/// Everything a ray found.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VoxelTrace {
    /// The requested crossing, if the ray has that many.
    pub hit: Option<FaceHit>,
    /// `[t_lo, t_hi]`; `None` when the ray misses the box.
    pub span: Option<(f64, f64)>,
    /// Whether the first voxel is inside (false when it is missing or the ray misses).
    pub inside_at_start: bool,
    /// Voxels walked up to and including the one entered at the hit; all on a miss.
    pub voxels_visited: u32,
    /// Voxels walked over the whole span.
    pub voxels_total: u32,
    /// Crossings with `t > 0` over the whole span.
    pub crossings: u32,
}

/// One voxel of a ray's walk, for `isoview probe`.
#[derive(Clone, Debug, PartialEq)]
pub struct VoxelVisit {
    /// The voxel's point.
    pub voxel: [usize; 3],
    /// Its sample.
    pub value: f64,
    /// Its inside state; `None` when missing.
    pub inside: Option<bool>,
    /// Ray parameters where the ray enters and leaves it.
    pub t_in: f64,
    pub t_out: f64,
}

/// Traces one ray through the voxels. `origin` and `dir` are world space; `dir` need not be
/// normalised (`t` is in its units). `opts.newton_steps` is not used: faces are exact.
pub fn trace(
    grid: &Grid,
    isovalue: f64,
    inside: Inside,
    origin: DVec3,
    dir: DVec3,
    opts: &AnalyticOptions,
) -> VoxelTrace {
    walk(grid, isovalue, inside, origin, dir, opts, None)
}

/// [`trace`], plus every visited voxel. The hit is identical to [`trace`]'s.
pub fn trace_detailed(
    grid: &Grid,
    isovalue: f64,
    inside: Inside,
    origin: DVec3,
    dir: DVec3,
    opts: &AnalyticOptions,
) -> (VoxelTrace, Vec<VoxelVisit>) {
    let mut visits = Vec::new();
    let hit = walk(grid, isovalue, inside, origin, dir, opts, Some(&mut visits));
    (hit, visits)
}

/// The whole image of the nearest interpolant's surface, as the GPU's voxel pass produces it:
/// `steps` is [`VoxelTrace::voxels_visited`] (with `render.skip`, those counted as the GPU's
/// jumps count them: [`Skipping`]), `crossings` [`VoxelTrace::crossings`] with
/// `render.count_crossings` and -1 without.
pub fn render(scene: &Scene, grid: &Grid) -> Vec<Pixel> {
    let (isos, inside, opts) = (scene.surface.isovalues(), scene.surface.inside, options(scene));
    let count = scene.render.count_crossings;
    let skipping = Skipping::for_scene(scene, grid);
    render_with_interp(scene, grid, Interpolant::Nearest, |o, d| {
        nearest_surface(isos.iter().map(|&iso| {
            let (v, steps) = match &skipping {
                None => {
                    let v = trace(grid, iso, inside, o, d, &opts);
                    (v, v.voxels_visited)
                }
                Some(s) => {
                    let (v, visits) = trace_detailed(grid, iso, inside, o, d, &opts);
                    let counted = visits.iter().take(v.voxels_visited as usize);
                    (
                        v,
                        s.steps(
                            grid,
                            o,
                            d,
                            &opts.clip,
                            counted.map(|x| (x.voxel, x.t_in, x.t_out)),
                        ),
                    )
                }
            };
            let hit = v.hit.map(|h| RayHit {
                t: h.t,
                position: h.position,
                normal: h.normal,
                grid_coords: h.grid_coords,
                cell: h.voxel,
                surface: 0,
            });
            (hit, steps, if count { v.crossings as i32 } else { -1 })
        }))
    })
}

/// The whole per-ray algorithm (numbered as in the module doc).
fn walk(
    grid: &Grid,
    iso: f64,
    inside: Inside,
    origin: DVec3,
    dir: DVec3,
    opts: &AnalyticOptions,
    mut trace: Option<&mut Vec<VoxelVisit>>,
) -> VoxelTrace {
    let mut result = VoxelTrace::default();
    let wanted = opts.crossing.max(1);

    // 1.-3. Index space, the span, the entry point (the trilinear walk's own steps).
    let Some(Span { o, d, n, t_lo, t_hi, p, .. }) = span(grid, origin, dir, &opts.clip) else {
        return result;
    };
    let cells = grid.cells();
    result.span = Some((t_lo, t_hi));

    // 4. First voxel: the kernel's, or on a plane the one the ray heads into.
    let mut voxel = voxel_of(grid, p).map(|v| v as i64);
    for a in 0..3 {
        let c = p[a].floor().clamp(0.0, n[a] - 1.0);
        if d[a] < 0.0 && p[a] - c == 0.5 {
            voxel[a] = c as i64;
        }
    }

    // 5. Next planes.
    let tmax_of = |a: usize, v: i64| -> f64 {
        if d[a] > 0.0 && (v as f64) < n[a] {
            (v as f64 + 0.5 - o[a]) / d[a]
        } else if d[a] < 0.0 && v > 0 {
            (v as f64 - 0.5 - o[a]) / d[a]
        } else {
            f64::INFINITY
        }
    };
    let mut tmax = DVec3::new(tmax_of(0, voxel[0]), tmax_of(1, voxel[1]), tmax_of(2, voxel[2]));

    // 6. Loop.
    let mut t_in = t_lo;
    // The previous voxel, its state, and the axes stepped from it to this one.
    let mut previous: Option<([i64; 3], Option<bool>)> = None;
    let mut stepped = [false; 3];
    let max_passes = cells[0] + cells[1] + cells[2] + 1;
    for _ in 0..max_passes {
        result.voxels_total += 1;
        // 6.1 The voxel's state.
        let at = voxel.map(|v| v as usize);
        let value = f64::from(grid.at(at[0], at[1], at[2]));
        let state = (!is_missing(value)).then(|| inside.contains(value, iso));
        if previous.is_none() {
            result.inside_at_start = state == Some(true);
        }

        // 6.2 A crossing on the face just passed.
        if let Some((before, Some(was))) = previous {
            if let Some(is) = state.filter(|&is| is != was) {
                if t_in > 0.0 {
                    result.crossings += 1;
                    if result.crossings == wanted {
                        result.hit = Some(face_hit(
                            origin, dir, o, d, n, t_in, before, voxel, stepped, is, wanted,
                        ));
                        result.voxels_visited = result.voxels_total;
                    }
                }
            }
        }

        // 6.3 Leave the voxel.
        let t_out = tmax.min_element().min(t_hi).max(t_in);
        if let Some(list) = trace.as_deref_mut() {
            list.push(VoxelVisit { voxel: at, value, inside: state, t_in, t_out });
        }
        if t_out >= t_hi {
            break;
        }
        previous = Some((voxel, state));
        for a in 0..3 {
            stepped[a] = tmax[a] <= t_out;
            if stepped[a] {
                voxel[a] += if d[a] > 0.0 { 1 } else { -1 };
                tmax[a] = tmax_of(a, voxel[a]);
            }
        }
        t_in = t_out;
    }
    if result.hit.is_none() {
        result.voxels_visited = result.voxels_total;
    }
    result
}

/// Step 7: the hit on the face between voxels `before` and `after` (the ray stepped along the
/// axes `stepped`), `after` inside when `entering`.
#[allow(clippy::too_many_arguments)]
fn face_hit(
    origin: DVec3,
    dir: DVec3,
    o: DVec3,
    d: DVec3,
    n: DVec3,
    t: f64,
    before: [i64; 3],
    after: [i64; 3],
    stepped: [bool; 3],
    entering: bool,
    crossing: u32,
) -> FaceHit {
    let axis = (0..3).find(|&a| stepped[a]).unwrap_or(0);
    let (vin, vout) = if entering { (after, before) } else { (before, after) };
    let mut normal = DVec3::ZERO;
    normal[axis] = if vout[axis] > vin[axis] { 1.0 } else { -1.0 };
    let mut grid_coords = (o + d * t).clamp(DVec3::ZERO, n);
    for a in 0..3 {
        if stepped[a] {
            grid_coords[a] = before[a].min(after[a]) as f64 + 0.5;
        }
    }
    FaceHit {
        t,
        position: origin + dir * t,
        normal,
        axis,
        grid_coords,
        voxel: vin.map(|v| v as usize),
        entering,
        crossing,
    }
}

#[cfg(test)]
mod tests;
