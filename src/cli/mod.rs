//! The `isoview` command line (the contract in README.md "Command line"). `main.rs` only calls
//! [`main`]; each subcommand parses its arguments here and returns an exit code:
//! 0 success, 1 `compare` found a difference, 2 bad input, 3 no usable Vulkan device or a GPU
//! failure. Errors are one line on stderr, never a panic.

pub mod compare;
pub mod console;
pub mod extract;
pub mod interrupt;
pub mod probe;
pub mod render;
pub mod serve;
pub mod slice;
pub mod stats;

use std::sync::Arc;

use clap::parser::ValueSource;
use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

use crate::gpu::{Context, ContextOptions, GpuError};
use console::{note, say};

/// Exit status for bad input (arguments, scene, data file).
pub const EXIT_INPUT: i32 = 2;
/// Exit status for a missing Vulkan device or a GPU failure.
pub const EXIT_GPU: i32 = 3;

/// A failure with its exit status and one-line message.
#[derive(Debug)]
pub struct Failure {
    pub code: i32,
    pub message: String,
}

impl Failure {
    pub fn input(message: impl std::fmt::Display) -> Self {
        Failure { code: EXIT_INPUT, message: message.to_string() }
    }
    pub fn gpu(message: impl std::fmt::Display) -> Self {
        Failure { code: EXIT_GPU, message: message.to_string() }
    }
    /// Not a failure: stdout's reader has gone, so the verb stops quietly with exit status 0
    /// (see [`console`]). It travels as a `Failure` so that `?` ends the verb where it prints.
    pub fn stopped() -> Self {
        Failure { code: 0, message: String::new() }
    }

    /// Prints the one line on stderr (nothing for [`Failure::stopped`]); returns the exit
    /// status.
    fn report(&self) -> i32 {
        if !self.message.is_empty() {
            note!("{}", self.message);
        }
        self.code
    }
}

impl From<GpuError> for Failure {
    fn from(e: GpuError) -> Self {
        Failure::gpu(e)
    }
}

#[derive(Parser, Debug)]
#[command(
    name = "isoview",
    version,
    about = "Isosurfaces of trilinearly interpolated scalar fields, rendered with Vulkan compute"
)]
pub struct Cli {
    /// Vulkan device to use: a case-insensitive part of its name (default: a discrete GPU, else
    /// an integrated one, else lavapipe). Also read from ISOVIEW_DEVICE. For `extract`,
    /// `--device auto|gpu|cpu` chooses where the extraction runs (auto, the default: on the CPU
    /// when the Vulkan device is a CPU such as lavapipe; the Vulkan device then comes from
    /// ISOVIEW_DEVICE); any other value names the Vulkan device.
    #[arg(long, global = true, env = "ISOVIEW_DEVICE")]
    pub device: Option<String>,
    /// Whether `device` was written on the command line (not read from ISOVIEW_DEVICE).
    #[arg(skip)]
    pub device_from_command_line: bool,
    /// Enable the Vulkan validation layer and print its warnings and errors.
    #[arg(long, global = true)]
    pub validation: bool,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a scene to a float EXR with AOVs (and optionally a PNG preview).
    Render(render::RenderArgs),
    /// Extract the isosurface as a mesh (.ply, .obj, .stl) with `render.mesh`'s algorithm.
    /// `--device auto|gpu|cpu` picks where it runs (auto: the CPU when the Vulkan device is one);
    /// the Vulkan device then comes from ISOVIEW_DEVICE.
    Extract(extract::ExtractArgs),
    /// Compare two float EXRs channel by channel (exit 1 on a difference over the thresholds).
    Compare(compare::CompareArgs),
    /// Print what the ray through one pixel meets: cells, cubics, roots, Newton iterates, and
    /// where fixed-step finds its crossing.
    Probe(probe::ProbeArgs),
    /// The field on an axis-aligned plane (EXR, PNG) and its contours by marching squares
    /// (JSON, SVG).
    Slice(slice::SliceArgs),
    /// Serve a live view of the scene as a web page on this machine (prints its URL first):
    /// sliders for every key, probe and slice panels, progressive rendering, tev push.
    Serve(serve::ServeArgs),
    /// Print what the field holds: dims, sample type, spacing, box, range, mean, sigma,
    /// percentiles and a histogram (to pick an isovalue).
    Stats(stats::StatsArgs),
    /// Print the Vulkan device, driver and the limits isoview relies on.
    Info,
}

impl Cli {
    pub fn gpu(&self) -> Result<Arc<Context>, Failure> {
        Ok(self.open_gpu(self.device.clone())?)
    }

