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
use crate::passes::bricks::{brick_counts, clear_by, super_counts, BRICK, SKIP_MARGIN, SUPER};
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

/// Bytes per brick (or superbrick) of the brick tables: its range (8) and its page-table entry (4).
pub const TABLE_BYTES: u64 = 12;

/// Bricks per block of the tables: a superbrick's.
pub const BLOCK: usize = SUPER * SUPER * SUPER;

/// Refuses, before the file is scanned, a grid whose dense brick ranges are over the cap (a
/// raw or npy file's scan holds one range per brick).
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

/// Refuses, before a sparse tree is scanned, a grid whose superbrick tables alone are over the
/// cap (the blocks of bricks the isovalues need are checked with the pool).
pub fn check_super_tables(
    dims: [usize; 3],
    limits: &GridLimits,
    what: &str,
) -> Result<(), FieldError> {
    let supers = super_counts(dims).iter().map(|&n| n as u64).product::<u64>();
    let bytes = supers.saturating_mul(TABLE_BYTES);
    if bytes > limits.max_bytes {
        return Err(FieldError::SuperTablesTooLarge {
            what: what.to_string(),
            dims,
            supers,
            bytes,
            cap: limits.max_bytes,
        });
    }
    Ok(())
}

/// The bricks' value ranges of a grid read in parts, in two levels: every superbrick's range
/// (the smallest minimum and largest maximum of its bricks, as `bricks::levels`), and the
/// ranges of the bricks of the superbricks that hold a block ([`BLOCK`] a block, x fastest
/// within the superbrick; places past the grid's faces hold the empty range). A superbrick
/// without a block is clear of every isovalue, and so is each of its bricks (`clear` is
/// monotone: a range inside a clear range is clear), so none of their own ranges is needed.
#[derive(Clone, Debug, PartialEq)]
pub struct BrickRanges {
    /// Bricks and superbricks per axis.
    pub counts: [usize; 3],
    pub supers: [usize; 3],
    /// Per superbrick (x fastest) its range.
    pub super_ranges: Vec<[f32; 2]>,
    /// Per superbrick its block, or [`NO_PAGE`].
    pub blocks: Vec<u32>,
    /// [`BLOCK`] ranges per block.
    pub bricks: Vec<[f32; 2]>,
}

const EMPTY_RANGE: [f32; 2] = [f32::INFINITY, f32::NEG_INFINITY];

impl BrickRanges {
    /// Both levels from every brick's range (a raw or npy file's scan): every superbrick a block.
    pub fn from_dense(dims: [usize; 3], dense: &[[f32; 2]]) -> BrickRanges {
        let counts = brick_counts(dims);
        let supers = super_counts(dims);
        let levels = crate::passes::bricks::levels(dims, dense);
        let n_super = supers.iter().product::<usize>();
        let mut bricks = vec![EMPTY_RANGE; n_super * BLOCK];
        for (n, &mm) in dense.iter().enumerate() {
            let b = unflat(n, counts);
            bricks[block_entry(b, supers)] = mm;
        }
        BrickRanges {
            counts,
            supers,
            super_ranges: levels[dense.len()..].to_vec(),
            blocks: (0..n_super as u32).collect(),
            bricks,
        }
    }

    /// The range of brick `b`: its block's entry, or its superbrick's.
    pub fn brick(&self, b: [usize; 3]) -> [f32; 2] {
        let s = super_index(b, self.supers);
        match self.blocks[s] {
            NO_PAGE => self.super_ranges[s],
            k => self.bricks[k as usize * BLOCK + local_index(b)],
        }
    }
}

/// Index `n` of a grid with `counts` per axis (x fastest) as coordinates.
fn unflat(n: usize, counts: [usize; 3]) -> [usize; 3] {
    [n % counts[0], (n / counts[0]) % counts[1], n / (counts[0] * counts[1])]
}

/// The superbrick (index) of brick `b`.
fn super_index(b: [usize; 3], supers: [usize; 3]) -> usize {
    let s = b.map(|c| c / SUPER);
    s[0] + supers[0] * (s[1] + supers[1] * s[2])
}

/// Brick `b`'s place in its superbrick's block.
fn local_index(b: [usize; 3]) -> usize {
    let l = b.map(|c| c % SUPER);
    l[0] + SUPER * (l[1] + SUPER * l[2])
}

/// Brick `b`'s entry in tables holding a block for every superbrick, in superbrick order.
fn block_entry(b: [usize; 3], supers: [usize; 3]) -> usize {
    super_index(b, supers) * BLOCK + local_index(b)
}

