//! Grids larger than memory: a `raw` or `npy` file read box by box with positioned reads
//! (`field.residency = "active"`, docs/large-data.md).
//!
//! Nothing is read when the grid is opened; each [`MappedGrid::read_box`] decodes the points it
//! asks for (any dtype and byte order the in-memory readers take, either storage order) into
//! the grid's x-fastest `f32` layout. The file is read with `pread` (`FileExt::read_exact_at`),
//! not through a memory map: a file another process truncates while it is being read would
//! make a mapped page fault with SIGBUS, which no Rust code can catch; a checked read instead
//! comes back short and is reported as one line ([`FieldError::Shrank`]). The process holds
//! only the buffers of what it reads (the kernel's page cache is not the process's memory).
//!
//! [`MappedGrid::brick_ranges`] is the one pass every use starts with: the min/max of every
//! brick of `passes::bricks::BRICK`³ cells over its (BRICK + 1)³ points, in the
//! layout of `passes::bricks` (the GPU builds the same grid from an uploaded image: min and max
//! are exact, so both are bit for bit equal), and the finiteness check of every sample.

use std::fs::File;
use std::os::unix::fs::FileExt;
use std::path::PathBuf;

use glam::DVec3;
use rayon::prelude::*;

use super::interpolant::STENCIL;
use super::samples::{self, Endian, SampleType, StorageOrder};
use super::source::FieldSource;
use super::{FieldError, FieldSpec, NanPolicy};

/// A `raw` or `npy` grid read from its file on demand (the name is from when it was mapped).
pub struct MappedGrid {
    path: PathBuf,
    file: File,
    /// Byte offset of the first sample.
    offset: u64,
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
    /// Opens the file of `spec` when its source is `npy` or `raw` (its size checked against the
    /// dims); None for other sources (they are computed or parsed whole).
    pub fn open(spec: &FieldSpec) -> Result<Option<MappedGrid>, FieldError> {
        let (path, offset, dtype, endian, order, dims, access) = match &spec.source {
            FieldSource::Npy(n) => {
                (n.path.clone(), n.data_offset, n.dtype, n.endian, n.order, n.dims, &n.access)
            }
            FieldSource::Raw(r) => {
                (r.path.clone(), 0, r.dtype, r.endian, StorageOrder::XFastest, r.dims, &r.access)
            }
            _ => return Ok(None),
        };
        let file = access.open(&path).map_err(|e| FieldError::io(&path, &e))?;
        let len = file.metadata().map_err(|e| FieldError::io(&path, &e))?.len();
        samples::check_file_size(&path, len, offset, dims, dtype)?;
        Ok(Some(MappedGrid {
            path,
            file,
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
            super::Residency::Auto => super::parts::Parts::f32_bytes(&grid) > limits.max_bytes,
            _ => true,
        };
        Ok(mapped.then_some(grid))
    }

    /// The file, for messages.
    pub fn label(&self) -> String {
        super::npy::path_str(&self.path)
    }

    /// The points `lo .. lo + n` (each inside the grid), x fastest, decoded to `f32`; fails
    /// (one line) if the file has shrunk since it was opened.
    pub fn read_box(&self, lo: [usize; 3], n: [usize; 3]) -> Result<Vec<f32>, FieldError> {
        let mut out = vec![0.0f32; n[0] * n[1] * n[2]];
        let [nx, ny, nz] = self.dims;
        let (mut run, mut raw) = (Vec::new(), Vec::new());
        match self.order {
            StorageOrder::XFastest => {
                for k in 0..n[2] {
                    for j in 0..n[1] {
                        let first = lo[0] + nx * ((lo[1] + j) + ny * (lo[2] + k));
                        self.read_run(first, n[0], &mut run, &mut raw)?;
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
                        self.read_run(first, n[2], &mut run, &mut raw)?;
                        for (k, &v) in run.iter().enumerate() {
                            out[i + n[0] * (j + n[1] * k)] = v;
                        }
                    }
                }
            }
        }
        Ok(out)
    }

    /// Samples `first .. first + count` in file order, decoded into `run` (`raw`: scratch for
    /// the bytes). The one place the file is read: a read that comes back short means the file
    /// shrank after it was opened (its size was checked then).
    fn read_run(
        &self,
        first: usize,
        count: usize,
        run: &mut Vec<f32>,
        raw: &mut Vec<u8>,
    ) -> Result<(), FieldError> {
        let size = self.dtype.size();
        let at = self.offset + (first * size) as u64;
        let read = |buf: &mut [u8]| {
            self.file.read_exact_at(buf, at).map_err(|e| match e.kind() {
                std::io::ErrorKind::UnexpectedEof => self.shrank(),
                _ => FieldError::io(&self.path, &e),
            })
        };
        run.clear();
        if (self.dtype, self.endian) == (SampleType::F32, Endian::Little)
            && cfg!(target_endian = "little")
        {
            // Little-endian f32 on a little-endian machine: the bytes are the values.
            run.resize(count, 0.0);
            read(bytemuck::cast_slice_mut(run.as_mut_slice()))
        } else {
            raw.resize(count * size, 0);
            read(raw)?;
            samples::decode(self.dtype, self.endian, raw, run).map_err(|o| {
                let at = first + o.at;
                let [_, ny, nz] = self.dims;
                let index = match self.order {
                    StorageOrder::XFastest => samples::grid_index(at, self.dims),
                    StorageOrder::ZFastest => [at / (ny * nz), (at / nz) % ny, at % nz],
                };
                let (what, value) = (self.label(), o.value);
                FieldError::OutOfRange { what, index, value, detail: String::new() }
            })
        }
    }

    /// The error for a file shorter than when it was opened, with its size now.
    fn shrank(&self) -> FieldError {
        let now = std::fs::metadata(&self.path).map(|m| m.len());
        FieldError::Shrank { path: self.path.clone(), len: now.ok() }
    }

    /// The min/max of every brick of `brick` cells (over the points it reads,
    /// [`Stencil::brick_points`](super::interpolant::Stencil::brick_points)), x
    /// fastest, `ceil(cells / brick)` per axis, as `passes::bricks` lays them out; with
    /// `field.nan = "error"` fails on a non-finite sample (the first the scan meets: by brick
    /// layer along the file's slowest axis), with `"empty"` leaves it out of the range
    /// ([`super::interpolant::widen`]); fails on a file that shrank. One pass over the file, in
    /// its order: each layer of bricks along the slowest axis is read row by row along the
    /// fastest (every row once per brick row holding it), in parallel over the brick rows.
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
        let span = |a: usize, b: usize| STENCIL.brick_points(b, brick, self.dims[a]);
        let n = self.dims[f];
        let (mut row, mut raw) = (Vec::with_capacity(n), Vec::new());
        for ps in span(s, bs) {
            for py in span(1, by) {
                // The row of file axis f at (py, ps): contiguous in the file.
                let first = n * (py + self.dims[1] * ps);
                self.read_run(first, n, &mut row, &mut raw)?;
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
                        crate::field::interpolant::widen(m, v);
                    }
                }
            }
        }
        Ok(mm)
    }
}
