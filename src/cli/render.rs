//! `isoview render SCENE.toml -o OUT.exr [--png P] [--set K=V]... [--time T] [--frames A..B]
//! [--tev [HOST:PORT]]`

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::console::note;
use super::{Cli, Failure};
use crate::cluster::{BlockError, Ranks};
use crate::output;
use crate::render::{GpuGrid, Renderer};
use crate::scene::Scene;
use crate::vocab::{echo, echo_number};

#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
    /// Output EXR. With --frames, `####` in the name becomes the zero-padded frame number.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write a tone-mapped sRGB preview of the beauty (with --frames: `####` as above).
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Override a scene key, value in TOML syntax: --set render.steps=64 --set render.method='"fixed-step"'
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Time of the field in seconds (`t` in expr fields).
    #[arg(long, default_value_t = 0.0, conflicts_with = "frames", allow_hyphen_values = true, value_parser = super::number)]
    pub time: f64,
    /// Render frames A to B inclusive (`A..B`), at time frame / fps.
    #[arg(long, value_name = "A..B", allow_hyphen_values = true)]
    pub frames: Option<String>,
    /// Frames per second for --frames.
    #[arg(long, default_value_t = 24.0, allow_hyphen_values = true, value_parser = super::number)]
    pub fps: f64,
    /// Also show each frame in the tev HDR viewer (every EXR channel), sent over tev's TCP
    /// protocol; HOST:PORT defaults to 127.0.0.1:14158 (tev's own default).
    #[arg(long, value_name = "HOST:PORT", num_args = 0..=1,
          default_missing_value = output::tev::DEFAULT_ADDRESS)]
    pub tev: Option<String>,
}

/// Parses `A..B` (or `A..=B`), inclusive, A <= B.
pub fn parse_frames(s: &str) -> Result<(i64, i64), String> {
    let bad = |why: String| format!("--frames {}: {why}", echo(s));
    let (a, b) = s
        .split_once("..=")
        .or_else(|| s.split_once(".."))
        .ok_or_else(|| bad("expected A..B, e.g. 1..48".into()))?;
    let int = |v: &str| {
        use std::num::IntErrorKind;
        v.trim().parse::<i64>().map_err(|e| {
            let v = echo(v.trim());
            // An integer past i64 is a number the user meant: say which limit it passes.
            bad(match e.kind() {
                IntErrorKind::PosOverflow => {
                    format!("`{v}` is too large: frame numbers go up to {}", i64::MAX)
                }
                IntErrorKind::NegOverflow => {
                    format!("`{v}` is too small: frame numbers go down to {}", i64::MIN)
                }
                _ => format!("`{v}` is not an integer"),
            })
        })
    };
    let (a, b) = (int(a)?, int(b)?);
    if a > b {
        return Err(bad("the first frame is after the last".into()));
    }
    Ok((a, b))
}

/// Replaces the run of `#` in `path` with `frame`, zero-padded to the run's length.
pub fn frame_path(path: &Path, frame: i64) -> Result<PathBuf, String> {
    let s = path.to_string_lossy();
    let start = s
        .find('#')
        .ok_or_else(|| format!("{}: with --frames the name needs #### for the frame number", s))?;
    let len = s[start..].chars().take_while(|&c| c == '#').count();
    let number = format!("{:0width$}", frame, width = len);
    Ok(PathBuf::from(format!("{}{}{}", &s[..start], number, &s[start + len..])))
}

fn check_extension(path: &Path, ext: &str, flag: &str) -> Result<(), Failure> {
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case(ext) => Ok(()),
        _ => Err(Failure::input(format!(
            "{flag} {}: the file name must end in .{ext}",
            path.display()
        ))),
    }
}

