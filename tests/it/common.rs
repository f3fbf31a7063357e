//! Shared test helpers: a seeded RNG, grids and scenes built in code, the GPU context.

use std::sync::Arc;

use glam::DVec3;
use isoview::field::{FieldSpec, Grid};
use isoview::gpu::{Context, ContextOptions};
use isoview::scene::*;

/// xorshift64*: deterministic, seeded per test.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn unit_vector(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0));
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
}

/// The GPU context for a test. Panics (fails the test) when no Vulkan device is found.
///
/// Every test that calls it is declared `#[gpu_test]` (crates/test-macros): with
/// `ISOVIEW_SKIP_GPU_TESTS=1` at build time (build.rs sets the cfg) libtest lists it as ignored;
/// without it, it runs and fails without a device. `ISOVIEW_VALIDATION=1` enables validation.
pub fn gpu() -> Arc<Context> {
    let validation = std::env::var("ISOVIEW_VALIDATION").as_deref() == Ok("1");
    match Context::new(&ContextOptions { device: None, validation }) {
        Ok(ctx) => ctx,
        Err(e) => panic!("GPU test needs a Vulkan device: {e}"),
    }
}

/// Fails the test, saying why, when the device lacks `shaderFloat64` (64-bit floats in
/// shaders: the mc33 passes). A test that calls it is declared `#[gpu_test(float64)]`: built
/// with `ISOVIEW_NO_FLOAT64_TESTS=1` (a device without it) libtest lists it as ignored instead.
pub fn need_float64(ctx: &Context) {
    assert!(
        ctx.info.float64,
        "this test needs shaderFloat64, which {} lacks; build and run the tests with \
         ISOVIEW_NO_FLOAT64_TESTS=1 to have such tests reported as ignored",
        ctx.info.name
    );
}

/// A grid of random values in [-1, 1] over a random box.
pub fn random_grid(rng: &mut Rng, dims: [usize; 3]) -> Grid {
    let min = DVec3::new(rng.range(-1.5, -0.5), rng.range(-1.5, -0.5), rng.range(-1.5, -0.5));
    let max = DVec3::new(rng.range(0.5, 1.5), rng.range(0.5, 1.5), rng.range(0.5, 1.5));
    let n = dims.iter().product();
    let values = (0..n).map(|_| rng.range(-1.0, 1.0) as f32).collect();
    Grid { dims, min, max, values }
}

/// A grid sampled from `f(world point)`.
pub fn grid_from(dims: [usize; 3], min: DVec3, max: DVec3, f: impl Fn(DVec3) -> f64) -> Grid {
    let mut g = Grid { dims, min, max, values: Vec::new() };
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let v = f(g.point(i, j, k)) as f32;
                g.values.push(v);
            }
        }
    }
    g
}

/// A scene around `grid` at the contract's defaults, looking at the box's centre from `eye`,
/// `size`² pixels, fixed-step with 64 steps or the given method, counting every crossing
/// (`render.count_crossings`: the tests check the `crossings` channel against the references;
/// `analytic::stopping_at_the_hit_changes_only_crossings` covers the default).
pub fn scene_for(grid: &Grid, eye: DVec3, size: u32, method: Method) -> Scene {
    let mut scene = Scene::new(FieldSpec::from_grid(grid.clone()));
    scene.image = ImageSettings { width: size, height: size };
    scene.camera.eye = eye;
    scene.camera.target = 0.5 * (grid.min + grid.max);
    scene.render.method = method;
    scene.render.steps = 64;
    scene.render.count_crossings = true;
    scene
}

/// A rod of `n` x 4 x 4 points, one unit apart from the origin, sampling `f`: the longest walk
/// or march a small grid gives (the llvmpipe loop-cap tests).
pub fn rod(n: usize, f: impl Fn(DVec3) -> f64) -> Grid {
    grid_from([n, 4, 4], DVec3::ZERO, DVec3::new(n as f64 - 1.0, 3.0, 3.0), f)
}

/// A one-pixel scene of `method` whose ray runs along [`rod`]'s length from x = -5, off the
/// voxel faces at y, z = 1.5.
pub fn along_rod(grid: &Grid, method: Method) -> Scene {
    let mut scene = scene_for(grid, DVec3::new(-5.0, 1.3, 1.4), 1, method);
    scene.camera.target = DVec3::new(1000.0, 1.3, 1.4);
    scene
}

/// A random camera position looking at the box from outside (or, with `inside`, from within).
pub fn random_eye(rng: &mut Rng, grid: &Grid, inside: bool) -> DVec3 {
    let c = 0.5 * (grid.min + grid.max);
    let r = 0.5 * (grid.max - grid.min).length();
    if inside {
        c + rng.unit_vector() * r * 0.3
    } else {
        c + rng.unit_vector() * r * rng.range(1.6, 3.0)
    }
}

