//! The `isoview` binary as users and scripts see it: outputs, exit codes, one-line errors, and
//! files that are never truncated or clobbered by a failed run.

use std::path::Path;

use isoview::output::exr;

use crate::common::{assert_fails, isoview, scratch, stderr, write};

const SPHERE: &str = r#"
[image]
width = 32
height = 24

[camera]
eye = [0.0, 0.5, 3.0]

[field]
source = "sdf"
shape = "sphere"
radius = 0.6
resolution = [12, 12, 12]
bounds = { min = [-1.0, -1.0, -1.0], max = [1.0, 1.0, 1.0] }

[render]
method = "fixed-step"
steps = 48
"#;

#[gpu_test]
fn render_writes_every_channel_and_a_preview() {
    let dir = scratch("cli-render");
    let scene = write(&dir, "sphere.toml", SPHERE);
    let out = dir.join("out.exr").display().to_string();
    let png = dir.join("out.png").display().to_string();
    let o = isoview(&["render", &scene, "-o", &out, "--png", &png], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = exr::read(Path::new(&out)).unwrap();
    assert_eq!((img.width, img.height), (32, 24));
    let mut names: Vec<&str> = img.channel_names().collect();
    names.sort();
    let mut want = vec![
        "R", "G", "B", "A", "Z", "N.X", "N.Y", "N.Z", "P.X", "P.Y", "P.Z", "steps", "cell.X",
        "cell.Y", "cell.Z",
    ];
    want.sort();
    assert_eq!(names, want);
    let a = &img.channel("A").unwrap().values;
    assert!(a.contains(&1.0) && a.contains(&0.0), "hits and misses");
    let text = format!("{:?}", img.attributes);
    for needle in ["fixed-step", "sphere.toml", isoview::VERSION] {
        assert!(text.contains(needle), "{needle} missing from the header: {text}");
    }
    let preview = image::open(&png).unwrap();
    assert_eq!((preview.width(), preview.height()), (32, 24));
}

#[gpu_test]
fn set_overrides_change_the_render() {
    let dir = scratch("cli-set");
    let scene = write(&dir, "sphere.toml", SPHERE);
    let a = dir.join("a.exr").display().to_string();
    let b = dir.join("b.exr").display().to_string();
    assert!(isoview(&["render", &scene, "-o", &a], &[]).status.success());
    let o = isoview(&["render", &scene, "-o", &b, "--set", "surface.isovalue=-0.2"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cover =
        |p: &str| exr::read(Path::new(p)).unwrap().channel("A").unwrap().values.iter().sum::<f32>();
    assert!(cover(&b) < cover(&a), "a lower isovalue gives a smaller sphere");
    // compare: identical files pass, different ones fail with status 1.
    assert_eq!(isoview(&["compare", &a, &a], &[]).status.code(), Some(0));
    assert_eq!(isoview(&["compare", &a, &b], &[]).status.code(), Some(1));
}

#[test]
fn bad_scenes_fail_with_one_line_naming_file_line_and_key() {
    let dir = scratch("cli-bad");
    let scene = write(&dir, "typo.toml", &SPHERE.replace("steps = 48", "stepz = 48"));
    let out = dir.join("out.exr").display().to_string();
    let o = isoview(&["render", &scene, "-o", &out], &[]);
    assert_fails(&o, 2, &["typo.toml:", "stepz"]);
    let o = isoview(&["render", &dir.join("missing.toml").display().to_string(), "-o", &out], &[]);
    assert_fails(&o, 2, &["missing.toml"]);
    let good = write(&dir, "good.toml", SPHERE);
    let o = isoview(&["render", &good, "-o", &out, "--set", "render.steps=[1]"], &[]);
    assert_fails(&o, 2, &["--set render.steps=[1]"]);
    let o = isoview(&["render", &good, "-o", &dir.join("out.png").display().to_string()], &[]);
    assert_fails(&o, 2, &[".exr"]);
    let o = isoview(&["render", &good, "-o", &out, "--frames", "3..1"], &[]);
    assert_fails(&o, 2, &["--frames"]);
    assert!(!Path::new(&out).exists(), "no output from failed runs");
    let o = isoview(&["render", &good], &[]);
    assert_eq!(o.status.code(), Some(2), "missing -o is a usage error");
}

#[test]
fn failed_runs_leave_existing_outputs_untouched() {
    let dir = scratch("cli-clobber");
    let good = write(&dir, "good.toml", SPHERE);
    let out = dir.join("out.exr");
    std::fs::write(&out, b"previous render").unwrap();
    let o = isoview(
        &["render", &good, "-o", &out.display().to_string(), "--set", "field.radius=-1"],
        &[],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = isoview(
        &["render", &good, "-o", &out.display().to_string()],
        &[("VK_DRIVER_FILES", "/nonexistent/icd.json"), ("VK_ICD_FILENAMES", "")],
    );
    assert_fails(&o, 3, &["Vulkan", "apt-get install"]);
    assert_eq!(std::fs::read(&out).unwrap(), b"previous render");
    let leftovers = std::fs::read_dir(&dir).unwrap().count();
    assert_eq!(leftovers, 2, "no temporary files left behind");
}

#[gpu_test]
fn missing_output_folder_is_bad_input() {
    let dir = scratch("cli-nodir");
    let good = write(&dir, "good.toml", SPHERE);
    let out = dir.join("no/such/dir/out.exr").display().to_string();
    assert_fails(&isoview(&["render", &good, "-o", &out], &[]), 2, &["no/such/dir"]);
}

#[gpu_test]
fn frames_render_a_time_varying_field() {
    let dir = scratch("cli-frames");
    let scene = write(
        &dir,
        "waves.toml",
        &SPHERE.replace(
            "source = \"sdf\"\nshape = \"sphere\"\nradius = 0.6",
            "source = \"expr\"\nexpression = \"x*x + y*y + z*z - 0.3 - 0.1*t\"",
        ),
    );
    let pattern = dir.join("f.####.exr").display().to_string();
    let o = isoview(&["render", &scene, "-o", &pattern, "--frames", "0..2", "--fps", "1"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cover = |n: u32| {
        let p = dir.join(format!("f.{n:04}.exr"));
        exr::read(&p).unwrap().channel("A").unwrap().values.iter().sum::<f32>()
    };
    let (c0, c1, c2) = (cover(0), cover(1), cover(2));
    assert!(c0 < c1 && c1 < c2, "the sphere grows with t: {c0} {c1} {c2}");
    let t = exr::read(&dir.join("f.0002.exr")).unwrap();
    assert!(format!("{:?}", t.attributes).contains('2'), "time recorded");
}

#[gpu_test]
fn info_names_the_device() {
    let o = isoview(&["info"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("device") && text.contains("max storage buffer"), "{text}");
}

/// One cell whose x = 0 face holds 0.7 rounded to f32 (0.699999988..., just below 0.7) and
/// whose x = 1 face holds 1: with isovalue 0.7 and inside = below, the x = 0 face is inside
/// (0.69999999 < 0.7 in f64: the f64 references and extraction say so), so the ray along +x
/// through the face's centre crosses the surface right at the face. Comparing samples with
/// `0.7 as f32` instead of the exact inside threshold made that face outside and the ray a
/// miss in both ray passes.
const JUST_BELOW: &str = r#"
[image]
width = 9
height = 9

[camera]
eye = [-1.0, 0.5, 0.5]
target = [0.5, 0.5, 0.5]

[field]
source = "corners"
values = [0.699999988079071044921875, 1.0, 0.699999988079071044921875, 1.0,
          0.699999988079071044921875, 1.0, 0.699999988079071044921875, 1.0]

[surface]
isovalue = 0.7
"#;

#[gpu_test]
fn ray_passes_use_the_exact_inside_threshold() {
    let dir = scratch("cli-threshold");
    let scene = write(&dir, "just-below.toml", JUST_BELOW);
    for method in ["analytic", "fixed-step"] {
        let out = dir.join(format!("{method}.exr")).display().to_string();
        let set = format!("render.method=\"{method}\"");
        let o = isoview(&["render", &scene, "-o", &out, "--set", &set], &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        let img = exr::read(Path::new(&out)).unwrap();
        let centre = 4 * 9 + 4;
        let (a, z) =
            (img.channel("A").unwrap().values[centre], img.channel("Z").unwrap().values[centre]);
        assert_eq!(a, 1.0, "{method}: the centre ray must hit the x = 0 face");
        assert!((z - 1.0).abs() < 1e-5, "{method}: hit at depth {z}, expected 1 (the face)");
    }
}
