//! `isoview extract` and `render.method = "mesh"` through the binary: mesh files in every
//! format equal to the library's extraction, `--stats`, `--device gpu|cpu` beside the global
//! Vulkan `--device`, exit codes with one-line errors, and outputs never truncated or clobbered.

use std::path::Path;

use isoview::field::TriangleMesh;
use isoview::mesh::{reference, stats, Request};
use isoview::output::exr;
use isoview::scene;

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
resolution = [14, 13, 12]
bounds = { min = [-1.0, -1.0, -1.0], max = [1.0, 1.0, 1.0] }

[render]
method = "mesh"
mesh = "mc33"
"#;

#[test]
fn extract_writes_every_format_with_the_library_s_mesh() {
    let dir = scratch("extract-formats");
    let scene_path = write(&dir, "sphere.toml", SPHERE);
    let s = scene::load(Path::new(&scene_path), &[]).unwrap();
    let grid = s.field.sample(0.0).unwrap();
    let want = reference(&grid, &Request::new(0.0, s.surface.inside, s.render.mesh)).unwrap();
    for ext in ["ply", "obj", "stl"] {
        let out = dir.join(format!("sphere.{ext}"));
        let o = isoview(
            &["extract", &scene_path, "-o", &out.display().to_string(), "--device", "cpu"],
            &[],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stderr(&o).contains("mc33 on cpu"), "{}", stderr(&o));
        let got = TriangleMesh::read(&out).unwrap();
        assert_eq!(got.triangles.len(), want.triangle_count(), "{ext}");
        for (t, tri) in got.triangles.iter().enumerate() {
            for (&a, &b) in tri.iter().zip(&want.triangle(t)) {
                assert_eq!(
                    got.positions[a as usize],
                    glam::DVec3::from(want.positions[b as usize].map(f64::from)),
                    "{ext} triangle {t}"
                );
            }
        }
    }
}

