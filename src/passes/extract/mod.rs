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
//! Every extraction pass binds the same twelve resources ([`EXTRACT_BINDINGS`]) and takes
//! [`SlabPush`]; a pass that does not use a binding still gets a (dummy) buffer there.

pub mod driver;

pub use driver::{extract, ExtractStats, Extractor, GpuExtractOptions, GpuMesh, GpuMeshError};

use std::sync::Arc;

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::gpu::{
    memory_barrier, Buffer, ComputePipeline, Context, Dispatch, GpuError, MemoryLocation, Resource,
};
use crate::mesh::tables;
use crate::shaders;

/// Workgroup size of the extraction passes (`local_size_x`).
pub const GROUP: u32 = shaders::consts::EXTRACT_GROUP;
/// Elements scanned by one workgroup of `scan.comp` (64 invocations × 16).
pub const SCAN_BLOCK: u64 = shaders::consts::SCAN_BLOCK as u64;
/// Most workgroups along one dispatch axis that every Vulkan device accepts.
const MAX_GROUPS_X: u32 = 65535;

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
    /// decide topology in f64 as the CPU reference does. z, w: unused.
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

/// Push constants of the scan passes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
struct ScanPush {
    groups_x: u32,
    count: u32,
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

/// The extraction pipelines.
pub struct ExtractPasses {
    pub values: ComputePipeline,
    pub classify: ComputePipeline,
    pub edge_vertices: ComputePipeline,
    pub mc: ComputePipeline,
    pub mt: ComputePipeline,
    pub dual_cells: ComputePipeline,
    pub dual_quads: ComputePipeline,
    /// The MC33 passes, made on first use ([`Mc33Passes::new`]: their shaders are large, and
    /// compiling them cost lavapipe about a second that the other algorithms need not pay).
    pub mc33: Option<Mc33Passes>,
    scan: ComputePipeline,
    scan_add: ComputePipeline,
}

impl ExtractPasses {
    pub fn new(ctx: &Arc<Context>) -> Result<Self, GpuError> {
        let push = std::mem::size_of::<SlabPush>() as u32;
        let extract = |name: &str, spirv: &[u8]| {
            ComputePipeline::new(ctx, name, spirv, &EXTRACT_BINDINGS, push)
        };
        let scan_bindings = [vk::DescriptorType::STORAGE_BUFFER; 2];
        let scan_push = std::mem::size_of::<ScanPush>() as u32;
        Ok(ExtractPasses {
            values: extract("extract values", shaders::EXTRACT_VALUES)?,
            classify: extract("extract classify", shaders::EXTRACT_CLASSIFY)?,
            edge_vertices: extract("extract edge vertices", shaders::EXTRACT_EDGE_VERTICES)?,
            mc: extract("extract marching cubes", shaders::EXTRACT_MC)?,
            mt: extract("extract marching tetrahedra", shaders::EXTRACT_MT)?,
            dual_cells: extract("extract dual cells", shaders::EXTRACT_DUAL_CELLS)?,
            dual_quads: extract("extract dual quads", shaders::EXTRACT_DUAL_QUADS)?,
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
    pub count: ComputePipeline,
    pub emit: ComputePipeline,
    pub fixup: ComputePipeline,
}

impl Mc33Passes {
    /// The pipelines, or None where the device has no `shaderFloat64`.
    pub fn new(ctx: &Arc<Context>) -> Result<Option<Self>, GpuError> {
        if !ctx.info.float64 {
            return Ok(None);
        }
        let push = std::mem::size_of::<SlabPush>() as u32;
        let extract = |name: &str, spirv: &[u8]| {
            ComputePipeline::new(ctx, name, spirv, &EXTRACT_BINDINGS, push)
        };
        Ok(Some(Mc33Passes {
            count: extract("extract mc33 count", shaders::EXTRACT_MC33_COUNT)?,
            emit: extract("extract mc33 emit", shaders::EXTRACT_MC33_EMIT)?,
            fixup: extract("extract mc33 fixup", shaders::EXTRACT_MC33_FIXUP)?,
        }))
    }
}

/// Workgroups for `groups` groups of 1D work, spread over x and y: `(x, y)` with `x * y >=
/// groups` and `x <= 65535`.
pub fn groups_2d(groups: u64) -> Result<[u32; 2], GpuError> {
    let x = groups.clamp(1, u64::from(MAX_GROUPS_X));
    let y = groups.div_ceil(x).max(1);
    let y =
        u32::try_from(y).ok().filter(|&y| y <= MAX_GROUPS_X).ok_or_else(|| GpuError::TooLarge {
            what: format!("a pass of {groups} workgroups"),
            limit: format!("one dispatch ({MAX_GROUPS_X} x {MAX_GROUPS_X} workgroups)"),
        })?;
    Ok([x as u32, y])
}

/// Records `pipeline` over `push.count` items (one invocation each); nothing when there are none.
pub fn record_items(
    cmd: vk::CommandBuffer,
    pipeline: &ComputePipeline,
    set: &Dispatch,
    mut push: SlabPush,
) -> Result<(), GpuError> {
    if push.count == 0 {
        return Ok(());
    }
    let [x, y] = groups_2d(u64::from(push.count).div_ceil(u64::from(GROUP)))?;
    push.groups_x = x;
    pipeline.record(cmd, set, bytemuck::bytes_of(&push), [x, y, 1]);
    Ok(())
}

/// Compute writes → compute reads and writes.
pub fn compute_barrier(ctx: &Context, cmd: vk::CommandBuffer) {
    memory_barrier(
        ctx,
        cmd,
        (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_WRITE),
        (
            vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE,
        ),
    );
}

/// An exclusive prefix sum, in place, over up to `capacity` u32 of one buffer: `scan.comp` on
/// blocks of [`SCAN_BLOCK`], the block sums scanned the same way level by level until one block
/// remains, then `scan add` back down. Holds the block-sum buffers and descriptor sets.
pub struct Scan {
    /// Block-sum buffers, level 1 up.
    _levels: Vec<Buffer>,
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
        Ok(Scan { _levels: levels, sets, capacity })
    }

    /// Records the scan of the first `len` elements (`len <= capacity`); writes and reads are
    /// fenced by barriers before and after.
    pub fn record(
        &self,
        ctx: &Context,
        passes: &ExtractPasses,
        cmd: vk::CommandBuffer,
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
        // Up: scan each level with more than one element, writing block sums one level up.
        for (l, &n) in lens[..lens.len() - 1].iter().enumerate() {
            self.dispatch(ctx, &passes.scan, &self.sets[l].0, cmd, n)?;
        }
        // Down: add the scanned sums of level l + 1 to level l (a single block's offset is 0).
        for l in (0..lens.len().saturating_sub(2)).rev() {
            self.dispatch(ctx, &passes.scan_add, &self.sets[l].1, cmd, lens[l])?;
        }
        Ok(())
    }

    fn dispatch(
        &self,
        ctx: &Context,
        pipeline: &ComputePipeline,
        set: &Dispatch,
        cmd: vk::CommandBuffer,
        len: u64,
    ) -> Result<(), GpuError> {
        let [x, y] = groups_2d(len.div_ceil(SCAN_BLOCK))?;
        let count = u32::try_from(len).map_err(|_| GpuError::TooLarge {
            what: format!("a scan of {len} elements"),
            limit: "32-bit counts".into(),
        })?;
        let push = ScanPush { groups_x: x, count };
        pipeline.record(cmd, set, bytemuck::bytes_of(&push), [x, y, 1]);
        compute_barrier(ctx, cmd);
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

    #[test]
    fn groups_spread_over_two_axes() {
        assert_eq!(groups_2d(1).unwrap(), [1, 1]);
        assert_eq!(groups_2d(65535).unwrap(), [65535, 1]);
        assert_eq!(groups_2d(65536).unwrap(), [65535, 2]);
        assert!(groups_2d(65535u64 * 65535 + 1).is_err());
    }
}
