//! `isoview extract SCENE.toml -o MESH.{ply,obj,stl} [--set K=V]... [--device auto|gpu|cpu]
//! [--stats] [--time T] [--quads]`
//!
//! Samples the scene's field, extracts the isosurface with `render.mesh` (marching-cubes, mc33,
//! surface-nets, dual-contouring, marching-tetrahedra) and writes it atomically in the format of
//! the output's extension: binary PLY with normals, OBJ with normals, or binary STL.
//!
//! `--device` is also isoview's global option naming the Vulkan device. For `extract` the words
//! `auto`, `gpu` and `cpu` written on the command line choose where the extraction runs; any
//! other value names the Vulkan device, as for every other subcommand, and implies `gpu`. With
//! `--device auto|gpu|cpu` the Vulkan device comes from `ISOVIEW_DEVICE`.
//!
//! * `cpu`: the multi-threaded CPU extraction (`mesh::extract_parallel`, all cores, rayon), whose
//!   mesh is the f64 reference's (`mesh::extract`) bit for bit.
//! * `gpu`: the Vulkan compute passes (`passes::extract`) on the Vulkan device.
//! * `auto` (the default): opens the Vulkan device and extracts on the CPU when its type is CPU
//!   (lavapipe, where the compute passes are software on the same cores and slower than the
//!   CPU path), or when there is no usable Vulkan device; else on the GPU. The summary line on
//!   stderr says which and why.
//!
//! Memory: a PLY of one surface, unclipped, by a method cut into slabs other than mc33,
//! extracted on the CPU, is written piece by piece as the slabs are done
//! ([`extract_streamed`]): the peak is a few slabs' meshes (and the positions with `--stats`). Every other mesh is held whole
//! until it is written, under the cap of `ISOVIEW_MAX_MESH_MIB` ([`MeshLimits`], 1024 MiB by
//! default), counted as the mesh grows and refused past it in one line (exit 2).
//!
//! Under an MPI launcher with more than one rank (`--features mpi`, `cluster::Ranks`), the
//! CPU extraction is split: each rank meshes a range of cell layers and rank 0 joins them
//! and writes the file, which is byte for byte the one process's `--device cpu` file. The
//! GPU extraction and the methods that are not cut into slabs are refused there in one line.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use super::console::{note, say};
use super::{Cli, Failure};
use crate::cluster::{Extracted, Points, Ranks};
use crate::field::mapped::MappedGrid;
use crate::field::Grid;
use crate::mesh::export::{self, Format};
use crate::mesh::stats;
use crate::mesh::{self, ExtractOptions, Mesh, MeshBudget, MeshLimits};
use crate::output::atomic;
use crate::scene::Scene;

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
    #[arg(long, default_value_t = 0.0, value_parser = super::number)]
    pub time: f64,
    /// Write the quads of surface-nets and dual-contouring instead of their triangles (PLY and
    /// OBJ; STL holds triangles only).
    #[arg(long)]
    pub quads: bool,
}

/// Where the extraction runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// The CPU when the Vulkan device is a CPU or missing, else the GPU (the default).
    Auto,
    /// Vulkan compute (`isoview::passes::extract`).
    Gpu,
    /// The multi-threaded CPU extraction (`isoview::mesh::extract_parallel`), equal to the f64
    /// reference `isoview::mesh::extract` bit for bit.
    Cpu,
}

impl Backend {
    pub fn name(self) -> &'static str {
        match self {
            Backend::Auto => "auto",
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
        Some(d) if from_command_line && d.eq_ignore_ascii_case("auto") => (Backend::Auto, env),
        Some(d) => (Backend::Gpu, Some(d.to_string())),
        None => (Backend::Auto, env),
    }
}

pub fn run(cli: &Cli, args: &ExtractArgs) -> Result<i32, Failure> {
    let ranks = Ranks::from_launcher();
    // Every rank reads the same input and so meets the same failures; rank 0 says it.
    match run_on(cli, args, &ranks) {
        Err(f) if !ranks.is_root() => Ok(f.code),
        other => other,
    }
}

