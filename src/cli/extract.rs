//! `isoview extract SCENE.toml -o MESH.{ply,obj,stl} [--set K=V]... [--device gpu|cpu] [--stats]
//! [--time T] [--quads]`
//!
//! Samples the scene's field, extracts the isosurface with `render.mesh` (marching-cubes, mc33,
//! surface-nets, dual-contouring, marching-tetrahedra) and writes it atomically in the format of
//! the output's extension: binary PLY with normals, OBJ with normals, or binary STL.
//!
//! `--device` is also isoview's global option naming the Vulkan device. For `extract` the words
//! `gpu` and `cpu` written on the command line choose where the extraction runs (the contract's
//! `--device gpu|cpu`); any other value names the Vulkan device, as for every other subcommand,
//! and implies `gpu`. With `--device gpu|cpu` the Vulkan device comes from `ISOVIEW_DEVICE`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::{Cli, Failure};
use crate::field::Grid;
use crate::mesh::export::{self, Format};
use crate::mesh::{self, ExtractOptions, Mesh};
use crate::output::atomic;
use crate::scene::{self, Scene};

#[derive(clap::Args, Debug)]
pub struct ExtractArgs {
    /// Scene file (TOML); `render.mesh` picks the algorithm, `[surface]` the isovalue and inside.
    pub scene: PathBuf,
    /// Output mesh: .ply (binary, with normals), .obj (with normals) or .stl (binary).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Override a scene key (as for `render`), e.g. --set render.mesh=mc33
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Print the mesh's statistics (size, area, volume, boundary and non-manifold edges,
    /// min-angle histogram) to stdout.
    #[arg(long)]
    pub stats: bool,
    /// Time of the field in seconds (`t` in expr fields).
    #[arg(long, default_value_t = 0.0)]
    pub time: f64,
    /// Write the quads of surface-nets and dual-contouring instead of their triangles (PLY and
    /// OBJ; STL holds triangles only).
    #[arg(long)]
    pub quads: bool,
}

/// Where the extraction runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// Vulkan compute (`isoview::passes::extract`).
    Gpu,
    /// The f64 CPU reference (`isoview::mesh::extract`).
    Cpu,
}

impl Backend {
    pub fn name(self) -> &'static str {
        match self {
            Backend::Gpu => "gpu",
            Backend::Cpu => "cpu",
        }
    }
}

/// Splits the global `--device` value into the backend and the Vulkan device name.
///
/// `device` is the parsed value, `from_command_line` whether it was written on the command line
/// (rather than read from `ISOVIEW_DEVICE`), `env` the value of `ISOVIEW_DEVICE`.
pub fn resolve_device(
    device: Option<&str>,
    from_command_line: bool,
    env: Option<&str>,
) -> (Backend, Option<String>) {
    let env = env.filter(|e| !e.trim().is_empty()).map(str::to_string);
    match device {
        Some(d) if from_command_line && d.eq_ignore_ascii_case("cpu") => (Backend::Cpu, env),
        Some(d) if from_command_line && d.eq_ignore_ascii_case("gpu") => (Backend::Gpu, env),
        Some(d) => (Backend::Gpu, Some(d.to_string())),
        None => (Backend::Gpu, env),
    }
}

pub fn run(cli: &Cli, args: &ExtractArgs) -> Result<i32, Failure> {
    let format = Format::from_path(&args.output).ok_or_else(|| {
        Failure::input(format!(
            "-o {}: the file name must end in .ply, .obj or .stl",
            args.output.display()
        ))
    })?;
    if !args.time.is_finite() {
        return Err(Failure::input(format!("--time {}: must be a finite number", args.time)));
    }
    let env = std::env::var("ISOVIEW_DEVICE").ok();
    let (backend, vulkan_device) =
        resolve_device(cli.device.as_deref(), cli.device_from_command_line, env.as_deref());
    let scene = scene::load(&args.scene, &args.sets).map_err(Failure::input)?;

    let started = Instant::now();
    let grid = scene.field.sample(args.time).map_err(Failure::input)?;
    let opts = ExtractOptions { keep_quads: args.quads, ..Default::default() };
    let (mesh, ran_on) = match backend {
        Backend::Cpu => (extract_cpu(&scene, &grid, opts)?, Backend::Cpu),
        Backend::Gpu => extract_gpu(cli, vulkan_device, &scene, &grid, opts)?,
    };
    let elapsed = started.elapsed().as_secs_f64() * 1e3;
    write_mesh(&args.output, &mesh, format)?;

    if args.stats {
        println!("{}", mesh::stats::compute(&mesh));
    }
    eprintln!(
        "isoview: {} vertices, {} triangles ({} on {}) in {elapsed:.0} ms -> {}",
        mesh.vertex_count(),
        mesh.triangle_count(),
        scene.render.mesh.name(),
        ran_on.name(),
        args.output.display()
    );
    if mesh.triangle_count() == 0 {
        let (lo, hi) = grid.range();
        eprintln!(
            "isoview: note: the mesh is empty: no grid edge crosses isovalue {} (samples span \
             [{lo}, {hi}])",
            scene.surface.isovalue
        );
    }
    Ok(0)
}

