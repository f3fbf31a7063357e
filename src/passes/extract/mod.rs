//! Isosurface extraction passes (`shaders/extract/`): classify → scan → emit, one slab of z
//! layers at a time. [`driver`] drives them; this module owns the shaders, their
//! bindings and push constants, the tables upload and the multi-level prefix sum.
//!
//! | pass | shader | one invocation per | writes |
//! | --- | --- | --- | --- |
//! | `values` | `values.comp` | padded point | the slab's samples, gathered from the grid image into a buffer |
//! | `classify` | `classify.comp` | padded point | point mask (inside bit, crossed families); counts: per point MC/MT vertices or dual quads, per cell MC/MT triangles or dual vertices |
//! | `scan`, `scan add` | `scan.comp`, `scan_add.comp` | 4 elements | exclusive prefix sums in place |
//! | `edge vertices` | `edge_vertices.comp` | vertex | MC/MT: the vertex of a crossed edge |
//! | `marching cubes` / `marching tetrahedra` | `mc.comp` / `mt.comp` | triangle | the triangle |
//! | `dual cells` | `dual_cells.comp` | vertex | SN/DC: the vertex of an active cell |
//! | `dual quads` | `dual_quads.comp` | quad | SN/DC: two triangles |
//! | `mc33 count` | `mc33_count.comp` | crossed cell | MC33: the cell's triangles and added vertices (f64) |
//! | `mc33 emit` | `mc33_emit.comp` | crossed cell | MC33: the cell's triangles and added vertices |
//! | `mc33 fixup` | `mc33_fixup.comp` | index | MC33: added-vertex placeholders → final ids |
//!
//! The emit passes (the last four) find the owner of their output item (the point or cell
//! whose scanned count range holds it) by bisection of the scan, so their work follows the
//! output, not the grid.
//!
//! Every extraction pass binds the same twelve resources ([`EXTRACT_BINDINGS`], given by
//! [`ExtractIo`]) and takes [`SlabPush`]; a pass that does not use a binding still gets a
//! (dummy) buffer there. Each [`ExtractPass`] declares which of them it writes (the table
//! above); it reads the others, and the recorder derives the barriers between passes from that.
//! [`plan`] holds the GPU-free slab arithmetic, [`driver`] records and submits.

pub mod driver;
pub mod plan;

pub use driver::{extract, ExtractStats, Extractor, GpuExtractOptions, GpuMesh};

use std::sync::Arc;

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::gpu::{
    spread_groups, Buffer, Compute, ComputePipeline, Context, Dispatch, GpuError, Image3d,
    MemoryLocation, Recorder, Resource,
};
use crate::mesh::{tables, MeshError};
use crate::shaders;

/// Why a GPU extraction failed.
#[derive(Debug, thiserror::Error)]
pub enum GpuMeshError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Mesh(#[from] MeshError),
    #[error(
        "render.mesh = \"{0}\" needs 64-bit floats (shaderFloat64) on the GPU, which this device \
         lacks; extract it on the CPU (--device cpu)"
    )]
    Unsupported(&'static str),
    #[error("render.mesh = \"{0}\" has no GPU extraction; extract it on the CPU (--device cpu)")]
    CpuOnly(&'static str),
}

/// Workgroup size of the extraction passes (`local_size_x`).
pub const GROUP: u32 = shaders::consts::EXTRACT_GROUP;
/// Elements scanned by one workgroup of `scan.comp` (64 invocations × 16).
pub const SCAN_BLOCK: u64 = shaders::consts::SCAN_BLOCK as u64;

/// Bindings of every extraction pass, in order: params (uniform), grid (3D image), point masks,
/// point scan, cell scan, tables, positions, normals, indices, values, added scan, triangle scan
/// (storage).
pub const EXTRACT_BINDINGS: [vk::DescriptorType; 12] = [
    vk::DescriptorType::UNIFORM_BUFFER,
    vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
];

/// std140 mirror of `Params` in `shaders/extract/common.glsl` (vec4 members only, so std140 is
/// the C layout).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ExtractParams {
    /// Grid points per axis; w: padding layers (1 for dual contouring, else 0).
    pub dims: [i32; 4],
    /// World position of grid point (0, 0, 0).
    pub box_min: [f32; 4],
    /// World size of one cell.
    pub spacing: [f32; 4],
    /// x: inside threshold (see [`inside_threshold`]); y, z: the isovalue as f32 hi + lo; w: +1
    /// for inside = below, -1 for above.
    pub iso: [f32; 4],
    /// x, y: the bits of the f64 isovalue, low word first (`packDouble2x32`); the mc33 passes
    /// decide topology in f64 as the CPU reference does. z: `dual-contouring-qef` flags (bit 0
    /// on, bit 1 clamp into the cell), w: its singular-value threshold's f32 bits.
    pub iso_bits: [u32; 4],
}

