//! Visual regression: every shipped scene, with every method that applies, rendered through
//! the `isoview render` binary at a small size and compared with its golden EXR in `golden/`.
//!
//! - A missing golden is a failure, never written automatically. `ISOVIEW_BLESS=1 cargo test
//!   --test it golden` (or `./x bless`) re-renders and overwrites only the goldens that fail or
//!   are missing, and prints what changed.
//! - On failure `target/golden-out/<name>-actual.exr`, `-diff.exr` and `-diff.png` are written
//!   and the failing channels printed; after every run `target/isoview-report/index.html` shows
//!   golden, actual and diff side by side, failures first.
//! - Goldens record the device and driver they were made on; a mismatch is printed loudly.
//! - Tolerances: [`golden_thresholds`], set from the noise measured by the ignored test
//!   `golden::calibrate` (see docs/compare.md "Visual regression").

use std::path::{Path, PathBuf};
use std::process::Command;

use isoview::compare::{self, ChannelClass, Report, Thresholds, Verdict};
use isoview::output::{exr, png};

/// Longest image side of a golden render.
const GOLDEN_SIZE: u32 = 96;

/// Methods rendered for every scene.
const METHODS: [&str; 3] = ["fixed-step", "analytic", "mesh"];

/// Extra goldens of time-varying scenes at another time: (scene, time).
const EXTRA_TIMES: [(&str, f64); 2] = [("cell-oscillating", 0.5), ("expr-waves", 1.0)];

/// Extra mesh renders with every other extraction algorithm (the scenes' own is marching
/// cubes): the tunnel cell, whose topology each algorithm gets differently, and the torus.
/// Their method is `mesh-<algorithm>`.
const EXTRA_MESH_SCENES: [&str; 2] = ["cell-tunnel", "torus"];
const EXTRA_MESHES: [&str; 4] = ["mc33", "marching-tetrahedra", "surface-nets", "dual-contouring"];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `target/` of this build (also when CARGO_TARGET_DIR moves it).
fn target_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).parent().map(Path::to_path_buf).unwrap_or_default()
}

/// One golden image: a scene rendered with a method at a time.
#[derive(Clone, Debug)]
pub struct Golden {
    pub scene: String,
    pub method: String,
    pub time: f64,
}

impl Golden {
    pub fn name(&self) -> String {
        if self.time == 0.0 {
            format!("{}.{}", self.scene, self.method)
        } else {
            format!("{}.{}.t{}", self.scene, self.method, self.time)
        }
    }

    pub fn path(&self) -> PathBuf {
        root().join("golden").join(format!("{}.exr", self.name()))
    }

    pub fn scene_path(&self) -> PathBuf {
        root().join("scenes").join(format!("{}.toml", self.scene))
    }
}

/// Every golden the suite expects: each `scenes/*.toml` with each method, plus extra times.
pub fn goldens() -> Vec<Golden> {
    let mut scenes: Vec<String> = std::fs::read_dir(root().join("scenes"))
        .unwrap()
        .filter_map(|e| {
            let p = e.unwrap().path();
            (p.extension()? == "toml").then(|| p.file_stem().unwrap().to_string_lossy().into())
        })
        .collect();
    scenes.sort();
    let mut out = Vec::new();
    for scene in &scenes {
        for method in METHODS {
            out.push(Golden { scene: scene.clone(), method: method.into(), time: 0.0 });
            for (s, t) in EXTRA_TIMES {
                if s == scene {
                    out.push(Golden { scene: scene.clone(), method: method.into(), time: t });
                }
            }
        }
        if EXTRA_MESH_SCENES.contains(&scene.as_str()) {
            for algo in EXTRA_MESHES {
                let method = format!("mesh-{algo}");
                out.push(Golden { scene: scene.clone(), method, time: 0.0 });
            }
        }
    }
    out
}

