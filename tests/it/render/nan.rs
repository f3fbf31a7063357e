//! `field.nan = "empty"` (the default): NaN and infinite samples are missing data, and a cell
//! whose 8 corners hold one holds no surface, for every method (`field::interpolant::cell_missing`,
//! `shaders/include/missing.glsl`).
//!
//! Closed form: a sphere's distance grid with a block of NaN (and inf) samples on its surface:
//! no hit, triangle or contour in the block's cells, and everything the block does not touch bit
//! for bit as without it (rays that never enter the missing cells, meshes minus the missing
//! cells' faces, in the same order). GPU = references on random grids with NaNs sprinkled (the
//! ray methods, the brick ranges, every GPU extraction). The CLI: such a file loads by default,
//! `nan = "error"` keeps today's refusal, `stats` counts them, `probe` says why a cell is empty.

use glam::{DVec2, DVec3};
use isoview::field::interpolant::cell_missing;
use isoview::field::Grid;
use isoview::frame::Pixel;
use isoview::mesh::{reference, ExtractOptions, Mesh, QuadSplit, Request};
use isoview::reference::analytic::{self, AnalyticOptions};
use isoview::reference::fixed_step;
use isoview::render::Renderer;
use isoview::scene::{Inside, MeshAlgorithm, Method};
use isoview::vocab::SharpSettings;

use crate::common::*;

/// Points per axis of the sphere grid.
const N: usize = 24;
/// The block of missing points (inclusive index ranges), where the sphere meets +x.
const BLOCK: [[usize; 2]; 3] = [[15, 19], [9, 14], [9, 14]];

/// `|p| - 0.6` on [-1, 1]³.
fn sphere() -> Grid {
    grid_from([N; 3], DVec3::splat(-1.0), DVec3::ONE, |p| p.length() - 0.6)
}

/// [`sphere`] with the block's samples NaN, one of them +inf.
fn holed() -> Grid {
    let mut g = sphere();
    for k in BLOCK[2][0]..=BLOCK[2][1] {
        for j in BLOCK[1][0]..=BLOCK[1][1] {
            for i in BLOCK[0][0]..=BLOCK[0][1] {
                let n = g.index(i, j, k);
                g.values[n] = f32::NAN;
            }
        }
    }
    let n = g.index(BLOCK[0][0], BLOCK[1][0], BLOCK[2][0]);
    g.values[n] = f32::INFINITY;
    g
}

/// The index-space box of the missing cells: the block grown by one cell on every side.
fn missing_box() -> (DVec3, DVec3) {
    let lo = DVec3::new(BLOCK[0][0] as f64, BLOCK[1][0] as f64, BLOCK[2][0] as f64) - 1.0;
    let hi = DVec3::new(BLOCK[0][1] as f64, BLOCK[1][1] as f64, BLOCK[2][1] as f64) + 1.0;
    (lo, hi)
}

/// Whether cell `c` of `grid` is missing.
fn missing(grid: &Grid, c: [usize; 3]) -> bool {
    cell_missing(&grid.corners(c[0], c[1], c[2]).map(f64::from))
}

/// Whether the world segment from `o` along `d` (t in [0, far]) meets the missing cells' box
/// (grown by a hair, so rays grazing it count as meeting it).
fn meets_missing(grid: &Grid, o: DVec3, d: DVec3) -> bool {
    let (lo, hi) = missing_box();
    let h = grid.spacing();
    let (lo, hi) = (grid.min + (lo - 1e-6) * h, grid.min + (hi + 1e-6) * h);
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < lo[a] || o[a] > hi[a] {
                return false;
            }
        } else {
            let (ta, tb) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
    }
    t0 <= t1
}

/// Rays from around the sphere grid, many of them through the block.
fn rays(rng: &mut Rng, count: usize) -> Vec<(DVec3, DVec3)> {
    (0..count)
        .map(|n| {
            let eye = rng.unit_vector() * rng.range(1.8, 3.0);
            // Half of them aimed at the block's centre, half at the sphere.
            let target = if n % 2 == 0 {
                DVec3::new(0.66, 0.05, 0.05) + 0.15 * rng.unit_vector()
            } else {
                0.5 * rng.unit_vector()
            };
            (eye, (target - eye).normalize())
        })
        .collect()
}

