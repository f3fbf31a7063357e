//! Mesh extraction through the public API: topology guarantees per algorithm on random closed
//! fields, closed-form answers (plane, sphere), determinism, scikit-image's marching cubes as a
//! reference, and export round trips through independent readers.

use std::f64::consts::PI;

use glam::DVec3;
use isoview::field::Grid;
use isoview::mesh::export::{self, Format};
use isoview::mesh::stats::{self, MeshStats};
use isoview::mesh::{reference, ExtractOptions, Mesh, QuadSplit, Request};
use isoview::scene::{Inside, MeshAlgorithm};

const ALL: [MeshAlgorithm; 5] = [
    MeshAlgorithm::MarchingCubes,
    MeshAlgorithm::Mc33,
    MeshAlgorithm::MarchingTetrahedra,
    MeshAlgorithm::SurfaceNets,
    MeshAlgorithm::DualContouring,
];

/// Deterministic pseudo-random numbers in [0, 1) (SplitMix64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A grid over `[min, max]` sampling `f` at its points.
fn sample(dims: [usize; 3], min: DVec3, max: DVec3, f: impl Fn(DVec3) -> f64) -> Grid {
    let mut g = Grid { dims, min, max, values: Vec::with_capacity(dims.iter().product()) };
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = g.point(i, j, k);
                g.values.push(f(p) as f32);
            }
        }
    }
    g
}

/// A sum of Gaussian blobs with centres in [0.3, 0.7]³ and widths ≤ 0.08, over [0, 1]³: the
/// level set 0.5 (inside above) stays clear of the box.
fn blobs(seed: u64, n: usize) -> Grid {
    let mut rng = Rng(seed);
    let blobs: Vec<(DVec3, f64, f64)> = (0..6)
        .map(|_| {
            let c = DVec3::new(rng.next(), rng.next(), rng.next()) * 0.4 + 0.3;
            (c, 0.04 + 0.04 * rng.next(), 0.7 + 0.6 * rng.next())
        })
        .collect();
    let g = sample([n, n, n], DVec3::ZERO, DVec3::ONE, |p| {
        blobs.iter().map(|&(c, s, a)| a * (-(p - c).length_squared() / (2.0 * s * s)).exp()).sum()
    });
    assert!(boundary_outside(&g, 0.5, Inside::Above));
    g
}

/// Uniform random values in [-1, 1] inside, +1 (outside for `below`) on the grid boundary: many
/// ambiguous faces and cells.
fn noise(seed: u64, n: usize) -> Grid {
    let mut rng = Rng(seed);
    let mut g = sample([n, n, n], DVec3::ZERO, DVec3::ONE, |_| 0.0);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let edge = [i, j, k].iter().any(|&c| c == 0 || c == n - 1);
                let idx = g.index(i, j, k);
                g.values[idx] = if edge { 1.0 } else { (2.0 * rng.next() - 1.0) as f32 };
            }
        }
    }
    g
}

fn boundary_outside(g: &Grid, iso: f64, inside: Inside) -> bool {
    let [nx, ny, nz] = g.dims;
    (0..nz).all(|k| {
        (0..ny).all(|j| {
            (0..nx).all(|i| {
                let edge = i == 0 || j == 0 || k == 0 || i == nx - 1 || j == ny - 1 || k == nz - 1;
                !edge || !inside.contains(f64::from(g.at(i, j, k)), iso)
            })
        })
    })
}

fn run(g: &Grid, iso: f64, inside: Inside, algo: MeshAlgorithm) -> (Mesh, MeshStats) {
    let m = reference(g, &Request::new(iso, inside, algo)).unwrap();
    let s = stats::compute(&m);
    (m, s)
}

#[test]
fn closed_fields_topology_per_algorithm() {
    for seed in 0..4 {
        let g = blobs(seed, 28);
        for algo in ALL {
            let (_, s) = run(&g, 0.5, Inside::Above, algo);
            let what = format!("{} seed {seed}: {s}", algo.name());
            assert!(s.triangles > 0, "{what}");
            assert_eq!(s.inconsistent_edges, 0, "{what}");
            assert_eq!(s.unreferenced_vertices, 0, "{what}");
            assert!(s.volume > 0.0, "{what}");
            match algo {
                MeshAlgorithm::MarchingCubes
                | MeshAlgorithm::Mc33
                | MeshAlgorithm::MarchingTetrahedra => {
                    assert!(s.is_closed_manifold(), "{what}");
                    assert_eq!(s.euler_characteristic % 2, 0, "{what}");
                }
                _ => assert_eq!(s.boundary_edges, 0, "{what}"),
            }
        }
    }
}