/// Renders `g` through the binary into `out`, with extra `--set` overrides and environment.
pub fn render(g: &Golden, out: &Path, sets: &[String], env: &[(&str, &str)]) {
    let scene = isoview::scene::load(&g.scene_path(), &[]).unwrap();
    let (w, h) = (scene.image.width as f64, scene.image.height as f64);
    let scale = GOLDEN_SIZE as f64 / w.max(h);
    let (w, h) = (((w * scale).round() as u32).max(1), ((h * scale).round() as u32).max(1));
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_isoview"));
    cmd.arg("render").arg(g.scene_path()).arg("-o").arg(out);
    cmd.args(["--time", &g.time.to_string()]);
    // `mesh-<algorithm>`: the mesh render with that extraction algorithm.
    let (method, mesh) = match g.method.strip_prefix("mesh-") {
        Some(algo) => ("mesh", Some(format!("render.mesh=\"{algo}\""))),
        None => (g.method.as_str(), None),
    };
    for s in [
        format!("image.width={w}"),
        format!("image.height={h}"),
        format!("render.method=\"{method}\""),
    ]
    .iter()
    .chain(&mesh)
    .chain(sets)
    {
        cmd.args(["--set", s]);
    }
    for (k, v) in env {
        cmd.env(k, v);
    }
    let o = cmd.output().unwrap();
    assert!(o.status.success(), "rendering {}: {}", g.name(), String::from_utf8_lossy(&o.stderr));
}

/// The golden comparison's thresholds, by the rule "10x the largest difference measured by
/// [`calibrate`], and never below a floor of 1e-6 absolute and 1e-6 relative (a few f32 ulps at
/// the scale of these scenes)". Measured (docs/compare.md "Visual regression"): no difference at all:
/// renders are bit-identical across LP_NUM_THREADS 1 and 2 and with
/// GALLIUM_OVERRIDE_CPU_CAPS=sse4.1 (no AVX/FMA codegen), so the floor applies. Integer
/// channels are exact and no pixel may fail.
///
/// A channel the renderer writes that a golden lacks (one added since the golden was made) is
/// named in a note and left out; every channel both have is compared. A channel the golden
/// has and the render lacks is a failure.
pub fn golden_thresholds() -> Thresholds {
    Thresholds {
        fail: 1e-6,
        fail_relative: 1e-6,
        fail_class: vec![(ChannelClass::Integer, 0.0)],
        fail_percent: 0.0,
        warn: 1e-6,
        flip: true,
        new_channels: true,
        ..Thresholds::default()
    }
}

fn preview_png(img: &exr::ExrImage, path: &Path) {
    let ch = |n: &str| img.channel(n).map(|c| c.values.clone());
    let (r, g, b, a) = (ch("R"), ch("G"), ch("B"), ch("A"));
    let n = img.width * img.height;
    let mut rgba = Vec::with_capacity(n * 4);
    for i in 0..n {
        let get = |c: &Option<Vec<f32>>, d: f32| c.as_ref().map_or(d, |v| v[i]);
        rgba.extend(png::to_srgb8([get(&r, 0.0), get(&g, 0.0), get(&b, 0.0), get(&a, 1.0)]));
    }
    png::write_rgba8(path, img.width as u32, img.height as u32, &rgba).unwrap();
}

struct Outcome {
    name: String,
    verdict: String,
    failed: bool,
    summary: String,
}

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

