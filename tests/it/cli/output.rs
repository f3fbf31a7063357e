//! EXR and PNG output: round trips, determinism, atomicity, and reading EXRs from other writers.

use std::path::Path;

use exr::prelude::*;
use glam::DVec3;
use isoview::frame::{Channel, Frame, FrameInfo, Pixel};
use isoview::output::exr::{self as out_exr, attr, SampleKind};
use isoview::output::{atomic, png};

pub use crate::common::scratch;

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn info() -> FrameInfo {
    FrameInfo {
        scene: "scenes/tôrus.toml".into(),
        eye: DVec3::new(2.2, 1.6, 2.4),
        target: DVec3::new(0.0, 0.1, 0.0),
        up: DVec3::Y,
        ortho_height: None,
        fov_y_deg: 40.0,
        isovalue: 0.25,
        method: "fixed-step".into(),
        time: 1.5,
        device: "llvmpipe (LLVM 15.0.6, 256 bits)".into(),
        driver: "Mesa 22.3.6".into(),
        extra: vec![
            ("steps".into(), "200".into()),
            ("newton_steps".into(), "10".into()),
            ("colormap.range".into(), "[0, 1]".into()),
        ],
        legend: None,
    }
}

/// A frame whose every channel varies per pixel; the left column misses.
pub fn test_frame(w: u32, h: u32) -> Frame {
    let mut pixels = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as f32;
            pixels.push(if x == 0 {
                Pixel::miss([0.1, 0.2, 0.3, 0.0], 3.0 + i)
            } else {
                Pixel {
                    rgba: [i / 64.0, 0.5 + x as f32 / 100.0, 1.0 - y as f32 / 50.0, 1.0],
                    normal: [0.6, -0.8, 0.0],
                    depth: 2.0 + i / 1000.0,
                    position: [x as f32 * 0.1, -(y as f32) * 0.2, 1e-7 * i],
                    steps: 10.0 + i,
                    cell: [x as i32, y as i32, 47],
                    crossings: (x % 3) as i32,
                    surface: (x % 2) as i32,
                    value: 0.5 - i,
                    pad: [0; 2],
                }
            });
        }
    }
    Frame { width: w, height: h, pixels, info: info() }
}

fn channel_of(p: &Pixel, name: &str) -> f32 {
    match name {
        "R" => p.rgba[0],
        "G" => p.rgba[1],
        "B" => p.rgba[2],
        "A" => p.rgba[3],
        "N.X" => p.normal[0],
        "N.Y" => p.normal[1],
        "N.Z" => p.normal[2],
        "Z" => p.depth,
        "P.X" => p.position[0],
        "P.Y" => p.position[1],
        "P.Z" => p.position[2],
        "steps" => p.steps,
        "cell.X" => p.cell[0] as f32,
        "cell.Y" => p.cell[1] as f32,
        "cell.Z" => p.cell[2] as f32,
        "crossings" => p.crossings as f32,
        "iso_index" => p.surface as f32,
        "color.value" => p.value,
        _ => unreachable!("{name}"),
    }
}

