//! The multi-threaded CPU extraction (`mesh::extract`, with `Request::slab_depth`)
//! against the single-threaded reference (`mesh::reference`): on random grids of 2..40 points
//! per axis (non-cubic, a third of the samples from a small set so that samples equal the
//! isovalue), random and tied isovalues, both inside modes, every algorithm and both quad
//! splits, on rayon pools of 1, 2 and 5 threads and slabs of 1, 2, 3, 7 layers, the default
//! depth and the whole grid as one slab, the mesh is the reference's bit for bit: the same
//! vertex order, positions and normals (compared as bits), triangles and quads.

use glam::DVec3;
use isoview::mesh::{extract, reference, ExtractOptions, Mesh, MeshBudget, QuadSplit, Request};
use isoview::scene::{Inside, MeshAlgorithm, SharpSettings};

use crate::common::*;

/// Every method cut into slabs (asked of its row, so a new one is tested here too).
fn algos() -> Vec<MeshAlgorithm> {
    let sharp = SharpSettings::default();
    MeshAlgorithm::ALL.into_iter().filter(|a| (a.method().not_in_slabs)(&sharp).is_none()).collect()
}

/// Slab depths tried: thin slabs (every layer a seam), odd depths, the default, one slab.
const DEPTHS: [Option<usize>; 6] = [Some(1), Some(2), Some(3), Some(7), None, Some(1000)];

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("rayon pool")
}

fn bits(v: &[[f32; 3]]) -> Vec<[u32; 3]> {
    v.iter().map(|p| p.map(f32::to_bits)).collect()
}

/// Asserts `got` is `want` bit for bit.
fn assert_identical(got: &Mesh, want: &Mesh, what: &str) {
    assert_eq!(got.vertex_count(), want.vertex_count(), "{what}: vertex count");
    assert_eq!(bits(&got.positions), bits(&want.positions), "{what}: positions");
    assert_eq!(bits(&got.normals), bits(&want.normals), "{what}: normals");
    assert_eq!(got.indices, want.indices, "{what}: triangles");
    assert_eq!(got.quads, want.quads, "{what}: quads");
}

fn options(algo: MeshAlgorithm, round: usize) -> ExtractOptions {
    let dual = algo.method().quads;
    ExtractOptions {
        split: if round % 2 == 0 { QuadSplit::Shorter } else { QuadSplit::Fixed },
        keep_quads: dual && round % 3 != 2,
    }
}

#[test]
fn parallel_equals_the_reference_on_random_grids() {
    let pools = [pool(1), pool(2), pool(5)];
    let mut rng = Rng::new(1729);
    for algo in algos() {
        let (mut verts, mut tris, mut compared) = (0, 0, 0);
        for round in 0..10 {
            let c = random_case(&mut rng, 40);
            let opts = options(algo, round);
            let what = format!(
                "{} round {round} dims {:?} iso {} {:?} {opts:?}",
                algo.name(),
                c.grid.dims,
                c.iso,
                c.inside
            );
            let reference =
                reference(&c.grid, &Request::new(c.iso, c.inside, algo).with_opts(opts)).unwrap();
            for p in &pools {
                for depth in DEPTHS {
                    let got = p
                        .install(|| {
                            extract(
                                &c.grid,
                                &Request::new(c.iso, c.inside, algo)
                                    .with_opts(opts)
                                    .with_slab_depth(depth),
                                &MeshBudget::unlimited(),
                            )
                        })
                        .unwrap();
                    let what =
                        format!("{what}, {} threads, depth {depth:?}", p.current_num_threads());
                    assert_identical(&got, &reference, &what);
                    compared += 1;
                }
            }
            verts += reference.vertex_count();
            tris += reference.triangle_count();
        }
        assert!(tris > 1000, "{}: too few triangles ({tris}) to test anything", algo.name());
        eprintln!(
            "{}: {compared} meshes identical, {verts} vertices, {tris} triangles",
            algo.name()
        );
    }
}

/// Small grids: every slab one or two layers, seams everywhere, and the grids of 2 points in
/// z (one cell layer) where a slab is the whole grid.
#[test]
fn parallel_equals_the_reference_on_small_grids() {
    let p = pool(3);
    let mut rng = Rng::new(7);
    for algo in algos() {
        for round in 0..40 {
            let c = random_case(&mut rng, 5);
            let opts = options(algo, round);
            let reference =
                reference(&c.grid, &Request::new(c.iso, c.inside, algo).with_opts(opts)).unwrap();
            for depth in [Some(1), Some(2), None] {
                let got = p
                    .install(|| {
                        extract(
                            &c.grid,
                            &Request::new(c.iso, c.inside, algo)
                                .with_opts(opts)
                                .with_slab_depth(depth),
                            &MeshBudget::unlimited(),
                        )
                    })
                    .unwrap();
                let what =
                    format!("{} round {round} dims {:?} depth {depth:?}", algo.name(), c.grid.dims);
                assert_identical(&got, &reference, &what);
            }
        }
    }
}

