use glam::DVec3;

/// Samples of a scalar field at the points of a regular grid.
///
/// Point `(i, j, k)` sits at `min + (i, j, k) * (max - min) / (dims - 1)` in world space, and
/// its value is `values[i + nx * (j + ny * k)]` (x varies fastest). Values are `f32` because
/// that is what the GPU sees; CPU references widen the same values to `f64`, so both interpolate
/// identical data.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// Points along x, y, z (each at least 2).
    pub dims: [usize; 3],
    /// World-space corner of point (0, 0, 0).
    pub min: DVec3,
    /// World-space corner of point (nx-1, ny-1, nz-1).
    pub max: DVec3,
    /// `nx * ny * nz` samples, x fastest.
    pub values: Vec<f32>,
}

impl Grid {
    /// Number of cells along each axis (`dims - 1`).
    pub fn cells(&self) -> [usize; 3] {
        [self.dims[0] - 1, self.dims[1] - 1, self.dims[2] - 1]
    }

    /// World-space size of one cell along each axis.
    pub fn spacing(&self) -> DVec3 {
        let c = self.cells();
        (self.max - self.min) / DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64)
    }

    /// Linear index of point (i, j, k).
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// Value at point (i, j, k).
    pub fn at(&self, i: usize, j: usize, k: usize) -> f32 {
        self.values[self.index(i, j, k)]
    }

    /// World-space position of point (i, j, k).
    pub fn point(&self, i: usize, j: usize, k: usize) -> DVec3 {
        self.min + self.spacing() * DVec3::new(i as f64, j as f64, k as f64)
    }

    /// The 8 corner values of cell (i, j, k), ordered `v000, v100, v010, v110, v001, v101, v011,
    /// v111` (vXYZ: corner at x+X, y+Y, z+Z), the order of `source = "corners"`.
    pub fn corners(&self, i: usize, j: usize, k: usize) -> [f32; 8] {
        let mut out = [0.0; 8];
        for (n, v) in out.iter_mut().enumerate() {
            *v = self.at(i + (n & 1), j + ((n >> 1) & 1), k + ((n >> 2) & 1));
        }
        out
    }

    /// Smallest and largest sample, of those that are not missing data (NaN or ±inf:
    /// [`super::interpolant::is_missing`]); `(inf, -inf)` when none is.
    pub fn range(&self) -> (f32, f32) {
        let mut mm = [f32::INFINITY, f32::NEG_INFINITY];
        for &v in &self.values {
            crate::field::interpolant::widen(&mut mm, v);
        }
        (mm[0], mm[1])
    }

    /// Position `pos` (the grid's frame) → continuous grid coordinates, clamped into the box
    /// (as `shaders/include/field.glsl` addresses the grid).
    pub fn to_grid(&self, pos: DVec3) -> DVec3 {
        let [nx, ny, nz] = self.dims.map(|d| (d - 1) as f64);
        ((pos - self.min) / self.spacing()).clamp(DVec3::ZERO, DVec3::new(nx, ny, nz))
    }

    /// The cell holding grid coordinates `u` (the last grid plane belongs to the last cell).
    pub fn cell_of(&self, u: DVec3) -> [usize; 3] {
        let c = self.cells();
        [
            (u.x.floor().max(0.0) as usize).min(c[0] - 1),
            (u.y.floor().max(0.0) as usize).min(c[1] - 1),
            (u.z.floor().max(0.0) as usize).min(c[2] - 1),
        ]
    }

    /// The interpolant (trilinear) at grid coordinates `u`, in f64 (the sources' field:
    /// [`Interpolated::value_at`](super::interpolant::Interpolated::value_at)).
    pub fn value_at(&self, u: DVec3) -> f64 {
        use super::interpolant::{Interpolant, Interpolated};
        Interpolated::new(self, Interpolant::Trilinear).value_at(u)
    }
}
