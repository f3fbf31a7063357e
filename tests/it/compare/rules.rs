//! `isoview compare`: value rules, thresholds, shift window, errors, diff outputs.

use std::path::{Path, PathBuf};

use clap::Parser;
use isoview::cli::compare::{run_with, CompareArgs};
use isoview::compare::{compare, ChannelClass, PixelState, Thresholds, Verdict};
use isoview::output::exr::{self as out_exr, ExrChannel, ExrImage, SampleKind};

use crate::cli::output::{scratch, test_frame};

/// An in-memory image from `(name, values)` pairs.
fn image(path: &str, w: usize, h: usize, channels: &[(&str, Vec<f32>)]) -> ExrImage {
    ExrImage {
        path: PathBuf::from(path),
        width: w,
        height: h,
        channels: channels
            .iter()
            .map(|(name, values)| {
                assert_eq!(values.len(), w * h);
                ExrChannel { name: name.to_string(), kind: SampleKind::F32, values: values.clone() }
            })
            .collect(),
        attributes: Vec::new(),
        parts: vec![String::new()],
    }
}

fn one(path: &str, name: &str, values: Vec<f32>) -> ExrImage {
    let n = values.len();
    image(path, n, 1, &[(name, values)])
}

fn no_flip() -> Thresholds {
    Thresholds { flip: false, ..Thresholds::default() }
}

/// Parses `isoview compare ARGS...` the way the binary will.
fn args(list: &[&str]) -> CompareArgs {
    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: CompareArgs,
    }
    let mut v = vec!["compare"];
    v.extend_from_slice(list);
    Cli::try_parse_from(v).unwrap().args
}