pub fn run(cli: &Cli, args: &RenderArgs) -> Result<i32, Failure> {
    check_extension(&args.output, "exr", "-o")?;
    if let Some(png) = &args.png {
        check_extension(png, "png", "--png")?;
    }
    if !(args.fps.is_finite() && args.fps > 0.0) {
        return Err(Failure::input(format!(
            "--fps {}: must be a positive number",
            echo_number(args.fps)
        )));
    }
    super::finite("--time", args.time)?;
    let range = args.frames.as_deref().map(parse_frames).transpose().map_err(Failure::input)?;
    // A frame's time is n / fps: the range's ends are its largest magnitudes, and a tiny fps
    // (5e-324) makes them infinite, which the field would be sampled at without a word.
    if let Some((a, b)) = range {
        if let Some(n) = [a, b].into_iter().find(|&n| !(n as f64 / args.fps).is_finite()) {
            return Err(Failure::input(format!(
                "--frames {} at --fps {}: frame {n}'s time ({n} / fps) is not a finite number",
                echo(args.frames.as_deref().unwrap_or_default()),
                echo_number(args.fps)
            )));
        }
    }
    let scene = super::load_scene(&args.scene, &args.sets)?;
    let frames = Frames { args, range };

    // Under mpirun with more than one rank: the grid is split (`cluster`), rank 0 writes.
    let ranks = Ranks::from_launcher();
    let tev = (args.tev.is_some() && !ranks.is_single())
        .then(|| "--tev is not available under MPI".to_string());
    let interp = scene.interpolation_refusal(scene.render_reader());
    if let Some(why) = interp.or_else(|| ranks.refuses(&scene)).or(tev) {
        return super::refuse_on_ranks(&ranks, Failure::input(why));
    }
    // An output that may not be written (an input, a special file): under MPI every rank
    // meets it alike and rank 0 says it.
    let refused = |f: Failure| super::refuse_on_ranks(&ranks, f);
    // The first frame's names are checked before the device opens, so that a bad pattern or
    // a refused output fails at once.
    if let Err(f) = frames.job(*frames.numbers().start()).and_then(|job| job.check(&scene)) {
        return refused(f);
    }
    let rank0 = ranks.is_root();

    let ctx = cli.gpu()?;
    let mut renderer = Renderer::new(&ctx).map_err(Failure::gpu)?;
    let progress = (frames.count() > 1 && rank0).then(|| {
        let bar = indicatif::ProgressBar::new(frames.count());
        bar.set_style(
            indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} frames, {eta} left")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar
    });
    // A field that does not depend on time is sampled and uploaded once; a memory-mapped one
    // (`field.residency`) is scanned and its active bricks uploaded once.
    let mut cached: Option<(crate::field::Grid, GpuGrid)> = None;
    let limits = crate::field::GridLimits::from_env().map_err(Failure::input)?;
    let mapped = crate::render::pool::mapped_for(&scene, &limits).map_err(pool_failure)?;
    // Under MPI each rank reads its block of the file (below): the default "auto" leaves the
    // brick pool to a single process; "active", asked for, is refused.
    let mapped = match (ranks.is_single(), scene.field.residency) {
        (true, _) | (false, crate::field::Residency::Active) => mapped,
        // "auto" for raw and npy, and a .vdb/.nvdb tree: each rank samples its block whole.
        (false, _) => None,
    };
    if let Some(mapped) = mapped {
        if !ranks.is_single() {
            return Err(Failure::input(
                "field.residency = \"active\" is not available under MPI (each rank uploads its \
                 block of the whole grid instead)",
            ));
        }
        let pooled = crate::render::pool::upload_for(&ctx, &scene, &*mapped, &limits)
            .map_err(pool_failure)?;
        if rank0 {
            note!("{}", pooled.summary);
        }
        cached = Some((pooled.shape, pooled.gpu));
    }
    // A grid uploaded whole is one 3D image: over the device's extent it is the input's size
    // that is wrong (exit 2, the key named), not the GPU. Under MPI each rank holds a block.
    let whole = cached.is_none() && ranks.is_single();
    if whole {
        let max = ctx.info.max_image_dimension_3d;
        scene.field.check_image_extent(max).map_err(Failure::input)?;
    }
    // The first failure to reach tev; the frames are still drawn and written.
    let mut tev_failed: Option<output::tev::TevError> = None;
    for n in frames.numbers() {
        let job = frames.job(n)?;
        if let Err(f) = job.check(&scene) {
            return refused(f);
        }
        let Job { time, exr, png } = job;
        let started = Instant::now();
        // Under MPI a raw or npy file is mapped and each rank reads only its block.
        if cached.is_none() {
            cached = match ranks.upload_mapped_block(&ctx, &scene.field) {
                Ok(block) => block,
                Err(BlockError::Open(e)) => return Err(Failure::input(e)),
                Err(BlockError::Read(e)) => {
                    return Err(super::failed_alone(&ranks, Failure::input(e)))
                }
                Err(BlockError::Gpu(e)) => return Err(Failure::gpu(e)),
            };
        }
        if cached.is_none() || scene.field.is_time_varying() {
            let grid = scene.field.sample(time).map_err(Failure::input)?;
            let uploaded = ranks.upload(&ctx, &grid)?;
            cached = Some((grid, uploaded));
        }
        let (grid, gpu_grid) = cached.as_ref().expect("sampled above");
        // Each band goes to the EXR, the PNG and tev as it is drawn; none is kept.
        // The scene's channels, and how the isovalue was picked beside `isoview/isovalue`.
        let mut outputs = crate::render::scene_files(&scene, &exr, png.as_deref());
        // With --tev, tev shows each band as it finishes (CreateImage first). Once tev has
        // failed it is not tried again; the failure is reported after the last frame.
        if let (Some(address), None) = (&args.tev, &tev_failed) {
            let (width, height) = (scene.image.width, scene.image.height);
            if let Err(e) = outputs.show_in_tev(address, width, height) {
                tev_failed = Some(e);
            }
        }
        let drawn = ranks.render_to(&mut renderer, &scene, (grid, gpu_grid), time, &mut outputs);
        // Under MPI the other ranks wait in a collective: a rank's failure ends them all.
        let drawn = drawn.map_err(|e| super::failed_alone(&ranks, render_failure(e)));
        // Under MPI: the ranks, and rank 0's time gathering and compositing.
        let split = match &drawn {
            Ok(Some(compositing)) => format!(
                ", {} MPI ranks, compositing {:.0} ms",
                ranks.size(),
                compositing.as_secs_f64() * 1e3
            ),
            _ => String::new(),
        };
        if let Some(e) = outputs.take_tev_error() {
            tev_failed.get_or_insert(e);
        }
        drawn?;
        let (width, height) = outputs.size();
        outputs.finish().map_err(Failure::input)?;
        // Memory stays bounded over any number of frames (see `release_pipelines`): every
        // RELEASE_EVERY frames, so that rebuilding the pipelines (tens of ms on lavapipe) costs
        // little per frame.
        let done = n.abs_diff(*frames.numbers().start()) + 1;
        if done % RELEASE_EVERY == 0 && n != *frames.numbers().end() {
            renderer.release_pipelines();
            // The compilers' freed memory back to the system (glibc keeps it otherwise, and
            // the heap's holes grow with each rebuild).
            #[cfg(all(target_os = "linux", target_env = "gnu"))]
            // SAFETY: malloc_trim only returns free heap memory to the system.
            unsafe {
                libc::malloc_trim(0);
            }
        }
        match &progress {
            _ if !rank0 => {}
            Some(bar) => bar.inc(1),
            // The failure's line ends the run instead (one line for a failed run).
            None if tev_failed.is_some() => {}
            None => {
                // The GPU time apart (benchmarks: the structures' builds against the trace), on
                // a line of its own before the summary, whose form scripts parse.
                if std::env::var_os("ISOVIEW_TIMINGS").is_some() {
                    if let Some(all) = renderer.last_gpu_ms {
                        let (bricks, occupancy) =
                            (renderer.last_bricks_ms, renderer.last_occupancy_ms);
                        let build = bricks.unwrap_or(0.0) + occupancy.unwrap_or(0.0);
                        let cpu = renderer.last_bricks_cpu_ms.map_or(String::new(), |ms| {
                            format!("; brick grid made on the CPU in {ms:.1} ms")
                        });
                        note!(
                            "GPU build {build:.1} ms (brick grid {:.1} ms, occupancy {:.1} ms), \
                             trace {:.1} ms{cpu}",
                            bricks.unwrap_or(0.0),
                            occupancy.unwrap_or(0.0),
                            all - build
                        );
                    }
                }
                note!(
                    "{}x{} {} on {} in {:.0} ms{}{split} -> {}",
                    width,
                    height,
                    scene.render.method.name(),
                    ctx.info.name,
                    started.elapsed().as_secs_f64() * 1e3,
                    renderer.last_gpu_ms.map(|ms| format!(" (GPU {ms:.1} ms)")).unwrap_or_default(),
                    exr.display()
                )
            }
        }
    }
    if let Some(bar) = progress {
        bar.finish();
    }
    match tev_failed {
        // docs/serve.md "Push to tev": nobody listening is one line naming the address, exit 2, after the files
        // are written (the files are what the render is for; tev only shows them).
        Some(e) => Err(Failure::input(format!("{e}; the render's files were written"))),
        None => Ok(0),
    }
}

