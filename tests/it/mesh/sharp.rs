//! Sharp-feature meshes (`dual-contouring-qef`) against answers known in advance: a box's
//! corners and edges, a rotated cube, a CSG notch (concave creases), Hausdorff distances to
//! the exact surface against surface nets', closed and oriented meshes, the threaded CPU path
//! against the reference, and the scene keys.
//!
//! Each geometric check is also run on a mesh it must reject (the mean-vertex
//! `dual-contouring`, which rounds corners and edges), so a check that cannot fail is caught.

use std::path::Path;

use glam::{DMat3, DVec3};
use isoview::field::{Grid, GridLimits, PointField};
use isoview::mesh::stats;
use isoview::mesh::{extract, reference, ExtractOptions, Mesh, MeshBudget, Request};
use isoview::scene::{self, HermiteNormals, Inside, MeshAlgorithm, SharpSettings};

/// Grid points per axis of the test grids over [-1, 1]³, and the cell size.
const N: usize = 33;
const H: f64 = 2.0 / (N as f64 - 1.0);

/// An analytic field: a function of world position.
type Sdf = dyn Fn(DVec3) -> f64 + Sync;

/// The grid of `f` over [-1, 1]³ with `n` points per axis.
fn sample(f: &Sdf, n: usize) -> Grid {
    let mut g = Grid {
        dims: [n; 3],
        min: DVec3::splat(-1.0),
        max: DVec3::ONE,
        values: Vec::with_capacity(n * n * n),
    };
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = g.point(i, j, k);
                g.values.push(f(p) as f32);
            }
        }
    }
    g
}

fn box_sdf(p: DVec3, half: DVec3) -> f64 {
    let q = p.abs() - half;
    q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
}

/// The test box: half extents and centre off the grid's planes.
const HALF: DVec3 = DVec3::new(0.53, 0.41, 0.47);
const CENTRE: DVec3 = DVec3::new(0.013, -0.021, 0.007);

fn the_box(p: DVec3) -> f64 {
    box_sdf(p - CENTRE, HALF)
}

/// The cube of half side 0.45, rotated by 0.7 rad about (1, 2, 3).
fn rotation() -> DMat3 {
    DMat3::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7)
}
fn rotated_cube(p: DVec3) -> f64 {
    box_sdf(rotation().transpose() * (p - CENTRE), DVec3::splat(0.45))
}

/// A CSG notch: the test box minus a box around its (+, +, +) corner, leaving three concave
/// edges and a concave corner at `notch_corner()`.
const NOTCH_HALF: DVec3 = DVec3::new(0.23, 0.19, 0.21);
fn notch_corner() -> DVec3 {
    CENTRE + HALF - NOTCH_HALF
}
fn notched(p: DVec3) -> f64 {
    the_box(p).max(-box_sdf(p - (CENTRE + HALF), NOTCH_HALF))
}

/// The mesh of `f` with `algo`, Hermite data from `hermite`.
fn mesh_of(f: &'static Sdf, algo: MeshAlgorithm, hermite: HermiteNormals) -> Mesh {
    let g = sample(f, N);
    let src = PointField { eval: Box::new(f), lipschitz: None };
    let sharp = SharpSettings { hermite, ..Default::default() };
    reference(&g, &Request::new(0.0, Inside::Below, algo).with_sharp(sharp).with_source(Some(&src)))
        .unwrap()
}

fn dcqef(f: &'static Sdf) -> Mesh {
    mesh_of(f, MeshAlgorithm::DualContouringQef, HermiteNormals::Source)
}

/// The mean-vertex dual contouring of `f`: the mesh every check must reject.
fn rounded(f: &'static Sdf) -> Mesh {
    mesh_of(f, MeshAlgorithm::DualContouring, HermiteNormals::Source)
}

fn v(p: [f32; 3]) -> DVec3 {
    DVec3::from(p.map(f64::from))
}

/// The distance from `corner` to the nearest vertex.
fn corner_error(m: &Mesh, corner: DVec3) -> f64 {
    m.positions.iter().map(|&p| v(p).distance(corner)).fold(f64::INFINITY, f64::min)
}

/// Each corner has a vertex on it within 1e-3 of a cell (the vertex of the cell holding it;
/// the cells around it have theirs on the edges, which [`edge_straight`] checks).
fn corners_sharp(m: &Mesh, corners: &[DVec3]) -> Result<(), String> {
    for &c in corners {
        let e = corner_error(m, c);
        if e > 1e-3 * H {
            return Err(format!("corner {c}: nearest vertex {e:e} away (cell {H})"));
        }
    }
    Ok(())
}