#[test]
fn ambiguous_noise_fields() {
    for seed in 0..4 {
        let g = noise(100 + seed, 12);
        for algo in ALL {
            let (_, s) = run(&g, 0.0, Inside::Below, algo);
            let what = format!("{} seed {seed}: {s}", algo.name());
            assert_eq!(s.inconsistent_edges, 0, "{what}");
            assert_eq!(s.zero_area_triangles, 0, "{what}");
            assert_eq!(s.boundary_edges, 0, "{what}");
            match algo {
                // Bourke's table always separates the inside corners of an ambiguous face, from
                // whichever cell it is seen, so it leaves no holes; it just ignores the trilinear
                // interpolant's topology there.
                MeshAlgorithm::MarchingCubes
                | MeshAlgorithm::Mc33
                | MeshAlgorithm::MarchingTetrahedra => {
                    assert!(s.is_closed_manifold(), "{what}");
                }
                // One vertex per cell: closed, but four quads meet at the dual edge of each
                // ambiguous face.
                _ => assert!(s.non_manifold_edges > 0, "{what}"),
            }
        }
    }
}

#[test]
fn sphere_volume_area_and_normals() {
    let r = 0.7;
    let n = 41;
    let g = sample([n, n, n], DVec3::splat(-1.0), DVec3::ONE, |p| p.length() - r);
    let (v_exact, a_exact) = (4.0 / 3.0 * PI * r * r * r, 4.0 * PI * r * r);
    for algo in ALL {
        let (m, s) = run(&g, 0.0, Inside::Below, algo);
        let what = format!("{}: {s}", algo.name());
        let dv = (s.volume - v_exact) / v_exact;
        let da = (s.area - a_exact) / a_exact;
        eprintln!("sphere {}: volume error {:+.4}, area error {:+.4}", algo.name(), dv, da);
        assert!(dv.abs() < 0.01, "volume error {dv}: {what}");
        assert!(da.abs() < 0.01, "area error {da}: {what}");
        assert_eq!(s.boundary_edges, 0, "{what}");
        assert_eq!(s.euler_characteristic, 2, "{what}");
        // Normals: unit, radial (up to the trilinear interpolant's error at this resolution).
        for (p, q) in m.positions.iter().zip(&m.normals) {
            let (p, q) = (DVec3::from(p.map(f64::from)), DVec3::from(q.map(f64::from)));
            assert!((q.length() - 1.0).abs() < 1e-6);
            assert!(q.dot(p.normalize()) > 0.99, "{}: normal {q} at {p}", algo.name());
        }
    }
}

#[test]
fn plane_from_linear_field_is_exact() {
    // f = x + 2y + 3z, level 0.37 over [-1, 1]³, anisotropic grid: every edge crossing lies on
    // the plane, and the gradient is constant.
    let g = sample([9, 11, 7], DVec3::splat(-1.0), DVec3::ONE, |p| p.x + 2.0 * p.y + 3.0 * p.z);
    let n_exact = DVec3::new(1.0, 2.0, 3.0).normalize();
    for algo in ALL {
        for inside in [Inside::Below, Inside::Above] {
            let (m, s) = run(&g, 0.37, inside, algo);
            assert!(s.triangles > 0);
            let sign = if inside == Inside::Below { 1.0 } else { -1.0 };
            let dc_cap = algo == MeshAlgorithm::DualContouring;
            let mut on_plane = 0;
            for (p, q) in m.positions.iter().zip(&m.normals) {
                let (p, q) = (DVec3::from(p.map(f64::from)), DVec3::from(q.map(f64::from)));
                let off = (p.x + 2.0 * p.y + 3.0 * p.z - 0.37).abs();
                if dc_cap && off > 1e-5 {
                    continue; // a cap vertex on the box face
                }
                on_plane += 1;
                assert!(
                    off < 1e-5,
                    "{} {inside:?}: vertex {p} off the plane by {off}",
                    algo.name()
                );
                if !dc_cap {
                    assert!((q - sign * n_exact).length() < 1e-6, "{}: normal {q}", algo.name());
                }
            }
            assert!(on_plane > 0);
            // Every triangle faces along the normal (caps of dual contouring excepted).
            if !dc_cap {
                for t in 0..m.triangle_count() {
                    let [a, b, c] =
                        m.triangle(t).map(|v| DVec3::from(m.positions[v as usize].map(f64::from)));
                    assert!((b - a).cross(c - a).dot(sign * n_exact) > 0.0, "{}", algo.name());
                }
            }
        }
    }
}