fn run_on(cli: &Cli, args: &ExtractArgs, ranks: &Ranks) -> Result<i32, Failure> {
    let format = Format::from_path(&args.output).ok_or_else(|| {
        Failure::input(format!(
            "-o {}: the file name must end in .ply, .obj or .stl",
            args.output.display()
        ))
    })?;
    super::finite("--time", args.time)?;
    let env = std::env::var("ISOVIEW_DEVICE").ok();
    let (backend, vulkan_device) =
        resolve_device(cli.device.as_deref(), cli.device_from_command_line, env.as_deref());
    let scene = super::load_scene(&args.scene, &args.sets)?;
    super::check_outputs(&[("-o", &args.output)], &scene)?;
    if let Some(why) = ranks.refuses_extract(&scene, backend == Backend::Gpu) {
        return super::refuse_on_ranks(ranks, Failure::input(why));
    }

    let started = Instant::now();
    let opts = ExtractOptions { keep_quads: args.quads, ..Default::default() };
    let limits = crate::field::GridLimits::from_env().map_err(Failure::input)?;
    // One count for every surface's mesh: they are all held until the file is written.
    let budget = Arc::new(MeshBudget::new(MeshLimits::from_env().map_err(Failure::input)?));
    // Under MPI a raw or npy file is mapped and each rank reads only its layers; other
    // sources are sampled whole by every rank.
    if !ranks.is_single() {
        let time = args.time;
        let how = Split { args, format, scene: &scene, opts, started, budget: &budget };
        return match MappedGrid::open(&scene.field).map_err(Failure::input)? {
            Some(m) => extract_ranks(ranks, Points::Mapped(&m), how),
            None => {
                let grid = scene.field.sample(time).map_err(Failure::input)?;
                extract_ranks(ranks, Points::Sampled(&grid), how)
            }
        };
    }
    if let Some(mapped) =
        MappedGrid::for_residency(&scene.field, &limits).map_err(Failure::input)?
    {
        return extract_mapped(args, format, &scene, &mapped, opts, started, &budget);
    }
    // `--device auto` asks Vulkan whether its device is a CPU (loading the drivers: 50–150 ms
    // on lavapipe) on its own thread while the field is read or sampled.
    let mut probe = (backend == Backend::Auto && !opts.keep_quads).then(|| {
        let wanted = vulkan_device.clone();
        std::thread::spawn(move || probe_cpu_device(wanted.as_deref()))
    });
    let grid = scene.field.sample(args.time).map_err(Failure::input)?;
    let cpu_device = probe.take().and_then(|p| p.join().ok().flatten());
    if let Some(why) = streamed_on_cpu(format, &scene, backend, opts, cpu_device.as_deref()) {
        return extract_streamed(args, &scene, &grid, opts, &budget, (why, started));
    }
    // Several isovalues: one mesh per surface, merged, each vertex labelled with its surface.
    let mut meshes = Vec::with_capacity(scene.surface.count);
    let (mut ran_on, mut why) = (Backend::Cpu, String::new());
    let time = args.time;
    for k in 0..scene.surface.count {
        let one = scene.single_surface(k);
        let job = Job { scene: &one, grid: &grid, time, opts, budget: &budget };
        let (mesh, on, reason) = match backend {
            Backend::Cpu => (extract_cpu(&job)?, Backend::Cpu, String::new()),
            Backend::Gpu => {
                let (mesh, ran_on) = extract_gpu(cli, vulkan_device.clone(), &job)?;
                (mesh, ran_on, String::new())
            }
            Backend::Auto => {
                let device = (vulkan_device.clone(), cpu_device.as_deref());
                extract_auto(cli, device, &job)?
            }
        };
        let mut mesh = mesh;
        mesh.place(&scene.field.placement);
        if scene.clip.count > 0 {
            mesh = mesh.clipped(&scene.clip);
        }
        meshes.push(mesh);
        (ran_on, why) = (on, reason);
    }
    let what = Summary { scene: &scene, ran_on, why, started, samples: Some(&grid) };
    write_meshes(args, format, meshes, what)
}