/// Along the edge from `a` to `b` (an edge of `f`'s surface, sampled as grid `g`), at every
/// half cell from half a cell after `a` to half a cell before `b`: where the cell holding that
/// point has crossings on the two faces meeting at the edge and no other, its vertex (the one inside the cell:
/// vertices are clamped into their cells) lies on the edge's line within 1e-3 of a cell, so
/// the vertices along the edge are collinear. Returns how many points were checked and how
/// many were skipped (cells seeing one face only, or a third face near a corner: their
/// vertex is the corner, or, for a corner in the next cell, clamped off the line).
fn edge_straight(
    m: &Mesh,
    g: &Grid,
    f: &Sdf,
    a: DVec3,
    b: DVec3,
) -> Result<(usize, usize), String> {
    let d = (b - a).normalize();
    let len = a.distance(b);
    let (mut checked, mut skipped) = (0, 0);
    let mut t = 0.5 * H;
    while t < len - 0.5 * H {
        let q = a + d * t;
        t += 0.5 * H;
        let cell = ((q + 1.0) / H).floor();
        if faces_seen(g, f, cell) != 2 {
            skipped += 1;
            continue;
        }
        let (lo, hi) = (cell * H - 1.0 - 1e-9, (cell + 1.0) * H - 1.0 + 1e-9);
        let off = m
            .positions
            .iter()
            .map(|&p| v(p))
            .filter(|p| p.cmpge(lo).all() && p.cmple(hi).all())
            .map(|p| (p - a).reject_from_normalized(d).length())
            .fold(f64::INFINITY, f64::min);
        if off > 1e-3 * H {
            return Err(format!(
                "edge {a} → {b} at {t:.3}: the cell's vertex is {off:e} off the line"
            ));
        }
        checked += 1;
    }
    Ok((checked, skipped))
}

/// The 8 corners of the box `centre ± half` seen through `rot`.
fn corners(centre: DVec3, half: DVec3, rot: DMat3) -> Vec<DVec3> {
    (0..8)
        .map(|n| {
            let s = DVec3::new(
                if n & 1 == 0 { -1.0 } else { 1.0 },
                if n & 2 == 0 { -1.0 } else { 1.0 },
                if n & 4 == 0 { -1.0 } else { 1.0 },
            );
            centre + rot * (s * half)
        })
        .collect()
}

/// The 12 edges of the box (pairs of corner numbers differing in one bit).
fn box_edges(c: &[DVec3]) -> Vec<(DVec3, DVec3)> {
    let mut e = Vec::new();
    for a in 0..8 {
        for bit in [1, 2, 4] {
            if a & bit == 0 {
                e.push((c[a], c[a | bit]));
            }
        }
    }
    e
}