const _: () = {
    assert!(std::mem::size_of::<ExtractParams>() == 80);
    assert!(std::mem::offset_of!(ExtractParams, iso) == 48);
    assert!(std::mem::offset_of!(ExtractParams, iso_bits) == 64);
};

/// Push constants of the extraction passes (`Push` in `common.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SlabPush {
    /// Workgroups along x of the dispatch (1D work spread over x and y).
    pub groups_x: u32,
    /// Items (points, cells, vertices or triangles) in the dispatch.
    pub count: u32,
    /// Padded z layer of the first item.
    pub z0: i32,
    /// Padded point layer of the slab's first point.
    pub point_z0: i32,
    /// Padded cell layer of the slab's first cell.
    pub cell_z0: i32,
    /// Slab index of the first point the slab owns.
    pub owned_point: u32,
    /// Slab index of the first cell the slab owns.
    pub owned_cell: u32,
    /// Global id of the slab's first vertex.
    pub vertex_base: u32,
    /// Pass-specific mode.
    pub mode: u32,
    /// Padded point layer of the slab's first sample in the values buffer.
    pub value_z0: i32,
    /// Slab index one past the last point the slab owns.
    pub owned_point_end: u32,
    /// Slab index one past the last cell the slab owns.
    pub owned_cell_end: u32,
    /// MC33: global number of the slab's first added vertex (among all added vertices).
    pub added_base: u32,
    /// MC33: where the slab's added vertices start in its output (after its edge vertices).
    pub added_offset: u32,
}

const _: () = assert!(std::mem::size_of::<SlabPush>() == 56);

/// Push constants of the scan passes (`Push` in `scan.comp` and `scan_add.comp`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ScanPush {
    pub groups_x: u32,
    pub count: u32,
}

/// The lookup tables of [`crate::mesh::tables`] as the shaders read them: `Tables` in
/// `common.glsl`, std430 arrays of `int` (stride 4, so the C layout).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct ExtractTables {
    pub mc_triangles: [[i32; 16]; 256],
    pub mc_edges: [[i32; 2]; 12],
    pub mc_vertex_corner: [i32; 8],
    pub mt_tets: [[i32; 4]; 6],
    pub mt_tet_edges: [[i32; 2]; 6],
    pub mt_triangles: [[i32; 6]; 16],
    /// `mc_edge_index[8 a + b]`: the Bourke number of the cell edge between corners `a` and
    /// `b`, -1 where they share no edge (MC33's face walks).
    pub mc_edge_index: [i32; 64],
}

const _: () = {
    assert!(std::mem::offset_of!(ExtractTables, mc_edges) == 256 * 16 * 4);
    assert!(std::mem::offset_of!(ExtractTables, mc_vertex_corner) == (4096 + 24) * 4);
    assert!(std::mem::offset_of!(ExtractTables, mt_tets) == (4096 + 24 + 8) * 4);
    assert!(std::mem::offset_of!(ExtractTables, mt_tet_edges) == (4096 + 24 + 8 + 24) * 4);
    assert!(std::mem::offset_of!(ExtractTables, mt_triangles) == (4096 + 24 + 8 + 24 + 12) * 4);
    assert!(
        std::mem::offset_of!(ExtractTables, mc_edge_index) == (4096 + 24 + 8 + 24 + 12 + 96) * 4
    );
    assert!(std::mem::size_of::<ExtractTables>() == (4096 + 24 + 8 + 24 + 12 + 96 + 64) * 4);
};