#[test]
fn analytic_reference_has_no_hit_in_missing_cells_and_the_rest_unchanged() {
    let (plain, holed) = (sphere(), holed());
    let opts = AnalyticOptions::default();
    let mut rng = Rng::new(2901);
    let (mut same, mut through, mut beyond) = (0, 0, 0);
    for (o, d) in rays(&mut rng, 600) {
        let a = analytic::trace(&plain, 0.0, Inside::Below, o, d, &opts);
        let b = analytic::trace(&holed, 0.0, Inside::Below, o, d, &opts);
        if let Some(h) = &b.hit {
            let c = h.cell.map(|c| c as usize);
            assert!(!missing(&holed, c), "hit in missing cell {c:?}");
        }
        if !meets_missing(&plain, o, d) {
            assert_eq!(a.hit, b.hit, "a ray clear of the block changed");
            assert_eq!((a.crossings, a.cells_total), (b.crossings, b.cells_total));
            same += 1;
        } else {
            through += 1;
            let hit_in_block = a.hit.as_ref().is_some_and(|h| {
                let c = h.cell.map(|c| c as usize);
                missing(&holed, c)
            });
            if hit_in_block {
                // The surface there is gone: a miss or a later hit behind the block.
                assert!(b.hit.as_ref().map_or(true, |h| h.t > a.hit.as_ref().unwrap().t));
                beyond += 1;
            }
        }
    }
    assert!(same > 100 && through > 100 && beyond > 50, "{same} {through} {beyond}");
}

#[test]
fn fixed_step_reference_has_no_hit_in_missing_cells_and_the_rest_unchanged() {
    let (plain, holed) = (sphere(), holed());
    let mut rng = Rng::new(2902);
    let (mut same, mut gone) = (0, 0);
    for (o, d) in rays(&mut rng, 600) {
        let a = fixed_step::march(&plain, 0.0, Inside::Below, o, d, 96);
        let b = fixed_step::march(&holed, 0.0, Inside::Below, o, d, 96);
        if let Some(h) = &b.hit {
            assert!(!missing(&holed, h.cell), "hit in missing cell {:?}", h.cell);
        }
        if !meets_missing(&plain, o, d) {
            assert_eq!(a, b, "a ray clear of the block changed");
            same += 1;
        } else if a.hit.is_some_and(|h| missing(&holed, h.cell)) {
            gone += 1;
        }
    }
    assert!(same > 100 && gone > 50, "{same} {gone}");
}

/// Index-space centroid of triangle `t` of `m` on the grid of [`sphere`].
fn centroid(grid: &Grid, m: &Mesh, t: usize) -> DVec3 {
    let tri = m.triangle(t);
    let sum: DVec3 = tri.iter().map(|&v| v3(m.positions[v as usize])).sum();
    (sum / 3.0 - grid.min) / grid.spacing()
}

/// Whether index-space point `u` lies in the missing cells' box: strictly (`open`), or in it
/// grown by one cell (a dropped quad's other triangle has its vertices in the cells around a
/// missing one).
fn in_missing(u: DVec3, open: bool) -> bool {
    let (lo, hi) = missing_box();
    if open {
        u.cmpgt(lo).all() && u.cmplt(hi).all()
    } else {
        u.cmpge(lo - 1.0).all() && u.cmple(hi + 1.0).all()
    }
}

/// The mesh of `algo` with the default settings (`mesh_error`: the octree).
fn mesh_of(grid: &Grid, algo: MeshAlgorithm, mesh_error: Option<f64>) -> Mesh {
    let opts = ExtractOptions { split: QuadSplit::Fixed, keep_quads: false };
    let sharp = SharpSettings { mesh_error, ..SharpSettings::default() };
    reference(grid, &Request::new(0.0, Inside::Below, algo).with_opts(opts).with_sharp(sharp))
        .unwrap()
}

