//! Meshes of every interpolant (`mesh::refine`, `mesh::voxel_faces`): the contract's closed
//! forms (Catmull-Rom reproduces a quadric, the B-spline shrinks it by its kernel's variance),
//! every vertex on its interpolant's own surface, `render.mesh_refine` splitting cells, nearest's
//! voxel faces enclosing exactly the inside voxels, and the CLI's keys and refusals.

use glam::DVec3;
use isoview::field::interpolant::{Interpolant, Interpolated};
use isoview::field::Grid;
use isoview::mesh::{extract, reference, ExtractOptions, Mesh, MeshBudget, Request};
use isoview::scene::{Inside, MeshAlgorithm};

use crate::common::*;

fn request(iso: f64, algo: MeshAlgorithm, interp: Interpolant, k: usize) -> Request<'static> {
    Request::new(iso, Inside::Below, algo).with_lattice(interp, k)
}

fn mesh(grid: &Grid, x: &Request) -> Mesh {
    extract(grid, x, &MeshBudget::unlimited()).unwrap()
}

/// The samples of x² + y² + z² − r² on `n`³ points over [-1, 1]³.
fn quadric(n: usize, r: f64) -> Grid {
    grid_from([n; 3], DVec3::splat(-1.0), DVec3::ONE, |p| p.length_squared() - r * r)
}

/// The largest |‖v‖ − radius| over the vertices, and the smallest cosine between a vertex's
/// normal and the sphere's.
fn off_sphere(m: &Mesh, radius: f64) -> (f64, f64) {
    let mut worst = (0.0f64, 1.0f64);
    for (p, n) in m.positions.iter().zip(&m.normals) {
        let p = v3(*p);
        worst.0 = worst.0.max((p.length() - radius).abs());
        worst.1 = worst.1.min(v3(*n).dot(p.normalize()));
    }
    worst
}

/// Away from the border Catmull-Rom reproduces quadratics, so the vertices of the mesh of
/// x² + y² + z² − r² lie on the sphere of radius r, and the B-spline's on the sphere of
/// radius √(r² − h²) (its kernel's variance h²/3 per axis), to f32 rounding (1e-5 of the
/// diagonal, the contract's bound), with the exact gradient's normals: for the methods whose
/// vertices are edge crossings, at k = 1 and refined. Trilinear's edge crossings of the same
/// samples (the line through the end values) miss by far more.
#[test]
fn cubic_meshes_have_their_vertices_on_the_exact_sphere() {
    let (n, r) = (17, 0.6);
    let h = 2.0 / (n - 1) as f64;
    let grid = quadric(n, r);
    let tol = 1e-5 * (grid.max - grid.min).length();
    let cases = [(Interpolant::CatmullRom, r), (Interpolant::CubicBspline, (r * r - h * h).sqrt())];
    for (interp, radius) in cases {
        for (algo, k) in [
            (MeshAlgorithm::MarchingCubes, 1),
            (MeshAlgorithm::MarchingCubes, 3),
            (MeshAlgorithm::MarchingTetrahedra, 2),
        ] {
            let m = mesh(&grid, &request(0.0, algo, interp, k));
            assert!(m.triangle_count() > 500 * k * k, "{}: {}", interp.name(), m.triangle_count());
            let (off, cos) = off_sphere(&m, radius);
            let what = format!("{} {} k = {k}", interp.name(), algo.name());
            assert!(off < tol, "{what}: a vertex {off} off the sphere of radius {radius}");
            assert!(cos > 0.99999, "{what}: a normal at cos {cos} from the sphere's");
        }
    }
    let m = mesh(&grid, &request(0.0, MeshAlgorithm::MarchingCubes, Interpolant::Trilinear, 1));
    let (off, _) = off_sphere(&m, r);
    assert!(off > 50.0 * tol, "trilinear is {off} off: the tolerance means nothing");
}

/// On random grids every edge vertex of every interpolant's mesh, at k = 1 and refined, lies
/// on its interpolant's isosurface: the value there is the isovalue to within what rounding
/// the position to f32 moves it (|∇f| times half an ulp of the coordinates, 4× for margin).
/// The refined trilinear mesh's vertices are on the trilinear surface too, and k = 1
/// trilinear stays the grid's own mesh. The dual methods' vertices are means of such crossings
/// and are checked against the mean of the f64 crossings by the sphere test above (not here).
#[test]
fn every_vertex_lies_on_its_interpolant_s_surface() {
    let mut rng = Rng::new(0x51ce_d1ce);
    for case in 0..6 {
        let dims = [5 + case % 3, 6, 4 + case % 2];
        let grid = random_grid(&mut rng, dims);
        let (lo, hi) = grid.range();
        let iso = f64::from(lo) + rng.range(0.3, 0.7) * f64::from(hi - lo);
        for interp in [Interpolant::Trilinear, Interpolant::CatmullRom, Interpolant::CubicBspline] {
            let field = Interpolated::new(&grid, interp);
            for k in [1, 2, 4] {
                let x = request(iso, MeshAlgorithm::MarchingCubes, interp, k);
                let m = mesh(&grid, &x);
                assert_eq!(m, reference(&grid, &x).unwrap(), "threads = the reference");
                let mut worst = 0.0f64;
                for p in &m.positions {
                    let w = v3(*p);
                    let u = (w - grid.min) / grid.spacing();
                    let g = field.gradient_at(u);
                    let slack = 4.0 * g.abs().dot(w.abs() + 1.0) * f64::from(f32::EPSILON) + 1e-12;
                    worst = worst.max((field.value_at(u) - iso).abs() / slack);
                }
                let what = format!("case {case} {} k = {k}", interp.name());
                assert!(worst <= 1.0, "{what}: a vertex {worst}× its rounding off the surface");
                assert!(!m.positions.is_empty(), "{what}: empty");
            }
        }
    }
}