/// How many distinct planes (normals more than 30° apart) the crossings of cell `cell`'s
/// crossed edges lie on, crossings and normals from the exact field `f`.
fn faces_seen(g: &Grid, f: &Sdf, cell: DVec3) -> usize {
    let [i, j, k] = cell.to_array().map(|x| x as usize);
    let mut normals: Vec<DVec3> = Vec::new();
    for axis in 0..3 {
        for m in 0..4 {
            let mut a = [i, j, k];
            a[(axis + 1) % 3] += m & 1;
            a[(axis + 2) % 3] += m >> 1;
            let pa = g.point(a[0], a[1], a[2]);
            let mut pb = pa;
            pb[axis] += H;
            if (f(pa) < 0.0) == (f(pb) < 0.0) {
                continue;
            }
            let (mut lo, mut hi) = (pa, pb);
            for _ in 0..60 {
                let mid = (lo + hi) / 2.0;
                if (f(mid) < 0.0) == (f(pa) < 0.0) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let e = 1e-7;
            let n = DVec3::new(
                f(lo + DVec3::X * e) - f(lo - DVec3::X * e),
                f(lo + DVec3::Y * e) - f(lo - DVec3::Y * e),
                f(lo + DVec3::Z * e) - f(lo - DVec3::Z * e),
            )
            .normalize();
            if normals.iter().all(|o| o.dot(n) < 30f64.to_radians().cos()) {
                normals.push(n);
            }
        }
    }
    normals.len()
}

fn closed_and_oriented(m: &Mesh, what: &str) {
    let s = stats::compute(m);
    assert!(s.triangles > 0, "{what}: {s}");
    assert_eq!(s.boundary_edges, 0, "{what}: {s}");
    assert_eq!(s.inconsistent_edges, 0, "{what}: {s}");
    assert_eq!(s.unreferenced_vertices, 0, "{what}: {s}");
    assert!(s.volume > 0.0, "{what}: {s}");
}

// ---- Hausdorff distance ------------------------------------------------------------------------

/// Points of the exact surface `f = 0`: the vertices of a 3× finer marching-cubes mesh,
/// projected onto the surface by a few Newton steps along the (central-difference) gradient,
/// more than two cells inside the grid's box (where a mesh open at the box, as the adaptive
/// one, stops short of it).
fn surface_points(f: &'static Sdf) -> Vec<DVec3> {
    let fine = sample(f, 3 * (N - 1) + 1);
    let m = isoview::mesh::reference(
        &fine,
        &isoview::mesh::Request::new(0.0, Inside::Below, MeshAlgorithm::MarchingCubes),
    )
    .unwrap();
    m.positions
        .iter()
        .map(|&p| {
            let mut p = v(p);
            for _ in 0..8 {
                let e = 1e-6;
                let g = DVec3::new(
                    f(p + DVec3::X * e) - f(p - DVec3::X * e),
                    f(p + DVec3::Y * e) - f(p - DVec3::Y * e),
                    f(p + DVec3::Z * e) - f(p - DVec3::Z * e),
                ) / (2.0 * e);
                if g.length_squared() == 0.0 {
                    break;
                }
                p -= g * (f(p) / g.length_squared());
            }
            p
        })
        .filter(|&p| f(p).abs() < 1e-9 && p.abs().max_element() < 1.0 - 2.0 * H)
        .collect()
}

/// The symmetric Hausdorff distance between `m` and the surface of `f` (world units): the
/// mesh side by |f| at each triangle's vertices, edge midpoints and centroid (f is a signed
/// distance, or close to one near the surface), the surface side by the distance from each of
/// [`surface_points`] to the nearest triangle.
fn hausdorff(m: &Mesh, f: &'static Sdf) -> f64 {
    let tris: Vec<[DVec3; 3]> = (0..m.triangle_count())
        .map(|t| m.triangle(t).map(|i| v(m.positions[i as usize])))
        .collect();
    let mut worst = 0.0f64;
    for [a, b, c] in &tris {
        for p in
            [*a, *b, *c, (*a + *b) / 2.0, (*b + *c) / 2.0, (*c + *a) / 2.0, (*a + *b + *c) / 3.0]
        {
            worst = worst.max(f(p).abs());
        }
    }
    // Triangles bucketed by the cells their boxes touch, to find near ones fast.
    let key = |p: DVec3| ((p + 1.5) / H).floor().as_ivec3();
    let mut buckets: std::collections::HashMap<glam::IVec3, Vec<usize>> = Default::default();
    for (t, [a, b, c]) in tris.iter().enumerate() {
        let (lo, hi) = (key(a.min(*b).min(*c)), key(a.max(*b).max(*c)));
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    buckets.entry(glam::IVec3::new(x, y, z)).or_default().push(t);
                }
            }
        }
    }
    for p in surface_points(f) {
        let k = key(p);
        let mut best = f64::INFINITY;
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    for &t in buckets.get(&(k + glam::IVec3::new(dx, dy, dz))).into_iter().flatten()
                    {
                        let [a, b, c] = tris[t];
                        best = best
                            .min(p.distance(isoview::field::mesh_sdf::closest_point(p, a, b, c)));
                    }
                }
            }
        }
        // Nothing within a cell: at least a cell away (enough for these comparisons).
        worst = worst.max(if best.is_finite() { best } else { H });
    }
    worst
}

// ---- tests -------------------------------------------------------------------------------------

#[test]
fn box_corners_land_on_the_corners() {
    let c = corners(CENTRE, HALF, DMat3::IDENTITY);
    let m = dcqef(&the_box);
    corners_sharp(&m, &c).unwrap();
    assert!(corners_sharp(&rounded(&the_box), &c).is_err(), "the check rejects rounded corners");
}

#[test]
fn box_edges_are_straight() {
    let c = corners(CENTRE, HALF, DMat3::IDENTITY);
    let m = dcqef(&the_box);
    let g = sample(&the_box, N);
    for (a, b) in box_edges(&c) {
        let (checked, skipped) = edge_straight(&m, &g, &the_box, a, b).unwrap();
        assert!(checked >= 10 && skipped <= 2, "{a} → {b}: {checked} checked, {skipped} skipped");
    }
    let r = rounded(&the_box);
    assert!(box_edges(&c).iter().all(|&(a, b)| edge_straight(&r, &g, &the_box, a, b).is_err()));
}

