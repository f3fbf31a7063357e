//! `compare` band by band: the same report and output files, byte for byte, as the whole-image
//! comparison (`compare::compare`, `write_diff_exr`, `write_heat_map_png`: the same code with
//! one band, whose outputs `one_copy` pins) for any band height, any EXR layout the reader
//! takes, and every threshold option; and its peak memory, measured on the child process, does
//! not grow with the image.

use std::path::Path;

use exr::prelude::*;
use isoview::compare::{
    compare, compare_files_in_bands, write_diff_exr, write_heat_map_png, Outputs, Report,
    Thresholds,
};
use isoview::output::exr as out_exr;
use isoview::output::exr::PlaneStream;

use crate::common::{assert_fails, isoview, scratch};

/// How a test image is stored.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Layout {
    /// isoview's own: f32, ZIP, 16-line blocks.
    Isoview,
    /// half floats, PIZ, 8 x 8 tiles.
    HalfTiles,
    /// f32, RLE scan lines stored bottom to top.
    Decreasing,
    /// Data window smaller than and offset into the display window (outside reads 0).
    Window,
    /// Two parts, `beauty` (R, G, B, A) and `aux` (the rest): `<part>.<channel>` names.
    TwoParts,
}

/// Deterministic noise in [0, 1).
fn noise(i: usize, seed: u32) -> f32 {
    let mut x = (i as u32).wrapping_mul(2_654_435_761) ^ seed.wrapping_mul(40_503);
    x ^= x >> 13;
    x = x.wrapping_mul(0x5bd1_e995);
    x ^= x >> 15;
    (x >> 8) as f32 / (1u32 << 24) as f32
}

/// A render-like picture: a disc (hit: finite Z, A = 1) on a miss background (Z = inf), with
/// colour, a normal channel with NaNs and an integer `steps`. `b` is the image under test:
/// the disc moved by a pixel, small noise in R, a few large errors, NaN and inf mismatches.
pub(crate) fn picture(w: usize, h: usize, b: bool) -> Vec<(String, Vec<f32>)> {
    let n = w * h;
    let (cx, cy, r) =
        (w as f32 * 0.5 + if b { 1.0 } else { 0.0 }, h as f32 * 0.45, w.min(h) as f32 * 0.35);
    let hit = |i: usize| {
        let (x, y) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
        (x - cx).powi(2) + (y - cy).powi(2) < r * r
    };
    let mut ch: Vec<(String, Vec<f32>)> = Vec::new();
    let col = |k: u32| -> Vec<f32> {
        (0..n)
            .map(|i| {
                let base = if hit(i) { 0.2 + 0.7 * noise(i, k) } else { 0.05 };
                let jitter = if b && k == 1 && i % 3 == 0 { 3e-6 } else { 0.0 };
                let big = if b && k == 2 && i % 97 == 5 { 0.25 } else { 0.0 };
                base + jitter + big
            })
            .collect()
    };
    ch.push(("R".into(), col(1)));
    ch.push(("G".into(), col(2)));
    ch.push(("B".into(), col(3)));
    ch.push(("A".into(), (0..n).map(|i| if hit(i) { 1.0 } else { 0.0 }).collect()));
    ch.push((
        "Z".into(),
        (0..n).map(|i| if hit(i) { 2.0 + (i % w) as f32 * 0.01 } else { f32::INFINITY }).collect(),
    ));
    ch.push((
        "N.X".into(),
        (0..n)
            .map(|i| match i % 11 {
                0 => f32::NAN,
                4 if b => f32::NAN, // NaN against a number
                7 if b => f32::NEG_INFINITY,
                _ => noise(i, 9) * 2.0 - 1.0 + if b && i % 5 == 0 { 2e-4 } else { 0.0 },
            })
            .collect(),
    ));
    ch.push((
        "steps".into(),
        (0..n)
            .map(|i| (noise(i, 4) * 40.0).floor() + if b && i % 13 == 1 { 1.0 } else { 0.0 })
            .collect(),
    ));
    ch
}