impl ExtractTables {
    /// The very arrays the CPU reference uses, widened to `i32`.
    pub fn new() -> Self {
        let mut t = ExtractTables::zeroed();
        for (row, src) in t.mc_triangles.iter_mut().zip(&tables::MC_TRIANGLES) {
            *row = src.map(i32::from);
        }
        for (e, &(corner, axis)) in t.mc_edges.iter_mut().zip(&tables::MC_EDGES) {
            *e = [i32::from(corner), i32::from(axis)];
        }
        t.mc_vertex_corner = tables::MC_VERTEX_CORNER.map(i32::from);
        for (tet, src) in t.mt_tets.iter_mut().zip(&tables::MT_TETS) {
            *tet = src.map(i32::from);
        }
        for (e, &(a, b)) in t.mt_tet_edges.iter_mut().zip(&tables::MT_TET_EDGES) {
            *e = [i32::from(a), i32::from(b)];
        }
        for (row, src) in t.mt_triangles.iter_mut().zip(&tables::MT_TRIANGLES) {
            *row = src.map(i32::from);
        }
        t.mc_edge_index = [-1; 64];
        for (e, &(corner, axis)) in tables::MC_EDGES.iter().enumerate() {
            let (a, b) = (usize::from(corner), usize::from(corner | (1 << axis)));
            t.mc_edge_index[8 * a + b] = e as i32;
            t.mc_edge_index[8 * b + a] = e as i32;
        }
        t
    }
}

impl Default for ExtractTables {
    fn default() -> Self {
        Self::new()
    }
}

/// The f32 threshold `t` for which `v < t` (inside = below) or `v > t` (above) equals the f64
/// comparison of every f32 `v` with `iso`: the smallest f32 ≥ `iso` for below, the largest
/// f32 ≤ `iso` for above (infinite beyond the f32 range).
pub fn inside_threshold(iso: f64, below: bool) -> f32 {
    let t = iso as f32; // round to nearest
    let t64 = f64::from(t);
    if below && t64 < iso {
        next_toward(t, 1.0)
    } else if !below && t64 > iso {
        next_toward(t, -1.0)
    } else {
        t
    }
}

/// The f32 after finite `t` in the direction of `sign` (`f32::next_up` / `next_down`, which
/// need a newer Rust than the crate's minimum).
fn next_toward(t: f32, sign: f32) -> f32 {
    if t == 0.0 {
        return f32::from_bits(1).copysign(sign);
    }
    let bits = t.to_bits();
    if (t > 0.0) == (sign > 0.0) {
        f32::from_bits(bits + 1)
    } else {
        f32::from_bits(bits - 1)
    }
}

/// Modes of `classify.comp`.
pub mod classify_mode {
    use crate::shaders::consts;
    pub const MC: u32 = consts::MODE_MC;
    pub const MT: u32 = consts::MODE_MT;
    pub const DUAL: u32 = consts::MODE_DUAL;
    pub const MC33: u32 = consts::MODE_MC33;
}

/// A buffer binding of the extraction passes that some pass writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    PointMask,
    PointScan,
    CellScan,
    Positions,
    Normals,
    Indices,
    Values,
    AddedScan,
    TriScan,
}

/// The resources of an extraction pass, in the roles of [`EXTRACT_BINDINGS`].
#[derive(Clone, Copy)]
pub struct ExtractIo<'a> {
    pub params: &'a Buffer,
    pub grid: &'a Image3d,
    pub point_mask: &'a Buffer,
    pub point_scan: &'a Buffer,
    pub cell_scan: &'a Buffer,
    pub tables: &'a Buffer,
    pub positions: &'a Buffer,
    pub normals: &'a Buffer,
    pub indices: &'a Buffer,
    pub values: &'a Buffer,
    pub added_scan: &'a Buffer,
    pub tri_scan: &'a Buffer,
}