/// `render.mesh_refine = k` splits each cell k ways: the refined trilinear mesh of a sphere's
/// samples has about k² as many triangles, and the B-spline's converges on its exact sphere as
/// every vertex stays on it.
#[test]
fn mesh_refine_splits_cells() {
    let grid = quadric(9, 0.6);
    let count = |interp, k| {
        mesh(&grid, &request(0.0, MeshAlgorithm::MarchingCubes, interp, k)).triangle_count()
    };
    let one = count(Interpolant::Trilinear, 1) as f64;
    for k in [2, 3, 5] {
        let ratio = count(Interpolant::Trilinear, k) as f64 / one;
        let kk = (k * k) as f64;
        assert!(ratio > 0.7 * kk && ratio < 1.3 * kk, "k = {k}: {ratio} times the triangles");
    }
}

/// The mesh of a nearest field is its voxels' faces: one quad per inside/outside neighbour
/// pair, at the half-integer plane between them, with the face's normal on each of its own
/// four vertices, counter-clockwise from outside; a ball of voxels inside the box is enclosed
/// exactly: the divergence theorem's volume of the mesh is the inside points' count times a
/// cell's volume, and Σ n·A vanishes.
#[test]
fn nearest_meshes_are_the_voxel_faces() {
    // f = x on x = 0..4: the plane x = 1.5 over the box's y, z extent (clipped).
    let grid = grid_from([5, 4, 4], DVec3::ZERO, DVec3::new(4.0, 3.0, 3.0), |p| p.x);
    let x = request(1.3, MeshAlgorithm::MarchingCubes, Interpolant::Nearest, 1)
        .with_opts(ExtractOptions { keep_quads: true, ..Default::default() });
    let m = mesh(&grid, &x);
    assert_eq!(m.quads.as_ref().map(Vec::len), Some(4 * 16), "one quad per (y, z) point");
    assert_eq!((m.vertex_count(), m.triangle_count()), (64, 32));
    let mut area = 0.0;
    for t in 0..m.triangle_count() {
        let [a, b, c] = m.triangle(t).map(|i| v3(m.positions[i as usize]));
        let cross = (b - a).cross(c - a);
        assert!(cross.normalize().abs_diff_eq(DVec3::X, 1e-12), "triangle {t} faces +x");
        area += 0.5 * cross.length();
    }
    assert!((area - 9.0).abs() < 1e-9, "the plane's area, clipped to the box: {area}");
    assert!(
        m.positions.iter().all(|p| p[0] == 1.5) && m.normals.iter().all(|n| *n == [1.0, 0.0, 0.0])
    );

    // A ball of voxels (inside = above), on an uneven spacing, every method the same faces.
    let grid = grid_from([11, 9, 12], DVec3::splat(-1.0), DVec3::ONE, |p| 0.8 - p.length());
    let h = grid.spacing();
    let inside = grid.values.iter().filter(|&&v| f64::from(v) > 0.0).count();
    let mut first = None;
    for algo in [MeshAlgorithm::MarchingCubes, MeshAlgorithm::SurfaceNets, MeshAlgorithm::Mc33] {
        let mut x = request(0.0, algo, Interpolant::Nearest, 3);
        x.inside = Inside::Above;
        let m = mesh(&grid, &x);
        let (mut volume, mut flux) = (0.0, DVec3::ZERO);
        for t in 0..m.triangle_count() {
            let [a, b, c] = m.triangle(t).map(|i| v3(m.positions[i as usize]));
            volume += a.dot(b.cross(c)) / 6.0;
            let n = v3(m.normals[m.triangle(t)[0] as usize]);
            flux += n * 0.5 * (b - a).cross(c - a).length();
            assert!((b - a).cross(c - a).normalize().abs_diff_eq(n, 1e-6), "winding of {t}");
        }
        let cell = h.x * h.y * h.z;
        // f32 positions: to their rounding.
        let want = inside as f64 * cell;
        assert!((volume - want).abs() < 1e-6 * want, "{volume}: {inside} voxels are {want}");
        assert!(flux.length() < 1e-6, "Σ n·A = {flux}");
        assert_eq!(*first.get_or_insert_with(|| m.clone()), m, "{}: the same faces", algo.name());
    }
}

