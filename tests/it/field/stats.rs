//! Isovalues picked from the data (`isovalue_sigma`, `isovalue_percentile`) and `isoview
//! stats`, checked against NumPy's numbers for a real EMDB map (mrcfile's data, `np.mean`,
//! `np.std`, `np.percentile`).

use std::path::PathBuf;

use isoview::field::GridLimits;
use isoview::scene::{self, IsoRule, Scene, SceneError};

fn data() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/formats")
}

fn load(surface: &str) -> Result<Scene, SceneError> {
    let text = format!("[field]\nsource = \"file\"\npath = \"EMD-3197.map\"\n[surface]\n{surface}");
    scene::from_str_with(&text, "t.toml", &data(), &[], &GridLimits::default())
}

// EMD-3197.map by NumPy: d.mean(), d.std(), np.percentile(d, 50) of mrcfile's float32 data.
const MEAN: f64 = 0.7836120336436434;
const SIGMA: f64 = 2.39995290849429;
const MEDIAN: f64 = 0.9346814155578613;

#[test]
fn sigma_and_percentile_resolve_from_the_samples() {
    let s = load("isovalue_sigma = 1.5\n").unwrap();
    assert!((s.surface.isovalue - (MEAN + 1.5 * SIGMA)).abs() < 1e-12, "{}", s.surface.isovalue);
    let IsoRule::Sigma { k, mean, sigma } = s.surface.rule else { panic!("{:?}", s.surface.rule) };
    assert_eq!(k, 1.5);
    assert!((mean - MEAN).abs() < 1e-12 && (sigma - SIGMA).abs() < 1e-12);
    let s = load("isovalue_percentile = 50\n").unwrap();
    assert!((s.surface.isovalue - MEDIAN).abs() < 1e-12, "{}", s.surface.isovalue);
    let s = load("isovalue_percentile = 100\ninside = \"above\"\n").unwrap();
    assert_eq!(s.surface.isovalue, 5.576736927032471);
    let s = load("isovalue = 0.5\n").unwrap();
    assert_eq!((s.surface.isovalue, s.surface.rule), (0.5, IsoRule::Value));
}

#[test]
fn one_isovalue_key_at_most() {
    let e = load("isovalue = 1\nisovalue_sigma = 2\n").unwrap_err().to_string();
    assert!(e.contains("t.toml:6") && e.contains("not both isovalue and isovalue_sigma"), "{e}");
    let e = load("isovalue_percentile = 101\n").unwrap_err().to_string();
    assert!(e.contains("surface.isovalue_percentile") && e.contains("0..=100"), "{e}");
    let text = "[field]\nsource = \"expr\"\nexpression = \"x - t\"\nresolution = [3, 3, 3]\n\
                [surface]\nisovalue_sigma = 1\n";
    let e = scene::from_str_with(text, "t.toml", &data(), &[], &GridLimits::default());
    let e = e.unwrap_err().to_string();
    assert!(e.contains("surface.isovalue_sigma") && e.contains("depend on the time"), "{e}");
}

