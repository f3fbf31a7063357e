//! `./x bench --gpu` (`isoview::bench`) at a tiny size on this machine's device: every table is
//! whole (both scenes and both extraction methods at each size, every golden of the set), the
//! JSON holds what the tables print, and on lavapipe, where the goldens were made, every golden
//! passes. Its figures are never asserted on.

use std::path::{Path, PathBuf};

use isoview::bench::{golden, run, Options};

use crate::common::*;

#[gpu_test]
fn the_gpu_benchmark_runs_every_table_at_a_tiny_size() {
    let ctx = gpu();
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let o = Options {
        sizes: vec![12, 17],
        image: 16,
        frames: 1,
        root: root.clone(),
        isoview: Some(PathBuf::from(env!("CARGO_BIN_EXE_isoview"))),
        scratch: scratch("bench-gpu"),
    };
    let v = run(&ctx, &o).unwrap();
    assert_eq!(v["device"], ctx.info.name.as_str());
    let rays = v["rays"].as_array().unwrap();
    assert_eq!(rays.len(), 4, "{rays:?}");
    for r in rays {
        for k in [
            "build_gpu_ms",
            "analytic_gpu_ms",
            "walk_gpu_ms",
            "fixed_step_512_gpu_ms",
            "new_isovalue_ms",
        ] {
            assert!(r[k].as_f64().is_some_and(|x| x > 0.0), "{k} in {r}");
        }
    }
    let extract = v["extract"].as_array().unwrap();
    assert_eq!(extract.len(), 4, "{extract:?}");
    assert!(extract.iter().all(|e| e["triangles"].as_u64().is_some_and(|t| t > 0)), "{extract:?}");
    let goldens = v["goldens"].as_array().unwrap();
    let all = golden::goldens(&root).unwrap();
    assert_eq!(goldens.len(), all.len());
    for (row, g) in goldens.iter().zip(&all) {
        assert_eq!(row["golden"], g.name().as_str());
        // The goldens are lavapipe's: here they are met, as the golden test says.
        if ctx.info.name.starts_with("llvmpipe") {
            let verdict = row["verdict"].as_str().unwrap();
            assert!(verdict == "identical" || verdict == "pass", "{row}");
        }
    }
    assert!(!Path::new(&o.scratch).join(format!("{}.exr", all[0].name())).exists(), "renders kept");
}
