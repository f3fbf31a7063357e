//! Bounded memory for images: the streamed EXR (written band by band as the render draws it)
//! is byte for byte the in-memory writer's, for shipped scenes and every method, with any split
//! into bands; so is the streamed PNG preview; and a large render's peak resident memory,
//! measured on the child process, grows far less than holding the frame would need.

use isoview::frame::{Channel, FrameInfo, Pixel};
use isoview::output::exr as out_exr;
use isoview::output::exr::ExrStream;
use isoview::output::png;
use isoview::passes::Band;
use isoview::render::{Collect, FrameSink, GpuGrid, RenderError, Renderer};

use crate::cli::output::test_frame;
use crate::common::{gpu, isoview, scratch, stderr};

/// The contract's channels plus `crossings` (what `test_frame` counts).
fn all_channels() -> Vec<Channel> {
    Channel::ALL.to_vec()
}

/// Streams `frame` pushing rows in the given numbers (cycled), returns the file's bytes.
fn stream_in_splits(
    path: &std::path::Path,
    frame: &isoview::frame::Frame,
    splits: &[usize],
) -> Vec<u8> {
    let channels = out_exr::written_channels(frame);
    let mut s = ExrStream::create(path, frame.width, frame.height, &channels, &frame.info).unwrap();
    let w = frame.width as usize;
    let (mut row, mut k) = (0, 0);
    while row < frame.height as usize {
        let n = splits[k % splits.len()].min(frame.height as usize - row);
        s.push_rows(&frame.pixels[row * w..(row + n) * w]).unwrap();
        row += n;
        k += 1;
    }
    s.finish().unwrap();
    std::fs::read(path).unwrap()
}

#[test]
fn exr_stream_equals_the_in_memory_writer_for_any_band_split() {
    let dir = scratch("stream-splits");
    // 41 rows: two whole ZIP blocks of 16 and a last one of 9.
    let frame = test_frame(37, 41);
    let reference = out_exr::encode_frame(&dir.join("r.exr"), &frame).unwrap();
    for splits in [&[41][..], &[1], &[16], &[15, 2], &[7, 23, 1], &[40, 1]] {
        let bytes = stream_in_splits(&dir.join("s.exr"), &frame, splits);
        assert!(bytes == reference, "bands of {splits:?} rows give other bytes");
    }
    // One row, one column.
    let tiny = test_frame(1, 1);
    let bytes = stream_in_splits(&dir.join("t.exr"), &tiny, &[1]);
    assert_eq!(bytes, out_exr::encode_frame(&dir.join("t.exr"), &tiny).unwrap());
}

#[test]
fn exr_stream_refuses_what_the_in_memory_writer_would_write_otherwise() {
    let dir = scratch("stream-refuse");
    let path = dir.join("out.exr");
    let old = test_frame(4, 3);
    out_exr::write_frame(&path, &old).unwrap();
    let old_bytes = std::fs::read(&path).unwrap();
    let frame = test_frame(5, 20);
    let no_crossings: Vec<Channel> =
        Channel::ALL.into_iter().filter(|&c| c != Channel::Crossings).collect();

    // Counts in a channel that was not declared: the in-memory writer would have written it.
    let mut s = ExrStream::create(&path, 5, 20, &no_crossings, &frame.info).unwrap();
    let err = s.push_rows(&frame.pixels).unwrap_err().to_string();
    assert!(err.contains("crossings") && err.contains("out.exr"), "{err}");
    drop(s);
    // Rows that are not whole, rows past the end, and a stream that ends early.
    let mut s = ExrStream::create(&path, 5, 20, &all_channels(), &frame.info).unwrap();
    assert!(s.push_rows(&frame.pixels[..7]).is_err());
    drop(s);
    let mut s = ExrStream::create(&path, 5, 20, &all_channels(), &frame.info).unwrap();
    s.push_rows(&frame.pixels).unwrap();
    assert!(s.push_rows(&frame.pixels[..5]).is_err());
    drop(s);
    let mut s = ExrStream::create(&path, 5, 20, &all_channels(), &frame.info).unwrap();
    s.push_rows(&frame.pixels[..50]).unwrap();
    let err = s.finish().unwrap_err().to_string();
    assert!(err.contains("10 of 20 rows"), "{err}");
    // None of it touched the previous file or left a temporary beside it.
    assert_eq!(std::fs::read(&path).unwrap(), old_bytes);
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
}

#[test]
fn png_stream_equals_the_whole_image_encoder() {
    let dir = scratch("stream-png");
    let frame = test_frame(19, 23);
    let path = dir.join("p.png");
    let mut s = png::PngStream::create(&path, 19, 23, None).unwrap();
    for rows in frame.pixels.chunks(19 * 5) {
        s.push_rows(rows).unwrap();
    }
    s.finish().unwrap();
    assert!(std::fs::read(&path).unwrap() == png::encode_preview(&path, &frame).unwrap());
    let img = image::open(&path).unwrap().to_rgba8();
    assert_eq!(img.dimensions(), (19, 23));
    assert_eq!(img.into_raw(), png::preview_rgba8(&frame).1);
    // Too few rows: an error, and no file.
    let short = dir.join("short.png");
    let mut s = png::PngStream::create(&short, 19, 23, None).unwrap();
    s.push_rows(&frame.pixels[..19]).unwrap();
    assert!(s.finish().is_err());
    assert!(!short.exists());
}

