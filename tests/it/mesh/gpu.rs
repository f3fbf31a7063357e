//! GPU extraction (`passes::extract`) against the CPU references (`mesh::extract`): on random grids,
//! both inside modes, random isovalues and isovalues equal to samples, the GPU mesh has the
//! reference's vertices in the same order (positions within 1e-5 of a cell plus f32 rounding of
//! the coordinates, normals within 1e-3) and exactly its triangles; slabs of any depth join
//! without a seam; empty results; slabs sized by the binding limit and halved when their output
//! would not fit.

use std::sync::Arc;

use glam::DVec3;
use isoview::field::Grid;
use isoview::gpu::{Context, Image3d};
use isoview::mesh::{reference, ExtractOptions, Mesh, QuadSplit, Request};
use isoview::passes::extract::{ExtractStats, Extractor, GpuExtractOptions, GpuMeshError};
use isoview::scene::{Inside, MeshAlgorithm};

use crate::common::*;

const GPU_ALGOS: [MeshAlgorithm; 5] = [
    MeshAlgorithm::MarchingCubes,
    MeshAlgorithm::Mc33,
    MeshAlgorithm::MarchingTetrahedra,
    MeshAlgorithm::SurfaceNets,
    MeshAlgorithm::DualContouring,
];

/// Position tolerance per axis: 1e-5 of a cell, plus 4 f32 ulps of the largest coordinate of the
/// box (the reference rounds its f64 positions to f32 once, the GPU computes in f32).
fn position_tol(grid: &Grid) -> DVec3 {
    let extent = grid.min.abs().max(grid.max.abs()).max_element();
    grid.spacing() * 1e-5 + DVec3::splat(extent * f64::from(f32::EPSILON) * 4.0)
}

/// Largest allowed |n_gpu - n_cpu| (f32 gradients against f64 ones).
const NORMAL_TOL: f64 = 1e-3;

struct Gpu {
    ctx: Arc<Context>,
    extractor: Extractor,
}

impl Gpu {
    fn new() -> Self {
        let ctx = gpu();
        let extractor = Extractor::new(&ctx).expect("extractor");
        Gpu { ctx, extractor }
    }

    fn run(
        &mut self,
        c: &Case,
        algo: MeshAlgorithm,
        opts: &GpuExtractOptions,
    ) -> Result<(Mesh, ExtractStats), GpuMeshError> {
        let extent = c.grid.dims.map(|d| d as u32);
        let image = Image3d::upload(&self.ctx, "grid", extent, &c.grid.values)?;
        let mesh = self.extractor.extract(&c.grid, &image, c.iso, c.inside, algo, opts)?;
        assert!(mesh.positions.size >= 16 * u64::from(mesh.vertex_count));
        assert!(mesh.indices.size >= 12 * u64::from(mesh.triangle_count));
        Ok((mesh.read()?, self.extractor.last))
    }
}

fn cpu(c: &Case, algo: MeshAlgorithm, split: QuadSplit) -> Mesh {
    let opts = ExtractOptions { split, keep_quads: false };
    reference(&c.grid, &Request::new(c.iso, c.inside, algo).with_opts(opts))
        .expect("CPU extraction")
}

/// Largest position and normal differences, after asserting equal counts and tolerances.
fn assert_vertices_match(c: &Case, gpu: &Mesh, cpu: &Mesh, what: &str) -> (f64, f64) {
    assert_eq!(gpu.vertex_count(), cpu.vertex_count(), "{what}: vertex count");
    let tol = position_tol(&c.grid);
    let spacing = c.grid.spacing();
    let (mut worst_p, mut worst_n) = (0.0f64, 0.0f64);
    for v in 0..cpu.vertex_count() {
        let g = DVec3::from(gpu.positions[v].map(f64::from));
        let r = DVec3::from(cpu.positions[v].map(f64::from));
        let d = (g - r).abs();
        assert!(d.cmple(tol).all(), "{what}: vertex {v} at {g} vs {r} (tolerance {tol})");
        worst_p = worst_p.max((d / spacing).max_element());
        let gn = DVec3::from(gpu.normals[v].map(f64::from));
        let rn = DVec3::from(cpu.normals[v].map(f64::from));
        let dn = (gn - rn).length();
        assert!(dn <= NORMAL_TOL, "{what}: normal {v} {gn} vs {rn}");
        worst_n = worst_n.max(dn);
    }
    (worst_p, worst_n)
}

