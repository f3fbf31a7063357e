use glam::DVec3;

use super::Grid;
use crate::scene::{Bounds, SdfShape};

/// Where a field's values come from, after validation.
#[derive(Clone, Debug)]
pub enum FieldSource {
    /// A signed-distance shape sampled at the grid points.
    Sdf { shape: SdfShape, center: DVec3 },
    /// One cell: `v000, v100, v010, v110, v001, v101, v011, v111`.
    Corners([f64; 8]),
}

/// A validated `[field]` table: the source, and the lattice it is sampled on.
#[derive(Clone, Debug)]
pub struct FieldSpec {
    pub source: FieldSource,
    /// Grid points along x, y, z (each at least 2).
    pub resolution: [usize; 3],
    pub bounds: Bounds,
}

impl FieldSpec {
    /// Samples the field at time `time` (seconds; only `expr` fields depend on it).
    pub fn sample(&self, _time: f64) -> Grid {
        let [nx, ny, nz] = self.resolution;
        let mut grid = Grid {
            dims: self.resolution,
            min: self.bounds.min,
            max: self.bounds.max,
            values: Vec::with_capacity(nx * ny * nz),
        };
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let v = match &self.source {
                        FieldSource::Sdf { shape, center } => {
                            shape.distance(grid.point(i, j, k) - *center)
                        }
                        FieldSource::Corners(v) => v[i + 2 * j + 4 * k],
                    };
                    grid.values.push(v as f32);
                }
            }
        }
        grid
    }
}

impl SdfShape {
    /// Signed distance at `p` (already relative to the shape's centre), per the contract's table.
    pub fn distance(&self, p: DVec3) -> f64 {
        match *self {
            SdfShape::Sphere { radius } => p.length() - radius,
            SdfShape::Box { half_extents } => {
                let q = p.abs() - half_extents;
                q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
            }
            SdfShape::Torus { major_radius, minor_radius } => {
                let ring = (p.x * p.x + p.z * p.z).sqrt() - major_radius;
                (ring * ring + p.y * p.y).sqrt() - minor_radius
            }
            SdfShape::Gyroid { scale: s, thickness: w } => {
                let g = (s * p.x).sin() * (s * p.y).cos()
                    + (s * p.y).sin() * (s * p.z).cos()
                    + (s * p.z).sin() * (s * p.x).cos();
                g.abs() / s - w
            }
        }
    }
}
