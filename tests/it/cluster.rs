//! MPI (`--features mpi`): `mpirun -np N isoview render` splits the grid across N ranks, and
//! its EXR equals the single-process render's byte for byte (so every channel bit for bit,
//! header included) for every shipped scene and for random grids, at 1 to 4 ranks
//! (oversubscribed on small machines). Without the feature these tests are listed as ignored.

use std::path::Path;
use std::process::{Command, Output};

use crate::common::{isoview, scratch, stderr, Rng};

/// `mpirun -np n --oversubscribe isoview args...` (as root too: CI runs as root).
fn mpirun(n: usize, args: &[&str]) -> Output {
    Command::new("mpirun")
        .args(["-np", &n.to_string(), "--oversubscribe", env!("CARGO_BIN_EXE_isoview")])
        .args(args)
        .env_remove("ISOVIEW_DEVICE")
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .output()
        .expect("mpirun (apt-get install openmpi-bin) must be on PATH for the MPI tests")
}

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
    let o = mpirun(n, &a.iter().map(String::as_str).collect::<Vec<_>>());
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

#[test]
#[cfg_attr(not(feature = "mpi"), ignore = "MPI test: build with --features mpi")]
#[cfg_attr(isoview_skip_gpu, ignore = "GPU test: ISOVIEW_SKIP_GPU_TESTS=1")]
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
        ];
        let name = scene.file_stem().unwrap().to_string_lossy().into_owned();
        let ranks = [2, 3, 4, 1][i % 4];
        same_under_mpi(&dir, scene.to_str().unwrap(), &sets, ranks, &name);
    }
}

#[test]
#[cfg_attr(not(feature = "mpi"), ignore = "MPI test: build with --features mpi")]
#[cfg_attr(isoview_skip_gpu, ignore = "GPU test: ISOVIEW_SKIP_GPU_TESTS=1")]
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
             [surface]\nisovalue = 0.0\n[render]\nshading = \"{shading}\"\ncount_crossings = {}\nskip = {}\n",
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
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // Rank 0 says it once (mpirun adds lines of its own and may cut into ours, so the message
    // is counted, not the lines).
    let err = stderr(&o);
    assert_eq!(err.matches("is not split across MPI ranks").count(), 1, "{err}");
    assert!(err.contains("render.method = \"fixed-step\""), "{err}");
    assert!(!out.exists());
}