/// Which bricks are in the pool, and the device's tables (`shaders/include/field.glsl`): per
/// superbrick its block or [`NO_PAGE`], then [`BLOCK`] entries per block (a brick's slot, or
/// [`NO_PAGE`]); the ranges likewise. A superbrick gets a block where it is not clear of every
/// isovalue or holds a resident brick; the others read as their superbrick's range (clear, so
/// every decision on one of their bricks is the one its own range gives). Hierarchical, the
/// tables grow with the superbricks (12 bytes each, a 32³-cell region) and the blocks near the
/// surface, not with the bricks of the box.
#[derive(Clone, Debug, PartialEq)]
pub struct Residency {
    /// Bricks and superbricks per axis.
    pub counts: [usize; 3],
    pub supers: [usize; 3],
    /// The page table: superbricks' blocks, then the blocks' slots.
    pub pages: Vec<u32>,
    /// The ranges in the same layout: superbricks', then the blocks' bricks' (emptied once on the
    /// device).
    pub ranges: Vec<[f32; 2]>,
    /// The resident bricks, in slot order.
    pub resident: Vec<[usize; 3]>,
    /// Bricks that hold a crossing (before the fixed-step neighbours are added).
    pub active: usize,
}

impl Residency {
    /// The bricks of a grid (`ranges`) that a render of the isovalue thresholds `thresholds`
    /// needs; with `neighbours` (fixed-step) also every brick next to one (faces, edges,
    /// corners). Every superbrick not clear of an isovalue must hold a block of `ranges`, and
    /// with `neighbours` every superbrick next to one.
    pub fn select(ranges: &BrickRanges, thresholds: &[f32], neighbours: bool) -> Residency {
        let (counts, supers) = (ranges.counts, ranges.supers);
        let needed = |mm: [f32; 2]| thresholds.iter().any(|&iso| !clear(mm, iso));
        let n_super = supers.iter().product::<usize>();
        // The bricks kept, per host block.
        let mut keep = vec![false; ranges.bricks.len()];
        let mut active = 0;
        let in_grid = |b: [usize; 3]| (0..3).all(|a| b[a] < counts[a]);
        let entry = |b: [usize; 3]| {
            let k = ranges.blocks[super_index(b, supers)];
            (k != NO_PAGE).then(|| k as usize * BLOCK + local_index(b))
        };
        let mut marks = Vec::new();
        for (s, &k) in ranges.blocks.iter().enumerate() {
            if k == NO_PAGE || !needed(ranges.super_ranges[s]) {
                continue;
            }
            let sb = unflat(s, supers);
            for l in 0..BLOCK {
                let lb = unflat(l, [SUPER; 3]);
                let b = [0, 1, 2].map(|a| sb[a] * SUPER + lb[a]);
                if !in_grid(b) || !needed(ranges.bricks[k as usize * BLOCK + l]) {
                    continue;
                }
                active += 1;
                marks.push(b);
            }
        }
        for &b in &marks {
            let span = |a: usize| {
                if neighbours {
                    b[a].saturating_sub(1)..=(b[a] + 1).min(counts[a] - 1)
                } else {
                    b[a]..=b[a]
                }
            };
            for z in span(2) {
                for y in span(1) {
                    for x in span(0) {
                        // The scan gave every superbrick next to a needed one a block.
                        if let Some(e) = entry([x, y, z]) {
                            keep[e] = true;
                        }
                    }
                }
            }
        }
        let mut pages = vec![NO_PAGE; n_super];
        let mut table = ranges.super_ranges.clone();
        let mut resident = Vec::new();
        for (s, &k) in ranges.blocks.iter().enumerate() {
            if k == NO_PAGE {
                continue;
            }
            let host = k as usize * BLOCK..(k as usize + 1) * BLOCK;
            if !needed(ranges.super_ranges[s]) && !keep[host.clone()].contains(&true) {
                continue;
            }
            pages[s] = ((pages.len() - n_super) / BLOCK) as u32;
            let sb = unflat(s, supers);
            for l in 0..BLOCK {
                let lb = unflat(l, [SUPER; 3]);
                let b = [0, 1, 2].map(|a| sb[a] * SUPER + lb[a]);
                table.push(ranges.bricks[host.start + l]);
                if keep[host.start + l] {
                    pages.push(resident.len() as u32);
                    resident.push(b);
                } else {
                    pages.push(NO_PAGE);
                }
            }
        }
        Residency { counts, supers, pages, ranges: table, resident, active }
    }

    /// Bricks of the grid.
    pub fn bricks(&self) -> usize {
        self.counts.iter().product()
    }

    /// Brick `b`'s slot, or [`NO_PAGE`] (as the shaders look it up).
    pub fn page(&self, b: [usize; 3]) -> u32 {
        let n_super = self.supers.iter().product::<usize>();
        match self.pages[super_index(b, self.supers)] {
            NO_PAGE => NO_PAGE,
            k => self.pages[n_super + k as usize * BLOCK + local_index(b)],
        }
    }

    /// Bytes of the pool.
    pub fn pool_bytes(&self) -> u64 {
        self.resident.len() as u64 * (SLOT * SLOT * SLOT * 4) as u64
    }

    /// Bytes of the tables on the device (the ranges as many as the page-table entries).
    pub fn table_bytes(&self) -> u64 {
        self.pages.len() as u64 * TABLE_BYTES
    }