/// A sphere and a gyroid on larger non-cubic grids, through `extract` (the default
/// slabs on the global pool), as `isoview extract` runs it.
#[test]
fn parallel_equals_the_reference_on_smooth_fields() {
    let fields = [
        grid_from([48, 40, 56], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.length() - 0.7),
        grid_from([50, 45, 61], DVec3::splat(-1.0), DVec3::splat(1.0), |p| {
            let q = p * 7.0;
            q.x.sin() * q.y.cos() + q.y.sin() * q.z.cos() + q.z.sin() * q.x.cos()
        }),
    ];
    for (n, grid) in fields.iter().enumerate() {
        for algo in algos() {
            for inside in Inside::ALL {
                let opts = ExtractOptions::default();
                let reference =
                    reference(grid, &Request::new(0.0, inside, algo).with_opts(opts)).unwrap();
                let got = extract(
                    grid,
                    &Request::new(0.0, inside, algo).with_opts(opts),
                    &MeshBudget::unlimited(),
                )
                .unwrap();
                assert_identical(
                    &got,
                    &reference,
                    &format!("field {n} {} {inside:?}", algo.name()),
                );
                assert!(reference.triangle_count() > 1000);
            }
        }
    }
}

#[test]
fn parallel_rejects_what_the_reference_rejects_and_handles_empty_meshes() {
    let grid = grid_from([9, 8, 7], DVec3::ZERO, DVec3::ONE, |p| p.x);
    for algo in algos() {
        let opts = ExtractOptions::default();
        assert!(extract(
            &grid,
            &Request::new(f64::NAN, Inside::Below, algo).with_opts(opts),
            &MeshBudget::unlimited()
        )
        .is_err());
        let mut bad = grid.clone();
        bad.values.pop();
        assert!(extract(
            &bad,
            &Request::new(0.5, Inside::Below, algo).with_opts(opts),
            &MeshBudget::unlimited()
        )
        .is_err());
        for iso in [-1.0, 5.0] {
            let want =
                reference(&grid, &Request::new(iso, Inside::Below, algo).with_opts(opts)).unwrap();
            let got = extract(
                &grid,
                &Request::new(iso, Inside::Below, algo).with_opts(opts).with_slab_depth(Some(2)),
                &MeshBudget::unlimited(),
            )
            .unwrap();
            assert_identical(&got, &want, &format!("{} iso {iso}", algo.name()));
        }
    }
}

const GYROID: &str = r#"
[field]
source = "sdf"
shape = "gyroid"
scale = 6.0
thickness = 0.05
resolution = [33, 30, 27]
bounds = { min = [-1.0, -1.0, -1.0], max = [1.0, 1.0, 1.0] }

[render]
mesh = "marching-cubes"
"#;

/// `isoview extract` without `--device` (auto): on a Vulkan device whose type is CPU
/// (lavapipe) it extracts on the CPU and says so, writing the very file `--device cpu` writes
/// (the reference's mesh); on a GPU it extracts on the GPU and says so. `--device auto` is the
/// same as no `--device`; `--device gpu` still runs the GPU passes.
#[gpu_test]
fn extract_auto_picks_the_cpu_on_a_cpu_vulkan_device() {
    let ctx = gpu();
    let on_cpu_device = ctx.info.device_type.starts_with("CPU");
    drop(ctx);
    let dir = scratch("extract-auto");
    let scene_path = dir.join("gyroid.toml");
    std::fs::write(&scene_path, GYROID).unwrap();
    let scene_path = scene_path.display().to_string();
    let out = |name: &str| dir.join(name).display().to_string();
    let (auto, auto2, cpu, gpu_file) =
        (out("auto.ply"), out("auto2.ply"), out("cpu.ply"), out("gpu.ply"));
    for algo in ["marching-cubes", "surface-nets", "mc33"] {
        let set = format!("render.mesh={algo}");
        let o = isoview(&["extract", &scene_path, "-o", &auto, "--set", &set], &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        let err = stderr(&o);
        if on_cpu_device {
            assert!(err.contains(&format!("({algo} on cpu; auto: the Vulkan device ")), "{err}");
            assert!(err.contains("is a CPU)"), "{err}");
        } else {
            assert!(err.contains(&format!("({algo} on gpu; auto: the Vulkan device ")), "{err}");
        }
        let o = isoview(
            &["extract", &scene_path, "-o", &auto2, "--device", "auto", "--set", &set],
            &[],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(std::fs::read(&auto).unwrap(), std::fs::read(&auto2).unwrap());
        let o =
            isoview(&["extract", &scene_path, "-o", &cpu, "--device", "cpu", "--set", &set], &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stderr(&o).contains(&format!("({algo} on cpu)")), "{}", stderr(&o));
        if on_cpu_device {
            assert_eq!(std::fs::read(&auto).unwrap(), std::fs::read(&cpu).unwrap(), "{algo}");
        }
        let o = isoview(
            &["extract", &scene_path, "-o", &gpu_file, "--device", "gpu", "--set", &set],
            &[],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stderr(&o).contains(&format!("({algo} on gpu)")), "{}", stderr(&o));
    }
}
