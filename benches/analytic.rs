//! `cargo bench --bench analytic` (or `./x bench`): exact ray tracing against fixed-step ray
//! marching, and empty-space skipping on and off, on the current Vulkan device. Prints a
//! markdown table; never asserts on time.
//!
//! For each scene, in one run:
//! 1. the analytic hit mask (skipping on; the brick grid is built by this first analytic frame
//!    and timed apart);
//! 2. the smallest fixed-step `steps` whose hit mask matches the analytic one on at least 99.9%
//!    of the pixels: doubling from 4 until it matches, then bisection between the last miss and
//!    the first match (matching is not strictly monotone in `steps`; this finds a boundary);
//! 3. `FRAMES` rounds of one frame each of analytic with skipping, analytic without, and
//!    fixed-step at that `steps`, interleaved so that a change in the machine's load hits all
//!    three alike; each reports the median GPU time of its frames (GPU timestamps around the ray
//!    passes, `Renderer::last_gpu_ms`).
//!
//! Scenes: a torus SDF on 64³ and a small sphere in a corner of a 256³ grid (default camera),
//! then every shipped scene in `scenes/` with its own camera, rendered square at the bench size.
//!
//! Environment: `ISOVIEW_BENCH_SIZE` (image side, default 512), `ISOVIEW_BENCH_FRAMES`
//! (default 5), `ISOVIEW_BENCH_SHIPPED=0` to leave out the shipped scenes.

use glam::DVec3;
use isoview::field::{FieldSource, FieldSpec, Grid};
use isoview::frame::Frame;
use isoview::gpu::{Context, ContextOptions};
use isoview::render::{GpuGrid, Renderer};
use isoview::scene::*;

fn sdf_grid(shape: SdfShape, center: DVec3, n: usize) -> Grid {
    let spec = FieldSpec {
        source: FieldSource::Sdf { shape, center },
        resolution: [n, n, n],
        bounds: Bounds { min: DVec3::splat(-1.0), max: DVec3::splat(1.0) },
        placement: Default::default(),
        residency: isoview::field::Residency::Whole,
        nan: Default::default(),
        interpolation: Default::default(),
    };
    spec.sample(0.0).expect("grid")
}

/// The contract's default scene (analytic, default camera) over `grid`.
fn scene(grid: &Grid, size: u32) -> Scene {
    let mut scene = Scene::new(FieldSpec::from_grid(grid.clone()));
    scene.image = ImageSettings { width: size, height: size };
    scene
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

struct Bench<'a> {
    renderer: &'a mut Renderer,
    grid: &'a Grid,
    gpu_grid: &'a GpuGrid,
    frames: usize,
}

impl Bench<'_> {
    fn frame(&mut self, scene: &Scene) -> Frame {
        self.renderer.render_uploaded(scene, self.grid, self.gpu_grid, 0.0).expect("render")
    }

    /// Median GPU seconds per frame of each scene, frames interleaved.
    fn time(&mut self, scenes: &[&Scene]) -> Vec<f64> {
        let mut times = vec![Vec::new(); scenes.len()];
        for _ in 0..self.frames {
            for (s, t) in scenes.iter().zip(&mut times) {
                self.frame(s);
                t.push(self.renderer.last_gpu_ms.unwrap_or(f64::NAN) / 1e3);
            }
        }
        times.into_iter().map(median).collect()
    }
}

/// Pixels whose hit/miss agree.
fn agreeing(a: &Frame, b: &Frame) -> usize {
    a.pixels.iter().zip(&b.pixels).filter(|(x, y)| x.is_hit() == y.is_hit()).count()
}

