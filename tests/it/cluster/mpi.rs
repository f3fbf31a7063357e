//! MPI (`--features mpi`): `mpirun -np N isoview render` splits the grid across N ranks, and
//! its EXR equals the single-process render's byte for byte (so every channel bit for bit,
//! header included) for every shipped scene and for random grids, at 1 to 4 ranks
//! (oversubscribed on small machines). `mpirun -np N isoview extract` joins the ranks' z-ranges
//! into the single-process `--device cpu` mesh, and its file equals that one's byte for byte,
//! for every shipped scene and random grids, every method the ranks split, 1 to 4 ranks.
//! Without the feature these tests are listed as ignored.

use crate::common::{isoview, mpirun, scratch, stderr, Rng};
use std::path::Path;

/// Renders `scene` with `sets` in one process and under `mpirun -np n`; the files must be equal.
fn same_under_mpi(dir: &Path, scene: &str, sets: &[String], n: usize, tag: &str) {
    let single = dir.join(format!("{tag}-1p.exr"));
    let split = dir.join(format!("{tag}-{n}r.exr"));
    let mut args = vec!["render".to_string(), scene.to_string(), "-o".into()];
    for s in sets {
        args.extend(["--set".to_string(), s.clone()]);
    }
    let with = |out: &Path| {
        let mut a = args.clone();
        a.insert(3, out.to_str().unwrap().to_string());
        a
    };
    let a = with(&single);
    let o = isoview(&a.iter().map(String::as_str).collect::<Vec<_>>(), &[]);
    assert!(o.status.success(), "{tag}: {}", stderr(&o));
    let a = with(&split);
    let o = mpirun(n, &a.iter().map(String::as_str).collect::<Vec<_>>(), &[]);
    assert!(o.status.success(), "{tag} under {n} ranks: {}", stderr(&o));
    let (x, y) = (std::fs::read(&single).unwrap(), std::fs::read(&split).unwrap());
    if x != y {
        let a = isoview::output::exr::read(&single).unwrap();
        let b = isoview::output::exr::read(&split).unwrap();
        let differ: Vec<String> = a
            .channels
            .iter()
            .zip(&b.channels)
            .filter(|(p, q)| {
                p.values.iter().zip(&q.values).any(|(u, v)| u.to_bits() != v.to_bits())
            })
            .map(|(p, _)| p.name.clone())
            .collect();
        panic!("{tag}: {n} ranks differ from one process in channels {differ:?}");
    }
    let _ = (std::fs::remove_file(&single), std::fs::remove_file(&split));
}

#[gpu_test]
#[cfg_attr(not(feature = "mpi"), ignore = "MPI test: build with --features mpi")]
fn every_shipped_scene_renders_the_same_on_1_to_4_ranks() {
    let dir = scratch("mpi-scenes");
    let mut scenes: Vec<_> = std::fs::read_dir("scenes")
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    scenes.sort();
    for (i, scene) in scenes.iter().enumerate() {
        // Analytic (what MPI splits), small pictures; every other scene counts crossings too.
        let sets = vec![
            "image.width=40".to_string(),
            "image.height=30".into(),
            "render.method=\"analytic\"".into(),
            "render.crossing=1".into(),
            format!("render.count_crossings={}", i % 2 == 0),
            // The ranks walk brick by brick (no occupancy structure over a block): `steps` is
            // that walk's in both.
            "render.occupancy=false".into(),
        ];
        let name = scene.file_stem().unwrap().to_string_lossy().into_owned();
        let ranks = [2, 3, 4, 1][i % 4];
        same_under_mpi(&dir, scene.to_str().unwrap(), &sets, ranks, &name);
    }
}

