//! `./x bench --gpu` (`cargo bench --bench gpu`): the benchmark tables that need no peer, on
//! whatever Vulkan device the run opens, in one command, and how far that device lands from
//! the lavapipe goldens. One home for the golden set too ([`golden`]), which the visual
//! regression test (`tests/it/compare/golden.rs`) renders.
//!
//! ```text
//!   rays:     torus and gyroid SDFs at each grid size: analytic (the structures' build, then
//!             the trace with them built; the brick-by-brick walk beside it), fixed-step at 512
//!             steps (skip off), a new isovalue on the uploaded grid (what `serve` re-renders)
//!   extract:  the gyroid at each grid size, marching cubes and surface nets on the GPU
//!   goldens:  every golden scene rendered by the `isoview` binary on this device, compared
//!             with its lavapipe golden channel by channel (the golden test's thresholds)
//! ```
//!
//! Times are GPU timestamps where the device has them (`GPU ms`), wall clock otherwise (the
//! extraction and the re-render are wall clock: what a user waits for). Medians of
//! `frames`. Printed as Markdown tables and written as JSON. Never asserted on: the test at a
//! tiny size (`tests/it/project/bench_gpu.rs`) checks the tables are whole.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde_json::{json, Value};

use crate::gpu::{Context, Image3d};
use crate::mesh::MeshAlgorithm;
use crate::passes::extract::{Extractor, GpuExtractOptions};
use crate::render::{GpuGrid, Renderer};
use crate::scene::{Method, Scene};

pub mod golden {
    //! The golden set: every `scenes/*.toml` with each method, extra times of the
    //! time-varying scenes, and the other extraction methods on two scenes; each rendered by
    //! the `isoview` binary at [`GOLDEN_SIZE`] and compared with [`thresholds`].

    use std::path::{Path, PathBuf};
    use std::process::Command;

    use crate::compare::{ChannelClass, Thresholds};

    /// Longest image side of a golden render.
    pub const GOLDEN_SIZE: u32 = 96;
    /// Methods rendered for every scene.
    pub const METHODS: [&str; 3] = ["fixed-step", "analytic", "mesh"];
    /// Extra goldens of time-varying scenes at another time: (scene, time).
    pub const EXTRA_TIMES: [(&str, f64); 2] = [("cell-oscillating", 0.5), ("expr-waves", 1.0)];
    /// Extra mesh renders with every other extraction algorithm (the scenes' own is marching
    /// cubes): the tunnel cell, whose topology each algorithm gets differently, and the
    /// torus. Their method is `mesh-<algorithm>`.
    pub const EXTRA_MESH_SCENES: [&str; 2] = ["cell-tunnel", "torus"];
    pub const EXTRA_MESHES: [&str; 4] =
        ["mc33", "marching-tetrahedra", "surface-nets", "dual-contouring"];

    /// One golden image: a scene rendered with a method at a time.
    #[derive(Clone, Debug)]
    pub struct Golden {
        pub scene: String,
        pub method: String,
        pub time: f64,
    }

    impl Golden {
        pub fn name(&self) -> String {
            if self.time == 0.0 {
                format!("{}.{}", self.scene, self.method)
            } else {
                format!("{}.{}.t{}", self.scene, self.method, self.time)
            }
        }

        /// Its golden EXR under the repository `root`.
        pub fn path(&self, root: &Path) -> PathBuf {
            root.join("golden").join(format!("{}.exr", self.name()))
        }

        pub fn scene_path(&self, root: &Path) -> PathBuf {
            root.join("scenes").join(format!("{}.toml", self.scene))
        }