/// The f64 CPU reference extraction.
pub fn extract_cpu(scene: &Scene, grid: &Grid, opts: ExtractOptions) -> Result<Mesh, Failure> {
    mesh::extract(grid, scene.surface.isovalue, scene.surface.inside, scene.render.mesh, opts)
        .map_err(|e| Failure::input(format!("{}: {e}", scene_name(scene))))
}

/// The GPU extraction (compute passes of [`passes::extract`]) on the Vulkan device `vulkan_device`,
/// read back into a [`Mesh`], and where it ran. `opts.split` is honoured; `opts.keep_quads`
/// needs the CPU quads, so `--quads` extracts on the CPU, with a note on stderr, as does `mc33`
/// on a device without `shaderFloat64`.
fn extract_gpu(
    cli: &Cli,
    vulkan_device: Option<String>,
    scene: &Scene,
    grid: &Grid,
    opts: ExtractOptions,
) -> Result<(Mesh, Backend), Failure> {
    if opts.keep_quads {
        eprintln!("isoview: note: --quads extracts on the CPU (the GPU extraction has no quads)");
        return Ok((extract_cpu(scene, grid, opts)?, Backend::Cpu));
    }
    let ctx = crate::gpu::Context::new(&crate::gpu::ContextOptions {
        device: vulkan_device,
        validation: cli.validation,
    })?;
    if scene.render.mesh == crate::scene::MeshAlgorithm::Mc33 && !ctx.info.float64 {
        eprintln!(
            "isoview: note: mc33 is extracted on the CPU ({} has no 64-bit floats, which the \
             GPU mc33 passes need)",
            ctx.info.name
        );
        return Ok((extract_cpu(scene, grid, opts)?, Backend::Cpu));
    }
    let image =
        crate::gpu::Image3d::upload(&ctx, "grid", grid.dims.map(|d| d as u32), &grid.values)?;
    let gpu_opts =
        crate::passes::extract::GpuExtractOptions { split: opts.split, ..Default::default() };
    let gpu_mesh = crate::passes::extract::Extractor::new(&ctx)
        .and_then(|mut x| {
            x.extract(
                grid,
                &image,
                scene.surface.isovalue,
                scene.surface.inside,
                scene.render.mesh,
                &gpu_opts,
            )
        })
        .map_err(|e| match e {
            crate::passes::extract::GpuMeshError::Gpu(g) => Failure::gpu(g),
            other => Failure::input(format!("{}: {other}", scene_name(scene))),
        })?;
    Ok((gpu_mesh.read()?, Backend::Gpu))
}

fn scene_name(scene: &Scene) -> String {
    scene.path.as_ref().map_or_else(|| "scene".to_string(), |p| p.display().to_string())
}

/// Writes `mesh` to `path` whole or not at all.
pub fn write_mesh(path: &Path, mesh: &Mesh, format: Format) -> Result<(), Failure> {
    atomic::write_with(path, |w| export::write(mesh, format, w)).map_err(Failure::input)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_words_choose_the_backend_and_other_values_name_the_vulkan_device() {
        assert_eq!(resolve_device(None, false, None), (Backend::Gpu, None));
        assert_eq!(resolve_device(Some("cpu"), true, None), (Backend::Cpu, None));
        assert_eq!(
            resolve_device(Some("GPU"), true, Some("llvmpipe")),
            (Backend::Gpu, Some("llvmpipe".into()))
        );
        assert_eq!(
            resolve_device(Some("llvmpipe"), true, None),
            (Backend::Gpu, Some("llvmpipe".into()))
        );
        // From ISOVIEW_DEVICE, a value is always a Vulkan device name.
        assert_eq!(
            resolve_device(Some("cpu"), false, Some("cpu")),
            (Backend::Gpu, Some("cpu".into()))
        );
    }
}