impl<'a> ExtractIo<'a> {
    fn slot(&self, slot: Slot) -> &'a Buffer {
        match slot {
            Slot::PointMask => self.point_mask,
            Slot::PointScan => self.point_scan,
            Slot::CellScan => self.cell_scan,
            Slot::Positions => self.positions,
            Slot::Normals => self.normals,
            Slot::Indices => self.indices,
            Slot::Values => self.values,
            Slot::AddedScan => self.added_scan,
            Slot::TriScan => self.tri_scan,
        }
    }

    /// The storage buffers, in binding order.
    fn storage(&self) -> [&'a Buffer; 10] {
        [
            self.point_mask,
            self.point_scan,
            self.cell_scan,
            self.tables,
            self.positions,
            self.normals,
            self.indices,
            self.values,
            self.added_scan,
            self.tri_scan,
        ]
    }
}

/// One extraction pass: its pipeline and the bindings it writes.
pub struct ExtractPass {
    pub pipeline: ComputePipeline,
    writes: &'static [Slot],
}

/// An extraction pass bound to its resources.
pub struct BoundExtract<'a> {
    pass: &'a ExtractPass,
    set: Dispatch,
    io: ExtractIo<'a>,
}

impl ExtractPass {
    fn new(
        ctx: &Arc<Context>,
        name: &str,
        spirv: &[u8],
        writes: &'static [Slot],
    ) -> Result<Self, GpuError> {
        let push = std::mem::size_of::<SlabPush>() as u32;
        let pipeline = ComputePipeline::new(ctx, name, spirv, &EXTRACT_BINDINGS, push)?;
        Ok(ExtractPass { pipeline, writes })
    }

    pub fn bind<'a>(&'a self, io: ExtractIo<'a>) -> Result<BoundExtract<'a>, GpuError> {
        let mut resources = vec![Resource::Uniform(io.params), Resource::Sampled(io.grid)];
        resources.extend(io.storage().map(Resource::Storage));
        Ok(BoundExtract { pass: self, set: self.pipeline.bind(&resources)?, io })
    }
}

impl BoundExtract<'_> {
    /// Records the pass over `push.count` items (one invocation each, [`GROUP`] per workgroup,
    /// spread over x and y); nothing when there are none.
    pub fn record(&self, rec: &mut Recorder, mut push: SlabPush) -> Result<(), GpuError> {
        if push.count == 0 {
            return Ok(());
        }
        let groups = spread_groups(u64::from(push.count).div_ceil(u64::from(GROUP)))?;
        push.groups_x = groups[0];
        let writes: Vec<&Buffer> = self.pass.writes.iter().map(|&w| self.io.slot(w)).collect();
        let mut reads = vec![self.io.params];
        let written = |b: &&Buffer| writes.iter().any(|w| w.raw == b.raw);
        reads.extend(self.io.storage().into_iter().filter(|b| !written(b)));
        rec.dispatch(&Compute {
            pipeline: &self.pass.pipeline,
            set: &self.set,
            push: bytemuck::bytes_of(&push),
            groups,
            reads: &reads,
            writes: &writes,
        });
        Ok(())
    }
}

/// The extraction pipelines.
pub struct ExtractPasses {
    pub values: ExtractPass,
    pub classify: ExtractPass,
    pub edge_vertices: ExtractPass,
    pub mc: ExtractPass,
    pub mt: ExtractPass,
    pub dual_cells: ExtractPass,
    pub dual_quads: ExtractPass,
    /// The MC33 passes, made on first use ([`Mc33Passes::new`]: their shaders are large, and
    /// compiling them cost lavapipe about a second that the other algorithms need not pay).
    pub mc33: Option<Mc33Passes>,
    scan: ComputePipeline,
    scan_add: ComputePipeline,
}