#[test]
fn exr_round_trip_of_every_channel_and_attribute() {
    let dir = scratch("roundtrip");
    let path = dir.join("frame.exr");
    let frame = test_frame(7, 5);
    out_exr::write_frame(&path, &frame).unwrap();
    let img = out_exr::read(&path).unwrap();

    assert_eq!((img.width, img.height), (7, 5));
    assert_eq!(img.parts, vec![String::new()]);
    let names: Vec<&str> = Channel::ALL.iter().map(|c| c.name()).collect();
    let mut want = names.clone();
    want.sort();
    let got: Vec<&str> = img.channel_names().collect();
    assert_eq!(got, want, "all 18 channels, stored sorted by name");
    for name in names {
        let c = img.channel(name).unwrap();
        assert_eq!(c.kind, SampleKind::F32, "{name}");
        for (i, p) in frame.pixels.iter().enumerate() {
            let (a, b) = (c.values[i], channel_of(p, name));
            assert!(a.to_bits() == b.to_bits(), "{name}[{i}]: {a} != {b}");
        }
    }
    // Miss column: Z = +inf, N = P = 0, cell = -1.
    assert_eq!(img.channel("Z").unwrap().values[0], f32::INFINITY);
    assert_eq!(img.channel("cell.Y").unwrap().values[7], -1.0);
    // Read back through the channel table: the same pixels, bit for bit.
    let back = img.frame_pixels().unwrap();
    let bits = |p: &[Pixel]| bytemuck::cast_slice::<Pixel, u32>(p).to_vec();
    assert_eq!(bits(&back), bits(&frame.pixels));

    let a = |name: &str| img.attribute(name).unwrap_or_else(|| panic!("no {name}"));
    assert_eq!(a(attr::VERSION), isoview::VERSION);
    assert_eq!(a(attr::SCENE), "scenes/tôrus.toml");
    assert_eq!(a(attr::EYE), "[2.2, 1.6, 2.4]");
    assert_eq!(a(attr::TARGET), "[0, 0.1, 0]");
    assert_eq!(a(attr::UP), "[0, 1, 0]");
    assert_eq!(a(attr::FOV_Y), "40");
    assert_eq!(a(attr::ISOVALUE), "0.25");
    assert_eq!(a(attr::METHOD), "fixed-step");
    assert_eq!(a(attr::TIME), "1.5");
    assert_eq!(a(attr::DEVICE), "llvmpipe (LLVM 15.0.6, 256 bits)");
    assert_eq!(a(attr::DRIVER), "Mesa 22.3.6");
    assert_eq!(a("isoview/extra/steps"), "200");
    assert_eq!(a("isoview/extra/newton_steps"), "10");
    assert_eq!(a("isoview/extra/colormap.range"), "[0, 1]");
    assert_eq!(a("software"), format!("isoview {}", isoview::VERSION));
    assert_eq!(a("compression"), "ZIP16");
    assert_eq!(a("lineOrder"), "Increasing");
    assert_eq!(a("dataWindow"), "(0 0) - (6 4)");
    assert_eq!(a("displayWindow"), "(0 0) - (6 4)");
    assert!(a("chromaticities").starts_with("red [0.64, 0.33]"));
    assert!(img.attribute("worldToCamera").is_some());
    assert!(img.attribute("worldToNDC").is_some());
}

#[test]
fn crossings_channel_only_when_some_pixel_counts_them() {
    let dir = scratch("crossings");
    let path = dir.join("f.exr");
    let mut frame = test_frame(4, 3);
    for p in &mut frame.pixels {
        p.crossings = -1;
    }
    out_exr::write_frame(&path, &frame).unwrap();
    let img = out_exr::read(&path).unwrap();
    assert!(img.channel("crossings").is_none());
    assert_eq!(img.channels.len(), 17);
    // Read back, a missing `crossings` is "not counted" again.
    let bits = |p: &[Pixel]| bytemuck::cast_slice::<Pixel, u32>(p).to_vec();
    assert_eq!(bits(&img.frame_pixels().unwrap()), bits(&frame.pixels));

    // The same for `iso_index` (-1: one surface) and `color.value` (NaN: no [color]).
    for p in &mut frame.pixels {
        (p.surface, p.value) = (-1, f32::NAN);
    }
    out_exr::write_frame(&path, &frame).unwrap();
    let img = out_exr::read(&path).unwrap();
    assert!(img.channel("iso_index").is_none() && img.channel("color.value").is_none());
    assert_eq!(img.channels.len(), 15);
    assert_eq!(bits(&img.frame_pixels().unwrap()), bits(&frame.pixels));
}

#[test]
fn the_channel_table_matches_the_contract() {
    // The interface contract's channels, names, order of the Pixel members and miss values.
    let rows: Vec<(&str, &str)> =
        Channel::ALL.iter().map(|c| (c.name(), c.class().name())).collect();
    assert_eq!(
        rows,
        [
            ("R", "colour"),
            ("G", "colour"),
            ("B", "colour"),
            ("A", "colour"),
            ("N.X", "normal"),
            ("N.Y", "normal"),
            ("N.Z", "normal"),
            ("Z", "depth"),
            ("P.X", "position"),
            ("P.Y", "position"),
            ("P.Z", "position"),
            ("steps", "integer"),
            ("cell.X", "integer"),
            ("cell.Y", "integer"),
            ("cell.Z", "integer"),
            ("crossings", "integer"),
            ("iso_index", "integer"),
            ("color.value", "other"),
        ]
    );
    let miss = Pixel::miss([0.1, 0.2, 0.3, 0.4], 9.0);
    let bits = |p: &Pixel| bytemuck::bytes_of(p).to_vec();
    assert_eq!(
        bits(&miss),
        bits(&Pixel {
            rgba: [0.1, 0.2, 0.3, 0.4],
            normal: [0.0; 3],
            depth: f32::INFINITY,
            position: [0.0; 3],
            steps: 9.0,
            cell: [-1; 3],
            crossings: -1,
            surface: -1,
            value: f32::NAN,
            pad: [0; 2],
        })
    );
    for c in Channel::ALL {
        assert_eq!(c.get(&miss).to_bits(), channel_of(&miss, c.name()).to_bits(), "{c:?}");
    }
}

