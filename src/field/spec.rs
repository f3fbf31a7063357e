//! [`FieldSpec`]: a validated field source plus its lattice, and sampling it into a [`Grid`]
//! (sdf and expr grids are evaluated over z-slabs on all cores).

use glam::DVec3;

use super::expr::ExprSource;
use super::mesh_sdf::{MeshSdf, MeshSource};
use super::npy::{path_str, NpySource};
use super::raw::{file_name, RawSource};
use super::samples::{self, StorageOrder};
use super::{FieldError, Grid, GridLimits};
use crate::vocab::{Bounds, SdfShape};

/// Where a field's values come from, after validation.
#[derive(Clone, Debug)]
pub enum FieldSource {
    /// A signed-distance shape sampled at the grid points; `center` is subtracted first.
    Sdf { shape: SdfShape, center: DVec3 },
    /// One cell: `v000, v100, v010, v110, v001, v101, v011, v111` (vXYZ: the corner at x = X,
    /// y = Y, z = Z of the box). On a grid finer than 2x2x2 the points sample the trilinear
    /// interpolant of these values, which describes the same field.
    Corners([f64; 8]),
    /// A `.npy` file whose header and size were checked at load time.
    Npy(NpySource),
    /// A headerless binary file whose size was checked at load time.
    Raw(RawSource),
    /// An expression over `x`, `y`, `z` (world coordinates) and `t`.
    Expr(ExprSource),
    /// Samples already in memory (scenes built in code, not from a file); the spec's
    /// resolution and bounds are the grid's.
    Grid(std::sync::Arc<Grid>),
    /// The signed distance to a triangle mesh read at load time (negative inside).
    Mesh(MeshSource),
}

/// A validated `[field]` table: the source, and the lattice it is sampled on.
#[derive(Clone, Debug)]
pub struct FieldSpec {
    pub source: FieldSource,
    /// Grid points along x, y, z (each at least 2). For `npy` and `raw` these are the file's
    /// dims.
    pub resolution: [usize; 3],
    pub bounds: Bounds,
}

impl FieldSpec {
    /// One cell over `bounds` with the given corner values (`source = "corners"`).
    pub fn corners(values: [f64; 8], bounds: Bounds) -> FieldSpec {
        FieldSpec { source: FieldSource::Corners(values), resolution: [2, 2, 2], bounds }
    }

    /// A signed-distance shape centred at `center`, sampled at `resolution` points over `bounds`.
    pub fn sdf(
        shape: SdfShape,
        center: DVec3,
        resolution: [usize; 3],
        bounds: Bounds,
    ) -> FieldSpec {
        FieldSpec { source: FieldSource::Sdf { shape, center }, resolution, bounds }
    }

    /// A grid already in memory, as it is (its dims and box become the lattice).
    pub fn from_grid(grid: Grid) -> FieldSpec {
        FieldSpec {
            resolution: grid.dims,
            bounds: Bounds { min: grid.min, max: grid.max },
            source: FieldSource::Grid(std::sync::Arc::new(grid)),
        }
    }

    /// An expression field; fails if the expression does not compile.
    pub fn expr(
        text: &str,
        resolution: [usize; 3],
        bounds: Bounds,
    ) -> Result<FieldSpec, FieldError> {
        Ok(FieldSpec { source: FieldSource::Expr(ExprSource::parse(text)?), resolution, bounds })
    }

    /// Samples the field at time `time` (only `expr` fields depend on it), under the memory
    /// cap of `ISOVIEW_MAX_GRID_MIB` (default 1024 MiB).
    ///
    /// `npy` and `raw` sources read their file on every call; sample once and keep the grid when
    /// [`FieldSpec::is_time_varying`] is false.
    pub fn sample(&self, time: f64) -> Result<Grid, FieldError> {
        self.sample_with(time, &GridLimits::from_env()?)
    }