impl ExtractPasses {
    pub fn new(ctx: &Arc<Context>) -> Result<Self, GpuError> {
        use Slot::*;
        let extract = |name, spirv, writes| ExtractPass::new(ctx, name, spirv, writes);
        let scan_bindings = [vk::DescriptorType::STORAGE_BUFFER; 2];
        let scan_push = std::mem::size_of::<ScanPush>() as u32;
        Ok(ExtractPasses {
            values: extract("extract values", shaders::EXTRACT_VALUES, &[Values])?,
            classify: extract(
                "extract classify",
                shaders::EXTRACT_CLASSIFY,
                &[PointMask, PointScan, CellScan],
            )?,
            edge_vertices: extract(
                "extract edge vertices",
                shaders::EXTRACT_EDGE_VERTICES,
                &[Positions, Normals],
            )?,
            mc: extract("extract marching cubes", shaders::EXTRACT_MC, &[Indices])?,
            mt: extract("extract marching tetrahedra", shaders::EXTRACT_MT, &[Indices])?,
            dual_cells: extract(
                "extract dual cells",
                shaders::EXTRACT_DUAL_CELLS,
                &[Positions, Normals],
            )?,
            dual_quads: extract("extract dual quads", shaders::EXTRACT_DUAL_QUADS, &[Indices])?,
            mc33: None,
            scan: ComputePipeline::new(
                ctx,
                "extract scan",
                shaders::EXTRACT_SCAN,
                &scan_bindings,
                scan_push,
            )?,
            scan_add: ComputePipeline::new(
                ctx,
                "extract scan add",
                shaders::EXTRACT_SCAN_ADD,
                &scan_bindings,
                scan_push,
            )?,
        })
    }
}

/// The MC33 pipelines (their shaders use f64).
pub struct Mc33Passes {
    pub count: ExtractPass,
    pub emit: ExtractPass,
    pub fixup: ExtractPass,
}

impl Mc33Passes {
    /// The pipelines, or None where the device has no `shaderFloat64`.
    pub fn new(ctx: &Arc<Context>) -> Result<Option<Self>, GpuError> {
        use Slot::*;
        if !ctx.info.float64 {
            return Ok(None);
        }
        let extract = |name, spirv, writes| ExtractPass::new(ctx, name, spirv, writes);
        Ok(Some(Mc33Passes {
            count: extract(
                "extract mc33 count",
                shaders::EXTRACT_MC33_COUNT,
                &[TriScan, AddedScan],
            )?,
            emit: extract(
                "extract mc33 emit",
                shaders::EXTRACT_MC33_EMIT,
                &[Positions, Normals, Indices],
            )?,
            fixup: extract("extract mc33 fixup", shaders::EXTRACT_MC33_FIXUP, &[Indices])?,
        }))
    }
}

/// An exclusive prefix sum, in place, over up to `capacity` u32 of one buffer: `scan.comp` on
/// blocks of [`SCAN_BLOCK`], the block sums scanned the same way level by level until one block
/// remains, then `scan add` back down. Holds the block-sum buffers and descriptor sets.
pub struct Scan {
    /// Block-sum buffers, level 1 up.
    levels: Vec<Buffer>,
    /// Per level: (scan set, add set) over (level l, level l + 1).
    sets: Vec<(Dispatch, Dispatch)>,
    capacity: u64,
}

impl Scan {
    pub fn new(
        ctx: &Arc<Context>,
        passes: &ExtractPasses,
        name: &str,
        data: &Buffer,
        capacity: u64,
    ) -> Result<Self, GpuError> {
        let mut levels = Vec::new();
        for len in level_lengths(capacity).into_iter().skip(1) {
            levels.push(Buffer::new(
                ctx,
                &format!("{name} block sums {}", levels.len() + 1),
                len * 4,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::GpuOnly,
            )?);
        }
        let mut sets = Vec::new();
        for l in 0..levels.len() {
            let lower = if l == 0 { data } else { &levels[l - 1] };
            let upper = &levels[l];
            let bind = [Resource::Storage(lower), Resource::Storage(upper)];
            sets.push((passes.scan.bind(&bind)?, passes.scan_add.bind(&bind)?));
        }
        Ok(Scan { levels, sets, capacity })
    }

