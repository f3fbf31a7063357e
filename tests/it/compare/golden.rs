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

use isoview::compare::{self, Report, Thresholds, Verdict};
use isoview::output::{exr, png};

use isoview::bench::golden::{self as set, Golden, METHODS};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `target/` of this build (also when CARGO_TARGET_DIR moves it).
fn target_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).parent().map(Path::to_path_buf).unwrap_or_default()
}

/// Every golden the suite expects (`isoview::bench::golden`, which `./x bench --gpu` renders
/// too).
pub fn goldens() -> Vec<Golden> {
    set::goldens(&root()).unwrap()
}

pub fn render(g: &Golden, out: &Path, sets: &[String], env: &[(&str, &str)]) {
    let mut cmd = g.command(Path::new(env!("CARGO_BIN_EXE_isoview")), &root(), out, sets).unwrap();
    for (k, v) in env {
        cmd.env(k, v);
    }
    let o = cmd.output().unwrap();
    assert!(o.status.success(), "rendering {}: {}", g.name(), String::from_utf8_lossy(&o.stderr));
}

pub fn golden_thresholds() -> Thresholds {
    set::thresholds()
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
        let golden = match exr::read(&g.path(&root())) {
            Ok(img) => img,
            Err(e) => {
                if bless {
                    bless_from(&actual_path, &g.path(&root()));
                    blessed.push(format!("{name}: new golden"));
                    continue;
                }
                failures.push(format!(
                    "{name}: missing golden {} ({e}); bless with ISOVIEW_BLESS=1",
                    g.path(&root()).display()
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
                    bless_from(&actual_path, &g.path(&root()));
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
                bless_from(&actual_path, &g.path(&root()));
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
    let expected: Vec<PathBuf> = goldens().iter().map(|g| g.path(&root())).collect();
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
    let actual = exr::read(&g.path(&root())).unwrap();
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
    let golden = exr::read(&g.path(&root())).unwrap();
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
    let fixed = exr::read(&Golden { method: METHODS[0].into(), ..g }.path(&root())).unwrap();
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
