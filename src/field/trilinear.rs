//! The trilinear interpolant, the one CPU implementation (f64): the corners source, the CPU
//! references (`reference::trilinear` re-exports these), the slices and the mesh tests all
//! evaluate it here.
//!
//! [`trilerp`] interpolates along x, then y, then z, with [`lerp`]`(a, b, w) = (1 - w) a + w b`
//! (GLSL's `mix`), which returns `a` and `b` bit for bit at `w = 0` and `w = 1`: a cell's corners
//! are reproduced exactly, and two cells sharing a face give bitwise identical values at a point
//! of that face (see `reference::trilinear`, "Face exactness").
//!
//! Corner order: `[v000, v100, v010, v110, v001, v101, v011, v111]` (vXYZ is the corner at
//! x+X, y+Y, z+Z), as `Grid::corners` returns them.

use glam::DVec3;

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

/// `(1 - w) a + w b`: exact at `w = 0` (gives `a`) and `w = 1` (gives `b`).
#[inline]
pub fn lerp(a: f64, b: f64, w: f64) -> f64 {
    (1.0 - w) * a + w * b
}

/// Value of the trilinear interpolant of corners `c` at cell-local `q` in `[0, 1]^3` (x first,
/// then y, then z).
#[inline]
pub fn trilerp(c: &[f64; 8], q: DVec3) -> f64 {
    let x00 = lerp(c[0], c[1], q.x);
    let x10 = lerp(c[2], c[3], q.x);
    let x01 = lerp(c[4], c[5], q.x);
    let x11 = lerp(c[6], c[7], q.x);
    let y0 = lerp(x00, x10, q.y);
    let y1 = lerp(x01, x11, q.y);
    lerp(y0, y1, q.z)
}