/// How many frames a [`Renderer`] draws before its pipelines are rebuilt (at most about 1 MiB
/// a frame is held until then on lavapipe; see `Renderer::release_pipelines`).
const RELEASE_EVERY: u64 = 16;

/// The frames of a run (`--frames A..B`, or the one frame at `--time`), made one at a time
/// as the loop reaches them: never collected, so a range of four billion frames costs
/// nothing before its frames are drawn, and memory does not grow with the range.
struct Frames<'a> {
    args: &'a RenderArgs,
    /// `--frames`, inclusive.
    range: Option<(i64, i64)>,
}

/// One frame to draw: its time and output names.
struct Job {
    time: f64,
    exr: PathBuf,
    png: Option<PathBuf>,
}

impl Frames<'_> {
    fn count(&self) -> u64 {
        self.range.map_or(1, |(a, b)| {
            u64::try_from(i128::from(b) - i128::from(a) + 1).unwrap_or(u64::MAX)
        })
    }

    /// The frame numbers, in order (the single frame: 0, unused).
    fn numbers(&self) -> std::ops::RangeInclusive<i64> {
        self.range.map_or(0..=0, |(a, b)| a..=b)
    }

    /// Frame `n`'s time and output names.
    fn job(&self, n: i64) -> Result<Job, Failure> {
        let args = self.args;
        if self.range.is_none() {
            return Ok(Job { time: args.time, exr: args.output.clone(), png: args.png.clone() });
        }
        let exr = frame_path(&args.output, n).map_err(Failure::input)?;
        let png = match &args.png {
            Some(p) => Some(frame_path(p, n).map_err(Failure::input)?),
            None => None,
        };
        Ok(Job { time: n as f64 / args.fps, exr, png })
    }
}

