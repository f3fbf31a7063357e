//! Physical space end to end, through the CLI: an oblique NRRD written by `teem-unu`
//! (`tests/data/formats/unu_gzip_oblique.nrrd`: 30° about z then 20° about x, spacing 0.8, 1.1,
//! 1.6) rendered, extracted, sliced and probed. Every world point isoview reports (hit
//! positions, mesh vertices, contour points) is mapped back to grid indices with the header's
//! geometry as `reference.json` records it (from pynrrd), and must lie on the trilinear
//! surface there: the geometry is the file's, not the axis-aligned grid's.

use std::path::PathBuf;

use glam::DVec3;
use isoview::field::{Grid, TriangleMesh};
use isoview::output::exr;
use isoview::reference::field::value_at;

use crate::common::*;

const ISO: f64 = 0.5;

/// The header's geometry, as the reference reader saw it.
struct Geometry {
    origin: DVec3,
    spacing: DVec3,
    axes: [DVec3; 3],
}

impl Geometry {
    /// World point -> continuous grid indices.
    fn index(&self, p: DVec3) -> DVec3 {
        let q = p - self.origin;
        DVec3::new(
            q.dot(self.axes[0]) / self.spacing.x,
            q.dot(self.axes[1]) / self.spacing.y,
            q.dot(self.axes[2]) / self.spacing.z,
        )
    }
}

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/formats").join(name)
}

fn geometry(name: &str) -> Geometry {
    let text = std::fs::read_to_string(data("reference.json")).unwrap();
    let all: serde_json::Value = serde_json::from_str(&text).unwrap();
    let r = &all[name];
    let v = |x: &serde_json::Value| {
        DVec3::new(x[0].as_f64().unwrap(), x[1].as_f64().unwrap(), x[2].as_f64().unwrap())
    };
    Geometry {
        origin: v(&r["origin"]),
        spacing: v(&r["spacing"]),
        axes: [v(&r["axes"][0]), v(&r["axes"][1]), v(&r["axes"][2])],
    }
}

/// The scene over the oblique file, and its samples in index space (unit spacing, so
/// `value_at` takes grid indices).
fn setup(dir: &std::path::Path) -> (String, Grid) {
    let path = data("unu_gzip_oblique.nrrd");
    let text = format!(
        "[image]\nwidth = 64\nheight = 48\n[camera]\neye = [0.3, -1.0, 0.4]\ntarget = [0, 0, 0]\n\
         up = [0, 0, 1]\nfit = true\n[field]\nsource = \"file\"\npath = \"{}\"\n\
         [surface]\nisovalue = {ISO}\n",
        path.display()
    );
    let scene = write(dir, "oblique.toml", &text);
    let loaded = isoview::scene::load(std::path::Path::new(&scene), &[]).unwrap();
    assert!(!loaded.field.placement.is_identity(), "the file's axes place the grid");
    let mut grid = loaded.field.sample(0.0).unwrap();
    grid.min = DVec3::ZERO;
    grid.max =
        DVec3::new((grid.dims[0] - 1) as f64, (grid.dims[1] - 1) as f64, (grid.dims[2] - 1) as f64);
    (scene, grid)
}

/// `p` (world) lies on the surface: inside the grid, where the field is the isovalue.
fn on_surface(g: &Geometry, grid: &Grid, p: DVec3, tol: f64, what: &str) {
    let u = g.index(p);
    let hi = grid.max + DVec3::splat(1e-4);
    assert!(u.cmpge(DVec3::splat(-1e-4)).all() && u.cmple(hi).all(), "{what}: {p} at {u}");
    let f = value_at(grid, u.clamp(DVec3::ZERO, grid.max));
    assert!((f - ISO).abs() < tol, "{what}: {p} (indices {u}) has value {f}, not {ISO}");
}

#[gpu_test]
fn an_oblique_file_renders_extracts_slices_and_probes_in_its_own_space() {
    let dir = scratch("physical");
    let g = geometry("unu_gzip_oblique.nrrd");
    let (scene, grid) = setup(&dir);
    let out = |name: &str| dir.join(name).display().to_string();

    // Render: every hit's P is on the surface, Z its distance from the eye.
    for method in ["analytic", "fixed-step", "mesh"] {
        let exr_path = out(&format!("{method}.exr"));
        let set = format!("render.method={method}");
        let o = isoview(&["render", &scene, "-o", &exr_path, "--set", &set], &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        let img = exr::read(std::path::Path::new(&exr_path)).unwrap();
        assert!(img.attribute("isoview/extra/placement").is_some_and(|p| p.contains("axes")));
        let eye: Vec<f64> = img
            .attribute("isoview/eye")
            .unwrap()
            .trim_matches(|c| c == '[' || c == ']')
            .split(',')
            .map(|s| s.trim().parse().unwrap())
            .collect();
        let eye = DVec3::new(eye[0], eye[1], eye[2]);
        let ch = |n: &str| &img.channel(n).unwrap().values;
        let (px, py, pz, z) = (ch("P.X"), ch("P.Y"), ch("P.Z"), ch("Z"));
        let mut hits = 0;
        for i in 0..z.len() {
            if !z[i].is_finite() {
                continue;
            }
            hits += 1;
            let p = DVec3::new(px[i] as f64, py[i] as f64, pz[i] as f64);
            // Fixed-step refines its crossing to a bracket, not to the root; the mesh's
            // triangles leave the trilinear surface between grid edges.
            let tol = if method == "analytic" { 2e-3 } else { 2e-2 };
            on_surface(&g, &grid, p, tol, method);
            assert!(((p - eye).length() - z[i] as f64).abs() < 1e-3, "{method}: Z of {p}");
        }
        assert!(hits > 200, "{method}: {hits} hits");
    }

    // Extract: marching-cubes vertices lie on grid edges, where the field is exactly linear.
    let ply = out("m.ply");
    let o = isoview(&["extract", &scene, "-o", &ply], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mesh = TriangleMesh::read(std::path::Path::new(&ply)).unwrap();
    assert!(mesh.positions.len() > 100);
    for &p in &mesh.positions {
        on_surface(&g, &grid, p, 1e-4, "mesh vertex");
    }

    // Slice across the grid's own z axis: contour points on the surface, on that plane.
    let json = out("c.json");
    let at = 3.3 * g.spacing.z + g.origin.z; // grid frame: origin + spacing * index
    let o = isoview(
        &[
            "slice",
            &scene,
            "-o",
            &out("s.exr"),
            "--axis",
            "z",
            "--at",
            &at.to_string(),
            "--json",
            &json,
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let contours: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let mut points = 0;
    for c in contours["contours"].as_array().unwrap() {
        for p in c["points"].as_array().unwrap() {
            let p =
                DVec3::new(p[0].as_f64().unwrap(), p[1].as_f64().unwrap(), p[2].as_f64().unwrap());
            on_surface(&g, &grid, p, 1e-4, "contour point");
            assert!((g.index(p).z - 3.3).abs() < 1e-6, "contour point {p} off the slice");
            points += 1;
        }
    }
    assert!(points > 10, "{points} contour points");

    // Probe: the exact hit is on the surface, reported in world space.
    let o = isoview(&["probe", &scene, "--pixel", "32,24", "--json"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let h = &report["analytic"]["hit"]["position"];
    let p = DVec3::new(h[0].as_f64().unwrap(), h[1].as_f64().unwrap(), h[2].as_f64().unwrap());
    on_surface(&g, &grid, p, 1e-6, "probe hit");
}