/// Runs the command; returns (exit status, stdout, stderr).
fn run(list: &[&str]) -> (i32, String, String) {
    let (mut out, mut err) = (Vec::new(), Vec::new());
    let code = run_with(&args(list), &mut out, &mut err);
    (code, String::from_utf8(out).unwrap(), String::from_utf8(err).unwrap())
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn identical_files_pass_with_exit_0() {
    let dir = scratch("cmp-identical");
    let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
    out_exr::write_frame(&a, &test_frame(9, 7)).unwrap();
    out_exr::write_frame(&b, &test_frame(9, 7)).unwrap();
    let (code, out, err) = run(&[s(&a), s(&b)]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("PASS: identical"), "{out}");
    for name in ["R", "N.X", "cell.Z", "crossings", "steps", "Z"] {
        assert!(out.lines().any(|l| l.starts_with(name)), "{name} row in\n{out}");
    }
    assert!(out.contains("FLIP"), "{out}");
    assert!(err.is_empty());
}

#[test]
fn infinities_and_nans_equal_themselves() {
    let a = one("a", "Z", vec![f32::INFINITY, f32::NAN, f32::NEG_INFINITY, 1.0]);
    let b = one("b", "Z", vec![f32::INFINITY, f32::NAN, f32::NEG_INFINITY, 1.0]);
    let r = compare(&a, &b, &no_flip()).unwrap();
    assert_eq!(r.verdict, Verdict::Identical);
    assert!(r.channels[0].identical);
    assert_eq!(r.channels[0].max_abs, 0.0);
}

#[test]
fn nan_against_a_number_is_a_difference() {
    let a = one("a", "R", vec![f32::NAN, 0.5, 0.5, 0.5]);
    let b = one("b", "R", vec![0.5, 0.5, 0.5, 0.5]);
    let r = compare(&a, &b, &no_flip()).unwrap();
    assert_eq!(r.verdict, Verdict::Fail);
    assert_eq!(r.channels[0].nonfinite, 1);
    assert_eq!(r.channels[0].over_fail, 1);
    // Also the other way round, and against infinity.
    let r = compare(&b, &a, &no_flip()).unwrap();
    assert_eq!(r.verdict, Verdict::Fail);
    let c = one("c", "R", vec![f32::INFINITY, 0.5, 0.5, 0.5]);
    assert_eq!(compare(&a, &c, &no_flip()).unwrap().verdict, Verdict::Fail);
}

#[test]
fn inf_against_finite_is_counted_not_a_nan_in_the_stats() {
    // A ray that hit in B but missed in A.
    let a = one("a", "Z", vec![f32::INFINITY, 2.0, 3.0, 4.0]);
    let b = one("b", "Z", vec![2.5, 2.0, 3.0, 4.5]);
    let r = compare(&a, &b, &no_flip()).unwrap();
    let z = &r.channels[0];
    assert_eq!(z.class, ChannelClass::Depth);
    assert_eq!(z.nonfinite, 1);
    assert_eq!(z.over_fail, 2);
    assert_eq!(z.max_abs, 0.5);
    assert_eq!(z.max_at, Some((3, 0)));
    assert!(z.mean_abs.is_finite() && z.rmse.is_finite() && z.rel_p99.is_finite());
    assert_eq!(r.failing_pixels, 2);
    let cov = r.coverage.as_ref().unwrap();
    assert_eq!((cov.channel.as_str(), cov.only_a, cov.only_b), ("Z", 0, 1));
}

#[test]
fn statistics_are_the_textbook_ones() {
    let a = one("a", "P.X", vec![0.0, 0.0, 0.0, 0.0]);
    let b = one("b", "P.X", vec![0.0, 1.0, 0.0, -3.0]);
    let r = compare(&a, &b, &no_flip()).unwrap();
    let c = &r.channels[0];
    assert_eq!(c.class, ChannelClass::Position);
    assert_eq!(c.max_abs, 3.0);
    assert_eq!(c.max_at, Some((3, 0)));
    assert_eq!(c.mean_abs, 1.0);
    assert!((c.rmse - (10.0f64 / 4.0).sqrt()).abs() < 1e-12);
    assert_eq!(c.rel_p99, 1.0);
    assert_eq!(c.over_fail, 2);
}

#[test]
fn fail_threshold_and_percentage() {
    // 100 pixels, one off by 5e-5, one off by 0.5.
    let a = one("a", "G", vec![0.5; 100]);
    let mut bv = vec![0.5; 100];
    bv[10] = 0.5 + 5e-5;
    let b = one("b", "G", bv.clone());
    assert_eq!(compare(&a, &b, &no_flip()).unwrap().verdict, Verdict::Warn);
    let strict = Thresholds { fail: 1e-5, ..no_flip() };
    assert_eq!(compare(&a, &b, &strict).unwrap().verdict, Verdict::Fail);

    bv[20] = 1.0;
    let b = one("b", "G", bv);
    let r = compare(&a, &b, &no_flip()).unwrap();
    assert_eq!((r.verdict, r.failing_pixels), (Verdict::Fail, 1));
    let one_percent = Thresholds { fail_percent: 1.0, warn_percent: 2.0, ..no_flip() };
    assert_eq!(compare(&a, &b, &one_percent).unwrap().verdict, Verdict::Pass);
    let half_percent = Thresholds { fail_percent: 0.5, ..no_flip() };
    assert_eq!(compare(&a, &b, &half_percent).unwrap().verdict, Verdict::Fail);
    // A hard-fail limit fails it whatever the percentage.
    let hard =
        Thresholds { fail_percent: 50.0, warn_percent: 50.0, hard_fail: Some(0.1), ..no_flip() };
    let r = compare(&a, &b, &hard).unwrap();
    assert_eq!((r.verdict, r.hard_failing_pixels), (Verdict::Fail, 1));
}

#[test]
fn relative_threshold_loosens_large_values() {
    let a = one("a", "Z", vec![1000.0, 1.0]);
    let b = one("b", "Z", vec![1000.01, 1.0]);
    assert_eq!(compare(&a, &b, &no_flip()).unwrap().verdict, Verdict::Fail);
    let rel = Thresholds { fail_relative: 1e-4, warn: 1.0, ..no_flip() };
    assert_eq!(compare(&a, &b, &rel).unwrap().verdict, Verdict::Pass);
}

#[test]
fn integer_channels_are_exact_unless_overridden() {
    let a = one("a", "steps", vec![10.0, 20.0]);
    let b = one("b", "steps", vec![10.0, 21.0]);
    let loose = Thresholds { fail: 10.0, warn: 10.0, ..no_flip() };
    let r = compare(&a, &b, &loose).unwrap();
    assert_eq!(r.channels[0].class, ChannelClass::Integer);
    assert_eq!(r.verdict, Verdict::Fail, "--fail does not loosen integer channels");
    let per_class =
        Thresholds { fail_class: vec![(ChannelClass::Integer, 1.0)], warn: 10.0, ..no_flip() };
    assert_eq!(compare(&a, &b, &per_class).unwrap().verdict, Verdict::Pass);
}

#[test]
fn cli_thresholds_and_exit_codes() {
    let dir = scratch("cmp-cli");
    let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
    let frame = test_frame(10, 10);
    let mut other = frame.clone();
    other.pixels[55].rgba[0] += 0.01;
    other.pixels[56].depth += 0.001;
    out_exr::write_frame(&a, &frame).unwrap();
    out_exr::write_frame(&b, &other).unwrap();

    let (code, out, _) = run(&[s(&a), s(&b)]);
    assert_eq!(code, 1, "{out}");
    assert!(out.contains("FAIL: 2 of 100 pixels"), "{out}");
    let row = |out: &str, name: &str| {
        out.lines().find(|l| l.split_whitespace().next() == Some(name)).unwrap().to_string()
    };
    // Over-threshold counts per channel, last column but one.
    let r = row(&out, "R");
    let cols: Vec<&str> = r.split_whitespace().collect();
    assert_eq!(cols[cols.len() - 2], "1", "{r}");
    assert!(r.contains("5,5"), "max at x=5, y=5: {r}");

    assert_eq!(run(&[s(&a), s(&b), "--fail", "0.02"]).0, 0);
    assert_eq!(run(&[s(&a), s(&b), "--fail-percent", "2"]).0, 0);
    assert_eq!(run(&[s(&a), s(&b), "--fail-percent", "1.5"]).0, 1);
    assert_eq!(
        run(&[s(&a), s(&b), "--fail-class", "colour=0.02", "--fail-class", "depth=0.01"]).0,
        0
    );
    assert_eq!(run(&[s(&a), s(&b), "--fail-class", "colour=0.02"]).0, 1);
    let (code, out, _) = run(&[s(&a), s(&b), "--fail", "0.02", "--warn", "0.02"]);
    assert_eq!(code, 0);
    assert!(out.contains("PASS: 0 of 100"), "{out}");
    let (code, out, _) = run(&[s(&a), s(&b), "--fail", "0.02"]);
    assert_eq!(code, 0);
    assert!(out.contains("WARN: 2 pixels"), "{out}");
    assert_eq!(run(&[s(&a), s(&b), "--channels", "G,B,steps"]).0, 0);
}

#[test]
fn bad_input_exits_2_naming_the_problem() {
    let dir = scratch("cmp-bad");
    let (a, b, c) = (dir.join("a.exr"), dir.join("b.exr"), dir.join("c.exr"));
    out_exr::write_frame(&a, &test_frame(8, 6)).unwrap();
    out_exr::write_frame(&b, &test_frame(8, 8)).unwrap();
    let mut no_crossings = test_frame(8, 6);
    no_crossings.pixels.iter_mut().for_each(|p| p.crossings = -1);
    out_exr::write_frame(&c, &no_crossings).unwrap();

    let (code, out, err) = run(&[s(&a), s(&b)]);
    assert_eq!(code, 2);
    assert!(out.is_empty());
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("8x6")
            && err.contains("8x8")
            && err.contains("a.exr")
            && err.contains("b.exr"),
        "{err}"
    );

    let (code, _, err) = run(&[s(&a), s(&c)]);
    assert_eq!(code, 2);
    assert!(
        err.contains("channel mismatch") && err.contains("only in") && err.contains("crossings"),
        "{err}"
    );
    // A subset that both have is fine; one that B lacks is named.
    assert_eq!(run(&[s(&a), s(&c), "--channels", "R,G,B,A,Z"]).0, 0);
    let (code, _, err) = run(&[s(&a), s(&c), "--channels", "R,crossings"]);
    assert_eq!(code, 2);
    assert!(err.contains("c.exr") && err.contains("\"crossings\""), "{err}");

    let missing = dir.join("missing.exr");
    let (code, _, err) = run(&[s(&a), s(&missing)]);
    assert_eq!(code, 2);
    assert!(err.contains("missing.exr"), "{err}");

    let garbage = dir.join("garbage.exr");
    std::fs::write(&garbage, b"nope").unwrap();
    let (code, _, err) = run(&[s(&garbage), s(&a)]);
    assert_eq!(code, 2);
    assert!(err.contains("garbage.exr"), "{err}");

    // Negative thresholds are usage errors (clap exits 2 for those).
    let parsed = {
        #[derive(Parser)]
        struct Cli {
            #[command(flatten)]
            args: CompareArgs,
        }
        Cli::try_parse_from(["compare", "a.exr", "b.exr", "--fail", "-1"])
    };
    assert_eq!(parsed.err().unwrap().exit_code(), 2);
}

