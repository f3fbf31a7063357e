//! Windows against the reference: random grids (ties at the isovalue, a box off the origin),
//! every method cut into ranges, split 1 to 6 ways, each range extracted from a copy of
//! exactly the point layers `point_layers` names (reading outside them panics), sent through
//! `to_words`/`from_words` and joined: the reference's mesh bit for bit.

use std::ops::Range;

use glam::DVec3;

use super::*;
use crate::mesh::tests::Rng;
use crate::mesh::{reference, ExtractOptions, QuadSplit, Request};
use crate::vocab::{HermiteNormals, Inside};

/// Every method cut into z-ranges (asked of its row, so a new one is tested here too).
fn algos() -> Vec<MeshAlgorithm> {
    let sharp = SharpSettings::default();
    MeshAlgorithm::ALL.into_iter().filter(|a| not_in_slabs(*a, &sharp).is_none()).collect()
}

fn random_grid(rng: &mut Rng) -> Grid {
    let dims = [0; 3].map(|_| 2 + (rng.next() * 11.0) as usize);
    let n = dims.iter().product();
    // A third of the samples from a small set, so that samples equal the isovalue.
    let values = (0..n)
        .map(|_| match rng.next() < 1.0 / 3.0 {
            true => [-0.5, 0.0, 0.25][(rng.next() * 3.0) as usize],
            false => rng.next() as f32 * 2.0 - 1.0,
        })
        .collect();
    let min = DVec3::new(-1.3, 0.2, 5.1);
    let max = min + DVec3::new(0.7 + rng.next(), 1.9, 0.3 + 3.0 * rng.next());
    Grid { dims, min, max, values }
}

/// Point layers `layers` of `grid` as a grid of their own.
fn cut(grid: &Grid, layers: &Range<usize>) -> Grid {
    let plane = grid.dims[0] * grid.dims[1];
    let values = grid.values[plane * layers.start..plane * layers.end].to_vec();
    Grid { dims: [grid.dims[0], grid.dims[1], layers.len()], min: grid.min, max: grid.max, values }
}

fn bits(m: &Mesh) -> (Vec<[u32; 3]>, Vec<[u32; 3]>) {
    let b = |v: &[[f32; 3]]| v.iter().map(|p| p.map(f32::to_bits)).collect();
    (b(&m.positions), b(&m.normals))
}

#[test]
fn windows_joined_are_the_reference_bit_for_bit() {
    let mut rng = Rng(14);
    let (mut added, mut seams) = (0, 0);
    for round in 0..36 {
        let grid = random_grid(&mut rng);
        let algos = algos();
        let algo = algos[round % algos.len()];
        let iso = [0.0, 0.25, 0.1, -0.3][(round / 6) % 4];
        let inside = [Inside::Below, Inside::Above][round % 2];
        let split = [QuadSplit::Shorter, QuadSplit::Fixed][(round / 2) % 2];
        let opts = ExtractOptions { split, keep_quads: round % 3 != 0 };
        let sharp = SharpSettings { hermite: HermiteNormals::Trilinear, ..Default::default() };
        let reference =
            reference(&grid, &Request::new(iso, inside, algo).with_opts(opts).with_sharp(sharp))
                .unwrap();
        let lattice = Lattice::of(&grid);
        let x = Request::new(iso, inside, algo).with_opts(opts).with_sharp(sharp);
        let layers = cell_layers(algo, grid.dims);
        for n in 1..=6 {
            let what = format!("round {round} {} {:?} in {n}", algo.name(), grid.dims);
            let mut join = Joiner::new();
            for k in 0..n {
                let cells = share(layers, n, k);
                let need = point_layers(algo, grid.dims, cells.clone());
                let window = cut(&grid, &need);
                let part = extract_window(&window, need.start, &lattice, &x, cells).unwrap();
                added += part.0.added.normals.len();
                seams += usize::from(k > 0 && part.vertex_count() > 0);
                let words = part.to_words();
                join.push(SlabMesh::from_words(&words).expect(&what)).unwrap();
            }
            let got = join.finish(x.keeps_quads()).unwrap();
            assert_eq!(bits(&got), bits(&reference), "{what}: vertices");
            assert_eq!(got.indices, reference.indices, "{what}: triangles");
            assert_eq!(got.quads, reference.quads, "{what}: quads");
        }
    }
    // The checks meant something: MC33 added vertices were renumbered, ranges above the first
    // had vertices to offset.
    assert!(added > 0 && seams > 100, "added {added}, seams {seams}");
}

#[test]
fn share_splits_every_layer_once_in_order() {
    for layers in 0..20 {
        for n in 1..8 {
            let all: Vec<usize> = (0..n).flat_map(|k| share(layers, n, k)).collect();
            assert_eq!(all, (0..layers).collect::<Vec<_>>(), "{layers} in {n}");
            let sizes: Vec<usize> = (0..n).map(|k| share(layers, n, k).len()).collect();
            assert!(sizes.iter().max().unwrap() - sizes.iter().min().unwrap() <= 1, "{sizes:?}");
        }
    }
}

#[test]
fn a_window_short_of_its_layers_and_bad_words_are_errors() {
    let mut rng = Rng(3);
    let mut grid = random_grid(&mut rng);
    grid.dims[2] = 8;
    grid.values = (0..grid.dims[0] * grid.dims[1] * 8).map(|i| (i % 5) as f32 - 2.0).collect();
    let x = Request::new(0.5, Inside::Below, MeshAlgorithm::MarchingCubes);
    let lattice = Lattice::of(&grid);
    let need = point_layers(x.algo, grid.dims, 3..5);
    assert_eq!(need, 2..7);
    let short = cut(&grid, &(3..7));
    let e = extract_window(&short, 3, &lattice, &x, 3..5).err().expect("a window one layer short");
    assert!(e.to_string().contains("need point layers 2..7"), "{e}");
    let e = extract_window(&grid, 0, &lattice, &x, 3..9).err().expect("past the last layer");
    assert!(matches!(e, MeshError::BadWindow(_)), "{e}");
    let emc = Request { algo: MeshAlgorithm::ExtendedMc, ..x };
    let e = extract_window(&grid, 0, &lattice, &emc, 0..7).err().expect("extended-mc");
    assert!(matches!(e, MeshError::NotInSlabs(_)), "{e}");
    let words = extract_window(&grid, 0, &lattice, &x, 0..7).unwrap().to_words();
    assert!(words[0] > 0);
    assert!(SlabMesh::from_words(&words[..words.len() - 1]).is_none());
    assert!(SlabMesh::from_words(&words[..3]).is_none());
}

#[test]
fn point_layers_are_the_old_trilinear_formula() {
    // Written for 2 points per axis before it was read from the stencil: a - pad - 1 .. b + 2.
    for algo in MeshAlgorithm::ALL {
        let pad = padding(algo);
        for nz in 2..12usize {
            let dims = [3, 3, nz];
            let layers = cell_layers(algo, dims);
            for a in 0..layers {
                for b in a + 1..=layers {
                    let old = a.saturating_sub(pad + 1)..(b + 2).min(nz);
                    let new = point_layers(algo, dims, a..b);
                    assert_eq!(new, old, "{} nz {nz} cells {a}..{b}", algo.name());
                    assert!(new.len() <= b - a + GHOST_LAYERS);
                }
            }
        }
    }
    assert_eq!(GHOST_LAYERS, 4);
}
