//! The GPU-free half of the extraction driver: which passes an algorithm maps onto, how the
//! grid is cut into slabs (sized from the binding limit, halved when a slab's output would not
//! fit one binding), what each slab holds and owns, the running totals that become each slab's
//! id bases, and where each slab's output lands in the assembled mesh. Pure arithmetic, tested
//! without a device; [`super::driver`] records and submits what it decides.

use super::{inside_threshold, ExtractParams, GpuMeshError, SlabPush};
use crate::field::interpolant::STENCIL;
use crate::field::Grid;
use crate::gpu::GpuError;
use crate::mesh::method::GpuPasses;
use crate::mesh::MeshError;
use crate::vocab::Inside;

/// Largest scratch buffer of a slab, in bytes, on devices whose binding limit is larger.
pub const MAX_SCRATCH_BYTES: u64 = 256 << 20;

/// Bytes per output vertex (position or normal: one vec4).
pub const VERTEX_BYTES: u64 = 16;
/// Bytes per output triangle (three u32 indices).
pub const TRIANGLE_BYTES: u64 = 12;

/// How an algorithm maps onto the passes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Vertices on lattice edges (points own them), triangles per cell; `mc33` also adds
    /// vertices per cell, numbered after all edge vertices.
    Edges { mt: bool, mc33: bool },
    /// Vertices per cell, quads per lattice edge (points own them); `pad` layers of outside
    /// points around the grid (dual contouring).
    Dual { pad: usize },
}

impl Kind {
    /// How the passes run a method's [`GpuPasses`], with `pad` layers of outside points
    /// around the grid (its `Method::padding`).
    pub fn of(passes: GpuPasses, pad: usize) -> Self {
        match passes {
            GpuPasses::MarchingCubes => Kind::Edges { mt: false, mc33: false },
            GpuPasses::Tetrahedra => Kind::Edges { mt: true, mc33: false },
            GpuPasses::Mc33 => Kind::Edges { mt: false, mc33: true },
            GpuPasses::Dual => Kind::Dual { pad },
        }
    }

    pub fn mc33(self) -> bool {
        matches!(self, Kind::Edges { mc33: true, .. })
    }

    /// Layers of outside points padded around the grid.
    pub fn pad(self) -> usize {
        match self {
            Kind::Edges { .. } => 0,
            Kind::Dual { pad } => pad,
        }
    }

    /// A slab's counts from its owned point and cell totals (the scans' readback): vertices,
    /// triangles (mc33: `crossed` are the crossed cells, triangles and added vertices come
    /// from the mc33 count pass).
    pub fn counts(self, point_owned: u64, cell_owned: u64) -> SlabCounts {
        match self {
            Kind::Edges { mc33: true, .. } => {
                SlabCounts { vertices: point_owned, crossed: cell_owned, ..Default::default() }
            }
            Kind::Edges { .. } => {
                SlabCounts { vertices: point_owned, triangles: cell_owned, ..Default::default() }
            }
            Kind::Dual { .. } => SlabCounts {
                vertices: cell_owned,
                triangles: 2 * point_owned,
                ..Default::default()
            },
        }
    }
}

/// What one slab outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlabCounts {
    /// Edge (or dual) vertices.
    pub vertices: u64,
    pub triangles: u64,
    /// MC33: vertices added per cell.
    pub added: u64,
    /// MC33: crossed cells (one invocation each of the mc33 passes).
    pub crossed: u64,
}

/// Owned totals from the four counters read back after a slab's scans: the point scan at the
/// first and one past the last owned point, the cell scan likewise. Returns (points, cells).
pub fn owned(counters: &[u32]) -> (u64, u64) {
    (
        u64::from(counters[1].wrapping_sub(counters[0])),
        u64::from(counters[3].wrapping_sub(counters[2])),
    )
}

/// Sample layers a slab holds beyond its cell layers: its 2 extra point layers, one more layer
/// each side for the gradients of the cells around them, and the stencil of those cells
/// (trilinear: 4).
const VALUE_LAYERS: usize = 2 + 1 + STENCIL.below + STENCIL.above;

/// Which layers a slab holds and owns. Indices are into the slab's point / cell buffers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlabPlan {
    /// First owned cell layer (padded); the owned points start at layer `z0` too.
    pub z0: usize,
    /// One past the last owned cell layer.
    pub z1: usize,
    pub point_z0: usize,
    pub points: usize,
    pub cell_z0: usize,
    pub cells: usize,
    pub owned_point: usize,
    pub owned_point_end: usize,
    pub owned_cell: usize,
    pub owned_cell_end: usize,
    /// Samples held: padded point layers from `value_z0`, `values` points (one layer around
    /// the point layers, for the gradients of the cells on either side of them).
    pub value_z0: usize,
    pub values: usize,
}

