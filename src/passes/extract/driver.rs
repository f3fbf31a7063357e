//! Isosurface extraction on the GPU: the CPU references of [`crate::mesh`], reproduced index
//! for index by the compute passes of this module's parent (`shaders/extract/`), with the mesh
//! left on the device.
//!
//! # Pass structure
//!
//! Per slab of z layers, two submissions and one small readback:
//!
//! ```text
//!  count:  values ─► classify ─► scan(points) ─► scan(cells) ─► copy 4 counters ─► host
//!                     │ per point: mask + count; per cell: count
//!  host:   size the slab's output buffers from the counters (exactly)
//!  emit:   vertices (one invocation each) ─► triangles (one invocation each, or per quad)
//!          ─► slab output ─► (several slabs) copied into one mesh
//! ```
//!
//! * **values**: the slab's samples, one texelFetch each from the grid image into a storage
//!   buffer that the other passes read.
//! * **classify** (one invocation per lattice point of the slab): the inside bit and one bit
//!   per crossed edge family starting at the point; the count of what the point owns: the
//!   vertices of its crossed edges (marching cubes: x, y, z; marching tetrahedra: 7 families),
//!   or for the dual methods the quads of its crossed edges that have four cells around them;
//!   and for the cell at the point, what it owns: its triangles (marching cubes / tetrahedra)
//!   or, if active, its vertex (dual methods).
//! * **scan**: an exclusive prefix sum in place (workgroup scans of 1024 elements, block sums
//!   scanned level by level, added back), so the id of every vertex and triangle is the scan
//!   value of its owner plus its rank within the owner: the CPU numbering (vertices in increasing
//!   edge or cell id, triangles in cell or edge order, then table order). No atomics: runs are
//!   deterministic.
//! * **emit**: one invocation per output vertex or triangle (quad), which finds its owner by
//!   bisection of the scan, so the work follows the output, not the grid. Vertices at the
//!   crossings (MC, MT) or at the mean of a cell's crossings (SN, DC) with normals from the
//!   field's gradient as `Field::normal` defines them; triangles through the scanned ids.
//!
//! # MC33
//!
//! MC33 decides each cell's topology by tests (`mesh::mc33`), not by a table, and some cells
//! get *added* vertices (contour centres, split tunnel rungs), numbered after all edge vertices.
//! Classify (mode mc33) counts 1 per crossed cell, so the cell scan numbers the crossed cells;
//! after a readback, `mc33 count` runs one invocation per crossed cell, builds its surface in
//! f64 (`shaders/extract/mc33.glsl`, the reference's operations in its order) and writes its
//! triangle and added-vertex counts, which two more scans turn into offsets. `mc33 emit` (one
//! invocation per crossed cell again) builds it once more and writes the triangles, and the
//! added vertices after the slab's edge vertices. (Only crossed cells run the large shader:
//! lavapipe pays a fixed cost per invocation of it even where it skips the work.) Triangles name
//! added vertex `n` (over the whole grid) `u32::MAX - n` until, with every slab emitted and the
//! edge-vertex total known, `mc33 fixup` resolves the placeholders in each slab's triangles and
//! the assembly puts all edge vertices first, then all added ones. The passes need
//! `shaderFloat64`; without it [`Extractor::extract`] returns [`GpuMeshError::Unsupported`].
//!
//! # Slabs
//!
//! The per-point and per-cell buffers of a slab must fit one storage-buffer binding
//! (`maxStorageBufferRange`, 128 MiB on lavapipe) and so must its output, so the grid is cut
//! into slabs of whole cell layers `[z0, z1)`. A slab classifies one layer more than it owns
//! where its neighbours' ids are needed: marching cubes / tetrahedra read the edges of point
//! layer `z1` (owned by the next slab, whose first ids follow this slab's last), the dual
//! methods the cells of layer `z0 - 1` (owned by the previous slab, whose ids end where this
//! slab's begin). Ids are `vertex_base + scan[owner] - scan[first owned]`, which is the
//! neighbour's own numbering in both cases, so slabs join seamlessly. A slab whose output would
//! not fit one binding is halved and redone. Memory: the per-slab scratch (12 bytes per point
//! and 4 per cell, 12 for mc33, of at most one slab) plus the output, held twice while slabs are
//! copied into one buffer (once with a single slab). Limits: a slab needs five point layers in
//! one binding, so an x·y layer of more than a fifth of a binding (6.7 M points on lavapipe) is
//! refused with an error, as is an axis beyond the device's 3D image size (4096 on lavapipe).
//!
//! # Precision
//!
//! Classification is exact: the isovalue enters as the f32 threshold that makes `v < t` equal
//! to the f64 comparison. Crossings, positions and normals are f32: positions agree with the
//! f64 reference to about 1e-6 of a cell plus a few f32 ulps of the coordinates; normals to
//! about 1e-6 except where the averaged gradient nearly cancels. Samples that are NaN, and
//! edges whose value difference overflows f32, are not handled like the reference.

