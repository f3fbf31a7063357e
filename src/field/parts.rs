//! Grids read in parts: box by box, never whole (`field.residency`, sparse `.vdb`/`.nvdb`;
//! docs/large-data.md). The brick pool of the ray methods (`render::pool`) and the windows of
//! `extract` (`mesh::mapped`) read such a grid only through [`Parts`]: its shape, boxes of its
//! points and the min/max of its bricks.
//!
//! Two kinds: a `raw` or `npy` file read with positioned reads ([`MappedGrid`]), and a sparse
//! OpenVDB or NanoVDB tree held as it is ([`SparseGrid`]).

use glam::DVec3;

use super::mapped::MappedGrid;
use super::source::FieldSource;
use super::sparse::SparseTree;
use super::{FieldError, FieldSpec, Grid, NanPolicy};

/// A grid read box by box.
pub trait Parts: Send + Sync {
    /// Points along x, y, z.
    fn dims(&self) -> [usize; 3];
    /// The box (the spec's bounds): first and last grid point.
    fn bounds(&self) -> (DVec3, DVec3);
    /// `field.nan` of the spec.
    fn nan(&self) -> NanPolicy;
    /// The file, for messages.
    fn label(&self) -> String;
    /// How the grid is read, for the log (`read from the file in parts`, `a sparse tree of
    /// 52124 leaves`).
    fn how(&self) -> String;
    /// The points `lo .. lo + n` (inside the grid), x fastest.
    fn read_box(&self, lo: [usize; 3], n: [usize; 3]) -> Result<Vec<f32>, FieldError>;
    /// The min/max of every brick of `brick` cells over the points it reads, x fastest,
    /// `ceil(cells / brick)` per axis, as `passes::bricks` lays them out; under `field.nan =
    /// "error"` fails on a non-finite sample, under `"empty"` leaves it out.
    fn brick_ranges(&self, brick: usize) -> Result<Vec<[f32; 2]>, FieldError>;

    /// The sparse tree, for the scans that follow its structure (a superbrick in empty space
    /// costs a lookup, not a pass over its points); None for a file read in parts.
    fn sparse(&self) -> Option<&SparseTree> {
        None
    }

    /// [`Parts::read_box`], checked finite under `field.nan` (the first non-finite point,
    /// x fastest, is named): what a process reading only its part of a grid (an MPI rank's
    /// block, a window) takes instead of sampling it.
    fn read_finite(&self, lo: [usize; 3], n: [usize; 3]) -> Result<Vec<f32>, FieldError> {
        let values = self.read_box(lo, n)?;
        if self.nan() == NanPolicy::Empty {
            return Ok(values);
        }
        match values.iter().position(|v| !v.is_finite()) {
            None => Ok(values),
            Some(at) => {
                let p = [at % n[0], (at / n[0]) % n[1], at / (n[0] * n[1])];
                Err(FieldError::NonFinite {
                    what: self.label(),
                    index: [0, 1, 2].map(|a| lo[a] + p[a]),
                    value: values[at],
                    detail: String::new(),
                })
            }
        }
    }

    /// Bytes the whole grid would take as `f32` samples.
    fn f32_bytes(&self) -> u64 {
        self.dims().iter().map(|&d| d as u64).product::<u64>() * 4
    }

    /// The grid's geometry: dims and box, no values (what the render path reads of a grid).
    fn shape(&self) -> Grid {
        let (min, max) = self.bounds();
        Grid { dims: self.dims(), min, max, values: Vec::new() }
    }
}

impl Parts for MappedGrid {
    fn dims(&self) -> [usize; 3] {
        self.dims
    }
    fn bounds(&self) -> (DVec3, DVec3) {
        (self.min, self.max)
    }
    fn nan(&self) -> NanPolicy {
        self.nan
    }
    fn label(&self) -> String {
        MappedGrid::label(self)
    }
    fn how(&self) -> String {
        "read from the file in parts".into()
    }
    fn read_box(&self, lo: [usize; 3], n: [usize; 3]) -> Result<Vec<f32>, FieldError> {
        MappedGrid::read_box(self, lo, n)
    }
    fn brick_ranges(&self, brick: usize) -> Result<Vec<[f32; 2]>, FieldError> {
        MappedGrid::brick_ranges(self, brick)
    }
}

/// A sparse `.vdb` or `.nvdb` grid: its tree, the spec's box and `field.nan`.
pub struct SparseGrid {
    pub tree: SparseTree,
    pub min: DVec3,
    pub max: DVec3,
    pub nan: NanPolicy,
    label: String,
}

impl SparseGrid {
    /// The sparse tree of `spec`'s file, when its source is a `.vdb` or `.nvdb` file.
    pub fn of(spec: &FieldSpec) -> Option<SparseGrid> {
        let FieldSource::File(f) = &spec.source else { return None };
        let tree = f.volume.sparse.clone()?;
        Some(SparseGrid {
            tree,
            min: spec.bounds.min,
            max: spec.bounds.max,
            nan: spec.nan,
            label: super::npy::path_str(&f.path),
        })
    }
}

impl Parts for SparseGrid {
    fn dims(&self) -> [usize; 3] {
        self.tree.dims
    }
    fn bounds(&self) -> (DVec3, DVec3) {
        (self.min, self.max)
    }
    fn nan(&self) -> NanPolicy {
        self.nan
    }
    fn label(&self) -> String {
        self.label.clone()
    }
    fn how(&self) -> String {
        format!(
            "a sparse tree of {} leaves ({:.1} MiB)",
            self.tree.tree.leaf_count(),
            self.tree.tree.bytes() as f64 / (1 << 20) as f64
        )
    }
    fn read_box(&self, lo: [usize; 3], n: [usize; 3]) -> Result<Vec<f32>, FieldError> {
        Ok(self.tree.read_box(lo, n))
    }
    fn brick_ranges(&self, brick: usize) -> Result<Vec<[f32; 2]>, FieldError> {
        self.tree.brick_ranges(brick, self.nan, &self.label)
    }
    fn sparse(&self) -> Option<&SparseTree> {
        Some(&self.tree)
    }
}

/// How `spec`'s grid is read in parts by the paths that can (the brick pool, `extract`'s
/// windows): a `.vdb`/`.nvdb` tree always (sparse by default), a `raw` or `npy` file under
/// `field.residency` ([`MappedGrid::for_residency`]); None to sample it whole.
pub fn for_residency(
    spec: &FieldSpec,
    limits: &super::GridLimits,
) -> Result<Option<Box<dyn Parts>>, FieldError> {
    if let Some(sparse) = SparseGrid::of(spec) {
        return Ok(Some(Box::new(sparse)));
    }
    Ok(MappedGrid::for_residency(spec, limits)?.map(|m| Box::new(m) as Box<dyn Parts>))
}

/// Whether `spec`'s grid is a sparse tree (read sparsely where a path can, densely under the
/// cap where it cannot).
pub fn is_sparse(spec: &FieldSpec) -> bool {
    matches!(&spec.source, FieldSource::File(f) if f.volume.sparse.is_some())
}
