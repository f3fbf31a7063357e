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
//! * `cpu`: the multi-threaded CPU extraction (`mesh::extract`, all cores, rayon), whose
//!   mesh is the f64 reference's (`mesh::reference`) bit for bit.
//! * `gpu`: the Vulkan compute passes (`passes::extract`) on the Vulkan device.
//! * `auto` (the default): opens the Vulkan device and extracts on the CPU when its type is CPU
//!   (lavapipe, where the compute passes are software on the same cores and slower than the
//!   CPU path), or when there is no usable Vulkan device; else on the GPU. The summary line on
//!   stderr says which and why.
//!
//! The library decides where (`isoview::extract`: once for every surface, one Vulkan context
//! and one upload of the grid); this file parses the arguments, builds the `extract::Job`,
//! prints the notes and the summary and writes the file.
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
use crate::extract::{self, scene_name, Device, ExtractError, Job, Probe};
use crate::field::mapped::MappedGrid;
use crate::field::Grid;
use crate::mesh::export::{self, Format};
use crate::mesh::stats;
use crate::mesh::{self, ExtractOptions, Mesh, MeshBudget, MeshLimits};
use crate::output::atomic;
use crate::scene::Scene;
use crate::vocab::echo_number;

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
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = super::number)]
    pub time: f64,
    /// Write the quads of surface-nets and dual-contouring instead of their triangles (PLY and
    /// OBJ; STL holds triangles only).
    #[arg(long)]
    pub quads: bool,
}