    /// [`FieldSpec::sample`] under an explicit memory cap.
    pub fn sample_with(&self, time: f64, limits: &GridLimits) -> Result<Grid, FieldError> {
        let [nx, ny, nz] = self.resolution;
        if self.resolution.iter().any(|&n| n < 2) {
            return Err(FieldError::BadShape {
                path: "field".into(),
                message: format!("every axis needs at least 2 points, got [{nx}, {ny}, {nz}]"),
            });
        }
        let dims = [nx as u64, ny as u64, nz as u64];
        let what = match &self.source {
            FieldSource::Npy(n) => path_str(&n.path),
            FieldSource::Raw(r) => path_str(&r.path),
            FieldSource::Mesh(m) => path_str(&m.path),
            _ => "field.resolution".to_string(),
        };
        limits.check(dims, &what)?;

        let mut grid = Grid {
            dims: self.resolution,
            min: self.bounds.min,
            max: self.bounds.max,
            values: Vec::new(),
        };
        grid.values = match &self.source {
            FieldSource::Sdf { shape, center } => fill(&grid, |p| shape.distance(p - *center)),
            FieldSource::Corners(v) => {
                let (lo, size) = (self.bounds.min, self.bounds.max - self.bounds.min);
                fill(&grid, |p| trilinear(v, (p - lo) / size))
            }
            FieldSource::Npy(n) => {
                self.check_file_dims(n.dims)?;
                n.read(limits)?
            }
            FieldSource::Raw(r) => {
                self.check_file_dims(r.dims)?;
                r.read(limits)?
            }
            FieldSource::Expr(e) => fill(&grid, |p| e.eval(p, time)),
            FieldSource::Grid(g) => g.values.clone(),
            FieldSource::Mesh(m) => {
                let sdf = MeshSdf::new(&m.mesh);
                fill(&grid, |p| sdf.distance(p))
            }
        };

        let spacing = grid.spacing();
        match &self.source {
            FieldSource::Expr(e) => samples::check_finite(
                &grid.values,
                grid.dims,
                || format!("expression \"{}\" at t = {time}", e.text),
                |[i, j, k]| {
                    let p = grid.min + spacing * DVec3::new(i as f64, j as f64, k as f64);
                    format!(" (x = {}, y = {}, z = {})", p.x, p.y, p.z)
                },
            )?,
            _ => {
                samples::check_finite(&grid.values, grid.dims, || what.clone(), |_| String::new())?
            }
        }
        Ok(grid)
    }

    fn check_file_dims(&self, dims: [usize; 3]) -> Result<(), FieldError> {
        if dims == self.resolution {
            Ok(())
        } else {
            Err(FieldError::BadShape {
                path: "field".into(),
                message: format!(
                    "resolution {:?} does not match the file's dims {:?}",
                    self.resolution, dims
                ),
            })
        }
    }

    /// Whether [`FieldSpec::sample`] depends on its time argument.
    pub fn is_time_varying(&self) -> bool {
        matches!(&self.source, FieldSource::Expr(e) if e.uses_time())
    }

    /// One line for output headers, e.g. `sdf torus R=0.6 r=0.25 48x48x48 in [-1, -1, -1]..[1, 1, 1]`.
    pub fn describe(&self) -> String {
        let [nx, ny, nz] = self.resolution;
        let what = match &self.source {
            FieldSource::Sdf { shape, center } => {
                let mut s = format!("sdf {}", shape.describe());
                if *center != DVec3::ZERO {
                    s += &format!(" center={}", vec3(*center));
                }
                s
            }
            FieldSource::Corners(v) => format!(
                "corners [{}]",
                v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", ")
            ),
            FieldSource::Npy(n) => format!(
                "npy {} {} {}-order",
                file_name(&n.path),
                n.descr,
                if n.order == StorageOrder::ZFastest { "C" } else { "Fortran" }
            ),
            FieldSource::Raw(r) => {
                format!("raw {} {} {}-endian", r.file_name(), r.dtype.name(), r.endian.name())
            }
            FieldSource::Expr(e) => format!("expr \"{}\"", e.text),
            FieldSource::Grid(_) => "grid in memory".to_string(),
            FieldSource::Mesh(m) => format!(
                "mesh {} ({} triangles) signed distance",
                file_name(&m.path),
                m.mesh.triangles.len()
            ),
        };
        format!("{what} {nx}x{ny}x{nz} in {}..{}", vec3(self.bounds.min), vec3(self.bounds.max))
    }
}

/// `[x, y, z]` with shortest round-trip formatting.
fn vec3(v: DVec3) -> String {
    format!("[{}, {}, {}]", v.x, v.y, v.z)
}

/// The trilinear interpolant of corner values `v` (vXYZ order) at unit-cube coordinates `u`.
fn trilinear(v: &[f64; 8], u: DVec3) -> f64 {
    let lerp = |a: f64, b: f64, s: f64| a + (b - a) * s;
    let x00 = lerp(v[0], v[1], u.x);
    let x10 = lerp(v[2], v[3], u.x);
    let x01 = lerp(v[4], v[5], u.x);
    let x11 = lerp(v[6], v[7], u.x);
    lerp(lerp(x00, x10, u.y), lerp(x01, x11, u.y), u.z)
}