#[test]
fn meshes_lose_the_missing_cells_faces_and_keep_the_rest_in_order() {
    let (plain, holed) = (sphere(), holed());
    for algo in MeshAlgorithm::ALL {
        let (a, b) = (mesh_of(&plain, algo, None), mesh_of(&holed, algo, None));
        let what = algo.name();
        // No vertex at a missing sample or in the block's interior.
        for p in &b.positions {
            let u = (v3(*p) - holed.min) / holed.spacing();
            assert!(u.is_finite(), "{what}: vertex {u}");
            let (lo, hi) = (
                DVec3::new(BLOCK[0][0] as f64, BLOCK[1][0] as f64, BLOCK[2][0] as f64),
                DVec3::new(BLOCK[0][1] as f64, BLOCK[1][1] as f64, BLOCK[2][1] as f64),
            );
            assert!(!(u.cmpge(lo).all() && u.cmple(hi).all()), "{what}: vertex {u} in the block");
        }
        assert!(b.normals.iter().all(|n| v3(*n).is_finite()), "{what}: normals");
        if matches!(algo, MeshAlgorithm::DualContouringQef | MeshAlgorithm::ExtendedMc) {
            // Their vertices come from Hermite normals, which beside a missing cell average
            // the finite cells only: the cells next to the block move. Farther away the plain
            // mesh's vertices in order, and no face in the missing cells.
            let far = |p: &[f32; 3]| !in_missing((v3(*p) - holed.min) / holed.spacing(), false);
            let mut next = a.positions.iter().filter(|p| far(p));
            for p in b.positions.iter().filter(|p| far(p)) {
                assert!(next.any(|q| q == p), "{what}: vertex {p:?} is not the plain mesh's");
            }
            for t in 0..b.triangle_count() {
                assert!(!in_missing(centroid(&holed, &b, t), true), "{what}: triangle in block");
            }
            assert!(b.triangle_count() > 100 && b.triangle_count() < a.triangle_count());
            continue;
        }
        // b's vertices are a's in order, less some (matched by position).
        let mut map = Vec::with_capacity(b.vertex_count());
        let mut next = 0;
        for p in &b.positions {
            while next < a.vertex_count() && a.positions[next] != *p {
                next += 1;
            }
            assert!(next < a.vertex_count(), "{what}: vertex {p:?} is not the plain mesh's");
            map.push(next as u32);
            next += 1;
        }
        // b's triangles are a's in order, less those of missing cells.
        let mut kept = 0;
        let (mut dropped, mut t) = (0, 0);
        for tb in 0..b.triangle_count() {
            let want = b.triangle(tb).map(|v| map[v as usize]);
            while t < a.triangle_count() && a.triangle(t) != want {
                assert!(in_missing(centroid(&plain, &a, t), false), "{what}: triangle {t} lost");
                dropped += 1;
                t += 1;
            }
            assert!(
                t < a.triangle_count(),
                "{what}: triangle {tb} {want:?} is not the plain mesh's"
            );
            assert!(!in_missing(centroid(&holed, &b, tb), true), "{what}: triangle in the block");
            kept += 1;
            t += 1;
        }
        for t in t..a.triangle_count() {
            assert!(in_missing(centroid(&plain, &a, t), false), "{what}: triangle {t} lost");
            dropped += 1;
        }
        assert!(kept > 100 && dropped > 10, "{what}: kept {kept}, dropped {dropped}");
    }
    // The octree of dual-contouring-qef: collapses differ near the block, but nothing is in it.
    let b = mesh_of(&holed, MeshAlgorithm::DualContouringQef, Some(0.01));
    assert!(b.triangle_count() > 100);
    for t in 0..b.triangle_count() {
        assert!(!in_missing(centroid(&holed, &b, t), true), "octree: triangle in the block");
    }
}

#[test]
fn a_finite_grid_meshes_as_before_and_an_all_missing_one_is_empty() {
    // Every sample missing: nothing at all, for every method.
    let mut none = sphere();
    none.values.iter_mut().for_each(|v| *v = f32::NAN);
    for algo in MeshAlgorithm::ALL {
        let m = reference(&none, &Request::new(0.0, Inside::Below, algo)).unwrap();
        assert_eq!((m.vertex_count(), m.triangle_count()), (0, 0), "{}", algo.name());
    }
    // -inf is missing too, though it compares below every isovalue.
    let mut low = holed();
    for v in &mut low.values {
        if v.is_nan() {
            *v = f32::NEG_INFINITY;
        }
    }
    let a = mesh_of(&holed(), MeshAlgorithm::MarchingCubes, None);
    let b = mesh_of(&low, MeshAlgorithm::MarchingCubes, None);
    assert_eq!((a.positions, a.indices), (b.positions, b.indices));
}