/// A disk of radius `r` centred in a `size`² image; inside it every channel is a smooth
/// function of the pixel position (so the surface itself is the same in both images).
fn disk(path: &str, size: usize, r: f64, blob: Option<(usize, usize)>) -> ExrImage {
    let c = size as f64 / 2.0;
    let mut z = vec![f32::INFINITY; size * size];
    let mut red = vec![0.0; size * size];
    let mut alpha = vec![0.0; size * size];
    for y in 0..size {
        for x in 0..size {
            let (dx, dy) = (x as f64 + 0.5 - c, y as f64 + 0.5 - c);
            let hit = dx * dx + dy * dy <= r * r || blob == Some((x, y));
            if hit {
                let i = y * size + x;
                z[i] = (2.0 + 0.01 * dx + 0.02 * dy) as f32;
                red[i] = (0.5 + 0.01 * dy) as f32;
                alpha[i] = 1.0;
            }
        }
    }
    image(path, size, size, &[("R", red), ("A", alpha), ("Z", z)])
}

#[test]
fn shift_window_forgives_a_one_pixel_silhouette_shift_only_when_enabled() {
    let a = disk("a", 32, 10.0, None);
    let b = disk("b", 32, 10.7, None);
    let r = compare(&a, &b, &no_flip()).unwrap();
    assert_eq!(r.verdict, Verdict::Fail);
    let ring = r.failing_pixels;
    assert!(ring > 10, "{ring}");
    assert_eq!(r.coverage.as_ref().unwrap().only_b, ring);

    let shift = Thresholds { shift: true, ..no_flip() };
    let r = compare(&a, &b, &shift).unwrap();
    assert_eq!(r.forgiven_pixels, ring);
    assert_eq!(r.failing_pixels, 0);
    assert_eq!(r.verdict, Verdict::Warn, "forgiven pixels still warn");

    // A two-pixel shift is not forgiven.
    let r = compare(&a, &disk("b", 32, 12.5, None), &shift).unwrap();
    assert_eq!(r.verdict, Verdict::Fail);
    assert!(r.failing_pixels > 0);

    // Nor is a blob far from the silhouette.
    let r = compare(&a, &disk("b", 32, 10.0, Some((2, 2))), &shift).unwrap();
    assert_eq!((r.verdict, r.failing_pixels, r.forgiven_pixels), (Verdict::Fail, 1, 0));

    // Value-matching rule (no coverage channel): an edge between two constant regions that
    // moved by one pixel.
    let edge =
        |at: usize| -> Vec<f32> { (0..64).map(|i| if i % 8 < at { 1.0 } else { 0.0 }).collect() };
    let a = image("a", 8, 8, &[("Y", edge(4))]);
    let b = image("b", 8, 8, &[("Y", edge(5))]);
    assert_eq!(compare(&a, &b, &no_flip()).unwrap().failing_pixels, 8);
    let r = compare(&a, &b, &shift).unwrap();
    assert_eq!((r.failing_pixels, r.forgiven_pixels), (0, 8), "{r}");
    assert_eq!(
        compare(&a, &image("b", 8, 8, &[("Y", edge(6))]), &shift).unwrap().verdict,
        Verdict::Fail
    );
}

