//! `cargo bench --bench mesh` (or `./x bench`): isosurface extraction speed on 128³ and 256³
//! grids (sphere, gyroid, noise): the GPU passes (`passes::extract`, marching cubes, surface nets and
//! mc33) on the current Vulkan device and the multi-threaded CPU extraction
//! (`mesh::extract`, all cores, rayon) against the f64 CPU references
//! (`mesh::reference`, one thread) and the crates `fast-surface-nets` (surface nets) and
//! `isosurface` (marching cubes), all in the same run; then the sharp-feature and adaptive
//! meshes (CPU) beside uniform dual contouring. Prints markdown tables; never asserts on
//! time (it asserts that the parallel mesh equals the reference's).
//!
//! Voxels are cells, `(n - 1)³` for `n³` grid points. GPU times are wall-clock around
//! `Extractor::extract` with the grid already uploaded: they include the host readback of the
//! counts after each slab's scan and the output allocation, like the timings of Usher's
//! WebGPU/Vulkan marching cubes; the GPU-timestamp sum is printed beside them. Every time is the
//! median of 3 runs after one warm-up, except the CPU references (one run).
//! `ISOVIEW_BENCH_SIZES=64,128` picks other grid sizes; `ISOVIEW_BENCH_GPU=0` leaves out the GPU
//! rows (no Vulkan device is opened: the CPU rows alone, on a host where lavapipe would take
//! the same cores); `ISOVIEW_BENCH_SHARP=0` leaves out the sharp-feature table;
//! `ISOVIEW_BENCH_ALGOS=surface-nets,marching-cubes` times only those methods;
//! `ISOVIEW_BENCH_FIELDS=gyroid` only those fields (sphere, gyroid, noise);
//! `ISOVIEW_BENCH_SCENE=path.toml` adds a table for that scene's sampled field (e.g. the peer
//! script's `target/peers/gyroid-256.toml`, the grid VTK's flying edges is timed on there).

use std::time::Instant;

use glam::DVec3;
use isoview::field::{FieldSource, FieldSpec, Grid};
use isoview::gpu::{Context, ContextOptions, Image3d};
use isoview::mesh::{extract, reference, ExtractOptions, Mesh, MeshBudget, Request};
use isoview::passes::extract::{Extractor, GpuExtractOptions};
use isoview::scene::{Bounds, Inside, MeshAlgorithm, SdfShape};

fn sdf_grid(shape: SdfShape, n: usize) -> Grid {
    let spec = FieldSpec {
        source: FieldSource::Sdf { shape, center: DVec3::ZERO },
        resolution: [n, n, n],
        bounds: Bounds { min: DVec3::splat(-1.0), max: DVec3::splat(1.0) },
        placement: Default::default(),
        residency: isoview::field::Residency::Whole,
        nan: Default::default(),
        interpolation: Default::default(),
    };
    spec.sample(0.0).expect("sdf grid")
}

/// Value noise: hashed lattice values at 8 and 16 cells across the box, trilinearly blended,
/// minus a little, so the zero set is a dense tangle of blobs and tunnels.
fn noise_grid(n: usize) -> Grid {
    fn hash(i: i64, j: i64, k: i64, seed: u64) -> f64 {
        let mut h = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            ^ (k as u64).wrapping_mul(0x1656_67B1_9E37_79F9)
            ^ seed;
        h ^= h >> 31;
        h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 29;
        (h >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
    fn octave(p: DVec3, freq: f64, seed: u64) -> f64 {
        let q = p * freq;
        let f = q.floor();
        let t = q - f;
        let (i, j, k) = (f.x as i64, f.y as i64, f.z as i64);
        let mut v = 0.0;
        for c in 0..8 {
            let (dx, dy, dz) = (c & 1, (c >> 1) & 1, (c >> 2) & 1);
            let w = (if dx == 1 { t.x } else { 1.0 - t.x })
                * (if dy == 1 { t.y } else { 1.0 - t.y })
                * (if dz == 1 { t.z } else { 1.0 - t.z });
            v += w * hash(i + dx, j + dy, k + dz, seed);
        }
        v
    }
    let mut g = Grid { dims: [n; 3], min: DVec3::ZERO, max: DVec3::ONE, values: Vec::new() };
    g.values.reserve(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = g.point(i, j, k);
                let v = octave(p, 8.0, 1) + 0.5 * octave(p, 16.0, 2) - 0.1;
                g.values.push(v as f32);
            }
        }
    }
    g
}

