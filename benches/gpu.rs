//! `./x bench --gpu` (`cargo bench --bench gpu -- [--sizes 256,512,1024] [--image 512]
//! [--frames 3] [--no-goldens] [--json PATH]`): the tables of `isoview::bench` on the Vulkan
//! device the run opens (ISOVIEW_DEVICE picks one), printed and written as JSON (default
//! `target/bench-gpu.json`). Never asserts on time. Sized for at most 8 minutes on one GPU.

use std::path::PathBuf;

use isoview::bench::{run, Options};
use isoview::gpu::{Context, ContextOptions};

fn main() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let target = root.join("target");
    let mut o = Options::full(
        root.clone(),
        Some(PathBuf::from(env!("CARGO_BIN_EXE_isoview"))),
        target.join("bench-gpu"),
    );
    let mut json = target.join("bench-gpu.json");
    let mut args = std::env::args().skip(1);
    let number = |v: Option<String>, what: &str| -> usize {
        v.and_then(|v| v.parse().ok()).unwrap_or_else(|| {
            eprintln!("bench: {what} needs a positive whole number");
            std::process::exit(2)
        })
    };
    while let Some(a) = args.next() {
        match a.as_str() {
            "--sizes" => {
                let v = args.next().unwrap_or_default();
                o.sizes = v.split(',').map(|n| number(Some(n.to_string()), "--sizes")).collect();
            }
            "--image" => o.image = number(args.next(), "--image") as u32,
            "--frames" => o.frames = number(args.next(), "--frames").max(1),
            "--no-goldens" => o.isoview = None,
            "--json" => json = PathBuf::from(args.next().unwrap_or_default()),
            // cargo bench passes --bench to harness = false targets.
            "--bench" => {}
            other => {
                eprintln!("bench: unknown argument {other:?} (--sizes, --image, --frames, --no-goldens, --json)");
                std::process::exit(2);
            }
        }
    }
    // A 1024³ grid is 4 GiB of samples, over the default cap of 1 GiB.
    if std::env::var_os(isoview::field::GRID_CAP_ENV).is_none() {
        std::env::set_var(isoview::field::GRID_CAP_ENV, "8192");
    }
    let ctx = match Context::new(&ContextOptions::default()) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("bench: {e}");
            std::process::exit(3);
        }
    };
    match run(&ctx, &o) {
        Ok(v) => {
            let text = serde_json::to_string_pretty(&v).unwrap_or_default();
            if let Err(e) = std::fs::write(&json, text + "\n") {
                eprintln!("bench: {}: {e}", json.display());
                std::process::exit(2);
            }
            println!();
            println!("-> {}", json.display());
        }
        Err(e) => {
            eprintln!("bench: {e}");
            std::process::exit(3);
        }
    }
}