fn write_report(outcomes: &mut [Outcome], report_dir: &Path) {
    outcomes.sort_by_key(|o| (!o.failed, o.name.clone()));
    let failed = outcomes.iter().filter(|o| o.failed).count();
    let mut html = format!(
        "<!doctype html><meta charset=utf-8><title>isoview golden report</title>\
         <style>body{{font:14px sans-serif;background:#222;color:#ddd}}td{{vertical-align:top;\
         padding:6px}}img{{width:192px;image-rendering:pixelated;background:#444}}\
         .fail{{color:#f66}}.pass{{color:#6c6}}pre{{font-size:11px}}</style>\
         <h1>isoview golden report</h1><p>{} goldens, {failed} failing</p><table>\
         <tr><th>golden</th><th>expected</th><th>actual</th><th>diff</th><th>metrics</th></tr>",
        outcomes.len()
    );
    for o in outcomes.iter() {
        let class = if o.failed { "fail" } else { "pass" };
        html += &format!(
            "<tr><td class={class}><b>{}</b><br>{}</td><td><img src=\"{0}-golden.png\"></td>\
             <td><img src=\"{0}-actual.png\"></td><td><img src=\"{0}-diff.png\"></td>\
             <td><pre>{}</pre></td></tr>",
            o.name,
            html_escape(&o.verdict),
            html_escape(&o.summary)
        );
    }
    html += "</table>";
    std::fs::write(report_dir.join("index.html"), html).unwrap();
}

/// Writes a golden from a render, atomically.
fn bless_from(actual: &Path, golden: &Path) {
    isoview::output::atomic::write_bytes(golden, &std::fs::read(actual).unwrap()).unwrap();
}

#[gpu_test]
fn goldens_match() {
    let bless = std::env::var("ISOVIEW_BLESS").as_deref() == Ok("1");
    let out_dir = target_dir().join("golden-out");
    let report_dir = target_dir().join("isoview-report");
    std::fs::create_dir_all(&out_dir).unwrap();
    std::fs::create_dir_all(&report_dir).unwrap();
    let thresholds = golden_thresholds();
    let mut outcomes = Vec::new();
    let mut failures = Vec::new();
    let mut blessed = Vec::new();
    let mut notes = Vec::new();
    for g in goldens() {
        let name = g.name();
        let actual_path = out_dir.join(format!("{name}-actual.exr"));
        render(&g, &actual_path, &[], &[]);
        let actual = exr::read(&actual_path).unwrap();
        preview_png(&actual, &report_dir.join(format!("{name}-actual.png")));
        let golden = match exr::read(&g.path()) {
            Ok(img) => img,
            Err(e) => {
                if bless {
                    bless_from(&actual_path, &g.path());
                    blessed.push(format!("{name}: new golden"));
                    continue;
                }
                failures.push(format!(
                    "{name}: missing golden {} ({e}); bless with ISOVIEW_BLESS=1",
                    g.path().display()
                ));
                outcomes.push(Outcome {
                    name,
                    verdict: "FAIL: missing golden".into(),
                    failed: true,
                    summary: String::new(),
                });
                continue;
            }
        };
        preview_png(&golden, &report_dir.join(format!("{name}-golden.png")));
        for key in ["isoview/device", "isoview/driver"] {
            if golden.attribute(key) != actual.attribute(key) {
                eprintln!(
                    "!!! {name}: golden made with {key} = {:?}, this run has {:?}: \
                     differences may come from the driver, not from isoview !!!",
                    golden.attribute(key),
                    actual.attribute(key)
                );
            }
        }
        let report: Report = match compare::compare(&golden, &actual, &thresholds) {
            Ok(r) => r,
            Err(e) => {
                // Not comparable (e.g. the channel set changed): blessing replaces it too.
                if bless {
                    bless_from(&actual_path, &g.path());
                    blessed.push(format!("{name}: re-blessed ({e})"));
                } else {
                    failures.push(format!("{name}: {e}"));
                }
                continue;
            }
        };
        if !report.new_channels.is_empty() {
            notes.push(format!(
                "{name}: the golden lacks {} (written by the renderer now): compared on the \
                 other channels; re-bless to record them",
                report.new_channels.join(", ")
            ));
        }
        let diff_png = out_dir.join(format!("{name}-diff.png"));
        compare::write_heat_map_png(&diff_png, &report).unwrap();
        std::fs::copy(&diff_png, report_dir.join(format!("{name}-diff.png"))).unwrap();
        let failed = report.verdict == Verdict::Fail;
        if failed {
            if bless {
                bless_from(&actual_path, &g.path());
                blessed.push(format!("{name}: re-blessed\n{report}"));
                continue;
            }
            let diff_exr = out_dir.join(format!("{name}-diff.exr"));
            compare::write_diff_exr(&diff_exr, &golden, &actual, &report).unwrap();
            let channels: Vec<&str> = report
                .channels
                .iter()
                .filter(|c| c.over_fail > 0)
                .map(|c| c.name.as_str())
                .collect();
            failures.push(format!(
                "{name}: {} (failing channels: {}); actual {}, diff {} and {}",
                report.verdict_line(),
                channels.join(", "),
                actual_path.display(),
                diff_exr.display(),
                diff_png.display()
            ));
        }
        outcomes.push(Outcome {
            name,
            verdict: report.verdict_line(),
            failed,
            summary: report.to_string(),
        });
    }
    write_report(&mut outcomes, &report_dir);
    for b in &blessed {
        eprintln!("blessed {b}");
    }
    for n in &notes {
        eprintln!("note: {n}");
    }
    assert!(
        failures.is_empty(),
        "{} golden(s) failed (report: {}):\n{}",
        failures.len(),
        report_dir.join("index.html").display(),
        failures.join("\n")
    );
}