/// `output::frame_files::FrameFiles`, the per-frame sink of `isoview render` (and of a future
/// binding), handed bands through `FrameSink`: its EXR is the in-memory writer's file of the
/// frame with its extra header pair, its PNG the whole-image preview, and neither name exists
/// before `finish`.
#[test]
fn frame_files_write_the_in_memory_files_band_by_band() {
    use isoview::output::frame_files::FrameFiles;
    let dir = scratch("stream-frame-files");
    let frame = test_frame(21, 17);
    let (exr, png_path) = (dir.join("f.exr"), dir.join("f.png"));
    let channels = out_exr::written_channels(&frame);
    let mut files =
        FrameFiles::new(&exr, Some(&png_path), channels).with_header("isovalue_rule", "sigma 1");
    let sink: &mut dyn FrameSink = &mut files;
    sink.begin(21, 17, &frame.info).unwrap();
    for (k, rows) in frame.pixels.chunks(21 * 4).enumerate() {
        let band = Band { row_offset: 4 * k as u32, rows: (rows.len() / 21) as u32 };
        sink.band(band, rows).unwrap();
    }
    assert_eq!(files.size(), (21, 17));
    assert!(files.take_tev_error().is_none());
    assert!(!exr.exists() && !png_path.exists(), "a file was in place before finish");
    files.finish().unwrap();

    let mut expected = frame.clone();
    expected.info.extra.push(("isovalue_rule".into(), "sigma 1".into()));
    let expected_exr = out_exr::encode_frame(&exr, &expected).unwrap();
    assert!(std::fs::read(&exr).unwrap() == expected_exr, "the EXRs differ");
    let expected_png = png::encode_preview(&png_path, &frame).unwrap();
    assert!(std::fs::read(&png_path).unwrap() == expected_png, "the PNGs differ");
}

/// A sink that keeps the frame and streams it at once, cutting each band the renderer sends
/// into pieces of `cut` rows (bands smaller than any real device's).
struct Tee {
    frame: Collect,
    stream: Option<ExrStream>,
    path: std::path::PathBuf,
    cut: usize,
    channels: Vec<Channel>,
}

impl FrameSink for Tee {
    fn begin(&mut self, w: u32, h: u32, info: &FrameInfo) -> Result<(), RenderError> {
        self.frame.begin(w, h, info)?;
        self.stream = Some(ExrStream::create(&self.path, w, h, &self.channels, info)?);
        Ok(())
    }
    fn band(&mut self, band: Band, pixels: &[Pixel]) -> Result<(), RenderError> {
        self.frame.band(band, pixels)?;
        let w = pixels.len() / band.rows as usize;
        for piece in pixels.chunks(w * self.cut) {
            self.stream.as_mut().unwrap().push_rows(piece)?;
        }
        Ok(())
    }
}

#[gpu_test]
fn streamed_renders_equal_in_memory_exrs_for_every_method() {
    let dir = scratch("stream-render");
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let cases: &[(&str, &[&str])] = &[
        ("scenes/torus.toml", &["image.width=67", "image.height=45"]),
        (
            "scenes/gyroid.toml",
            &["image.width=40", "image.height=33", "render.method=\"fixed-step\""],
        ),
        ("scenes/sphere.toml", &["image.width=50", "image.height=17", "render.method=\"mesh\""]),
        (
            "scenes/cell-tunnel.toml",
            &["image.width=31", "image.height=40", "render.count_crossings=true"],
        ),
        ("scenes/gyroid-clipped.toml", &["image.width=48", "image.height=36"]),
        ("scenes/mesh-sphere.toml", &["image.width=30", "image.height=20"]),
    ];
    for (n, (file, sets)) in cases.iter().enumerate() {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        let scene = isoview::scene::load(std::path::Path::new(file), &sets).unwrap();
        let grid = scene.field.sample(0.0).unwrap();
        let gpu_grid = GpuGrid::upload(&ctx, &grid).unwrap();
        let path = dir.join(format!("{n}.exr"));
        let mut tee = Tee {
            frame: Collect::default(),
            stream: None,
            path: path.clone(),
            cut: 3 + n,
            channels: isoview::render::scene_channels(&scene),
        };
        renderer.render_to(&scene, &grid, &gpu_grid, 0.0, &mut tee).unwrap();
        tee.stream.take().unwrap().finish().unwrap();
        let frame = tee.frame.into_frame().unwrap();
        assert!(frame.pixels.iter().any(|p| p.is_hit()), "{file}: nothing hit");
        let streamed = std::fs::read(&path).unwrap();
        assert!(streamed == out_exr::encode_frame(&path, &frame).unwrap(), "{file}: bytes differ");

        // The command line streams too: same bytes (same header facts) and the PNG's pixels.
        let exr = dir.join(format!("cli{n}.exr"));
        let png_path = dir.join(format!("cli{n}.png"));
        let mut args =
            vec!["render", file, "-o", exr.to_str().unwrap(), "--png", png_path.to_str().unwrap()];
        for s in &sets {
            args.extend(["--set", s]);
        }
        let out = isoview(&args, &[]);
        assert!(out.status.success(), "{file}: {}", stderr(&out));
        let mut expected = frame.clone();
        if let Some(how) = scene.surface.rule.describe(scene.surface.isovalue) {
            expected.info.extra.push(("isovalue_rule".into(), how));
        }
        assert!(
            std::fs::read(&exr).unwrap() == out_exr::encode_frame(&exr, &expected).unwrap(),
            "{file}: the command line's EXR differs from the in-memory writer's"
        );
        let preview = std::fs::read(&png_path).unwrap();
        assert!(preview == png::encode_preview(&png_path, &frame).unwrap(), "{file}: PNG bytes");
    }
}