use std::sync::Arc;

use ash::vk;

use super::{
    classify_mode, compute_barrier, inside_threshold, record_items, ExtractParams, ExtractPasses,
    ExtractTables, Mc33Passes, Scan, SlabPush,
};
use crate::field::Grid;
use crate::gpu::{
    copy_buffer, fill_buffer, memory_barrier, Buffer, ComputePipeline, Context, Dispatch, GpuError,
    Image3d, MemoryLocation, Resource, Timer,
};
use crate::mesh::{Mesh, MeshError, QuadSplit};
use crate::vocab::{Inside, MeshAlgorithm};

/// Largest scratch buffer of a slab, in bytes, on devices whose binding limit is larger.
const MAX_SCRATCH_BYTES: u64 = 256 << 20;

/// A mesh on the device, for the mesh renderer: positions `(x, y, z, 1)` and normals
/// `(x, y, z, 0)` as vec4 per vertex (world space, normals unit and inside → outside), indices
/// as three u32 per triangle, counter-clockwise seen from outside.
pub struct GpuMesh {
    pub positions: Buffer,
    pub normals: Buffer,
    pub indices: Buffer,
    pub vertex_count: u32,
    pub triangle_count: u32,
    ctx: Arc<Context>,
}

impl GpuMesh {
    /// Wraps buffers already in this layout (e.g. a CPU-extracted mesh uploaded by
    /// `passes::mesh_render::upload`).
    pub fn from_buffers(
        ctx: &Arc<Context>,
        positions: Buffer,
        normals: Buffer,
        indices: Buffer,
        vertex_count: u32,
        triangle_count: u32,
    ) -> Self {
        GpuMesh { positions, normals, indices, vertex_count, triangle_count, ctx: ctx.clone() }
    }

    /// Copies the mesh back to the host (through staging buffers).
    pub fn read(&self) -> Result<Mesh, GpuError> {
        let ctx = &self.ctx;
        let v_bytes = u64::from(self.vertex_count) * 16;
        let i_bytes = u64::from(self.triangle_count) * 12;
        let staging = |name: &str, bytes: u64| {
            Buffer::new(
                ctx,
                name,
                bytes,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )
        };
        let positions = staging("mesh positions readback", v_bytes)?;
        let normals = staging("mesh normals readback", v_bytes)?;
        let indices = staging("mesh indices readback", i_bytes)?;
        ctx.submit("read mesh", |cmd| {
            if v_bytes > 0 {
                copy_buffer(ctx, cmd, &self.positions, 0, &positions, 0, v_bytes);
                copy_buffer(ctx, cmd, &self.normals, 0, &normals, 0, v_bytes);
            }
            if i_bytes > 0 {
                copy_buffer(ctx, cmd, &self.indices, 0, &indices, 0, i_bytes);
            }
            memory_barrier(
                ctx,
                cmd,
                (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_WRITE),
                (vk::PipelineStageFlags::HOST, vk::AccessFlags::HOST_READ),
            );
            Ok(())
        })?;
        let n = self.vertex_count as usize;
        let xyz = |v: [f32; 4]| [v[0], v[1], v[2]];
        Ok(Mesh {
            positions: positions.read::<[f32; 4]>(n)?.into_iter().map(xyz).collect(),
            normals: normals.read::<[f32; 4]>(n)?.into_iter().map(xyz).collect(),
            indices: indices.read::<u32>(3 * self.triangle_count as usize)?,
            quads: None,
        })
    }
}

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
}

/// Options of [`Extractor::extract`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GpuExtractOptions {
    /// Quad split of `surface-nets` and `dual-contouring`. [`QuadSplit::Fixed`] reproduces the
    /// CPU reference bit for bit; [`QuadSplit::Shorter`] compares f32 diagonals, so near ties
    /// may split the other way than the f64 reference.
    pub split: QuadSplit,
    /// At most this many cell layers per slab (tests force small slabs with it); None: as many
    /// as the device's binding limit allows.
    pub max_slab_layers: Option<usize>,
    /// Treat this many bytes as the largest buffer binding instead of the device's
    /// `maxStorageBufferRange` (tests exercise the slab sizing and the halving of slabs whose
    /// output would not fit with it); None: the device's limit.
    pub max_binding_bytes: Option<u64>,
}

/// What the last extraction did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExtractStats {
    /// Slabs extracted.
    pub slabs: usize,
    /// Slabs halved and redone because their output would not fit one binding.
    pub retries: usize,
    /// GPU time of all submissions, in milliseconds (None without timestamps).
    pub gpu_ms: Option<f64>,
}

/// The extraction pipelines and tables; extracts any number of meshes.
pub struct Extractor {
    ctx: Arc<Context>,
    passes: ExtractPasses,
    tables: Buffer,
    /// Bound where a pass's output is not written yet (the counting passes).
    dummy: Buffer,
    /// Statistics of the last [`Extractor::extract`].
    pub last: ExtractStats,
}