fn main() {
    let ctx = match Context::new(&ContextOptions::default()) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("bench: {e}");
            std::process::exit(3);
        }
    };
    let env = |k: &str, d: usize| std::env::var(k).ok().and_then(|v| v.parse().ok()).unwrap_or(d);
    let size = env("ISOVIEW_BENCH_SIZE", 512) as u32;
    let frames = env("ISOVIEW_BENCH_FRAMES", 5).max(1);
    let mut renderer = Renderer::new(&ctx).expect("renderer");
    let rays = (size * size) as f64;
    println!("device: {} ({})", ctx.info.name, ctx.info.driver_info);
    println!(
        "analytic vs fixed-step, {size}x{size} image, default camera (shipped scenes: their own); GPU time: median of \
         {frames} frames (GPU timestamps); fixed-step at the smallest steps whose hit mask \
         matches analytic on >= 99.9% of pixels"
    );
    println!();
    println!(
        "| scene | analytic rays/s | no skipping rays/s | skipping speed-up | bricks ms | \
         fixed-step steps | mask match | fixed-step rays/s | analytic / fixed-step |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let torus = SdfShape::Torus { major_radius: 0.6, minor_radius: 0.25 };
    let sphere = SdfShape::Sphere { radius: 0.15 };
    let mut scenes: Vec<(String, Scene, Grid)> = Vec::new();
    for (name, grid) in [
        ("torus SDF 64³", sdf_grid(torus, DVec3::ZERO, 64)),
        ("sphere r = 0.15 in a corner of 256³", sdf_grid(sphere, DVec3::splat(-0.75), 256)),
    ] {
        scenes.push((name.to_string(), scene(&grid, size), grid));
    }
    if env("ISOVIEW_BENCH_SHIPPED", 1) != 0 {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let mut paths: Vec<_> = std::fs::read_dir(&dir)
            .expect("scenes/")
            .map(|e| e.expect("entry").path())
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        paths.sort();
        for path in paths {
            let mut sc = load(&path, &[]).expect("shipped scene");
            let grid = sc.field.sample(0.0).expect("shipped scene's grid");
            sc.image = ImageSettings { width: size, height: size };
            sc.render.method = Method::Analytic;
            sc.render.skip = true;
            let name = format!(
                "scenes/{} ({}x{}x{})",
                path.file_name().expect("name").to_string_lossy(),
                grid.dims[0],
                grid.dims[1],
                grid.dims[2]
            );
            scenes.push((name, sc, grid));
        }
    }
    for (name, analytic, grid) in &scenes {
        let gpu_grid = GpuGrid::upload(&ctx, grid).expect("upload");
        let mut b = Bench { renderer: &mut renderer, grid, gpu_grid: &gpu_grid, frames };
        let analytic = analytic.clone();
        let reference = b.frame(&analytic);
        let bricks_ms = b.renderer.last_bricks_ms;
        let mut no_skip = analytic.clone();
        no_skip.render.skip = false;

        let mut fixed = analytic.clone();
        fixed.render.method = Method::FixedStep;
        let need = (0.999 * rays).ceil() as usize;
        let mut matches = |steps: u32, b: &mut Bench| {
            fixed.render.steps = steps;
            agreeing(&b.frame(&fixed), &reference)
        };
        let (mut lo, mut hi) = (2u32, 4u32);
        while matches(hi, &mut b) < need && hi < 1 << 16 {
            lo = hi;
            hi *= 2;
        }
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if matches(mid, &mut b) >= need {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        let matched = matches(hi, &mut b);
        fixed.render.steps = hi;
        let t = b.time(&[&analytic, &no_skip, &fixed]);
        let (t_skip, t_plain, t_fixed) = (t[0], t[1], t[2]);
        println!(
            "| {name} | {:.3e} | {:.3e} | {:.2}× | {} | {hi} | {matched} / {} ({:.3}%) | {:.3e} | {:.2}× |",
            rays / t_skip,
            rays / t_plain,
            t_plain / t_skip,
            bricks_ms.map(|ms| format!("{ms:.1}")).unwrap_or_else(|| "-".into()),
            rays as usize,
            100.0 * matched as f64 / rays,
            rays / t_fixed,
            t_fixed / t_skip,
        );
    }
}