    /// Opens the Vulkan device whose name contains `device` (None: isoview's pick).
    pub fn open_gpu(&self, device: Option<String>) -> Result<Arc<Context>, GpuError> {
        Context::new(&ContextOptions { device, validation: self.validation }).map_err(cut_device)
    }
}

/// A GPU error as the command line prints it: the name asked for (--device, ISOVIEW_DEVICE) is
/// the user's value, cut as every message cuts one (the error's `{:?}` escapes it); matching
/// used it whole. Every verb's device errors pass here, `extract`'s from the library included.
pub(crate) fn cut_device(e: GpuError) -> GpuError {
    match e {
        GpuError::DeviceNotFound { wanted, available } => {
            GpuError::DeviceNotFound { wanted: crate::vocab::echo_cut(&wanted).into(), available }
        }
        e => e,
    }
}

/// Runs the command line and returns the process exit status.
pub fn main() -> i32 {
    interrupt::install();
    // clap's `get_matches` would print help and errors itself and exit, ignoring a failed
    // write; console::print_clap prints them under the verbs' rules.
    let matches = match Cli::command().try_get_matches() {
        Ok(m) => m,
        Err(e) => return console::print_clap(e),
    };
    let mut cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => return console::print_clap(e),
    };
    cli.device_from_command_line = matches.value_source("device") == Some(ValueSource::CommandLine);
    let result = match &cli.command {
        Command::Render(args) => render::run(&cli, args),
        Command::Extract(args) => extract::run(&cli, args),
        Command::Compare(args) => Ok(compare::run_with(
            args,
            &mut std::io::stdout().lock(),
            &mut std::io::stderr().lock(),
        )),
        Command::Probe(args) => probe::run(&cli, args),
        Command::Slice(args) => slice::run(&cli, args),
        Command::Serve(args) => serve::run(&cli, args),
        Command::Stats(args) => stats::run(args),
        Command::Info => info(&cli),
    };
    match result {
        Ok(code) => code,
        Err(f) => f.report(),
    }
}

/// A failure that every rank meets alike (a scene's setting, an output name: the same on every
/// rank). One process: the failure, returned as usual. Under MPI rank 0 reports it once, then
/// every rank waits for it before returning the exit code: without the wait a rank exiting
/// first makes mpirun end the job, which can cut rank 0 before its line is out.
fn refuse_on_ranks(ranks: &crate::cluster::Ranks, f: Failure) -> Result<i32, Failure> {
    if ranks.is_single() {
        return Err(f);
    }
    let code = if ranks.is_root() { f.report() } else { f.code };
    ranks.barrier();
    Ok(code)
}

/// A failure that this rank meets alone (its block of the file, its part of the render) while
/// the other ranks wait in a collective: under MPI this rank says it, with its number, and
/// ends every rank with its code. One process: the failure, to return as usual.
fn failed_alone(ranks: &crate::cluster::Ranks, f: Failure) -> Failure {
    if !ranks.is_single() {
        note!("rank {}: {}", ranks.rank(), f.message);
        ranks.abort(f.code);
    }
    f
}

/// `FLAG V: must be a finite number` for a number flag (`--time`, `--at`) that is not finite:
/// the one check every verb that takes one runs before any work.
pub fn finite(flag: &str, v: f64) -> Result<(), Failure> {
    if v.is_finite() {
        return Ok(());
    }
    Err(Failure::input(format!("{flag} {}: must be a finite number", crate::vocab::echo_number(v))))
}

/// clap's parser of a number flag (`--time`, `--at`, `--fps`): Rust reads digits past
/// f64's range (`1e400`, 400 nines) as infinity, so such a value is refused here as too
/// large, where clap quotes the text the user gave (cut, through `echo_clap_values`);
/// otherwise the flag's own check would call it `inf`. Infinity and NaN spelled out pass,
/// for that check to refuse in its own words.
pub fn number(s: &str) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|_| "not a number".to_string())?;
    let spelled = s.trim().trim_start_matches(['+', '-']).to_ascii_lowercase();
    if v.is_infinite() && !matches!(spelled.as_str(), "inf" | "infinity") {
        return Err("too large: numbers go from about -1.8e308 to 1.8e308".to_string());
    }
    // A nonzero number too small for f64 reads as 0, which a flag's own check would then
    // report as "0" although the user typed something else (`--fps 1e-400`).
    let mantissa = spelled.split('e').next().unwrap_or("");
    if v == 0.0 && mantissa.bytes().any(|b| (b'1'..=b'9').contains(&b)) {
        return Err("too close to 0: numbers other than 0 start at about 4.9e-324".to_string());
    }
    Ok(v)
}