#[gpu_test]
#[cfg_attr(not(feature = "mpi"), ignore = "MPI test: build with --features mpi")]
fn random_grids_render_the_same_on_1_to_4_ranks() {
    let dir = scratch("mpi-random");
    let mut rng = Rng::new(0x5ca1e);
    for case in 0..8 {
        let dims = [0; 3].map(|_| 2 + (rng.next_u64() % 19) as usize);
        let n: usize = dims.iter().product();
        // Values on a coarse lattice of levels, so corners often equal the isovalue (ties).
        let values: Vec<u8> =
            (0..n).flat_map(|_| ((rng.next_u64() % 9) as f32 * 0.25 - 1.0).to_le_bytes()).collect();
        std::fs::write(dir.join(format!("g{case}.raw")), values).unwrap();
        let eye =
            rng.unit_vector() * rng.range(1.6, 3.0) * dims.iter().max().copied().unwrap() as f64;
        let centre = dims.map(|d| (d - 1) as f64 / 2.0);
        let shading = ["lambert", "steps", "cells", "normal"][case % 4];
        let scene = format!(
            "[image]\nwidth = 37\nheight = 29\n[camera]\neye = [{}, {}, {}]\ntarget = [{}, {}, {}]\n\
             [field]\nsource = \"raw\"\npath = \"g{case}.raw\"\ndims = [{}, {}, {}]\ndtype = \"f32\"\n\
             [surface]\nisovalue = 0.0\n[render]\nshading = \"{shading}\"\ncount_crossings = {}\nskip = {}\noccupancy = false\n",
            eye.x + centre[0], eye.y + centre[1], eye.z + centre[2],
            centre[0], centre[1], centre[2],
            dims[0], dims[1], dims[2],
            case % 3 != 0,
            case % 4 != 1,
        );
        let path = dir.join(format!("g{case}.toml"));
        std::fs::write(&path, scene).unwrap();
        let ranks = 1 + case % 4;
        same_under_mpi(&dir, path.to_str().unwrap(), &[], ranks, &format!("g{case}"));
    }
}