/// Every golden on disk belongs to a golden the suite renders (no stale files).
#[test]
fn no_stale_goldens() {
    let expected: Vec<PathBuf> = goldens().iter().map(Golden::path).collect();
    for e in std::fs::read_dir(root().join("golden")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "exr") {
            assert!(expected.contains(&p), "{} is not rendered by any golden", p.display());
        }
    }
}

/// A golden made before a channel existed: the channel is reported, the others compared, and
/// a change in them still fails. (GPU-free: the "render" is a golden read from disk.)
#[test]
fn a_golden_lacking_a_new_channel_is_compared_on_the_others() {
    let g = Golden { scene: "torus".into(), method: "analytic".into(), time: 0.0 };
    let actual = exr::read(&g.path()).unwrap();
    assert!(actual.channel("cell.Z").is_some() && actual.channel("steps").is_some());
    let mut old = actual.clone();
    old.channels.retain(|c| c.name != "cell.Z" && c.name != "steps");
    let r = compare::compare(&old, &actual, &golden_thresholds()).unwrap();
    assert_eq!(r.verdict, Verdict::Identical);
    assert_eq!(r.new_channels, ["cell.Z", "steps"]);
    assert_eq!(r.channels.len(), actual.channels.len() - 2);
    assert!(r.to_string().contains("new channels): cell.Z, steps"), "{r}");
    // The channels both have are still compared.
    let mut changed = actual.clone();
    changed.channels.iter_mut().find(|c| c.name == "N.X").unwrap().values[0] += 1e-3;
    let r = compare::compare(&old, &changed, &golden_thresholds()).unwrap();
    assert_eq!(r.verdict, Verdict::Fail);
    // A channel the golden has and the render lost fails to compare at all.
    let err = compare::compare(&actual, &old, &golden_thresholds()).unwrap_err().to_string();
    assert!(err.contains("channel mismatch") && err.contains("cell.Z"), "{err}");
}

/// Renders the torus golden with `sets` and compares it with the golden's thresholds.
fn torus_verdict(name: &str, sets: &[String]) -> Verdict {
    let g = Golden { scene: "torus".into(), method: METHODS[0].into(), time: 0.0 };
    let out = crate::common::scratch(name).join("actual.exr");
    render(&g, &out, sets, &[]);
    let golden = exr::read(&g.path()).unwrap();
    let actual = exr::read(&out).unwrap();
    compare::compare(&golden, &actual, &golden_thresholds()).unwrap().verdict
}

#[gpu_test]
fn goldens_pass_an_unchanged_render() {
    assert_eq!(torus_verdict("golden-same", &[]), Verdict::Identical);
}