    /// Records the scan of the first `len` elements (`len <= capacity`) of `data` (the buffer
    /// the scan was made for).
    pub fn record(
        &self,
        rec: &mut Recorder,
        passes: &ExtractPasses,
        data: &Buffer,
        len: u64,
    ) -> Result<(), GpuError> {
        if len > self.capacity {
            return Err(GpuError::Bug(format!(
                "scan of {len} elements exceeds its capacity {}",
                self.capacity
            )));
        }
        if len == 0 {
            return Ok(());
        }
        let lens = level_lengths(len);
        let level = |l: usize| if l == 0 { data } else { &self.levels[l - 1] };
        // Up: scan each level with more than one element, writing block sums one level up.
        for (l, &n) in lens[..lens.len() - 1].iter().enumerate() {
            let (set, rw) = (&self.sets[l].0, [level(l), level(l + 1)]);
            Self::dispatch(rec, &passes.scan, set, n, &[], &rw)?;
        }
        // Down: add the scanned sums of level l + 1 to level l (a single block's offset is 0).
        for l in (0..lens.len().saturating_sub(2)).rev() {
            let set = &self.sets[l].1;
            Self::dispatch(rec, &passes.scan_add, set, lens[l], &[level(l + 1)], &[level(l)])?;
        }
        Ok(())
    }

    /// One level: [`SCAN_BLOCK`] elements per workgroup, spread over x and y.
    fn dispatch(
        rec: &mut Recorder,
        pipeline: &ComputePipeline,
        set: &Dispatch,
        len: u64,
        reads: &[&Buffer],
        writes: &[&Buffer],
    ) -> Result<(), GpuError> {
        let groups = spread_groups(len.div_ceil(SCAN_BLOCK))?;
        let count = u32::try_from(len).map_err(|_| GpuError::TooLarge {
            what: format!("a scan of {len} elements"),
            limit: "32-bit counts".into(),
        })?;
        let push = ScanPush { groups_x: groups[0], count };
        let push = bytemuck::bytes_of(&push);
        rec.dispatch(&Compute { pipeline, set, push, groups, reads, writes });
        Ok(())
    }
}

/// Element counts per scan level: `len`, then `ceil(previous / SCAN_BLOCK)` down to a single
/// element (always at least two levels, so even one element is scanned).
fn level_lengths(len: u64) -> Vec<u64> {
    let mut lens = vec![len];
    loop {
        let next = lens[lens.len() - 1].div_ceil(SCAN_BLOCK).max(1);
        lens.push(next);
        if next == 1 {
            return lens;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inside_threshold_reproduces_the_f64_comparison() {
        let isos = [0.1, -0.1, 0.0, 1.0 / 3.0, 1e-40, -1e-40, 1e39, -1e39, 0.5, 16777217.0];
        for &iso in &isos {
            let t_below = inside_threshold(iso, true);
            let t_above = inside_threshold(iso, false);
            let near = iso as f32;
            let (up, down) = (next_toward(near, 1.0), next_toward(near, -1.0));
            let mut vs = vec![near, up, down, 0.0, -0.0, 1.0, -1.0, f32::from_bits(1)];
            vs.extend([f32::MAX, f32::MIN, f32::INFINITY, f32::NEG_INFINITY]);
            for v in vs {
                assert_eq!(v < t_below, f64::from(v) < iso, "below iso {iso} v {v}");
                assert_eq!(v > t_above, f64::from(v) > iso, "above iso {iso} v {v}");
            }
        }
    }

    #[test]
    fn next_toward_steps_one_ulp() {
        assert_eq!(next_toward(1.0, 1.0), 1.0 + f32::EPSILON);
        assert_eq!(next_toward(1.0, -1.0), 1.0 - f32::EPSILON / 2.0);
        assert_eq!(next_toward(-1.0, 1.0), -1.0 + f32::EPSILON / 2.0);
        assert_eq!(next_toward(0.0, -1.0), -f32::from_bits(1));
    }

    #[test]
    fn tables_widen_the_cpu_tables() {
        let t = ExtractTables::new();
        assert_eq!(t.mc_triangles[1][..4], [0, 8, 3, -1]);
        assert_eq!(t.mc_edges[11], [2, 2]);
        assert_eq!(t.mt_tets[5], [0, 6, 4, 7]);
        assert_eq!(t.mt_triangles[3], [1, 2, 4, 1, 4, 3]);
    }

    #[test]
    fn scan_levels_end_in_one_block() {
        assert_eq!(level_lengths(1), [1, 1]);
        assert_eq!(level_lengths(1024), [1024, 1]);
        assert_eq!(level_lengths(1025), [1025, 2, 1]);
        assert_eq!(level_lengths(1 << 30), [1 << 30, 1 << 20, 1 << 10, 1]);
    }
}