impl SlabPlan {
    /// The slab of cell layers `[z0, z1)` of `cell_layers`, with `lp` points and `lc` cells per
    /// (padded) layer.
    pub fn new(kind: Kind, z0: usize, z1: usize, cell_layers: usize, lp: usize, lc: usize) -> Self {
        let mut plan = SlabPlan::layers(kind, z0, z1, cell_layers, lp, lc);
        let point_end = plan.point_z0 + plan.points / lp;
        // The cells on either side of the point layers (the gradients), with their stencils.
        plan.value_z0 = plan.point_z0.saturating_sub(1 + STENCIL.below);
        plan.values = ((point_end + STENCIL.above).min(cell_layers + 1) - plan.value_z0) * lp;
        plan
    }

    fn layers(kind: Kind, z0: usize, z1: usize, cell_layers: usize, lp: usize, lc: usize) -> Self {
        match kind {
            Kind::Edges { .. } => {
                // Points of layer z1 are read for their ids; the last slab owns them too.
                let owned_layers = z1 - z0 + usize::from(z1 == cell_layers);
                SlabPlan {
                    z0,
                    z1,
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
                    z1,
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

    /// The push constants of a pass over `count` items from padded layer `z0`.
    pub fn push(&self, count: usize, z0: usize, vertex_base: u32, mode: u32) -> SlabPush {
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

/// Checks the isovalue and the grid's shape.
pub fn validate(grid: &Grid, iso: f64) -> Result<(), MeshError> {
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
pub fn params(grid: &Grid, iso: f64, inside: Inside, pad: usize) -> ExtractParams {
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

/// The scratch buffers' sizes, in elements (u32 or f32), for slabs of up to `layers` cell
/// layers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScratchSizes {
    /// Point masks (the point scan holds one more, for the total).
    pub points: usize,
    /// The cell scan holds one more, for the total; so do the mc33 scans.
    pub cells: usize,
    pub values: usize,
}

/// How an extraction cuts the (padded) grid into slabs, and the running totals of the slabs
/// emitted so far. Drive it with [`Slabs::next`] and [`Slabs::counted`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Slabs {
    pub kind: Kind,
    /// Cell layers of the padded grid.
    pub cell_layers: usize,
    /// Points and cells per padded z layer.
    pub lp: usize,
    pub lc: usize,
    /// The largest binding a slab's buffer may take, in bytes.
    pub limit_bytes: u64,
    /// Cell layers of the next slab (halved when a slab's output does not fit).
    pub layers: usize,
    /// The next slab's first cell layer.
    z0: usize,
    /// Edge (or dual) vertices, triangles and mc33 added vertices of the slabs so far.
    pub totals: SlabCounts,
    /// Slabs emitted, and slabs halved and redone.
    pub slabs: usize,
    pub retries: usize,
}

/// What to do with a counted slab.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// Emit it: its first edge (or dual) vertex and first mc33 added vertex.
    Emit { bases: [u64; 2] },
    /// Its output does not fit one binding: count again with half the layers.
    Redo,
}

impl Slabs {
    /// The slab sizing of a grid of `dims` points for `kind` under a binding limit of
    /// `binding_bytes` (the device's `maxStorageBufferRange`, or a test's smaller one), with at
    /// most `max_layers` cell layers per slab when given.
    pub fn new(
        kind: Kind,
        dims: [usize; 3],
        binding_bytes: u64,
        max_layers: Option<usize>,
    ) -> Result<Self, GpuError> {
        let pad = kind.pad();
        let np = dims.map(|n| n + 2 * pad);
        let nc = np.map(|n| n - 1);
        let (lp, lc) = (np[0] * np[1], nc[0] * nc[1]);
        let limit_bytes = binding_bytes.min(MAX_SCRATCH_BYTES);
        let limit_elems = (limit_bytes / 4) as usize;
        // Slab depth: a slab holds at most `layers + 2` point layers (plus one total) and
        // `layers + VALUE_LAYERS` layers of samples.
        let by_limit = (limit_elems.saturating_sub(1) / lp).saturating_sub(VALUE_LAYERS);
        if by_limit == 0 {
            return Err(GpuError::TooLarge {
                what: format!("a z layer of {}x{} points", np[0], np[1]),
                limit: format!("one storage buffer ({limit_bytes} bytes)"),
            });
        }
        let mut layers = by_limit.min(nc[2]);
        if let Some(m) = max_layers {
            layers = layers.min(m.max(1));
        }
        Ok(Slabs {
            kind,
            cell_layers: nc[2],
            lp,
            lc,
            limit_bytes,
            layers,
            z0: 0,
            totals: SlabCounts::default(),
            slabs: 0,
            retries: 0,
        })
    }

    /// The scratch every slab fits in (sized for the first, deepest slabs).
    pub fn scratch(&self) -> ScratchSizes {
        ScratchSizes {
            points: (self.layers + 2) * self.lp,
            cells: (self.layers + 1) * self.lc,
            values: (self.layers + VALUE_LAYERS) * self.lp,
        }
    }

    /// The next slab to count, None when every layer is emitted.
    pub fn next(&self) -> Option<SlabPlan> {
        (self.z0 < self.cell_layers).then(|| {
            let z1 = (self.z0 + self.layers).min(self.cell_layers);
            SlabPlan::new(self.kind, self.z0, z1, self.cell_layers, self.lp, self.lc)
        })
    }

    /// Decides on the slab `plan` (from [`Slabs::next`]) with `counts`: redo it halved when its
    /// output would not fit one binding (an error for a single layer), fail when the mesh would
    /// overflow u32 ids, else emit it at the returned bases and add it to the totals.
    pub fn counted(&mut self, plan: &SlabPlan, counts: SlabCounts) -> Result<Step, GpuMeshError> {
        let SlabCounts { vertices, triangles, added, .. } = counts;
        let limit_bytes = self.limit_bytes;
        let fits = (vertices + added) * VERTEX_BYTES <= limit_bytes
            && triangles * TRIANGLE_BYTES <= limit_bytes;
        if !fits {
            if plan.z1 - plan.z0 == 1 {
                return Err(GpuError::TooLarge {
                    what: format!(
                        "the mesh of one z layer ({vertices} vertices, {triangles} triangles)"
                    ),
                    limit: format!("one storage buffer ({limit_bytes} bytes)"),
                }
                .into());
            }
            self.layers = (plan.z1 - plan.z0) / 2;
            self.retries += 1;
            return Ok(Step::Redo);
        }
        let t = &mut self.totals;
        if t.vertices + vertices + t.added + added >= u64::from(u32::MAX) {
            return Err(MeshError::TooLarge { what: "vertices" }.into());
        }
        if 3 * (t.triangles + triangles) >= u64::from(u32::MAX) {
            return Err(MeshError::TooLarge { what: "indices" }.into());
        }
        let bases = [t.vertices, t.added];
        t.vertices += vertices;
        t.triangles += triangles;
        t.added += added;
        self.slabs += 1;
        self.z0 = plan.z1;
        Ok(Step::Emit { bases })
    }
}

/// Where one slab's output goes in the assembled mesh, in bytes: its own (edge or dual)
/// vertices from the start of its vertex buffers to `vertex_at`, its mc33 added vertices (after
/// its own) to `added_at`, its triangles to `triangle_at`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PieceCopy {
    pub vertex_bytes: u64,
    pub vertex_at: u64,
    pub added_bytes: u64,
    pub added_at: u64,
    pub triangle_bytes: u64,
    pub triangle_at: u64,
}

/// The copies that assemble slab outputs (each with `vertices` vertices of which the last
/// `added` are mc33 added ones, and `triangles` triangles) into one mesh: every slab's own
/// vertices in slab order, then every slab's added vertices (from `total_own` own vertices on),
/// triangles in slab order.
pub fn assembly(pieces: &[SlabCounts], total_own: u64) -> Vec<PieceCopy> {
    let (mut v, mut a, mut t) = (0, total_own * VERTEX_BYTES, 0);
    pieces
        .iter()
        .map(|p| {
            let own = p.vertices - p.added;
            let c = PieceCopy {
                vertex_bytes: own * VERTEX_BYTES,
                vertex_at: v,
                added_bytes: p.added * VERTEX_BYTES,
                added_at: a,
                triangle_bytes: p.triangles * TRIANGLE_BYTES,
                triangle_at: t,
            };
            v += c.vertex_bytes;
            a += c.added_bytes;
            t += c.triangle_bytes;
            c
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const MC: Kind = Kind::Edges { mt: false, mc33: false };
    const DC: Kind = Kind::Dual { pad: 1 };

    /// Written for 2 points per axis before it was read from the stencil (and checked in
    /// `slabs_own_every_layer_once`: the samples are the point layers and one on either side).
    #[test]
    fn trilinear_slabs_hold_the_old_four_sample_layers() {
        assert_eq!(VALUE_LAYERS, 4);
    }

    /// Every owned point and cell layer of a grid is owned by exactly one slab, whatever the
    /// slab depth.
    #[test]
    fn slabs_own_every_layer_once() {
        let (lp, lc) = (20, 12);
        for kind in [MC, Kind::Edges { mt: true, mc33: true }, Kind::Dual { pad: 0 }, DC] {
            for cell_layers in 1..9 {
                for layers in 1..=cell_layers {
                    let (mut points, mut cells) = (0, 0);
                    let mut z0 = 0;
                    while z0 < cell_layers {
                        let z1 = (z0 + layers).min(cell_layers);
                        let p = SlabPlan::new(kind, z0, z1, cell_layers, lp, lc);
                        assert!(p.owned_point_end <= p.points && p.owned_cell_end <= p.cells);
                        assert_eq!(p.owned_point, (z0 - p.point_z0) * lp, "{kind:?}");
                        points += p.owned_point_end - p.owned_point;
                        cells += p.owned_cell_end - p.owned_cell;
                        // The samples cover the point layers and one layer on either side,
                        // within the grid.
                        assert_eq!(p.value_z0, p.point_z0.saturating_sub(1));
                        let point_end = p.point_z0 + p.points / lp;
                        assert_eq!(
                            p.value_z0 + p.values / lp,
                            (point_end + 1).min(cell_layers + 1)
                        );
                        z0 = z1;
                    }
                    let owned_points = match kind {
                        Kind::Edges { .. } => (cell_layers + 1) * lp,
                        Kind::Dual { .. } => cell_layers * lp,
                    };
                    assert_eq!(points, owned_points, "{kind:?} {cell_layers} {layers}");
                    assert_eq!(cells, cell_layers * lc, "{kind:?} {cell_layers} {layers}");
                }
            }
        }
    }

    #[test]
    fn dual_slabs_read_the_cell_layer_before() {
        let p = SlabPlan::new(DC, 3, 5, 9, 16, 9);
        assert_eq!((p.point_z0, p.cell_z0), (2, 2));
        assert_eq!((p.points, p.cells), (4 * 16, 3 * 9));
        assert_eq!((p.owned_cell, p.owned_cell_end), (9, 27));
        let push = p.push(7, p.z0, 11, 1);
        assert_eq!((push.count, push.z0, push.point_z0, push.vertex_base), (7, 3, 2, 11));
        assert_eq!((push.owned_point, push.owned_point_end), (16, 48));
    }

    #[test]
    fn slab_depth_follows_the_binding_limit() {
        // 10x10 points per layer: (limit/4 - 1) / 100 - 4 layers.
        let s = Slabs::new(MC, [10, 10, 100], 4 * 1001, None).unwrap();
        assert_eq!(s.layers, 6);
        assert_eq!(s.scratch(), ScratchSizes { points: 800, cells: 7 * 81, values: 1000 });
        assert_eq!(Slabs::new(MC, [10, 10, 4], 4 * 1001, None).unwrap().layers, 3);
        assert_eq!(Slabs::new(MC, [10, 10, 100], 4 * 1001, Some(2)).unwrap().layers, 2);
        assert_eq!(Slabs::new(MC, [10, 10, 100], 4 * 1001, Some(0)).unwrap().layers, 1);
        // Dual contouring pads: 12x12 points per layer.
        let s = Slabs::new(DC, [10, 10, 100], 4 * 1001, None).unwrap();
        assert_eq!((s.lp, s.lc, s.cell_layers, s.layers), (144, 121, 101, 2));
        // A layer that leaves no room for one slab.
        assert!(Slabs::new(MC, [10, 10, 100], 4 * 500, None).is_err());
        // Never more than MAX_SCRATCH_BYTES per buffer.
        let s = Slabs::new(MC, [2, 2, 1 << 30], u64::MAX, None).unwrap();
        assert_eq!(s.limit_bytes, MAX_SCRATCH_BYTES);
        assert_eq!(s.layers, ((MAX_SCRATCH_BYTES / 4 - 1) / 4 - 4) as usize);
    }

    fn counts(vertices: u64, triangles: u64) -> SlabCounts {
        SlabCounts { vertices, triangles, ..Default::default() }
    }

    #[test]
    fn slabs_walk_the_grid_with_running_bases() {
        let mut s = Slabs::new(MC, [3, 3, 7], 1 << 20, Some(4)).unwrap();
        let a = s.next().unwrap();
        assert_eq!((a.z0, a.z1), (0, 4));
        assert_eq!(s.counted(&a, counts(10, 5)).unwrap(), Step::Emit { bases: [0, 0] });
        let b = s.next().unwrap();
        assert_eq!((b.z0, b.z1), (4, 6));
        assert_eq!(s.counted(&b, counts(7, 3)).unwrap(), Step::Emit { bases: [10, 0] });
        assert_eq!(s.next(), None);
        assert_eq!((s.totals.vertices, s.totals.triangles, s.slabs, s.retries), (17, 8, 2, 0));
    }

    #[test]
    fn a_slab_too_large_is_halved_and_redone() {
        // 64 bytes per binding: 4 vertices or 5 triangles.
        let mut s = Slabs { limit_bytes: 64, ..Slabs::new(MC, [3, 3, 9], 1 << 20, None).unwrap() };
        let a = s.next().unwrap();
        assert_eq!((a.z0, a.z1), (0, 8));
        assert_eq!(s.counted(&a, counts(5, 1)).unwrap(), Step::Redo);
        assert_eq!(s.layers, 4);
        let a = s.next().unwrap();
        assert_eq!((a.z0, a.z1), (0, 4));
        assert_eq!(s.counted(&a, counts(2, 6)).unwrap(), Step::Redo);
        let a = s.next().unwrap();
        assert_eq!((a.z0, a.z1), (0, 2));
        assert_eq!(s.counted(&a, counts(4, 5)).unwrap(), Step::Emit { bases: [0, 0] });
        assert_eq!((s.retries, s.slabs, s.totals.vertices), (2, 1, 4));
        // mc33 added vertices count against the binding too.
        let b = s.next().unwrap();
        let over = SlabCounts { vertices: 3, added: 2, ..Default::default() };
        assert_eq!(s.counted(&b, over).unwrap(), Step::Redo);
        // A single layer that does not fit is an error.
        s.layers = 1;
        let c = s.next().unwrap();
        assert!(matches!(s.counted(&c, counts(5, 0)), Err(GpuMeshError::Gpu(_))));
    }

    #[test]
    fn ids_past_u32_are_refused() {
        let mut s = Slabs::new(MC, [3, 3, 9], u64::MAX, Some(1)).unwrap();
        s.limit_bytes = u64::MAX / 64;
        let a = s.next().unwrap();
        s.counted(&a, counts(u64::from(u32::MAX) - 10, 0)).unwrap();
        let b = s.next().unwrap();
        let e = s.counted(&b, counts(10, 0)).unwrap_err();
        assert!(matches!(e, GpuMeshError::Mesh(MeshError::TooLarge { what: "vertices" })));
        let mut s = Slabs::new(MC, [3, 3, 9], u64::MAX, Some(1)).unwrap();
        s.limit_bytes = u64::MAX / 64;
        let a = s.next().unwrap();
        let e = s.counted(&a, counts(0, u64::from(u32::MAX) / 3)).unwrap_err();
        assert!(matches!(e, GpuMeshError::Mesh(MeshError::TooLarge { what: "indices" })));
    }

    #[test]
    fn assembly_puts_own_vertices_first_then_added() {
        let pieces = [
            SlabCounts { vertices: 5, added: 2, triangles: 4, crossed: 0 },
            SlabCounts { vertices: 3, added: 0, triangles: 1, crossed: 0 },
            SlabCounts { vertices: 4, added: 1, triangles: 2, crossed: 0 },
        ];
        let own = 3 + 3 + 3;
        let c = assembly(&pieces, own);
        let at = |c: &PieceCopy| (c.vertex_at / 16, c.added_at / 16, c.triangle_at / 12);
        assert_eq!(c.iter().map(at).collect::<Vec<_>>(), [(0, 9, 0), (3, 11, 4), (6, 11, 5)]);
        assert_eq!((c[0].vertex_bytes, c[0].added_bytes, c[0].triangle_bytes), (48, 32, 48));
        assert_eq!(c[1].added_bytes, 0);
    }

    #[test]
    fn counters_give_owned_totals() {
        assert_eq!(owned(&[3, 10, 0, 7]), (7, 7));
        // The scans wrap at 2^32; the difference does not.
        assert_eq!(owned(&[u32::MAX, 4, 1, 1]), (5, 0));
        assert_eq!(MC.counts(4, 6), counts(4, 6));
        assert_eq!(DC.counts(4, 6), counts(6, 8));
        let mc33 = Kind::of(GpuPasses::Mc33, 0).counts(4, 6);
        assert_eq!(mc33, SlabCounts { vertices: 4, crossed: 6, ..Default::default() });
    }
}