#[test]
fn rotated_cube_corners_and_edges() {
    let c = corners(CENTRE, DVec3::splat(0.45), rotation());
    let m = dcqef(&rotated_cube);
    // Dual contouring reproduces a corner when the cell holding it has crossings on all three
    // faces meeting there; where the tip pokes into a cell without covering any of its samples
    // (the cell is inactive) or its crossed edges reach only two faces, the vertex stays on an
    // edge and the tip is cut off (Ju et al. 2002: features are recovered from the cell's own
    // Hermite data). Which corners qualify is worked out from the exact field here.
    let g = sample(&rotated_cube, N);
    let covered: Vec<DVec3> = c
        .iter()
        .copied()
        .filter(|&k| faces_seen(&g, &rotated_cube, ((k + 1.0) / H).floor()) == 3)
        .collect();
    eprintln!("{} of 8 corners have crossings on three faces in their cell", covered.len());
    assert!(covered.len() >= 4, "{covered:?}");
    corners_sharp(&m, &covered).unwrap();
    let (mut checked, mut skipped) = (0, 0);
    for (a, b) in box_edges(&c) {
        let (c, s) = edge_straight(&m, &g, &rotated_cube, a, b).unwrap();
        (checked, skipped) = (checked + c, skipped + s);
    }
    eprintln!("rotated cube edges: {checked} points checked, {skipped} skipped");
    assert!(checked > 3 * skipped, "{checked} checked, {skipped} skipped");
    closed_and_oriented(&m, "rotated cube");
    assert!(corners_sharp(&rounded(&rotated_cube), &c).is_err());
}

#[test]
fn csg_notch_keeps_its_concave_corner_and_creases() {
    let m = dcqef(&notched);
    closed_and_oriented(&m, "notch");
    let k = notch_corner();
    let top = CENTRE + HALF;
    // The concave corner, and the notch's three convex corners on the box's faces.
    let notch =
        [k, DVec3::new(k.x, k.y, top.z), DVec3::new(k.x, top.y, k.z), DVec3::new(top.x, k.y, k.z)];
    corners_sharp(&m, &notch).unwrap();
    // The three concave creases from the concave corner.
    let g = sample(&notched, N);
    for axis in 0..3 {
        let mut end = k;
        end[axis] = top[axis];
        let (checked, skipped) = edge_straight(&m, &g, &notched, k, end).unwrap();
        assert!(
            checked >= 4 && skipped <= 2,
            "crease {axis}: {checked} checked, {skipped} skipped"
        );
    }
    assert!(corners_sharp(&rounded(&notched), &notch[..1]).is_err());
}