/// Whether `ISOVIEW_BENCH_ALGOS` (comma-separated method names; unset: all) names `algo`.
fn picked(algo: &str) -> bool {
    std::env::var("ISOVIEW_BENCH_ALGOS").map_or(true, |v| v.split(',').any(|a| a.trim() == algo))
}

/// Whether `ISOVIEW_BENCH_FIELDS` (comma-separated field names; unset: all) names `field`.
fn picked_field(field: &str) -> bool {
    std::env::var("ISOVIEW_BENCH_FIELDS").map_or(true, |v| v.split(',').any(|a| a.trim() == field))
}

/// `/proc/loadavg`'s first three fields (other work on the host skews every time here,
/// lavapipe's most, as it runs on the same cores).
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Median seconds of 3 runs after a warm-up, and the last run's output.
fn time<T>(mut f: impl FnMut() -> T) -> (f64, T) {
    let mut out = f();
    let mut times = Vec::new();
    for _ in 0..3 {
        let started = Instant::now();
        out = f();
        times.push(started.elapsed().as_secs_f64());
    }
    (median(times), out)
}

/// The grid as the `isosurface` crate samples it: its `Source` is evaluated at
/// `(x, y, z) * (size - 1)` for integer x, y, z in `0..=size` (the last z layer is one past the
/// grid; clamped).
struct GridSource<'a>(&'a Grid);

impl isosurface::source::Source for GridSource<'_> {
    fn sample(&self, x: f32, y: f32, z: f32) -> f32 {
        let g = self.0;
        let at = |u: f32, n: usize| ((u * (n - 1) as f32).round() as usize).min(n - 1);
        g.at(at(x, g.dims[0]), at(y, g.dims[1]), at(z, g.dims[2]))
    }
}

struct Row {
    field: &'static str,
    n: usize,
    method: String,
    seconds: f64,
    gpu_ms: Option<f64>,
    vertices: usize,
    triangles: usize,
    /// Seconds of the isoview CPU reference of the same algorithm.
    reference: f64,
}

