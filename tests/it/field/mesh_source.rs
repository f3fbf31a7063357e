//! `[field] source = "mesh"`: the signed distance of STL, OBJ and PLY meshes on a grid with cubic
//! cells, its scene keys and one-line errors, and FOSSIL's resample round trip
//! (extract -> mesh SDF -> extract) staying watertight.

use std::path::{Path, PathBuf};

use glam::DVec3;
use isoview::field::{FieldSource, Grid, GridLimits, TriangleMesh};
use isoview::mesh::export::{self, Format};
use isoview::mesh::stats;
use isoview::mesh::{reference, Mesh, Request};
use isoview::reference::fixed_step;
use isoview::render::Renderer;
use isoview::scene::{self, Inside, MeshAlgorithm, Method, Scene, SceneError};

use crate::common::*;

fn dir(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("isoview-meshfield-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn load(dir: &Path, field: &str) -> Result<Scene, SceneError> {
    scene::from_str_with(&format!("[field]\n{field}"), "t.toml", dir, &[], &GridLimits::default())
}

fn load_err(dir: &Path, field: &str) -> String {
    let Err(e) = load(dir, field) else { panic!("expected an error for {field}") };
    let e = e.to_string();
    assert!(!e.contains('\n'), "not one line: {e:?}");
    e
}

fn sample(s: &Scene) -> Grid {
    s.field.sample_with(0.0, &GridLimits::default()).unwrap()
}

/// The marching-cubes mesh of a sphere of radius `r` sampled on an n^3 SDF grid over [-1, 1]^3.
fn sphere_mesh(r: f64, n: usize) -> Mesh {
    let g = grid_from([n, n, n], DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.length() - r);
    reference(&g, &Request::new(0.0, Inside::Below, MeshAlgorithm::Mc33)).unwrap()
}

fn save(mesh: &Mesh, path: &Path) {
    let mut bytes = Vec::new();
    export::write(mesh, Format::from_path(path).unwrap(), &mut bytes).unwrap();
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn every_format_reads_the_same_triangles_and_the_grid_has_cubic_cells_with_a_margin() {
    let d = dir("formats");
    let mesh = sphere_mesh(0.6, 17);
    let mut grids = Vec::new();
    for name in ["s.ply", "s.obj", "s.stl"] {
        save(&mesh, &d.join(name));
        let read = TriangleMesh::read(&d.join(name)).unwrap();
        assert_eq!(read.triangles.len(), mesh.triangle_count(), "{name}");
        for (t, tri) in read.triangles.iter().enumerate() {
            for (&a, &b) in tri.iter().zip(&mesh.triangle(t)) {
                let (pa, pb) = (read.positions[a as usize], mesh.positions[b as usize]);
                assert_eq!(pa, DVec3::from(pb.map(f64::from)), "{name} triangle {t}");
            }
        }
        let s =
            load(&d, &format!("source = \"mesh\"\npath = \"{name}\"\nresolution = 24")).unwrap();
        assert!(matches!(s.field.source, FieldSource::Mesh(_)));
        let (lo, hi) = read.bounds();
        let b = s.field.bounds;
        let h = (b.max - b.min) / (DVec3::from(s.field.resolution.map(|n| n as f64)) - 1.0);
        assert!((h.x - h.y).abs() < 1e-9 && (h.y - h.z).abs() < 1e-9, "cubic cells {h}");
        let margin = 0.05 * (hi - lo).max_element();
        assert!((b.min - (lo - margin)).abs().max_element() < 1e-6, "{b:?}");
        assert!((b.max - (hi + margin)).abs().max_element() < 1e-6, "{b:?}");
        assert_eq!(s.field.resolution, [24, 24, 24]);
        grids.push(sample(&s));
    }
    assert!(grids.windows(2).all(|w| w[0] == w[1]), "same field from every format");
}

/// The distance field of a sphere of radius 0.6 extracted with 33 points per axis, sampled at
/// 40 points per axis (in a scratch folder named after `test`).
fn extracted_sphere_sdf(test: &str) -> Grid {
    let d = dir(test);
    save(&sphere_mesh(0.6, 33), &d.join("sphere.ply"));
    let s = load(&d, "source = \"mesh\"\npath = \"sphere.ply\"\nresolution = 40").unwrap();
    sample(&s)
}

#[test]
fn sdf_of_an_extracted_sphere_is_the_sphere_s_distance() {
    let grid = extracted_sphere_sdf("sphere");
    // The mesh lies within ~1e-3 of the sphere (h = 1/16); the distance to it within as much of
    // |p| - 0.6 everywhere, with the sign from the winding number.
    let mut worst = 0.0f64;
    for k in 0..grid.dims[2] {
        for j in 0..grid.dims[1] {
            for i in 0..grid.dims[0] {
                let p = grid.point(i, j, k);
                worst = worst.max((grid.at(i, j, k) as f64 - (p.length() - 0.6)).abs());
            }
        }
    }
    assert!(worst < 3e-3, "largest |sdf - (|p| - 0.6)| = {worst}");
}

#[gpu_test]
fn sdf_of_an_extracted_sphere_renders_as_a_sphere() {
    let grid = extracted_sphere_sdf("sphere-render");
    let ctx = gpu();
    let mut scene = scene_for(&grid, DVec3::new(0.3, 0.5, 2.5), 48, Method::FixedStep);
    scene.render.steps = 300;
    let frame = Renderer::new(&ctx).unwrap().render(&scene, &grid, 0.0).unwrap();
    let reference = fixed_step::render(&scene, &grid);
    let mut hits = 0;
    for (p, r) in frame.pixels.iter().zip(&reference) {
        if p.is_hit() {
            hits += 1;
            let pos = DVec3::from(p.position.map(f64::from));
            assert!((pos.length() - 0.6).abs() < 5e-3, "|{pos}| = {}", pos.length());
            assert!(r.is_hit());
        }
    }
    assert!(hits > 400, "{hits} hits");
}

#[test]
fn resampling_round_trip_stays_watertight() {
    let d = dir("resample");
    // A torus (genus 1) and a sphere, extracted, resampled as distance fields, re-extracted.
    let torus = grid_from([28, 28, 28], DVec3::splat(-1.0), DVec3::splat(1.0), |p| {
        let ring = (p.x * p.x + p.z * p.z).sqrt() - 0.6;
        (ring * ring + p.y * p.y).sqrt() - 0.25
    });
    let torus =
        reference(&torus, &Request::new(0.0, Inside::Below, MeshAlgorithm::MarchingCubes)).unwrap();
    for (name, mesh, euler) in [("torus.stl", torus, 0), ("sphere.obj", sphere_mesh(0.7, 20), 2)] {
        save(&mesh, &d.join(name));
        let s =
            load(&d, &format!("source = \"mesh\"\npath = \"{name}\"\nresolution = 30")).unwrap();
        let grid = sample(&s);
        for algo in [MeshAlgorithm::Mc33, MeshAlgorithm::MarchingTetrahedra] {
            let again = reference(&grid, &Request::new(0.0, Inside::Below, algo)).unwrap();
            let st = stats::compute(&again);
            assert!(st.is_closed_manifold(), "{name} {}: {st}", algo.name());
            assert_eq!(st.euler_characteristic, euler, "{name} {}: {st}", algo.name());
            let before = stats::compute(&mesh);
            assert!(
                (st.volume - before.volume).abs() < 0.03 * before.volume,
                "{name} {}: volume {} vs {}",
                algo.name(),
                st.volume,
                before.volume
            );
        }
    }
}

#[test]
fn open_and_inverted_meshes_get_their_sign_from_the_winding_number() {
    let d = dir("open");
    // A sphere with a cap of triangles removed is still "inside" at its centre (w ≈ 0.9), and
    // the same sphere wound inside-out (w = -1 inside) still has its inside negative.
    let mut holed = sphere_mesh(0.6, 17);
    let keep: Vec<u32> = (0..holed.triangle_count())
        .filter(|&t| holed.triangle(t).iter().any(|&v| holed.positions[v as usize][1] < 0.45))
        .flat_map(|t| holed.triangle(t))
        .collect();
    assert!(keep.len() < holed.indices.len(), "the cap was cut");
    holed.indices = keep;
    save(&holed, &d.join("holed.ply"));
    let s = load(&d, "source = \"mesh\"\npath = \"holed.ply\"\nresolution = 20").unwrap();
    let g = sample(&s);
    let at = |g: &Grid, p: DVec3| {
        let u = (p - g.min) / g.spacing();
        g.at(u.x.round() as usize, u.y.round() as usize, u.z.round() as usize)
    };
    assert!(at(&g, DVec3::ZERO) < -0.5, "centre inside: {}", at(&g, DVec3::ZERO));
    assert!(at(&g, g.min) > 0.0, "corner outside");

    let mut flipped = sphere_mesh(0.6, 17);
    for t in flipped.indices.chunks_exact_mut(3) {
        t.swap(1, 2);
    }
    save(&flipped, &d.join("flipped.stl"));
    let s = load(&d, "source = \"mesh\"\npath = \"flipped.stl\"\nresolution = 20").unwrap();
    let g = sample(&s);
    assert!(at(&g, DVec3::ZERO) < -0.5 && at(&g, g.min) > 0.0);
}

#[test]
fn bad_mesh_files_and_keys_fail_with_one_line() {
    let d = dir("errors");
    let p = |name: &str| d.join(name).display().to_string();
    let field = |name: &str| format!("source = \"mesh\"\npath = \"{name}\"\nresolution = 16\n");
    let write = |name: &str, bytes: &[u8]| std::fs::write(d.join(name), bytes).unwrap();

    assert_eq!(
        load_err(&d, &field("missing.stl")),
        format!("t.toml:3:8: field.path: {}: file not found", p("missing.stl"))
    );
    write("mesh.dae", b"<COLLADA/>");
    assert_eq!(
        load_err(&d, &field("mesh.dae")),
        format!(
            "t.toml:3:8: field.path: {}: unsupported mesh format: the file name must end in \
             .stl, .obj or .ply",
            p("mesh.dae")
        )
    );
    write("text.ply", b"this is not a ply file\n");
    let e = load_err(&d, &field("text.ply"));
    assert!(
        e.starts_with(&format!(
            "t.toml:3:8: field.path: {}: not a valid PLY file (",
            p("text.ply")
        )),
        "{e}"
    );
    // A binary STL header promising 5 triangles, then 10 bytes.
    let mut short = vec![b' '; 80];
    short.extend(5u32.to_le_bytes());
    short.extend([0u8; 10]);
    write("short.stl", &short);
    let e = load_err(&d, &field("short.stl"));
    assert!(e.contains("short.stl: not a valid STL file"), "{e}");
    write("index.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
    let e = load_err(&d, &field("index.obj"));
    assert!(e.contains("index.obj:") && e.contains("field.path"), "{e}");
    write("empty.obj", b"# nothing\nv 0 0 0\n");
    assert_eq!(
        load_err(&d, &field("empty.obj")),
        format!("t.toml:3:8: field.path: {}: the mesh has no triangles", p("empty.obj"))
    );
    write("nan.obj", b"v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let e = load_err(&d, &field("nan.obj"));
    assert!(e.contains("nan.obj: vertex 0 is not finite: [0, 0, NaN] (NaN, or"), "{e}");
    // A finite coordinate past f32's range reads inf: the line says why, not that the file
    // holds a non-finite number (it said `vertex 0 is not finite: [inf, 0, 0]` for 1e300).
    write("big.obj", b"v 1e300 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let e = load_err(&d, &field("big.obj"));
    assert!(e.contains("big.obj: vertex 0 is not finite: [inf, 0, 0] (NaN, or in an STL"), "{e}");
    assert!(e.contains("beyond ±3.4028235e38, the range of the 32-bit floats they are"), "{e}");
    write("point.obj", b"v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\n");
    let e = load_err(&d, &field("point.obj"));
    assert!(e.contains("no extent"), "{e}");

    let mesh = sphere_mesh(0.5, 9);
    save(&mesh, &d.join("ok.ply"));
    let e = load_err(&d, "source = \"mesh\"\npath = \"ok.ply\"\nresolution = [16, 16, 16]");
    assert_eq!(e, "t.toml:4:14: field.resolution: expected an integer, got an array [16, 16, 16]");
    let e = load_err(&d, "source = \"mesh\"\npath = \"ok.ply\"\nresolution = 1");
    assert!(e.starts_with("t.toml:4:14: field.resolution:"), "{e}");
    let e = load_err(&d, "source = \"mesh\"\npath = \"ok.ply\"");
    assert!(e.contains("field.resolution: missing"), "{e}");
    let e = load_err(
        &d,
        "source = \"mesh\"\npath = \"ok.ply\"\nresolution = 16\nbounds = { min = [0, 0, 0], max = [1, 1, 1] }",
    );
    assert!(e.starts_with("t.toml:5:1: field.bounds: not a key of source \"mesh\""), "{e}");
    let e =
        load_err(&d, "source = \"mesh\"\npath = \"ok.ply\"\nresolution = 16\nshape = \"sphere\"");
    assert!(e.contains("field.shape: not a key of source \"mesh\""), "{e}");
    // The memory cap counts the grid that the mesh's box makes.
    let capped = scene::from_str_with(
        "[field]\nsource = \"mesh\"\npath = \"ok.ply\"\nresolution = 200",
        "t.toml",
        &d,
        &[],
        &GridLimits { max_bytes: 1 << 20 },
    );
    let e = capped.unwrap_err().to_string();
    assert!(e.starts_with("t.toml:4:14: field.resolution:") && e.contains("over the cap"), "{e}");
}

/// A closed prism of `sides` sides around the z axis through `(cx, cy)`, radius `r` at its
/// vertices, from `z = -half` to `z = half`, as OBJ text (vertex numbers from `first`).
fn prism_obj(cx: f64, cy: f64, r: f64, half: f64, sides: usize, first: usize) -> String {
    let mut s = String::new();
    for z in [-half, half] {
        for n in 0..sides {
            let a = std::f64::consts::TAU * n as f64 / sides as f64;
            s += &format!("v {} {} {z}\n", cx + r * a.cos(), cy + r * a.sin());
        }
    }
    let (bottom, top) = (|n: usize| first + n % sides, |n: usize| first + sides + n % sides);
    for n in 0..sides {
        s += &format!("f {} {} {}\n", bottom(n), bottom(n + 1), top(n + 1));
        s += &format!("f {} {} {}\n", bottom(n), top(n + 1), top(n));
    }
    for n in 1..sides - 1 {
        s += &format!("f {} {} {}\n", bottom(0), bottom(n + 1), bottom(n));
        s += &format!("f {} {} {}\n", top(0), top(n), top(n + 1));
    }
    s
}

/// `slice.ambiguity = "sample"` on a mesh field (#16: it was refused as "sampled data"): the
/// mesh's signed distance decides the ambiguous cell. Two long prisms of radius 0.6 about
/// (-0.5, -0.5) and (0.5, 0.5): their grid (23 points along z, cubic cells of side 1, 5 cells
/// across x and y) has grid points on both axes, and the plane z = 0 one ambiguous cell between
/// them whose corner average is inside (-0.1) and whose centre is outside both (+0.107), as in
/// `slice::a_saddle_under_each_ambiguity_rule`.
#[test]
fn sample_ambiguity_evaluates_a_mesh_field() {
    use isoview::slice::{self as slicing, Axis, PlaneGrid, SourceField};
    let d = dir("sample");
    let sides = 256;
    let obj = prism_obj(-0.5, -0.5, 0.6, 10.0, sides, 1)
        + &prism_obj(0.5, 0.5, 0.6, 10.0, sides, 2 * sides + 1);
    std::fs::write(d.join("prisms.obj"), obj).unwrap();
    let field = "source = \"mesh\"\npath = \"prisms.obj\"\nresolution = 23\n";
    for (rule, loops, joined) in [("average", 1, 1), ("sample", 2, 0), ("saddle", 1, 1)] {
        let s = load(&d, &format!("{field}[slice]\nambiguity = \"{rule}\"\n"))
            .unwrap_or_else(|e| panic!("{rule}: {e}"));
        assert_eq!(s.field.resolution, [6, 6, 23], "{rule}");
        assert!(s.field.source.supports().point);
        let grid = sample(&s);
        assert!((grid.spacing() - DVec3::ONE).abs().max_element() < 1e-9, "{:?}", grid.spacing());
        let plane = PlaneGrid::new(&grid, Axis::Z, 0.0).unwrap();
        let set = slicing::scene_contours(&s, &grid, &plane, 0.0).unwrap();
        assert_eq!(set.counts(), (loops, 0), "{rule}");
        assert_eq!((set.stats.ambiguous, set.stats.joined), (1, joined), "{rule}");
        if rule == "sample" {
            // The decision came from the mesh's distance at the cell's centre.
            let source = SourceField::from_spec(&s.field, 0.0).unwrap();
            let centre = (source.eval)(DVec3::ZERO);
            assert!((centre - (0.5f64.sqrt() - 0.6)).abs() < 1e-3, "{centre}");
            assert_eq!(set.stats.evaluations, 1);
        }
    }
}