#[test]
#[cfg_attr(not(feature = "mpi"), ignore = "MPI test: build with --features mpi")]
fn what_is_not_split_is_refused_in_one_line() {
    let dir = scratch("mpi-refuse");
    let out = dir.join("o.exr");
    let o = mpirun(
        2,
        &[
            "render",
            "scenes/torus.toml",
            "-o",
            out.to_str().unwrap(),
            "--set",
            "render.method=\"fixed-step\"",
        ],
        &[],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // Rank 0 says it once (mpirun adds lines of its own and may cut into ours, so the message
    // is counted, not the lines).
    let err = stderr(&o);
    assert_eq!(err.matches("is not split across MPI ranks").count(), 1, "{err}");
    assert!(err.contains("render.method = \"fixed-step\""), "{err}");
    assert!(!out.exists());
}

/// Methods that `extract` splits across ranks.
const SPLIT_METHODS: [&str; 6] = [
    "marching-cubes",
    "mc33",
    "surface-nets",
    "dual-contouring",
    "marching-tetrahedra",
    "dual-contouring-qef",
];

/// Extracts `scene` with `extra` arguments (after `-o FILE`) in one process on the CPU and
/// under `mpirun -np n`; the files must be equal byte for byte.
fn same_mesh_under_mpi(dir: &Path, scene: &str, extra: &[String], n: usize, tag: &str) {
    let single = dir.join(format!("{tag}-1p.ply"));
    let split = dir.join(format!("{tag}-{n}r.ply"));
    let args = |out: &Path, cpu: bool| {
        let mut a: Vec<String> = Vec::new();
        if cpu {
            a.extend(["--device".into(), "cpu".into()]);
        }
        a.extend(["extract".into(), scene.into(), "-o".into(), out.to_str().unwrap().into()]);
        a.extend(extra.iter().cloned());
        a
    };
    let a = args(&single, true);
    let o = isoview(&a.iter().map(String::as_str).collect::<Vec<_>>(), &[]);
    assert!(o.status.success(), "{tag}: {}", stderr(&o));
    // Without --device: `auto` picks the CPU under MPI.
    let a = args(&split, false);
    let o = mpirun(n, &a.iter().map(String::as_str).collect::<Vec<_>>(), &[]);
    assert!(o.status.success(), "{tag} under {n} ranks: {}", stderr(&o));
    if n > 1 {
        assert!(stderr(&o).contains(&format!("mpi: {n} ranks")), "{tag}: {}", stderr(&o));
    }
    let (x, y) = (std::fs::read(&single).unwrap(), std::fs::read(&split).unwrap());
    // An empty mesh would prove little.
    let header = String::from_utf8_lossy(&x[..x.len().min(1024)]).into_owned();
    let vertices = header.lines().find_map(|l| l.strip_prefix("element vertex "));
    assert!(vertices.is_some_and(|n| n.trim() != "0"), "{tag}: no vertices: {header}");
    if x != y {
        let at = x.iter().zip(&y).position(|(a, b)| a != b).unwrap_or(x.len().min(y.len()));
        panic!(
            "{tag}: {n} ranks wrote {} bytes, one process {}; first difference at byte {at}",
            y.len(),
            x.len()
        );
    }
    let _ = (std::fs::remove_file(&single), std::fs::remove_file(&split));
}

#[test]
#[cfg_attr(not(feature = "mpi"), ignore = "MPI test: build with --features mpi")]
fn every_shipped_scene_extracts_the_same_on_1_to_4_ranks() {
    let dir = scratch("mpi-extract-scenes");
    let mut scenes: Vec<_> = std::fs::read_dir("scenes")
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    scenes.sort();
    for (i, scene) in scenes.iter().enumerate() {
        let method = SPLIT_METHODS[i % SPLIT_METHODS.len()];
        let mut extra = vec!["--set".to_string(), format!("render.mesh=\"{method}\"")];
        if matches!(method, "surface-nets" | "dual-contouring") && i % 4 < 2 {
            extra.push("--quads".into());
        }
        let name = scene.file_stem().unwrap().to_string_lossy().into_owned();
        let ranks = [2, 3, 4, 1][i % 4];
        let tag = format!("{name}-{method}");
        same_mesh_under_mpi(&dir, scene.to_str().unwrap(), &extra, ranks, &tag);
    }
}

#[test]
#[cfg_attr(not(feature = "mpi"), ignore = "MPI test: build with --features mpi")]
fn random_grids_extract_the_same_on_1_to_4_ranks() {
    let dir = scratch("mpi-extract-random");
    let mut rng = Rng::new(0x14e);
    for case in 0..12 {
        // Thin along z too, so that some ranks get no cell layer or a single one.
        let dims = [
            2 + (rng.next_u64() % 19) as usize,
            2 + (rng.next_u64() % 19) as usize,
            [2, 3, 4 + (rng.next_u64() % 30) as usize][case % 3],
        ];
        let n: usize = dims.iter().product();
        // Values on a coarse lattice of levels, so corners often equal the isovalue (ties).
        let values: Vec<u8> =
            (0..n).flat_map(|_| ((rng.next_u64() % 9) as f32 * 0.25 - 1.0).to_le_bytes()).collect();
        std::fs::write(dir.join(format!("g{case}.raw")), values).unwrap();
        let method = SPLIT_METHODS[case % SPLIT_METHODS.len()];
        let inside = ["below", "above"][(case / 2) % 2];
        let scene = format!(
            "[field]\nsource = \"raw\"\npath = \"g{case}.raw\"\ndims = [{}, {}, {}]\ndtype = \"f32\"\n\
             bounds = {{ min = [-0.7, 0.1, 2.0], max = [0.9, 1.3, 2.6] }}\n\
             [surface]\nisovalue = {}\ninside = \"{inside}\"\n[render]\nmesh = \"{method}\"\n",
            dims[0],
            dims[1],
            dims[2],
            ["0.0", "0.1", "-0.25"][case % 3],
        );
        let path = dir.join(format!("g{case}.toml"));
        std::fs::write(&path, scene).unwrap();
        let ranks = 1 + (case + case / 4) % 4;
        let tag = format!("g{case}-{method}");
        same_mesh_under_mpi(&dir, path.to_str().unwrap(), &[], ranks, &tag);
    }
}

#[test]
#[cfg_attr(not(feature = "mpi"), ignore = "MPI test: build with --features mpi")]
fn what_extract_does_not_split_is_refused_in_one_line() {
    let dir = scratch("mpi-extract-refuse");
    let out = dir.join("o.ply");
    let cases: [(&[&str], &str); 3] = [
        (&["--set", "render.mesh=\"extended-mc\""], "render.mesh = \"extended-mc\""),
        (
            &["--set", "render.mesh=\"dual-contouring-qef\"", "--set", "render.mesh_error=0.01"],
            "with mesh_error",
        ),
        (&[], "the GPU extraction is not split"),
    ];
    for (i, (sets, says)) in cases.iter().enumerate() {
        let mut args = vec!["extract", "scenes/torus.toml", "-o", out.to_str().unwrap()];
        args.extend_from_slice(sets);
        if i == 2 {
            args.splice(0..0, ["--device", "gpu"]);
        }
        let o = mpirun(2 + i % 2, &args, &[]);
        assert_eq!(o.status.code(), Some(2), "{says}: {}", stderr(&o));
        let err = stderr(&o);
        assert_eq!(err.matches("is not split across MPI ranks").count(), 1, "{err}");
        assert!(err.contains(says), "{err}");
        assert!(!out.exists());
    }
}