#[gpu_test]
fn gpu_equals_cpu_on_random_grids() {
    let mut gpu = Gpu::new();
    let mut rng = Rng::new(41);
    let opts = GpuExtractOptions { split: QuadSplit::Fixed, ..Default::default() };
    for algo in GPU_ALGOS {
        let (mut worst_p, mut worst_n, mut verts, mut tris) = (0.0f64, 0.0f64, 0, 0);
        for round in 0..24 {
            let c = random_case(&mut rng, 12);
            let what = format!(
                "{} round {round} dims {:?} iso {} {:?}",
                algo.name(),
                c.grid.dims,
                c.iso,
                c.inside
            );
            let reference = cpu(&c, algo, QuadSplit::Fixed);
            let (mesh, _) = gpu.run(&c, algo, &opts).unwrap();
            let (p, n) = assert_vertices_match(&c, &mesh, &reference, &what);
            assert_eq!(mesh.indices, reference.indices, "{what}: triangles");
            worst_p = worst_p.max(p);
            worst_n = worst_n.max(n);
            verts += mesh.vertex_count();
            tris += mesh.triangle_count();
        }
        eprintln!(
            "{}: {verts} vertices, {tris} triangles equal; worst position {worst_p:.2e} cells, \
             worst normal {worst_n:.2e}",
            algo.name()
        );
    }
}

/// With the shorter-diagonal split the GPU compares f32 diagonals: a quad may split the other way
/// only where the two diagonals tie to f32 precision.
#[gpu_test]
fn shorter_split_differs_only_at_ties() {
    let mut gpu = Gpu::new();
    let mut rng = Rng::new(7);
    let opts = GpuExtractOptions { split: QuadSplit::Shorter, ..Default::default() };
    for algo in [MeshAlgorithm::SurfaceNets, MeshAlgorithm::DualContouring] {
        let (mut quads, mut ties) = (0, 0);
        for _ in 0..16 {
            let c = random_case(&mut rng, 12);
            let reference = cpu(&c, algo, QuadSplit::Shorter);
            let (mesh, _) = gpu.run(&c, algo, &opts).unwrap();
            assert_vertices_match(&c, &mesh, &reference, algo.name());
            assert_eq!(mesh.indices.len(), reference.indices.len());
            for (q, (g, r)) in mesh.indices.chunks(6).zip(reference.indices.chunks(6)).enumerate() {
                quads += 1;
                if g == r {
                    continue;
                }
                // The same quad (q0 q1 q2 q3) split along the other diagonal.
                let quad =
                    if r[2] == r[4] { [r[0], r[1], r[2], r[5]] } else { [r[0], r[1], r[4], r[2]] };
                let p = |i: u32| DVec3::from(reference.positions[i as usize].map(f64::from));
                let d02 = p(quad[0]).distance_squared(p(quad[2]));
                let d13 = p(quad[1]).distance_squared(p(quad[3]));
                assert!(
                    (d02 - d13).abs() <= 1e-5 * d02.max(d13),
                    "{}: quad {q} split {g:?} vs {r:?}, diagonals² {d02} vs {d13}",
                    algo.name()
                );
                ties += 1;
            }
        }
        eprintln!("{}: {quads} quads, {ties} near-tie splits differ", algo.name());
    }
}

