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
    let (command, args) = number_values(Cli::command(), std::env::args_os());
    let matches = match command.try_get_matches_from(args) {
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

/// The command and the words of a command line, with isoview's rule for the values of
/// number flags in place of clap's.
///
/// `allow_hyphen_values` on a verb's argument marks a number flag (`--time`, `--at`, `--fps`,
/// `--pixel`, `--frames`, compare's thresholds, ...): its value may be negative. Under clap's
/// own rule such a flag takes whatever word follows it, so a flag given no value took the
/// next flag as its value (`--time --set x=1` set the time to "--set" and named `x=1` as
/// unexpected). isoview's rule: the word after a number flag is its value when it is a
/// negative number, a '-' followed by a digit or '.' (`-1`, `-1e-3`, `-.5`, `-1,5`, `-3..0`)
/// or a word Rust reads as a float (`-inf`, `-NaN`, for the flags' own checks to refuse);
/// any other word starting with '-' is a flag (`--time --set x=1`: "a value is required for
/// '--time'"). Such a value is joined to its flag (`--time=-1e-3`, which clap takes as it
/// is) and clap's rule is turned off. Words after `--` are left as they are.
pub fn number_values(
    command: clap::Command,
    args: impl IntoIterator<Item = std::ffi::OsString>,
) -> (clap::Command, Vec<std::ffi::OsString>) {
    let mut flags = std::collections::HashSet::new();
    for verb in command.get_subcommands() {
        for arg in verb.get_arguments().filter(|a| a.is_allow_hyphen_values_set()) {
            flags.extend(arg.get_long().map(|l| format!("--{l}")));
            flags.extend(arg.get_short().map(|c| format!("-{c}")));
        }
    }
    let command = command.mut_subcommands(|verb| verb.mut_args(|a| a.allow_hyphen_values(false)));
    let negative = |word: &str| {
        let rest = word.strip_prefix('-').unwrap_or("");
        let starts_a_number = rest.starts_with(|c: char| c.is_ascii_digit() || c == '.');
        !rest.is_empty() && (starts_a_number || word.parse::<f64>().is_ok())
    };
    let mut words = args.into_iter().peekable();
    let mut out = Vec::new();
    while let Some(mut word) = words.next() {
        if word == "--" {
            out.push(word);
            out.extend(words);
            break;
        }
        let number_flag = word.to_str().is_some_and(|w| flags.contains(w));
        if number_flag && words.peek().and_then(|v| v.to_str()).is_some_and(negative) {
            word.push("=");
            word.push(words.next().unwrap_or_default());
        }
        out.push(word);
    }
    (command, out)
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::ffi::OsString;

    fn words(line: &str) -> Vec<OsString> {
        line.split(' ').map(OsString::from).collect()
    }

    /// The rule of [`number_values`] both ways: a negative number after a number flag is its
    /// value; any other word starting with '-' is left to be a flag.
    #[test]
    fn number_flags_take_negative_numbers_and_not_the_next_flag() {
        let joined = [
            ("isoview stats s --time -1", "isoview stats s --time=-1"),
            ("isoview stats s --time -1e-3 --bins 4", "isoview stats s --time=-1e-3 --bins 4"),
            ("isoview stats s --time -.5", "isoview stats s --time=-.5"),
            ("isoview stats s --time -inf", "isoview stats s --time=-inf"),
            ("isoview probe s --pixel -1,5", "isoview probe s --pixel=-1,5"),
            ("isoview render s -o o --frames -3..0", "isoview render s -o o --frames=-3..0"),
            ("isoview compare a b --fail -1", "isoview compare a b --fail=-1"),
        ];
        let left = [
            "isoview stats s --time --set x=1",
            "isoview stats s --time -x",
            "isoview stats s --time -",
            "isoview render s -o -1.exr",
            "isoview stats s --set -1=2",
            "isoview stats s -- --time -1",
        ];
        let cases = joined.into_iter().chain(left.into_iter().map(|l| (l, l)));
        for (line, want) in cases {
            let (_, got) = number_values(Cli::command(), words(line));
            assert_eq!(got, words(want), "{line}");
        }
    }

    /// clap's own rule is off: the flag given no value is named as such, not given the next
    /// flag. And the words the rule joins are what clap reads.
    #[test]
    fn a_number_flag_given_no_value_is_refused_as_one() {
        let parse = |line: &str| {
            let (command, args) = number_values(Cli::command(), words(line));
            command.try_get_matches_from(args)
        };
        let e = parse("isoview stats s --time --set x=1").unwrap_err();
        let text = e.to_string();
        assert!(text.contains("a value is required for '--time <TIME>'"), "{text}");
        let m = parse("isoview stats s --time -1e-3").unwrap();
        let (_, stats) = m.subcommand().unwrap();
        assert_eq!(stats.get_one::<f64>("time"), Some(&-1e-3));
    }

    /// The flags are told by their names, whatever the verb: a name that is a number flag in
    /// one verb must be one in every verb that has it, or the rule would join a value that
    /// another verb's flag of that name does not take.
    #[test]
    fn a_number_flags_name_is_one_in_every_verb() {
        let command = Cli::command();
        let verbs: Vec<_> = command.get_subcommands().collect();
        let numbers: Vec<_> = verbs
            .iter()
            .flat_map(|v| v.get_arguments())
            .filter(|a| a.is_allow_hyphen_values_set())
            .filter_map(|a| a.get_long())
            .collect();
        assert!(numbers.contains(&"time") && numbers.contains(&"pixel"), "{numbers:?}");
        for verb in &verbs {
            for arg in verb.get_arguments() {
                if arg.get_long().is_some_and(|l| numbers.contains(&l)) {
                    assert!(arg.is_allow_hyphen_values_set(), "{} --{:?}", verb, arg.get_long());
                }
            }
        }
    }
}
