//! Grids larger than the device (`field.residency = "active"`): only the bricks an isovalue
//! needs are uploaded, into a pool of slots the ray shaders read through a page table
//! (`shaders/include/field.glsl`, `GRID_POOL`).
//!
//! ```text
//!   source file ──brick_ranges──> min/max of every brick of BRICK³ cells (one pass, in file order)
//!        │                            │ select: active = not clear of every isovalue
//!        │                            ▼   (fixed-step: and the bricks around them)
//!        └──read_box per resident brick──> slots of SLOT³ points ──staging chunks──> pool buffer
//!                                      page table: brick -> slot or NO_PAGE
//! ```
//!
//! A slot holds its brick's (BRICK + 1)³ points and [`APRON`] more on every side (the central
//! differences of smooth normals), clamped at the grid's faces; point `p` read for a cell of
//! brick `b` sits at `p - (b BRICK - APRON)` in the slot.
//!
//! Which bricks may be left out, so that images stay bit for bit those of the whole grid:
//! - **analytic**: a brick whose value range is clear of every isovalue by the skipping margin
//!   holds no crossing, not even one of f32 rounding (`shaders/include/bricks.glsl`, `SKIP_MARGIN`);
//!   the walk goes through it without evaluating its cells, as through another MPI rank's block,
//!   and re-evaluates the carried value on entering a resident cell (same bits: face values
//!   depend on the face's corners only). Only the *active* bricks are resident.
//! - **fixed-step**: samples in a left-out brick read as the brick's minimum, on the same side
//!   of every isovalue as every value in it, so the march and its bisections take the same
//!   path; only the two samples that end the refinement enter the hit's interpolation, and they
//!   lie within one bracket (a step / 2^8) of the crossing, in an active brick or a neighbour of
//!   one. The active bricks and their 26 neighbours are resident, so the image is the whole
//!   grid's whenever a step is shorter than 2^8 BRICK = 2048 cells (always, in practice).
//!
//! The cap (`ISOVIEW_MAX_GRID_MIB`) applies to what the device holds: the resident slots and
//! the brick tables (12 bytes a brick), the tables checked before the file is scanned.

use std::sync::Arc;

use ash::vk;
use rayon::prelude::*;

use crate::field::interpolant::{SMOOTH_NORMAL_REACH, STENCIL};
use crate::field::parts::{self, Parts};
use crate::field::{FieldError, GridLimits};
use crate::gpu::{Buffer, Context, GpuError, MemoryLocation, Tracker};
use crate::passes::bricks::{brick_counts, clear_by, BRICK, SKIP_MARGIN};
use crate::shaders;

/// Points a slot holds around its brick's points, per side.
pub const APRON: usize = shaders::consts::POOL_APRON as usize;

/// Points per edge of a slot.
pub const SLOT: usize = BRICK + 1 + 2 * APRON;

// The apron covers what a cell of the brick reads beyond the brick's BRICK + 1 points (its
// stencil) plus the smooth normals' central differences. build.rs keeps the number (the shaders
// need it at compile time); this holds it to the stencil.
const _: () = {
    let s = STENCIL;
    let beyond = if s.below > s.above - 1 { s.below } else { s.above - 1 };
    assert!(APRON >= beyond + SMOOTH_NORMAL_REACH);
};

/// Page table entry of a brick not in the pool.
pub const NO_PAGE: u32 = shaders::consts::NO_PAGE;

/// A brick is left out when its range is clear of every isovalue by this, relative to the
/// magnitudes involved: twice the analytic walk's [`SKIP_MARGIN`] (2^-10), so every brick left
/// out is one the walk's rounding cannot cross (the margin there has a factor of 30 to spare).
pub const CLEAR_MARGIN: f32 = 2.0 * SKIP_MARGIN;