/// Points below which sampling stays on the calling thread.
const PARALLEL_MIN_POINTS: usize = 1 << 15;

/// Evaluates `f` at every grid point (world space, the same arithmetic as [`Grid::point`]),
/// x fastest, splitting z-slabs over the available cores for large grids.
fn fill(grid: &Grid, f: impl Fn(DVec3) -> f64 + Sync) -> Vec<f32> {
    let [nx, ny, nz] = grid.dims;
    let slab = nx * ny;
    let (min, spacing) = (grid.min, grid.spacing());
    let mut values = vec![0.0f32; slab * nz];
    let fill_slabs = |first_k: usize, out: &mut [f32]| {
        for (dk, slab_out) in out.chunks_mut(slab).enumerate() {
            let k = first_k + dk;
            for j in 0..ny {
                for i in 0..nx {
                    let p = min + spacing * DVec3::new(i as f64, j as f64, k as f64);
                    slab_out[i + nx * j] = f(p) as f32;
                }
            }
        }
    };
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(nz);
    if values.len() < PARALLEL_MIN_POINTS || threads < 2 {
        fill_slabs(0, &mut values);
    } else {
        let slabs_per_thread = nz.div_ceil(threads);
        std::thread::scope(|s| {
            for (n, chunk) in values.chunks_mut(slabs_per_thread * slab).enumerate() {
                let fill_slabs = &fill_slabs;
                s.spawn(move || fill_slabs(n * slabs_per_thread, chunk));
            }
        });
    }
    values
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

    /// The shape's name as written in scene files.
    pub fn name(&self) -> &'static str {
        match self {
            SdfShape::Sphere { .. } => "sphere",
            SdfShape::Box { .. } => "box",
            SdfShape::Torus { .. } => "torus",
            SdfShape::Gyroid { .. } => "gyroid",
        }
    }

    /// Name and parameters, e.g. `torus R=0.6 r=0.25`.
    pub fn describe(&self) -> String {
        match *self {
            SdfShape::Sphere { radius } => format!("sphere r={radius}"),
            SdfShape::Box { half_extents } => format!("box b={}", vec3(half_extents)),
            SdfShape::Torus { major_radius, minor_radius } => {
                format!("torus R={major_radius} r={minor_radius}")
            }
            SdfShape::Gyroid { scale, thickness } => format!("gyroid s={scale} w={thickness}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> Bounds {
        Bounds { min: DVec3::ZERO, max: DVec3::ONE }
    }

    #[test]
    fn corners_resampled_finer_reproduce_the_cell() {
        let v = [0.1, -0.4, 0.3, 0.9, -0.7, 0.2, 0.5, -0.3];
        let coarse =
            FieldSpec::corners(v, unit()).sample_with(0.0, &GridLimits::default()).unwrap();
        assert_eq!(coarse.corners(0, 0, 0), v.map(|x| x as f32));
        let mut fine = FieldSpec::corners(v, unit());
        fine.resolution = [3, 5, 2];
        let g = fine.sample_with(0.0, &GridLimits::default()).unwrap();
        assert_eq!(g.at(2, 4, 1), v[7] as f32);
        assert!((g.at(1, 2, 0) as f64 - trilinear(&v, DVec3::new(0.5, 0.5, 0.0))).abs() < 1e-7);
    }

    #[test]
    fn parallel_fill_matches_serial_points() {
        let b = Bounds { min: DVec3::splat(-1.0), max: DVec3::new(1.0, 2.0, 3.0) };
        let spec = FieldSpec::expr("x + 10*y + 100*z", [40, 33, 37], b).unwrap();
        let g = spec.sample_with(0.0, &GridLimits::default()).unwrap();
        for (i, j, k) in [(0, 0, 0), (39, 32, 36), (7, 20, 30), (13, 1, 19)] {
            let p = g.point(i, j, k);
            assert_eq!(g.at(i, j, k), (p.x + 10.0 * p.y + 100.0 * p.z) as f32);
        }
    }

    #[test]
    fn cap_refuses_before_sampling() {
        let cap = GridLimits { max_bytes: 1 << 20 };
        let sphere =
            |res| FieldSpec::sdf(SdfShape::Sphere { radius: 1.0 }, DVec3::ZERO, res, unit());
        // 64^3 f32 samples are exactly 1 MiB: allowed; one more slab is over.
        assert!(sphere([64, 64, 64]).sample_with(0.0, &cap).is_ok());
        let e = sphere([64, 64, 65]).sample_with(0.0, &cap).err();
        assert!(matches!(e, Some(FieldError::TooLarge { bytes: 1064960, .. })), "{e:?}");
    }
}