#[gpu_test]
fn goldens_catch_small_changes() {
    // The torus SDF spans about [-0.25, 0.9] on its grid: 1% of that range.
    assert_eq!(torus_verdict("golden-iso", &["surface.isovalue=0.0115".into()]), Verdict::Fail);
    // One pixel sideways: the eye and target move by one pixel's width at the target's
    // distance (|eye - target| = 3.62, fov 40, 96 px high: 2 * 3.62 * tan(20°) / 96 = 0.0274).
    let right = glam::DVec3::new(2.4, 0.0, -2.2).normalize() * 0.0274;
    let moved =
        |p: [f64; 3]| format!("[{}, {}, {}]", p[0] + right.x, p[1] + right.y, p[2] + right.z);
    let sets = [
        format!("camera.eye={}", moved([2.2, 1.6, 2.4])),
        format!("camera.target={}", moved([0.0, 0.0, 0.0])),
    ];
    assert_eq!(torus_verdict("golden-camera", &sets), Verdict::Fail);
    // Another shading: only the colour channels change.
    assert_eq!(
        torus_verdict("golden-shading", &["render.shading=\"normal\"".into()]),
        Verdict::Fail
    );
    // More march steps: a different method configuration.
    assert_eq!(torus_verdict("golden-steps", &["render.steps=201".into()]), Verdict::Fail);
    // Another method (the exact ray tracer against the fixed-step golden): the channel sets
    // differ (`crossings`), so compare the contract's common channels only.
    let g = Golden { scene: "torus".into(), method: "analytic".into(), time: 0.0 };
    let out = crate::common::scratch("golden-method").join("actual.exr");
    render(&g, &out, &[], &[]);
    let fixed = exr::read(&Golden { method: METHODS[0].into(), ..g }.path()).unwrap();
    let common: Vec<String> = fixed.channel_names().map(String::from).collect();
    let t = Thresholds { only: Some(common), ..golden_thresholds() };
    let r = compare::compare(&fixed, &exr::read(&out).unwrap(), &t).unwrap();
    assert_eq!(r.verdict, Verdict::Fail);
}

/// The noise measurement behind [`golden_thresholds`]: every golden rendered under each
/// configuration that may change lavapipe's results (thread count; no AVX/FMA codegen), compared
/// with the default render; prints the largest difference per channel class.
/// Run with `cargo test --test it golden::calibrate -- --ignored --nocapture`.
#[test]
#[ignore]
fn calibrate() {
    let matrix: [&[(&str, &str)]; 3] = [
        &[("LP_NUM_THREADS", "1")],
        &[("LP_NUM_THREADS", "2")],
        &[("GALLIUM_OVERRIDE_CPU_CAPS", "sse4.1")],
    ];
    let dir = crate::common::scratch("golden-calibrate");
    let exact = Thresholds { fail: 0.0, warn: 0.0, flip: false, ..Thresholds::default() };
    let classes = ["colour", "depth", "normal", "position", "integer"];
    let mut worst = vec![0.0f64; classes.len()];
    let mut coverage = 0;
    for g in goldens() {
        let base = dir.join(format!("{}-default.exr", g.name()));
        render(&g, &base, &[], &[]);
        let a = exr::read(&base).unwrap();
        for (n, env) in matrix.iter().enumerate() {
            let p = dir.join(format!("{}-{n}.exr", g.name()));
            render(&g, &p, &[], env);
            let r = compare::compare(&a, &exr::read(&p).unwrap(), &exact).unwrap();
            for c in &r.channels {
                let i = classes.iter().position(|k| *k == c.class.name()).unwrap_or(0);
                worst[i] = worst[i].max(c.max_abs);
            }
            coverage += r.coverage.as_ref().map_or(0, |c| c.only_a + c.only_b);
            eprintln!("{} under {env:?}: {}", g.name(), r.verdict_line());
        }
    }
    eprintln!("largest difference from the default render, per channel class:");
    for (c, w) in classes.iter().zip(&worst) {
        eprintln!("  {c:10} {w:.3e}");
    }
    eprintln!("  coverage flips: {coverage}");
}
