//! Property-based fuzzing (proptest) of what reads user input: scene parsing (arbitrary text,
//! mutated shipped scenes, arbitrary `--set` overrides) and the npy/raw loaders (arbitrary and
//! mutated files). Every input must give a scene or one line of error: never a panic, never a
//! multi-line message. `PROPTEST_CASES=N` runs longer (the README gives the count run once).

use std::path::{Path, PathBuf};

use isoview::field::GridLimits;
use isoview::scene;
use proptest::prelude::*;

/// A small cap so that hostile headers are refused quickly rather than sampled.
fn limits() -> GridLimits {
    GridLimits { max_bytes: 4 << 20 }
}

fn scenes_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

/// Loads `text` as a scene (and samples its field when it loads): no panic, one-line errors.
fn check(text: &str, dir: &Path, overrides: &[String]) {
    match scene::from_str_with(text, "fuzz.toml", dir, overrides, &limits()) {
        Ok(s) => {
            if let Err(e) = s.field.sample_with(0.0, &limits()) {
                let m = e.to_string();
                assert!(!m.contains('\n') && !m.is_empty(), "{m:?}");
            }
        }
        Err(e) => {
            let m = e.to_string();
            assert!(!m.contains('\n') && !m.is_empty(), "{m:?}");
        }
    }
}

fn shipped() -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(scenes_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .map(|p| std::fs::read_to_string(p).unwrap())
        .collect();
    v.sort();
    v
}

/// Applies byte edits (position, new byte, kind) to `text`, keeping it UTF-8 (lossy).
fn mutate(text: &str, edits: &[(usize, u8, u8)]) -> String {
    let mut b = text.as_bytes().to_vec();
    for &(pos, byte, kind) in edits {
        if b.is_empty() {
            b.push(byte);
            continue;
        }
        let i = pos % b.len();
        match kind % 3 {
            0 => b[i] = byte,
            1 => b.insert(i, byte),
            _ => {
                b.remove(i);
            }
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

/// Bytes that look like TOML to the parser more often than uniform noise.
fn tomlish() -> impl Strategy<Value = u8> {
    prop_oneof![
        4 => any::<u8>(),
        6 => prop::sample::select(b"[]{}=.,\"'#\n -0123456789eE+_abcdefghijklmnopqrstuvwxyz".to_vec()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_text_never_panics(bytes in prop::collection::vec(tomlish(), 0..400)) {
        check(&String::from_utf8_lossy(&bytes), &scenes_dir(), &[]);
    }

    #[test]
    fn mutated_scenes_never_panic(
        which in 0usize..64,
        edits in prop::collection::vec((any::<usize>(), any::<u8>(), any::<u8>()), 1..6),
    ) {
        let all = shipped();
        check(&mutate(&all[which % all.len()], &edits), &scenes_dir(), &[]);
    }

    #[test]
    fn arbitrary_overrides_never_panic(
        which in 0usize..64,
        key in prop::sample::select(vec![
            "image.width", "camera.eye", "field.resolution", "field.bounds.min", "field.source",
            "field.shape", "field.path", "field.dims", "field.dtype", "surface.isovalue",
            "render.method", "render.steps", "field.expression", "x", "field", "render.steps.x",
        ]),
        value in prop::collection::vec(tomlish(), 0..24),
    ) {
        let all = shipped();
        let set = format!("{key}={}", String::from_utf8_lossy(&value));
        check(&all[which % all.len()], &scenes_dir(), &[set]);
    }

    #[test]
    fn mutated_npy_files_never_panic(
        edits in prop::collection::vec((0usize..200, any::<u8>(), any::<u8>()), 1..8),
        truncate in prop::option::of(0usize..40000),
    ) {
        let dir = crate::common::scratch("fuzz-npy");
        let mut bytes = std::fs::read(scenes_dir().join("data/blobs.npy")).unwrap();
        // Edits land in the header (first 200 bytes), where the loader parses.
        for &(pos, byte, kind) in &edits {
            let i = pos.min(bytes.len() - 1);
            match kind % 3 {
                0 => bytes[i] = byte,
                1 => bytes.insert(i, byte),
                _ => { bytes.remove(i); }
            }
        }
        if let Some(n) = truncate {
            bytes.truncate(n);
        }
        std::fs::write(dir.join("v.npy"), &bytes).unwrap();
        check("[field]\nsource = \"npy\"\npath = \"v.npy\"\n", &dir, &[]);
    }

    #[test]
    fn arbitrary_raw_files_never_panic(
        dims in prop::array::uniform3(0i64..40),
        dtype in prop::sample::select(vec!["u8", "u16", "i16", "f32", "f64", "f16", "x"]),
        endian in prop::sample::select(vec!["little", "big", "middle"]),
        len in 0usize..20000,
        fill in any::<u8>(),
    ) {
        let dir = crate::common::scratch("fuzz-raw");
        std::fs::write(dir.join("v.raw"), vec![fill; len]).unwrap();
        let text = format!(
            "[field]\nsource = \"raw\"\npath = \"v.raw\"\ndims = [{}, {}, {}]\ndtype = \"{dtype}\"\nendian = \"{endian}\"\n",
            dims[0], dims[1], dims[2]
        );
        check(&text, &dir, &[]);
    }

    #[test]
    fn mutated_volume_files_never_panic(
        which in 0usize..64,
        edits in prop::collection::vec((0usize..1200, any::<u8>(), any::<u8>()), 1..8),
        truncate in prop::option::of(0usize..20000),
    ) {
        // Each format's real files, their headers edited (first 1200 bytes) and maybe cut short.
        let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/formats");
        let mut files: Vec<_> = std::fs::read_dir(&data).unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| isoview::field::formats::Format::from_path(p).is_some())
            .filter(|p| p.metadata().unwrap().len() < 100_000)
            .collect();
        files.sort();
        let src = &files[which % files.len()];
        let name = src.file_name().unwrap().to_string_lossy().to_string();
        let dir = crate::common::scratch("fuzz-formats");
        let mut bytes = std::fs::read(src).unwrap();
        for &(pos, byte, kind) in &edits {
            let i = pos.min(bytes.len() - 1);
            match kind % 3 {
                0 => bytes[i] = byte,
                1 => bytes.insert(i, byte),
                _ => { bytes.remove(i); }
            }
        }
        if let Some(n) = truncate {
            bytes.truncate(n);
        }
        std::fs::write(dir.join(&name), &bytes).unwrap();
        // A detached header's data file comes along unchanged.
        for data_file in ["unu_detached.raw", "sitk_int16.raw"] {
            std::fs::copy(data.join(data_file), dir.join(data_file)).unwrap();
        }
        check(&format!("[field]\nsource = \"file\"\npath = \"{name}\"\n"), &dir, &[]);
    }
}
