//! The interpolant: how the field is evaluated between its samples, one home per side (Rust
//! here; GLSL: `shaders/include/interpolant.glsl` once the shaders are moved onto it). Only the
//! trilinear interpolant exists today ([`trilinear`]); docs/contributing.md says what adding one
//! touches.
//!
//! The missing-data rule below does not depend on the interpolant: a cell is missing when the
//! samples its interpolant reads (its stencil: the trilinear interpolant's 8 corners) hold one.

pub mod trilinear;

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