/// Whether a brick of value range `mm` is clear of isovalue `iso` (its threshold as the shaders
/// get it).
pub fn clear(mm: [f32; 2], iso: f32) -> bool {
    clear_by(mm, iso, CLEAR_MARGIN)
}

/// Device bytes per brick of the brick tables: the min/max grid (8) and the page table (4).
pub const TABLE_BYTES: u64 = 12;

/// Refuses, before the file is scanned, a grid whose brick tables alone are over the cap.
pub fn check_tables(dims: [usize; 3], limits: &GridLimits, what: &str) -> Result<(), FieldError> {
    let bricks = brick_counts(dims).iter().map(|&n| n as u64).product::<u64>();
    let bytes = bricks.saturating_mul(TABLE_BYTES);
    if bytes > limits.max_bytes {
        return Err(FieldError::TablesTooLarge {
            what: what.to_string(),
            dims,
            bricks,
            bytes,
            cap: limits.max_bytes,
        });
    }
    Ok(())
}

/// Which bricks are in the pool.
#[derive(Clone, Debug, PartialEq)]
pub struct Residency {
    /// Bricks per axis.
    pub counts: [usize; 3],
    /// Per brick (x fastest): its slot, or [`NO_PAGE`].
    pub pages: Vec<u32>,
    /// The resident bricks, in slot order.
    pub resident: Vec<[usize; 3]>,
    /// Bricks that hold a crossing (before the fixed-step neighbours are added).
    pub active: usize,
}

impl Residency {
    /// The bricks of a grid of `dims` points (ranges from [`MappedGrid::brick_ranges`]) that a
    /// render of the isovalue thresholds `thresholds` needs; with `neighbours` (fixed-step) also
    /// every brick next to one (faces, edges, corners).
    pub fn select(
        dims: [usize; 3],
        ranges: &[[f32; 2]],
        thresholds: &[f32],
        neighbours: bool,
    ) -> Residency {
        let counts = brick_counts(dims);
        let index = |b: [usize; 3]| b[0] + counts[0] * (b[1] + counts[1] * b[2]);
        let is_active: Vec<bool> =
            ranges.iter().map(|&mm| thresholds.iter().any(|&iso| !clear(mm, iso))).collect();
        let active = is_active.iter().filter(|&&a| a).count();
        let mut keep = is_active.clone();
        if neighbours {
            for (n, _) in is_active.iter().enumerate().filter(|(_, &a)| a) {
                let b = [n % counts[0], (n / counts[0]) % counts[1], n / (counts[0] * counts[1])];
                let span = |a: usize| b[a].saturating_sub(1)..=(b[a] + 1).min(counts[a] - 1);
                for z in span(2) {
                    for y in span(1) {
                        for x in span(0) {
                            keep[index([x, y, z])] = true;
                        }
                    }
                }
            }
        }
        let mut pages = vec![NO_PAGE; keep.len()];
        let mut resident = Vec::new();
        for (n, _) in keep.iter().enumerate().filter(|(_, &k)| k) {
            pages[n] = resident.len() as u32;
            resident.push([
                n % counts[0],
                (n / counts[0]) % counts[1],
                n / (counts[0] * counts[1]),
            ]);
        }
        Residency { counts, pages, resident, active }
    }

    /// Bytes of the pool.
    pub fn pool_bytes(&self) -> u64 {
        self.resident.len() as u64 * (SLOT * SLOT * SLOT * 4) as u64
    }

    /// Refuses a pool over the cap (with the brick tables), naming what it would need.
    pub fn check(&self, limits: &GridLimits, what: &str) -> Result<(), FieldError> {
        let bytes = self.pool_bytes() + self.pages.len() as u64 * TABLE_BYTES;
        if bytes > limits.max_bytes {
            return Err(FieldError::PoolTooLarge {
                what: what.to_string(),
                resident: self.resident.len(),
                bricks: self.pages.len(),
                bytes,
                cap: limits.max_bytes,
            });
        }
        Ok(())
    }
}