fn main() {
    let with_gpu = std::env::var("ISOVIEW_BENCH_GPU").map_or(true, |v| v != "0");
    let ctx = match with_gpu.then(|| Context::new(&ContextOptions::default())).transpose() {
        Ok(c) => c,
        Err(e) => {
            eprintln!("bench: {e}");
            std::process::exit(3);
        }
    };
    let sizes: Vec<usize> = std::env::var("ISOVIEW_BENCH_SIZES")
        .ok()
        .map(|s| s.split(',').filter_map(|x| x.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![128, 256]);
    let mut extractor = ctx.as_ref().map(|c| Extractor::new(c).expect("extractor"));
    let opts = GpuExtractOptions::default();
    let threads = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    match &ctx {
        Some(c) => println!(
            "device: {} ({}); host: {threads} CPU threads",
            c.info.name, c.info.driver_info
        ),
        None => println!("device: none (ISOVIEW_BENCH_GPU=0); host: {threads} CPU threads"),
    }
    println!("load average at start: {}", load_average());
    println!();

    let mut rows = Vec::new();
    for &n in &sizes {
        for field in ["sphere", "gyroid", "noise"].into_iter().filter(|f| picked_field(f)) {
            let grid = &match field {
                "sphere" => sdf_grid(SdfShape::Sphere { radius: 0.6 }, n),
                "gyroid" => sdf_grid(SdfShape::Gyroid { scale: 10.0, thickness: 0.05 }, n),
                _ => noise_grid(n),
            };
            let image = ctx.as_ref().map(|c| {
                Image3d::upload(c, "grid", grid.dims.map(|d| d as u32), &grid.values).unwrap()
            });
            let algos =
                [MeshAlgorithm::MarchingCubes, MeshAlgorithm::SurfaceNets, MeshAlgorithm::Mc33];
            for algo in algos.into_iter().filter(|a| picked(a.name())) {
                let started = Instant::now();
                let cpu: Mesh = reference(grid, &Request::new(0.0, Inside::Below, algo)).unwrap();
                let reference = started.elapsed().as_secs_f64();
                let mut row = |method: String, seconds, gpu_ms, v, t| {
                    rows.push(Row {
                        field,
                        n,
                        method,
                        seconds,
                        gpu_ms,
                        vertices: v,
                        triangles: t,
                        reference,
                    })
                };
                row(
                    format!("isoview CPU {}", algo.name()),
                    reference,
                    None,
                    cpu.vertex_count(),
                    cpu.triangle_count(),
                );
                let (s, par) = time(|| {
                    extract(grid, &Request::new(0.0, Inside::Below, algo), &MeshBudget::unlimited())
                        .unwrap()
                });
                assert!(par == cpu, "parallel vs reference: {} {field} {n}", algo.name());
                row(
                    format!("isoview CPU parallel {}", algo.name()),
                    s,
                    None,
                    par.vertex_count(),
                    par.triangle_count(),
                );
                if let (Some(x), Some(image)) = (extractor.as_mut(), &image) {
                    let (s, (v, t, ms)) = time(|| {
                        let m = x
                            .extract(grid, image, 0.0, Inside::Below, algo, &opts)
                            .expect("GPU extraction");
                        (m.vertex_count as usize, m.triangle_count as usize, x.last.gpu_ms)
                    });
                    assert_eq!((v, t), (cpu.vertex_count(), cpu.triangle_count()), "GPU vs CPU");
                    row(format!("isoview GPU {}", algo.name()), s, ms, v, t);
                }
                match algo {
                    MeshAlgorithm::MarchingCubes => {
                        let (s, (v, t)) = time(|| {
                            let mut mc = isosurface::marching_cubes::MarchingCubes::new(n);
                            let (mut verts, mut idx) = (Vec::new(), Vec::new());
                            mc.extract(&GridSource(grid), &mut verts, &mut idx);
                            (verts.len() / 3, idx.len() / 3)
                        });
                        row("isosurface 0.0.4 marching cubes".into(), s, None, v, t);
                    }
                    MeshAlgorithm::SurfaceNets => {
                        use fast_surface_nets::ndshape::{RuntimeShape, Shape};
                        let shape = RuntimeShape::<u32, 3>::new([n as u32; 3]);
                        assert_eq!(shape.linearize([1, 0, 0]), 1, "x fastest, like Grid");
                        let mut buffer = fast_surface_nets::SurfaceNetsBuffer::default();
                        let (s, (v, t)) = time(|| {
                            let m = (n - 1) as u32;
                            fast_surface_nets::surface_nets(
                                &grid.values,
                                &shape,
                                [0; 3],
                                [m; 3],
                                &mut buffer,
                            );
                            (buffer.positions.len(), buffer.indices.len() / 3)
                        });
                        row("fast-surface-nets 0.2.1".into(), s, None, v, t);
                    }
                    _ => {}
                }
            }
        }
    }

    println!("load average at end: {}", load_average());
    println!();
    println!("| field | grid | implementation | ms | GPU-timestamp ms | Mvoxels/s | vertices | triangles | × isoview CPU |");
    println!("|---|---|---|---:|---:|---:|---:|---:|---:|");
    for r in &rows {
        let voxels = ((r.n - 1) as f64).powi(3);
        println!(
            "| {} | {}³ | {} | {:.1} | {} | {:.1} | {} | {} | {:.2} |",
            r.field,
            r.n,
            r.method,
            r.seconds * 1e3,
            r.gpu_ms.map(|m| format!("{m:.1}")).unwrap_or_else(|| "–".into()),
            voxels / r.seconds / 1e6,
            r.vertices,
            r.triangles,
            r.reference / r.seconds,
        );
    }

    // The parallel CPU path beside the reference, the GPU passes and the peer crate.
    let ms = |field: &str, n: usize, method: &str| {
        rows.iter()
            .find(|r| r.field == field && r.n == n && r.method == method)
            .map(|r| r.seconds * 1e3)
    };
    println!();
    println!("| field | grid | algorithm | CPU parallel ms | CPU reference ms | GPU ms | peer ms | reference / parallel | GPU / parallel | peer / parallel |");
    println!("|---|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for &n in &sizes {
        for field in ["sphere", "gyroid", "noise"] {
            for (algo, peer) in [
                ("marching-cubes", Some("isosurface 0.0.4 marching cubes")),
                ("surface-nets", Some("fast-surface-nets 0.2.1")),
                ("mc33", None),
            ] {
                let Some(par) = ms(field, n, &format!("isoview CPU parallel {algo}")) else {
                    continue;
                };
                let reference = ms(field, n, &format!("isoview CPU {algo}")).unwrap_or(f64::NAN);
                let gpu = ms(field, n, &format!("isoview GPU {algo}")).unwrap_or(f64::NAN);
                let peer = peer.and_then(|p| ms(field, n, p));
                let fmt = |x: Option<f64>| x.map_or_else(|| "–".into(), |x| format!("{x:.1}"));
                println!(
                    "| {field} | {n}³ | {algo} | {par:.1} | {reference:.1} | {gpu:.1} | {} | {:.2} | {:.2} | {} |",
                    fmt(peer),
                    reference / par,
                    gpu / par,
                    peer.map_or_else(|| "–".into(), |p| format!("{:.2}", p / par)),
                );
            }
        }
    }
    if let Ok(path) = std::env::var("ISOVIEW_BENCH_SCENE") {
        scene_rows(std::path::Path::new(&path));
    }
    if std::env::var("ISOVIEW_BENCH_SHARP").map_or(true, |v| v != "0") {
        sharp(&sizes);
    }
}

/// The threaded CPU extraction of a scene's sampled field (its surface, marching cubes and
/// surface nets), already in memory, as the peer script times VTK's: median of 3 after a
/// warm-up.
fn scene_rows(path: &std::path::Path) {
    let scene = isoview::scene::load(path, &[]).expect("bench scene");
    let grid = scene.field.sample(0.0).expect("bench scene's field");
    let s = &scene.surface;
    println!();
    println!("{}: {:?} points, isovalue {}", path.display(), grid.dims, s.isovalue);
    println!();
    println!("| algorithm | CPU parallel ms | vertices | triangles |");
    println!("|---|---:|---:|---:|");
    for algo in [MeshAlgorithm::MarchingCubes, MeshAlgorithm::SurfaceNets] {
        let opts = ExtractOptions::default();
        let (t, m) = time(|| {
            extract(
                &grid,
                &Request::new(s.isovalue, s.inside, algo).with_opts(opts),
                &MeshBudget::unlimited(),
            )
            .expect("extract")
        });
        println!(
            "| {} | {:.1} | {} | {} |",
            algo.name(),
            t * 1e3,
            m.vertex_count(),
            m.triangle_count()
        );
    }
}

/// The sharp-feature and adaptive meshes (CPU only) against uniform dual contouring on a
/// sphere and a box (trilinear Hermite data: the grid alone): threaded where the algorithm
/// is, ms (median of 3) and triangles.
fn sharp(sizes: &[usize]) {
    use isoview::scene::SharpSettings;
    println!();
    println!("| field | grid | mesh | ms | triangles | × uniform dual-contouring ms |");
    println!("|---|---|---|---:|---:|---:|");
    for &n in sizes {
        let cell = 2.0 / (n - 1) as f64;
        let fields = [
            ("sphere", sdf_grid(SdfShape::Sphere { radius: 0.6 }, n)),
            ("box", sdf_grid(SdfShape::Box { half_extents: DVec3::new(0.6, 0.4, 0.3) }, n)),
        ];
        for (field, grid) in &fields {
            let mut base = f64::NAN;
            for (name, algo, eps) in [
                ("dual-contouring", MeshAlgorithm::DualContouring, None),
                ("dual-contouring-qef", MeshAlgorithm::DualContouringQef, None),
                ("extended-mc", MeshAlgorithm::ExtendedMc, None),
                (
                    "dual-contouring-qef, mesh_error = 1 cell",
                    MeshAlgorithm::DualContouringQef,
                    Some(1.0),
                ),
                (
                    "dual-contouring-qef, mesh_error = 4 cells",
                    MeshAlgorithm::DualContouringQef,
                    Some(4.0),
                ),
            ] {
                let sharp =
                    SharpSettings { mesh_error: eps.map(|e| e * cell), ..Default::default() };
                let opts = ExtractOptions::default();
                let (s, m) = time(|| {
                    extract(
                        grid,
                        &Request::new(0.0, Inside::Below, algo).with_opts(opts).with_sharp(sharp),
                        &MeshBudget::unlimited(),
                    )
                    .unwrap()
                });
                if algo == MeshAlgorithm::DualContouring {
                    base = s;
                }
                println!(
                    "| {field} | {n}³ | {name} | {:.1} | {} | {:.2} |",
                    s * 1e3,
                    m.triangle_count(),
                    s / base
                );
            }
        }
    }
}