/// What the summary line says besides the mesh's size.
struct Summary<'a> {
    scene: &'a Scene,
    ran_on: Backend,
    /// Appended to where it ran ("; auto: ...").
    why: String,
    started: Instant,
    /// The samples, whose range the note on an empty mesh gives (None: not at hand). Taken
    /// only then: a pass over every sample (256³: tens of ms) for a line rarely printed.
    samples: Option<&'a Grid>,
}

/// Merges the meshes of the surfaces (labelling each vertex with its surface when there are
/// several), writes the file atomically, prints the statistics and the summary line.
fn write_meshes(
    args: &ExtractArgs,
    format: Format,
    mut meshes: Vec<Mesh>,
    what: Summary,
) -> Result<i32, Failure> {
    let Summary { scene, ran_on, why, started, samples } = what;
    let (mesh, labels) = match meshes.len() {
        1 => (meshes.pop().expect("one mesh"), None),
        _ => {
            let (merged, labels) = mesh::merge(&meshes);
            (merged, Some(labels))
        }
    };
    let elapsed = started.elapsed().as_secs_f64() * 1e3;
    // Whole or not at all.
    atomic::write_with(&args.output, |w| {
        export::write_labelled(&mesh, labels.as_deref(), format, w)
    })
    .map_err(Failure::input)?;

    if args.stats {
        say!("{}", stats::compute(&mesh))?;
    }
    let what = Summary { scene, ran_on, why, started, samples };
    report(args, what, (mesh.vertex_count(), mesh.triangle_count()), elapsed);
    Ok(0)
}

/// The summary line on stderr (and the note on an empty mesh) for a mesh of `size` vertices
/// and triangles extracted in `elapsed` ms.
fn report(args: &ExtractArgs, what: Summary, size: (usize, usize), elapsed: f64) {
    let Summary { scene, ran_on, why, samples, .. } = what;
    note!(
        "{} vertices, {} triangles ({} on {}{why}) in {elapsed:.0} ms -> {}",
        size.0,
        size.1,
        scene.render.mesh.name(),
        ran_on.name(),
        args.output.display()
    );
    if let (0, Some((lo, hi))) = (size.1, samples.map(Grid::range)) {
        note!(
            "note: the mesh is empty: no grid edge crosses isovalue {} (samples span \
             [{lo}, {hi}])",
            scene.surface.isovalue
        );
    }
}

/// Where the CPU extraction writes its file piece by piece ([`extract_streamed`]): a PLY of one
/// surface, unclipped, by a method cut into slabs other than mc33 (`mesh::not_streamed`),
/// extracted on the CPU as settled before any Vulkan device is opened. Some(the summary line's
/// reason) when it does.
fn streamed_on_cpu(
    format: Format,
    scene: &Scene,
    backend: Backend,
    opts: ExtractOptions,
    probed_cpu: Option<&str>,
) -> Option<String> {
    let x = extraction(scene, 0, opts, None);
    let one_piece_at_a_time = format == Format::Ply
        && scene.surface.count == 1
        && scene.clip.count == 0
        && mesh::not_streamed(&x).is_none();
    match backend {
        _ if !one_piece_at_a_time => None,
        Backend::Cpu => Some(String::new()),
        Backend::Auto => settled_on_cpu(opts, probed_cpu),
        Backend::Gpu => None,
    }
}

/// How [`extract_streamed`] failed.
enum Streamed {
    Mesh(mesh::MeshError),
    Write(std::io::Error),
}

impl From<mesh::MeshError> for Streamed {
    fn from(e: mesh::MeshError) -> Self {
        Streamed::Mesh(e)
    }
}

