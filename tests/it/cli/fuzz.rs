//! Property-based fuzzing (proptest) of what reads user input: scene parsing (arbitrary text,
//! mutated shipped scenes, arbitrary `--set` overrides) and the npy/raw loaders (arbitrary and
//! mutated files). Every input must give a scene or one line of error: never a panic, never a
//! multi-line message. `PROPTEST_CASES=N` runs longer (docs/contributing.md gives the count run once).

use std::path::{Path, PathBuf};

use isoview::field::{DataAccess, GridLimits};
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

// ---- issue 29: inputs that crashed or misled the volume readers ------------------------------

/// Reads `path` under the small cap: a volume whose box is finite and whose samples fit the
/// cap, or one line of error naming the file; never a panic or an abort.
fn read_volume(path: &Path) -> Result<(), String> {
    let format = isoview::field::formats::Format::from_path(path).unwrap();
    let opts = isoview::field::formats::ReadOptions {
        limits: limits(),
        spacing: None,
        access: DataAccess::Any,
        grid: None,
        has_bounds: false,
    };
    match isoview::field::formats::read(path, format, &opts) {
        Ok(v) => {
            assert!(v.values.len() * 4 <= limits().max_bytes as usize);
            assert_eq!(v.values.len(), v.dims.iter().product::<usize>());
            let far =
                (0..3).fold(v.origin, |p, k| p + v.axes[k] * v.spacing[k] * (v.dims[k] - 1) as f64);
            assert!(v.origin.is_finite() && far.is_finite(), "{:?} {:?}", v.origin, v.spacing);
            Ok(())
        }
        Err(e) => {
            let m = e.to_string();
            assert!(!m.contains('\n') && m.contains(&path.display().to_string()), "{m}");
            Err(m)
        }
    }
}

/// Header numbers that broke or nearly broke a reader: huge (valid alone, out of range once
/// multiplied by the points), zero, negative, not finite, not numbers.
fn odd_number() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => prop::sample::select(vec!["1", "2", "0.5", "-1", "1e308", "-1e308", "3e38"]),
        1 => prop::sample::select(vec!["0", "nan", "inf", "-inf", "1e-320", "abc", ""]),
    ]
    .prop_map(str::to_string)
}

/// Axis sizes: small, at the edges of integer types, and past them.
fn odd_size() -> impl Strategy<Value = u64> {
    prop_oneof![
        1 => 0u64..2,
        6 => 2u64..5,
        1 => prop::sample::select(vec![
            65535u64, 65536, 1 << 31, (1 << 31) - 1, 1 << 32, 1 << 40, u64::MAX / 3, u64::MAX,
        ]),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, failure_persistence: None, ..ProptestConfig::default() })]

    /// Nesting deep enough to overflow a recursive parser (20,000 aborted), with comments,
    /// CDATA and self-closing elements mixed in: refused with a located line, never an abort.
    #[test]
    fn nested_markup_never_overflows(
        depth in prop_oneof![0usize..80, 1000usize..40000],
        extras in prop::collection::vec(0u8..4, 0..6),
        npy in any::<bool>(),
    ) {
        let dir = crate::common::scratch("fuzz-nesting");
        if npy {
            let header = format!(
                "{{'descr': '<f4', 'fortran_order': False, 'shape': (2, 2, 2), 'x': {}{}}}\n",
                "(".repeat(depth), ")".repeat(depth)
            );
            let mut b = b"\x93NUMPY\x02\x00".to_vec();
            b.extend((header.len() as u32).to_le_bytes());
            b.extend(header.as_bytes());
            b.extend([0u8; 32]);
            std::fs::write(dir.join("v.npy"), b).unwrap();
            check("[field]\nsource = \"npy\"\npath = \"v.npy\"\n", &dir, &[]);
        } else {
            let mut inner = String::new();
            for e in &extras {
                inner.push_str(["<!-- <x> -->", "<![CDATA[<y>]]>", "<z/>", "<?pi <w>?>"][*e as usize]);
            }
            let text = format!(
                "<VTKFile type=\"ImageData\"><ImageData WholeExtent=\"0 1 0 1 0 1\"><Piece>\
                 <PointData>{inner}{}{}<DataArray type=\"Float32\" format=\"ascii\">0 1 2 3 4 5 6 7\
                 </DataArray></PointData></Piece></ImageData></VTKFile>",
                "<a b='>'>".repeat(depth), "</a>".repeat(depth)
            );
            let p = dir.join("v.vti");
            std::fs::write(&p, text).unwrap();
            let r = read_volume(&p);
            if depth > 64 {
                let m = r.unwrap_err();
                prop_assert!(m.contains("the XML nests deeper than 64"), "{}", m);
            }
        }
    }

}