#[test]
fn an_exr_without_a_contract_channel_is_not_a_frame() {
    let dir = scratch("not-a-frame");
    let path = dir.join("f.exr");
    out_exr::write_channels(&path, 2, 1, vec![("R".into(), vec![0.0, 1.0])], &[]).unwrap();
    let err = out_exr::read(&path).unwrap().frame_pixels().unwrap_err().to_string();
    assert!(err.contains("f.exr") && err.contains("\"G\""), "{err}");
}

#[test]
fn exr_bytes_are_deterministic() {
    let dir = scratch("determinism");
    let mut frame = test_frame(33, 21);
    // Many custom attributes: their HashMap order differs between map instances.
    frame.info.extra = (0..12).map(|i| (format!("k{i}"), format!("v{i}"))).collect();
    let first = dir.join("a.exr");
    out_exr::write_frame(&first, &frame).unwrap();
    let reference = std::fs::read(&first).unwrap();
    for i in 0..6 {
        let p = dir.join(format!("b{i}.exr"));
        out_exr::write_frame(&p, &frame).unwrap();
        assert!(std::fs::read(&p).unwrap() == reference, "write {i} differs");
    }
    assert_eq!(out_exr::encode_frame(&first, &frame).unwrap(), reference);
}

#[test]
fn failed_write_leaves_the_previous_file_and_no_temporary() {
    let dir = scratch("atomic");
    let path = dir.join("out.exr");
    let old = test_frame(5, 4);
    out_exr::write_frame(&path, &old).unwrap();
    let old_bytes = std::fs::read(&path).unwrap();

    // An encoder error (a key OpenEXR cannot store) ...
    let mut bad = test_frame(6, 6);
    bad.info.extra.push(("bad\0key".into(), "x".into()));
    let msg = out_exr::write_frame(&path, &bad).unwrap_err().to_string();
    assert!(msg.contains("out.exr"), "{msg}");
    // ... and a write that dies half-way through the new file.
    let new_bytes = out_exr::encode_frame(&path, &test_frame(6, 6)).unwrap();
    let err = atomic::write_with(&path, |w| {
        use std::io::Write;
        w.write_all(&new_bytes[..new_bytes.len() / 2])?;
        Err(std::io::Error::other("disk full"))
    })
    .unwrap_err();
    assert!(err.to_string().contains("disk full"));
    // Same for the PNG writer: a mismatched frame is refused before anything is written.
    let png_path = dir.join("out.png");
    png::write_preview(&png_path, &old).unwrap();
    let png_bytes = std::fs::read(&png_path).unwrap();
    let mut short = old.clone();
    short.pixels.pop();
    assert!(png::write_preview(&png_path, &short).is_err());

    assert_eq!(std::fs::read(&path).unwrap(), old_bytes);
    assert_eq!(std::fs::read(&png_path).unwrap(), png_bytes);
    assert_eq!(out_exr::read(&path).unwrap().width, 5);
    assert_eq!(entries(&dir), vec!["out.exr", "out.png"]);
}

#[test]
fn png_preview_is_srgb_rgba8() {
    let dir = scratch("png");
    let path = dir.join("p.png");
    let mut frame = test_frame(3, 2);
    frame.pixels[1].rgba = [0.2159, 1.0, 5.0, 1.0];
    frame.pixels[2].rgba = [0.0, -1.0, 0.0031308, 0.5];
    png::write_preview(&path, &frame).unwrap();
    let img = image::open(&path).unwrap();
    assert_eq!(img.color(), image::ColorType::Rgba8);
    let img = img.to_rgba8();
    assert_eq!(img.dimensions(), (3, 2));
    assert_eq!(img.get_pixel(1, 0).0, [128, 255, 255, 255]);
    assert_eq!(img.get_pixel(2, 0).0, [0, 0, 10, 128]);
    // The miss pixel keeps its alpha of 0.
    assert_eq!(img.get_pixel(0, 0).0[3], 0);
}

