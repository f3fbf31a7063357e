//! `isoview render SCENE.toml -o OUT.exr [--png P] [--set K=V]... [--time T] [--frames A..B]
//! [--tev [HOST:PORT]]`

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::{Cli, Failure};
use crate::output;
use crate::render::{GpuGrid, Progressive, Renderer};
use crate::scene::Scene;

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
    #[arg(long, default_value_t = 0.0, conflicts_with = "frames")]
    pub time: f64,
    /// Render frames A to B inclusive (`A..B`), at time frame / fps.
    #[arg(long, value_name = "A..B")]
    pub frames: Option<String>,
    /// Frames per second for --frames.
    #[arg(long, default_value_t = 24.0)]
    pub fps: f64,
    /// Also show each frame in the tev HDR viewer (every EXR channel), sent over tev's TCP
    /// protocol; HOST:PORT defaults to 127.0.0.1:14158 (tev's own default).
    #[arg(long, value_name = "HOST:PORT", num_args = 0..=1,
          default_missing_value = output::tev::DEFAULT_ADDRESS)]
    pub tev: Option<String>,
}

/// Parses `A..B` (or `A..=B`), inclusive, A <= B.
pub fn parse_frames(s: &str) -> Result<(i64, i64), String> {
    let (a, b) = s
        .split_once("..=")
        .or_else(|| s.split_once(".."))
        .ok_or_else(|| format!("--frames {s}: expected A..B, e.g. 1..48"))?;
    let a: i64 = a.trim().parse().map_err(|_| format!("--frames {s}: `{a}` is not an integer"))?;
    let b: i64 = b.trim().parse().map_err(|_| format!("--frames {s}: `{b}` is not an integer"))?;
    if a > b {
        return Err(format!("--frames {s}: the first frame is after the last"));
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
        return Err(Failure::input(format!("--fps {}: must be a positive number", args.fps)));
    }
    if !args.time.is_finite() {
        return Err(Failure::input(format!("--time {}: must be a finite number", args.time)));
    }
    let scene = super::load_scene(&args.scene, &args.sets)?;
    let frames = match &args.frames {
        Some(f) => {
            let (a, b) = parse_frames(f).map_err(Failure::input)?;
            let mut jobs = Vec::new();
            for n in a..=b {
                let exr = frame_path(&args.output, n).map_err(Failure::input)?;
                let png = match &args.png {
                    Some(p) => Some(frame_path(p, n).map_err(Failure::input)?),
                    None => None,
                };
                jobs.push((n as f64 / args.fps, exr, png));
            }
            jobs
        }
        None => vec![(args.time, args.output.clone(), args.png.clone())],
    };

    let ctx = cli.gpu()?;
    let mut renderer = Renderer::new(&ctx).map_err(Failure::gpu)?;
    let progress = (frames.len() > 1).then(|| {
        let bar = indicatif::ProgressBar::new(frames.len() as u64);
        bar.set_style(
            indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} frames, {eta} left")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar
    });
    // A field that does not depend on time is sampled and uploaded once.
    let mut cached: Option<(crate::field::Grid, GpuGrid)> = None;
    for (time, exr, png) in &frames {
        let started = Instant::now();
        if cached.is_none() || scene.field.is_time_varying() {
            let grid = scene.field.sample(*time).map_err(Failure::input)?;
            let uploaded = GpuGrid::upload(&ctx, &grid)?;
            cached = Some((grid, uploaded));
        }
        let (grid, gpu_grid) = cached.as_ref().expect("sampled above");
        // With --tev, tev shows each band as it finishes (CreateImage first).
        let mut tev = match &args.tev {
            Some(address) => Some(open_tev(address, exr, &scene)?),
            None => None,
        };
        let mut tev_error = None;
        let drawn = {
            let mut after_band = |band: crate::passes::Band, records: &[crate::frame::Pixel]| {
                let Some(image) = tev.as_mut() else { return true };
                match image.send_rows(band.row_offset, records) {
                    Ok(()) => true,
                    Err(e) => {
                        tev_error = Some(e);
                        false
                    }
                }
            };
            let whole = Progressive { stride: 1, band_rows: u32::MAX, after_band: &mut after_band };
            renderer.render_progressive(&scene, grid, gpu_grid, *time, whole)
        };
        if let Some(e) = tev_error {
            return Err(Failure::input(e));
        }
        let mut frame = drawn.map_err(render_failure)?;
        if let Some(how) = scene.surface.rule.describe(scene.surface.isovalue) {
            // Beside isoview/isovalue (the resolved number): how it was picked.
            frame.info.extra.push(("isovalue_rule".into(), how));
        }
        write_outputs(&scene, &frame, exr, png.as_deref())?;
        match &progress {
            Some(bar) => bar.inc(1),
            None => eprintln!(
                "isoview: {}x{} {} on {} in {:.0} ms{} -> {}",
                frame.width,
                frame.height,
                scene.render.method.name(),
                ctx.info.name,
                started.elapsed().as_secs_f64() * 1e3,
                renderer.last_gpu_ms.map(|ms| format!(" (GPU {ms:.1} ms)")).unwrap_or_default(),
                exr.display()
            ),
        }
    }
    if let Some(bar) = progress {
        bar.finish();
    }
    Ok(0)
}

fn render_failure(e: crate::render::RenderError) -> Failure {
    match e {
        crate::render::RenderError::Gpu(g) => Failure::gpu(g),
        other => Failure::input(other),
    }
}

fn write_outputs(
    _scene: &Scene,
    frame: &crate::frame::Frame,
    exr: &Path,
    png: Option<&Path>,
) -> Result<(), Failure> {
    output::exr::write_frame(exr, frame).map_err(Failure::input)?;
    if let Some(png) = png {
        output::png::write_preview(png, frame).map_err(Failure::input)?;
    }
    Ok(())
}

/// Opens the tev image of the render to `exr`: named as the file, with the channels the EXR
/// will have.
fn open_tev(address: &str, exr: &Path, scene: &Scene) -> Result<output::tev::TevImage, Failure> {
    let channels = crate::render::scene_channels(scene);
    let name = exr.display().to_string();
    output::tev::TevImage::open(address, &name, scene.image.width, scene.image.height, channels)
        .map_err(Failure::input)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_ranges_and_names() {
        assert_eq!(parse_frames("1..48"), Ok((1, 48)));
        assert_eq!(parse_frames("3..=3"), Ok((3, 3)));
        assert!(parse_frames("5..2").is_err());
        assert!(parse_frames("a..2").is_err());
        assert_eq!(
            frame_path(Path::new("out.####.exr"), 7).unwrap(),
            PathBuf::from("out.0007.exr")
        );
        assert_eq!(frame_path(Path::new("f#.exr"), 12).unwrap(), PathBuf::from("f12.exr"));
        assert!(frame_path(Path::new("out.exr"), 1).is_err());
    }
}
