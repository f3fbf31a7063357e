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

use super::plan::{self, Kind, SlabCounts, SlabPlan, Slabs, Step, TRIANGLE_BYTES, VERTEX_BYTES};
use super::{
    classify_mode, ExtractIo, ExtractPass, ExtractPasses, ExtractTables, GpuMeshError, Mc33Passes,
    Scan, SlabPush,
};
use crate::field::Grid;
use crate::gpu::{
    Buffer, Context, GpuError, Image3d, MemoryLocation, Recorder, Stage, Timer, Tracker,
};
use crate::mesh::MeshAlgorithm;
use crate::mesh::{Mesh, QuadSplit};
use crate::vocab::Inside;

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
        let v_bytes = u64::from(self.vertex_count) * VERTEX_BYTES;
        let i_bytes = u64::from(self.triangle_count) * TRIANGLE_BYTES;
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
        ctx.record("read mesh", &mut Tracker::default(), |rec| {
            if v_bytes > 0 {
                rec.copy(&self.positions, 0, &positions, 0, v_bytes);
                rec.copy(&self.normals, 0, &normals, 0, v_bytes);
                rec.host_read(&positions);
                rec.host_read(&normals);
            }
            if i_bytes > 0 {
                rec.copy(&self.indices, 0, &indices, 0, i_bytes);
                rec.host_read(&indices);
            }
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

/// Options of [`Extractor::extract`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpuExtractOptions {
    /// `dual-contouring-qef`'s settings (None: the defaults); only `qef_threshold` and
    /// `qef_clamp` are used: trilinear Hermite data on a uniform grid is what the passes do
    /// (`mesh::method::Method::gpu_off`).
    pub sharp: Option<crate::vocab::SharpSettings>,
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

/// One slab's output: `vertices` vertices (for mc33, `added` of them, at the end, added per
/// cell) and `triangles` triangles.
struct SlabOutput {
    positions: Buffer,
    normals: Buffer,
    indices: Buffer,
    counts: SlabCounts,
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

/// What changes over an extraction's submissions.
struct Run {
    /// The last writer of every buffer, across the submissions.
    tracker: Tracker,
    stats: ExtractStats,
}

impl Scratch<'_> {
    /// Records and submits `record` as `pass`, adding its GPU time to the stats. Barriers come
    /// from the recorded passes' declared accesses, tracked across submissions. Descriptor sets
    /// the commands use must outlive this call (bind before it).
    fn submit<F>(&self, ctx: &Context, run: &mut Run, pass: &str, record: F) -> Result<(), GpuError>
    where
        F: FnOnce(&mut Recorder) -> Result<(), GpuError>,
    {
        ctx.record(pass, &mut run.tracker, |rec| rec.timed(self.timer.as_ref(), record))?;
        if let (Some(t), Some(ms)) = (&self.timer, run.stats.gpu_ms.as_mut()) {
            *ms += t.elapsed_ms()?;
        }
        Ok(())
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
    plan::validate(grid, iso)?;
    let image = Image3d::upload(ctx, "grid", grid.dims.map(|d| d as u32), &grid.values)?;
    Extractor::new(ctx)?.extract(grid, &image, iso, inside, algo, &GpuExtractOptions::default())
}

impl Extractor {
    pub fn new(ctx: &Arc<Context>) -> Result<Self, GpuMeshError> {
        let passes = ExtractPasses::new(ctx)?;
        let tables = Buffer::upload(
            ctx,
            "extract tables",
            std::slice::from_ref(&ExtractTables::new()),
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
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
    /// `mesh::reference`'s up to f32 rounding of positions and normals (see the module docs).
    pub fn extract(
        &mut self,
        grid: &Grid,
        image: &Image3d,
        iso: f64,
        inside: Inside,
        algo: MeshAlgorithm,
        opts: &GpuExtractOptions,
    ) -> Result<GpuMesh, GpuMeshError> {
        plan::validate(grid, iso)?;
        if image.extent.map(|e| e as usize) != grid.dims {
            return Err(GpuError::Bug(format!(
                "grid image {:?} does not match the grid's dimensions {:?}",
                image.extent, grid.dims
            ))
            .into());
        }
        let sharp = opts.sharp.unwrap_or_default();
        let m = algo.method();
        let passes = match (m.gpu, (m.gpu_off)(&sharp)) {
            (Some(passes), None) => passes,
            _ => return Err(GpuMeshError::CpuOnly(m.name)),
        };
        let kind = Kind::of(passes, m.padding);
        if m.gpu_float64 && !self.ctx.info.float64 {
            return Err(GpuMeshError::Unsupported(m.name));
        }
        if kind.mc33() {
            if self.passes.mc33.is_none() {
                self.passes.mc33 = Mc33Passes::new(&self.ctx)?;
            }
            if self.passes.mc33.is_none() {
                return Err(GpuMeshError::Unsupported(m.name));
            }
        }
        let range = self.ctx.info.max_storage_buffer_range;
        let binding_bytes = opts.max_binding_bytes.unwrap_or(range).min(range);
        let mut slabs = Slabs::new(kind, grid.dims, binding_bytes, opts.max_slab_layers)?;
        let mut params = plan::params(grid, iso, inside, kind.pad());
        if m.sharp {
            // dual.glsl's `qef_on`: bit 0 on, bit 1 clamp; w: the threshold's bits.
            params.iso_bits[2] = 1 | (u32::from(sharp.qef_clamp) << 1);
            params.iso_bits[3] = (sharp.qef_threshold as f32).to_bits();
        }
        let (s, mut run) = self.scratch(image, &params, slabs.scratch(), kind.mc33())?;
        let mut pieces = Vec::new();
        while let Some(slab) = slabs.next() {
            let counts = self.count(&s, &mut run, kind, &slab)?;
            match slabs.counted(&slab, counts)? {
                Step::Redo => {}
                Step::Emit { bases } => {
                    pieces.push(self.emit(&s, &mut run, kind, &slab, opts, bases, counts)?)
                }
            }
        }
        run.stats.slabs = slabs.slabs;
        run.stats.retries = slabs.retries;
        let mesh = self.assemble(&s, &mut run, pieces, slabs.totals)?;
        self.last = run.stats;
        Ok(mesh)
    }

    fn scratch<'a>(
        &self,
        image: &'a Image3d,
        params: &super::ExtractParams,
        sizes: plan::ScratchSizes,
        mc33: bool,
    ) -> Result<(Scratch<'a>, Run), GpuError> {
        let ctx = &self.ctx;
        let plan::ScratchSizes { points, cells, values } = sizes;
        let params = Buffer::upload(
            ctx,
            "extract params",
            std::slice::from_ref(params),
            vk::BufferUsageFlags::UNIFORM_BUFFER,
        )?;
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
        // The uploads were submitted on their own: the first passes that read them wait.
        let mut tracker = Tracker::default();
        tracker.written(&params, Stage::Transfer);
        tracker.written(&self.tables, Stage::Transfer);
        let timer = Timer::new(ctx)?;
        let stats = ExtractStats { gpu_ms: timer.as_ref().map(|_| 0.0), ..Default::default() };
        let scratch = Scratch {
            image,
            params,
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
            timer,
        };
        Ok((scratch, Run { tracker, stats }))
    }

    /// The extraction resources, with `out` as the output buffers (the dummy before a slab's
    /// output exists).
    fn io<'a>(&'a self, s: &'a Scratch, out: Option<&'a SlabOutput>) -> ExtractIo<'a> {
        let (positions, normals, indices) = match out {
            Some(o) => (&o.positions, &o.normals, &o.indices),
            None => (&self.dummy, &self.dummy, &self.dummy),
        };
        ExtractIo {
            params: &s.params,
            grid: s.image,
            point_mask: &s.point_mask,
            point_scan: &s.point_scan,
            cell_scan: &s.cell_scan,
            tables: &self.tables,
            positions,
            normals,
            indices,
            values: &s.values,
            added_scan: &s.added_scan,
            tri_scan: &s.tri_scan,
        }
    }

    /// Classifies and scans one slab; returns its counts (mc33: after its count pass).
    fn count(
        &self,
        s: &Scratch,
        run: &mut Run,
        kind: Kind,
        slab: &SlabPlan,
    ) -> Result<SlabCounts, GpuError> {
        let p = &self.passes;
        let mode = match kind {
            Kind::Edges { mc33: true, .. } => classify_mode::MC33,
            Kind::Edges { mt: false, .. } => classify_mode::MC,
            Kind::Edges { mt: true, .. } => classify_mode::MT,
            Kind::Dual { .. } => classify_mode::DUAL,
        };
        let values = p.values.bind(self.io(s, None))?;
        let classify = p.classify.bind(self.io(s, None))?;
        s.submit(&self.ctx, run, "extract count", |rec| {
            // The element after each array holds the total once scanned.
            rec.fill(&s.point_scan, slab.points as u64 * 4, 4, 0);
            rec.fill(&s.cell_scan, slab.cells as u64 * 4, 4, 0);
            values.record(rec, slab.push(slab.values, slab.value_z0, 0, 0))?;
            classify.record(rec, slab.push(slab.points, slab.point_z0, 0, mode))?;
            s.point_scanner.record(rec, p, slab.points as u64 + 1)?;
            s.cell_scanner.record(rec, p, slab.cells as u64 + 1)?;
            let counters = [
                (&s.point_scan, slab.owned_point),
                (&s.point_scan, slab.owned_point_end),
                (&s.cell_scan, slab.owned_cell),
                (&s.cell_scan, slab.owned_cell_end),
            ];
            record_counters(rec, &counters, &s.readback);
            Ok(())
        })?;
        let (point_owned, cell_owned) = plan::owned(&s.readback.read::<u32>(4)?);
        let mut counts = kind.counts(point_owned, cell_owned);
        if kind.mc33() {
            [counts.triangles, counts.added] = self.count_mc33(s, run, slab, counts.crossed)?;
        }
        Ok(counts)
    }

    /// MC33, after [`Extractor::count`]: the triangles and added vertices of the slab's
    /// `crossed` crossed cells, counted per cell (only crossed cells run the large mc33
    /// shader) and scanned.
    fn count_mc33(
        &self,
        s: &Scratch,
        run: &mut Run,
        slab: &SlabPlan,
        crossed: u64,
    ) -> Result<[u64; 2], GpuError> {
        if crossed == 0 {
            return Ok([0, 0]);
        }
        let p = &self.passes;
        let (Some(passes), Some((tri_scanner, added_scanner))) = (&p.mc33, &s.mc33_scanners) else {
            unreachable!("mc33 extraction without its passes and scans")
        };
        let count = passes.count.bind(self.io(s, None))?;
        s.submit(&self.ctx, run, "extract mc33 count", |rec| {
            rec.fill(&s.tri_scan, crossed * 4, 4, 0);
            rec.fill(&s.added_scan, crossed * 4, 4, 0);
            count.record(rec, slab.push(crossed as usize, slab.z0, 0, 0))?;
            tri_scanner.record(rec, p, crossed + 1)?;
            added_scanner.record(rec, p, crossed + 1)?;
            let at = crossed as usize;
            record_counters(rec, &[(&s.tri_scan, at), (&s.added_scan, at)], &s.readback);
            Ok(())
        })?;
        let c: Vec<u32> = s.readback.read(2)?;
        Ok([u64::from(c[0]), u64::from(c[1])])
    }

    /// Writes one slab's vertices and triangles into new buffers sized for them. `bases`: the
    /// edge (or dual) vertices and the mc33 added vertices of the slabs before.
    #[allow(clippy::too_many_arguments)]
    fn emit(
        &self,
        s: &Scratch,
        run: &mut Run,
        kind: Kind,
        slab: &SlabPlan,
        opts: &GpuExtractOptions,
        bases: [u64; 2],
        counts: SlabCounts,
    ) -> Result<SlabOutput, GpuError> {
        let SlabCounts { vertices, triangles, added, crossed } = counts;
        let out = output(&self.ctx, "slab", vertices + added, triangles, added)?;
        if vertices == 0 && triangles == 0 {
            return Ok(out);
        }
        let p = &self.passes;
        let vb = bases[0] as u32;
        // One invocation per vertex, then per triangle (per quad for the dual methods).
        let (first, first_push, second, mut second_push): (&ExtractPass, _, &ExtractPass, _) =
            match kind {
                Kind::Edges { mt, mc33 } => (
                    &p.edge_vertices,
                    slab.push(vertices as usize, slab.z0, vb, u32::from(mt)),
                    match (mt, mc33, &p.mc33) {
                        (_, true, Some(m)) => &m.emit,
                        (true, ..) => &p.mt,
                        _ => &p.mc,
                    },
                    // mc33: one invocation per crossed cell.
                    slab.push(if mc33 { crossed } else { triangles } as usize, slab.z0, vb, 1),
                ),
                Kind::Dual { .. } => (
                    &p.dual_cells,
                    slab.push(vertices as usize, slab.z0, vb, 1),
                    &p.dual_quads,
                    slab.push(
                        triangles as usize / 2,
                        slab.z0,
                        vb,
                        u32::from(opts.split == QuadSplit::Shorter),
                    ),
                ),
            };
        second_push.added_base = bases[1] as u32;
        second_push.added_offset = vertices as u32;
        let first = first.bind(self.io(s, Some(&out)))?;
        let second = second.bind(self.io(s, Some(&out)))?;
        s.submit(&self.ctx, run, "extract emit", |rec| {
            first.record(rec, first_push)?;
            // The dual quads read the vertex positions just written (a declared read).
            second.record(rec, second_push)
        })?;
        drop((first, second));
        Ok(out)
    }

    /// The slabs' outputs as one mesh: the only slab's buffers, or all copied into new ones
    /// (vertices: every slab's edge or dual vertices, then every slab's mc33 added vertices).
    /// For mc33 (`added` > 0), the triangles' added-vertex placeholders are resolved first.
    fn assemble(
        &self,
        s: &Scratch,
        run: &mut Run,
        mut pieces: Vec<SlabOutput>,
        totals: SlabCounts,
    ) -> Result<GpuMesh, GpuError> {
        let ctx = &self.ctx;
        let SlabCounts { vertices, triangles, added, .. } = totals;
        // mc33: resolve the added-vertex placeholders in each slab's triangles (a slab's buffers
        // fit one binding; the assembled mesh's need not).
        if let Some(passes) = self.passes.mc33.as_ref().filter(|_| added > 0) {
            let mut fixups = Vec::new();
            for piece in pieces.iter().filter(|p| p.counts.triangles > 0) {
                let push = SlabPush {
                    count: (3 * piece.counts.triangles) as u32,
                    vertex_base: vertices as u32,
                    added_base: added as u32,
                    ..Default::default()
                };
                fixups.push((passes.fixup.bind(self.io(s, Some(piece)))?, push));
            }
            s.submit(ctx, run, "extract mc33 fixup", |rec| {
                for (fixup, push) in &fixups {
                    fixup.record(rec, *push)?;
                }
                Ok(())
            })?;
        }
        let out = if pieces.len() == 1 {
            pieces.pop().expect("one slab")
        } else {
            let out = output(ctx, "mesh", vertices + added, triangles, added)?;
            let counts: Vec<SlabCounts> = pieces.iter().map(|p| p.counts).collect();
            let copies = plan::assembly(&counts, vertices);
            s.submit(ctx, run, "extract assemble", |rec| {
                for (piece, c) in pieces.iter().zip(&copies) {
                    for (src, dst) in
                        [(&piece.positions, &out.positions), (&piece.normals, &out.normals)]
                    {
                        if c.vertex_bytes > 0 {
                            rec.copy(src, 0, dst, c.vertex_at, c.vertex_bytes);
                        }
                        if c.added_bytes > 0 {
                            rec.copy(src, c.vertex_bytes, dst, c.added_at, c.added_bytes);
                        }
                    }
                    if c.triangle_bytes > 0 {
                        let (i, at) = (&piece.indices, c.triangle_at);
                        rec.copy(i, 0, &out.indices, at, c.triangle_bytes);
                    }
                }
                Ok(())
            })?;
            out
        };
        // Make the mesh visible to whatever reads it next (draws, copies, shaders).
        ctx.record("extract finish", &mut run.tracker, |rec| {
            rec.release();
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

/// Output buffers for `vertices` (the last `added` of them mc33 added ones) and `triangles`,
/// usable as storage, vertex / index buffers and copy sources and destinations.
fn output(
    ctx: &Arc<Context>,
    what: &str,
    vertices: u64,
    triangles: u64,
    added: u64,
) -> Result<SlabOutput, GpuError> {
    let copy = vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST;
    let vertex = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::VERTEX_BUFFER | copy;
    let index = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::INDEX_BUFFER | copy;
    let buf = |name: &str, bytes: u64, usage| {
        Buffer::new(ctx, &format!("{what} {name}"), bytes, usage, MemoryLocation::GpuOnly)
    };
    Ok(SlabOutput {
        positions: buf("positions", vertices * VERTEX_BYTES, vertex)?,
        normals: buf("normals", vertices * VERTEX_BYTES, vertex)?,
        indices: buf("indices", triangles * TRIANGLE_BYTES, index)?,
        counts: SlabCounts { vertices, triangles, added, crossed: 0 },
    })
}

/// Copies the u32 at element `at` of each buffer into `readback`, in order, and makes them
/// visible to the host.
fn record_counters(rec: &mut Recorder, counters: &[(&Buffer, usize)], readback: &Buffer) {
    for (n, &(buf, at)) in counters.iter().enumerate() {
        rec.copy(buf, at as u64 * 4, readback, n as u64 * 4, 4);
    }
    rec.host_read(readback);
}