        /// The `isoview render` command (binary `bin`) that makes it into `out`, with `sets`
        /// after its own overrides: the scene's image scaled to [`GOLDEN_SIZE`], the method.
        pub fn command(
            &self,
            bin: &Path,
            root: &Path,
            out: &Path,
            sets: &[String],
        ) -> Result<Command, String> {
            let scene =
                crate::scene::load(&self.scene_path(root), &[]).map_err(|e| e.to_string())?;
            let (w, h) = (scene.image.width as f64, scene.image.height as f64);
            let scale = GOLDEN_SIZE as f64 / w.max(h);
            let (w, h) = (((w * scale).round() as u32).max(1), ((h * scale).round() as u32).max(1));
            let mut cmd = Command::new(bin);
            cmd.arg("render").arg(self.scene_path(root)).arg("-o").arg(out);
            cmd.args(["--time", &self.time.to_string()]);
            let (method, mesh) = match self.method.strip_prefix("mesh-") {
                Some(algo) => ("mesh", Some(format!("render.mesh=\"{algo}\""))),
                None => (self.method.as_str(), None),
            };
            let own = [
                format!("image.width={w}"),
                format!("image.height={h}"),
                format!("render.method=\"{method}\""),
            ];
            for s in own.iter().chain(&mesh).chain(sets) {
                cmd.args(["--set", s]);
            }
            Ok(cmd)
        }
    }

    /// Every golden of the repository at `root`, scenes in name order.
    pub fn goldens(root: &Path) -> std::io::Result<Vec<Golden>> {
        let mut scenes = Vec::new();
        for e in std::fs::read_dir(root.join("scenes"))? {
            let p = e?.path();
            if p.extension().is_some_and(|x| x == "toml") {
                if let Some(stem) = p.file_stem() {
                    scenes.push(stem.to_string_lossy().into_owned());
                }
            }
        }
        scenes.sort();
        let mut out = Vec::new();
        for scene in &scenes {
            for method in METHODS {
                out.push(Golden { scene: scene.clone(), method: method.into(), time: 0.0 });
                for (s, t) in EXTRA_TIMES {
                    if s == scene {
                        out.push(Golden { scene: scene.clone(), method: method.into(), time: t });
                    }
                }
            }
            if EXTRA_MESH_SCENES.contains(&scene.as_str()) {
                for algo in EXTRA_MESHES {
                    let method = format!("mesh-{algo}");
                    out.push(Golden { scene: scene.clone(), method, time: 0.0 });
                }
            }
        }
        Ok(out)
    }

    /// The goldens' tolerances, set from the noise the ignored test `golden::calibrate`
    /// measures across lavapipe's configurations (docs/compare.md "Visual regression").
    pub fn thresholds() -> Thresholds {
        Thresholds {
            fail: 1e-6,
            fail_relative: 1e-6,
            fail_class: vec![(ChannelClass::Integer, 0.0)],
            fail_percent: 0.0,
            warn: 1e-6,
            flip: true,
            new_channels: true,
            ..Thresholds::default()
        }
    }
}

/// What to run.
#[derive(Clone, Debug)]
pub struct Options {
    /// Grid points per axis of the rays and extraction tables.
    pub sizes: Vec<usize>,
    /// Image side of the rays table.
    pub image: u32,
    /// Frames per timing (the median is reported).
    pub frames: usize,
    /// The repository (its `scenes/` and `golden/`).
    pub root: PathBuf,
    /// The `isoview` binary that renders the goldens; None: no goldens table.
    pub isoview: Option<PathBuf>,
    /// Scratch folder for the golden renders.
    pub scratch: PathBuf,
}

impl Options {
    /// The full run: 256³ to 1024³ grids, 512² images, 3 frames.
    pub fn full(root: PathBuf, isoview: Option<PathBuf>, scratch: PathBuf) -> Options {
        Options { sizes: vec![256, 512, 1024], image: 512, frames: 3, root, isoview, scratch }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// Shows a float with 1 decimal, "-" for NaN.
fn cell(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.1}")
    } else {
        "-".into()
    }
}

/// One of the shipped SDF scenes at `n`³ points, `size`² pixels.
fn scene_at(root: &Path, name: &str, n: usize, size: u32) -> Result<Scene, String> {
    let sets = [
        format!("field.resolution=[{n},{n},{n}]"),
        format!("image.width={size}"),
        format!("image.height={size}"),
    ];
    crate::scene::load(&root.join("scenes").join(format!("{name}.toml")), &sets)
        .map_err(|e| e.to_string())
}