fn write_with_exr_crate(path: &Path, layer: Layer<AnyChannels<FlatSamples>>) {
    Image::from_layer(layer).write().to_file(path).unwrap();
}

fn channels(list: Vec<AnyChannel<FlatSamples>>) -> AnyChannels<FlatSamples> {
    AnyChannels::sort(SmallVec::from_vec(list))
}

#[test]
fn reads_half_channels_layer_names_and_every_compression() {
    let dir = scratch("other-writers");
    let (w, h) = (19usize, 11usize);
    let n = w * h;
    let ramp: Vec<f32> = (0..n).map(|i| i as f32 * 0.25).collect();
    let half: Vec<f16> = ramp.iter().map(|&v| f16::from_f32(v)).collect();
    let ids: Vec<u32> = (0..n as u32).collect();
    for (i, compression) in [
        Compression::Uncompressed,
        Compression::RLE,
        Compression::ZIP1,
        Compression::ZIP16,
        Compression::PIZ,
        Compression::PXR24,
    ]
    .into_iter()
    .enumerate()
    {
        for blocks in [Blocks::ScanLines, Blocks::Tiles(Vec2(8, 8))] {
            let path = dir.join(format!("c{i}-{blocks:?}.exr").replace(['(', ')', ' ', ','], ""));
            let list = channels(vec![
                AnyChannel::new("R", FlatSamples::F16(half.clone())),
                AnyChannel::new("G", FlatSamples::F16(half.clone())),
                AnyChannel::new("depth.Z", FlatSamples::F32(ramp.clone())),
                AnyChannel::new("id", FlatSamples::U32(ids.clone())),
            ]);
            let encoding = Encoding { compression, blocks, line_order: LineOrder::Increasing };
            let mut attrs = LayerAttributes::default();
            attrs.other.insert(
                Text::from("note"),
                AttributeValue::Text(Text::from("from another writer")),
            );
            write_with_exr_crate(&path, Layer::new((w, h), attrs, encoding, list));

            let img = out_exr::read(&path).unwrap_or_else(|e| panic!("{compression:?}: {e}"));
            assert_eq!((img.width, img.height), (w, h));
            let names: Vec<&str> = img.channel_names().collect();
            assert_eq!(names, ["G", "R", "depth.Z", "id"], "{compression:?}");
            let r = img.channel("R").unwrap();
            assert_eq!(r.kind, SampleKind::F16);
            let z = img.channel("depth.Z").unwrap();
            let id = img.channel("id").unwrap();
            assert_eq!(id.kind, SampleKind::U32);
            for k in 0..n {
                assert_eq!(r.values[k], half[k].to_f32(), "{compression:?} R[{k}]");
                assert_eq!(id.values[k], k as f32);
                // PXR24 keeps 24 bits of a float.
                let tol = if compression == Compression::PXR24 { 1e-4 * ramp[k] } else { 0.0 };
                assert!((z.values[k] - ramp[k]).abs() <= tol, "{compression:?} Z[{k}]");
            }
            assert_eq!(img.attribute("note"), Some("from another writer"));
        }
    }
}

#[test]
fn data_window_is_placed_in_the_display_window() {
    let dir = scratch("windows");
    let path = dir.join("w.exr");
    // 2x2 data at (1, 1) in a 4x3 display window at (0, 0).
    let attrs = LayerAttributes { layer_position: Vec2(1, 1), ..LayerAttributes::default() };
    let layer = Layer::new(
        (2, 2),
        attrs,
        Encoding::UNCOMPRESSED,
        channels(vec![AnyChannel::new("Y", FlatSamples::F32(vec![1.0, 2.0, 3.0, 4.0]))]),
    );
    let image = Image::new(ImageAttributes::new(IntegerBounds::new(Vec2(0, 0), Vec2(4, 3))), layer);
    image.write().to_file(&path).unwrap();
    let img = out_exr::read(&path).unwrap();
    assert_eq!((img.width, img.height), (4, 3));
    assert_eq!(
        img.channel("Y").unwrap().values,
        vec![0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 2.0, 0.0, 0.0, 3.0, 4.0, 0.0]
    );
}