#[test]
fn flip_is_reported_and_gates_only_when_asked() {
    let size = 24;
    let grey = |v: f32| {
        image(
            "x",
            size,
            size,
            &[
                ("R", vec![v; size * size]),
                ("G", vec![v; size * size]),
                ("B", vec![v; size * size]),
            ],
        )
    };
    let (a, b) = (grey(0.5), grey(0.52));
    let t = Thresholds { fail: 0.1, warn: 0.1, ..Thresholds::default() };
    let r = compare(&a, &a, &t).unwrap();
    assert_eq!(r.flip.unwrap().mean, 0.0);
    let r = compare(&a, &b, &t).unwrap();
    let f = r.flip.unwrap();
    assert!(f.mean > 0.0 && f.max >= f.p99 && f.p99 >= f.p50, "{f:?}");
    assert_eq!(r.verdict, Verdict::Pass);
    let gated = Thresholds { flip_fail: Some(f64::from(f.mean) / 2.0), ..t.clone() };
    let r = compare(&a, &b, &gated).unwrap();
    assert_eq!(r.verdict, Verdict::Fail);
    assert!(r.verdict_line().contains("FLIP mean"), "{}", r.verdict_line());

    // No beauty: FLIP is skipped with a note, and gating on it fails.
    let z = one("z", "Z", vec![1.0; 4]);
    let r = compare(&z, &z, &Thresholds::default()).unwrap();
    assert!(r.flip.is_none() && r.flip_note.is_some());
    assert_eq!(r.verdict, Verdict::Identical);
    let r = compare(&z, &z, &gated).unwrap();
    assert_eq!(r.verdict, Verdict::Fail);
}