/// Loads a scene for a verb; an isovalue picked from the data (`isovalue_sigma`,
/// `isovalue_percentile`) is said on stderr, once.
pub fn load_scene(path: &std::path::Path, sets: &[String]) -> Result<crate::scene::Scene, Failure> {
    let scene = crate::scene::load(path, sets).map_err(Failure::input)?;
    if let Some(how) = scene.surface.rule.describe(scene.surface.isovalue) {
        note!("{how}");
    }
    Ok(scene)
}

/// Refuses `scene` for a verb that reads its field as `reader` and does not take its
/// interpolant ([`crate::scene::Scene::interpolation_refusal`]), before any sample is read.
pub fn refuse_interpolation(
    scene: &crate::scene::Scene,
    reader: crate::field::interpolant::Reader,
) -> Result<(), Failure> {
    scene.interpolation_refusal(reader).map_or(Ok(()), |why| Err(Failure::input(why)))
}

/// The files a run over `scene` reads, with what each is: the scene file and its data files.
/// No output may be one of them ([`check_outputs`]).
pub fn scene_inputs(scene: &crate::scene::Scene) -> Vec<(&'static str, &std::path::Path)> {
    let mut inputs = Vec::new();
    if let Some(p) = &scene.path {
        inputs.push(("the scene file", p.as_path()));
    }
    for (spec, path, data) in [
        (Some(&scene.field), "the scene's field.path", "the data file of field.path's header"),
        (scene.field2.as_ref(), "the scene's field2.path", "the data file of field2.path's header"),
    ] {
        let Some(source) = spec.map(|f| &f.source) else { continue };
        if let Some(p) = source.data_path() {
            inputs.push((path, p));
        }
        // A detached header's samples are in another file, which the run reads as well.
        if let crate::field::FieldSource::File(f) = source {
            if let Some(p) = &f.volume.data_file {
                inputs.push((data, p.as_path()));
            }
        }
    }
    inputs
}

/// Refuses to write a run's `outputs` (each given as its flag and path) when one is one of
/// `scene`'s inputs, two are one file, or one is not a regular file (the rule:
/// [`crate::output::guard`]). A verb passes all of its outputs at once.
pub fn check_outputs(
    outputs: &[(&str, &std::path::Path)],
    scene: &crate::scene::Scene,
) -> Result<(), Failure> {
    crate::output::guard::check(outputs, &scene_inputs(scene)).map_err(Failure::input)
}

fn info(cli: &Cli) -> Result<i32, Failure> {
    let ctx = cli.gpu()?;
    let i = &ctx.info;
    let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
    say!("isoview {}", crate::VERSION)?;
    say!("device                 {} ({})", i.name, i.device_type)?;
    say!("driver                 {} {}", i.driver_name, i.driver_info)?;
    say!("Vulkan                 {}", i.api_version)?;
    say!("device-local memory    {:.0} MiB", mib(i.device_local_heap))?;
    say!("max allocation         {:.0} MiB", mib(i.max_memory_allocation_size))?;
    say!(
        "max storage buffer     {:.0} MiB (pixel buffers are split into bands below this)",
        mib(i.max_storage_buffer_range)
    )?;
    say!("max 3D image           {} per axis (largest grid)", i.max_image_dimension_3d)?;
    say!(
        "max workgroups         {:?}, {} invocations per group",
        i.max_compute_work_group_count,
        i.max_compute_work_group_invocations
    )?;
    say!("push constants         {} bytes", i.max_push_constants_size)?;
    say!(
        "timestamps             {}",
        if i.timestamps {
            format!("yes, {} ns per tick", i.timestamp_period_ns)
        } else {
            "no".into()
        }
    )?;
    say!(
        "64-bit buffer atomics  {}",
        if i.int64_atomics {
            "yes (render.method = \"mesh\" works)"
        } else {
            "no (no mesh render)"
        }
    )?;
    say!(
        "64-bit floats          {}",
        if i.float64 { "yes (mc33 extracts on the GPU)" } else { "no (mc33 extracts on the CPU)" }
    )?;
    say!(
        "linear filter of f32    {}, {} sub-texel bits",
        if i.r32f_linear_filter {
            "yes (field.interpolation = \"device\" works)"
        } else {
            "no (no field.interpolation = \"device\")"
        },
        i.sub_texel_precision_bits
    )?;
    say!("validation             {}", if cli.validation { "on" } else { "off" })?;
    Ok(0)
}
