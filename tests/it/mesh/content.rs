//! Every CPU mesh keeps its content (issue #24): the same vertices, normals and faces in the same
//! order, bit for bit, across the refactors of the extraction methods and the interpolant. The
//! fingerprints below were recorded on `main` at 50d75bd, before those refactors, for each of the
//! 7 methods on small grids (a sphere, a box with sharp edges, noise, NaN and ±inf samples,
//! `inside = "above"`) and the options that change a mesh (quads kept, the fixed quad split,
//! Hermite data from the source, the adaptive octree). A changed fingerprint means a mesh moved:
//! find out why before touching the table.
//!
//! The grids and their noise are built here, not from `common`, so that nothing outside this
//! file can move them.

use glam::DVec3;
use isoview::field::{Grid, PointField};
use isoview::mesh::{extract, reference, ExtractOptions, Mesh, MeshBudget, QuadSplit, Request};
use isoview::scene::{HermiteNormals, Inside, MeshAlgorithm, SharpSettings};

use crate::common::{assert_fingerprints, fnv, FNV_START};

/// The fingerprint of everything a mesh holds: counts, positions' and normals' bits, triangles,
/// quads (and whether there are any).
fn fingerprint(m: &Mesh) -> u64 {
    let mut h = FNV_START;
    let counts = [m.positions.len(), m.normals.len(), m.indices.len()];
    for c in counts {
        h = fnv(h, &(c as u64).to_le_bytes());
    }
    for v in m.positions.iter().chain(&m.normals).flatten() {
        h = fnv(h, &v.to_bits().to_le_bytes());
    }
    for i in &m.indices {
        h = fnv(h, &i.to_le_bytes());
    }
    match &m.quads {
        None => fnv(h, b"no quads"),
        Some(q) => {
            h = fnv(h, &(q.len() as u64).to_le_bytes());
            q.iter().fold(h, |h, i| fnv(h, &i.to_le_bytes()))
        }
    }
}

/// A fixed xorshift generator (this file's own, see the module doc).
struct Noise(u64);
impl Noise {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    /// Uniform in [-1, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

fn sampled(dims: [usize; 3], f: impl Fn(DVec3) -> f64) -> Grid {
    let mut g = Grid { dims, min: DVec3::splat(-1.0), max: DVec3::ONE, values: Vec::new() };
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let v = f(g.point(i, j, k)) as f32;
                g.values.push(v);
            }
        }
    }
    g
}

/// A sphere off the grid's centre.
fn sphere(p: DVec3) -> f64 {
    (p - DVec3::new(0.031, -0.017, 0.023)).length() - 0.61
}

/// A box with its edges and corners off the grid's planes: sharp features.
fn boxed(p: DVec3) -> f64 {
    let q = (p - DVec3::new(0.013, -0.021, 0.007)).abs() - DVec3::new(0.53, 0.41, 0.47);
    q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
}

/// Noise on an uneven grid.
fn noise() -> Grid {
    let mut n = Noise(0x2545_f491_4f6c_dd1d);
    let mut g = sampled([9, 11, 13], |_| 0.0);
    g.values.iter_mut().for_each(|v| *v = n.unit() as f32);
    g
}

/// The sphere with about a tenth of its samples NaN and a few ±inf.
fn holed() -> Grid {
    let mut n = Noise(0x9e37_79b9_7f4a_7c15);
    let mut g = sampled([15, 14, 16], sphere);
    for v in &mut g.values {
        match n.next() % 40 {
            0..=3 => *v = f32::NAN,
            4 => *v = f32::INFINITY,
            5 => *v = f32::NEG_INFINITY,
            _ => {}
        }
    }
    g
}

/// One extraction: what it is called, its grid and its settings.
struct Case<'a> {
    name: String,
    grid: &'a Grid,
    iso: f64,
    inside: Inside,
    algo: MeshAlgorithm,
    opts: ExtractOptions,
    sharp: SharpSettings,
    source: Option<&'a PointField<'a>>,
}

