//! The extraction passes ([`ExtractPasses`], [`Mc33Passes`]): each a shader, the twelve
//! bindings every pass shares ([`bindings`], filled from [`ExtractIo`]) and the ones it writes
//! ([`Slot`]), declared with its pipeline; [`BoundExtract::record`] dispatches one over its
//! items, and the recorder derives the barriers between passes from those declarations.

use std::sync::Arc;

use super::params::SlabPush;
use super::scan::ScanPush;
use crate::gpu::{
    spread_groups, Binding, Buffer, ComputePipeline, Context, Dispatch, GpuError, Image3d,
    Recorder, Resource,
};
use crate::shaders;

/// Workgroup size of the extraction passes (`local_size_x`).
pub const GROUP: u32 = shaders::consts::EXTRACT_GROUP;

/// The storage bindings of every extraction pass in binding order (after params and grid), as
/// the [`Slot`] a pass may write (`None`: the tables, only read).
const STORAGE: [Option<Slot>; 10] = [
    Some(Slot::PointMask),
    Some(Slot::PointScan),
    Some(Slot::CellScan),
    None,
    Some(Slot::Positions),
    Some(Slot::Normals),
    Some(Slot::Indices),
    Some(Slot::Values),
    Some(Slot::AddedScan),
    Some(Slot::TriScan),
];

/// Bindings of an extraction pass that writes `writes`, in order: params, grid, point masks,
/// point scan, cell scan, tables, positions, normals, indices, values, added scan, triangle
/// scan; the ones in `writes` are read and written, the others read.
pub fn bindings(writes: &[Slot]) -> [Binding; 12] {
    let mut b = [Binding::Read; 12];
    b[0] = Binding::Uniform;
    b[1] = Binding::Sampled;
    for (i, slot) in STORAGE.iter().enumerate() {
        if slot.is_some_and(|s| writes.contains(&s)) {
            b[2 + i] = Binding::ReadWrite;
        }
    }
    b
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

/// The resources of an extraction pass, in the roles of [`bindings`].
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
    /// The storage buffers, in binding order ([`STORAGE`]).
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

/// One extraction pass: its pipeline, made with the bindings it writes.
pub struct ExtractPass {
    pub pipeline: ComputePipeline,
}

/// An extraction pass bound to its resources.
pub struct BoundExtract<'a> {
    pass: &'a ExtractPass,
    set: Dispatch,
    /// Keeps the bound buffers borrowed while the set refers to them.
    _io: ExtractIo<'a>,
}

impl ExtractPass {
    fn new(
        ctx: &Arc<Context>,
        name: &str,
        spirv: &[u8],
        writes: &[Slot],
    ) -> Result<Self, GpuError> {
        let push = std::mem::size_of::<SlabPush>() as u32;
        let pipeline = ComputePipeline::new(ctx, name, spirv, &bindings(writes), push)?;
        Ok(ExtractPass { pipeline })
    }

    pub fn bind<'a>(&'a self, io: ExtractIo<'a>) -> Result<BoundExtract<'a>, GpuError> {
        let mut resources = vec![Resource::Uniform(io.params), Resource::Sampled(io.grid)];
        resources.extend(io.storage().map(Resource::Storage));
        Ok(BoundExtract { pass: self, set: self.pipeline.bind(&resources)?, _io: io })
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
        rec.dispatch(&self.pass.pipeline, &self.set, bytemuck::bytes_of(&push), groups);
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
    pub(super) scan: ComputePipeline,
    pub(super) scan_add: ComputePipeline,
}

impl ExtractPasses {
    pub fn new(ctx: &Arc<Context>) -> Result<Self, GpuError> {
        use Slot::*;
        let extract = |name, spirv, writes| ExtractPass::new(ctx, name, spirv, writes);
        // (level l, level l + 1): scan scans level l in place and writes its block sums one
        // level up; scan add adds level l + 1's scanned sums to level l.
        let scan_bindings = [Binding::ReadWrite, Binding::Write];
        let add_bindings = [Binding::ReadWrite, Binding::Read];
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
                &add_bindings,
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
