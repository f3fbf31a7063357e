//! [`FieldSpec`]: a validated field source plus its lattice, and sampling it into a [`Grid`]
//! (sdf and expr grids are evaluated over z-slabs on all cores).

use glam::DVec3;

use super::formats::Format;
use super::interpolant::Interpolant;
use super::source::show3;
use super::{shown, ExprSource, FieldError, FieldSource, Grid, GridLimits};
use crate::vocab::{Bounds, Placement, SdfShape};

/// A validated `[field]` table: the source, and the lattice it is sampled on.
#[derive(Clone, Debug)]
pub struct FieldSpec {
    pub source: FieldSource,
    /// Grid points along x, y, z (each at least 2). For `npy` and `raw` these are the file's
    /// dims.
    pub resolution: [usize; 3],
    pub bounds: Bounds,
    /// Where the grid's frame sits in world space (identity unless a file's header orients
    /// it); every method works in the grid's frame and maps its outputs through this.
    pub placement: Placement,
    /// How much of the grid is read and uploaded (`field.residency`; `npy` and `raw` only).
    pub residency: Residency,
    /// What a NaN or infinite sample means (`field.nan`).
    pub nan: NanPolicy,
    /// How the field is evaluated between its samples (`field.interpolation`; which readers
    /// take which: [`Interpolant::refusal`]).
    pub interpolation: Interpolant,
}

/// The keys every `[field]` takes whatever its source (`bounds` only where the source has no
/// box of its own); each source adds its own.
pub const COMMON_KEYS: [&str; 4] = ["source", "bounds", "nan", "interpolation"];

/// `field.nan`: what a non-finite sample (NaN or ±inf) means. With `Empty` it is missing data:
/// a cell whose interpolation stencil holds one holds no surface, for every method (the rule:
/// [`crate::field::interpolant::cell_missing`]; docs/scene.md "Missing data").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NanPolicy {
    /// The grid is refused at load time, naming the first such sample.
    Error,
    /// Missing data: the cells around the sample hold no surface.
    #[default]
    Empty,
}