#[test]
fn extraction_is_deterministic_and_inside_rule_symmetric() {
    let g = noise(7, 10);
    let mut neg = g.clone();
    neg.values.iter_mut().for_each(|v| *v = -*v);
    for algo in ALL {
        let a = reference(&g, &Request::new(0.1, Inside::Below, algo)).unwrap();
        let b = reference(&g, &Request::new(0.1, Inside::Below, algo)).unwrap();
        assert_eq!(a, b, "{}", algo.name());
        // Same inside set through the other rule: the same mesh, normals included.
        let c = reference(&neg, &Request::new(-0.1, Inside::Above, algo)).unwrap();
        assert_eq!(a, c, "{}", algo.name());
    }
}

#[test]
fn quads_and_split_rules() {
    let g = blobs(9, 20);
    for algo in [MeshAlgorithm::SurfaceNets, MeshAlgorithm::DualContouring] {
        for split in [QuadSplit::Shorter, QuadSplit::Fixed] {
            let opts = ExtractOptions { split, keep_quads: true };
            let m = reference(&g, &Request::new(0.5, Inside::Above, algo).with_opts(opts)).unwrap();
            let quads = m.quads.as_ref().unwrap();
            assert_eq!(quads.len() / 4 * 2, m.triangle_count());
            for (q, tris) in quads.chunks_exact(4).zip(m.indices.chunks_exact(6)) {
                let mut a: Vec<u32> = tris.to_vec();
                a.sort();
                a.dedup();
                let mut b = q.to_vec();
                b.sort();
                assert_eq!(a, b);
                if split == QuadSplit::Fixed {
                    assert_eq!(tris, [q[0], q[1], q[2], q[0], q[2], q[3]]);
                }
            }
            let s = stats::compute(&m);
            assert_eq!(s.boundary_edges, 0);
            assert_eq!(s.inconsistent_edges, 0);
        }
    }
}

#[test]
fn surface_nets_open_and_dual_contouring_closed_at_the_boundary() {
    // A slab crossing the whole box: surface nets leaves it open at the box, GEL-style dual
    // contouring caps it.
    let g = sample([10, 10, 10], DVec3::ZERO, DVec3::ONE, |p| (p.z - 0.5).abs() - 0.2);
    let (_, sn) = run(&g, 0.0, Inside::Below, MeshAlgorithm::SurfaceNets);
    assert!(sn.boundary_edges > 0, "{sn}");
    let (_, dc) = run(&g, 0.0, Inside::Below, MeshAlgorithm::DualContouring);
    assert!(dc.is_closed_manifold(), "{dc}");
    assert_eq!(dc.euler_characteristic, 2, "{dc}");
    // The capped slab: its volume is close to 1 x 1 x 0.4.
    assert!((dc.volume - 0.4).abs() < 0.05, "{dc}");
}

#[test]
fn values_equal_to_the_isovalue() {
    // Integer-valued field with many samples exactly at the isovalue (outside by the rule):
    // vertices collapse onto grid points and zero-area triangles appear (they are counted), but
    // the combinatorial topology of marching tetrahedra stays a closed manifold.
    let n = 10;
    let g = sample([n, n, n], DVec3::ZERO, DVec3::splat(9.0), |p| {
        let (i, j, k) = (p.x as i64, p.y as i64, p.z as i64);
        if [i, j, k].iter().any(|&c| c == 0 || c == 9) {
            1.0
        } else {
            ((i * 7 + j * 3 + k * 5) % 3 - 1) as f64
        }
    });
    let (_, s) = run(&g, 0.0, Inside::Below, MeshAlgorithm::MarchingTetrahedra);
    assert!(s.is_closed_manifold(), "{s}");
    assert!(s.zero_area_triangles > 0, "{s}");
}