/// `mpirun -np n --oversubscribe isoview args...` with extra environment (as root too: CI runs
/// as root). Each run gets its own short `TMPDIR`: Open MPI keeps its session folder under
/// `$TMPDIR/ompi.HOST.UID`, and runs started at once by parallel tests raced on that shared
/// folder (one removing it while another created its own: "orte_session_dir failed" in CI).
#[allow(dead_code)] // used only by the MPI tests
pub fn mpirun(n: usize, args: &[&str], env: &[(&str, &str)]) -> std::process::Output {
    static RUN: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    // One mpirun at a time: Open MPI's launcher also meets other jobs' daemons through files
    // and ports of the machine, and CI (2 cores, tests on 2 threads) saw `orte_init` fail when
    // two started together. A poisoned lock (an earlier MPI test failed) still serializes.
    static ONE: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one = ONE.lock().unwrap_or_else(|p| p.into_inner());
    let run = RUN.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    // Short: Open MPI puts Unix sockets below it (108 bytes at most for a socket path).
    let tmp = std::path::PathBuf::from(format!("/tmp/iv-mpi-{}-{run}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    let mut cmd = std::process::Command::new("mpirun");
    cmd.args(["-np", &n.to_string(), "--oversubscribe", env!("CARGO_BIN_EXE_isoview")])
        .args(args)
        .env_remove("ISOVIEW_DEVICE")
        .env("TMPDIR", &tmp)
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1");
    for (k, v) in env {
        cmd.env(k, v);
    }
    let out = cmd
        .output()
        .expect("mpirun (apt-get install openmpi-bin) must be on PATH for the MPI tests");
    let _ = std::fs::remove_dir_all(&tmp);
    out
}

/// A fresh scratch folder for one test.
pub fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("isoview-it-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs the `isoview` binary with `args` and extra environment (`ISOVIEW_DEVICE` removed, so the
/// tests pick the device as a user without settings would).
pub fn isoview(args: &[&str], env: &[(&str, &str)]) -> std::process::Output {
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_isoview"));
    cmd.args(args).env_remove("ISOVIEW_DEVICE");
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("run isoview")
}

/// Runs `cmd` under an address-space limit of `gib` GiB (what `ulimit -v` sets).
pub fn with_memory_limit(cmd: &mut std::process::Command, gib: u64) {
    // SAFETY: setrlimit is async-signal-safe; the closure touches nothing else.
    unsafe {
        std::os::unix::process::CommandExt::pre_exec(cmd, move || {
            let limit = libc::rlimit { rlim_cur: gib << 30, rlim_max: gib << 30 };
            if libc::setrlimit(libc::RLIMIT_AS, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
}

/// A finished run's stderr as text.
pub fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Exit status `code` with exactly one line on stderr containing every `needle`.
pub fn assert_fails(o: &std::process::Output, code: i32, needles: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(code), "stderr: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line expected: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "`{n}` missing from: {err}");
    }
}

/// Writes `text` to `dir/name` and returns the path as a string.
pub fn write(dir: &std::path::Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

/// An extraction input: a grid, an isovalue and the inside rule.
pub struct Case {
    pub grid: Grid,
    pub iso: f64,
    pub inside: Inside,
}

/// Random values in [-1, 1], a third of them from {-0.5, 0, 0.25, 0.5} (so samples equal the
/// isovalue and crossings sit on grid points); isovalues uniform, from that set, or 0.1 (not an
/// f32). Dims 2..=max_dim per axis.
pub fn random_case(rng: &mut Rng, max_dim: usize) -> Case {
    const SET: [f32; 4] = [-0.5, 0.0, 0.25, 0.5];
    let dims = [0; 3].map(|_| 2 + (rng.next_u64() % (max_dim as u64 - 1)) as usize);
    let mut grid = random_grid(rng, dims);
    for v in &mut grid.values {
        if rng.next_u64() % 3 == 0 {
            *v = SET[(rng.next_u64() % 4) as usize];
        }
    }
    let iso = match rng.next_u64() % 3 {
        0 => rng.range(-0.6, 0.6),
        1 => f64::from(SET[(rng.next_u64() % 4) as usize]),
        _ => 0.1,
    };
    let inside = Inside::ALL[(rng.next_u64() % 2) as usize];
    Case { grid, iso, inside }
}

/// An f32 triple (a pixel's position or normal) in f64.
pub fn v3(a: [f32; 3]) -> DVec3 {
    DVec3::from(a.map(f64::from))
}

/// The method's f64 reference picture of `scene` (the mesh method's of the CPU mesh).
pub fn reference_pixels(scene: &Scene, grid: &Grid) -> Vec<isoview::frame::Pixel> {
    use isoview::field::interpolant::Interpolant;
    use isoview::reference;
    let interp = scene.field.interpolation;
    match scene.render.method {
        Method::Analytic if interp == Interpolant::Nearest => {
            reference::voxels::render(scene, grid)
        }
        Method::Analytic => reference::analytic::render(scene, grid),
        Method::FixedStep => {
            let sampling = reference::fixed_step::Sampling::new(interp);
            reference::fixed_step::render_sampled(scene, grid, sampling)
        }
        Method::Mesh if scene.surface.several() => {
            let layers: Vec<_> = (0..scene.surface.count)
                .map(|k| reference_pixels(&scene.single_surface(k), grid))
                .collect();
            isoview::frame::composite_surfaces(&layers)
        }
        Method::Mesh => {
            let m = isoview::render::mesh::scene_mesh(scene, grid).unwrap();
            reference::mesh::render(scene, grid, &m).0
        }
    }
}

/// How two pictures of the same rays agree: `b` against `a` moved by `moved` (position,
/// normal), over the pixels both hit.
#[derive(Clone, Copy, Debug, Default)]
pub struct Agreement {
    /// Pixels `a` hits.
    pub hits: usize,
    /// Pixels one picture hits and the other misses.
    pub mismatched: usize,
    /// Largest depth difference.
    pub depth: f64,
    /// Largest position difference.
    pub position: f64,
    /// Largest angle between normals, degrees.
    pub normal_deg: f64,
}

impl Agreement {
    pub fn of(
        a: &[isoview::frame::Pixel],
        b: &[isoview::frame::Pixel],
        moved: impl Fn(DVec3, DVec3) -> (DVec3, DVec3),
    ) -> Agreement {
        let mut out = Agreement::default();
        for (a, b) in a.iter().zip(b) {
            out.hits += a.is_hit() as usize;
            if a.is_hit() != b.is_hit() {
                out.mismatched += 1;
                continue;
            }
            if !a.is_hit() {
                continue;
            }
            let (p, n) = moved(v3(a.position), v3(a.normal));
            out.depth = out.depth.max((a.depth - b.depth).abs() as f64);
            out.position = out.position.max((p - v3(b.position)).length());
            let cos = n.normalize().dot(v3(b.normal).normalize()).clamp(-1.0, 1.0);
            out.normal_deg = out.normal_deg.max(cos.acos().to_degrees());
        }
        out
    }

    /// [`Agreement::of`] with nothing moved.
    pub fn same(a: &[isoview::frame::Pixel], b: &[isoview::frame::Pixel]) -> Agreement {
        Agreement::of(a, b, |p, n| (p, n))
    }
}

/// FNV-1a (64 bits) from `h` (start at [`FNV_START`]): a fingerprint of bytes, enough to
/// notice any change (the fingerprint tests `mesh_content.rs` and `one_copy.rs`).
pub fn fnv(h: u64, bytes: &[u8]) -> u64 {
    bytes.iter().fold(h, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3))
}

/// FNV-1a's offset basis.
pub const FNV_START: u64 = 0xcbf2_9ce4_8422_2325;

/// Every fingerprint of `got` is the one recorded in `expected` under its name, and there are
/// as many; on a mismatch the message names those that differ (from `recorded`, what the table
/// was taken from) and prints this run's table, ready to paste once a change is meant.
pub fn assert_fingerprints(got: &[(String, u64)], expected: &[(&str, u64)], recorded: &str) {
    let table: String =
        got.iter().map(|(what, h)| format!("    ({what:?}, {h:#018x}),\n")).collect();
    let differ: Vec<&str> = got
        .iter()
        .filter(|(what, h)| expected.iter().find(|(w, _)| w == what).map(|(_, e)| e) != Some(h))
        .map(|(what, _)| what.as_str())
        .collect();
    assert!(
        differ.is_empty() && got.len() == expected.len(),
        "{} of {} differ from {recorded}: {differ:?}\nthis run:\n{table}",
        differ.len(),
        expected.len()
    );
}

/// The first `count` elements of a device-local buffer, copied to a host-visible one through
/// the barrier tracker (`Context::record`): how a test looks at what a pass left on the GPU.
pub fn read_device_buffer<T: bytemuck::Pod>(
    ctx: &Arc<Context>,
    buffer: &isoview::gpu::Buffer,
    count: usize,
) -> Vec<T> {
    let bytes = (count * std::mem::size_of::<T>()) as u64;
    let readback = isoview::gpu::Buffer::new(
        ctx,
        "test readback",
        bytes,
        isoview::gpu::vk::BufferUsageFlags::TRANSFER_DST,
        isoview::gpu::MemoryLocation::GpuToCpu,
    )
    .unwrap();
    ctx.record("test readback", &mut isoview::gpu::Tracker::default(), |rec| {
        rec.readback(buffer, &readback, bytes);
        Ok(())
    })
    .unwrap();
    readback.read(count).unwrap()
}

/// A smooth random field: a few random plane waves plus a ramp.
pub fn smooth_grid(rng: &mut Rng, n: usize) -> Grid {
    let waves: Vec<(DVec3, f64, f64)> = (0..4)
        .map(|_| {
            (
                rng.unit_vector() * rng.range(2.0, 6.0),
                rng.range(0.0, std::f64::consts::TAU),
                rng.range(0.2, 0.6),
            )
        })
        .collect();
    let ramp = rng.unit_vector() * rng.range(0.0, 1.5);
    grid_from([n, n + 3, n - 2], DVec3::splat(-1.0), DVec3::splat(1.0), |p| {
        waves.iter().map(|(k, ph, a)| a * (k.dot(p) + ph).sin()).sum::<f64>() + ramp.dot(p)
    })
}