#[test]
fn diff_exr_and_heat_map_png_are_written() {
    let dir = scratch("cmp-diff");
    let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
    let frame = test_frame(6, 5);
    let mut other = frame.clone();
    other.pixels[8].rgba[1] += 0.25; // x = 2, y = 1: fails
    other.pixels[9].rgba[1] += 1e-5; // x = 3, y = 1: warns
    other.pixels[0].depth = 7.0; // a miss in A, a hit in B: inf vs finite
    out_exr::write_frame(&a, &frame).unwrap();
    out_exr::write_frame(&b, &other).unwrap();
    let (diff, png) = (dir.join("d.exr"), dir.join("d.png"));
    let (code, out, err) = run(&[s(&a), s(&b), "--diff", s(&diff), "--png", s(&png), "--shift"]);
    assert_eq!(code, 1, "{out}{err}");

    let d = out_exr::read(&diff).unwrap();
    assert_eq!((d.width, d.height), (6, 5));
    let g = &d.channel("diff.G").unwrap().values;
    assert!((g[8] - 0.25).abs() < 1e-6 && g[0] == 0.0);
    let z = &d.channel("diff.Z").unwrap().values;
    assert_eq!(z[0], f32::NEG_INFINITY, "B - A = 7 - inf");
    assert_eq!(z[1], 0.0, "equal values give 0");
    let fail = &d.channel("fail").unwrap().values;
    assert_eq!(fail[8], 1.0);
    assert_eq!(fail[9], 0.0);
    assert!(d.channel("forgiven").is_some() && d.channel("ratio").is_some());
    assert!(d.channel("flip").is_some());
    assert!(d.attribute("isoview/compare/verdict").unwrap().starts_with("FAIL"));
    assert_eq!(d.channels.len(), 18 + 4);

    let heat = image::open(&png).unwrap().to_rgba8();
    assert_eq!(heat.dimensions(), (6, 5));
    assert_eq!(heat.get_pixel(5, 4).0, [0, 0, 0, 255], "equal pixel is black");
    let failing = heat.get_pixel(2, 1).0;
    let warning = heat.get_pixel(3, 1).0;
    assert_ne!(failing, warning);
    assert!(failing[0] > 200 && failing[1] > 200, "failing is pale yellow: {failing:?}");
    assert!(warning[..3].iter().any(|&c| c > 0), "{warning:?}");
}