/// Slabs of 1, 2 and 3 cell layers give the same mesh, bit for bit, as one slab (with either
/// quad split), and it equals the reference.
#[gpu_test]
fn slabs_join_without_seams() {
    let mut gpu = Gpu::new();
    let mut rng = Rng::new(3);
    for algo in GPU_ALGOS {
        for _ in 0..3 {
            let mut c = random_case(&mut rng, 9);
            c.grid = random_grid(&mut rng, [7, 6, 11]);
            let fixed = GpuExtractOptions { split: QuadSplit::Fixed, ..Default::default() };
            let (whole, stats) = gpu.run(&c, algo, &fixed).unwrap();
            assert_eq!(stats.slabs, 1);
            let reference = cpu(&c, algo, QuadSplit::Fixed);
            assert_vertices_match(&c, &whole, &reference, algo.name());
            assert_eq!(whole.indices, reference.indices);
            let shorter = GpuExtractOptions { split: QuadSplit::Shorter, ..fixed };
            let (whole_shorter, _) = gpu.run(&c, algo, &shorter).unwrap();
            for layers in [1, 2, 3] {
                for (base, whole) in [(fixed, &whole), (shorter, &whole_shorter)] {
                    let opts = GpuExtractOptions { max_slab_layers: Some(layers), ..base };
                    let (sliced, stats) = gpu.run(&c, algo, &opts).unwrap();
                    let cells =
                        c.grid.dims[2] - 1 + 2 * usize::from(algo == MeshAlgorithm::DualContouring);
                    assert_eq!(stats.slabs, cells.div_ceil(layers), "{} slabs", algo.name());
                    assert_eq!(&sliced, whole, "{} in slabs of {layers} layers", algo.name());
                }
            }
        }
    }
}

/// A binding limit of 16 KiB: slabs are sized from it, and a slab whose output would not fit
/// is halved and redone; the mesh still equals the reference.
#[gpu_test]
fn small_binding_limit_splits_and_retries() {
    let mut gpu = Gpu::new();
    let mut rng = Rng::new(11);
    for algo in GPU_ALGOS {
        let c =
            Case { grid: random_grid(&mut rng, [12, 10, 24]), iso: 0.05, inside: Inside::Below };
        let opts = GpuExtractOptions {
            split: QuadSplit::Fixed,
            max_binding_bytes: Some(16 << 10),
            ..Default::default()
        };
        let (mesh, stats) = gpu.run(&c, algo, &opts).unwrap();
        let reference = cpu(&c, algo, QuadSplit::Fixed);
        assert_vertices_match(&c, &mesh, &reference, algo.name());
        assert_eq!(mesh.indices, reference.indices, "{}", algo.name());
        assert!(stats.slabs > 1 && stats.retries > 0, "{}: {stats:?}", algo.name());
        eprintln!("{}: {} slabs, {} halved", algo.name(), stats.slabs, stats.retries);
    }
}

#[gpu_test]
fn no_crossing_gives_an_empty_mesh() {
    let mut gpu = Gpu::new();
    let mut rng = Rng::new(5);
    let grid = random_grid(&mut rng, [6, 5, 7]);
    for algo in GPU_ALGOS {
        for (iso, inside) in [(2.0, Inside::Below), (2.0, Inside::Above), (-2.0, Inside::Below)] {
            let c = Case { grid: grid.clone(), iso, inside };
            let (mesh, _) = gpu.run(&c, algo, &GpuExtractOptions::default()).unwrap();
            let reference = cpu(&c, algo, QuadSplit::Shorter);
            assert_eq!(mesh.vertex_count(), reference.vertex_count(), "{}", algo.name());
            assert_eq!(mesh.indices, reference.indices, "{}", algo.name());
            // Only dual contouring caps a grid that is all inside.
            let capped =
                algo == MeshAlgorithm::DualContouring && (iso, inside) == (2.0, Inside::Below);
            assert_eq!(mesh.vertex_count() == 0, !capped, "{} iso {iso} {inside:?}", algo.name());
        }
    }
}

/// A sphere in the middle of a tall grid cut into slabs: the slabs above and below it are empty.
#[gpu_test]
fn empty_slabs_around_a_surface() {
    let mut gpu = Gpu::new();
    let grid = grid_from([9, 9, 30], DVec3::splat(-1.0), DVec3::new(1.0, 1.0, 6.0), |p| {
        (p - DVec3::new(0.0, 0.0, 2.5)).length() - 0.7
    });
    let c = Case { grid, iso: 0.0, inside: Inside::Below };
    for algo in GPU_ALGOS {
        let opts = GpuExtractOptions {
            split: QuadSplit::Fixed,
            max_slab_layers: Some(4),
            ..Default::default()
        };
        let (mesh, stats) = gpu.run(&c, algo, &opts).unwrap();
        let reference = cpu(&c, algo, QuadSplit::Fixed);
        assert!(reference.triangle_count() > 0);
        assert_vertices_match(&c, &mesh, &reference, algo.name());
        assert_eq!(mesh.indices, reference.indices, "{}", algo.name());
        assert!(stats.slabs >= 7);
    }
}