    /// Refuses a pool over the cap (with the brick tables), naming what it would need.
    pub fn check(&self, limits: &GridLimits, what: &str) -> Result<(), FieldError> {
        let bytes = self.pool_bytes() + self.table_bytes();
        if bytes > limits.max_bytes {
            return Err(FieldError::PoolTooLarge {
                what: what.to_string(),
                resident: self.resident.len(),
                bricks: self.bricks(),
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

/// The ranges of `grid`'s bricks a selection for `thresholds` needs ([`Residency::select`]):
/// a raw or npy file is scanned whole, one range per brick (its tables checked against the cap
/// first); a sparse tree superbrick by superbrick, then the bricks of the superbricks not clear
/// of every isovalue (with `neighbours`, and of those next to them), so that its tables grow
/// with the superbricks and the surface, never with the bricks of the box.
pub fn scan(
    grid: &dyn Parts,
    thresholds: &[f32],
    neighbours: bool,
    limits: &GridLimits,
) -> Result<BrickRanges, FieldError> {
    let (dims, label) = (grid.dims(), grid.label());
    let Some(tree) = grid.sparse() else {
        check_tables(dims, limits, &label)?;
        return Ok(BrickRanges::from_dense(dims, &grid.brick_ranges(BRICK)?));
    };
    check_super_tables(dims, limits, &label)?;
    let super_ranges = tree.super_ranges(BRICK, SUPER, grid.nan(), &label)?;
    let (counts, supers) = (brick_counts(dims), super_counts(dims));
    let needed = |mm: [f32; 2]| thresholds.iter().any(|&iso| !clear(mm, iso));
    let mut want = vec![false; super_ranges.len()];
    for s in (0..super_ranges.len()).filter(|&s| needed(super_ranges[s])) {
        let c = unflat(s, supers);
        let reach = usize::from(neighbours);
        let span = |a: usize| c[a].saturating_sub(reach)..=(c[a] + reach).min(supers[a] - 1);
        for z in span(2) {
            for y in span(1) {
                for x in span(0) {
                    want[x + supers[0] * (y + supers[1] * z)] = true;
                }
            }
        }
    }
    let listed: Vec<usize> = (0..want.len()).filter(|&s| want[s]).collect();
    // The blocks' ranges on the host, before any is computed: bounded by the cap.
    let bytes = (listed.len() * BLOCK) as u64 * TABLE_BYTES;
    if bytes > limits.max_bytes {
        return Err(FieldError::PoolTooLarge {
            what: label,
            resident: listed.len() * BLOCK,
            bricks: counts.iter().product(),
            bytes,
            cap: limits.max_bytes,
        });
    }
    let (nan, what) = (grid.nan(), label.as_str());
    let blocks: Vec<Result<Vec<[f32; 2]>, FieldError>> = listed
        .par_iter()
        .map(|&s| {
            let sb = unflat(s, supers);
            (0..BLOCK)
                .map(|l| {
                    let lb = unflat(l, [SUPER; 3]);
                    let b = [0, 1, 2].map(|a| sb[a] * SUPER + lb[a]);
                    match (0..3).all(|a| b[a] < counts[a]) {
                        true => tree.brick_range(b, BRICK, nan, what),
                        false => Ok(EMPTY_RANGE),
                    }
                })
                .collect()
        })
        .collect();
    let mut out = BrickRanges {
        counts,
        supers,
        super_ranges,
        blocks: vec![NO_PAGE; want.len()],
        bricks: Vec::with_capacity(listed.len() * BLOCK),
    };
    for (k, (&s, block)) in listed.iter().zip(blocks).enumerate() {
        out.blocks[s] = k as u32;
        out.bricks.extend(block?);
    }
    Ok(out)
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
    let thresholds = super::params::RenderParams::new(scene, &shape).surface_thresholds();
    let neighbours = scene.render.method == crate::scene::Method::FixedStep;
    let ranges = scan(grid, &thresholds, neighbours, limits)?;
    let scanned = started.elapsed();
    let residency = Residency::select(&ranges, &thresholds, neighbours);
    residency.check(limits, &grid.label())?;
    let (active, bricks) = (residency.active, residency.bricks());
    let (resident, pool_mib) =
        (residency.resident.len(), residency.pool_bytes() as f64 / (1 << 20) as f64);
    // Only the superbricks' ranges are kept (the walk's choice of levels): the blocks are in
    // the residency's tables.
    let BrickRanges { super_ranges, .. } = ranges;
    let largest = super::grid::largest_finite(super_ranges.iter().flatten().copied());
    if let Some(why) = super::grid::sample_bound_refusal(largest, scene.path.as_deref()) {
        return Err(PoolError::Refused(why));
    }
    let gpu = super::GpuGrid::upload_pool(ctx, grid, super_ranges, residency)?;
    let summary = format!(
        "{}x{}x{} grid {} ({} as dense f32): {active} of {bricks} bricks of {BRICK}^3 \
         cells active, {resident} resident, {pool_mib:.1} MiB pool (scan {:.1} s, upload {:.1} s)",
        grid.dims()[0],
        grid.dims()[1],
        grid.dims()[2],
        grid.how(),
        crate::field::mib(grid.f32_bytes() as u128),
        scanned.as_secs_f64(),
        (started.elapsed() - scanned).as_secs_f64(),
    );
    Ok(PooledGrid { shape, gpu, summary })
}
