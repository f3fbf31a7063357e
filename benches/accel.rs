//! `cargo bench --bench accel`: the analytic walk with and without its acceleration structure
//! (the occupancy structure, `passes::occupancy`), on the peer benchmark's grids (the torus at 64³ and 256³,
//! the gyroid at 256³, on [-1, 1]³, each scene's camera) and more cameras, in one run: rounds of
//! one frame each of every variant, interleaved so that a change in the machine's load hits all
//! alike; the median and the smallest GPU time of each (GPU timestamps over every pass of the
//! render: the structure's build included). Images are compared bit for bit (all channels but
//! `steps`). Never asserts on time.
//!
//! Environment: `ISOVIEW_BENCH_SIZE` (image side, default 512), `ISOVIEW_BENCH_FRAMES`
//! (rounds, default 7).

use glam::DVec3;
use isoview::field::{FieldSource, FieldSpec, Grid};
use isoview::frame::{Frame, Pixel};
use isoview::gpu::{Context, ContextOptions};
use isoview::render::{Accel, GpuGrid, Renderer};
use isoview::scene::*;

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
    spec.sample(0.0).expect("grid")
}

/// CPU seconds this process has used (user + system, every thread: lavapipe's too).
fn cpu_seconds() -> f64 {
    // SAFETY: getrusage writes the struct it is given.
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut u) };
    let s = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    s(u.ru_utime) + s(u.ru_stime)
}

fn stats(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(|a, b| a.total_cmp(b));
    (v[v.len() / 2], v[0])
}

fn same_but_steps(a: &Frame, b: &Frame) -> usize {
    let key = |p: &Pixel| {
        let mut p = *p;
        p.steps = 0.0;
        bytemuck::bytes_of(&p).to_vec()
    };
    a.pixels.iter().zip(&b.pixels).filter(|(x, y)| key(x) != key(y)).count()
}

fn main() {
    let ctx = Context::new(&ContextOptions::default()).expect("device");
    let env = |k: &str, d: usize| std::env::var(k).ok().and_then(|v| v.parse().ok()).unwrap_or(d);
    let size = env("ISOVIEW_BENCH_SIZE", 512) as u32;
    let frames = env("ISOVIEW_BENCH_FRAMES", 7).max(1);
    let mut renderer = Renderer::new(&ctx).expect("renderer");
    println!("device: {} ({})", ctx.info.name, ctx.info.driver_info);
    println!(
        "| scene | walk ms (median, min) | occupancy ms (median, min) | occupancy / walk | \
         CPU ms: walk, occupancy (medians) | CPU ratio | new isovalue each frame, GPU ms: walk, \
         occupancy with its rebuild (medians) | ratio | pixels differing |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let torus = SdfShape::Torus { major_radius: 0.6, minor_radius: 0.25 };
    let gyroid = SdfShape::Gyroid { scale: 6.0, thickness: 0.08 };
    let eye_torus = [2.2, 1.6, 2.4];
    let eye_gyroid = [3.0, 2.3, 3.3];
    let cases = [
        ("torus 64³", torus, 64, eye_torus, 40.0),
        ("torus 256³", torus, 256, eye_torus, 40.0),
        ("gyroid 256³", gyroid, 256, eye_gyroid, 40.0),
        ("torus 256³, close", torus, 256, [0.9, 0.5, 0.9], 60.0),
        ("gyroid 256³, inside", gyroid, 256, [0.3, 0.2, 0.5], 70.0),
        ("torus 256³, every ray misses the box", torus, 256, [2.2, 1.6, 2.4], 40.0),
    ];
    for (name, shape, n, eye, fov) in cases {
        let grid = sdf_grid(shape, n);
        let gpu_grid = GpuGrid::upload(&ctx, &grid).expect("upload");
        let mut scene = Scene::new(FieldSpec::from_grid(grid.clone()));
        scene.image = ImageSettings { width: size, height: size };
        scene.camera.eye = DVec3::from_array(eye);
        scene.camera.fov_y_deg = fov;
        if name.contains("misses") {
            scene.camera.target = DVec3::splat(10.0);
        }
        let mut times = [Vec::new(), Vec::new()];
        let mut cpu = [Vec::new(), Vec::new()];
        // A new isovalue every frame (what serve does while the isovalue is dragged): the
        // occupancy walk then rebuilds its structure every frame, the plain walk has none.
        let mut moved = [Vec::new(), Vec::new()];
        let mut last: [Option<Frame>; 2] = [None, None];
        for _ in 0..frames {
            for (v, t) in times.iter_mut().enumerate() {
                renderer.accel = if v == 1 {
                    isoview::render::Accel::TwoPass
                } else {
                    isoview::render::Accel::Plain
                };
                let c0 = cpu_seconds();
                let f = renderer.render_uploaded(&scene, &grid, &gpu_grid, 0.0).expect("render");
                cpu[v].push((cpu_seconds() - c0) * 1e3);
                t.push(renderer.last_gpu_ms.unwrap_or(f64::NAN));
                last[v] = Some(f);
            }
        }
        for round in 0..frames {
            for (v, t) in moved.iter_mut().enumerate() {
                renderer.accel = if v == 1 { Accel::TwoPass } else { Accel::Plain };
                let mut s = scene.clone();
                s.surface.isovalue += 0.001 * (1 + round) as f64;
                renderer.render_uploaded(&s, &grid, &gpu_grid, 0.0).expect("render");
                t.push(renderer.last_gpu_ms.unwrap_or(f64::NAN));
            }
        }
        let [a, b] = times.map(stats);
        let [ca, cb] = cpu.map(stats);
        let [ma, mb] = moved.map(stats);
        let differ = same_but_steps(last[0].as_ref().unwrap(), last[1].as_ref().unwrap());
        println!(
            "| {name} | {:.1}, {:.1} | {:.1}, {:.1} | {:.2}× | {:.0}, {:.0} | {:.2}× | {:.1}, {:.1} | {:.2}× | {differ} |",
            a.0,
            a.1,
            b.0,
            b.1,
            b.0 / a.0,
            ca.0,
            cb.0,
            cb.0 / ca.0,
            ma.0,
            mb.0,
            mb.0 / ma.0
        );
    }
}