#[gpu_test]
fn runs_are_deterministic() {
    let mut gpu = Gpu::new();
    let mut rng = Rng::new(9);
    let c = random_case(&mut rng, 16);
    for algo in GPU_ALGOS {
        let (a, _) = gpu.run(&c, algo, &GpuExtractOptions::default()).unwrap();
        let (b, _) = gpu.run(&c, algo, &GpuExtractOptions::default()).unwrap();
        let bits = |m: &Mesh| -> Vec<u32> {
            m.positions.iter().chain(&m.normals).flatten().map(|x| x.to_bits()).collect()
        };
        assert_eq!(bits(&a), bits(&b), "{}", algo.name());
        assert_eq!(a.indices, b.indices, "{}", algo.name());
    }
}

/// mc33 needs `shaderFloat64` (lavapipe has it): with it the GPU extracts, without it the
/// extraction says so. Tiny bindings and NaN isovalues are errors.
#[gpu_test]
fn mc33_support_bad_input_and_tiny_bindings() {
    let mut gpu = Gpu::new();
    let mut rng = Rng::new(1);
    let c = Case { grid: random_grid(&mut rng, [4, 4, 4]), iso: 0.0, inside: Inside::Below };
    let opts = GpuExtractOptions::default();
    match gpu.run(&c, MeshAlgorithm::Mc33, &opts) {
        Ok((mesh, _)) => {
            assert!(gpu.ctx.info.float64);
            let reference = cpu(&c, MeshAlgorithm::Mc33, QuadSplit::Fixed);
            assert_vertices_match(&c, &mesh, &reference, "mc33");
            assert_eq!(mesh.indices, reference.indices);
        }
        Err(err) => {
            assert!(!gpu.ctx.info.float64, "{err}");
            assert!(matches!(err, GpuMeshError::Unsupported("mc33")), "{err}");
        }
    }
    let tiny = GpuExtractOptions { max_binding_bytes: Some(64), ..opts };
    let err = gpu.run(&c, MeshAlgorithm::SurfaceNets, &tiny).expect_err("64-byte bindings");
    assert!(err.to_string().contains("does not fit one storage buffer"), "{err}");
    let bad = Case { iso: f64::NAN, ..c };
    let err = gpu.run(&bad, MeshAlgorithm::MarchingCubes, &opts).expect_err("NaN isovalue");
    assert!(err.to_string().contains("isovalue"), "{err}");
}

