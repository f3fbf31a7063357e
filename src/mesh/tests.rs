//! Unit tests of the extractors on single cells and cell pairs, exhaustively over sign
//! configurations.

use glam::DVec3;

use crate::field::interpolant::trilinear::{gradient as trilinear_gradient, trilerp};

use super::stats::compute;
use super::tables::*;
use super::MeshAlgorithm;
use super::{reference, Mesh, Request};
use crate::field::Grid;
use crate::vocab::Inside;

/// [`trilerp`] at local `(x, y, z)`.
fn trilinear(v: &[f64; 8], x: f64, y: f64, z: f64) -> f64 {
    trilerp(v, DVec3::new(x, y, z))
}

/// A grid over its own index space.
fn grid(dims: [usize; 3], values: Vec<f32>) -> Grid {
    let max = DVec3::new(dims[0] as f64 - 1.0, dims[1] as f64 - 1.0, dims[2] as f64 - 1.0);
    Grid { dims, min: DVec3::ZERO, max, values }
}

/// Deterministic pseudo-random numbers in [0, 1) (SplitMix64).
pub(crate) struct Rng(pub u64);
impl Rng {
    pub fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Values for an inside mask: inside corners get `-m`, outside `+m` (m random in [0.1, 1.1)).
fn values_for(mask: u32, n: usize, rng: &mut Rng) -> Vec<f32> {
    (0..n)
        .map(|c| {
            let m = 0.1 + rng.next();
            if mask & (1 << c) != 0 {
                -m as f32
            } else {
                m as f32
            }
        })
        .collect()
}

fn p64(m: &Mesh, v: u32) -> DVec3 {
    let p = m.positions[v as usize];
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

/// Every boundary edge of `m` lies in a face of the box `[0, hi]`.
fn boundary_edges_on_box(m: &Mesh, hi: DVec3) -> bool {
    use std::collections::HashMap;
    let mut uses: HashMap<(u32, u32), i32> = HashMap::new();
    for t in 0..m.triangle_count() {
        let tri = m.triangle(t);
        for e in 0..3 {
            let (a, b) = (tri[e], tri[(e + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    uses.iter().filter(|(_, &n)| n == 1).all(|(&(a, b), _)| {
        let (pa, pb) = (p64(m, a), p64(m, b));
        (0..3).any(|ax| (pa[ax] == 0.0 && pb[ax] == 0.0) || (pa[ax] == hi[ax] && pb[ax] == hi[ax]))
    })
}

/// Orientation of each connected component of a single-cell patch: summed over its triangles
/// and their vertices, the geometric normal points along the vertices' edges from the inside end
/// to the outside end. (Within a component, consistency is checked by the edge statistics.)
fn orientation_ok(m: &Mesh, mask: u32, hi: DVec3) -> bool {
    let n = m.vertex_count();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], x: usize) -> usize {
        let mut r = x;
        while p[r] != r {
            r = p[r];
        }
        p[x] = r;
        r
    }
    for t in 0..m.triangle_count() {
        let tri = m.triangle(t);
        for e in 0..3 {
            let (a, b) =
                (find(&mut parent, tri[e] as usize), find(&mut parent, tri[(e + 1) % 3] as usize));
            parent[a] = b;
        }
    }
    let mut score = vec![0.0f64; n];
    let inside_at = |p: DVec3| {
        let c = p.x as u32 + 2 * p.y as u32 + 4 * p.z as u32;
        mask & (1 << c) != 0
    };
    for t in 0..m.triangle_count() {
        let tri = m.triangle(t);
        let [a, b, c] = tri.map(|v| p64(m, v));
        let nrm = (b - a).cross(c - a).normalize();
        for &v in &tri {
            // The vertex's edge: round its fractional coordinate down and up.
            let p = p64(m, v);
            let lo = p.floor().min(hi);
            let up = p.ceil();
            let (lo, up) = if lo == up {
                continue;
            } else {
                (lo, up)
            };
            let d = if inside_at(lo) { up - lo } else { lo - up };
            score[find(&mut parent, tri[0] as usize)] += nrm.dot(d);
        }
    }
    (0..n).all(|v| find(&mut parent, v) != v || score[v] > 0.0)
}

#[test]
fn mc_table_matches_bourke_edges() {
    // Bourke's edges as pairs of his vertices, mapped to our corners.
    let bourke = [
        (0, 1),
        (1, 2),
        (2, 3),
        (3, 0),
        (4, 5),
        (5, 6),
        (6, 7),
        (7, 4),
        (0, 4),
        (1, 5),
        (2, 6),
        (3, 7),
    ];
    for (e, &(a, b)) in bourke.iter().enumerate() {
        let (ca, cb) = (MC_VERTEX_CORNER[a], MC_VERTEX_CORNER[b]);
        let (start, axis) = MC_EDGES[e];
        let (lo, hi) = if ca < cb { (ca, cb) } else { (cb, ca) };
        assert_eq!((lo, hi), (start, start | (1 << axis)), "edge {e}");
    }
    for (case, row) in MC_TRIANGLES.iter().enumerate() {
        let mut used = 0u16;
        for &e in row.iter().take_while(|&&e| e >= 0) {
            used |= 1 << e;
        }
        let mut crossed = 0u16;
        for (e, &(a, b)) in bourke.iter().enumerate() {
            if (case >> a) & 1 != (case >> b) & 1 {
                crossed |= 1 << e;
            }
        }
        assert_eq!(used, crossed, "case {case}");
    }
}

#[test]
fn mt_tets_are_positive_and_fill_the_cube() {
    let corner = |c: u8| DVec3::new((c & 1) as f64, ((c >> 1) & 1) as f64, ((c >> 2) & 1) as f64);
    let mut volume = 0.0;
    for t in &MT_TETS {
        let [a, b, c, d] = t.map(corner);
        let det = (b - a).dot((c - a).cross(d - a));
        assert!(det > 0.0, "{t:?}");
        volume += det / 6.0;
        assert_eq!((t[0], t[3]), (0, 7));
    }
    assert!((volume - 1.0).abs() < 1e-12);
}

/// Single cells, all 256 sign patterns, random magnitudes: valid triangles, vertices on the
/// crossed edges, orientation along the gradient, patch closed inside the cell.
fn single_cell_exhaustive(algo: MeshAlgorithm) {
    let mut rng = Rng(7);
    for inside in [Inside::Below, Inside::Above] {
        for mask in 0..256u32 {
            let mut values = values_for(mask, 8, &mut rng);
            if inside == Inside::Above {
                values.iter_mut().for_each(|v| *v = -*v);
            }
            let g = grid([2, 2, 2], values);
            let m = reference(&g, &Request::new(0.0, inside, algo)).unwrap();
            let crossed = (0..12)
                .filter(|&e| {
                    let (c, axis) = MC_EDGES[e];
                    (mask >> c) & 1 != (mask >> (c | 1 << axis)) & 1
                })
                .count();
            if algo == MeshAlgorithm::MarchingCubes {
                assert_eq!(m.vertex_count(), crossed, "mask {mask}");
            }
            assert_eq!(m.triangle_count() == 0, mask == 0 || mask == 255);
            let s = compute(&m);
            assert_eq!(s.zero_area_triangles, 0, "mask {mask}");
            assert_eq!(s.unreferenced_vertices, 0, "mask {mask}");
            assert_eq!(s.non_manifold_edges, 0, "mask {mask}");
            assert_eq!(s.inconsistent_edges, 0, "mask {mask}");
            assert!(
                boundary_edges_on_box(&m, DVec3::ONE),
                "{algo:?} mask {mask}: open inside the cell"
            );
            // Every vertex on the trilinear surface where it is on a cube edge.
            let v: [f64; 8] = g.corners(0, 0, 0).map(f64::from);
            for p in 0..m.vertex_count() {
                let u = p64(&m, p as u32);
                let on_edge = (0..3).filter(|&a| u[a] == 0.0 || u[a] == 1.0).count() >= 2;
                if on_edge {
                    assert!(trilinear(&v, u.x, u.y, u.z).abs() < 1e-6, "mask {mask} vertex {u}");
                }
                let n = DVec3::from(m.normals[p].map(f64::from));
                assert!((n.length() - 1.0).abs() < 1e-6);
            }
            // `mask` is the inside mask for both rules (values were negated for `above`).
            assert!(orientation_ok(&m, mask, DVec3::ONE), "{algo:?} mask {mask}");
            // Orientation against the corners: the volume inside the patch has the sign of ...
            // each triangle faces away from the inside corners on its edges.
            for t in 0..m.triangle_count() {
                let [a, b, c] = m.triangle(t).map(|v| p64(&m, v));
                let n = (b - a).cross(c - a);
                let centroid = (a + b + c) / 3.0;
                // Nearest corner on each side along the normal is not guaranteed; check that
                // the mean inside corner lies behind the triangle for 1-corner cases.
                if mask.count_ones() == 1 || mask.count_ones() == 7 {
                    let lone = if mask.count_ones() == 1 { mask } else { !mask & 0xff };
                    let c = lone.trailing_zeros() as u8;
                    let pc =
                        DVec3::new((c & 1) as f64, ((c >> 1) & 1) as f64, ((c >> 2) & 1) as f64);
                    let facing = n.dot(pc - centroid);
                    let lone_inside = mask.count_ones() == 1;
                    assert_eq!(facing < 0.0, lone_inside, "{algo:?} mask {mask}");
                }
            }
        }
    }
}

#[test]
fn mc_single_cell_all_256_cases() {
    single_cell_exhaustive(MeshAlgorithm::MarchingCubes);
}

#[test]
fn mt_single_cell_all_256_cases() {
    single_cell_exhaustive(MeshAlgorithm::MarchingTetrahedra);
}

/// Two cells side by side along each axis, all 4096 sign patterns: no crack along the shared
/// face (every boundary edge lies on the outer box), and for MT a closed consistent surface.
fn two_cells_exhaustive(algo: MeshAlgorithm) {
    let mut rng = Rng(11);
    for axis in 0..3 {
        let mut dims = [2, 2, 2];
        dims[axis] = 3;
        let hi = DVec3::new(dims[0] as f64 - 1.0, dims[1] as f64 - 1.0, dims[2] as f64 - 1.0);
        for mask in 0..4096u32 {
            let g = grid(dims, values_for(mask, 12, &mut rng));
            let m = reference(&g, &Request::new(0.0, Inside::Below, algo)).unwrap();
            let s = compute(&m);
            assert!(boundary_edges_on_box(&m, hi), "{algo:?} axis {axis} mask {mask}: crack");
            assert_eq!(s.inconsistent_edges, 0, "{algo:?} axis {axis} mask {mask}");
            assert_eq!(s.non_manifold_edges, 0, "{algo:?} axis {axis} mask {mask}");
        }
    }
}

#[test]
fn mc_two_cells_no_cracks() {
    two_cells_exhaustive(MeshAlgorithm::MarchingCubes);
}

#[test]
fn mt_two_cells_no_cracks() {
    two_cells_exhaustive(MeshAlgorithm::MarchingTetrahedra);
}

#[test]
fn dc_closes_every_single_cell_pattern() {
    let mut rng = Rng(3);
    for mask in 1..256u32 {
        let g = grid([2, 2, 2], values_for(mask, 8, &mut rng));
        let algo = MeshAlgorithm::DualContouring;
        let m = reference(&g, &Request::new(0.0, Inside::Below, algo)).unwrap();
        let s = compute(&m);
        assert_eq!(s.boundary_edges, 0, "mask {mask}");
        assert_eq!(s.inconsistent_edges, 0, "mask {mask}");
        assert!(s.volume > 0.0, "mask {mask}");
    }
}

#[test]
fn gradient_matches_finite_differences() {
    let mut rng = Rng(5);
    let v: [f64; 8] = std::array::from_fn(|_| rng.next() * 2.0 - 1.0);
    for _ in 0..100 {
        let (x, y, z) = (rng.next(), rng.next(), rng.next());
        let g = trilinear_gradient(&v, x, y, z);
        let h = 1e-6;
        let fd = DVec3::new(
            (trilinear(&v, x + h, y, z) - trilinear(&v, x - h, y, z)) / (2.0 * h),
            (trilinear(&v, x, y + h, z) - trilinear(&v, x, y - h, z)) / (2.0 * h),
            (trilinear(&v, x, y, z + h) - trilinear(&v, x, y, z - h)) / (2.0 * h),
        );
        assert!((g - fd).length() < 1e-6);
    }
}

#[test]
fn equal_to_isovalue_is_outside() {
    // v000 below, all others exactly at the isovalue: one corner inside, its three edges
    // crossed at their far ends (s = 1), so the triangle's vertices are the three neighbouring
    // corners, and it faces away from v000.
    let mut values = vec![0.0f32; 8];
    values[0] = -1.0;
    let g = grid([2, 2, 2], values);
    for algo in [MeshAlgorithm::MarchingCubes, MeshAlgorithm::MarchingTetrahedra] {
        let m = reference(&g, &Request::new(0.0, Inside::Below, algo)).unwrap();
        assert!(m.triangle_count() >= 1, "{algo:?}");
        let [a, b, c] = m.triangle(0).map(|v| p64(&m, v));
        assert!((b - a).cross(c - a).dot(DVec3::ONE) > 0.0, "{algo:?}");
    }
    // Everything at the isovalue: nothing inside, no surface.
    let g = grid([2, 2, 2], vec![0.0; 8]);
    let m = reference(&g, &Request::new(0.0, Inside::Below, MeshAlgorithm::MarchingCubes)).unwrap();
    assert_eq!(m.triangle_count(), 0);
}

#[test]
fn mc33_single_cell_all_256_cases() {
    single_cell_exhaustive(MeshAlgorithm::Mc33);
}

#[test]
fn mc33_two_cells_no_cracks() {
    two_cells_exhaustive(MeshAlgorithm::Mc33);
}

/// Connected components and Euler characteristic of a mesh's triangles.
fn components_and_euler(m: &Mesh) -> (usize, i64) {
    let s = compute(m);
    let n = m.vertex_count();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    let mut used = vec![false; n];
    for t in 0..m.triangle_count() {
        let tri = m.triangle(t);
        for e in 0..3 {
            used[tri[e] as usize] = true;
            let (a, b) =
                (find(&mut parent, tri[e] as usize), find(&mut parent, tri[(e + 1) % 3] as usize));
            parent[a] = b;
        }
    }
    let comps = (0..n).filter(|&v| used[v] && find(&mut parent, v) == v).count();
    (comps, s.euler_characteristic)
}

/// The topology of MC33's patch in a random cell equals that of the trilinear interpolant's
/// level set in the cell, approximated by marching tetrahedra on the interpolant resampled
/// 16 times finer (components and Euler characteristic: disks count 1, tunnels 0). Cells whose
/// fine approximation disagrees with itself at 2x finer resolution are too close to a
/// topological transition to judge and are skipped.
#[test]
fn mc33_topology_matches_the_trilinear_interpolant() {
    let fine = |v: &[f64; 8], n: usize| {
        let mut values = Vec::with_capacity(n * n * n);
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let d = (n - 1) as f64;
                    values.push(trilinear(v, i as f64 / d, j as f64 / d, k as f64 / d) as f32);
                }
            }
        }
        let g = grid([n, n, n], values);
        let m = reference(&g, &Request::new(0.0, Inside::Below, MeshAlgorithm::MarchingTetrahedra))
            .unwrap();
        components_and_euler(&m)
    };
    let mut rng = Rng(2024);
    let (mut checked, mut tunnels, mut skipped, mut mc_wrong) = (0, 0, 0, 0);
    for n in 0..3000 {
        // Values in [-1, 1]; every other cell has its minority sign strengthened threefold,
        // which makes tunnels (MC33 cases 4.1.2, 6.1.2, 7.4.2, 10.1.2, 12.1.2, 13.5.2) common.
        let mut v: [f64; 8] = std::array::from_fn(|_| 2.0 * rng.next() - 1.0);
        let mask =
            v.iter().enumerate().filter(|(_, &x)| x < 0.0).fold(0u32, |m, (c, _)| m | 1 << c);
        if mask == 0 || mask == 255 {
            continue;
        }
        if n % 2 == 1 {
            let minority_negative = mask.count_ones() <= 4;
            for x in v.iter_mut() {
                if (*x < 0.0) == minority_negative {
                    *x *= 3.0;
                }
            }
        }
        let g1 = grid([2, 2, 2], v.map(|x| x as f32).to_vec());
        let v32: [f64; 8] = g1.corners(0, 0, 0).map(f64::from);
        // A face saddle within 0.01 of the isovalue is beyond what the fine approximation
        // resolves.
        let near_face_saddle = super::mc33::FACES.iter().any(|f| {
            let [a, b, c, d] = f.map(|k| v32[k as usize]);
            let den = a + c - b - d;
            den != 0.0 && ((a * c - b * d) / den).abs() < 0.01
        });
        if near_face_saddle {
            skipped += 1;
            continue;
        }
        let want = fine(&v32, 17);
        if want != fine(&v32, 33) {
            skipped += 1;
            continue;
        }
        checked += 1;
        let m = reference(&g1, &Request::new(0.0, Inside::Below, MeshAlgorithm::Mc33)).unwrap();
        let got = components_and_euler(&m);
        assert_eq!(got, want, "values {v32:?}");
        if got.0 as i64 != got.1 {
            tunnels += 1;
        }
        let mc = reference(&g1, &Request::new(0.0, Inside::Below, MeshAlgorithm::MarchingCubes))
            .unwrap();
        if components_and_euler(&mc) != want {
            mc_wrong += 1;
        }
    }
    eprintln!("mc33 topology: {checked} cells checked, {tunnels} with tunnels, {skipped} skipped; marching cubes wrong in {mc_wrong}");
    assert!(checked > 2000 && tunnels > 20 && mc_wrong > 0);
}

/// The lanes of `Field::units_in_corners` (a row's normals at once) are `unit_in_corners`'s
/// bits, lane by lane: random cells and points, both inside rules, anisotropic spacing, and
/// gradients that vanish (equal corners) or are not finite (an infinite corner).
#[test]
fn normals_in_lanes_are_the_scalar_normals_bit_for_bit() {
    use super::field::Field;
    use super::lanes::{F64x4, LANES};
    let g = Grid {
        dims: [4, 3, 5],
        min: DVec3::new(-0.3, 1.0, 2.0),
        max: DVec3::new(0.9, 1.5, 9.0),
        values: vec![0.0; 60],
    };
    let mut rng = Rng(99);
    for inside in Inside::ALL {
        let f = Field::new(&g, 0.1, inside);
        for round in 0..2000 {
            let mut v = [[0.0f64; 8]; LANES];
            let mut lo = [[0.0f64; 3]; LANES];
            let mut u = [[0.0f64; 3]; LANES];
            for i in 0..LANES {
                for (k, x) in v[i].iter_mut().enumerate() {
                    *x = match (round + i) % 7 {
                        0 => 0.25,                               // a flat cell
                        1 if k == 3 => f64::from(f32::INFINITY), // not finite
                        _ => f64::from((rng.next() * 4.0 - 2.0) as f32),
                    };
                }
                lo[i] = [0, 1, 2].map(|_| (rng.next() * 3.0).floor());
                u[i] = [0, 1, 2].map(|a| lo[i][a] + rng.next());
            }
            let lanes = |x: &dyn Fn(usize) -> f64| F64x4(std::array::from_fn(x));
            let lv: [F64x4; 8] = std::array::from_fn(|k| lanes(&|i| v[i][k]));
            let llo = [0, 1, 2].map(|a| lanes(&|i| lo[i][a]));
            let lu = [0, 1, 2].map(|a| lanes(&|i| u[i][a]));
            let (normals, ok) = f.units_in_corners(&lv, llo, lu);
            for i in 0..LANES {
                let one = f.unit_in_corners(&v[i], DVec3::from(lo[i]), DVec3::from(u[i]));
                assert_eq!(ok[i], one.is_some(), "{inside:?} round {round} lane {i}");
                if let Some(n) = one {
                    assert_eq!(normals[i].map(f32::to_bits), n.map(f32::to_bits));
                }
            }
        }
    }
}