/// How an algorithm maps onto the passes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// Vertices on lattice edges (points own them), triangles per cell; `mc33` also adds
    /// vertices per cell, numbered after all edge vertices.
    Edges { mt: bool, mc33: bool },
    /// Vertices per cell, quads per lattice edge (points own them); `pad` layers of outside
    /// points around the grid (dual contouring).
    Dual { pad: usize },
}

/// Which layers a slab holds and owns. Indices are into the slab's point / cell buffers.
#[derive(Clone, Copy, Debug)]
struct SlabPlan {
    /// First owned cell layer (padded); the owned points start at layer `z0` too.
    z0: usize,
    point_z0: usize,
    points: usize,
    cell_z0: usize,
    cells: usize,
    owned_point: usize,
    owned_point_end: usize,
    owned_cell: usize,
    owned_cell_end: usize,
    /// Samples held: padded point layers from `value_z0`, `values` points (one layer around
    /// the point layers, for the gradients of the cells on either side of them).
    value_z0: usize,
    values: usize,
}

impl SlabPlan {
    fn new(kind: Kind, z0: usize, z1: usize, cell_layers: usize, lp: usize, lc: usize) -> Self {
        let mut plan = SlabPlan::layers(kind, z0, z1, cell_layers, lp, lc);
        let point_end = plan.point_z0 + plan.points / lp;
        plan.value_z0 = plan.point_z0.saturating_sub(1);
        plan.values = ((point_end + 1).min(cell_layers + 1) - plan.value_z0) * lp;
        plan
    }

    fn layers(kind: Kind, z0: usize, z1: usize, cell_layers: usize, lp: usize, lc: usize) -> Self {
        match kind {
            Kind::Edges { .. } => {
                // Points of layer z1 are read for their ids; the last slab owns them too.
                let owned_layers = z1 - z0 + usize::from(z1 == cell_layers);
                SlabPlan {
                    z0,
                    point_z0: z0,
                    points: (z1 - z0 + 1) * lp,
                    cell_z0: z0,
                    cells: (z1 - z0) * lc,
                    owned_point: 0,
                    owned_point_end: owned_layers * lp,
                    owned_cell: 0,
                    owned_cell_end: (z1 - z0) * lc,
                    value_z0: 0,
                    values: 0,
                }
            }
            Kind::Dual { .. } => {
                // Cells of layer z0 - 1 are read for their ids (quads of point layer z0).
                let zs = z0.saturating_sub(1);
                SlabPlan {
                    z0,
                    point_z0: zs,
                    points: (z1 - zs + 1) * lp,
                    cell_z0: zs,
                    cells: (z1 - zs) * lc,
                    owned_point: (z0 - zs) * lp,
                    owned_point_end: (z1 - zs) * lp,
                    owned_cell: (z0 - zs) * lc,
                    owned_cell_end: (z1 - zs) * lc,
                    value_z0: 0,
                    values: 0,
                }
            }
        }
    }

    fn push(&self, count: usize, z0: usize, vertex_base: u32, mode: u32) -> SlabPush {
        SlabPush {
            groups_x: 0,
            count: count as u32,
            z0: z0 as i32,
            point_z0: self.point_z0 as i32,
            cell_z0: self.cell_z0 as i32,
            owned_point: self.owned_point as u32,
            owned_cell: self.owned_cell as u32,
            vertex_base,
            mode,
            value_z0: self.value_z0 as i32,
            owned_point_end: self.owned_point_end as u32,
            owned_cell_end: self.owned_cell_end as u32,
            added_base: 0,
            added_offset: 0,
        }
    }
}

/// One slab's output: `vertices` vertices (for mc33, `added` of them, at the end, added per
/// cell) and `triangles` triangles.
struct SlabOutput {
    positions: Buffer,
    normals: Buffer,
    indices: Buffer,
    vertices: u64,
    added: u64,
    triangles: u64,
}

/// The per-extraction resources shared by all slabs.
struct Scratch<'a> {
    image: &'a Image3d,
    params: Buffer,
    values: Buffer,
    point_mask: Buffer,
    point_scan: Buffer,
    cell_scan: Buffer,
    /// MC33's triangles and added vertices per crossed cell (one element each for the other
    /// algorithms).
    tri_scan: Buffer,
    added_scan: Buffer,
    point_scanner: Scan,
    cell_scanner: Scan,
    /// MC33: the scans of `tri_scan` and `added_scan`.
    mc33_scanners: Option<(Scan, Scan)>,
    readback: Buffer,
    timer: Option<Timer>,
}