/// Each case's mesh, from the single-threaded reference; the threaded slab path must give the
/// same mesh (it is asserted equal, so one fingerprint covers both).
fn outcomes() -> Vec<(String, u64)> {
    let sphere_grid = sampled([17; 3], sphere);
    let box_grid = sampled([17; 3], boxed);
    let (noise_grid, holed_grid) = (noise(), holed());
    let sphere_src = PointField { eval: Box::new(sphere), lipschitz: Some(1.0) };
    let box_src = PointField { eval: Box::new(boxed), lipschitz: Some(1.0) };
    let grids: [(&str, &Grid, f64, Inside); 6] = [
        ("sphere", &sphere_grid, 0.0, Inside::Below),
        ("sphere above", &sphere_grid, 0.0, Inside::Above),
        ("box", &box_grid, 0.02, Inside::Below),
        ("noise", &noise_grid, 0.1, Inside::Below),
        ("noise above", &noise_grid, -0.2, Inside::Above),
        ("nan", &holed_grid, 0.0, Inside::Below),
    ];
    let mut cases = Vec::new();
    for (what, grid, iso, inside) in grids {
        for algo in MeshAlgorithm::ALL {
            cases.push(Case {
                name: format!("{what} {}", algo.name()),
                grid,
                iso,
                inside,
                algo,
                opts: ExtractOptions::default(),
                sharp: SharpSettings::default(),
                source: None,
            });
        }
    }
    let quad_methods = [
        MeshAlgorithm::SurfaceNets,
        MeshAlgorithm::DualContouring,
        MeshAlgorithm::DualContouringQef,
    ];
    for (what, grid) in [("sphere", &sphere_grid), ("noise", &noise_grid)] {
        for algo in quad_methods {
            for (opt, opts) in [
                ("quads", ExtractOptions { keep_quads: true, ..Default::default() }),
                ("fixed split", ExtractOptions { split: QuadSplit::Fixed, keep_quads: false }),
            ] {
                cases.push(Case {
                    name: format!("{what} {} {opt}", algo.name()),
                    grid,
                    iso: 0.05,
                    inside: Inside::Below,
                    algo,
                    opts,
                    sharp: SharpSettings::default(),
                    source: None,
                });
            }
        }
    }
    let from_source = SharpSettings { hermite: HermiteNormals::Source, ..Default::default() };
    let adaptive = SharpSettings { mesh_error: Some(0.01), ..Default::default() };
    for (what, grid, src) in [("sphere", &sphere_grid, &sphere_src), ("box", &box_grid, &box_src)] {
        for algo in [MeshAlgorithm::DualContouringQef, MeshAlgorithm::ExtendedMc] {
            cases.push(Case {
                name: format!("{what} {} hermite source", algo.name()),
                grid,
                iso: 0.0,
                inside: Inside::Below,
                algo,
                opts: ExtractOptions::default(),
                sharp: from_source,
                source: Some(src),
            });
        }
        for (opt, sharp) in [
            ("mesh_error", adaptive),
            ("mesh_error hermite source", SharpSettings { mesh_error: Some(0.01), ..from_source }),
        ] {
            cases.push(Case {
                name: format!("{what} dual-contouring-qef {opt}"),
                grid,
                iso: 0.0,
                inside: Inside::Below,
                algo: MeshAlgorithm::DualContouringQef,
                opts: ExtractOptions::default(),
                sharp,
                source: Some(src),
            });
        }
    }
    cases
        .iter()
        .map(|c| {
            let (g, opts, sharp) = (c.grid, c.opts, &c.sharp);
            let m = reference(
                g,
                &Request::new(c.iso, c.inside, c.algo)
                    .with_opts(opts)
                    .with_sharp(*sharp)
                    .with_source(c.source),
            )
            .unwrap();
            let threaded = extract(
                g,
                &Request::new(c.iso, c.inside, c.algo)
                    .with_opts(opts)
                    .with_sharp(*sharp)
                    .with_source(c.source)
                    .with_slab_depth(Some(2)),
                &MeshBudget::unlimited(),
            )
            .unwrap();
            assert!(m == threaded, "{}: the slab path differs from the reference", c.name);
            assert!(!m.indices.is_empty(), "{}: an empty mesh fingerprints nothing", c.name);
            (c.name.clone(), fingerprint(&m))
        })
        .collect()
}

#[test]
fn every_cpu_mesh_keeps_its_content() {
    assert_fingerprints(&outcomes(), EXPECTED, "main's meshes at 50d75bd");
}

