//! The trilinear interpolant, the one CPU implementation (f64): the corners source, the CPU
//! references (`reference::trilinear` re-exports these), the slices and the extractors' normals
//! all evaluate it here.
//!
//! [`trilerp`] interpolates along x, then y, then z, with [`lerp`]`(a, b, w) = (1 - w) a + w b`
//! (GLSL's `mix`), which returns `a` and `b` bit for bit at `w = 0` and `w = 1`: a cell's corners
//! are reproduced exactly, and two cells sharing a face give bitwise identical values at a point
//! of that face (see `reference::trilinear`, "Face exactness").
//!
//! Corner order: `[v000, v100, v010, v110, v001, v101, v011, v111]` (vXYZ is the corner at
//! x+X, y+Y, z+Z), as `Grid::corners` returns them.

use glam::DVec3;

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

/// Gradient (index space, value per cell) of the trilinear interpolant of corner values `v` at
/// cell-local `(x, y, z)` in `[0, 1]³`, as a sum of products: the mesh normals (`mesh::field`)
/// and the GPU extraction's `cell_gradient` (`shaders/extract/common.glsl`) depend on these
/// exact bits. (`reference::trilinear::gradient` is the same derivative as a bilerp of edge
/// differences: equal in exact arithmetic, not bit for bit.)
#[inline]
pub fn gradient(v: &[f64; 8], x: f64, y: f64, z: f64) -> DVec3 {
    let (mx, my, mz) = (1.0 - x, 1.0 - y, 1.0 - z);
    DVec3::new(
        my * mz * (v[1] - v[0])
            + y * mz * (v[3] - v[2])
            + my * z * (v[5] - v[4])
            + y * z * (v[7] - v[6]),
        mx * mz * (v[2] - v[0])
            + x * mz * (v[3] - v[1])
            + mx * z * (v[6] - v[4])
            + x * z * (v[7] - v[5]),
        mx * my * (v[4] - v[0])
            + x * my * (v[5] - v[1])
            + mx * y * (v[6] - v[2])
            + x * y * (v[7] - v[3]),
    )
}