#[test]
fn slices_show_no_data_and_draw_no_contour_in_missing_cells() {
    use isoview::scene::Ambiguity;
    use isoview::slice::contour::{self, ContourOptions};
    use isoview::slice::plane::{Axis, PlaneGrid};
    let (plain, holed) = (sphere(), holed());
    // z through the block: index 11.5.
    let at = holed.min.z + 11.5 * holed.spacing().z;
    let opts = ContourOptions {
        isovalue: 0.0,
        inside: Inside::Below,
        ambiguity: Ambiguity::Average,
        max_depth: 0,
    };
    let pa = PlaneGrid::new(&plain, Axis::Z, at).unwrap();
    let pb = PlaneGrid::new(&holed, Axis::Z, at).unwrap();
    let (ca, cb) =
        (contour::extract(&pa, None, &opts).unwrap(), contour::extract(&pb, None, &opts).unwrap());
    let (lo, hi) = missing_box();
    let inside_block = |q: DVec2| q.x > lo.x && q.x < hi.x && q.y > lo.y && q.y < hi.y;
    let count = |set: &contour::ContourSet| -> (usize, usize) {
        let pts = set.contours.iter().flat_map(|c| c.points.iter());
        pts.fold((0, 0), |(i, o), &q| if inside_block(q) { (i + 1, o) } else { (i, o + 1) })
    };
    let ((ia, oa), (ib, ob)) = (count(&ca), count(&cb));
    assert!(ia > 0 && ib == 0, "contour points in the block: {ia} plain, {ib} holed");
    assert!(ob + 2 >= oa && ob > 0, "the rest of the contour stays: {oa} vs {ob}");
    // The value image: NaN exactly where the pixel's cell is missing.
    let (w, h) = (40, 40);
    let values = isoview::slice::reference::values(&holed, &pb, w, h);
    let mut nan = 0;
    for py in 0..h {
        for px in 0..w {
            let u = pb.pixel_grid_point(px, py, w, h);
            let c = holed.cell_of(u);
            let v = values[(py * w + px) as usize];
            assert_eq!(v.is_nan(), missing(&holed, c), "pixel ({px}, {py}) cell {c:?}: {v}");
            nan += v.is_nan() as usize;
        }
    }
    assert!(nan > 0);
    let (lo, hi) = pb.range();
    assert!(lo.is_finite() && hi.is_finite());
}

/// A random grid with a tenth of its samples NaN (and a few ±inf).
fn sprinkled(rng: &mut Rng, dims: [usize; 3]) -> Grid {
    let mut g = random_grid(rng, dims);
    for v in &mut g.values {
        match rng.next_u64() % 40 {
            0..=3 => *v = f32::NAN,
            4 => *v = f32::INFINITY,
            5 => *v = f32::NEG_INFINITY,
            _ => {}
        }
    }
    g
}

/// GPU pixels against the reference's: no GPU hit in a missing cell; hit or miss the same but
/// for a few rays within rounding of a surface or a missing cell's face.
fn check_pixels(grid: &Grid, gpu: &[Pixel], reference: &[Pixel], what: &str) -> (usize, usize) {
    let diag = (grid.max - grid.min).length();
    let (mut hits, mut differ) = (0, 0);
    for (n, (g, r)) in gpu.iter().zip(reference).enumerate() {
        if g.is_hit() {
            let c = g.cell.map(|c| c as usize);
            assert!(!missing(grid, c), "{what}: pixel {n}: GPU hit in missing cell {c:?}");
        }
        if g.is_hit() != r.is_hit()
            || (g.is_hit() && (g.depth - r.depth).abs() as f64 > 1e-3 * diag)
        {
            differ += 1;
        }
        hits += r.is_hit() as usize;
    }
    (hits, differ)
}