/// One surface into a PLY on the CPU, piece by piece (`mesh::extract_streamed`: a slab of cell
/// layers per thread at a time): each piece placed and its records written to two scratch
/// files beside the output (`atomic::scratch`), then the file written whole from them, with
/// the exact counts in its header (`export::PlyPieces`). The bytes of the joined mesh's file;
/// memory for a few slabs' meshes, not the mesh's. `--stats` keeps the positions (counted into
/// `budget`) and the triangles in a third scratch file, read again for each pass of the edge
/// count (`stats::compute_from`): the same statistics, without the mesh held.
fn extract_streamed(
    args: &ExtractArgs,
    scene: &Scene,
    grid: &Grid,
    opts: ExtractOptions,
    budget: &MeshBudget,
    (why, started): (String, Instant),
) -> Result<i32, Failure> {
    let source = crate::field::PointField::from_spec(&scene.field, args.time);
    let x = extraction(scene, 0, opts, source.as_ref());
    let (vertices, vertices_read) = atomic::scratch(&args.output).map_err(Failure::input)?;
    let (faces, faces_read) = atomic::scratch(&args.output).map_err(Failure::input)?;
    let mut pieces = export::PlyPieces::new(vertices, faces);
    let mut kept = match args.stats {
        true => {
            let (write, read) = atomic::scratch(&args.output).map_err(Failure::input)?;
            Some((Vec::new(), std::io::BufWriter::new(write), read))
        }
        false => None,
    };
    let placement = &scene.field.placement;
    let written = mesh::extract_streamed(grid, &x, |mut piece: Mesh| {
        piece.place(placement);
        pieces.push(&piece).map_err(Streamed::Write)?;
        if let Some((positions, triangles, _)) = kept.as_mut() {
            budget.add_positions(piece.vertex_count(), piece.triangle_count())?;
            positions.extend_from_slice(&piece.positions);
            stats::write_triangles(triangles, &piece.indices).map_err(Streamed::Write)?;
        }
        Ok(())
    });
    match written {
        Ok(()) => {}
        Err(Streamed::Mesh(e)) => {
            return Err(Failure::input(format!("{}: {e}", scene_name(scene))));
        }
        Err(Streamed::Write(e)) => {
            return Err(Failure::input(crate::output::OutputError::io(&args.output, "write", e)));
        }
    }
    let (nv, _, nt) = pieces.counts();
    let elapsed = started.elapsed().as_secs_f64() * 1e3;
    atomic::write_with(&args.output, |w| pieces.finish(w, vertices_read, faces_read))
        .map_err(Failure::input)?;
    if let Some((positions, triangles, read)) = kept {
        let read_error =
            |e| Failure::input(crate::output::OutputError::io(&args.output, "read", e));
        triangles.into_inner().map_err(|e| read_error(e.into_error()))?;
        let mut triangles = stats::TriangleFile(read);
        let pass = stats::pass_size(3 * nt);
        let s = stats::compute_from(&positions, &mut triangles, pass).map_err(read_error)?;
        say!("{s}")?;
    }
    let what = Summary { scene, ran_on: Backend::Cpu, why, started, samples: Some(grid) };
    report(args, what, (nv, nt), elapsed);
    Ok(0)
}

/// `field.residency = "active"`: every surface extracted on the CPU from the memory-mapped
/// file, a window of point layers at a time (`mesh::mapped`), the mesh the whole grid's.
fn extract_mapped(
    args: &ExtractArgs,
    format: Format,
    scene: &Scene,
    grid: &MappedGrid,
    opts: ExtractOptions,
    started: Instant,
    budget: &Arc<MeshBudget>,
) -> Result<i32, Failure> {
    let mut meshes = Vec::with_capacity(scene.surface.count);
    for k in 0..scene.surface.count {
        let x = extraction(scene, k, opts, None);
        let window = mesh::mapped::WINDOW_BYTES;
        let mut mesh = mesh::mapped::extract_mapped_within(grid, &x, window, budget)
            .map_err(|e| Failure::input(format!("{}: {e}", scene_name(scene))))?;
        mesh.place(&scene.field.placement);
        if scene.clip.count > 0 {
            mesh = mesh.clipped(&scene.clip);
        }
        meshes.push(mesh);
    }
    let why = format!(
        "; field.residency: streamed from the {}x{}x{} memory-mapped file",
        grid.dims[0], grid.dims[1], grid.dims[2]
    );
    let what = Summary { scene, ran_on: Backend::Cpu, why, started, samples: None };
    write_meshes(args, format, meshes, what)
}