#[gpu_test]
fn frames_are_streamed_one_by_one() {
    let dir = scratch("stream-frames");
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let file = "scenes/cell-oscillating.toml";
    let sets = vec!["image.width=24".to_string(), "image.height=20".to_string()];
    let pattern = dir.join("f.##.exr");
    let mut args = vec!["render", file, "-o", pattern.to_str().unwrap(), "--frames", "3..4"];
    for s in &sets {
        args.extend(["--set", s]);
    }
    let out = isoview(&args, &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    let scene = isoview::scene::load(std::path::Path::new(file), &sets).unwrap();
    let mut seen = Vec::new();
    for f in [3, 4] {
        let t = f as f64 / 24.0;
        let grid = scene.field.sample(t).unwrap();
        let frame = renderer.render(&scene, &grid, t).unwrap();
        let path = dir.join(format!("f.{f:02}.exr"));
        let bytes = std::fs::read(&path).unwrap();
        assert!(bytes == out_exr::encode_frame(&path, &frame).unwrap(), "frame {f}");
        seen.push(bytes);
    }
    assert_ne!(seen[0], seen[1], "the frames differ in time");
}

/// Runs isoview and returns its exit status and peak resident memory in MiB, measured by the
/// kernel for that one child (`wait4`'s rusage), not for this test binary's other children.
/// Mesa's shader cache is off, so every run pays the same shader compile (LLVM's peak is a few
/// hundred MiB on lavapipe; a warm cache would hide it on some runs and not on others).
pub(crate) fn peak_rss_mib(args: &[&str]) -> (i32, f64) {
    use std::process::{Command, Stdio};
    let child = Command::new(env!("CARGO_BIN_EXE_isoview"))
        .args(args)
        .env_remove("ISOVIEW_DEVICE")
        .env("MESA_SHADER_CACHE_DISABLE", "true")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: rusage is plain data the kernel fills; `pid` is our own child, waited once here
    // (the `Child` handle is dropped without waiting, which std allows).
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(r, pid, "wait4");
    drop(child);
    let code = if libc::WIFEXITED(status) { libc::WEXITSTATUS(status) } else { -1 };
    (code, usage.ru_maxrss as f64 / 1024.0)
}

/// 4096 x 2048 pixels of one cell against 64 x 32: holding the frame and its channel planes (as
/// the writer did before streaming) grew memory by about 130 bytes a pixel, 1 GiB here;
/// streamed, it grows by a few bands (3 x 64 MiB at this width).
#[gpu_test]
fn a_large_render_stays_in_bounded_memory() {
    let dir = scratch("stream-peak");
    let run = |w: u32, h: u32| {
        let out = dir.join(format!("{w}.exr"));
        let png_path = dir.join(format!("{w}.png"));
        let (width, height) = (format!("image.width={w}"), format!("image.height={h}"));
        let (code, mib) = peak_rss_mib(&[
            "render",
            "scenes/cell-tunnel.toml",
            "-o",
            out.to_str().unwrap(),
            "--png",
            png_path.to_str().unwrap(),
            "--set",
            &width,
            "--set",
            &height,
        ]);
        assert_eq!(code, 0, "{w}x{h}");
        let img = out_exr::read(&out).unwrap();
        assert_eq!((img.width, img.height), (w as usize, h as usize));
        mib
    };
    let small = run(64, 32);
    let large = run(4096, 2048);
    let held_mib = 4096.0 * 2048.0 * 128.0 / (1 << 20) as f64;
    eprintln!(
        "peak RSS {small:.0} MiB at 64x32, {large:.0} MiB at 4096x2048 (a held frame + planes \
         alone: {held_mib:.0} MiB)"
    );
    assert!(large - small < 300.0, "peak RSS grew {:.0} MiB", large - small);
    std::fs::remove_dir_all(&dir).unwrap();
}