/// Runs every table on `ctx`, printing each as it is done; the whole as JSON.
pub fn run(ctx: &std::sync::Arc<Context>, o: &Options) -> Result<Value, String> {
    let e = |e: &dyn std::fmt::Display| e.to_string();
    let mut renderer = Renderer::new(ctx).map_err(|x| e(&x))?;
    println!("device: {} ({}), {}", ctx.info.name, ctx.info.driver_info, ctx.info.device_type);
    println!();
    println!(
        "rays: {0}x{0} image, medians of {1}; GPU ms (timestamps); build: the brick min/max grid \
         (once per grid) and the occupancy structure (once per isovalue) in the first analytic \
         frame; trace: a frame with both built; walk: the same frame brick by brick \
         (render.occupancy = false); new isovalue: wall ms of a render on the uploaded grid with \
         the isovalue moved (what serve re-renders, the structure's rebuild included)",
        o.image, o.frames
    );
    println!();
    println!("| scene | grid | build GPU ms (bricks + occupancy) | analytic trace GPU ms | Mrays/s | walk GPU ms | trace / walk | fixed-step 512 GPU ms | analytic / fixed-step | new isovalue ms |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut rays = Vec::new();
    for name in ["torus", "gyroid"] {
        for &n in &o.sizes {
            let mut scene = scene_at(&o.root, name, n, o.image)?;
            let grid = scene.field.sample(0.0).map_err(|x| e(&x))?;
            let gpu_grid = GpuGrid::upload(ctx, &grid).map_err(|x| e(&x))?;
            let time = |scene: &Scene, renderer: &mut Renderer| -> Result<(f64, f64), String> {
                let (mut gpu, mut wall) = (Vec::new(), Vec::new());
                for _ in 0..o.frames {
                    let t = Instant::now();
                    renderer.render_uploaded(scene, &grid, &gpu_grid, 0.0).map_err(|x| e(&x))?;
                    wall.push(ms_since(t));
                    gpu.push(renderer.last_gpu_ms.unwrap_or(f64::NAN));
                }
                Ok((median(gpu), median(wall)))
            };
            scene.render.method = Method::Analytic;
            renderer.render_uploaded(&scene, &grid, &gpu_grid, 0.0).map_err(|x| e(&x))?;
            // The brick grid on the device, or on a CPU device by the CPU (its wall time).
            let bricks_ms = renderer.last_bricks_ms.or(renderer.last_bricks_cpu_ms);
            let build =
                bricks_ms.unwrap_or(f64::NAN) + renderer.last_occupancy_ms.unwrap_or(f64::NAN);
            let (analytic, _) = time(&scene, &mut renderer)?;
            let mut plain = scene.clone();
            plain.render.occupancy = false;
            let (walk, _) = time(&plain, &mut renderer)?;
            let mut fixed = scene.clone();
            fixed.render.method = Method::FixedStep;
            fixed.render.steps = 512;
            fixed.render.skip = false;
            let (fixed_ms, _) = time(&fixed, &mut renderer)?;
            let mut moved = scene.clone();
            moved.surface.isovalue += 0.01;
            let (_, again) = time(&moved, &mut renderer)?;
            let mrays = (o.image as f64).powi(2) / (analytic * 1e3);
            let ratio = |a: f64, b: f64| match a.is_finite() && b > 0.0 {
                true => format!("{:.2}×", a / b),
                false => "-".into(),
            };
            println!(
                "| {name} | {n}³ | {} | {} | {} | {} | {} | {} | {} | {} |",
                cell(build),
                cell(analytic),
                cell(mrays),
                cell(walk),
                ratio(analytic, walk),
                cell(fixed_ms),
                ratio(analytic, fixed_ms),
                cell(again)
            );
            rays.push(json!({
                "scene": name, "n": n, "image": o.image, "build_gpu_ms": build,
                "analytic_gpu_ms": analytic, "walk_gpu_ms": walk,
                "fixed_step_512_gpu_ms": fixed_ms, "new_isovalue_ms": again,
            }));
        }
    }
    println!();
    println!(
        "extract (GPU passes, wall ms of the extraction and its read-back, median of {}):",
        o.frames
    );
    println!();
    println!("| scene | grid | method | ms | triangles |");
    println!("|---|---|---|---|---|");
    let mut extract = Vec::new();
    let mut extractor = Extractor::new(ctx).map_err(|x| e(&x))?;
    for &n in &o.sizes {
        let scene = scene_at(&o.root, "gyroid", n, o.image)?;
        let grid = scene.field.sample(0.0).map_err(|x| e(&x))?;
        let dims = grid.dims.map(|d| d as u32);
        let image = Image3d::upload(ctx, "grid", dims, &grid.values).map_err(|x| e(&x))?;
        for algo in [MeshAlgorithm::MarchingCubes, MeshAlgorithm::SurfaceNets] {
            let (mut times, mut triangles) = (Vec::new(), 0);
            for _ in 0..o.frames {
                let t = Instant::now();
                let iso = scene.surface.isovalue;
                let inside = scene.surface.inside;
                let opts = GpuExtractOptions::default();
                let mesh = extractor
                    .extract(&grid, &image, iso, inside, algo, &opts)
                    .map_err(|x| e(&x))?;
                triangles = mesh.triangle_count;
                mesh.read().map_err(|x| e(&x))?;
                times.push(ms_since(t));
            }
            let ms = median(times);
            println!("| gyroid | {n}³ | {} | {} | {triangles} |", algo.name(), cell(ms));
            extract.push(json!({"scene": "gyroid", "n": n, "method": algo.name(), "ms": ms, "triangles": triangles}));
        }
    }
    let goldens = match &o.isoview {
        None => Value::Null,
        Some(bin) => goldens_table(ctx, bin, o)?,
    };
    Ok(json!({
        "device": ctx.info.name, "driver": ctx.info.driver_info, "device_type": ctx.info.device_type,
        "rays": rays, "extract": extract, "goldens": goldens,
    }))
}

/// Every golden rendered by `bin` on this run's device and compared with its lavapipe golden.
fn goldens_table(ctx: &Context, bin: &Path, o: &Options) -> Result<Value, String> {
    let thresholds = golden::thresholds();
    let all = golden::goldens(&o.root).map_err(|e| format!("{}: {e}", o.root.display()))?;
    std::fs::create_dir_all(&o.scratch).map_err(|e| format!("{}: {e}", o.scratch.display()))?;
    println!();
    println!(
        "goldens on {} against lavapipe's (golden/, the golden test's thresholds): the verdict, \
         and per channel class the largest |Δ|",
        ctx.info.name
    );
    println!();
    println!("| golden | verdict | colour | depth | normal | position | integer | other |");
    println!("|---|---|---|---|---|---|---|---|");
    let classes = ["colour", "depth", "normal", "position", "integer", "other"];
    let mut rows = Vec::new();
    for g in all {
        let out = o.scratch.join(format!("{}.exr", g.name()));
        let mut cmd = g.command(bin, &o.root, &out, &[])?;
        cmd.env("ISOVIEW_DEVICE", &ctx.info.name);
        let run = cmd.output().map_err(|e| format!("{}: {e}", bin.display()))?;
        if !run.status.success() {
            return Err(format!(
                "rendering {}: {}",
                g.name(),
                String::from_utf8_lossy(&run.stderr).trim()
            ));
        }
        let read = |p: &Path| crate::output::exr::read(p).map_err(|e| e.to_string());
        let report = crate::compare::compare(&read(&g.path(&o.root))?, &read(&out)?, &thresholds)
            .map_err(|e| e.to_string())?;
        let worst: Vec<f64> = classes
            .iter()
            .map(|k| {
                report
                    .channels
                    .iter()
                    .filter(|c| c.class.name() == *k)
                    .map(|c| c.max_abs)
                    .fold(f64::NAN, f64::max)
            })
            .collect();
        let verdict = format!("{:?}", report.verdict).to_lowercase();
        let shown: Vec<String> = worst
            .iter()
            .map(|v| if v.is_nan() { "-".into() } else { format!("{v:.1e}") })
            .collect();
        println!("| {} | {verdict} | {} |", g.name(), shown.join(" | "));
        let max: serde_json::Map<String, Value> = classes
            .iter()
            .zip(&worst)
            .filter(|(_, v)| !v.is_nan())
            .map(|(k, v)| (k.to_string(), json!(v)))
            .collect();
        rows.push(json!({
            "golden": g.name(), "verdict": verdict, "failing_pixels": report.failing_pixels,
            "max_abs": max,
        }));
        let _ = std::fs::remove_file(&out);
    }
    Ok(Value::Array(rows))
}