/// Every sign configuration of a cell, 16 times with other magnitudes: random ones (which
/// send each face and interior ambiguity both ways), ones from {0.25, 0.5, 1} (exact ties of
/// the face and section saddles) and outside corners equal to the isovalue. The cells sit at
/// even coordinates of one grid (the cells between them mix two configurations), extracted
/// whole and in slabs of 2 layers; the GPU mesh equals the CPU reference, tunnels and added
/// vertices included.
#[gpu_test(float64)]
fn mc33_every_cell_configuration_matches_the_reference() {
    let mut gpu = Gpu::new();
    need_float64(&gpu.ctx);
    let mut rng = Rng::new(33);
    let (na, nb, nc) = (16, 16, 16); // 4096 case cells: 256 masks x 16 variants
    let dims = [2 * na, 2 * nb, 2 * nc];
    for inside in Inside::ALL {
        let mut grid = random_grid(&mut rng, dims);
        grid.values.iter_mut().for_each(|v| *v = 0.0);
        for case in 0..na * nb * nc {
            let (mask, variant) = (case % 256, case / 256);
            let (a, b, c) = (case % na, (case / na) % nb, case / (na * nb));
            for corner in 0..8 {
                let magnitude = match variant % 4 {
                    0 | 1 => rng.range(0.01, 1.0),
                    2 => [0.25, 0.5, 1.0][(rng.next_u64() % 3) as usize],
                    _ => rng.range(0.2, 0.3),
                };
                let is_in = (mask >> corner) & 1 == 1;
                let below = inside == Inside::Below;
                // Signed so that `is_in` corners are inside; a fifth of the outside corners of
                // variants 1 and 3 sit exactly on the isovalue (which is outside).
                let on_iso = !is_in && variant % 2 == 1 && rng.next_u64() % 5 == 0;
                let v = if on_iso {
                    0.0
                } else if is_in == below {
                    -magnitude
                } else {
                    magnitude
                };
                let (i, j, k) =
                    (2 * a + (corner & 1), 2 * b + (corner >> 1 & 1), 2 * c + (corner >> 2));
                grid.values[i + dims[0] * (j + dims[1] * k)] = v as f32;
            }
        }
        let case = Case { grid, iso: 0.0, inside };
        let reference = cpu(&case, MeshAlgorithm::Mc33, QuadSplit::Fixed);
        let mc = cpu(&case, MeshAlgorithm::MarchingCubes, QuadSplit::Fixed);
        let added = reference.vertex_count() - mc.vertex_count();
        assert!(added > 100, "{inside:?}: only {added} added vertices (tunnels, centres)");
        for layers in [None, Some(2)] {
            let opts = GpuExtractOptions { max_slab_layers: layers, ..Default::default() };
            let (mesh, stats) = gpu.run(&case, MeshAlgorithm::Mc33, &opts).unwrap();
            let what = format!("mc33 {inside:?} slabs of {layers:?} layers");
            assert_vertices_match(&case, &mesh, &reference, &what);
            assert_eq!(mesh.indices, reference.indices, "{what}: triangles");
            eprintln!(
                "{what}: {} slabs, {} vertices ({added} added), {} triangles equal",
                stats.slabs,
                mesh.vertex_count(),
                mesh.triangle_count()
            );
        }
    }
}

/// The multi-level scan on lengths around its block size and over three levels.
#[gpu_test]
fn scan_is_an_exclusive_prefix_sum() {
    use isoview::gpu::{vk, Buffer, MemoryLocation, Tracker};
    use isoview::passes::extract::{ExtractPasses, Scan};
    let ctx = gpu();
    let passes = ExtractPasses::new(&ctx).unwrap();
    let mut rng = Rng::new(17);
    for len in [1usize, 2, 1023, 1024, 1025, 4096 + 3, 1 << 20, (1 << 20) + 1025 * 3] {
        let data: Vec<u32> = (0..len).map(|_| (rng.next_u64() % 8) as u32).collect();
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_SRC
            | vk::BufferUsageFlags::TRANSFER_DST;
        let bytes = len as u64 * 4;
        let mut up = Buffer::new(&ctx, "up", bytes, usage, MemoryLocation::CpuToGpu).unwrap();
        up.write(&data).unwrap();
        let buf = Buffer::new(&ctx, "data", bytes, usage, MemoryLocation::GpuOnly).unwrap();
        let down = Buffer::new(&ctx, "down", bytes, usage, MemoryLocation::GpuToCpu).unwrap();
        let scan = Scan::new(&ctx, &passes, "test", &buf, len as u64 + 7).unwrap();
        ctx.record("scan test", &mut Tracker::default(), |rec| {
            rec.copy(&up, 0, &buf, 0, bytes);
            scan.record(rec, &passes, len as u64)?;
            rec.readback(&buf, &down, bytes);
            Ok(())
        })
        .unwrap();
        let got: Vec<u32> = down.read(len).unwrap();
        let mut sum = 0u32;
        let want: Vec<u32> = data
            .iter()
            .map(|&x| {
                let before = sum;
                sum += x;
                before
            })
            .collect();
        assert_eq!(got, want, "scan of {len}");
    }
}