#[test]
fn compares_isoview_output_with_a_half_float_piz_copy() {
    use exr::prelude::*;
    let dir = scratch("cmp-half");
    let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
    out_exr::write_frame(&a, &test_frame(12, 9)).unwrap();
    // Re-encode every channel as half with PIZ, as another tool might.
    let img = out_exr::read(&a).unwrap();
    let list: Vec<AnyChannel<FlatSamples>> = img
        .channels
        .iter()
        .map(|c| {
            AnyChannel::new(
                c.name.as_str(),
                FlatSamples::F16(c.values.iter().map(|&v| f16::from_f32(v)).collect()),
            )
        })
        .collect();
    let encoding = Encoding {
        compression: Compression::PIZ,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    Image::from_layer(Layer::new(
        (12, 9),
        LayerAttributes::default(),
        encoding,
        AnyChannels::sort(SmallVec::from_vec(list)),
    ))
    .write()
    .to_file(&b)
    .unwrap();
    assert_eq!(run(&[s(&a), s(&b)]).0, 1, "half rounding is over 1e-4");
    let (code, out, _) = run(&[s(&a), s(&b), "--fail-relative", "1e-3", "--warn", "1"]);
    assert_eq!(code, 0, "{out}");
    // The state of every pixel is available for tools.
    let r =
        compare(&out_exr::read(&a).unwrap(), &out_exr::read(&b).unwrap(), &Thresholds::default())
            .unwrap();
    assert!(r.maps.unwrap().pixels.contains(&PixelState::Fail));
}

#[test]
fn tiny_and_thin_images_compare() {
    for (w, h) in [(1, 1), (1, 7), (9, 1), (2, 2)] {
        let n = w * h;
        let rgb = |v: f32| {
            image(
                "x",
                w,
                h,
                &[("R", vec![v; n]), ("G", vec![v; n]), ("B", vec![v; n]), ("Z", vec![1.0; n])],
            )
        };
        let shift = Thresholds { shift: true, ..Thresholds::default() };
        let r = compare(&rgb(0.2), &rgb(0.3), &shift).unwrap();
        assert_eq!(r.verdict, Verdict::Fail, "{w}x{h}");
        assert!(r.flip.is_some(), "{w}x{h}");
    }
}

#[test]
fn new_channels_in_b_are_a_mismatch_unless_asked_for() {
    let dir = scratch("cmp-new-channels");
    let (old, new) = (dir.join("old.exr"), dir.join("new.exr"));
    let mut no_crossings = test_frame(8, 6);
    no_crossings.pixels.iter_mut().for_each(|p| p.crossings = -1);
    out_exr::write_frame(&old, &no_crossings).unwrap();
    out_exr::write_frame(&new, &test_frame(8, 6)).unwrap();
    // Today's contract: different channel sets are bad input.
    let (code, _, err) = run(&[s(&old), s(&new)]);
    assert_eq!(code, 2);
    assert!(err.contains("channel mismatch") && err.contains("crossings"), "{err}");
    // --new-channels: B's extra channel is named, the others compared (equal here).
    let (code, out, err) = run(&[s(&old), s(&new), "--new-channels"]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("not in A, not compared (new channels): crossings"), "{out}");
    assert!(out.contains("17 channels compared") && out.contains("PASS: identical"), "{out}");
    // A channel only A has is still a mismatch.
    let (code, _, err) = run(&[s(&new), s(&old), "--new-channels"]);
    assert_eq!(code, 2);
    assert!(err.contains("channel mismatch") && err.contains("crossings"), "{err}");
    // The compared channels still fail on a difference.
    let mut moved = test_frame(8, 6);
    moved.pixels[9].depth += 0.5;
    out_exr::write_frame(&new, &moved).unwrap();
    assert_eq!(run(&[s(&old), s(&new), "--new-channels"]).0, 1);
}