/// Writes `channels` (each `w * h`) to `path` in `layout`.
pub(crate) fn write(
    path: &Path,
    w: usize,
    h: usize,
    channels: &[(String, Vec<f32>)],
    layout: Layout,
) {
    if let Layout::Isoview = layout {
        out_exr::write_channels(path, w, h, channels.to_vec(), &[]).unwrap();
        return;
    }
    let any = |list: &[&(String, Vec<f32>)], half: bool, x0: usize, y0: usize| {
        let list: Vec<AnyChannel<FlatSamples>> = list
            .iter()
            .map(|(name, v)| {
                let crop: Vec<f32> =
                    (y0..h).flat_map(|y| (x0..w).map(move |x| v[y * w + x])).collect();
                let samples = if half {
                    FlatSamples::F16(crop.iter().map(|&x| f16::from_f32(x)).collect())
                } else {
                    FlatSamples::F32(crop)
                };
                AnyChannel::new(name.as_str(), samples)
            })
            .collect();
        AnyChannels::sort(SmallVec::from_vec(list))
    };
    let all: Vec<&(String, Vec<f32>)> = channels.iter().collect();
    let enc = |compression, blocks, line_order| Encoding { compression, blocks, line_order };
    match layout {
        Layout::Isoview => unreachable!(),
        Layout::HalfTiles => Image::from_layer(Layer::new(
            (w, h),
            LayerAttributes::default(),
            enc(Compression::PIZ, Blocks::Tiles(Vec2(8, 8)), LineOrder::Increasing),
            any(&all, true, 0, 0),
        ))
        .write()
        .to_file(path)
        .unwrap(),
        Layout::Decreasing => Image::from_layer(Layer::new(
            (w, h),
            LayerAttributes::default(),
            enc(Compression::RLE, Blocks::ScanLines, LineOrder::Decreasing),
            any(&all, false, 0, 0),
        ))
        .write()
        .to_file(path)
        .unwrap(),
        Layout::Window => {
            let (x0, y0) = ((w / 4).min(w - 1), (h / 3).min(h - 1));
            let mut layer = Layer::new(
                (w - x0, h - y0),
                LayerAttributes::default(),
                enc(Compression::ZIP1, Blocks::ScanLines, LineOrder::Increasing),
                any(&all, false, x0, y0),
            );
            layer.attributes.layer_position = Vec2(x0 as i32, y0 as i32);
            let mut image = Image::from_layer(layer);
            image.attributes.display_window = IntegerBounds::new((0, 0), (w, h));
            image.write().to_file(path).unwrap()
        }
        Layout::TwoParts => {
            let (beauty, aux): (Vec<_>, Vec<_>) =
                all.iter().partition(|(n, _)| ["R", "G", "B", "A"].contains(&n.as_str()));
            let layer = |name: &str, list: &[&(String, Vec<f32>)], blocks| {
                Layer::new(
                    (w, h),
                    LayerAttributes::named(name),
                    enc(Compression::ZIP16, blocks, LineOrder::Increasing),
                    any(list, false, 0, 0),
                )
            };
            let layers = SmallVec::from_vec(vec![
                layer("beauty", &beauty, Blocks::ScanLines),
                layer("aux", &aux, Blocks::Tiles(Vec2(16, 4))),
            ]);
            Image::from_layers(ImageAttributes::new(IntegerBounds::from_dimensions((w, h))), layers)
                .write()
                .to_file(path)
                .unwrap()
        }
    }
}

/// The report's fields, as text (Debug prints floats exactly), without the per-pixel maps
/// only the whole-image comparison keeps.
fn fields(r: &Report) -> String {
    let mut r = r.clone();
    r.maps = None;
    format!("{r:?}\n{r}")
}

/// Compares `a` with `b` whole and band by band (several band heights) under `t`: reports,
/// difference EXRs and heat maps must be equal, byte for byte.
fn check(dir: &Path, a: &Path, b: &Path, t: &Thresholds, what: &str) {
    let (ia, ib) = (out_exr::read(a).unwrap(), out_exr::read(b).unwrap());
    let whole = compare(&ia, &ib, t).unwrap();
    let (diff, png) = (dir.join("whole.exr"), dir.join("whole.png"));
    write_diff_exr(&diff, &ia, &ib, &whole).unwrap();
    write_heat_map_png(&png, &whole).unwrap();
    let (diff_bytes, png_bytes) = (std::fs::read(&diff).unwrap(), std::fs::read(&png).unwrap());
    for rows in [1, 3, 16, 1000] {
        let (sd, sp) = (dir.join("band.exr"), dir.join("band.png"));
        let outputs = Outputs { diff: Some(&sd), png: Some(&sp) };
        let (streamed, err) = compare_files_in_bands(a, b, t, outputs, rows).unwrap();
        assert!(err.is_none(), "{what}: {err:?}");
        assert_eq!(fields(&streamed), fields(&whole), "{what}, bands of {rows}");
        assert!(std::fs::read(&sd).unwrap() == diff_bytes, "{what}, bands of {rows}: diff EXR");
        assert!(std::fs::read(&sp).unwrap() == png_bytes, "{what}, bands of {rows}: PNG");
    }
}