/// What an extraction under MPI writes, and how.
struct Split<'a> {
    args: &'a ExtractArgs,
    format: Format,
    scene: &'a Scene,
    opts: ExtractOptions,
    started: Instant,
    budget: &'a Arc<MeshBudget>,
}

/// Under MPI: every rank meshes its share of every surface from the point layers it reads
/// (`cluster::mesh`), rank 0 joins the shares and writes the file.
fn extract_ranks(w: &Ranks, grid: Points, how: Split) -> Result<i32, Failure> {
    let Split { args, format, scene, opts, started, budget } = how;
    let read = started.elapsed();
    let source = crate::field::PointField::from_spec(&scene.field, args.time);
    let mut meshes = Vec::with_capacity(scene.surface.count);
    let (mut own_share, mut gathered) = (std::time::Duration::ZERO, std::time::Duration::ZERO);
    for k in 0..scene.surface.count {
        let x = extraction(scene, k, opts, source.as_ref());
        let done = w
            .extract(grid, &x, budget)
            .map_err(|e| Failure::input(format!("{}: {e}", scene_name(scene))))?;
        match done {
            Extracted::Whole(mesh, own, joined) => {
                let mut mesh = *mesh;
                mesh.place(&scene.field.placement);
                if scene.clip.count > 0 {
                    mesh = mesh.clipped(&scene.clip);
                }
                meshes.push(mesh);
                own_share += own;
                gathered += joined;
            }
            Extracted::Sent => {}
            Extracted::FailedElsewhere => return Ok(super::EXIT_INPUT),
        }
    }
    if !w.is_root() {
        return Ok(0); // rank 0 writes
    }
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    let reading = match grid {
        Points::Mapped(_) => "each rank reads its layers of the mapped file",
        Points::Sampled(_) => "each rank samples the whole field",
    };
    let why = format!(
        "; mpi: {} ranks, {reading}; rank 0 read or sampled in {:.0} ms, meshed its share in \
         {:.0} ms, gathered and joined in {:.0} ms",
        w.size(),
        ms(read),
        ms(own_share),
        ms(gathered)
    );
    let what = Summary { scene, ran_on: Backend::Cpu, why, started, samples: None };
    write_meshes(args, format, meshes, what)
}

/// Surface `k` of `scene` as the window extraction takes it.
fn extraction<'a>(
    scene: &'a Scene,
    k: usize,
    opts: ExtractOptions,
    source: Option<&'a crate::field::PointField<'a>>,
) -> mesh::window::Extraction<'a> {
    let s = scene.single_surface(k).surface;
    mesh::window::Extraction {
        iso: s.isovalue,
        inside: s.inside,
        algo: scene.render.mesh,
        opts,
        sharp: &scene.render.sharp,
        source,
    }
}

/// One surface's extraction: the scene (with that surface only), its samples at `time`, and
/// the count of the mesh held so far, which refuses a mesh past the cap.
pub struct Job<'a> {
    pub scene: &'a Scene,
    pub grid: &'a Grid,
    pub time: f64,
    pub opts: ExtractOptions,
    pub budget: &'a MeshBudget,
}

/// The CPU extraction on all cores: the f64 reference's mesh, bit for bit, each slab counted
/// into the budget as it is done.
pub fn extract_cpu(job: &Job) -> Result<Mesh, Failure> {
    let Job { scene, grid, time, opts, budget } = *job;
    let s = &scene.surface;
    let source = crate::field::PointField::from_spec(&scene.field, time);
    let (algo, sharp) = (scene.render.mesh, &scene.render.sharp);
    let x = mesh::window::Extraction {
        iso: s.isovalue,
        inside: s.inside,
        algo,
        opts,
        sharp,
        source: source.as_ref(),
    };
    mesh::extract_budgeted(grid, &x, budget)
        .map_err(|e| Failure::input(format!("{}: {e}", scene_name(scene))))
}