#[gpu_test]
fn gpu_ray_methods_match_the_references_with_missing_samples() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(2903);
    for method in [Method::Analytic, Method::FixedStep] {
        let (mut hits, mut differ, mut rays) = (0, 0, 0);
        for case in 0..10 {
            let dims = [0; 3].map(|_| 3 + (rng.next_u64() % 10) as usize);
            let grid = if case == 0 { holed() } else { sprinkled(&mut rng, dims) };
            let eye = random_eye(&mut rng, &grid, case % 4 == 3);
            let mut scene = scene_for(&grid, eye, 40, method);
            scene.surface.isovalue = if case == 0 { 0.0 } else { rng.range(-0.3, 0.3) };
            scene.render.skip = case % 2 == 0;
            if case % 3 == 2 {
                // Two surfaces: the nearest crossing of either, missing cells skipped for both.
                scene.surface.more[0] = scene.surface.isovalue + 0.2;
                scene.surface.count = 2;
            }
            let frame = renderer.render(&scene, &grid, 0.0).unwrap();
            let reference = reference_pixels(&scene, &grid);
            let what = format!("{method:?} case {case}");
            let (h, d) = check_pixels(&grid, &frame.pixels, &reference, &what);
            (hits, differ, rays) = (hits + h, differ + d, rays + frame.pixels.len());
        }
        assert!(hits * 10 > rays, "{method:?}: too few hits ({hits} of {rays})");
        assert!(differ * 200 <= rays, "{method:?}: {differ} of {rays} rays differ");
    }
}

#[gpu_test]
fn gpu_brick_ranges_leave_missing_samples_out() {
    use isoview::passes::bricks;
    use isoview::render::GpuGrid;
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut rng = Rng::new(2904);
    for dims in [[9, 9, 9], [19, 10, 26], [40, 41, 30]] {
        let mut grid = sprinkled(&mut rng, dims);
        // One brick all missing (NaN and both infinities): [inf, -inf].
        for k in 0..=8 {
            for j in 0..=8 {
                for i in 0..=8 {
                    let n = grid.index(i, j, k);
                    grid.values[n] = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY][n % 3];
                }
            }
        }
        let gpu_grid = GpuGrid::upload(&ctx, &grid).unwrap();
        let scene = scene_for(&grid, random_eye(&mut rng, &grid, false), 8, Method::Analytic);
        renderer.render_uploaded(&scene, &grid, &gpu_grid, 0.0).unwrap();
        let built = gpu_grid.bricks().expect("built by the analytic render");
        let expected = bricks::levels(grid.dims, &bricks::reference(&grid));
        assert_eq!(expected[0], [f32::INFINITY, f32::NEG_INFINITY]);
        assert!(expected.iter().all(|mm| !mm[0].is_nan() && !mm[1].is_nan()));
        let seen: Vec<[f32; 2]> = read_device_buffer(&ctx, built, expected.len());
        assert_eq!(seen, expected, "dims {dims:?}");
    }
}

#[gpu_test]
fn gpu_extraction_equals_cpu_with_missing_samples() {
    use isoview::gpu::Image3d;
    use isoview::passes::extract::{Extractor, GpuExtractOptions};
    let ctx = gpu();
    let mut extractor = Extractor::new(&ctx).unwrap();
    let mut rng = Rng::new(2905);
    let opts = GpuExtractOptions { split: QuadSplit::Fixed, ..Default::default() };
    for algo in [
        MeshAlgorithm::MarchingCubes,
        MeshAlgorithm::Mc33,
        MeshAlgorithm::MarchingTetrahedra,
        MeshAlgorithm::SurfaceNets,
        MeshAlgorithm::DualContouring,
    ] {
        let mut tris = 0;
        for round in 0..12 {
            let dims = [0; 3].map(|_| 3 + (rng.next_u64() % 10) as usize);
            let grid = if round == 0 { holed() } else { sprinkled(&mut rng, dims) };
            let iso = if round == 0 { 0.0 } else { rng.range(-0.4, 0.4) };
            let inside = Inside::ALL[round % 2];
            let what = format!("{} round {round} dims {:?}", algo.name(), grid.dims);
            let cpu_opts = ExtractOptions { split: QuadSplit::Fixed, keep_quads: false };
            let reference =
                reference(&grid, &Request::new(iso, inside, algo).with_opts(cpu_opts)).unwrap();
            let image =
                Image3d::upload(&ctx, "grid", grid.dims.map(|d| d as u32), &grid.values).unwrap();
            let mesh =
                extractor.extract(&grid, &image, iso, inside, algo, &opts).unwrap().read().unwrap();
            assert_eq!(mesh.vertex_count(), reference.vertex_count(), "{what}: vertices");
            let tol = grid.spacing() * 1e-4;
            for v in 0..mesh.vertex_count() {
                let (g, r) = (v3(mesh.positions[v]), v3(reference.positions[v]));
                assert!((g - r).abs().cmple(tol).all(), "{what}: vertex {v} {g} vs {r}");
                let (gn, rn) = (v3(mesh.normals[v]), v3(reference.normals[v]));
                assert!((gn - rn).length() < 1e-2, "{what}: normal {v} {gn} vs {rn}");
            }
            assert_eq!(mesh.indices, reference.indices, "{what}: triangles");
            if round == 0 {
                for t in 0..mesh.triangle_count() {
                    let c = centroid(&grid, &mesh, t);
                    assert!(!in_missing(c, true), "{what}: triangle {t} in the block");
                }
            }
            tris += mesh.triangle_count();
        }
        assert!(tris > 100, "{}: {tris} triangles", algo.name());
    }
}