#[test]
fn hausdorff_far_below_surface_nets() {
    for (name, f) in
        [("box", &the_box as &'static Sdf), ("notch", &notched), ("cube", &rotated_cube)]
    {
        let sharp = hausdorff(&dcqef(f), f);
        let nets = hausdorff(&mesh_of(f, MeshAlgorithm::SurfaceNets, HermiteNormals::Source), f);
        eprintln!("{name}: Hausdorff dual-contouring-qef {sharp:.2e}, surface-nets {nets:.2e}");
        if name == "cube" {
            // The rotated cube's uncovered corner tips (see rotated_cube_corners_and_edges)
            // are cut off by both methods; they dominate both distances.
            assert!(sharp * 1.5 < nets, "{name}: {sharp} vs surface nets' {nets}");
        } else {
            assert!(sharp < 1e-3 * H, "{name}: {sharp} (cell {H})");
            assert!(sharp * 100.0 < nets, "{name}: {sharp} vs surface nets' {nets}");
        }
    }
}

#[test]
fn trilinear_hermite_data_also_sharpens() {
    // From the samples alone the planes near a feature are blurred by the interpolant, so the
    // corners are not exact, but the mesh is still much closer than the mean-vertex one.
    let f: &'static Sdf = &the_box;
    let m = mesh_of(f, MeshAlgorithm::DualContouringQef, HermiteNormals::Trilinear);
    closed_and_oriented(&m, "trilinear box");
    let sharp = hausdorff(&m, f);
    let mean = hausdorff(&mesh_of(f, MeshAlgorithm::DualContouring, HermiteNormals::Trilinear), f);
    eprintln!("trilinear: Hausdorff dual-contouring-qef {sharp:.2e}, dual-contouring {mean:.2e}");
    assert!(sharp * 1.5 < mean, "{sharp} vs {mean}");
}

#[test]
fn box_volume_and_closure() {
    let m = dcqef(&the_box);
    closed_and_oriented(&m, "box");
    let s = stats::compute(&m);
    let exact = 8.0 * HALF.x * HALF.y * HALF.z;
    assert!((s.volume - exact).abs() < 1e-4 * exact, "volume {} vs {exact}", s.volume);
}

/// The threaded path equals the reference bit for bit, for both Hermite sources, unclamped
/// too, on blobs touching the grid's boundary (padding cells) and a box.
#[test]
fn slabs_equal_the_reference() {
    let blobs: &'static Sdf = &|p: DVec3| {
        let a = (p - DVec3::new(0.3, 0.2, -0.1)).length() - 0.5;
        let b = (p - DVec3::new(-0.4, -0.1, 0.5)).length() - 0.7;
        a.min(b).max(-(p.z + 0.6))
    };
    for f in [blobs, &the_box as &'static Sdf] {
        let g = sample(f, 20);
        let src = PointField { eval: Box::new(f), lipschitz: None };
        for hermite in HermiteNormals::ALL {
            for qef_clamp in [true, false] {
                let sharp = SharpSettings { hermite, qef_clamp, ..Default::default() };
                let opts = ExtractOptions::default();
                let algo = MeshAlgorithm::DualContouringQef;
                let one = reference(
                    &g,
                    &Request::new(0.0, Inside::Below, algo)
                        .with_opts(opts)
                        .with_sharp(sharp)
                        .with_source(Some(&src)),
                )
                .unwrap();
                closed_and_oriented(&one, "blobs");
                for depth in [1, 3, 7] {
                    let s = extract(
                        &g,
                        &Request::new(0.0, Inside::Below, algo)
                            .with_opts(opts)
                            .with_sharp(sharp)
                            .with_source(Some(&src))
                            .with_slab_depth(Some(depth)),
                        &MeshBudget::unlimited(),
                    )
                    .unwrap();
                    assert_eq!(s, one, "depth {depth}, {hermite:?}, clamp {qef_clamp}");
                }
            }
        }
    }
}

#[test]
fn hermite_source_needs_a_point_source() {
    let g = sample(&the_box, 8);
    let sharp = SharpSettings { hermite: HermiteNormals::Source, ..Default::default() };
    let algo = MeshAlgorithm::DualContouringQef;
    let e = reference(&g, &Request::new(0.0, Inside::Below, algo).with_sharp(sharp)).unwrap_err();
    assert!(e.to_string().contains("hermite = \"source\""), "{e}");
}

fn parse(text: &str) -> Result<scene::Scene, scene::SceneError> {
    scene::from_str_with(text, "t.toml", Path::new("."), &[], &GridLimits::default())
}

#[test]
fn scene_keys() {
    let sdf = "[field]\nsource = \"sdf\"\nshape = \"box\"\nhalf_extents = [0.5, 0.4, 0.3]\n\
               resolution = [9, 9, 9]\nbounds = { min = [-1, -1, -1], max = [1, 1, 1] }\n";
    let s = parse(&format!(
        "{sdf}[render]\nmesh = \"dual-contouring-qef\"\nhermite = \"source\"\n\
         qef_threshold = 0.05\nqef_clamp = false\n"
    ))
    .unwrap();
    assert_eq!(s.render.mesh, MeshAlgorithm::DualContouringQef);
    assert_eq!(s.render.sharp.hermite, HermiteNormals::Source);
    assert_eq!(s.render.sharp.qef_threshold, 0.05);
    assert!(!s.render.sharp.qef_clamp);
    assert_eq!(parse(sdf).unwrap().render.sharp, SharpSettings::default());

    let e = parse(&format!("{sdf}[render]\nqef_threshold = 1.5\n")).unwrap_err().to_string();
    assert!(e.contains("t.toml:8:17: render.qef_threshold: must be in (0, 1)"), "{e}");
    let s = parse(&format!("{sdf}[render]\nmesh = \"extended-mc\"\nfeature_angle = 45\n")).unwrap();
    assert_eq!(
        (s.render.mesh, s.render.sharp.feature_angle_deg),
        (MeshAlgorithm::ExtendedMc, 45.0)
    );
    let e = parse(&format!("{sdf}[render]\nfeature_angle = 180\n")).unwrap_err().to_string();
    assert!(e.contains("render.feature_angle: must be in (0, 180) degrees"), "{e}");
    let e = parse(&format!("{sdf}[render]\nhermite = \"exact\"\n")).unwrap_err().to_string();
    assert!(e.contains("render.hermite") && e.contains("trilinear"), "{e}");
    let npy = "[field]\nsource = \"npy\"\npath = \"scenes/data/blobs.npy\"\n[render]\n\
               hermite = \"source\"\n";
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let e = scene::from_str_with(npy, "t.toml", root, &[], &GridLimits::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("t.toml:5:11: render.hermite: \"source\""), "{e}");
}

// ---- extended marching cubes -------------------------------------------------------------------

fn emc(f: &'static Sdf) -> Mesh {
    mesh_of(f, MeshAlgorithm::ExtendedMc, HermiteNormals::Source)
}

fn manifold(m: &Mesh, what: &str) {
    closed_and_oriented(m, what);
    let s = stats::compute(m);
    assert!(s.is_closed_manifold(), "{what}: {s}");
}

#[test]
fn emc_box_corners_edges_and_hausdorff() {
    let c = corners(CENTRE, HALF, DMat3::IDENTITY);
    let m = emc(&the_box);
    manifold(&m, "emc box");
    corners_sharp(&m, &c).unwrap();
    let g = sample(&the_box, N);
    for (a, b) in box_edges(&c) {
        let (checked, skipped) = edge_straight(&m, &g, &the_box, a, b).unwrap();
        assert!(checked >= 10 && skipped <= 2, "{a} → {b}: {checked} checked, {skipped} skipped");
    }
    let mc = mesh_of(&the_box, MeshAlgorithm::MarchingCubes, HermiteNormals::Source);
    assert!(corners_sharp(&mc, &c).is_err(), "the check rejects marching cubes' corners");
    let (sharp, plain) = (hausdorff(&m, &the_box), hausdorff(&mc, &the_box));
    eprintln!("box: Hausdorff extended-mc {sharp:.2e}, marching-cubes {plain:.2e}");
    assert!(sharp < 1e-3 * H && sharp * 100.0 < plain, "{sharp} vs {plain}");
}

#[test]
fn emc_notch_and_rotated_cube() {
    let m = emc(&notched);
    manifold(&m, "emc notch");
    corners_sharp(&m, &[notch_corner()]).unwrap();
    let (sharp, plain) = (
        hausdorff(&m, &notched),
        hausdorff(
            &mesh_of(&notched, MeshAlgorithm::MarchingCubes, HermiteNormals::Source),
            &notched,
        ),
    );
    eprintln!("notch: Hausdorff extended-mc {sharp:.2e}, marching-cubes {plain:.2e}");
    assert!(sharp < 1e-3 * H && sharp * 100.0 < plain, "{sharp} vs {plain}");

    let m = emc(&rotated_cube);
    manifold(&m, "emc cube");
    let (sharp, plain) = (
        hausdorff(&m, &rotated_cube),
        hausdorff(
            &mesh_of(&rotated_cube, MeshAlgorithm::MarchingCubes, HermiteNormals::Source),
            &rotated_cube,
        ),
    );
    eprintln!("cube: Hausdorff extended-mc {sharp:.2e}, marching-cubes {plain:.2e}");
    assert!(sharp * 1.5 < plain, "{sharp} vs {plain}");
}

/// Without features (a smooth sphere, a wide feature angle) extended MC is marching cubes, bit
/// for bit, and the threaded path is the reference.
#[test]
fn emc_without_features_is_marching_cubes() {
    let sphere: &'static Sdf = &|p: DVec3| (p - CENTRE).length() - 0.71;
    let g = sample(sphere, 21);
    let sharp = SharpSettings { feature_angle_deg: 60.0, ..Default::default() };
    let opts = ExtractOptions::default();
    let e = reference(
        &g,
        &Request::new(0.0, Inside::Below, MeshAlgorithm::ExtendedMc)
            .with_opts(opts)
            .with_sharp(sharp),
    )
    .unwrap();
    let mc = isoview::mesh::reference(
        &g,
        &isoview::mesh::Request::new(0.0, Inside::Below, MeshAlgorithm::MarchingCubes)
            .with_opts(opts),
    )
    .unwrap();
    assert_eq!(e, mc);
    let t = isoview::mesh::extract(
        &g,
        &isoview::mesh::Request::new(0.0, Inside::Below, MeshAlgorithm::ExtendedMc)
            .with_opts(opts)
            .with_sharp(SharpSettings::default()),
        &isoview::mesh::MeshBudget::unlimited(),
    )
    .unwrap();
    let r = reference(
        &g,
        &Request::new(0.0, Inside::Below, MeshAlgorithm::ExtendedMc)
            .with_opts(opts)
            .with_sharp(SharpSettings::default()),
    )
    .unwrap();
    assert_eq!(t, r);
}

// ---- adaptive octree ---------------------------------------------------------------------------

/// The adaptive mesh of `f` at `eps` (world units) and the uniform one.
fn adaptive(f: &'static Sdf, eps: f64, hermite: HermiteNormals) -> (Mesh, Mesh) {
    let g = sample(f, N);
    let src = PointField { eval: Box::new(f), lipschitz: None };
    let algo = MeshAlgorithm::DualContouringQef;
    let opts = ExtractOptions::default();
    let uniform = SharpSettings { hermite, ..Default::default() };
    let sharp = SharpSettings { mesh_error: Some(eps), ..uniform };
    (
        reference(
            &g,
            &Request::new(0.0, Inside::Below, algo)
                .with_opts(opts)
                .with_sharp(sharp)
                .with_source(Some(&src)),
        )
        .unwrap(),
        reference(
            &g,
            &Request::new(0.0, Inside::Below, algo)
                .with_opts(opts)
                .with_sharp(uniform)
                .with_source(Some(&src)),
        )
        .unwrap(),
    )
}

#[test]
fn adaptive_sphere_box_and_plane() {
    let sphere: &'static Sdf = &|p: DVec3| (p - CENTRE).length() - 0.71;
    let plane: &'static Sdf = &|p: DVec3| DVec3::new(0.3, 0.1, 1.0).normalize().dot(p) - 0.05;
    for (name, f, closed) in
        [("sphere", sphere, true), ("box", &the_box as &'static Sdf, true), ("plane", plane, false)]
    {
        for eps in [0.1 * H, 0.5 * H, 2.0 * H] {
            let (a, u) = adaptive(f, eps, HermiteNormals::Source);
            let s = stats::compute(&a);
            let d = hausdorff(&a, f);
            eprintln!(
                "{name} eps {eps:.4}: {} triangles adaptive, {} uniform; Hausdorff {d:.2e}",
                a.triangle_count(),
                u.triangle_count()
            );
            assert_eq!(s.inconsistent_edges, 0, "{name}: {s}");
            assert_eq!(s.non_manifold_edges, 0, "{name}: {s}");
            if closed {
                manifold(&a, name);
            }
            assert!(d <= eps, "{name} eps {eps}: Hausdorff {d}");
            if eps >= 0.5 * H {
                assert!(a.triangle_count() * 3 < u.triangle_count(), "{name}: {s}");
            }
        }
    }
}

// ---- command line ------------------------------------------------------------------------------

/// `isoview extract` with the new meshes: the CPU mesh whatever device is asked for (a note
/// says so), the library's mesh; bad keys are one line and exit 2.
#[test]
fn extract_cli_runs_the_sharp_meshes() {
    use crate::common::{isoview, stderr};
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene_path = root.join("scenes/box.toml").display().to_string();
    let dir = std::env::temp_dir().join(format!("isoview-sharp-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("m.ply").display().to_string();
    for (mesh, extra) in [
        ("dual-contouring-qef", "render.mesh_error=0.05"),
        ("extended-mc", "render.feature_angle=40"),
    ] {
        let sets = [
            "--set",
            &format!("render.mesh=\"{mesh}\""),
            "--set",
            "render.hermite=\"source\"",
            "--set",
            extra,
        ];
        let mut args = vec!["extract", &scene_path, "-o", &out, "--device", "gpu", "--stats"];
        args.extend_from_slice(&sets);
        let o = isoview(&args, &[]);
        let err = stderr(&o);
        assert!(o.status.success(), "{err}");
        assert!(err.contains(&format!("{mesh} is extracted on the CPU")), "{err}");
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(text.contains("boundary edges: 0"), "{text}");
    }
    // Uniform, trilinear: the GPU passes.
    let o = isoview(
        &[
            "extract",
            &scene_path,
            "-o",
            &out,
            "--device",
            "gpu",
            "--set",
            "render.mesh=\"dual-contouring-qef\"",
        ],
        &[],
    );
    let err = stderr(&o);
    assert!(o.status.success() && err.contains("(dual-contouring-qef on gpu"), "{err}");
    let o = isoview(
        &["extract", &scene_path, "-o", &out, "--set", "render.mesh_error=0.05", "--device", "cpu"],
        &[],
    );
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(err.contains("render.mesh_error") && err.trim().lines().count() == 1, "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

// ---- docs figures --------------------------------------------------------------------------------

/// docs/meshes.md's table and picture for the sharp-feature section (not a check): triangle counts,
/// Hausdorff distances and single-thread times of each method on the box of `scenes/box.toml`
/// and the CSG shape of `docs/sharp/csg.toml` (Hermite data from the source), and
/// `docs/sharp.png` rendered by isoview itself (`render.method = "mesh"`, normal shading).
/// `cargo test --test it sharp::readme_figures -- --ignored --nocapture`.
#[test]
#[ignore = "writes docs/sharp.png and prints docs/meshes.md's table"]
fn readme_figures() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scenes = ["scenes/box.toml", "docs/sharp/csg.toml"];
    let runs: [(&str, MeshAlgorithm, Option<f64>); 7] = [
        ("marching-cubes", MeshAlgorithm::MarchingCubes, None),
        ("surface-nets", MeshAlgorithm::SurfaceNets, None),
        ("dual-contouring", MeshAlgorithm::DualContouring, None),
        ("dual-contouring-qef", MeshAlgorithm::DualContouringQef, None),
        ("extended-mc", MeshAlgorithm::ExtendedMc, None),
        ("dual-contouring-qef, mesh_error = ½ cell", MeshAlgorithm::DualContouringQef, Some(0.5)),
        ("dual-contouring-qef, mesh_error = 2 cells", MeshAlgorithm::DualContouringQef, Some(2.0)),
    ];
    println!("| shape | mesh | triangles | Hausdorff (cells) | ms (one thread) |");
    println!("|---|---|---:|---:|---:|");
    for path in scenes {
        let scene: &'static scene::Scene =
            Box::leak(Box::new(scene::load(&root.join(path), &[]).unwrap()));
        let grid = scene.field.sample(0.0).unwrap();
        let cell = grid.spacing().x;
        let src: &'static PointField =
            Box::leak(Box::new(PointField::from_spec(&scene.field, 0.0).unwrap()));
        let f: &'static Sdf = Box::leak(Box::new(move |p: DVec3| (src.eval)(p)));
        for (name, algo, eps) in runs {
            let sharp = SharpSettings {
                hermite: HermiteNormals::Source,
                mesh_error: eps.map(|e| e * cell),
                ..Default::default()
            };
            let t = std::time::Instant::now();
            let m = reference(
                &grid,
                &Request::new(0.0, Inside::Below, algo).with_sharp(sharp).with_source(Some(src)),
            )
            .unwrap();
            let ms = t.elapsed().as_secs_f64() * 1e3;
            let d = hausdorff(&m, f) / cell;
            println!("| {path} | {name} | {} | {d:.3} | {ms:.0} |", m.triangle_count());
        }
    }

    // The picture: 5 columns (marching cubes, surface nets, DC-QEF, extended MC, adaptive at one
    // cell), one row per shape, each tile rendered by `isoview render`.
    let out = std::env::temp_dir().join(format!("isoview-sharp-{}", std::process::id()));
    std::fs::create_dir_all(&out).unwrap();
    let columns: [(&str, &[&str]); 5] = [
        ("mc", &["render.mesh=\"marching-cubes\""]),
        ("sn", &["render.mesh=\"surface-nets\""]),
        ("dcqef", &["render.mesh=\"dual-contouring-qef\"", "render.hermite=\"source\""]),
        ("emc", &["render.mesh=\"extended-mc\"", "render.hermite=\"source\""]),
        (
            "adaptive",
            &[
                "render.mesh=\"dual-contouring-qef\"",
                "render.hermite=\"source\"",
                "render.mesh_error=0.0645",
            ],
        ),
    ];
    let tile = 200u32;
    let mut sheet =
        image::RgbaImage::from_pixel(tile * 5, tile * 2, image::Rgba([255, 255, 255, 255]));
    for (row, path) in scenes.iter().enumerate() {
        for (col, (name, sets)) in columns.iter().enumerate() {
            let png = out.join(format!("{row}-{name}.png"));
            let exr = out.join(format!("{row}-{name}.exr"));
            let mut args = vec![
                "render".to_string(),
                root.join(path).display().to_string(),
                "-o".into(),
                exr.display().to_string(),
                "--png".into(),
                png.display().to_string(),
            ];
            for s in [
                "render.method=\"mesh\"",
                "render.shading=\"normal\"",
                "image.width=200",
                "image.height=200",
            ]
            .iter()
            .chain(sets.iter())
            {
                args.extend(["--set".to_string(), s.to_string()]);
            }
            let args: Vec<&str> = args.iter().map(String::as_str).collect();
            let o = crate::common::isoview(&args, &[]);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let img = image::open(&png).unwrap().to_rgba8();
            for (x, y, p) in img.enumerate_pixels() {
                // Over white.
                let a = f32::from(p[3]) / 255.0;
                let c = |i: usize| (f32::from(p[i]) * a + 255.0 * (1.0 - a)).round() as u8;
                sheet.put_pixel(
                    col as u32 * tile + x,
                    row as u32 * tile + y,
                    image::Rgba([c(0), c(1), c(2), 255]),
                );
            }
        }
    }
    image::DynamicImage::ImageRgba8(sheet).to_rgb8().save(root.join("docs/sharp.png")).unwrap();
    std::fs::remove_dir_all(&out).ok();
}