#[test]
fn stats_prints_what_the_field_holds() {
    let dir = crate::common::scratch("stats-cli");
    let scene = crate::common::write(
        &dir,
        "s.toml",
        &format!(
            "[field]\nsource = \"file\"\npath = \"{}\"\n[surface]\nisovalue_sigma = 1.5\n",
            data().join("EMD-3197.map").display()
        ),
    );
    let out = crate::common::isoview(&["stats", &scene], &[]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{}", crate::common::stderr(&out));
    for needle in [
        "dims        20 x 20 x 20 (8000 points)",
        "dtype       mode 2 (float32)",
        "spacing     11.4 11.4 11.4",
        &format!("mean        {MEAN}"),
        &format!("p50={MEDIAN}"),
        "range       -4.1337456703186035 .. 5.576736927032471",
        "<- isovalue",
    ] {
        assert!(text.contains(needle), "`{needle}` missing from:\n{text}");
    }
    let err = crate::common::stderr(&out);
    assert!(err.contains("from isovalue_sigma = 1.5") && err.lines().count() == 1, "{err}");
    // An override of another isovalue key replaces the file's (the page's slider sends one).
    let out = crate::common::isoview(&["stats", &scene, "--set", "surface.isovalue=2"], &[]);
    assert_eq!(out.status.code(), Some(0), "{}", crate::common::stderr(&out));
    assert!(String::from_utf8_lossy(&out.stdout).contains("isovalue    2 (sigma"));
    let sets = ["--set", "surface.isovalue=2", "--set", "surface.isovalue_percentile=50"];
    let out = crate::common::isoview(&[&["stats", scene.as_str()][..], &sets[..]].concat(), &[]);
    assert_eq!(out.status.code(), Some(0), "{}", crate::common::stderr(&out));
    assert!(crate::common::stderr(&out).contains("percentile 50"), "the last override wins");
}

/// The EXR says how its isovalue was picked: the number in `isoview/isovalue`, the rule in
/// `isoview/extra/isovalue_rule`.
#[gpu_test]
fn the_exr_header_records_the_rule() {
    use isoview::output::exr::{self, attr};
    let dir = crate::common::scratch("stats-exr");
    let scene = crate::common::write(
        &dir,
        "s.toml",
        &format!(
            "[image]\nwidth = 24\nheight = 16\n[camera]\neye = [520, 420, 480]\n\
             target = [85, 108, 108]\n[field]\nsource = \"file\"\npath = \"{}\"\n\
             [surface]\nisovalue_percentile = 50\ninside = \"above\"\n",
            data().join("EMD-3197.map").display()
        ),
    );
    let out = dir.join("o.exr").display().to_string();
    let o = crate::common::isoview(&["render", &scene, "-o", &out], &[]);
    assert!(o.status.success(), "{}", crate::common::stderr(&o));
    let img = exr::read(std::path::Path::new(&out)).unwrap();
    assert_eq!(img.attribute(attr::ISOVALUE).unwrap(), MEDIAN.to_string());
    let rule = img.attribute("isoview/extra/isovalue_rule").expect("isovalue_rule");
    assert!(rule.contains("percentile 50") && rule.contains(&MEDIAN.to_string()), "{rule}");
}

/// A field whose every sample is missing data (NaN or ±inf) has no mean or percentile: an
/// isovalue picked from it is refused at its key, and `stats` says there is no range. Both
/// read 0 before: `isovalue_sigma` picked 0 and rendered nothing, `stats` printed
/// `range 0 .. 0`, `mean -0` and a histogram of zeros.
#[test]
fn a_field_without_a_finite_sample_gives_no_isovalue_and_no_range() {
    let field = "[field]\nsource = \"expr\"\nexpression = \"sqrt(-1 - x*x)\"\n\
                 resolution = [3, 3, 3]\n[surface]\n";
    for (key, col) in [("isovalue_sigma = 1", 18), ("isovalue_percentile = 50", 23)] {
        let text = format!("{field}{key}\n");
        let e = scene::from_str_with(&text, "t.toml", &data(), &[], &GridLimits::default());
        let e = e.unwrap_err().to_string();
        let name = key.split(' ').next().unwrap();
        assert!(e.starts_with(&format!("t.toml:6:{col}: surface.{name}: ")), "{e}");
        assert!(e.contains("no finite sample to pick the isovalue from (all 27 are NaN"), "{e}");
    }
    let dir = crate::common::scratch("stats-no-finite");
    let scene = crate::common::write(&dir, "s.toml", &format!("{field}isovalue = 0.5\n"));
    let out = crate::common::isoview(&["stats", &scene], &[]);
    assert_eq!(out.status.code(), Some(0), "{}", crate::common::stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("range       none: every sample is missing data\n"), "{text}");
    assert!(text.ends_with("isovalue    0.5\n"), "no figure after the isovalue:\n{text}");
    assert!(!text.contains("mean") && !text.contains("histogram"), "{text}");
    let out = crate::common::isoview(&["stats", &scene, "--set", "surface.isovalue_sigma=1"], &[]);
    assert_eq!(out.status.code(), Some(2));
    let err = crate::common::stderr(&out);
    assert!(err.contains("no finite sample") && err.lines().count() == 1, "{err}");
}