/// A raw f32 file of the holed sphere and a scene `name` over it (extra `[field]` lines in
/// `field`).
fn raw_scene(dir: &std::path::Path, name: &str, field: &str) -> String {
    let grid = holed();
    let bytes: Vec<u8> = grid.values.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(dir.join("holed.raw"), bytes).unwrap();
    write(
        dir,
        name,
        &format!(
            "[field]\nsource = \"raw\"\npath = \"holed.raw\"\ndims = [{N}, {N}, {N}]\n\
             dtype = \"f32\"\n{field}\n[surface]\nisovalue = 0.3\n\
             [image]\nwidth = 32\nheight = 32\n[camera]\neye = [40, 12, 12]\ntarget = [11.5, 11.5, 11.5]\n"
        ),
    )
}

#[test]
fn files_with_missing_samples_load_by_default_and_error_keeps_the_refusal() {
    let dir = scratch("nan-cli");
    let scene = raw_scene(&dir, "s.toml", "");
    let out = isoview(&["stats", &scene], &[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("non-finite  180 sample(s)"), "{text}");
    let ply = dir.join("m.ply");
    let out = isoview(&["extract", &scene, "-o", ply.to_str().unwrap()], &[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(ply.exists());

    let refused = raw_scene(&dir, "e.toml", "nan = \"error\"");
    let out = isoview(&["stats", &refused], &[]);
    assert_fails(&out, 2, &["holed.raw", "at grid point [15, 9, 9]", "is not finite"]);
    let out = isoview(&["stats", &scene, "--set", "field.nan=error"], &[]);
    assert_fails(&out, 2, &["is not finite"]);
    let out = isoview(&["stats", &scene, "--set", "field.nan=maybe"], &[]);
    assert_fails(&out, 2, &["field.nan", "\"error\"", "\"empty\""]);
    // A memory-mapped extraction reads the file a window at a time: the same two answers.
    let active = raw_scene(&dir, "a.toml", "residency = \"active\"");
    let out = isoview(&["extract", &active, "-o", ply.to_str().unwrap()], &[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let x = dir.join("x.ply");
    let sets = ["--set", "field.nan=error", "-o", x.to_str().unwrap()];
    let out = isoview(&[&["extract", active.as_str()][..], &sets[..]].concat(), &[]);
    assert_fails(&out, 2, &["holed.raw", "at grid point [15, 9, 9]", "is not finite"]);
    assert!(!x.exists());
}

#[test]
fn probe_says_why_a_cell_has_no_surface() {
    let dir = scratch("nan-probe");
    let scene = raw_scene(&dir, "s.toml", "");
    // The centre pixel looks along -x through the block's rows.
    let out = isoview(&["probe", &scene, "--pixel", "16,16"], &[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("holds a non-finite sample: no surface"), "{text}");
    let out = isoview(&["probe", &scene, "--pixel", "16,16", "--json"], &[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("holds a non-finite sample: no surface"), "{text}");
}

/// Seventh attack pass: a ray whose samples are all missing data, or that takes none, has no
/// "closest sample": the probe printed "closest sample is NaN from the isovalue" (all NaN) and
/// "inf" (all infinite, or a ray past the box). It says which.
#[test]
fn probe_says_why_fixed_step_has_no_closest_sample() {
    let dir = scratch("nan-probe-march");
    let field = "[field]\nsource = \"expr\"\nexpression = \"sqrt(-1 - x*x)\"\n\
                 resolution = [5, 5, 5]\n[surface]\nisovalue = 0.5\n\
                 [image]\nwidth = 8\nheight = 8\n";
    let scene = write(&dir, "s.toml", field);
    // The corner pixel of a wide view from far away passes the box by.
    let past = "camera.eye=[0, 0, 40]; camera.fov_y_deg=170";
    for (pixel, set, want) in [
        ("4,4", "render.steps=64", "no crossing found: none of the 64 samples on the ray"),
        ("4,4", "field.expression=\"1/0\"; render.steps=100", "none of the 100 samples on the"),
        ("0,0", past, "no sample taken: the ray misses the field's box"),
    ] {
        let mut args = vec!["probe", &scene, "--pixel", pixel];
        for s in set.split("; ") {
            args.extend(["--set", s]);
        }
        let out = isoview(&args, &[]);
        assert_eq!(out.status.code(), Some(0), "{set}: {}", stderr(&out));
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.contains(want) && !text.contains("closest sample"), "{set}: {text}");
        args.push("--json");
        let out = isoview(&args, &[]);
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(json["fixed_step"]["miss"].as_str().map(|m| m.contains(want)), Some(true));
    }
    // A ray with a finite sample still names the closest one.
    let out =
        isoview(&["probe", &scene, "--pixel", "4,4", "--set", "field.expression=\"x-5\""], &[]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("no crossing found (closest sample is"), "{text}");
}

#[gpu_test]
fn gpu_slice_shows_no_data_where_the_reference_does() {
    use isoview::render::GpuGrid;
    use isoview::scene::Ambiguity;
    use isoview::slice::contour::{self, ContourOptions};
    use isoview::slice::image::{colormap_half_range, SliceRenderer, SliceStyle};
    use isoview::slice::plane::{Axis, PlaneGrid};
    let ctx = gpu();
    let mut renderer = SliceRenderer::new(&ctx).unwrap();
    let mut rng = Rng::new(2906);
    for trial in 0..6 {
        let dims = [0; 3].map(|_| 3 + (rng.next_u64() % 15) as usize);
        let grid = if trial == 0 { holed() } else { sprinkled(&mut rng, dims) };
        let axis = [Axis::X, Axis::Y, Axis::Z][trial % 3];
        let a = axis.index();
        let f = if trial == 0 { 16.5 / (N - 1) as f64 } else { rng.range(0.0, 1.0) };
        let at = grid.min[a] + f * (grid.max[a] - grid.min[a]);
        let plane = PlaneGrid::new(&grid, axis, at).unwrap();
        let inside = Inside::ALL[trial % 2];
        let opts =
            ContourOptions { isovalue: 0.1, inside, ambiguity: Ambiguity::Average, max_depth: 0 };
        let set = contour::extract(&plane, None, &opts).unwrap();
        let (w, h) = (37, 29);
        let style = SliceStyle {
            width: w,
            height: h,
            isovalue: 0.1,
            inside,
            half_range: colormap_half_range(&plane, 0.1),
            line_width: 1.5,
            line_color: [0.0, 0.0, 0.0, 1.0],
        };
        let gpu_grid = GpuGrid::upload(&ctx, &grid).unwrap();
        let image = renderer.render(&gpu_grid, &plane, &set.contours, &style).unwrap();
        let reference = isoview::slice::reference::values(&grid, &plane, w, h);
        let no_data = isoview::slice::reference::NO_DATA;
        let mut gaps = 0;
        let mut face = 0;
        for (n, (p, r)) in image.pixels.iter().zip(&reference).enumerate() {
            if p.value.is_nan() != r.is_nan() {
                // The GPU finds the pixel's cell in f32: only a point within rounding of a
                // cell face may land in the cell next to the reference's.
                let u = plane.pixel_grid_point(n as u32 % w, n as u32 / w, w, h);
                let near = (0..3).any(|a| (u[a] - u[a].round()).abs() < 1e-4);
                assert!(near, "trial {trial} pixel {n} at {u}: {} vs {r}", p.value);
                face += 1;
                continue;
            }
            if r.is_nan() {
                gaps += 1;
                if p.contour == 0.0 {
                    assert_eq!(p.rgba[..3], no_data, "trial {trial} pixel {n}");
                }
            } else {
                assert!((p.value as f64 - r).abs() < 1e-4, "trial {trial} pixel {n}");
            }
        }
        assert!(gaps > 0 && face * 50 <= gaps, "trial {trial}: {gaps} missing, {face} on faces");
    }
}

#[test]
fn colour_by_a_field2_with_missing_samples_keeps_a_finite_range() {
    use isoview::field::FieldSpec;
    use isoview::render::color::Colorer;
    use isoview::scene::{ColorBy, Scene};
    let mut scene = Scene::new(FieldSpec::from_grid(sphere()));
    scene.field2 = Some(FieldSpec::from_grid(holed()));
    scene.color.by = ColorBy::Field2;
    let c = Colorer::new(&scene, &sphere(), 0.0).unwrap().expect("colours by field2");
    let (lo, hi) = (c.legend.lo, c.legend.hi);
    assert!(lo.is_finite() && hi.is_finite() && lo < hi, "{lo} {hi}");
    let (plain_lo, plain_hi) = sphere().range();
    assert!(lo >= f64::from(plain_lo) && hi <= f64::from(plain_hi));
    // In the block: no value, the colormap's low end (a colour, not NaN).
    let g = holed();
    let p = g.point(17, 11, 11);
    assert!(c.value(p, 0).is_nan());
    assert!(c.base(f64::NAN).is_finite());
    assert!(c.value(g.point(3, 3, 3), 0).is_finite());
}

#[gpu_test]
fn brick_pool_renders_equal_whole_grid_renders_with_missing_samples() {
    use isoview::field::SampleType;
    use isoview::field::{
        DataAccess, Endian, FieldSource, FieldSpec, GridLimits, RawSource, Residency,
    };
    use isoview::render::{pool, Collect};
    use isoview::vocab::{Bounds, Placement};
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    // The pool walks brick by brick: so does the whole grid's render here (`steps` compares).
    renderer.accel = isoview::render::Accel::Plain;
    let dir = scratch("nan-pool");
    let mut rng = Rng::new(2907);
    let n = 49;
    let mut grid = grid_from([n; 3], DVec3::splat(-1.0), DVec3::ONE, |p| p.length() - 0.6);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let block =
                    (31..=38).contains(&i) && (19..=28).contains(&j) && (19..=28).contains(&k);
                let corner = i <= 8 && j <= 8 && k <= 8; // a whole brick missing
                if block || corner || rng.next_u64() % 500 == 0 {
                    let at = grid.index(i, j, k);
                    grid.values[at] = f32::NAN;
                }
            }
        }
    }
    let file = dir.join("g.raw");
    let bytes: Vec<u8> = grid.values.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(&file, bytes).unwrap();
    for (c, method) in
        [Method::Analytic, Method::Analytic, Method::FixedStep].into_iter().enumerate()
    {
        let eye = DVec3::new(2.5, 0.4, 0.3) + 0.5 * rng.unit_vector();
        let mut scene = scene_for(&grid, eye, 40, method);
        scene.render.skip = c == 0;
        let whole = renderer.render(&scene, &grid, 0.0).unwrap().pixels;
        let mut mapped_scene = scene.clone();
        mapped_scene.field = FieldSpec {
            source: FieldSource::Raw(RawSource {
                path: file.clone(),
                dims: grid.dims,
                dtype: SampleType::F32,
                endian: Endian::Little,
                access: DataAccess::Any,
            }),
            resolution: grid.dims,
            bounds: Bounds { min: grid.min, max: grid.max },
            placement: Placement::IDENTITY,
            residency: Residency::Active,
            nan: Default::default(),
            interpolation: Default::default(),
        };
        let limits = GridLimits::default();
        let mapped = pool::mapped_for(&mapped_scene, &limits).unwrap().unwrap();
        let pooled = pool::upload_for(&ctx, &mapped_scene, &*mapped, &limits).unwrap();
        let mut sink = Collect::default();
        renderer.render_to(&mapped_scene, &pooled.shape, &pooled.gpu, 0.0, &mut sink).unwrap();
        let pixels = sink.into_frame().unwrap().pixels;
        assert!(whole.iter().filter(|p| p.is_hit()).count() > 100, "{method:?}: too few hits");
        for (i, (a, b)) in whole.iter().zip(&pixels).enumerate() {
            assert_eq!(bytemuck::bytes_of(a), bytemuck::bytes_of(b), "{method:?} pixel {i}");
        }
        // And no hit in a missing cell.
        for p in whole.iter().filter(|p| p.is_hit()) {
            assert!(!missing(&grid, p.cell.map(|c| c as usize)), "{method:?}: {p:?}");
        }
    }
}