#[test]
fn stats_of_a_known_cube() {
    // The unit cube as 12 triangles, wound outward.
    let positions: Vec<[f32; 3]> =
        (0..8u32).map(|c| [(c & 1) as f32, ((c >> 1) & 1) as f32, ((c >> 2) & 1) as f32]).collect();
    let quads =
        [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let indices: Vec<u32> =
        quads.iter().flat_map(|q| [q[0], q[1], q[2], q[0], q[2], q[3]]).collect();
    let mut m = Mesh { positions, normals: vec![[0.0, 0.0, 1.0]; 8], indices, quads: None };
    let s = stats::compute(&m);
    assert!(s.is_closed_manifold(), "{s}");
    assert!((s.area - 6.0).abs() < 1e-12 && (s.volume - 1.0).abs() < 1e-12, "{s}");
    assert_eq!((s.edges, s.euler_characteristic), (18, 2));
    assert_eq!(s.min_angle_histogram, [0, 0, 0, 0, 12, 0]); // all 45°
                                                            // Flip one triangle: three edges become inconsistent.
    m.indices.swap(0, 1);
    let s = stats::compute(&m);
    assert_eq!(s.inconsistent_edges, 3, "{s}");
    // Drop it: three boundary edges.
    m.indices.drain(0..3);
    let s = stats::compute(&m);
    assert_eq!((s.boundary_edges, s.inconsistent_edges), (3, 0), "{s}");
}

/// scikit-image's `marching_cubes` (tests/data/skimage_mc.py) on the same samples: the same
/// welded vertex set and triangle count.
#[test]
fn marching_cubes_matches_scikit_image() {
    let text = include_str!("../../data/skimage_mc_cassini16.txt");
    let mut n = 0;
    let mut level = 0.0;
    let mut value_sum = 0.0;
    let mut lorensen = (0, 0);
    let mut verts: Vec<DVec3> = Vec::new();
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w[0] {
            "n" => n = w[1].parse().unwrap(),
            "level" => level = w[1].parse().unwrap(),
            "value_sum" => value_sum = w[1].parse().unwrap(),
            "lorensen" => lorensen = (w[1].parse().unwrap(), w[2].parse().unwrap()),
            "v" => verts.push(DVec3::new(
                w[1].parse().unwrap(),
                w[2].parse().unwrap(),
                w[3].parse().unwrap(),
            )),
            _ => {}
        }
    }
    let (c1, c2) = (DVec3::new(5.3, 7.1, 7.7), DVec3::new(10.2, 8.4, 7.2));
    let sq = |p: DVec3, c: DVec3| {
        (p.x - c.x) * (p.x - c.x) + (p.y - c.y) * (p.y - c.y) + (p.z - c.z) * (p.z - c.z)
    };
    let max = DVec3::splat(n as f64 - 1.0);
    let g = sample([n, n, n], DVec3::ZERO, max, |p| sq(p, c1) * sq(p, c2));
    let sum: f64 = g.values.iter().map(|&v| f64::from(v)).sum();
    assert!((sum - value_sum).abs() < 1e-9 * value_sum, "samples differ from the script's");
    // skimage's default treats values above the level as the object; the vertex set does not
    // depend on the rule.
    let (m, s) = run(&g, level, Inside::Below, MeshAlgorithm::MarchingCubes);
    assert_eq!((m.vertex_count(), m.triangle_count()), lorensen, "{s}");
    let mut ours: Vec<DVec3> = m.positions.iter().map(|p| DVec3::from(p.map(f64::from))).collect();
    let key = |p: &DVec3| (p.x, p.y, p.z);
    ours.sort_by(|a, b| key(a).partial_cmp(&key(b)).unwrap());
    verts.sort_by(|a, b| key(a).partial_cmp(&key(b)).unwrap());
    for (a, b) in ours.iter().zip(&verts) {
        assert!((*a - *b).abs().max_element() < 2e-4, "{a} vs scikit-image {b}");
    }
    assert!(s.is_closed_manifold() && s.euler_characteristic == 2, "{s}");
}

fn round_trip_mesh() -> Mesh {
    let g = blobs(3, 16);
    reference(&g, &Request::new(0.5, Inside::Above, MeshAlgorithm::MarchingTetrahedra)).unwrap()
}