/// Closed-form answers through the one-call API: for a linear field every vertex of every
/// algorithm lies on the plane and every normal is the plane's (the trilinear interpolant is
/// the plane itself); for a sphere's distance field the vertices lie within a fraction of a cell
/// of the sphere and the normals point radially.
#[gpu_test]
fn closed_form_plane_and_sphere() {
    let ctx = gpu();
    let a = DVec3::new(0.3, -0.5, 0.8);
    let plane = grid_from([9, 8, 10], DVec3::splat(-1.0), DVec3::ONE, |p| a.dot(p) - 0.1);
    let sphere = grid_from([24, 24, 24], DVec3::splat(-1.0), DVec3::ONE, |p| p.length() - 0.7);
    let h = sphere.spacing().x;
    for algo in GPU_ALGOS {
        let m = isoview::passes::extract::extract(&ctx, &plane, 0.0, Inside::Below, algo)
            .unwrap()
            .read()
            .unwrap();
        assert!(m.triangle_count() > 0);
        for (p, n) in m.positions.iter().zip(&m.normals) {
            let (p, n) = (DVec3::from(p.map(f64::from)), DVec3::from(n.map(f64::from)));
            let on_box = p.abs().max_element() > 1.0 - 1e-6;
            // Dual contouring's caps lie in the box faces, with the box's normals.
            if algo == MeshAlgorithm::DualContouring && on_box {
                continue;
            }
            assert!((a.dot(p) - 0.1).abs() < 1e-5, "{}: {p} off the plane", algo.name());
            assert!((n - a.normalize()).length() < 1e-5, "{}: normal {n}", algo.name());
        }
        let m = isoview::passes::extract::extract(&ctx, &sphere, 0.0, Inside::Below, algo)
            .unwrap()
            .read()
            .unwrap();
        for (p, n) in m.positions.iter().zip(&m.normals) {
            let (p, n) = (DVec3::from(p.map(f64::from)), DVec3::from(n.map(f64::from)));
            assert!((p.length() - 0.7).abs() < 0.1 * h, "{}: {p} off the sphere", algo.name());
            assert!(n.dot(p.normalize()) > 0.99, "{}: normal {n} at {p}", algo.name());
        }
    }
}