/// The slot of brick `b`: its points and [`APRON`] more per side, x fastest, [`SLOT`]³ values;
/// positions past the grid's faces repeat the nearest point (nothing reads them with weight).
/// Fails if the file shrank since it was opened.
pub fn slot(grid: &dyn Parts, b: [usize; 3]) -> Result<Vec<f32>, FieldError> {
    let dims = grid.dims();
    // The slot's first point, per axis (may be -APRON), and the points of the grid it covers.
    let first = [0, 1, 2].map(|a| (b[a] * BRICK) as i64 - APRON as i64);
    let lo = [0, 1, 2].map(|a| first[a].max(0) as usize);
    let hi = [0, 1, 2].map(|a| ((first[a] + SLOT as i64 - 1) as usize).min(dims[a] - 1));
    let n = [0, 1, 2].map(|a| hi[a] - lo[a] + 1);
    let values = grid.read_box(lo, n)?;
    let mut out = Vec::with_capacity(SLOT * SLOT * SLOT);
    let clamp = |a: usize, l: usize| {
        let p = (first[a] + l as i64).clamp(lo[a] as i64, hi[a] as i64) as usize;
        p - lo[a]
    };
    for z in 0..SLOT {
        for y in 0..SLOT {
            for x in 0..SLOT {
                out.push(values[clamp(0, x) + n[0] * (clamp(1, y) + n[1] * clamp(2, z))]);
            }
        }
    }
    Ok(out)
}

/// The pool and page table on the device.
pub struct Pool {
    pub pool: Buffer,
    pub pages: Buffer,
    pub residency: Residency,
}

/// Slots per staging chunk (about 21 MiB): the host holds one chunk at a time.
const CHUNK_SLOTS: usize = 4096;