#[test]
fn ply_round_trip() {
    use ply_rs_bw::parser::Parser;
    use ply_rs_bw::ply::{DefaultElement, Property};
    let m = round_trip_mesh();
    let mut bytes = Vec::new();
    export::write(&m, Format::Ply, &mut bytes).unwrap();
    let ply = Parser::<DefaultElement>::new().read_ply(&mut bytes.as_slice()).unwrap();
    let float = |e: &DefaultElement, k: &str| match e[k] {
        Property::Float(v) => v,
        ref p => panic!("{k}: {p:?}"),
    };
    let verts = &ply.payload["vertex"];
    assert_eq!(verts.len(), m.vertex_count());
    for (i, v) in verts.iter().enumerate() {
        assert_eq!([float(v, "x"), float(v, "y"), float(v, "z")], m.positions[i]);
        assert_eq!([float(v, "nx"), float(v, "ny"), float(v, "nz")], m.normals[i]);
    }
    let faces: Vec<u32> = ply.payload["face"]
        .iter()
        .flat_map(|f| match &f["vertex_indices"] {
            Property::ListUInt(l) => l.clone(),
            p => panic!("{p:?}"),
        })
        .collect();
    assert_eq!(faces, m.indices);
}

#[test]
fn ply_and_obj_write_quads() {
    let g = blobs(3, 12);
    let opts = ExtractOptions { keep_quads: true, ..Default::default() };
    let m = reference(
        &g,
        &Request::new(0.5, Inside::Above, MeshAlgorithm::DualContouring).with_opts(opts),
    )
    .unwrap();
    let mut bytes = Vec::new();
    export::write(&m, Format::Obj, &mut bytes).unwrap();
    let text = String::from_utf8(bytes).unwrap();
    let faces: Vec<&str> = text.lines().filter(|l| l.starts_with("f ")).collect();
    assert_eq!(faces.len(), m.quads.as_ref().unwrap().len() / 4);
    assert!(faces.iter().all(|f| f.split_whitespace().count() == 5));
}

#[test]
fn obj_round_trip() {
    let m = round_trip_mesh();
    let mut bytes = Vec::new();
    export::write(&m, Format::Obj, &mut bytes).unwrap();
    let opts = tobj::LoadOptions { single_index: true, ..Default::default() };
    let (models, _) = tobj::load_obj_buf(&mut bytes.as_slice(), &opts, |_| unreachable!()).unwrap();
    assert_eq!(models.len(), 1);
    // tobj renumbers vertices in order of first use; compare corner by corner.
    let t = &models[0].mesh;
    assert_eq!(t.indices.len(), m.indices.len());
    let at = |v: &[f32], i: u32| [v[3 * i as usize], v[3 * i as usize + 1], v[3 * i as usize + 2]];
    for (&a, &b) in t.indices.iter().zip(&m.indices) {
        assert_eq!(at(&t.positions, a), m.positions[b as usize]);
        assert_eq!(at(&t.normals, a), m.normals[b as usize]);
    }
}

#[test]
fn stl_round_trip() {
    let m = round_trip_mesh();
    let mut bytes = Vec::new();
    export::write(&m, Format::Stl, &mut bytes).unwrap();
    assert!(!bytes.starts_with(b"solid"));
    let stl = stl_io::read_stl(&mut std::io::Cursor::new(&bytes)).unwrap();
    assert_eq!(stl.faces.len(), m.triangle_count());
    for (t, f) in stl.faces.iter().enumerate() {
        let tri = m.triangle(t);
        for (&sv, &mv) in f.vertices.iter().zip(&tri) {
            let v = stl.vertices[sv];
            assert_eq!([v[0], v[1], v[2]], m.positions[mv as usize]);
        }
        let [a, b, c] = tri.map(|v| glam::Vec3::from(m.positions[v as usize]));
        let n = (b - a).cross(c - a).normalize_or_zero();
        assert_eq!([f.normal[0], f.normal[1], f.normal[2]], n.to_array());
    }
}

#[test]
fn format_from_extension() {
    use std::path::Path;
    assert_eq!(Format::from_path(Path::new("a/b.PLY")), Some(Format::Ply));
    assert_eq!(Format::from_path(Path::new("b.obj")), Some(Format::Obj));
    assert_eq!(Format::from_path(Path::new("b.stl")), Some(Format::Stl));
    assert_eq!(Format::from_path(Path::new("b.exr")), None);
}