/// `dual-contouring-qef` on the GPU (f32 QEF solve) against the f64 reference: same vertex
/// count and order, the same triangles (cells and quads do not depend on positions with the
/// fixed split), and positions within [`QEF_TOL_CELLS`] of a cell and normals within
/// `NORMAL_TOL` for all but a small share of vertices (a vertex on a cell face whose f32 and
/// f64 positions fall on different sides of it gets the other cell's trilinear normal).
///
/// Why a looser, two-part tolerance than the other algorithms': the vertex is `m + Σ vᵢ (vᵢ ·
/// r) / λᵢ` over the eigenvalues λᵢ above the cut `threshold² λ_max`. In f32, an eigenvalue
/// just above the cut divides a rounding error of ~1e-7 by λᵢ ≥ 0.01 λ_max, so a well
/// separated solve agrees to ~1e-5 cells; but where λᵢ lies within f32 rounding of the cut
/// (or the Jacobi sweep's residual), the f32 and f64 solves keep different sets of directions,
/// and the vertex moves along the dropped direction by up to the cell (clamped): random noise
/// fields, with their many nearly flat corner configurations, have such cells. Those vertices
/// are allowed up to one cell, and must be under [`QEF_STRADDLE_SHARE`] of all.
#[gpu_test]
fn dual_contouring_qef_gpu_equals_cpu_within_the_qef_tolerance() {
    use isoview::scene::SharpSettings;
    let mut gpu = Gpu::new();
    let mut rng = Rng::new(1515);
    let algo = MeshAlgorithm::DualContouringQef;
    let (mut verts, mut off, mut worst_good, mut worst) = (0usize, 0usize, 0.0f64, 0.0f64);
    for round in 0..32 {
        let c = if round % 2 == 0 { random_case(&mut rng, 14) } else { smooth_case(&mut rng) };
        let sharp = SharpSettings { qef_clamp: round % 4 != 3, ..Default::default() };
        let opts =
            GpuExtractOptions { split: QuadSplit::Fixed, sharp: Some(sharp), ..Default::default() };
        let eopts = ExtractOptions { split: QuadSplit::Fixed, keep_quads: false };
        let reference = reference(
            &c.grid,
            &Request::new(c.iso, c.inside, algo).with_opts(eopts).with_sharp(sharp),
        )
        .unwrap();
        let (mesh, _) = gpu.run(&c, algo, &opts).unwrap();
        let what = format!("round {round} dims {:?} iso {} {:?}", c.grid.dims, c.iso, c.inside);
        assert_eq!(mesh.vertex_count(), reference.vertex_count(), "{what}");
        assert_eq!(mesh.indices, reference.indices, "{what}: triangles");
        let spacing = c.grid.spacing();
        let cells = |m: &Mesh, v: usize| {
            let g = DVec3::from(m.positions[v].map(f64::from));
            let r = DVec3::from(reference.positions[v].map(f64::from));
            ((g - r).abs() / spacing).max_element()
        };
        if round % 2 == 1 {
            // Slabs of 2 layers join without a seam: the same mesh bit for bit.
            let slabbed = GpuExtractOptions { max_slab_layers: Some(2), ..opts };
            assert_eq!(gpu.run(&c, algo, &slabbed).unwrap().0, mesh, "{what}: slabs of 2");
            // The comparison has teeth: the GPU's mean vertices (dual-contouring), or its QEF
            // with another threshold, are told apart from the reference.
            for other in [
                gpu.run(&c, MeshAlgorithm::DualContouring, &opts).unwrap().0,
                gpu.run(
                    &c,
                    algo,
                    &GpuExtractOptions {
                        sharp: Some(SharpSettings { qef_threshold: 0.6, ..sharp }),
                        ..opts
                    },
                )
                .unwrap()
                .0,
            ] {
                let far = (0..other.vertex_count()).map(|v| cells(&other, v)).fold(0.0, f64::max);
                assert!(far > 10.0 * QEF_TOL_CELLS, "{what}: {far}");
            }
        }
        for v in 0..mesh.vertex_count() {
            let (g, r) = (mesh.positions[v], reference.positions[v]);
            let d = cells(&mesh, v);
            let dn = (DVec3::from(mesh.normals[v].map(f64::from))
                - DVec3::from(reference.normals[v].map(f64::from)))
            .length();
            if d > QEF_TOL_CELLS || dn > NORMAL_TOL {
                off += 1;
                // Unclamped, a dropped direction is not bounded by the cell.
                if sharp.qef_clamp {
                    assert!(d <= 1.0 + 1e-5, "{what}: vertex {v} {g:?} vs {r:?}: {d} cells");
                }
            } else {
                worst_good = worst_good.max(d);
            }
            worst = worst.max(d);
        }
        verts += mesh.vertex_count();
    }
    eprintln!(
        "dual-contouring-qef: {verts} vertices; {off} beyond {QEF_TOL_CELLS} cells or \
         {NORMAL_TOL} in the normal (worst position {worst:.2e} cells), the rest within \
         {worst_good:.2e} cells"
    );
    assert!((off as f64) < QEF_STRADDLE_SHARE * verts as f64, "{off} of {verts}");
}

/// Position tolerance of the GPU QEF solve, in cells (see the test above).
const QEF_TOL_CELLS: f64 = 1e-3;
/// Share of vertices whose f32 and f64 QEF solves may keep different directions.
const QEF_STRADDLE_SHARE: f64 = 0.01;

/// A smooth field: a few random spheres' union minus a box, on a random grid of up to 16
/// points per axis (sharp creases, well conditioned cells).
fn smooth_case(rng: &mut Rng) -> Case {
    let dims = [0; 3].map(|_| 6 + (rng.next_u64() % 11) as usize);
    let centres: Vec<(DVec3, f64)> = (0..3)
        .map(|_| {
            (
                DVec3::new(rng.range(0.3, 0.7), rng.range(0.3, 0.7), rng.range(0.3, 0.7)),
                rng.range(0.15, 0.3),
            )
        })
        .collect();
    let corner = DVec3::new(rng.range(0.4, 0.6), rng.range(0.4, 0.6), rng.range(0.4, 0.6));
    let mut grid = Grid { dims, min: DVec3::ZERO, max: DVec3::ONE, values: Vec::new() };
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = grid.point(i, j, k);
                let blobs =
                    centres.iter().map(|&(c, r)| (p - c).length() - r).fold(f64::MAX, f64::min);
                let q = (p - corner).abs() - 0.12;
                let cut = q.max(DVec3::ZERO).length() + q.max_element().min(0.0);
                grid.values.push(blobs.max(-cut) as f32);
            }
        }
    }
    Case { grid, iso: 0.0, inside: Inside::Below }
}