impl Pool {
    /// Reads every resident brick of `grid` into slots and uploads them, a chunk at a time.
    pub fn upload(
        ctx: &Arc<Context>,
        grid: &dyn Parts,
        residency: Residency,
    ) -> Result<Pool, PoolError> {
        let slot_bytes = (SLOT * SLOT * SLOT * 4) as u64;
        let pool = Buffer::new(
            ctx,
            "brick pool",
            residency.pool_bytes(),
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        let chunk = CHUNK_SLOTS.min(residency.resident.len()).max(1);
        let mut staging = Buffer::new(
            ctx,
            "brick pool staging",
            chunk as u64 * slot_bytes,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        for (c, bricks) in residency.resident.chunks(chunk).enumerate() {
            let slots: Vec<Vec<f32>> =
                bricks.par_iter().map(|&b| slot(grid, b)).collect::<Result<_, _>>()?;
            staging.write(&slots.concat())?;
            let offset = (c * chunk) as u64 * slot_bytes;
            let bytes = bricks.len() as u64 * slot_bytes;
            ctx.record("upload brick pool", &mut Tracker::default(), |rec| {
                rec.copy(&staging, 0, &pool, offset, bytes);
                // The ray passes of later submissions read the pool.
                rec.release();
                Ok(())
            })?;
        }
        let pages = Buffer::upload(
            ctx,
            "page table",
            &residency.pages,
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        Ok(Pool { pool, pages, residency })
    }
}

/// A grid held as a brick pool, ready for [`super::Renderer::render_to`].
pub struct PooledGrid {
    /// The grid's geometry (dims and box, no values): what the render path reads of it.
    pub shape: crate::field::Grid,
    pub gpu: super::GpuGrid,
    /// One line for the log: what is resident and what it cost.
    pub summary: String,
}

/// Why a grid could not be pooled.
#[derive(Debug, thiserror::Error)]
pub enum PoolError {
    #[error(transparent)]
    Field(#[from] FieldError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("{0}")]
    Refused(String),
}

/// Whether `scene` renders from a brick pool read in parts: a `.vdb`/`.nvdb` tree (sparse by
/// default), or a raw/npy file under `field.residency = "active"`, or `"auto"` with the whole
/// grid over the cap; the grid to read, or None to sample it whole.
pub fn mapped_for(
    scene: &crate::scene::Scene,
    limits: &GridLimits,
) -> Result<Option<Box<dyn Parts>>, PoolError> {
    let Some(grid) = parts::for_residency(&scene.field, limits)? else { return Ok(None) };
    let refusal = scene.interpolation_refusal(crate::field::interpolant::Reader::BrickPool);
    let mesh = scene.render.method == crate::scene::Method::Mesh;
    if parts::is_sparse(&scene.field) {
        // Sparse where the pool can read it; otherwise the box densified, under the cap.
        let Some(why) = refusal
            .or_else(|| mesh.then(|| "render.method = \"mesh\" needs the whole grid".to_string()))
        else {
            return Ok(Some(grid));
        };
        return match limits.check(grid.dims().map(|d| d as u64), &grid.label()) {
            Ok(_) => Ok(None),
            Err(e) => Err(PoolError::Refused(format!(
                "{e}; {why} (the ray methods with trilinear interpolation read a .vdb or .nvdb \
                 grid sparsely, and so does `isoview extract`)"
            ))),
        };
    }
    if let Some(why) = refusal {
        return Err(PoolError::Refused(why));
    }
    if mesh {
        // Under "auto" (the default) the user asked for nothing: say why the grid is too large
        // (the cap's own message) and which paths read it in parts.
        if scene.field.residency == crate::field::Residency::Auto {
            let over = limits.check(grid.dims().map(|d| d as u64), &grid.label()).err();
            let why = over.map_or_else(|| grid.label(), |e| e.to_string());
            return Err(PoolError::Refused(format!(
                "{why}; render.method = \"mesh\" needs the whole grid (a ray method or \
                 `isoview extract` reads a grid over the cap in parts)"
            )));
        }
        return Err(PoolError::Refused(
            "field.residency = \"active\": render.method = \"mesh\" needs the whole grid; use \
             `isoview extract`, which streams the file, or a ray method"
                .into(),
        ));
    }
    Ok(Some(grid))
}

/// Scans `grid`, picks the bricks `scene`'s isovalues need, checks them against the cap and
/// uploads them.
pub fn upload_for(
    ctx: &Arc<Context>,
    scene: &crate::scene::Scene,
    grid: &dyn Parts,
    limits: &GridLimits,
) -> Result<PooledGrid, PoolError> {
    let started = std::time::Instant::now();
    let shape = grid.shape();
    check_tables(grid.dims(), limits, &grid.label())?;
    let ranges = grid.brick_ranges(BRICK)?;
    let scanned = started.elapsed();
    let thresholds = super::params::RenderParams::new(scene, &shape).surface_thresholds();
    let neighbours = scene.render.method == crate::scene::Method::FixedStep;
    let residency = Residency::select(grid.dims(), &ranges, &thresholds, neighbours);
    residency.check(limits, &grid.label())?;
    let (active, bricks) = (residency.active, residency.pages.len());
    let (resident, pool_mib) =
        (residency.resident.len(), residency.pool_bytes() as f64 / (1 << 20) as f64);
    let gpu = super::GpuGrid::upload_pool(ctx, grid, &ranges, residency)?;
    let summary = format!(
        "{}x{}x{} grid {} ({} MiB as dense f32): {active} of {bricks} bricks of {BRICK}^3 \
         cells active, {resident} resident, {pool_mib:.1} MiB pool (scan {:.1} s, upload {:.1} s)",
        grid.dims()[0],
        grid.dims()[1],
        grid.dims()[2],
        grid.how(),
        grid.f32_bytes() >> 20,
        scanned.as_secs_f64(),
        (started.elapsed() - scanned).as_secs_f64(),
    );
    Ok(PooledGrid { shape, gpu, summary })
}
