//! A GPU test that cannot run shows up as ignored, never as passed (issue #24 item 5,
//! docs/contributing.md "Tests"): no test returns early after looking at the device (a
//! missing feature such as `shaderFloat64`, or no device at all). Such a test declares what it
//! needs (`common::need_float64` panics without it) and is ignored only through a build-time
//! opt-out (`ISOVIEW_SKIP_GPU_TESTS=1`, `ISOVIEW_NO_FLOAT64_TESTS=1`), which libtest reports;
//! the rules of that opt-out are written once, in `#[gpu_test]` (crates/test-macros).
//!
//! Read from the source text: every file of `tests/` and the unit tests of `src/` and
//! `crates/`.

use std::path::{Path, PathBuf};

/// What a line that looks at the device contains.
const DEVICE_CHECKS: [&str; 7] =
    [".info.", "float64", "int64_atomics", "Context::new", "Gpu::new", "gpu()", "device"];

/// Lines before an early return searched for a device check (the condition of its block).
const LOOK_BACK: usize = 3;

/// `(line number, line)` of each bare early return (`return;`, `return Ok(());`) within
/// [`LOOK_BACK`] lines of a device check.
fn silent_device_returns(text: &str) -> Vec<(usize, String)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut found = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let code = line.split("//").next().unwrap_or("");
        if !(code.contains("return;") || code.contains("return Ok(());")) {
            continue;
        }
        let checked = lines[i.saturating_sub(LOOK_BACK)..=i]
            .iter()
            .map(|l| l.split("//").next().unwrap_or(""))
            .any(|l| DEVICE_CHECKS.iter().any(|c| l.contains(c)));
        if checked {
            found.push((i + 1, line.trim().to_string()));
        }
    }
    found
}

/// Every `.rs` file under `dir`.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The test code of the repository: whole files under `tests/` (this one excepted: its
/// patterns are the ones it looks for), and of `src/` and `crates/` what follows the first
/// `#[cfg(test)]` of a file (library code may well return early when a device lacks a feature:
/// that is the fallback rule).
fn test_sources() -> Vec<(PathBuf, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut out = Vec::new();
    let mut files = Vec::new();
    rust_files(&root.join("tests"), &mut files);
    for p in files {
        if p.ends_with("it/gpu/skips.rs") {
            continue;
        }
        out.push((p.clone(), std::fs::read_to_string(&p).unwrap()));
    }
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    rust_files(&root.join("crates"), &mut files);
    for p in files {
        let text = std::fs::read_to_string(&p).unwrap();
        if let Some(at) = text.find("#[cfg(test)]") {
            out.push((p, text[at..].to_string()));
        }
    }
    assert!(out.len() > 40, "found only {} test sources", out.len());
    out
}

#[test]
fn the_check_finds_a_silent_return_on_a_device_check() {
    let silent = "fn t() {\n    let gpu = Gpu::new();\n    if !gpu.ctx.info.float64 {\n        return;\n    }\n}\n";
    assert_eq!(silent_device_returns(silent), [(4, "return;".to_string())]);
    let no_device = "let Ok(ctx) = Context::new(&opts) else { return; };\n";
    assert_eq!(silent_device_returns(no_device).len(), 1);
    let unrelated = "if let Layout::Isoview = layout {\n    write(path);\n    return;\n}\n";
    assert!(silent_device_returns(unrelated).is_empty());
}

#[test]
fn no_test_returns_early_on_a_device_check() {
    let mut found = Vec::new();
    for (path, text) in test_sources() {
        for (line, code) in silent_device_returns(&text) {
            found.push(format!("{}:{line}: {code}", path.display()));
        }
    }
    assert!(
        found.is_empty(),
        "tests that return early after a device check pass without running; call \
         common::need_float64 (or fail) and declare the opt-out instead:\n{}",
        found.join("\n")
    );
}

/// The attribute lines of the function around line `at` (0-based) of `lines`: the nearest
/// `fn` line at or above it, then the `#[...]` lines (and doc comments) just above that.
fn attributes_of_enclosing_fn<'a>(lines: &[&'a str], at: usize) -> Vec<&'a str> {
    let Some(f) = (0..=at).rev().find(|&i| {
        let l = lines[i].trim_start();
        l.starts_with("fn ") || l.starts_with("pub fn ")
    }) else {
        return Vec::new();
    };
    let mut attrs = Vec::new();
    let mut in_attr = false;
    for l in lines[..f].iter().rev() {
        let t = l.trim();
        // A multi-line attribute is read bottom up: its last line is `)]`.
        if t == ")]" {
            in_attr = true;
        }
        if in_attr || t.starts_with("#[") || t.starts_with("///") {
            attrs.push(*l);
            if t.starts_with("#[") {
                in_attr = false;
            }
        } else {
            break;
        }
    }
    attrs
}

#[test]
fn tests_that_need_float64_can_be_opted_out() {
    let mut found = Vec::new();
    for (path, text) in test_sources() {
        let lines: Vec<&str> = text.lines().collect();
        for (i, l) in lines.iter().enumerate() {
            if !l.contains("need_float64(") || l.trim_start().starts_with("pub fn need_float64") {
                continue;
            }
            let attrs = attributes_of_enclosing_fn(&lines, i);
            let declared = attrs.iter().any(|a| a.trim() == "#[gpu_test(float64)]");
            if !declared {
                found.push(format!("{}:{}", path.display(), i + 1));
            }
        }
    }
    assert!(
        found.is_empty(),
        "these tests call need_float64 but are not declared #[gpu_test(float64)] (so not \
         ignored under ISOVIEW_NO_FLOAT64_TESTS=1):\n{}",
        found.join("\n")
    );
}

/// The ignore rules of GPU tests live in `#[gpu_test]` (crates/test-macros) alone: a test that
/// spells out its own `cfg_attr` is a copy that can drift (a wrong reason, a missing cfg).
#[test]
fn gpu_tests_are_declared_with_the_attribute() {
    let mut found = Vec::new();
    for (path, text) in test_sources() {
        for (i, l) in text.lines().enumerate() {
            let code = l.split("//").next().unwrap_or("");
            if code.contains("isoview_skip_gpu") || code.contains("isoview_no_float64") {
                found.push(format!("{}:{}: {}", path.display(), i + 1, l.trim()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "declare GPU tests #[gpu_test] or #[gpu_test(float64)] instead of these cfgs:\n{}",
        found.join("\n")
    );
}