#[test]
fn band_by_band_equals_the_whole_image_comparison() {
    let dir = scratch("cmp-stream-eq");
    let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
    let variants: Vec<(&str, Thresholds)> = vec![
        ("default", Thresholds::default()),
        ("shift", Thresholds { shift: true, ..Thresholds::default() }),
        // Without FLIP's 10-row halo: only the shift window's one row.
        ("shift, no FLIP", Thresholds { shift: true, flip: false, ..Thresholds::default() }),
        (
            "relative, hard, percentages",
            Thresholds {
                fail_relative: 1e-3,
                hard_fail: Some(0.3),
                fail_percent: 2.0,
                warn_percent: 5.0,
                ..Thresholds::default()
            },
        ),
        ("flip gate", Thresholds { flip_fail: Some(0.01), shift: true, ..Thresholds::default() }),
    ];
    for (w, h) in [(37, 41), (23, 18), (16, 32)] {
        for layout in [Layout::Isoview, Layout::HalfTiles, Layout::Decreasing, Layout::Window] {
            write(&a, w, h, &picture(w, h, false), layout);
            write(&b, w, h, &picture(w, h, true), layout);
            for (name, t) in &variants {
                check(&dir, &a, &b, t, &format!("{w}x{h} {layout:?} {name}"));
            }
            // An image against itself: identical.
            check(&dir, &a, &a, &Thresholds::default(), &format!("{w}x{h} {layout:?} same"));
        }
    }
    // Two parts: no plain R, G, B, so FLIP gives its note; a subset of channels.
    let (w, h) = (29, 21);
    write(&a, w, h, &picture(w, h, false), Layout::TwoParts);
    write(&b, w, h, &picture(w, h, true), Layout::TwoParts);
    check(&dir, &a, &b, &Thresholds::default(), "two parts");
    let only =
        Thresholds { only: Some(vec!["aux.Z".into(), "beauty.G".into()]), ..Thresholds::default() };
    check(&dir, &a, &b, &only, "two parts, two channels");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn tiny_odd_images_and_new_channels_compare_the_same_band_by_band() {
    let dir = scratch("cmp-stream-tiny");
    let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
    for (w, h) in [(1, 1), (1, 7), (9, 1), (2, 3), (5, 17)] {
        write(&a, w, h, &picture(w, h, false), Layout::Isoview);
        write(&b, w, h, &picture(w, h, true), Layout::Isoview);
        for t in [Thresholds::default(), Thresholds { shift: true, ..Thresholds::default() }] {
            check(&dir, &a, &b, &t, &format!("{w}x{h}"));
        }
    }
    // B has a channel A lacks.
    let (w, h) = (13, 10);
    write(&a, w, h, &picture(w, h, false), Layout::Isoview);
    let mut more = picture(w, h, true);
    more.push(("extra".into(), vec![0.5; w * h]));
    write(&b, w, h, &more, Layout::Isoview);
    check(&dir, &a, &b, &Thresholds { new_channels: true, ..Thresholds::default() }, "new");
    // Without FLIP.
    check(
        &dir,
        &a,
        &b,
        &Thresholds { flip: false, new_channels: true, ..Thresholds::default() },
        "no flip",
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn streamed_compare_refuses_bad_input_in_one_line() {
    let dir = scratch("cmp-stream-bad");
    let (a, b, c) = (dir.join("a.exr"), dir.join("b.exr"), dir.join("c.exr"));
    write(&a, 20, 18, &picture(20, 18, false), Layout::Isoview);
    write(&b, 20, 17, &picture(20, 17, false), Layout::Isoview);
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let out = isoview(&["compare", &s(&a), &s(&b)], &[]);
    assert_fails(&out, 2, &["size mismatch", "20x18", "20x17"]);
    // A file cut short in its pixel data: one line naming it, no output written.
    let bytes = std::fs::read(&a).unwrap();
    std::fs::write(&c, &bytes[..bytes.len() - 200]).unwrap();
    let diff = dir.join("d.exr");
    let out = isoview(&["compare", &s(&a), &s(&c), "--diff", &s(&diff)], &[]);
    assert_fails(&out, 2, &["c.exr"]);
    assert!(!diff.exists());
    // Channel mismatch.
    let mut fewer = picture(20, 18, false);
    fewer.pop();
    write(&b, 20, 18, &fewer, Layout::Isoview);
    let out = isoview(&["compare", &s(&a), &s(&b)], &[]);
    assert_fails(&out, 2, &["channel mismatch", "steps"]);
    // An output that cannot be written: the report is printed, then one line, exit 2.
    let out = isoview(&["compare", &s(&a), &s(&a), "--png", &s(&dir.join("no/such/dir.png"))], &[]);
    assert_fails(&out, 2, &["dir.png"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("PASS: identical"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A `w` x `h` picture with R, G, B, A, Z written row by row (cheap at any size).
fn big_exr(path: &Path, w: usize, h: usize, seed: u32) {
    let names: Vec<String> = ["R", "G", "B", "A", "Z"].iter().map(|s| s.to_string()).collect();
    let mut s = PlaneStream::create(path, w, h, &names, &[]).unwrap();
    for y0 in (0..h).step_by(64) {
        let y1 = (y0 + 64).min(h);
        let planes: Vec<Vec<f32>> = (0..5)
            .map(|c| {
                (y0 * w..y1 * w)
                    .map(|i| {
                        let (x, y) = (i % w, i / w);
                        let v = ((x / 37 + y / 23 + c) % 7) as f32 / 7.0;
                        if seed == 1 && (x * 7 + y * 3) % 101 == 0 {
                            v + 0.01
                        } else {
                            v
                        }
                    })
                    .collect()
            })
            .collect();
        let refs: Vec<&[f32]> = planes.iter().map(Vec::as_slice).collect();
        s.push_rows(&refs).unwrap();
    }
    s.finish().unwrap();
}

/// 4096 x 2048 against 64 x 32: the whole-image comparison held both images (5 channels), the
/// per-pixel maps and FLIP's working images of the whole picture (docs/large-data.md: over
/// 1 GiB here); band by band, memory grows by a few bands' worth.
#[test]
fn a_large_compare_stays_in_bounded_memory() {
    let dir = scratch("cmp-stream-peak");
    let run = |w: usize, h: usize| {
        let (a, b) = (dir.join(format!("a{w}.exr")), dir.join(format!("b{w}.exr")));
        let start = std::time::Instant::now();
        big_exr(&a, w, h, 0);
        big_exr(&b, w, h, 1);
        let made = start.elapsed().as_secs_f64();
        let (diff, png) = (dir.join(format!("d{w}.exr")), dir.join(format!("d{w}.png")));
        let (code, mib) = crate::render::stream::peak_rss_mib(&[
            "compare",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--diff",
            diff.to_str().unwrap(),
            "--png",
            png.to_str().unwrap(),
        ]);
        let compared = start.elapsed().as_secs_f64() - made;
        eprintln!("{w}x{h}: inputs written in {made:.1} s, compared in {compared:.1} s");
        assert_eq!(code, 1, "{w}x{h}: the pictures differ");
        assert_eq!(out_exr::read(&diff).unwrap().width, w);
        mib
    };
    let small = run(64, 32);
    let large = run(4096, 2048);
    let image_mib = 4096.0 * 2048.0 * 5.0 * 4.0 / (1 << 20) as f64;
    eprintln!("compare peak RSS {small:.0} MiB at 64x32, {large:.0} MiB at 4096x2048 (one image: {image_mib:.0} MiB)");
    // Bands of 128 rows at this width: about 80 MiB. Holding both images alone is 320 MiB.
    assert!(large - small < 200.0, "peak RSS grew {:.0} MiB", large - small);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Fifth attack pass, left over: a band held `band_rows(width)` rows of every compared channel,
/// so memory grew with width x channel count (512 x 256 with 512 channels: two bands of 256 rows
/// of 1 MiB, over 512 MiB). Bands now shrink to `BAND_BYTES` of rows, so the peak grows by
/// about two bands, a block row and a decoded block an image, whatever the channel count.
#[test]
fn rows_of_many_channels_compare_in_bounded_memory() {
    let dir = scratch("cmp-wide-channels");
    let run = |channels: usize| {
        let names: Vec<String> = (0..channels).map(|i| format!("c{i:03}")).collect();
        let (w, h) = (512, 256);
        let (a, b) = (dir.join(format!("a{channels}.exr")), dir.join(format!("b{channels}.exr")));
        for (path, bump) in [(&a, 0.0f32), (&b, 0.25)] {
            let mut s = PlaneStream::create(path, w, h, &names, &[]).unwrap();
            for y in 0..h {
                let planes: Vec<Vec<f32>> = (0..channels)
                    .map(|c| {
                        let mut row = vec![c as f32; w];
                        if y == h - 1 && c == channels - 1 {
                            row[w - 1] += bump; // one pixel of the last channel differs
                        }
                        row
                    })
                    .collect();
                let refs: Vec<&[f32]> = planes.iter().map(Vec::as_slice).collect();
                s.push_rows(&refs).unwrap();
            }
            s.finish().unwrap();
        }
        let (code, mib) = crate::render::stream::peak_rss_mib(&[
            "compare",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--no-flip",
        ]);
        assert_eq!(code, 1, "{channels} channels: the last channel differs");
        let _ = (std::fs::remove_file(&a), std::fs::remove_file(&b));
        mib
    };
    let few = run(4);
    let many = run(512);
    eprintln!("compare peak RSS {few:.0} MiB with 4 channels, {many:.0} MiB with 512 (512 x 256)");
    // Per image: 64 MiB of band, 16 more rows of a block row and a block decoded (16 MiB
    // each); and 64 channels' percentile tables (1.5 MiB each). Bands of 256 rows were 512 MiB.
    let bound = 2.0 * 96.0 + 96.0 + 100.0;
    assert!(many - few < bound, "peak RSS grew {:.0} MiB", many - few);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Fifth attack pass: every channel's relative-error percentile held three 64 Ki-entry tables
/// (1.5 MiB) at once, so a 1x1 EXR of 5000 channels (129 KB) aborted under a 4 GB limit
/// ("memory allocation of 524288 bytes failed", SIGABRT). The tables are now built for a
/// batch of channels at a time: 3000 channels compare under 1 GiB, with the same report.
#[test]
fn many_channels_compare_in_bounded_memory() {
    let dir = scratch("cmp-many-channels");
    let names: Vec<String> = (0..3000).map(|i| format!("c{i:04}")).collect();
    let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
    for (path, bump) in [(&a, 0.0f32), (&b, 0.5)] {
        let mut s = PlaneStream::create(path, 1, 1, &names, &[]).unwrap();
        // The last channel differs: its percentile is found in the last batch.
        let planes: Vec<Vec<f32>> =
            (0..names.len()).map(|i| vec![i as f32 + if i == 2999 { bump } else { 0.0 }]).collect();
        let refs: Vec<&[f32]> = planes.iter().map(Vec::as_slice).collect();
        s.push_rows(&refs).unwrap();
        s.finish().unwrap();
    }
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_isoview"));
    cmd.args(["compare", a.to_str().unwrap(), b.to_str().unwrap(), "--no-flip"]);
    crate::common::with_memory_limit(&mut cmd, 1);
    let o = cmd.output().unwrap();
    let (out, err) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert_eq!(o.status.code(), Some(1), "stderr: {}", &err[..err.len().min(2000)]);
    assert!(out.contains("c2999"), "{out}");
    let report =
        compare_files_in_bands(&a, &b, &Thresholds::default(), Outputs::default(), 1).unwrap().0;
    let last = report.channels.iter().find(|c| c.name == "c2999").unwrap();
    assert_eq!((last.max_abs, last.rel_p99 > 0.0), (0.5, true));
    assert!(report.channels.iter().filter(|c| c.name != "c2999").all(|c| c.identical));
    std::fs::remove_dir_all(&dir).unwrap();
}
