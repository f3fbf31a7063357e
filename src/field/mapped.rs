//! Grids larger than memory: a `raw` or `npy` file memory-mapped and read box by box
//! (`field.residency = "active"`, README "Large data").
//!
//! Nothing is read when the map is made; each [`MappedGrid::read_box`] decodes the points it
//! asks for (any dtype and byte order the in-memory readers take, either storage order) into
//! the grid's x-fastest `f32` layout. Pages the kernel brought in are handed back with
//! [`MappedGrid::release`] after a pass over the file, so the resident set stays at what one
//! pass holds (a slab of brick layers), not the file.
//!
//! [`MappedGrid::brick_ranges`] is the one pass every use starts with: the min/max of every
//! brick of `passes::bricks::BRICK`³ cells over its (BRICK + 1)³ points, in the
//! layout of `passes::bricks` (the GPU builds the same grid from an uploaded image: min and max
//! are exact, so both are bit for bit equal), and the finiteness check of every sample.

use std::fs::File;
use std::path::PathBuf;

use glam::DVec3;
use rayon::prelude::*;

use super::samples::{self, Endian, SampleType, StorageOrder};
use super::source::FieldSource;
use super::{FieldError, FieldSpec, Grid, NanPolicy};

/// A memory-mapped `raw` or `npy` grid.
pub struct MappedGrid {
    path: PathBuf,
    map: memmap2::Mmap,
    /// Byte offset of the first sample.
    offset: usize,
    dtype: SampleType,
    endian: Endian,
    order: StorageOrder,
    /// Points along x, y, z.
    pub dims: [usize; 3],
    /// The box (the spec's bounds).
    pub min: DVec3,
    pub max: DVec3,
    /// `field.nan` of the spec: whether a non-finite sample is refused or missing data.
    pub nan: NanPolicy,
}

impl MappedGrid {
    /// Maps the file of `spec` when its source is `npy` or `raw`; None for other sources
    /// (they are computed or parsed whole).
    pub fn open(spec: &FieldSpec) -> Result<Option<MappedGrid>, FieldError> {
        let (path, offset, dtype, endian, order, dims) = match &spec.source {
            FieldSource::Npy(n) => {
                (n.path.clone(), n.data_offset, n.dtype, n.endian, n.order, n.dims)
            }
            FieldSource::Raw(r) => {
                (r.path.clone(), 0, r.dtype, r.endian, StorageOrder::XFastest, r.dims)
            }
            _ => return Ok(None),
        };
        let file = File::open(&path).map_err(|e| FieldError::io(&path, &e))?;
        let len = file.metadata().map_err(|e| FieldError::io(&path, &e))?.len();
        samples::check_file_size(&path, len, offset, dims, dtype)?;
        // SAFETY: the map is read only; a file truncated by another process while mapped
        // would fault (SIGBUS), as with any reader of a memory-mapped file (README "Large data").
        let map = unsafe { memmap2::Mmap::map(&file) }.map_err(|e| FieldError::io(&path, &e))?;
        let offset = usize::try_from(offset).map_err(|_| FieldError::Io {
            path: path.clone(),
            message: "the data offset does not fit this machine's address space".into(),
        })?;
        Ok(Some(MappedGrid {
            path,
            map,
            offset,
            dtype,
            endian,
            order,
            dims,
            min: spec.bounds.min,
            max: spec.bounds.max,
            nan: spec.nan,
        }))
    }

    /// The map of `spec`'s file when its residency asks for one: `"active"`, or `"auto"` with
    /// the whole grid over the cap; None to read the grid whole.
    pub fn for_residency(
        spec: &FieldSpec,
        limits: &super::GridLimits,
    ) -> Result<Option<MappedGrid>, FieldError> {
        if spec.residency == super::Residency::Whole {
            return Ok(None);
        }
        let Some(grid) = MappedGrid::open(spec)? else { return Ok(None) };
        let mapped = match spec.residency {
            super::Residency::Auto => grid.f32_bytes() > limits.max_bytes,
            _ => true,
        };
        Ok(mapped.then_some(grid))
    }

    /// The grid's geometry: dims and box, no values (what the render path reads of a grid).
    pub fn shape(&self) -> Grid {
        Grid { dims: self.dims, min: self.min, max: self.max, values: Vec::new() }
    }

    /// The file, for messages.
    pub fn label(&self) -> String {
        super::npy::path_str(&self.path)
    }

    /// Bytes the whole grid takes as `f32` samples.
    pub fn f32_bytes(&self) -> u64 {
        self.dims.iter().map(|&d| d as u64).product::<u64>() * 4
    }

    /// The points `lo .. lo + n` (each inside the grid), x fastest, decoded to `f32`.
    pub fn read_box(&self, lo: [usize; 3], n: [usize; 3]) -> Vec<f32> {
        let mut out = vec![0.0f32; n[0] * n[1] * n[2]];
        let size = self.dtype.size();
        let [nx, ny, nz] = self.dims;
        let mut run = Vec::new();
        match self.order {
            StorageOrder::XFastest => {
                for k in 0..n[2] {
                    for j in 0..n[1] {
                        let first = lo[0] + nx * ((lo[1] + j) + ny * (lo[2] + k));
                        run.clear();
                        samples::decode(
                            self.dtype,
                            self.endian,
                            self.bytes(first, n[0], size),
                            &mut run,
                        );
                        let at = n[0] * (j + n[1] * k);
                        out[at..at + n[0]].copy_from_slice(&run);
                    }
                }
            }
            StorageOrder::ZFastest => {
                // Element [i, j, k] at k + nz (j + ny i): runs along z, scattered into x-fastest.
                for i in 0..n[0] {
                    for j in 0..n[1] {
                        let first = lo[2] + nz * ((lo[1] + j) + ny * (lo[0] + i));
                        run.clear();
                        samples::decode(
                            self.dtype,
                            self.endian,
                            self.bytes(first, n[2], size),
                            &mut run,
                        );
                        for (k, &v) in run.iter().enumerate() {
                            out[i + n[0] * (j + n[1] * k)] = v;
                        }
                    }
                }
            }
        }
        out
    }