/// A scene of three isovalues of a gyroid by `mesh`.
fn three_surfaces(mesh: &str) -> isoview::scene::Scene {
    let text = format!(
        "[field]\nsource = \"sdf\"\nshape = \"gyroid\"\nscale = 5.0\nthickness = 0.1\n\
         resolution = [21, 19, 17]\n[surface]\nisovalues = [-0.05, 0.0, 0.08]\n\
         [render]\nmesh = \"{mesh}\"\n"
    );
    isoview::scene::from_str(&text, "three", std::path::Path::new("."), &[]).expect("scene")
}

fn job<'a>(
    scene: &'a isoview::scene::Scene,
    device: isoview::extract::Device,
    budget: &'a isoview::mesh::MeshBudget,
) -> isoview::extract::Job<'a> {
    isoview::extract::Job {
        scene,
        time: 0.0,
        device,
        vulkan: isoview::gpu::ContextOptions::default(),
        opts: ExtractOptions::default(),
        budget,
    }
}

/// `isoview::extract::surfaces` on the GPU: one context, one upload, one `Extractor` for the
/// three surfaces, and each mesh the one a single-surface extraction of that isovalue gives
/// (bit for bit: the same passes on the same device), in the order of the isovalues.
#[gpu_test]
fn several_surfaces_share_one_context_and_one_upload() {
    use isoview::extract::{surfaces, Device};
    let mut gpu = Gpu::new();
    for mesh in ["marching-cubes", "dual-contouring"] {
        let scene = three_surfaces(mesh);
        let grid = scene.field.sample(0.0).unwrap();
        let budget = isoview::mesh::MeshBudget::unlimited();
        let done = surfaces(&job(&scene, Device::Gpu, &budget), &grid, None).unwrap();
        assert_eq!(done.ran_on, Device::Gpu, "{mesh}");
        assert_eq!((done.why.as_str(), done.notes.len()), ("", 0), "{mesh}");
        assert_eq!(done.meshes.len(), 3);
        for (k, iso) in scene.surface.isovalues().into_iter().enumerate() {
            let c = Case { grid: grid.clone(), iso, inside: scene.surface.inside };
            let (want, _) = gpu.run(&c, scene.render.mesh, &GpuExtractOptions::default()).unwrap();
            assert!(want.triangle_count() > 100, "{mesh} surface {k}: too small to compare");
            assert_eq!(done.meshes[k], want, "{mesh} surface {k}");
        }
    }
}

/// A method without GPU passes asked for on the GPU: the CPU extracts every surface, the
/// reference's meshes, and the note is given once for the three of them.
#[gpu_test]
fn a_cpu_only_method_on_the_gpu_notes_it_once() {
    use isoview::extract::{surfaces, Device};
    let scene = three_surfaces("extended-mc");
    let grid = scene.field.sample(0.0).unwrap();
    let budget = isoview::mesh::MeshBudget::unlimited();
    let done = surfaces(&job(&scene, Device::Gpu, &budget), &grid, None).unwrap();
    assert_eq!(done.ran_on, Device::Cpu);
    assert_eq!(
        done.notes,
        ["note: extended-mc is extracted on the CPU (no GPU extraction passes for it)"]
    );
    for (k, iso) in scene.surface.isovalues().into_iter().enumerate() {
        let x = Request::new(iso, scene.surface.inside, scene.render.mesh)
            .with_sharp(scene.render.sharp);
        assert_eq!(done.meshes[k], reference(&grid, &x).unwrap(), "surface {k}");
    }
}