impl NanPolicy {
    pub const NAMES: [(&'static str, NanPolicy); 2] =
        [("error", NanPolicy::Error), ("empty", NanPolicy::Empty)];
}

/// `field.residency`: whether a render reads the whole grid or only the bricks its isovalues
/// need from the file (docs/large-data.md). The default is `Auto`: a grid under the cap is
/// read whole as before, a larger one goes to the paths that can read it in parts (the ray
/// methods' brick pool, `extract`'s streaming) and the others refuse it with the cap.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Residency {
    /// The whole grid, read into memory and uploaded (the cap applies to the grid).
    Whole,
    /// The file read in parts as needed; the ray methods upload only the active bricks (the cap applies
    /// to them), `extract` streams slabs; other commands refuse.
    Active,
    /// `Active` when the whole grid is over the cap, else `Whole`: the default.
    #[default]
    Auto,
}

impl Residency {
    pub const NAMES: [(&'static str, Residency); 3] =
        [("whole", Residency::Whole), ("active", Residency::Active), ("auto", Residency::Auto)];
}

impl FieldSpec {
    /// One cell over `bounds` with the given corner values (`source = "corners"`).
    pub fn corners(values: [f64; 8], bounds: Bounds) -> FieldSpec {
        FieldSpec {
            source: FieldSource::Corners(values),
            resolution: [2, 2, 2],
            bounds,
            placement: Placement::IDENTITY,
            residency: Residency::Whole,
            nan: NanPolicy::default(),
            interpolation: Interpolant::Trilinear,
        }
    }

    /// A signed-distance shape centred at `center`, sampled at `resolution` points over `bounds`.
    pub fn sdf(
        shape: SdfShape,
        center: DVec3,
        resolution: [usize; 3],
        bounds: Bounds,
    ) -> FieldSpec {
        FieldSpec {
            source: FieldSource::Sdf { shape, center },
            resolution,
            bounds,
            placement: Placement::IDENTITY,
            residency: Residency::Whole,
            nan: NanPolicy::default(),
            interpolation: Interpolant::Trilinear,
        }
    }

    /// A grid already in memory, as it is (its dims and box become the lattice).
    pub fn from_grid(grid: Grid) -> FieldSpec {
        FieldSpec {
            resolution: grid.dims,
            bounds: Bounds { min: grid.min, max: grid.max },
            source: FieldSource::Grid(std::sync::Arc::new(grid)),
            placement: Placement::IDENTITY,
            residency: Residency::Whole,
            nan: NanPolicy::default(),
            interpolation: Interpolant::Trilinear,
        }
    }

    /// An expression field; fails if the expression does not compile.
    pub fn expr(
        text: &str,
        resolution: [usize; 3],
        bounds: Bounds,
    ) -> Result<FieldSpec, FieldError> {
        Ok(FieldSpec {
            source: FieldSource::Expr(ExprSource::parse(text)?),
            resolution,
            bounds,
            placement: Placement::IDENTITY,
            residency: Residency::Whole,
            nan: NanPolicy::default(),
            interpolation: Interpolant::Trilinear,
        })
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
        limits.check(dims, &self.source.label()).map_err(|e| match (&e, &self.source) {
            // The grid could be read in parts, but not by the command that asked for it whole.
            (FieldError::TooLarge { .. }, FieldSource::Npy(_) | FieldSource::Raw(_))
                if self.residency != Residency::Whole =>
            {
                super::limits::with_hint(e, super::error::WHOLE_GRID_HINT)
            }
            (FieldError::TooLarge { .. }, FieldSource::File(f)) if f.volume.sparse.is_some() => {
                super::limits::with_hint(e, super::error::SPARSE_HINT)
            }
            _ => e,
        })?;
        let mut grid = Grid {
            dims: self.resolution,
            min: self.bounds.min,
            max: self.bounds.max,
            values: Vec::new(),
        };
        grid.values = self.source.sample(&grid, time, limits, self.nan)?;
        Ok(grid)
    }

    /// Checks that the grid fits one 3D image of at most `max` points per axis (the device's
    /// limit, for paths that upload the grid whole), naming what sets its dims; the memory cap
    /// is not the only limit, and a device's failure to create the image would read as a GPU
    /// fault (exit 3) rather than the input's size.
    pub fn check_image_extent(&self, max: u32) -> Result<(), FieldError> {
        let Some(axis) = (0..3).find(|&a| self.resolution[a] as u64 > max as u64) else {
            return Ok(());
        };
        let pool = "; with field.residency = \"active\" the ray methods read it from a brick pool \
                    instead";
        let (what, hint) = match &self.source {
            FieldSource::Npy(n) => (format!("{}: the array's shape", shown(&n.path)), pool),
            FieldSource::Raw(_) => ("field.dims".to_string(), pool),
            // A VDB grid has no header dims: its size is the active voxels' index box (which
            // the ray methods read sparsely, through the brick pool, whatever its extent).
            FieldSource::File(f) if matches!(f.format, Format::Vdb | Format::Nvdb) => (
                format!("{}: the grid's active box", shown(&f.path)),
                "; render (analytic, fixed-step) reads the tree through a brick pool instead",
            ),
            FieldSource::File(f) => (format!("{}: the header's dims", shown(&f.path)), ""),
            _ => ("field.resolution".to_string(), ""),
        };
        Err(FieldError::OverDevice { what, dims: self.resolution, axis, max, hint })
    }

    /// Whether [`FieldSpec::sample`] depends on its time argument.
    pub fn is_time_varying(&self) -> bool {
        self.source.is_time_varying()
    }

    /// One line for output headers, e.g. `sdf torus R=0.6 r=0.25 48x48x48 in [-1, -1, -1]..[1, 1, 1]`.
    pub fn describe(&self) -> String {
        let [nx, ny, nz] = self.resolution;
        format!(
            "{} {nx}x{ny}x{nz} in {}..{}",
            self.source.describe(),
            show3(self.bounds.min),
            show3(self.bounds.max)
        )
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
        assert!(
            (g.at(1, 2, 0) as f64
                - super::super::interpolant::trilinear::trilerp(&v, DVec3::new(0.5, 0.5, 0.0)))
            .abs()
                < 1e-7
        );
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