proptest! {
    // Cheap cases (a header and a few bytes each): enough of them to meet a huge spacing on an
    // axis of several points (the box at infinity) in most runs.
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    /// Every text format's header with odd sizes and odd geometry, over a few bytes of data:
    /// refused under the cap before anything is allocated, or read with a finite box.
    #[test]
    fn odd_headers_never_panic(
        sizes in prop::array::uniform3(odd_size()),
        geometry in prop::collection::vec(odd_number(), 6),
        which in 0usize..6,
        payload in prop::collection::vec(any::<u8>(), 60..130),
    ) {
        let dir = crate::common::scratch("fuzz-headers");
        let [x, y, z] = sizes;
        let g = |k: usize| geometry[k].as_str();
        let (name, head): (&str, String) = match which {
            0 => ("v.nrrd", format!(
                "NRRD0004\ntype: uchar\ndimension: 3\nsizes: {x} {y} {z}\nencoding: raw\n\
                 spacings: {} {} {}\naxis mins: {} {} {}\n\n", g(0), g(1), g(2), g(3), g(4), g(5))),
            1 => ("v.mha", format!(
                "NDims = 3\nDimSize = {x} {y} {z}\nElementType = MET_UCHAR\n\
                 ElementSpacing = {} {} {}\nOffset = {} {} {}\nElementDataFile = LOCAL\n",
                g(0), g(1), g(2), g(3), g(4), g(5))),
            2 => ("v.vtk", format!(
                "# vtk DataFile Version 3.0\nt\nBINARY\nDATASET STRUCTURED_POINTS\n\
                 DIMENSIONS {x} {y} {z}\nSPACING {} {} {}\nORIGIN {} {} {}\n\
                 POINT_DATA {}\nSCALARS s unsigned_char\n",
                g(0), g(1), g(2), g(3), g(4), g(5), x.wrapping_mul(y).wrapping_mul(z))),
            3 => ("v.vti", format!(
                "<VTKFile type=\"ImageData\"><ImageData WholeExtent=\"0 {} 0 {} 0 {}\" \
                 Spacing=\"{} {} {}\" Origin=\"{} {} {}\"><Piece><PointData>\
                 <DataArray type=\"UInt8\" format=\"ascii\">1 2 3 4 5 6 7 8</DataArray>\
                 </PointData></Piece></ImageData></VTKFile>",
                x.wrapping_sub(1), y.wrapping_sub(1), z.wrapping_sub(1),
                g(0), g(1), g(2), g(3), g(4), g(5))),
            4 => {
                // NIfTI-1: dims, pixdim and (half the time) an sform from the odd numbers.
                let mut h = vec![0u8; 352];
                h[0..4].copy_from_slice(&348i32.to_le_bytes());
                let mut short = |o: usize, v: i16| h[o..o + 2].copy_from_slice(&v.to_le_bytes());
                short(40, 3);
                for (k, &size) in sizes.iter().enumerate() {
                    short(42 + 2 * k, size.min(i16::MAX as u64) as i16);
                }
                short(70, 2); // uint8
                short(72, 8);
                let sform = payload.first().is_some_and(|b| b % 2 == 0);
                short(254, sform as i16);
                let mut real = |o: usize, v: f32| h[o..o + 4].copy_from_slice(&v.to_le_bytes());
                let num = |k: usize| g(k).parse::<f32>().unwrap_or(1.0);
                real(108, 352.0); // vox_offset
                for k in 0..3 {
                    real(80 + 4 * k, num(k)); // pixdim[1..3]
                    real(280 + 16 * k + 4 * k, num(k)); // srow diagonal
                    real(280 + 16 * k + 12, num(3 + k)); // srow offsets
                }
                h[344..348].copy_from_slice(b"n+1\0");
                let p = dir.join("v.nii");
                std::fs::write(&p, [h.as_slice(), &payload].concat()).unwrap();
                let _ = read_volume(&p);
                return Ok(());
            }
            _ => {
                // MRC: dims, cell and origin words in a 1024-byte header.
                let mut h = vec![0u8; 1024];
                let mut put = |i: usize, v: [u8; 4]| h[4 * i..4 * i + 4].copy_from_slice(&v);
                for (k, &size) in sizes.iter().enumerate() {
                    put(k, (size as i32).to_le_bytes());
                    put(7 + k, (size as i32).to_le_bytes());
                    put(10 + k, g(k).parse::<f32>().unwrap_or(1.0).to_le_bytes());
                    put(16 + k, (k as i32 + 1).to_le_bytes());
                    put(49 + k, g(3 + k).parse::<f32>().unwrap_or(0.0).to_le_bytes());
                }
                h[208..212].copy_from_slice(b"MAP ");
                h[212] = 0x44;
                let p = dir.join("v.mrc");
                std::fs::write(&p, [h.as_slice(), &payload].concat()).unwrap();
                let _ = read_volume(&p);
                return Ok(());
            }
        };
        let p = dir.join(name);
        std::fs::write(&p, [head.as_bytes(), &payload].concat()).unwrap();
        let _ = read_volume(&p);
    }

}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, failure_persistence: None, ..ProptestConfig::default() })]

    /// A raw file cut to any length after it was opened for `field.residency`: every read of
    /// what is gone is the one-line "shrank" error, what is left reads as before.
    #[test]
    fn a_file_cut_while_read_is_one_line(
        dims in prop::array::uniform3(2usize..12),
        cut in 0.0f64..1.0,
        lo in prop::array::uniform3(0usize..12),
    ) {
        let dir = crate::common::scratch("fuzz-shrink");
        let n: usize = dims.iter().product();
        let bytes: Vec<u8> = (0..n).flat_map(|i| (i as f32).to_le_bytes()).collect();
        std::fs::write(dir.join("v.raw"), &bytes).unwrap();
        let text = format!(
            "[field]\nsource = \"raw\"\npath = \"v.raw\"\ndims = [{}, {}, {}]\ndtype = \"f32\"\n\
             residency = \"active\"\n", dims[0], dims[1], dims[2]
        );
        let s = scene::from_str_with(&text, "t.toml", &dir, &[], &limits()).unwrap();
        let grid = isoview::field::mapped::MappedGrid::open(&s.field).unwrap().unwrap();
        let len = (bytes.len() as f64 * cut) as u64;
        std::fs::OpenOptions::new().write(true).open(dir.join("v.raw")).unwrap().set_len(len).unwrap();
        let e = grid.brick_ranges(8).unwrap_err();
        prop_assert!(matches!(e, isoview::field::FieldError::Shrank { len: Some(l), .. } if l == len), "{}", e);
        let lo = [0, 1, 2].map(|a| lo[a] % dims[a]);
        let box_n = [0, 1, 2].map(|a| dims[a] - lo[a]);
        let last = lo[0] + box_n[0] - 1 + dims[0] * (lo[1] + box_n[1] - 1 + dims[1] * (lo[2] + box_n[2] - 1));
        match grid.read_box(lo, box_n) {
            Ok(v) => {
                prop_assert!((last as u64 + 1) * 4 <= len);
                prop_assert_eq!(v[0], (lo[0] + dims[0] * (lo[1] + dims[1] * lo[2])) as f32);
            }
            Err(e) => {
                let want = format!("shrank to {} bytes while being read", len);
                prop_assert!(e.to_string().ends_with(&want), "{}", e);
            }
        }
    }
}