/// `--device auto`: the CPU extraction when the Vulkan device is a CPU (lavapipe) or there is
/// none, else the GPU's; returns the mesh, where it ran and the reason, worded for the summary
/// line. `device` is the Vulkan device wanted and what [`probe_cpu_device`] said of it (the
/// CPU device's name; None: not a CPU, or not known). When the probe did not settle it, knowing
/// the device type costs opening the device (instance, device and allocator: tens of
/// milliseconds on lavapipe), which the GPU path needs anyway.
fn extract_auto(
    cli: &Cli,
    device: (Option<String>, Option<&str>),
    job: &Job,
) -> Result<(Mesh, Backend, String), Failure> {
    let (vulkan_device, probed_cpu) = device;
    // The cheap probe first: a CPU device needs no device opened.
    if let Some(why) = settled_on_cpu(job.opts, probed_cpu) {
        return Ok((extract_cpu(job)?, Backend::Cpu, why));
    }
    let ctx = match open_context(cli, vulkan_device) {
        Ok(ctx) => ctx,
        Err(e) => {
            let why = format!("; auto: no usable Vulkan device ({e})");
            return Ok((extract_cpu(job)?, Backend::Cpu, why));
        }
    };
    // `DeviceInfo::device_type` is the gpu crate's wording of `vk::PhysicalDeviceType::CPU`.
    if ctx.info.device_type.starts_with("CPU") {
        let why = format!("; auto: the Vulkan device {} is a CPU", ctx.info.name);
        drop(ctx);
        return Ok((extract_cpu(job)?, Backend::Cpu, why));
    }
    let why = format!("; auto: the Vulkan device {} is a {}", ctx.info.name, ctx.info.device_type);
    let (mesh, ran_on) = extract_on(ctx, job)?;
    Ok((mesh, ran_on, why))
}

/// `--device auto`: the reason to extract on the CPU when it is settled without opening a
/// Vulkan device (`--quads`, or the probe found the device to be a CPU), worded for the
/// summary line; None when the device must be opened to know.
fn settled_on_cpu(opts: ExtractOptions, probed_cpu: Option<&str>) -> Option<String> {
    if opts.keep_quads {
        return Some("; auto: --quads needs the CPU extraction".to_string());
    }
    probed_cpu.map(|name| format!("; auto: the Vulkan device {name} is a CPU"))
}

/// The name of the Vulkan device that `gpu::Context::new` would pick for `wanted` (the first
/// whose name contains it, case-insensitively, else the best-ranked type: discrete, integrated,
/// virtual, CPU) if that device's type is CPU; None otherwise or when Vulkan cannot say. Costs
/// one instance and no device (a few tens of ms on lavapipe; opening the device costs 150–300 ms);
/// the context's own device type is checked again when this says no.
//
// A stopgap in the CLI: this belongs in the gpu crate beside `Context::new`'s selection.
fn probe_cpu_device(wanted: Option<&str>) -> Option<String> {
    use ash::vk;
    // SAFETY: loading the system's libvulkan, as `gpu::Context::new` does.
    let entry = unsafe { ash::Entry::load() }.ok()?;
    let app = vk::ApplicationInfo::default()
        .application_name(c"isoview")
        .api_version(vk::API_VERSION_1_2);
    let create = vk::InstanceCreateInfo::default().application_info(&app);
    // SAFETY: the create info and the strings it points to outlive the call.
    let instance = unsafe { entry.create_instance(&create, None) }.ok()?;
    // SAFETY: a valid instance; its physical devices live as long as it does.
    let devices = unsafe { instance.enumerate_physical_devices() }.unwrap_or_default();
    let props: Vec<vk::PhysicalDeviceProperties> = devices
        .iter()
        // SAFETY: `pd` comes from this instance.
        .map(|&pd| unsafe { instance.get_physical_device_properties(pd) })
        .collect();
    // SAFETY: nothing created from the instance outlives it.
    unsafe { instance.destroy_instance(None) };
    let name = |p: &vk::PhysicalDeviceProperties| {
        p.device_name_as_c_str().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
    };
    let rank = |t: vk::PhysicalDeviceType| match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    };
    let chosen = match wanted {
        Some(w) => {
            let w = w.to_lowercase();
            props.iter().find(|p| name(p).to_lowercase().contains(&w))
        }
        None => props.iter().min_by_key(|p| rank(p.device_type)),
    }?;
    (chosen.device_type == vk::PhysicalDeviceType::CPU).then(|| name(chosen))
}