#[test]
fn multi_part_files_are_merged_with_part_names() {
    let dir = scratch("multipart");
    let path = dir.join("m.exr");
    let size = Vec2(3, 2);
    let beauty = Layer::new(
        size,
        LayerAttributes::named("beauty"),
        Encoding::SMALL_LOSSLESS,
        channels(vec![
            AnyChannel::new("R", FlatSamples::F32(vec![1.0; 6])),
            AnyChannel::new("G", FlatSamples::F32(vec![2.0; 6])),
        ]),
    );
    let depth = Layer::new(
        size,
        LayerAttributes::named("depth"),
        Encoding::SMALL_LOSSLESS,
        channels(vec![
            AnyChannel::new("Z", FlatSamples::F32(vec![3.0; 6])),
            AnyChannel::new("depth.ZBack", FlatSamples::F32(vec![4.0; 6])),
        ]),
    );
    Image::empty(ImageAttributes::new(IntegerBounds::from_dimensions(size)))
        .with_layer(beauty)
        .with_layer(depth)
        .write()
        .to_file(&path)
        .unwrap();
    let img = out_exr::read(&path).unwrap();
    assert_eq!(img.parts, vec!["beauty", "depth"]);
    let names: Vec<&str> = img.channel_names().collect();
    assert_eq!(names, ["beauty.G", "beauty.R", "depth.Z", "depth.ZBack"]);
    assert_eq!(img.channel("depth.Z").unwrap().values, vec![3.0; 6]);
    assert_eq!(img.attribute("name"), Some("beauty"));
}

#[test]
fn read_errors_name_the_file() {
    let dir = scratch("read-errors");
    let missing = dir.join("missing.exr");
    let msg = out_exr::read(&missing).unwrap_err().to_string();
    assert!(msg.contains("missing.exr"), "{msg}");

    let garbage = dir.join("garbage.exr");
    std::fs::write(&garbage, b"this is not an exr file at all").unwrap();
    let msg = out_exr::read(&garbage).unwrap_err().to_string();
    assert!(msg.contains("garbage.exr") && msg.contains("OpenEXR"), "{msg}");
    assert_eq!(msg.lines().count(), 1);

    // A valid file cut short.
    let cut = dir.join("cut.exr");
    let bytes = out_exr::encode_frame(&cut, &test_frame(16, 16)).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let msg = out_exr::read(&cut).unwrap_err().to_string();
    assert!(msg.contains("cut.exr"), "{msg}");
}

#[test]
fn write_channels_round_trip() {
    let dir = scratch("channels");
    let path = dir.join("c.exr");
    out_exr::write_channels(
        &path,
        2,
        2,
        vec![
            ("diff.R".into(), vec![1.0, -1.0, f32::NAN, f32::INFINITY]),
            ("fail".into(), vec![0.0, 1.0, 0.0, 1.0]),
        ],
        &[("isoview/compare/a".into(), "a.exr".into())],
    )
    .unwrap();
    let img = out_exr::read(&path).unwrap();
    let d = &img.channel("diff.R").unwrap().values;
    assert_eq!(&d[..2], &[1.0, -1.0]);
    assert!(d[2].is_nan() && d[3] == f32::INFINITY);
    assert_eq!(img.attribute("isoview/compare/a"), Some("a.exr"));
    // Mismatched lengths are refused.
    assert!(out_exr::write_channels(&path, 3, 3, vec![("x".into(), vec![0.0])], &[]).is_err());
}