    /// [`MappedGrid::read_box`], checked finite under `field.nan` (the first non-finite point,
    /// x fastest, is named), with the pages read handed back: what a process reading only its part of the
    /// file (an MPI rank's block or window) takes instead of sampling the grid.
    pub fn read_finite(&self, lo: [usize; 3], n: [usize; 3]) -> Result<Vec<f32>, FieldError> {
        let values = self.read_box(lo, n);
        self.release();
        if self.nan == NanPolicy::Empty {
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

    fn bytes(&self, first: usize, count: usize, size: usize) -> &[u8] {
        let start = self.offset + first * size;
        &self.map[start..start + count * size]
    }

    /// Hands every page of the map back to the kernel (they are re-read from the file if asked
    /// for again): called after each pass so the process does not keep the file resident.
    pub fn release(&self) {
        // Advice only: if the kernel refuses, the pages stay cached and nothing else changes.
        // SAFETY: the map is private and read-only; DONTNEED drops clean file pages, and later
        // reads fault them in again from the file.
        let _ = unsafe { self.map.unchecked_advise(memmap2::UncheckedAdvice::DontNeed) };
    }

    /// The min/max of every brick of `brick` cells (over its `brick + 1` points per axis), x
    /// fastest, `ceil(cells / brick)` per axis, as `passes::bricks` lays them out; with
    /// `field.nan = "error"` fails on a non-finite sample (the first the scan meets: by brick
    /// layer along the file's slowest axis), with `"empty"` leaves it out of the range
    /// ([`super::trilinear::widen`]). One pass over the file, in its order: each layer of
    /// bricks along the slowest axis is read row by row along the fastest (every row once per
    /// brick row holding it), in parallel over the brick rows, and its pages released before
    /// the next.
    pub fn brick_ranges(&self, brick: usize) -> Result<Vec<[f32; 2]>, FieldError> {
        let counts = self.dims.map(|n| (n - 1).div_ceil(brick));
        // File axes: fastest f, middle y, slowest s (x, y, z for XFastest; z, y, x for C order).
        let (f, s) = match self.order {
            StorageOrder::XFastest => (0, 2),
            StorageOrder::ZFastest => (2, 0),
        };
        let mut out = vec![[f32::INFINITY, f32::NEG_INFINITY]; counts.iter().product()];
        let index = |b: [usize; 3]| b[0] + counts[0] * (b[1] + counts[1] * b[2]);
        for bs in 0..counts[s] {
            let rows: Vec<Result<Vec<[f32; 2]>, FieldError>> = (0..counts[1])
                .into_par_iter()
                .map(|by| self.brick_row(f, s, bs, by, brick, counts[f]))
                .collect();
            for (by, row) in rows.into_iter().enumerate() {
                for (bf, mm) in row?.into_iter().enumerate() {
                    let mut b = [0; 3];
                    (b[f], b[1], b[s]) = (bf, by, bs);
                    out[index(b)] = mm;
                }
            }
            self.release();
        }
        Ok(out)
    }

    /// The ranges of the bricks `0 .. count_f` along file axis `f` at brick `by` along y and
    /// `bs` along file axis `s`.
    fn brick_row(
        &self,
        f: usize,
        s: usize,
        bs: usize,
        by: usize,
        brick: usize,
        count_f: usize,
    ) -> Result<Vec<[f32; 2]>, FieldError> {
        let mut mm = vec![[f32::INFINITY, f32::NEG_INFINITY]; count_f];
        let span = |a: usize, b: usize| b * brick..=((b + 1) * brick).min(self.dims[a] - 1);
        let n = self.dims[f];
        let size = self.dtype.size();
        let mut run = Vec::with_capacity(n);
        for ps in span(s, bs) {
            for py in span(1, by) {
                // The row of file axis f at (py, ps): contiguous in the file.
                let first = n * (py + self.dims[1] * ps);
                let bytes = self.bytes(first, n, size);
                let row: &[f32] = match (self.dtype, self.endian) {
                    (SampleType::F32, Endian::Little) if bytes.as_ptr() as usize % 4 == 0 => {
                        bytemuck::cast_slice(bytes)
                    }
                    _ => {
                        run.clear();
                        samples::decode(self.dtype, self.endian, bytes, &mut run);
                        &run
                    }
                };
                let refused = self.nan == NanPolicy::Error;
                if let Some(pf) = row.iter().position(|v| refused && !v.is_finite()) {
                    let mut index = [0; 3];
                    (index[f], index[1], index[s]) = (pf, py, ps);
                    return Err(FieldError::NonFinite {
                        what: super::npy::path_str(&self.path),
                        index,
                        value: row[pf],
                        detail: String::new(),
                    });
                }
                for (bf, m) in mm.iter_mut().enumerate() {
                    for &v in &row[span(f, bf)] {
                        crate::field::trilinear::widen(m, v);
                    }
                }
            }
        }
        Ok(mm)
    }
}