fn validate(grid: &Grid, iso: f64) -> Result<(), MeshError> {
    if !iso.is_finite() {
        return Err(MeshError::BadIsovalue(iso));
    }
    let want = grid.dims.iter().product::<usize>();
    if grid.dims.iter().any(|&n| n < 2) || grid.values.len() != want {
        return Err(MeshError::BadGrid { dims: grid.dims, got: grid.values.len(), want });
    }
    Ok(())
}

fn v4(v: glam::DVec3) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, 0.0]
}

/// The constants of an extraction (`Params` in `common.glsl`).
fn params(grid: &Grid, iso: f64, inside: Inside, pad: usize) -> ExtractParams {
    let below = inside == Inside::Below;
    let hi = iso as f32;
    ExtractParams {
        dims: [grid.dims[0] as i32, grid.dims[1] as i32, grid.dims[2] as i32, pad as i32],
        box_min: v4(grid.min),
        spacing: v4(grid.spacing()),
        iso: [
            inside_threshold(iso, below),
            hi,
            (iso - f64::from(hi)) as f32,
            if below { 1.0 } else { -1.0 },
        ],
        iso_bits: [iso.to_bits() as u32, (iso.to_bits() >> 32) as u32, 0, 0],
    }
}

/// Uploads `grid` and extracts its isosurface with default options (one-off use; keep an
/// [`Extractor`] and an uploaded grid to extract repeatedly).
pub fn extract(
    ctx: &Arc<Context>,
    grid: &Grid,
    iso: f64,
    inside: Inside,
    algo: MeshAlgorithm,
) -> Result<GpuMesh, GpuMeshError> {
    validate(grid, iso)?;
    let image = Image3d::upload(ctx, "grid", grid.dims.map(|d| d as u32), &grid.values)?;
    Extractor::new(ctx)?.extract(grid, &image, iso, inside, algo, &GpuExtractOptions::default())
}