/// Recorded on `main` at 50d75bd (before #24's method registry and interpolant home).
const EXPECTED: &[(&str, u64)] = &[
    ("sphere marching-cubes", 0x2c74d2098116c399),
    ("sphere mc33", 0x754264855239de24),
    ("sphere surface-nets", 0xb58ab373087ebb1d),
    ("sphere dual-contouring", 0xb58ab373087ebb1d),
    ("sphere marching-tetrahedra", 0xb76ea985da22810e),
    ("sphere dual-contouring-qef", 0x32ce4fb801bac1f5),
    ("sphere extended-mc", 0x2c74d2098116c399),
    ("sphere above marching-cubes", 0xa2de92433934d0ad),
    ("sphere above mc33", 0xd0aa0eeaae702504),
    ("sphere above surface-nets", 0x79de16185145aa81),
    ("sphere above dual-contouring", 0xb48fa029e9364fa5),
    ("sphere above marching-tetrahedra", 0x7fbd4911fa2ff01e),
    ("sphere above dual-contouring-qef", 0x8b763d970b6c8351),
    ("sphere above extended-mc", 0xa2de92433934d0ad),
    ("box marching-cubes", 0xc1e43d50db833ce0),
    ("box mc33", 0xb50f9fb5bd8b2a75),
    ("box surface-nets", 0xcc3e9a5bb2dd0046),
    ("box dual-contouring", 0xcc3e9a5bb2dd0046),
    ("box marching-tetrahedra", 0xfeae305341bf98f6),
    ("box dual-contouring-qef", 0x11e1407d80476dc3),
    ("box extended-mc", 0xdd24ced63bd20534),
    ("noise marching-cubes", 0x4384ffffb1edaefc),
    ("noise mc33", 0xd4cfc15d964a9530),
    ("noise surface-nets", 0x7325579c5eff8725),
    ("noise dual-contouring", 0x978623445dbdb20b),
    ("noise marching-tetrahedra", 0x7f004f6f5b08da1d),
    ("noise dual-contouring-qef", 0xe7f4fde7e63dfb5a),
    ("noise extended-mc", 0x1fea69ee288eaa58),
    ("noise above marching-cubes", 0xb77f6ad015926a72),
    ("noise above mc33", 0xb4b661500e5719a3),
    ("noise above surface-nets", 0x81c4ff47f83ab8f1),
    ("noise above dual-contouring", 0x41e0e3420a8e90c2),
    ("noise above marching-tetrahedra", 0x9f4f82bc5baf7720),
    ("noise above dual-contouring-qef", 0x9181bfe62228c1bd),
    ("noise above extended-mc", 0x1adf27614b876a7a),
    ("nan marching-cubes", 0x817572c654b3b1ab),
    ("nan mc33", 0x3cba3ccbf452333d),
    ("nan surface-nets", 0x0b772cd858c5ccbc),
    ("nan dual-contouring", 0x0b772cd858c5ccbc),
    ("nan marching-tetrahedra", 0x5a79a61f4801de2e),
    ("nan dual-contouring-qef", 0x9e3e2c1783b75bbd),
    ("nan extended-mc", 0x3d665e15215469ab),
    ("sphere surface-nets quads", 0x0791c6a1c2ee5e29),
    ("sphere surface-nets fixed split", 0x33247249b7c0f227),
    ("sphere dual-contouring quads", 0x0791c6a1c2ee5e29),
    ("sphere dual-contouring fixed split", 0x33247249b7c0f227),
    ("sphere dual-contouring-qef quads", 0x6f5e5b00e4300c69),
    ("sphere dual-contouring-qef fixed split", 0xdf1b26bb1e8fcf05),
    ("noise surface-nets quads", 0xc84859a432db84e8),
    ("noise surface-nets fixed split", 0x1b8848927cd1603a),
    ("noise dual-contouring quads", 0x21b29ff808b3076a),
    ("noise dual-contouring fixed split", 0x57222a2f65f8e2dc),
    ("noise dual-contouring-qef quads", 0x4f706b5303ea2020),
    ("noise dual-contouring-qef fixed split", 0x195e6e94c5b09039),
    ("sphere dual-contouring-qef hermite source", 0x3d90a9ef6784cb94),
    ("sphere extended-mc hermite source", 0xd81338577e8758b6),
    ("sphere dual-contouring-qef mesh_error", 0x902f9e10cb3842f7),
    ("sphere dual-contouring-qef mesh_error hermite source", 0x5ab57658a20590b6),
    ("box dual-contouring-qef hermite source", 0x3fe7bd9cef654d86),
    ("box extended-mc hermite source", 0x18dc441fb9064777),
    ("box dual-contouring-qef mesh_error", 0xe59c2063f782eca0),
    ("box dual-contouring-qef mesh_error hermite source", 0xf460c716d48ae48b),
];
