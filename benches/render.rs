//! `cargo bench --bench render` (or `./x bench`): fixed-step ray marching rays/s and samples/s
//! on the current Vulkan device, against the f64 CPU reference measured in the same run; then
//! the same march through each `field.interpolation`, against trilinear in the same run.
//! Prints tables; never asserts on time.

use std::time::Instant;

use glam::DVec3;
use isoview::field::{FieldSource, FieldSpec, Grid};
use isoview::gpu::{Context, ContextOptions};
use isoview::reference::fixed_step;
use isoview::render::{GpuGrid, Renderer};
use isoview::scene::*;

fn torus_grid(n: usize) -> Grid {
    let spec = FieldSpec {
        source: FieldSource::Sdf {
            shape: SdfShape::Torus { major_radius: 0.6, minor_radius: 0.25 },
            center: DVec3::ZERO,
        },
        resolution: [n, n, n],
        bounds: Bounds { min: DVec3::splat(-1.0), max: DVec3::splat(1.0) },
        placement: Default::default(),
        residency: isoview::field::Residency::Whole,
        nan: Default::default(),
        interpolation: Default::default(),
    };
    spec.sample(0.0).expect("torus grid")
}

/// The contract's default scene (camera included) over `grid`, fixed-step.
fn scene(grid: &Grid, size: u32, steps: u32) -> Scene {
    let mut scene = Scene::new(FieldSpec::from_grid(grid.clone()));
    scene.image = ImageSettings { width: size, height: size };
    scene.render.method = Method::FixedStep;
    scene.render.steps = steps;
    scene
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

fn main() {
    let ctx = match Context::new(&ContextOptions::default()) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("bench: {e}");
            std::process::exit(3);
        }
    };
    let mut renderer = Renderer::new(&ctx).expect("renderer");
    let size = 512;
    let steps = 200;
    println!("device: {} ({})", ctx.info.name, ctx.info.driver_info);
    println!("fixed-step, {size}x{size} image, torus SDF, steps = {steps}; GPU: median of 5 frames (GPU timestamps); CPU: f64 reference, one thread, every 8th row");
    println!();
    println!("| grid | GPU ms/frame | GPU rays/s | GPU samples/s | CPU rays/s | CPU samples/s | GPU/CPU |");
    println!("|---|---|---|---|---|---|---|");
    for n in [64usize, 256] {
        let grid = torus_grid(n);
        let sc = scene(&grid, size, steps);
        let gpu_grid = GpuGrid::upload(&ctx, &grid).expect("upload");
        let mut times = Vec::new();
        let mut samples = 0.0;
        for _ in 0..5 {
            let frame = renderer.render_uploaded(&sc, &grid, &gpu_grid, 0.0).expect("render");
            times.push(renderer.last_gpu_ms.unwrap_or(f64::NAN) / 1e3);
            samples = frame.pixels.iter().map(|p| p.steps as f64).sum();
        }
        let gpu_s = median(times);
        let rays = (size * size) as f64;

        let cam = isoview::camera::Camera::new(&sc.camera, &sc.image);
        let started = Instant::now();
        let (mut cpu_rays, mut cpu_samples) = (0.0, 0.0);
        for py in (0..size).step_by(8) {
            for px in 0..size {
                let (origin, dir) = cam.ray(px, py);
                let m = fixed_step::march(&grid, 0.0, Inside::Below, origin, dir, steps);
                cpu_rays += 1.0;
                cpu_samples += m.steps as f64;
            }
        }
        let cpu_s = started.elapsed().as_secs_f64();
        println!(
            "| {n}³ | {:.1} | {:.3e} | {:.3e} | {:.3e} | {:.3e} | {:.1}× |",
            gpu_s * 1e3,
            rays / gpu_s,
            samples / gpu_s,
            cpu_rays / cpu_s,
            cpu_samples / cpu_s,
            (rays / gpu_s) / (cpu_rays / cpu_s)
        );
    }
    interpolants(&ctx, &mut renderer);
}

/// Fixed-step through each interpolant on the torus at 64³ and 256³ (the same rays, steps and
/// grid), as a ratio of trilinear's time in the same run.
fn interpolants(ctx: &std::sync::Arc<Context>, renderer: &mut Renderer) {
    use isoview::field::interpolant::Interpolant;
    let (size, steps) = (256, 200);
    println!();
    println!("fixed-step through each field.interpolation, {size}x{size} image, torus SDF, steps = {steps}; GPU: median of 3 frames (GPU timestamps), ratio to trilinear in this run");
    println!();
    println!("| grid | interpolation | GPU ms/frame | × trilinear |");
    println!("|---|---|---|---|");
    for n in [64usize, 256] {
        let grid = torus_grid(n);
        let gpu_grid = GpuGrid::upload(ctx, &grid).expect("upload");
        let mut trilinear = f64::NAN;
        for interp in Interpolant::ALL {
            let mut sc = scene(&grid, size, steps);
            sc.field.interpolation = interp;
            let times: Vec<f64> = (0..3)
                .map(|_| {
                    renderer.render_uploaded(&sc, &grid, &gpu_grid, 0.0).expect("render");
                    renderer.last_gpu_ms.unwrap_or(f64::NAN)
                })
                .collect();
            let ms = median(times);
            if interp == Interpolant::Trilinear {
                trilinear = ms;
            }
            println!("| {n}³ | {} | {ms:.1} | {:.2}× |", interp.name(), ms / trilinear);
        }
    }
}