impl Extractor {
    pub fn new(ctx: &Arc<Context>) -> Result<Self, GpuMeshError> {
        let passes = ExtractPasses::new(ctx)?;
        let data = ExtractTables::new();
        let bytes = std::mem::size_of::<ExtractTables>() as u64;
        let mut staging = Buffer::new(
            ctx,
            "extract tables staging",
            bytes,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(std::slice::from_ref(&data))?;
        let tables = Buffer::new(
            ctx,
            "extract tables",
            bytes,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        ctx.submit("upload extract tables", |cmd| {
            copy_buffer(ctx, cmd, &staging, 0, &tables, 0, bytes);
            Ok(())
        })?;
        let dummy = Buffer::new(
            ctx,
            "extract dummy output",
            16,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuOnly,
        )?;
        Ok(Extractor { ctx: ctx.clone(), passes, tables, dummy, last: ExtractStats::default() })
    }

    /// Extracts the isosurface `{x : f(x) = iso}` of `grid` (uploaded as `image`, e.g. a
    /// renderer's `GpuGrid::image`), inside per `inside`, with `algo`; the mesh equals
    /// `mesh::extract`'s up to f32 rounding of positions and normals (see the module docs).
    pub fn extract(
        &mut self,
        grid: &Grid,
        image: &Image3d,
        iso: f64,
        inside: Inside,
        algo: MeshAlgorithm,
        opts: &GpuExtractOptions,
    ) -> Result<GpuMesh, GpuMeshError> {
        validate(grid, iso)?;
        if image.extent.map(|e| e as usize) != grid.dims {
            return Err(GpuError::Bug(format!(
                "grid image {:?} does not match the grid's dimensions {:?}",
                image.extent, grid.dims
            ))
            .into());
        }
        let kind = match algo {
            MeshAlgorithm::MarchingCubes => Kind::Edges { mt: false, mc33: false },
            MeshAlgorithm::MarchingTetrahedra => Kind::Edges { mt: true, mc33: false },
            MeshAlgorithm::SurfaceNets => Kind::Dual { pad: 0 },
            MeshAlgorithm::DualContouring => Kind::Dual { pad: 1 },
            MeshAlgorithm::Mc33 => {
                if self.passes.mc33.is_none() {
                    self.passes.mc33 = Mc33Passes::new(&self.ctx)?;
                }
                if self.passes.mc33.is_none() {
                    return Err(GpuMeshError::Unsupported("mc33"));
                }
                Kind::Edges { mt: false, mc33: true }
            }
        };
        let mc33 = matches!(kind, Kind::Edges { mc33: true, .. });
        let ctx = self.ctx.clone();
        let pad = match kind {
            Kind::Edges { .. } => 0,
            Kind::Dual { pad } => pad,
        };
        let np = grid.dims.map(|n| n + 2 * pad);
        let nc = np.map(|n| n - 1);
        let (lp, lc) = (np[0] * np[1], nc[0] * nc[1]);

        let limit_bytes = opts
            .max_binding_bytes
            .unwrap_or(ctx.info.max_storage_buffer_range)
            .min(ctx.info.max_storage_buffer_range)
            .min(MAX_SCRATCH_BYTES);
        let limit_elems = (limit_bytes / 4) as usize;
        // Slab depth: a slab holds at most `layers + 2` point layers (plus one total) and
        // `layers + 4` layers of samples.
        let by_limit = (limit_elems.saturating_sub(1) / lp).saturating_sub(4);
        if by_limit == 0 {
            return Err(GpuError::TooLarge {
                what: format!("a z layer of {}x{} points", np[0], np[1]),
                limit: format!("one storage buffer ({limit_bytes} bytes)"),
            }
            .into());
        }
        let mut layers = by_limit.min(nc[2]);
        if let Some(m) = opts.max_slab_layers {
            layers = layers.min(m.max(1));
        }

        let mut scratch = self.scratch(
            image,
            &params(grid, iso, inside, pad),
            (layers + 2) * lp,
            (layers + 1) * lc,
            (layers + 4) * lp,
            mc33,
        )?;
        let mut stats =
            ExtractStats { gpu_ms: scratch.timer.as_ref().map(|_| 0.0), ..Default::default() };
        let mut pieces = Vec::new();
        // Edge vertices, triangles and (mc33) added vertices of the slabs so far.
        let (mut vbase, mut tbase, mut abase) = (0u64, 0u64, 0u64);
        let mut z0 = 0;
        while z0 < nc[2] {
            let z1 = (z0 + layers).min(nc[2]);
            let plan = SlabPlan::new(kind, z0, z1, nc[2], lp, lc);
            let [vertices, triangles, added, crossed] =
                self.count(&mut scratch, &mut stats, kind, &plan)?;
            let fits = (vertices + added) * 16 <= limit_bytes && triangles * 12 <= limit_bytes;
            if !fits {
                if z1 - z0 == 1 {
                    return Err(GpuError::TooLarge {
                        what: format!(
                            "the mesh of one z layer ({vertices} vertices, {triangles} triangles)"
                        ),
                        limit: format!("one storage buffer ({limit_bytes} bytes)"),
                    }
                    .into());
                }
                layers = (z1 - z0) / 2;
                stats.retries += 1;
                continue;
            }
            if vbase + vertices + abase + added >= u64::from(u32::MAX) {
                return Err(MeshError::TooLarge { what: "vertices" }.into());
            }
            if 3 * (tbase + triangles) >= u64::from(u32::MAX) {
                return Err(MeshError::TooLarge { what: "indices" }.into());
            }
            let bases = [vbase, abase];
            let counts = [vertices, triangles, added, crossed];
            let out = self.emit(&mut scratch, &mut stats, kind, &plan, opts, bases, counts)?;
            vbase += vertices;
            tbase += triangles;
            abase += added;
            pieces.push(out);
            stats.slabs += 1;
            z0 = z1;
        }
        let mesh = self.assemble(&scratch, pieces, vbase, tbase, abase)?;
        self.last = stats;
        Ok(mesh)
    }

    fn scratch<'a>(
        &self,
        image: &'a Image3d,
        params: &ExtractParams,
        points: usize,
        cells: usize,
        values: usize,
        mc33: bool,
    ) -> Result<Scratch<'a>, GpuError> {
        let ctx = &self.ctx;
        let bytes = std::mem::size_of::<ExtractParams>() as u64;
        let mut staging = Buffer::new(
            ctx,
            "extract params staging",
            bytes,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(std::slice::from_ref(params))?;
        let params_buf = Buffer::new(
            ctx,
            "extract params",
            bytes,
            vk::BufferUsageFlags::UNIFORM_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        ctx.submit("upload extract params", |cmd| {
            copy_buffer(ctx, cmd, &staging, 0, &params_buf, 0, bytes);
            Ok(())
        })?;
        let storage = |name: &str, elems: usize| {
            Buffer::new(
                ctx,
                name,
                elems as u64 * 4,
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_SRC
                    | vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuOnly,
            )
        };
        let values = storage("extract values", values)?;
        let point_mask = storage("extract point masks", points)?;
        let point_scan = storage("extract point scan", points + 1)?;
        let cell_scan = storage("extract cell scan", cells + 1)?;
        let point_scanner =
            Scan::new(ctx, &self.passes, "point scan", &point_scan, points as u64 + 1)?;
        let cell_scanner = Scan::new(ctx, &self.passes, "cell scan", &cell_scan, cells as u64 + 1)?;
        let per_crossed = if mc33 { cells + 1 } else { 1 };
        let tri_scan = storage("extract mc33 triangle scan", per_crossed)?;
        let added_scan = storage("extract mc33 added scan", per_crossed)?;
        let mc33_scanners = if mc33 {
            let n = cells as u64 + 1;
            Some((
                Scan::new(ctx, &self.passes, "mc33 triangle scan", &tri_scan, n)?,
                Scan::new(ctx, &self.passes, "mc33 added scan", &added_scan, n)?,
            ))
        } else {
            None
        };
        let readback = Buffer::new(
            ctx,
            "extract counters readback",
            16,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        Ok(Scratch {
            image,
            params: params_buf,
            values,
            point_mask,
            point_scan,
            cell_scan,
            tri_scan,
            added_scan,
            point_scanner,
            cell_scanner,
            mc33_scanners,
            readback,
            timer: Timer::new(ctx)?,
        })
    }

    /// Binds the extraction resources for `pipeline`, with `out` as the output buffers.
    fn bind(
        &self,
        pipeline: &ComputePipeline,
        s: &Scratch,
        out: Option<&SlabOutput>,
    ) -> Result<Dispatch, GpuError> {
        let (p, n, i) = match out {
            Some(o) => (&o.positions, &o.normals, &o.indices),
            None => (&self.dummy, &self.dummy, &self.dummy),
        };
        pipeline.bind(&[
            Resource::Uniform(&s.params),
            Resource::Sampled(s.image),
            Resource::Storage(&s.point_mask),
            Resource::Storage(&s.point_scan),
            Resource::Storage(&s.cell_scan),
            Resource::Storage(&self.tables),
            Resource::Storage(p),
            Resource::Storage(n),
            Resource::Storage(i),
            Resource::Storage(&s.values),
            Resource::Storage(&s.added_scan),
            Resource::Storage(&s.tri_scan),
        ])
    }

    /// Submits `record`, adding its GPU time to `stats`.
    fn submit<F>(
        &self,
        s: &Scratch,
        stats: &mut ExtractStats,
        pass: &str,
        record: F,
    ) -> Result<(), GpuError>
    where
        F: FnOnce(vk::CommandBuffer) -> Result<(), GpuError>,
    {
        let ctx = &self.ctx;
        ctx.submit(pass, |cmd| {
            if let Some(t) = &s.timer {
                t.begin(cmd);
            }
            // Writes of earlier submissions (the scans, the slab before) become visible.
            memory_barrier(
                ctx,
                cmd,
                (
                    vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                    vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE,
                ),
                (
                    vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                    vk::AccessFlags::SHADER_READ
                        | vk::AccessFlags::SHADER_WRITE
                        | vk::AccessFlags::TRANSFER_READ
                        | vk::AccessFlags::TRANSFER_WRITE,
                ),
            );
            record(cmd)?;
            if let Some(t) = &s.timer {
                t.end(cmd);
            }
            Ok(())
        })?;
        if let (Some(t), Some(ms)) = (&s.timer, stats.gpu_ms.as_mut()) {
            *ms += t.elapsed_ms()?;
        }
        Ok(())
    }

    /// Classifies and scans one slab; returns its vertex (edge vertices for mc33), triangle,
    /// mc33 added-vertex and mc33 crossed-cell counts.
    fn count(
        &self,
        s: &mut Scratch,
        stats: &mut ExtractStats,
        kind: Kind,
        plan: &SlabPlan,
    ) -> Result<[u64; 4], GpuError> {
        let ctx = &self.ctx;
        let p = &self.passes;
        let mode = match kind {
            Kind::Edges { mc33: true, .. } => classify_mode::MC33,
            Kind::Edges { mt: false, .. } => classify_mode::MC,
            Kind::Edges { mt: true, .. } => classify_mode::MT,
            Kind::Dual { .. } => classify_mode::DUAL,
        };
        let values_set = self.bind(&p.values, s, None)?;
        let classify_set = self.bind(&p.classify, s, None)?;
        self.submit(s, stats, "extract count", |cmd| {
            // The element after each array holds the total once scanned.
            fill_buffer(ctx, cmd, &s.point_scan, plan.points as u64 * 4, 4, 0);
            fill_buffer(ctx, cmd, &s.cell_scan, plan.cells as u64 * 4, 4, 0);
            memory_barrier(
                ctx,
                cmd,
                (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_WRITE),
                (
                    vk::PipelineStageFlags::COMPUTE_SHADER,
                    vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE,
                ),
            );
            record_items(cmd, &p.values, &values_set, plan.push(plan.values, plan.value_z0, 0, 0))?;
            compute_barrier(ctx, cmd);
            let push = plan.push(plan.points, plan.point_z0, 0, mode);
            record_items(cmd, &p.classify, &classify_set, push)?;
            compute_barrier(ctx, cmd);
            s.point_scanner.record(ctx, p, cmd, plan.points as u64 + 1)?;
            s.cell_scanner.record(ctx, p, cmd, plan.cells as u64 + 1)?;
            let counters = [
                (&s.point_scan, plan.owned_point),
                (&s.point_scan, plan.owned_point_end),
                (&s.cell_scan, plan.owned_cell),
                (&s.cell_scan, plan.owned_cell_end),
            ];
            record_counters(ctx, cmd, &counters, &s.readback);
            Ok(())
        })?;
        let c: Vec<u32> = s.readback.read(4)?;
        let point_owned = u64::from(c[1].wrapping_sub(c[0]));
        let cell_owned = u64::from(c[3].wrapping_sub(c[2]));
        Ok(match kind {
            Kind::Edges { mc33: true, .. } => {
                let [triangles, added] = self.count_mc33(s, stats, plan, cell_owned)?;
                [point_owned, triangles, added, cell_owned]
            }
            Kind::Edges { .. } => [point_owned, cell_owned, 0, 0],
            Kind::Dual { .. } => [cell_owned, 2 * point_owned, 0, 0],
        })
    }

    /// MC33, after [`Extractor::count`]: the triangles and added vertices of the slab's
    /// `crossed` crossed cells, counted per cell (only crossed cells run the large mc33
    /// shader) and scanned.
    fn count_mc33(
        &self,
        s: &mut Scratch,
        stats: &mut ExtractStats,
        plan: &SlabPlan,
        crossed: u64,
    ) -> Result<[u64; 2], GpuError> {
        if crossed == 0 {
            return Ok([0, 0]);
        }
        let ctx = &self.ctx;
        let p = &self.passes;
        let (Some(passes), Some((tri_scanner, added_scanner))) = (&p.mc33, &s.mc33_scanners) else {
            unreachable!("mc33 extraction without its passes and scans")
        };
        let set = self.bind(&passes.count, s, None)?;
        self.submit(s, stats, "extract mc33 count", |cmd| {
            fill_buffer(ctx, cmd, &s.tri_scan, crossed * 4, 4, 0);
            fill_buffer(ctx, cmd, &s.added_scan, crossed * 4, 4, 0);
            memory_barrier(
                ctx,
                cmd,
                (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_WRITE),
                (
                    vk::PipelineStageFlags::COMPUTE_SHADER,
                    vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE,
                ),
            );
            let push = plan.push(crossed as usize, plan.z0, 0, 0);
            record_items(cmd, &passes.count, &set, push)?;
            compute_barrier(ctx, cmd);
            tri_scanner.record(ctx, p, cmd, crossed + 1)?;
            added_scanner.record(ctx, p, cmd, crossed + 1)?;
            let at = crossed as usize;
            record_counters(ctx, cmd, &[(&s.tri_scan, at), (&s.added_scan, at)], &s.readback);
            Ok(())
        })?;
        let c: Vec<u32> = s.readback.read(2)?;
        Ok([u64::from(c[0]), u64::from(c[1])])
    }

    /// Writes one slab's vertices and triangles into new buffers sized for them. `bases`: the
    /// edge (or dual) vertices and the mc33 added vertices of the slabs before; `counts`: this
    /// slab's vertices, triangles, mc33 added vertices and mc33 crossed cells.
    #[allow(clippy::too_many_arguments)]
    fn emit(
        &self,
        s: &mut Scratch,
        stats: &mut ExtractStats,
        kind: Kind,
        plan: &SlabPlan,
        opts: &GpuExtractOptions,
        bases: [u64; 2],
        counts: [u64; 4],
    ) -> Result<SlabOutput, GpuError> {
        let [vertices, triangles, added, crossed] = counts;
        let mut out = output(&self.ctx, "slab", vertices + added, triangles)?;
        out.added = added;
        if vertices == 0 && triangles == 0 {
            return Ok(out);
        }
        let ctx = &self.ctx;
        let p = &self.passes;
        let vb = bases[0] as u32;
        // One invocation per vertex, then per triangle (per quad for the dual methods).
        let (first, first_push, second, mut second_push) = match kind {
            Kind::Edges { mt, mc33 } => (
                &p.edge_vertices,
                plan.push(vertices as usize, plan.z0, vb, u32::from(mt)),
                match (mt, mc33, &p.mc33) {
                    (_, true, Some(m)) => &m.emit,
                    (true, ..) => &p.mt,
                    _ => &p.mc,
                },
                // mc33: one invocation per crossed cell.
                plan.push(if mc33 { crossed } else { triangles } as usize, plan.z0, vb, 1),
            ),
            Kind::Dual { .. } => (
                &p.dual_cells,
                plan.push(vertices as usize, plan.z0, vb, 1),
                &p.dual_quads,
                plan.push(
                    triangles as usize / 2,
                    plan.z0,
                    vb,
                    u32::from(opts.split == QuadSplit::Shorter),
                ),
            ),
        };
        second_push.added_base = bases[1] as u32;
        second_push.added_offset = vertices as u32;
        let first_set = self.bind(first, s, Some(&out))?;
        let second_set = self.bind(second, s, Some(&out))?;
        self.submit(s, stats, "extract emit", |cmd| {
            record_items(cmd, first, &first_set, first_push)?;
            // The dual quads read the vertex positions just written.
            compute_barrier(ctx, cmd);
            record_items(cmd, second, &second_set, second_push)?;
            Ok(())
        })?;
        Ok(out)
    }

    /// The slabs' outputs as one mesh: the only slab's buffers, or all copied into new ones
    /// (vertices: every slab's edge or dual vertices, then every slab's mc33 added vertices).
    /// For mc33 (`added` > 0), the triangles' added-vertex placeholders are resolved first.
    fn assemble(
        &self,
        s: &Scratch,
        mut pieces: Vec<SlabOutput>,
        vertices: u64,
        triangles: u64,
        added: u64,
    ) -> Result<GpuMesh, GpuError> {
        let ctx = &self.ctx;
        let writes = (
            vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE,
        );
        // mc33: resolve the added-vertex placeholders in each slab's triangles (a slab's buffers
        // fit one binding; the assembled mesh's need not).
        if let Some(passes) = self.passes.mc33.as_ref().filter(|_| added > 0) {
            let mut dispatches = Vec::new();
            for piece in pieces.iter().filter(|p| p.triangles > 0) {
                let push = SlabPush {
                    count: (3 * piece.triangles) as u32,
                    vertex_base: vertices as u32,
                    added_base: added as u32,
                    ..Default::default()
                };
                dispatches.push((self.bind(&passes.fixup, s, Some(piece))?, push));
            }
            ctx.submit("extract mc33 fixup", |cmd| {
                let rw = vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE;
                memory_barrier(ctx, cmd, writes, (vk::PipelineStageFlags::COMPUTE_SHADER, rw));
                for (set, push) in &dispatches {
                    record_items(cmd, &passes.fixup, set, *push)?;
                }
                Ok(())
            })?;
        }
        let single = pieces.len() == 1;
        let out = if single {
            pieces.pop().expect("one slab")
        } else {
            let out = output(ctx, "mesh", vertices + added, triangles)?;
            ctx.submit("extract assemble", |cmd| {
                memory_barrier(
                    ctx,
                    cmd,
                    writes,
                    (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_READ),
                );
                let (mut v, mut a, mut t) = (0, vertices * 16, 0);
                for piece in &pieces {
                    let own = piece.vertices - piece.added;
                    let (vb, ab, tb) = (own * 16, piece.added * 16, piece.triangles * 12);
                    for (src, dst) in
                        [(&piece.positions, &out.positions), (&piece.normals, &out.normals)]
                    {
                        if vb > 0 {
                            copy_buffer(ctx, cmd, src, 0, dst, v, vb);
                        }
                        if ab > 0 {
                            copy_buffer(ctx, cmd, src, vb, dst, a, ab);
                        }
                    }
                    if tb > 0 {
                        copy_buffer(ctx, cmd, &piece.indices, 0, &out.indices, t, tb);
                    }
                    v += vb;
                    a += ab;
                    t += tb;
                }
                Ok(())
            })?;
            out
        };
        // Make the mesh visible to whatever reads it next (draws, copies, shaders).
        ctx.submit("extract finish", |cmd| {
            let reads = (vk::PipelineStageFlags::ALL_COMMANDS, vk::AccessFlags::MEMORY_READ);
            memory_barrier(ctx, cmd, writes, reads);
            Ok(())
        })?;
        Ok(GpuMesh {
            positions: out.positions,
            normals: out.normals,
            indices: out.indices,
            vertex_count: (vertices + added) as u32,
            triangle_count: triangles as u32,
            ctx: ctx.clone(),
        })
    }
}

/// Output buffers for `vertices` and `triangles`, usable as storage, vertex / index buffers and
/// copy sources and destinations.
fn output(
    ctx: &Arc<Context>,
    what: &str,
    vertices: u64,
    triangles: u64,
) -> Result<SlabOutput, GpuError> {
    let copy = vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST;
    let vertex = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::VERTEX_BUFFER | copy;
    let index = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::INDEX_BUFFER | copy;
    let buf = |name: &str, bytes: u64, usage| {
        Buffer::new(ctx, &format!("{what} {name}"), bytes, usage, MemoryLocation::GpuOnly)
    };
    Ok(SlabOutput {
        positions: buf("positions", vertices * 16, vertex)?,
        normals: buf("normals", vertices * 16, vertex)?,
        indices: buf("indices", triangles * 12, index)?,
        vertices,
        added: 0,
        triangles,
    })
}

/// Copies the u32 at element `at` of each buffer into `readback`, in order, and makes them
/// visible to the host.
fn record_counters(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    counters: &[(&Buffer, usize)],
    readback: &Buffer,
) {
    memory_barrier(
        ctx,
        cmd,
        (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_WRITE),
        (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_READ),
    );
    for (n, &(buf, at)) in counters.iter().enumerate() {
        copy_buffer(ctx, cmd, buf, at as u64 * 4, readback, n as u64 * 4, 4);
    }
    memory_barrier(
        ctx,
        cmd,
        (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_WRITE),
        (vk::PipelineStageFlags::HOST, vk::AccessFlags::HOST_READ),
    );
}