impl Job {
    /// Refuses outputs that are the scene's inputs, one file twice, or special files.
    fn check(&self, scene: &Scene) -> Result<(), Failure> {
        let mut outputs = vec![("-o", self.exr.as_path())];
        if let Some(png) = &self.png {
            outputs.push(("--png", png.as_path()));
        }
        super::check_outputs(&outputs, scene)
    }
}

fn pool_failure(e: crate::render::pool::PoolError) -> Failure {
    match e {
        crate::render::pool::PoolError::Gpu(g) => Failure::gpu(g),
        other => Failure::input(other),
    }
}

fn render_failure(e: crate::render::RenderError) -> Failure {
    match e {
        crate::render::RenderError::Gpu(g) => Failure::gpu(g),
        other => Failure::input(other),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_ranges_and_names() {
        assert_eq!(parse_frames("1..48"), Ok((1, 48)));
        assert_eq!(parse_frames("3..=3"), Ok((3, 3)));
        assert!(parse_frames("5..2").is_err());
        assert!(parse_frames("a..2").unwrap_err().ends_with("`a` is not an integer"));
        assert_eq!(
            parse_frames("-9223372036854775808..9223372036854775807"),
            Ok((i64::MIN, i64::MAX))
        );
        let e = parse_frames("0..9223372036854775808").unwrap_err();
        assert!(
            e.ends_with(
                "`9223372036854775808` is too large: frame numbers go up to 9223372036854775807"
            ),
            "{e}"
        );
        let e = parse_frames("-9223372036854775809..0").unwrap_err();
        assert!(e.contains("is too small: frame numbers go down to -9223372036854775808"), "{e}");
        assert_eq!(
            frame_path(Path::new("out.####.exr"), 7).unwrap(),
            PathBuf::from("out.0007.exr")
        );
        assert_eq!(frame_path(Path::new("f#.exr"), 12).unwrap(), PathBuf::from("f12.exr"));
        assert!(frame_path(Path::new("out.exr"), 1).is_err());
    }
}