/// Ctrl-C, SIGTERM or SIGHUP during a render left the writers' temporary files (the EXR's
/// is created before the render starts, up to the image's size) in the output folder: now
/// the run removes them, leaves the previous output as it was, says so in one line and ends
/// by the signal as before (seen failing before `cli::interrupt`: `.out.exr.<pid>.0.tmp`
/// and `.out.png.<pid>.1.tmp` left, no line).
#[test]
fn an_interrupted_render_leaves_no_temporary_file() {
    use std::os::unix::process::ExitStatusExt;
    let dir = crate::common::scratch("interrupted");
    let scene = crate::common::write(
        &dir,
        "s.toml",
        "[image]\nwidth = 2048\nheight = 2048\n[field]\nsource = \"sdf\"\nshape = \"sphere\"\n\
         radius = 0.7\nresolution = [8, 8, 8]\n",
    );
    let mut interrupted = 0;
    for (sig, name) in
        [(libc::SIGINT, "SIGINT"), (libc::SIGTERM, "SIGTERM"), (libc::SIGHUP, "SIGHUP")]
    {
        std::fs::write(dir.join("out.exr"), b"the previous file").unwrap();
        let child = std::process::Command::new(env!("CARGO_BIN_EXE_isoview"))
            .args(["render", &scene, "-o"])
            .arg(dir.join("out.exr"))
            .arg("--png")
            .arg(dir.join("out.png"))
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        // Interrupted once its temporary file exists (the render is under way).
        let started = std::time::Instant::now();
        while !entries(&dir).iter().any(|e| e.ends_with(".tmp")) {
            assert!(started.elapsed().as_secs() < 120, "no temporary file: {:?}", entries(&dir));
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        // SAFETY: a signal to our own child.
        unsafe { libc::kill(child.id() as i32, sig) };
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        if out.status.success() {
            // The render finished before the signal arrived: nothing to check this time.
            continue;
        }
        assert_eq!(out.status.signal(), Some(sig), "{name}: {:?} {err}", out.status);
        let left: Vec<String> = entries(&dir).into_iter().filter(|e| e.ends_with(".tmp")).collect();
        assert!(left.is_empty(), "{name}: left {left:?}");
        assert_eq!(std::fs::read(dir.join("out.exr")).unwrap(), b"the previous file", "{name}");
        assert!(!dir.join("out.png").exists(), "{name}");
        assert_eq!(err.trim_end().lines().count(), 1, "{name}: {err}");
        assert!(err.starts_with(&format!("isoview: interrupted by {name}; ")), "{err}");
        interrupted += 1;
    }
    assert!(interrupted >= 2, "only {interrupted} of 3 renders were still running when signalled");
}

/// Third #29 pass: a signal during `compare --diff` hung the process for good (the signal
/// thread waited for the stderr lock compare holds, compare for the writer's lock the signal
/// thread held); SIGQUIT left the temporary file; an ignored SIGHUP (`nohup`) still killed.
#[test]
fn signals_never_hang_and_ignored_ones_stay_ignored() {
    use std::os::unix::process::ExitStatusExt;
    use std::process::{Command, Stdio};
    let dir = crate::common::scratch("interrupted-compare");
    let scene = crate::common::write(
        &dir,
        "s.toml",
        "[image]\nwidth = 1024\nheight = 1024\n[field]\nsource = \"sdf\"\nshape = \"sphere\"\n\
         radius = 0.7\nresolution = [8, 8, 8]\n",
    );
    let a = dir.join("a.exr");
    let r = crate::common::isoview(&["render", &scene, "-o", a.to_str().unwrap()], &[]);
    assert!(r.status.success(), "{}", crate::common::stderr(&r));
    let run = |args: Vec<String>, sig: i32, ignore: bool| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_isoview"));
        cmd.args(&args).stderr(Stdio::piped()).stdout(Stdio::null());
        if ignore {
            // SAFETY: in the child before exec: set the signal to be ignored, as nohup does.
            unsafe {
                use std::os::unix::process::CommandExt;
                cmd.pre_exec(move || {
                    libc::signal(sig, libc::SIG_IGN);
                    Ok(())
                });
            }
        }
        let mut child = cmd.spawn().unwrap();
        // Signalled once an output is being written (or at once if it ended first).
        while !entries(&dir).iter().any(|e| e.ends_with(".tmp")) {
            if child.try_wait().unwrap().is_some() {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        // SAFETY: a signal to our own child.
        unsafe { libc::kill(child.id() as i32, sig) };
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || tx.send(child.wait_with_output().unwrap()));
        let out = rx.recv_timeout(std::time::Duration::from_secs(120)).expect("it hung");
        let left: Vec<String> = entries(&dir).into_iter().filter(|e| e.ends_with(".tmp")).collect();
        assert!(left.is_empty(), "left {left:?}");
        out
    };
    let s = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let diff = dir.join("d.exr").display().to_string();
    let compare = s(&["compare", a.to_str().unwrap(), a.to_str().unwrap(), "--diff", &diff]);
    let out = run(compare, libc::SIGINT, false);
    if !out.status.success() {
        assert_eq!(out.status.signal(), Some(libc::SIGINT), "{:?}", out.status);
    }
    let o = dir.join("o.exr").display().to_string();
    let out = run(s(&["render", &scene, "-o", &o]), libc::SIGQUIT, false);
    if !out.status.success() {
        assert_eq!(out.status.signal(), Some(libc::SIGQUIT), "{:?}", out.status);
    }
    let out = run(s(&["render", &scene, "-o", &o]), libc::SIGHUP, true);
    assert!(out.status.success(), "an ignored SIGHUP ended it: {:?}", out.status);
    assert!(std::path::Path::new(&o).exists());
}