/// The CLI: `extract` and `render.method = "mesh"` through each interpolant and
/// `render.mesh_refine`; the GPU's note; the keys' bounds; mc33 and the sharp methods refused
/// off trilinear cells with one line; a lattice over the grid cap refused naming the key.
#[test]
fn the_cli_meshes_each_interpolant() {
    let dir = scratch("mesh-interpolants");
    let scene = write(
        &dir,
        "s.toml",
        "[image]\nwidth = 24\nheight = 24\n[field]\nsource = \"sdf\"\nshape = \"torus\"\n\
         major_radius = 0.55\nminor_radius = 0.25\nresolution = [12, 12, 12]\n\
         bounds = { min = [-1, -1, -1], max = [1, 1, 1] }\n",
    );
    let ply = dir.join("m.ply");
    let p = ply.to_str().unwrap();
    let exr = dir.join("m.exr");
    let e = exr.to_str().unwrap();
    let interp = |i: &str| format!("field.interpolation=\"{i}\"");
    let mut files = Vec::new();
    for (i, k) in [
        ("trilinear", 1),
        ("trilinear", 2),
        ("catmull-rom", 1),
        ("cubic-bspline", 3),
        ("nearest", 1),
    ] {
        let refine = format!("render.mesh_refine={k}");
        let r = isoview(&["extract", &scene, "-o", p, "--set", &interp(i), "--set", &refine], &[]);
        assert!(r.status.success(), "{i} k = {k}: {}", stderr(&r));
        files.push(std::fs::read(&ply).unwrap());
        let r = isoview(
            &[
                "render",
                &scene,
                "-o",
                e,
                "--set",
                &interp(i),
                "--set",
                &refine,
                "--set",
                "render.method=\"mesh\"",
            ],
            &[],
        );
        assert!(r.status.success(), "{i} k = {k}, mesh render: {}", stderr(&r));
        std::fs::remove_file(&exr).unwrap();
    }
    let distinct: std::collections::BTreeSet<_> = files.iter().collect();
    assert_eq!(distinct.len(), files.len(), "each lattice its own mesh");

    let r = isoview(
        &["extract", &scene, "-o", p, "--device", "gpu", "--set", &interp("catmull-rom")],
        &[],
    );
    assert!(r.status.success(), "{}", stderr(&r));
    let note = "note: extracted on the CPU (the GPU extraction passes mesh trilinear cells";
    assert!(stderr(&r).contains(note), "{}", stderr(&r));

    for bad in ["0", "17", "1.5", "\"2\""] {
        let r = isoview(
            &["extract", &scene, "-o", p, "--set", &format!("render.mesh_refine={bad}")],
            &[],
        );
        assert_fails(&r, 2, &["render.mesh_refine"]);
    }
    std::fs::remove_file(&ply).unwrap();
    for method in ["mc33", "extended-mc", "dual-contouring-qef"] {
        let m = format!("render.mesh=\"{method}\"");
        for extra in [interp("catmull-rom"), "render.mesh_refine=2".to_string()] {
            let r = isoview(&["extract", &scene, "-o", p, "--set", &m, "--set", &extra], &[]);
            let line = format!(
                "render.mesh = \"{method}\" meshes trilinear cells at render.mesh_refine = 1 only"
            );
            assert_fails(&r, 2, &["s.toml", &line, "\"marching-cubes\""]);
            assert!(!ply.exists(), "{method}: written");
        }
    }
    // field.residency = "active" streams trilinear cells only: refused before a window is
    // read (a window all outside the surface used to skip the check and mesh trilinear cells).
    for values in [vec![0f32; 4096], (0..4096).map(|i| (i % 16) as f32 - 7.5).collect()] {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        std::fs::write(dir.join("p.raw"), bytes).unwrap();
        let mapped = write(
            &dir,
            "m.toml",
            "[field]\nsource = \"raw\"\npath = \"p.raw\"\ndims = [16, 16, 16]\ndtype = \"f32\"\n\
             residency = \"active\"\n",
        );
        let r = isoview(&["extract", &mapped, "-o", p], &[]);
        assert!(r.status.success(), "{}", stderr(&r));
        for extra in [interp("catmull-rom"), "render.mesh_refine=3".to_string()] {
            let r = isoview(&["extract", &mapped, "-o", p, "--set", &extra], &[]);
            assert_fails(
                &r,
                2,
                &["m.toml", "extract reads a grid in parts (field.residency = \"active\", or a grid over the memory cap) as trilinear cells"],
            );
        }
    }
    std::fs::remove_file(&ply).unwrap();
    let big = ["--set", "render.mesh_refine=16", "--set", "field.resolution=[40,40,40]"];
    let r = isoview(
        &[&["extract", &scene, "-o", p][..], &big[..]].concat(),
        &[("ISOVIEW_MAX_GRID_MIB", "64")],
    );
    assert_fails(&r, 2, &["render.mesh_refine = 16", "625x625x625", "ISOVIEW_MAX_GRID_MIB"]);
}