#[test]
fn stats_device_and_overrides() {
    let dir = scratch("extract-stats");
    let scene_path = write(&dir, "sphere.toml", SPHERE);
    let (a, b, c) = (dir.join("a.ply"), dir.join("b.ply"), dir.join("c.ply"));
    let path = |p: &Path| p.display().to_string();
    let o = isoview(&["extract", &scene_path, "-o", &path(&a), "--stats", "--device", "cpu"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    let s = scene::load(Path::new(&scene_path), &[]).unwrap();
    let grid = s.field.sample(0.0).unwrap();
    let mesh = reference(&grid, &Request::new(0.0, s.surface.inside, s.render.mesh)).unwrap();
    assert_eq!(text.trim_end(), stats::compute(&mesh).to_string());
    for needle in [
        "vertices:",
        "triangles:",
        "area:",
        "volume:",
        "boundary edges: 0",
        "non-manifold edges: 0",
        "min-angle histogram:",
    ] {
        assert!(text.contains(needle), "{needle} missing from {text}");
    }
    // The global flag before the subcommand gives the same file; `--device gpu` the same
    // triangles, with f32 positions within 1e-5 of the reference's.
    let o = isoview(&["--device", "cpu", "extract", &scene_path, "-o", &path(&c)], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&c).unwrap());
    let o = isoview(&["extract", &scene_path, "-o", &path(&b), "--device", "gpu"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("mc33 on gpu"), "{}", stderr(&o));
    let (cpu, gpu) = (TriangleMesh::read(&a).unwrap(), TriangleMesh::read(&b).unwrap());
    assert_eq!(cpu.triangles, gpu.triangles);
    assert_eq!(cpu.positions.len(), gpu.positions.len());
    for (p, q) in cpu.positions.iter().zip(&gpu.positions) {
        assert!((*p - *q).abs().max_element() < 1e-5, "{p} vs {q}");
    }
    // --set reaches the extraction: another algorithm, another mesh.
    let o = isoview(
        &[
            "extract",
            &scene_path,
            "-o",
            &path(&c),
            "--device",
            "cpu",
            "--set",
            "render.mesh=surface-nets",
            "--quads",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("surface-nets on cpu"));
    assert_ne!(std::fs::read(&a).unwrap(), std::fs::read(&c).unwrap());
    let header = String::from_utf8_lossy(&std::fs::read(&c).unwrap()[..400]).into_owned();
    assert!(header.contains("element face"), "{header}");
}

#[test]
fn extract_errors_are_one_line_and_never_clobber_the_output() {
    let dir = scratch("extract-errors");
    let good = write(&dir, "good.toml", SPHERE);
    let out = dir.join("out.ply");
    let o = out.display().to_string();
    std::fs::write(&out, b"previous mesh").unwrap();
    assert_fails(
        &isoview(&["extract", &good, "-o", &dir.join("m.dae").display().to_string()], &[]),
        2,
        &["m.dae", ".ply, .obj or .stl"],
    );
    let typo = write(&dir, "typo.toml", &SPHERE.replace("mesh = \"mc33\"", "mesh = \"mc34\""));
    assert_fails(&isoview(&["extract", &typo, "-o", &o], &[]), 2, &["typo.toml:", "render.mesh"]);
    assert_fails(
        &isoview(&["extract", &good, "-o", &o, "--set", "surface.isovalue=nan"], &[]),
        2,
        &["--set surface.isovalue=nan"],
    );
    assert_fails(&isoview(&["extract", &good, "-o", &o, "--time", "inf"], &[]), 2, &["--time"]);
    let missing = dir.join("no/such/dir/m.ply").display().to_string();
    assert_fails(
        &isoview(&["extract", &good, "-o", &missing, "--device", "cpu"], &[]),
        2,
        &["no/such/dir"],
    );
    assert_eq!(std::fs::read(&out).unwrap(), b"previous mesh");
    let entries = std::fs::read_dir(&dir).unwrap().count();
    assert_eq!(entries, 3, "no temporary files left behind");
}

#[test]
fn empty_meshes_are_written_with_a_note() {
    let dir = scratch("extract-empty");
    let good = write(&dir, "good.toml", SPHERE);
    let out = dir.join("empty.stl");
    let o = isoview(
        &[
            "extract",
            &good,
            "-o",
            &out.display().to_string(),
            "--device",
            "cpu",
            "--set",
            "surface.isovalue=5",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("the mesh is empty"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&out).unwrap().len(), 84, "an STL header with 0 triangles");
}

#[gpu_test]
fn render_method_mesh_writes_every_channel_and_says_how_it_was_made() {
    let dir = scratch("extract-render");
    let scene_path = write(&dir, "sphere.toml", SPHERE);
    let out = dir.join("mesh.exr");
    let count = "render.count_crossings=true";
    let o =
        isoview(&["render", &scene_path, "-o", &out.display().to_string(), "--set", count], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = exr::read(&out).unwrap();
    let names: Vec<&str> = img.channel_names().collect();
    for c in ["R", "A", "Z", "N.X", "P.Z", "steps", "cell.Y", "crossings"] {
        assert!(names.contains(&c), "{c} missing from {names:?}");
    }
    let a = &img.channel("A").unwrap().values;
    assert!(a.contains(&1.0) && a.contains(&0.0), "hits and misses");
    let text = format!("{:?}", img.attributes);
    assert!(text.contains("mesh") && text.contains("mc33"), "{text}");
    // The exact surface has the same channels, so `compare` measures the mesh's departure.
    let exact = dir.join("analytic.exr");
    let e = exact.display().to_string();
    let o = isoview(
        &["render", &scene_path, "-o", &e, "--set", "render.method=analytic", "--set", count],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = isoview(&["compare", &e, &out.display().to_string()], &[]);
    assert_eq!(o.status.code(), Some(1), "differences, not an error: {}", stderr(&o));
    let report = String::from_utf8_lossy(&o.stdout);
    assert!(report.contains("crossings") && report.contains("Z "), "{report}");
}