/// Opens the Vulkan device `vulkan_device` (None: isoview's pick).
fn open_context(
    cli: &Cli,
    vulkan_device: Option<String>,
) -> Result<std::sync::Arc<crate::gpu::Context>, crate::gpu::GpuError> {
    cli.open_gpu(vulkan_device)
}

/// The GPU extraction (compute passes of [`passes::extract`]) on the Vulkan device `vulkan_device`,
/// read back into a [`Mesh`], and where it ran. `opts.split` is honoured; `opts.keep_quads`
/// needs the CPU quads, so `--quads` extracts on the CPU, with a note on stderr, as does `mc33`
/// on a device without `shaderFloat64`.
fn extract_gpu(
    cli: &Cli,
    vulkan_device: Option<String>,
    job: &Job,
) -> Result<(Mesh, Backend), Failure> {
    if job.opts.keep_quads {
        note!("note: --quads extracts on the CPU (the GPU extraction has no quads)");
        return Ok((extract_cpu(job)?, Backend::Cpu));
    }
    extract_on(open_context(cli, vulkan_device)?, job)
}

/// The GPU extraction on `ctx` (see [`extract_gpu`]); `opts.keep_quads` must be false. The
/// mesh's counts go into the budget before it is read back.
fn extract_on(ctx: Arc<crate::gpu::Context>, job: &Job) -> Result<(Mesh, Backend), Failure> {
    let Job { scene, grid, opts, budget, .. } = *job;
    if !scene.render.mesh.on_gpu(&scene.render.sharp) {
        note!(
            "note: {} is extracted on the CPU (no GPU extraction passes for it{})",
            scene.render.mesh.name(),
            if scene.render.mesh == crate::scene::MeshAlgorithm::DualContouringQef {
                " with hermite = \"source\" or mesh_error"
            } else {
                ""
            }
        );
        return Ok((extract_cpu(job)?, Backend::Cpu));
    }
    if scene.render.mesh == crate::scene::MeshAlgorithm::Mc33 && !ctx.info.float64 {
        note!(
            "note: mc33 is extracted on the CPU ({} has no 64-bit floats, which the \
             GPU mc33 passes need)",
            ctx.info.name
        );
        return Ok((extract_cpu(job)?, Backend::Cpu));
    }
    // The GPU passes read the grid as one 3D image: over the device's extent the CPU extracts
    // it instead (as for mc33 above), rather than a GPU failure (exit 3) naming no key.
    if let Err(e) = scene.field.check_image_extent(ctx.info.max_image_dimension_3d) {
        note!("note: extracted on the CPU ({e})");
        return Ok((extract_cpu(job)?, Backend::Cpu));
    }
    let image =
        crate::gpu::Image3d::upload(&ctx, "grid", grid.dims.map(|d| d as u32), &grid.values)?;
    let gpu_opts = crate::passes::extract::GpuExtractOptions {
        split: opts.split,
        sharp: Some(scene.render.sharp),
        ..Default::default()
    };
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
    let counts = (gpu_mesh.vertex_count as usize, gpu_mesh.triangle_count as usize);
    budget
        .add(counts.0, counts.1, 0)
        .map_err(|e| Failure::input(format!("{}: {e}", scene_name(scene))))?;
    Ok((gpu_mesh.read()?, Backend::Gpu))
}

fn scene_name(scene: &Scene) -> String {
    scene.path.as_ref().map_or_else(|| "scene".to_string(), |p| p.display().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_words_choose_the_backend_and_other_values_name_the_vulkan_device() {
        assert_eq!(resolve_device(None, false, None), (Backend::Auto, None));
        assert_eq!(
            resolve_device(None, false, Some("llvmpipe")),
            (Backend::Auto, Some("llvmpipe".into()))
        );
        assert_eq!(resolve_device(Some("Auto"), true, None), (Backend::Auto, None));
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