/// Splits the global `--device` value into where the extraction runs and the Vulkan device
/// name.
///
/// `device` is the parsed value, `from_command_line` whether it was written on the command line
/// (rather than read from `ISOVIEW_DEVICE`), `env` the value of `ISOVIEW_DEVICE`.
pub fn resolve_device(
    device: Option<&str>,
    from_command_line: bool,
    env: Option<&str>,
) -> (Device, Option<String>) {
    let env = env.filter(|e| !e.trim().is_empty()).map(str::to_string);
    match device {
        Some(d) if from_command_line && d.eq_ignore_ascii_case("cpu") => (Device::Cpu, env),
        Some(d) if from_command_line && d.eq_ignore_ascii_case("gpu") => (Device::Gpu, env),
        Some(d) if from_command_line && d.eq_ignore_ascii_case("auto") => (Device::Auto, env),
        Some(d) => (Device::Gpu, Some(d.to_string())),
        None => (Device::Auto, env),
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
    let (device, vulkan_device) =
        resolve_device(cli.device.as_deref(), cli.device_from_command_line, env.as_deref());
    let scene = super::load_scene(&args.scene, &args.sets)?;
    super::check_outputs(&[("-o", &args.output)], &scene)?;
    let interp = scene.interpolation_refusal(crate::field::interpolant::Reader::Mesh);
    if let Some(why) = interp.or_else(|| ranks.refuses_extract(&scene, device == Device::Gpu)) {
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
    if let Some(parts) =
        crate::field::parts::for_residency(&scene.field, &limits).map_err(Failure::input)?
    {
        // A sparse tree streams trilinear cells at mesh_refine = 1 by the methods extracted in
        // z-ranges; other meshes of it need the lattice whole, so its box is densified under
        // the cap (below).
        let x = scene.mesh_request(0, None);
        let streams = !crate::field::parts::is_sparse(&scene.field)
            || (x.on_grid() && mesh::window::not_in_slabs(x.algo, &x.sharp).is_none());
        if streams {
            return extract_mapped(args, format, &scene, &*parts, opts, started, &budget);
        }
    }
    let job = Job {
        scene: &scene,
        time: args.time,
        device,
        vulkan: crate::gpu::ContextOptions { device: vulkan_device, validation: cli.validation },
        opts,
        budget: &budget,
    };
    // `--device auto` asks Vulkan whether its device is a CPU on its own thread while the
    // field is read or sampled.
    let probe = Probe::start(&job);
    let grid = scene.field.sample(args.time).map_err(Failure::input)?;
    let cpu_device = probe.cpu_device();
    if let Some(why) = extract::streams_on_cpu(&job, format == Format::Ply, cpu_device.as_deref()) {
        return extract_streamed(args, &scene, &grid, opts, &budget, (why, started));
    }
    // Several isovalues: one mesh per surface, merged, each vertex labelled with its surface.
    let done = extract::surfaces(&job, &grid, cpu_device.as_deref()).map_err(|e| match e {
        ExtractError::Input(m) => Failure::input(m),
        ExtractError::Gpu(g) => Failure::gpu(super::cut_device(g)),
    })?;
    for n in &done.notes {
        note!("{n}");
    }
    let what = Summary {
        scene: &scene,
        ran_on: done.ran_on,
        why: done.why,
        started,
        samples: Some(&grid),
    };
    write_meshes(args, format, done.meshes, what)
}

/// What the summary line says besides the mesh's size.
struct Summary<'a> {
    scene: &'a Scene,
    ran_on: Device,
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
        // Short numbers: samples of 3e38 printed as 39 digits.
        let (v, lo, hi) = (echo_number(scene.surface.isovalue), echo_number(lo), echo_number(hi));
        note!("note: the mesh is empty: no grid edge crosses isovalue {v} (samples span [{lo}, {hi}])");
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
    let x = scene.mesh_request(0, source.as_ref()).with_opts(opts);
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
    let what = Summary { scene, ran_on: Device::Cpu, why, started, samples: Some(grid) };
    report(args, what, (nv, nt), elapsed);
    Ok(0)
}

/// A grid read in parts (`field.residency = "active"`, a sparse `.vdb`/`.nvdb` tree): every
/// surface extracted on the CPU, a window of point layers at a time (`mesh::mapped`), the
/// mesh the whole grid's.
fn extract_mapped(
    args: &ExtractArgs,
    format: Format,
    scene: &Scene,
    grid: &dyn crate::field::parts::Parts,
    opts: ExtractOptions,
    started: Instant,
    budget: &Arc<MeshBudget>,
) -> Result<i32, Failure> {
    let mut meshes = Vec::with_capacity(scene.surface.count);
    for k in 0..scene.surface.count {
        let x = scene.mesh_request(k, None).with_opts(opts);
        let window = mesh::mapped::WINDOW_BYTES;
        let mesh = mesh::mapped::extract_mapped_within(grid, &x, window, budget)
            .map_err(|e| Failure::input(format!("{}: {e}", scene_name(scene))))?;
        meshes.push(mesh.in_world(&scene.field.placement, &scene.clip));
    }
    let [nx, ny, nz] = grid.dims();
    let why = format!("; streamed from the {nx}x{ny}x{nz} grid {}", grid.how());
    let what = Summary { scene, ran_on: Device::Cpu, why, started, samples: None };
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
        let x = scene.mesh_request(k, source.as_ref()).with_opts(opts);
        let done = w
            .extract(grid, &x, budget)
            .map_err(|e| Failure::input(format!("{}: {e}", scene_name(scene))))?;
        match done {
            Extracted::Whole(mesh, own, joined) => {
                meshes.push(mesh.in_world(&scene.field.placement, &scene.clip));
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
    let what = Summary { scene, ran_on: Device::Cpu, why, started, samples: None };
    write_meshes(args, format, meshes, what)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_words_choose_where_it_runs_and_other_values_name_the_vulkan_device() {
        assert_eq!(resolve_device(None, false, None), (Device::Auto, None));
        assert_eq!(
            resolve_device(None, false, Some("llvmpipe")),
            (Device::Auto, Some("llvmpipe".into()))
        );
        assert_eq!(resolve_device(Some("Auto"), true, None), (Device::Auto, None));
        assert_eq!(resolve_device(Some("cpu"), true, None), (Device::Cpu, None));
        assert_eq!(
            resolve_device(Some("GPU"), true, Some("llvmpipe")),
            (Device::Gpu, Some("llvmpipe".into()))
        );
        assert_eq!(
            resolve_device(Some("llvmpipe"), true, None),
            (Device::Gpu, Some("llvmpipe".into()))
        );
        // From ISOVIEW_DEVICE, a value is always a Vulkan device name.
        assert_eq!(
            resolve_device(Some("cpu"), false, Some("cpu")),
            (Device::Gpu, Some("cpu".into()))
        );
    }
}
