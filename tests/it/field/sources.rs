//! Field sources: `.npy` dtypes, orders and byte orders, `.raw` files, expressions, signed
//! distances, corner cells; data errors (one line, naming the file) and the memory cap.

use std::path::{Path, PathBuf};

use glam::DVec3;
use isoview::field::{FieldError, FieldSource, FieldSpec, Grid, GridLimits, NanPolicy};
use isoview::scene::{self, Bounds, Scene, SceneError, SceneErrorKind, SdfShape};

/// A fresh folder for this test's files.
fn dir(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("isoview-sources-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Loads a scene whose `[field]` is `field` (the rest default), from `dir`.
fn load(dir: &Path, field: &str) -> Result<Scene, SceneError> {
    load_capped(dir, field, GridLimits::default())
}

fn load_capped(dir: &Path, field: &str, limits: GridLimits) -> Result<Scene, SceneError> {
    scene::from_str_with(&format!("[field]\n{field}"), "t.toml", dir, &[], &limits)
}

fn load_err(dir: &Path, field: &str) -> String {
    let Err(e) = load(dir, field) else { panic!("expected an error for {field}") };
    let e = e.to_string();
    assert!(!e.contains('\n'), "not one line: {e:?}");
    e
}

fn sample(s: &Scene) -> Result<Grid, FieldError> {
    s.field.sample_with(0.0, &GridLimits::default())
}

/// An `.npy` version 1.0 file.
fn npy(descr: &str, fortran: bool, shape: &[u64], payload: &[u8]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(u64::to_string).collect();
    let shape = if dims.len() == 1 { format!("{},", dims[0]) } else { dims.join(", ") };
    let fortran = if fortran { "True" } else { "False" };
    let mut header =
        format!("{{'descr': {descr}, 'fortran_order': {fortran}, 'shape': ({shape}), }}");
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend((header.len() as u16).to_le_bytes());
    out.extend(header.as_bytes());
    out.extend(payload);
    out
}

/// `x` encoded as numpy type `ty` (`i2`, `f4`, ...) in the given byte order.
fn encode(ty: &str, big: bool, x: f64) -> Vec<u8> {
    let mut b = match ty {
        "b1" => vec![(x != 0.0) as u8],
        "u1" => vec![x as u8],
        "i1" => vec![x as i8 as u8],
        "u2" => (x as u16).to_le_bytes().to_vec(),
        "i2" => (x as i16).to_le_bytes().to_vec(),
        "u4" => (x as u32).to_le_bytes().to_vec(),
        "i4" => (x as i32).to_le_bytes().to_vec(),
        "u8" => (x as u64).to_le_bytes().to_vec(),
        "i8" => (x as i64).to_le_bytes().to_vec(),
        "f2" => f16_bits(x).to_le_bytes().to_vec(),
        "f4" => (x as f32).to_le_bytes().to_vec(),
        "f8" => x.to_le_bytes().to_vec(),
        _ => panic!("{ty}"),
    };
    if big {
        b.reverse();
    }
    b
}

/// Half-precision bits of a small integer (exact for |x| < 2048).
fn f16_bits(x: f64) -> u16 {
    if x == 0.0 {
        return 0;
    }
    let sign = if x < 0.0 { 0x8000 } else { 0 };
    let a = x.abs();
    let e = a.log2().floor() as i32;
    let man = ((a / 2f64.powi(e) - 1.0) * 1024.0).round() as u16;
    sign | (((e + 15) as u16) << 10) | man
}

/// The test volume: value at point (i, j, k) of a (2, 3, 4) grid, distinct everywhere.
fn value(i: usize, j: usize, k: usize, signed: bool) -> f64 {
    (100 * i + 10 * j + k) as f64 - if signed { 60.0 } else { 0.0 }
}

/// Samples in storage order: C (k fastest) or Fortran (i fastest).
fn payload(
    ty: &str,
    big: bool,
    fortran: bool,
    dims: [usize; 3],
    f: impl Fn(usize, usize, usize) -> f64,
) -> Vec<u8> {
    let mut out = Vec::new();
    let [nx, ny, nz] = dims;
    if fortran {
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    out.extend(encode(ty, big, f(i, j, k)));
                }
            }
        }
    } else {
        for i in 0..nx {
            for j in 0..ny {
                for k in 0..nz {
                    out.extend(encode(ty, big, f(i, j, k)));
                }
            }
        }
    }
    out
}

// ---- npy --------------------------------------------------------------------------------------

#[test]
fn npy_reads_every_real_and_integer_dtype_in_both_orders_and_byte_orders() {
    let d = dir("npy-dtypes");
    let dims = [2, 3, 4];
    let types = ["b1", "u1", "i1", "u2", "i2", "u4", "i4", "u8", "i8", "f2", "f4", "f8"];
    let mut n = 0;
    for ty in types {
        let one_byte = matches!(ty, "b1" | "u1" | "i1");
        let signed = ty.starts_with('i') || ty.starts_with('f');
        for big in [false, true] {
            if one_byte && big {
                continue;
            }
            let order = if one_byte {
                "|"
            } else if big {
                ">"
            } else {
                "<"
            };
            for fortran in [false, true] {
                let f = |i, j, k| {
                    if ty == "b1" {
                        ((i + j + k) % 2) as f64
                    } else {
                        value(i, j, k, signed)
                    }
                };
                let bytes = npy(
                    &format!("'{order}{ty}'"),
                    fortran,
                    &[2, 3, 4],
                    &payload(ty, big, fortran, dims, f),
                );
                let name = format!("v{n}.npy");
                n += 1;
                std::fs::write(d.join(&name), bytes).unwrap();
                let s = load(&d, &format!("source = \"npy\"\npath = \"{name}\"\n")).unwrap();
                assert_eq!(s.field.resolution, dims);
                assert_eq!(s.field.bounds, Bounds::index_space(dims));
                let g = sample(&s).unwrap();
                for k in 0..4 {
                    for j in 0..3 {
                        for i in 0..2 {
                            assert_eq!(
                                g.at(i, j, k) as f64,
                                f(i, j, k),
                                "{order}{ty} fortran={fortran} [{i}, {j}, {k}]"
                            );
                        }
                    }
                }
                let desc = s.field.describe();
                assert!(
                    desc.starts_with(&format!(
                        "npy {name} {order}{ty} {}-order 2x3x4",
                        if fortran { "Fortran" } else { "C" }
                    )),
                    "{desc}"
                );
            }
        }
    }
}

/// An array handed over in memory (the Python module's path: `field::from_memory`, then
/// `scene::from_str_with_grid`) gives the grid the same bytes saved as `.npy` give, bit for
/// bit, for every dtype, order and byte order; its scene takes the keys every source takes and
/// refuses `source`.
#[test]
fn arrays_in_memory_become_the_grid_their_npy_file_gives() {
    let d = dir("memory");
    let dims = [2, 3, 4];
    let what = Path::new("the array");
    let mut n = 0;
    for ty in ["b1", "u1", "i1", "u2", "i2", "u4", "i4", "u8", "i8", "f2", "f4", "f8"] {
        let signed = ty.starts_with('i') || ty.starts_with('f');
        for (big, fortran) in [(false, false), (false, true), (true, false), (true, true)] {
            let one_byte = matches!(ty, "b1" | "u1" | "i1");
            let order = match (one_byte, big) {
                (true, _) => "|",
                (false, true) => ">",
                (false, false) => "<",
            };
            let f = |i, j, k| match ty {
                "b1" => ((i + j + k) % 2) as f64,
                _ => value(i, j, k, signed) + 0.25 * (ty.starts_with('f') as u8 as f64),
            };
            let bytes = payload(ty, big, fortran, dims, f);
            let name = format!("m{n}.npy");
            n += 1;
            let descr = format!("{order}{ty}");
            std::fs::write(d.join(&name), npy(&format!("'{descr}'"), fortran, &[2, 3, 4], &bytes))
                .unwrap();
            let file = load(&d, &format!("source = \"npy\"\npath = \"{name}\"\n")).unwrap();
            let (st, endian) = isoview::field::sample_type_of_descr(what, &descr).unwrap();
            let order = match fortran {
                true => isoview::field::StorageOrder::XFastest,
                false => isoview::field::StorageOrder::ZFastest,
            };
            let values =
                isoview::field::from_memory(&bytes, what, st, endian, dims, order).unwrap();
            assert_eq!(values, sample(&file).unwrap().values, "{descr} fortran={fortran}");
            let zero = DVec3::ZERO;
            let grid = std::sync::Arc::new(Grid { dims, min: zero, max: zero, values });
            let s = scene::from_str_with_grid("[field]\n", "array", &d, &[], &grid).unwrap();
            assert_eq!(s.field.bounds, Bounds::index_space(dims));
            assert_eq!(sample(&s).unwrap().values, grid.values);
        }
    }
    // The dtype rule is the .npy files' (the same refusals), and the byte count is checked.
    let e = isoview::field::sample_type_of_descr(what, "<c8").unwrap_err().to_string();
    assert_eq!(e, "the array: unsupported dtype <c8 (complex samples are not supported; save the real part or the magnitude)");
    let e = isoview::field::sample_type_of_descr(what, "|O").unwrap_err().to_string();
    assert!(e.starts_with("the array: unsupported dtype |O ("), "{e}");
    let (st, endian) = isoview::field::sample_type_of_descr(what, "<f4").unwrap();
    let order = isoview::field::StorageOrder::ZFastest;
    let short = isoview::field::from_memory(&[0; 95], what, st, endian, dims, order);
    assert!(matches!(short, Err(FieldError::SizeMismatch { actual: 95, expected: 96, .. })));
    // Only the keys every source takes; the array is the source; the box is `bounds`.
    let grid = std::sync::Arc::new(Grid {
        dims,
        min: DVec3::ZERO,
        max: DVec3::ZERO,
        values: (0..24).map(|v| v as f32).collect(),
    });
    let sets = ["field.bounds.min=[0, 0, 0]".to_string(), "field.bounds.max=[1, 2, 6]".into()];
    let s = scene::from_str_with_grid("[field]\n", "array", &d, &sets, &grid).unwrap();
    assert_eq!(s.field.bounds.max, DVec3::new(1.0, 2.0, 6.0));
    assert_eq!(s.field.describe(), "grid in memory 2x3x4 in [0, 0, 0]..[1, 2, 6]");
    let e = scene::from_str_with_grid("[field]\nsource = \"npy\"\n", "array", &d, &[], &grid)
        .unwrap_err()
        .to_string();
    assert!(e.contains("field.source: ") && e.contains("the field is the array passed in"), "{e}");
    let e = scene::from_str_with_grid("[field]\npath = \"a.npy\"\n", "array", &d, &[], &grid)
        .unwrap_err();
    assert_eq!(e.kind, SceneErrorKind::UnknownKey, "{e}");
    let sets = ["surface.isovalue_percentile=50".to_string()];
    let s = scene::from_str_with_grid("[field]\n", "array", &d, &sets, &grid).unwrap();
    let p50 = isoview::field::stats::Stats::of(&grid.values).percentile(50.0).unwrap();
    assert_eq!(s.surface.isovalue, p50, "the percentile is the array's samples'");
}

#[test]
fn npy_path_is_relative_to_the_scene_file() {
    let d = dir("npy-relative");
    std::fs::create_dir_all(d.join("data")).unwrap();
    let bytes = npy(
        "'<f4'",
        false,
        &[2, 2, 2],
        &payload("f4", false, false, [2, 2, 2], |i, j, k| value(i, j, k, true)),
    );
    std::fs::write(d.join("data/v.npy"), bytes).unwrap();
    std::fs::write(d.join("scene.toml"), "[field]\nsource = \"npy\"\npath = \"data/v.npy\"\n")
        .unwrap();
    let s = scene::load(&d.join("scene.toml"), &[]).unwrap();
    assert_eq!(sample(&s).unwrap().at(1, 1, 1), value(1, 1, 1, true) as f32);
}

#[test]
fn npy_errors_name_the_file_and_what_is_wrong() {
    let d = dir("npy-errors");
    let p = |name: &str| d.join(name).display().to_string();
    let field = |name: &str| format!("source = \"npy\"\npath = \"{name}\"\n");
    let write = |name: &str, bytes: Vec<u8>| std::fs::write(d.join(name), bytes).unwrap();
    let f4 = |n: usize| vec![0u8; 4 * n];

    assert_eq!(
        load_err(&d, &field("missing.npy")),
        format!("t.toml:3:8: field.path: {}: file not found", p("missing.npy"))
    );

    write("text.npy", b"just some text, no magic".to_vec());
    assert_eq!(
        load_err(&d, &field("text.npy")),
        format!("t.toml:3:8: field.path: {}: not a valid .npy file (it does not start with the \\x93NUMPY magic)", p("text.npy"))
    );
    write("short.npy", b"\x93NU".to_vec());
    assert!(load_err(&d, &field("short.npy")).contains("not a valid .npy file"));

    write("complex.npy", npy("'<c8'", false, &[2, 2, 2], &[0; 64]));
    assert_eq!(
        load_err(&d, &field("complex.npy")),
        format!(
            "t.toml:3:8: field.path: {}: unsupported dtype <c8 (complex samples are not supported; \
             save the real part or the magnitude)",
            p("complex.npy")
        )
    );
    write("str.npy", npy("'<U3'", false, &[2, 2, 2], &[0; 96]));
    assert!(load_err(&d, &field("str.npy"))
        .ends_with("unsupported dtype <U3 (expected a boolean, integer or real dtype)"));
    write("rec.npy", npy("[('a', '<f4'), ('b', '<f4')]", false, &[2, 2, 2], &f4(16)));
    assert!(load_err(&d, &field("rec.npy"))
        .contains("(structured arrays are not supported; save one real field)"));
    write("f16.npy", npy("'<f16'", false, &[2, 2, 2], &[0; 128]));
    assert!(load_err(&d, &field("f16.npy")).contains("extended-precision floats are not supported"));

    write("flat.npy", npy("'<f4'", false, &[4, 4], &f4(16)));
    assert_eq!(
        load_err(&d, &field("flat.npy")),
        format!("t.toml:3:8: field.path: {}: expected a 3-D array of shape (nx, ny, nz), got shape (4, 4)", p("flat.npy"))
    );
    write("thin.npy", npy("'<f4'", false, &[1, 4, 4], &f4(16)));
    assert_eq!(
        load_err(&d, &field("thin.npy")),
        format!(
            "t.toml:3:8: field.path: {}: every axis needs at least 2 points, got shape (1, 4, 4)",
            p("thin.npy")
        )
    );

    let mut cut = npy("'<f4'", false, &[2, 3, 4], &f4(24));
    cut.truncate(cut.len() - 6);
    write("cut.npy", cut);
    assert_eq!(
        load_err(&d, &field("cut.npy")),
        format!("t.toml:3:8: field.path: {}: truncated data: expected 96 bytes of samples ([2, 3, 4] x f32), found 90", p("cut.npy"))
    );
    write("long.npy", npy("'<f4'", false, &[2, 3, 4], &f4(25)));
    assert_eq!(
        load_err(&d, &field("long.npy")),
        format!(
            "t.toml:3:8: field.path: {}: dims do not match the data: [2, 3, 4] x f32 is 96 bytes of samples, the file has 100",
            p("long.npy")
        )
    );
}

#[test]
fn npy_non_finite_samples_are_reported_at_their_grid_point() {
    let d = dir("npy-nan");
    let f = |i, j, k| match (i, j, k) {
        (1, 0, 2) => f64::NAN,
        (0, 2, 3) => f64::INFINITY,
        _ => 1.0,
    };
    std::fs::write(
        d.join("nan.npy"),
        npy("'>f8'", false, &[2, 3, 4], &payload("f8", true, false, [2, 3, 4], f)),
    )
    .unwrap();
    // Missing data by default (tests/it/render/nan.rs); `nan = "error"` refuses it.
    let s = load(&d, "source = \"npy\"\npath = \"nan.npy\"\n").unwrap();
    assert!(sample(&s).is_ok());
    let s = load(&d, "source = \"npy\"\npath = \"nan.npy\"\nnan = \"error\"\n").unwrap();
    let e = sample(&s).unwrap_err();
    // The first bad point in x-fastest order: [1, 0, 2] comes before [0, 2, 3].
    assert_eq!(
        e.to_string(),
        format!("{}: value NaN at grid point [1, 0, 2] is not finite", d.join("nan.npy").display())
    );
    assert!(matches!(e, FieldError::NonFinite { index: [1, 0, 2], .. }));
    // A finite f64 beyond the f32 range is refused too, as what it is (it used to read as inf).
    let g = |i, _, _| if i == 1 { 1e300 } else { 0.0 };
    std::fs::write(
        d.join("big.npy"),
        npy("'<f8'", true, &[2, 2, 2], &payload("f8", false, true, [2, 2, 2], g)),
    )
    .unwrap();
    let s = load(&d, "source = \"npy\"\npath = \"big.npy\"\nnan = \"error\"\n").unwrap();
    assert!(sample(&s)
        .unwrap_err()
        .to_string()
        .ends_with("value 1e300 at grid point [1, 0, 0] is beyond ±3.4028235e38, the range of the 32-bit floats samples are kept in"));
}

#[test]
fn npy_over_the_memory_cap_is_refused_without_reading_the_data() {
    let d = dir("npy-cap");
    // A 128-byte file whose header claims 100000^3 float32 samples (4 PB): refused for its size,
    // not reported as truncated, so nothing past the header was considered.
    std::fs::write(d.join("huge.npy"), npy("'<f4'", false, &[100000, 100000, 100000], &[]))
        .unwrap();
    // (With residency "auto", the default, the cap applies to what a render uploads: the
    // header's size against the file's is what refuses it then.)
    let e = load_err(&d, "source = \"npy\"\npath = \"huge.npy\"\nresidency = \"whole\"\n");
    assert_eq!(
        e,
        format!(
            "t.toml:3:8: field.path: {}: a grid of 100000x100000x100000 points needs 3814697266 MiB \
             of f32 samples, over the cap of 1024 MiB; raise the cap with \
             ISOVIEW_MAX_GRID_MIB=3814697266 (or GridLimits::max_bytes), or read only the bricks \
             a render needs with field.residency = \"auto\"",
            d.join("huge.npy").display()
        )
    );
    // Dims whose product overflows 64 bits are refused without a panic, and without a cap to
    // raise (no cap reaches that far: `FieldError::Unaddressable`).
    let max = u64::MAX;
    std::fs::write(d.join("overflow.npy"), npy("'<f4'", false, &[max, max, 4], &[])).unwrap();
    let e = load_err(&d, "source = \"npy\"\npath = \"overflow.npy\"\nresidency = \"whole\"\n");
    assert!(e.contains("more than 64-bit memory can address (16 EiB)"), "{e}");
    assert!(!e.contains("ISOVIEW_MAX_GRID_MIB"), "{e}");
    // A header length larger than the file.
    let mut bad = npy("'<f4'", false, &[2, 2, 2], &[0; 32]);
    bad[6] = 2;
    bad.splice(8..10, [0xff, 0xff, 0xff, 0x7f]);
    std::fs::write(d.join("header.npy"), bad).unwrap();
    assert!(load_err(&d, "source = \"npy\"\npath = \"header.npy\"\n")
        .contains("not a valid .npy file (the header claims 2147483647 bytes, the file has"));
    // The cap is settable in code: a real 2x3x4 file under a 64-byte cap.
    std::fs::write(d.join("small.npy"), npy("'<f4'", false, &[2, 3, 4], &[0; 96])).unwrap();
    let e = load_capped(
        &d,
        "source = \"npy\"\npath = \"small.npy\"\nresidency = \"whole\"\n",
        GridLimits { max_bytes: 64 },
    )
    .unwrap_err();
    assert_eq!(e.kind, SceneErrorKind::Data);
    assert!(
        matches!(e.field_error.as_deref(), Some(FieldError::TooLarge { bytes: 96, cap: 64, .. })),
        "{e}"
    );
    let s = load(&d, "source = \"npy\"\npath = \"small.npy\"\n").unwrap();
    let e = s.field.sample_with(0.0, &GridLimits { max_bytes: 64 }).unwrap_err();
    assert!(
        e.to_string().contains("needs 96 bytes of f32 samples, over the cap of 64 bytes"),
        "{e}"
    );
}

// ---- raw --------------------------------------------------------------------------------------

#[test]
fn raw_reads_x_fastest_in_either_byte_order() {
    let d = dir("raw");
    let dims = [3, 2, 4];
    let f = |i: usize, j: usize, k: usize| (i + 3 * j + 6 * k) as f64 - 5.0;
    for (dtype, ty) in [
        ("u8", "u1"),
        ("u16", "u2"),
        ("i16", "i2"),
        ("f32", "f4"),
        ("f64", "f8"),
        ("i32", "i4"),
        ("f16", "f2"),
    ] {
        for big in [false, true] {
            let signed = !dtype.starts_with('u');
            let g = |i, j, k| if signed { f(i, j, k) } else { f(i, j, k) + 5.0 };
            // Fortran storage of an (nx, ny, nz) array is x fastest: the raw layout.
            std::fs::write(d.join("v.raw"), payload(ty, big, true, dims, g)).unwrap();
            let endian = if big { "big" } else { "little" };
            let s = load(&d, &format!("source = \"raw\"\npath = \"v.raw\"\ndims = [3, 2, 4]\ndtype = \"{dtype}\"\nendian = \"{endian}\"\n")).unwrap();
            assert_eq!(s.field.resolution, dims);
            let grid = sample(&s).unwrap();
            for (n, &v) in grid.values.iter().enumerate() {
                let (i, j, k) = (n % 3, (n / 3) % 2, n / 6);
                assert_eq!(v as f64, g(i, j, k), "{dtype} {endian} [{i}, {j}, {k}]");
            }
            assert_eq!(
                s.field.describe(),
                format!("raw v.raw {dtype} {endian}-endian 3x2x4 in [0, 0, 0]..[2, 1, 3]")
            );
        }
    }
    // endian defaults to little.
    std::fs::write(d.join("le.raw"), payload("u2", false, true, dims, |i, _, _| 300.0 + i as f64))
        .unwrap();
    let s = load(&d, "source = \"raw\"\npath = \"le.raw\"\ndims = [3, 2, 4]\ndtype = \"u16\"\n")
        .unwrap();
    assert_eq!(sample(&s).unwrap().at(2, 1, 3), 302.0);
}

#[test]
fn raw_errors_name_the_file_dims_and_sizes() {
    let d = dir("raw-errors");
    let p = d.join("v.raw").display().to_string();
    std::fs::write(d.join("v.raw"), vec![0u8; 47]).unwrap();
    let field = |dims: &str, dtype: &str| {
        format!("source = \"raw\"\npath = \"v.raw\"\ndims = {dims}\ndtype = \"{dtype}\"\n")
    };
    assert_eq!(
        load_err(&d, &field("[3, 2, 4]", "u16")),
        format!("t.toml:4:8: field.dims: {p}: truncated data: expected 48 bytes of samples ([3, 2, 4] x u16), found 47")
    );
    assert_eq!(
        load_err(&d, &field("[3, 2, 2]", "u16")),
        format!("t.toml:4:8: field.dims: {p}: dims do not match the data: [3, 2, 2] x u16 is 24 bytes of samples, the file has 47")
    );
    assert_eq!(
        load_err(&d, &format!("{}residency = \"whole\"\n", field("[4096, 4096, 4096]", "f32"))),
        format!(
            "t.toml:4:8: field.dims: {p}: a grid of 4096x4096x4096 points needs 262144 MiB of f32 samples, \
             over the cap of 1024 MiB; raise the cap with ISOVIEW_MAX_GRID_MIB=262144 (or GridLimits::max_bytes), \
             or read only the bricks a render needs with field.residency = \"auto\""
        )
    );
    assert!(load_err(&d, &field("[3, 2, 4]", "u24")).starts_with(
        "t.toml:5:9: field.dtype: unknown value \"u24\" (expected \"u8\", \"i8\", \"u16\""
    ));
    assert_eq!(
        load_err(&d, &format!("{}endian = \"middle\"\n", field("[3, 2, 4]", "u16"))),
        "t.toml:6:10: field.endian: unknown value \"middle\" (expected \"little\" or \"big\")"
    );
    assert_eq!(
        load_err(&d, "source = \"raw\"\npath = \"nope.raw\"\ndims = [2, 2, 2]\ndtype = \"u8\"\n"),
        format!("t.toml:3:8: field.path: {}: file not found", d.join("nope.raw").display())
    );
    assert_eq!(
        load_err(&d, "source = \"raw\"\npath = \"v.raw\"\ndtype = \"u8\"\n"),
        "t.toml:1:1: field.dims: missing (grid points along x, y, z, e.g. [64, 64, 64])"
    );
    assert_eq!(
        load_err(&d, "source = \"raw\"\ndims = [2, 2, 2]\ndtype = \"u8\"\n"),
        "t.toml:1:1: field.path: missing (the data file, relative to the scene file)"
    );
    assert_eq!(
        load_err(&d, "source = \"raw\"\npath = \"\"\n"),
        "t.toml:3:8: field.path: must not be empty"
    );
    assert_eq!(
        load_err(&d, "source = \"raw\"\npath = \".\"\ndims = [2, 2, 2]\ndtype = \"u8\"\n"),
        format!("t.toml:3:8: field.path: {}: is a directory, not a file", d.join(".").display())
    );
}

// ---- expr, sdf, corners -----------------------------------------------------------------------

#[test]
fn expressions_are_evaluated_at_world_points_and_time() {
    let b = Bounds { min: DVec3::new(-1.0, 0.0, 2.0), max: DVec3::new(1.0, 3.0, 2.5) };
    let spec = FieldSpec::expr("sin(3*x)*cos(3*y) + z - 0.2*t", [5, 4, 3], b).unwrap();
    assert!(spec.is_time_varying());
    for t in [0.0, 1.5] {
        let g = spec.sample_with(t, &GridLimits::default()).unwrap();
        for (i, j, k) in [(0, 0, 0), (4, 3, 2), (2, 1, 1)] {
            let p = g.point(i, j, k);
            let want = (3.0 * p.x).sin() * (3.0 * p.y).cos() + p.z - 0.2 * t;
            assert!((g.at(i, j, k) as f64 - want).abs() < 1e-6);
        }
    }
    assert_eq!(
        spec.describe(),
        "expr \"sin(3*x)*cos(3*y) + z - 0.2*t\" 5x4x3 in [-1, 0, 2]..[1, 3, 2.5]"
    );
    assert!(!FieldSpec::expr("x + y", [2, 2, 2], Bounds::UNIT).unwrap().is_time_varying());
    // A 64^3 grid (sampled over several threads) agrees with the formula everywhere checked.
    let big = FieldSpec::expr("x*x - y + 0.5*z*t", [64, 64, 64], b).unwrap();
    let g = big.sample_with(2.0, &GridLimits::default()).unwrap();
    for n in (0..g.values.len()).step_by(997) {
        let (i, j, k) = (n % 64, (n / 64) % 64, n / 4096);
        let p = g.point(i, j, k);
        assert_eq!(g.values[n], (p.x * p.x - p.y + 0.5 * p.z * 2.0) as f32);
    }
}

#[test]
fn non_finite_expression_values_name_the_point_and_time() {
    let b = Bounds { min: DVec3::splat(-1.0), max: DVec3::ONE };
    // With `field.nan = "error"` (the default takes them as missing data: tests/it/render/nan.rs).
    let error = |s: FieldSpec| FieldSpec { nan: NanPolicy::Error, ..s };
    let spec = FieldSpec::expr("sqrt(x)", [3, 3, 3], b).unwrap();
    assert!(spec.sample_with(0.0, &GridLimits::default()).is_ok());
    let spec = error(spec);
    let e = spec.sample_with(0.0, &GridLimits::default()).unwrap_err();
    assert_eq!(
        e.to_string(),
        "expression \"sqrt(x)\" at t = 0: value NaN at grid point [0, 0, 0] (x = -1, y = -1, z = -1) is not finite"
    );
    let spec = error(FieldSpec::expr("1/(t - 2) + x", [2, 2, 2], Bounds::UNIT).unwrap());
    assert!(spec.sample_with(0.0, &GridLimits::default()).is_ok());
    let e = spec.sample_with(2.0, &GridLimits::default()).unwrap_err().to_string();
    assert!(
        e.starts_with("expression \"1/(t - 2) + x\" at t = 2: value inf at grid point [0, 0, 0]"),
        "{e}"
    );
    // Numbers in their short form: `--time 1e308` printed t's 309 digits (a 496-byte line).
    let big = Bounds { min: DVec3::splat(1e300), max: DVec3::splat(2e300) };
    let spec = error(FieldSpec::expr("t * x", [2, 2, 2], big).unwrap());
    let e = spec.sample_with(1e308, &GridLimits::default()).unwrap_err().to_string();
    assert!(e.starts_with("expression \"t * x\" at t = 1e308: "), "{e}");
    assert!(e.contains("(x = 1e300, y = 1e300, z = 1e300)") && e.len() < 200, "{e}");
}

#[test]
fn sdf_values_follow_the_contract_formulas() {
    let b = Bounds { min: DVec3::new(-1.0, -0.8, -1.2), max: DVec3::new(1.1, 0.9, 1.0) };
    let c = DVec3::new(0.1, -0.05, 0.2);
    type Formula = fn(DVec3) -> f64;
    let shapes: [(SdfShape, Formula); 4] = [
        (SdfShape::Sphere { radius: 0.6 }, |p| p.length() - 0.6),
        (SdfShape::Box { half_extents: DVec3::new(0.5, 0.3, 0.4) }, |p| {
            let q = p.abs() - DVec3::new(0.5, 0.3, 0.4);
            q.max(DVec3::ZERO).length() + q.x.max(q.y).max(q.z).min(0.0)
        }),
        (SdfShape::Torus { major_radius: 0.6, minor_radius: 0.25 }, |p| {
            DVec3::new((p.x * p.x + p.z * p.z).sqrt() - 0.6, p.y, 0.0).length() - 0.25
        }),
        (SdfShape::Gyroid { scale: 5.0, thickness: 0.1 }, |p| {
            let s = 5.0;
            ((s * p.x).sin() * (s * p.y).cos()
                + (s * p.y).sin() * (s * p.z).cos()
                + (s * p.z).sin() * (s * p.x).cos())
            .abs()
                / s
                - 0.1
        }),
    ];
    for (shape, formula) in shapes {
        let g = FieldSpec::sdf(shape, c, [9, 8, 7], b)
            .sample_with(0.0, &GridLimits::default())
            .unwrap();
        for k in 0..7 {
            for j in 0..8 {
                for i in 0..9 {
                    let want = formula(g.point(i, j, k) - c);
                    assert!(
                        (g.at(i, j, k) as f64 - want).abs() < 1e-6,
                        "{shape:?} [{i}, {j}, {k}]"
                    );
                }
            }
        }
    }
    let d = FieldSpec::sdf(SdfShape::Sphere { radius: 0.5 }, c, [4, 4, 4], Bounds::UNIT).describe();
    assert_eq!(d, "sdf sphere r=0.5 center=[0.1, -0.05, 0.2] 4x4x4 in [0, 0, 0]..[1, 1, 1]");
    let d = FieldSpec::sdf(
        SdfShape::Box { half_extents: DVec3::splat(0.5) },
        DVec3::ZERO,
        [4, 4, 4],
        Bounds::UNIT,
    )
    .describe();
    assert_eq!(d, "sdf box b=[0.5, 0.5, 0.5] 4x4x4 in [0, 0, 0]..[1, 1, 1]");
    let d = FieldSpec::sdf(
        SdfShape::Gyroid { scale: 6.0, thickness: 0.08 },
        DVec3::ZERO,
        [4, 4, 4],
        Bounds::UNIT,
    )
    .describe();
    assert_eq!(d, "sdf gyroid s=6 w=0.08 4x4x4 in [0, 0, 0]..[1, 1, 1]");
}

#[test]
fn corners_are_in_vxyz_order() {
    let s =
        load(Path::new("."), "source = \"corners\"\nvalues = [0, 1, 2, 3, 4, 5, 6, 7]\n").unwrap();
    let g = sample(&s).unwrap();
    assert_eq!(g.dims, [2, 2, 2]);
    assert_eq!((g.min, g.max), (DVec3::ZERO, DVec3::ONE));
    assert_eq!(g.at(0, 0, 0), 0.0);
    assert_eq!(g.at(1, 0, 0), 1.0);
    assert_eq!(g.at(0, 1, 0), 2.0);
    assert_eq!(g.at(1, 1, 0), 3.0);
    assert_eq!(g.at(0, 0, 1), 4.0);
    assert_eq!(g.at(1, 1, 1), 7.0);
    assert_eq!(g.corners(0, 0, 0), [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]);
    assert!(!s.field.is_time_varying());
    assert_eq!(
        s.field.describe(),
        "corners [0, 1, 2, 3, 4, 5, 6, 7] 2x2x2 in [0, 0, 0]..[1, 1, 1]"
    );
    let FieldSource::Corners(_) = s.field.source else { panic!() };
}

// ---- the shipped volumes ----------------------------------------------------------------------

/// `scenes/data/make_blobs.py`'s field.
fn blobs(p: DVec3) -> f64 {
    let balls = [
        (DVec3::new(-0.35, -0.20, 0.10), 0.45),
        (DVec3::new(0.40, 0.10, -0.20), 0.40),
        (DVec3::new(0.00, 0.45, 0.35), 0.35),
        (DVec3::new(0.10, -0.45, -0.35), 0.30),
    ];
    balls.iter().map(|&(c, r)| r * r / (p - c).length_squared().max(1e-6)).sum()
}

#[test]
fn shipped_volumes_hold_the_generator_s_field_at_each_grid_point() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes");
    // npy: element [i, j, k] at point (x_i, y_j, z_k) of [-1, 1]^3 (the scene's bounds).
    let s = scene::load(&root.join("volume-npy.toml"), &[]).unwrap();
    let g = sample(&s).unwrap();
    assert_eq!(g.dims, [32, 32, 32]);
    for (i, j, k) in [(5, 9, 20), (20, 12, 3), (16, 16, 16), (31, 0, 7)] {
        let want = (50.0 * blobs(g.point(i, j, k))).round().min(255.0);
        assert!((g.at(i, j, k) as f64 - want).abs() <= 1.0, "npy [{i}, {j}, {k}]");
    }
    // raw: index-space bounds; the generator's world box is [-1, 1] x [-1.2, 1.2] x [-1.4, 1.4].
    let s = scene::load(&root.join("raw.toml"), &[]).unwrap();
    let g = sample(&s).unwrap();
    assert_eq!(g.dims, [20, 24, 28]);
    assert_eq!(s.field.bounds, Bounds::index_space([20, 24, 28]));
    for (i, j, k) in [(3, 9, 20), (15, 12, 3), (10, 11, 14), (19, 0, 27)] {
        let p = DVec3::new(
            -1.0 + i as f64 * 2.0 / 19.0,
            -1.2 + j as f64 * 2.4 / 23.0,
            -1.4 + k as f64 * 2.8 / 27.0,
        );
        let want = (5000.0 * blobs(p)).round().min(65535.0);
        assert!((g.at(i, j, k) as f64 - want).abs() <= 1.0, "raw [{i}, {j}, {k}]");
    }
    for f in ["data/blobs.npy", "data/blobs.raw"] {
        assert!(std::fs::metadata(root.join(f)).unwrap().len() <= 64 * 1024, "{f}");
    }
}

/// Every source kind answers what it supports from one place (#16), and the answers hold: it
/// gives a point evaluation exactly when it says it can be evaluated off the grid, that
/// evaluation agrees with its samples at the grid points, and only a time-dependent expression
/// is time-varying. `sample` is accepted for exactly those sources.
#[test]
fn each_source_kind_says_what_it_supports() {
    use isoview::field::SourceKind;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let fields = [
        ("sdf", "source = \"sdf\"\nshape = \"sphere\"\nradius = 0.6\nresolution = [5, 6, 7]\n"),
        ("corners", "source = \"corners\"\nvalues = [0.1, -0.4, 0.3, 0.9, -0.7, 0.2, 0.5, -0.3]\n"),
        ("npy", "source = \"npy\"\npath = \"data/blobs.npy\"\n"),
        (
            "raw",
            "source = \"raw\"\npath = \"data/blobs.raw\"\ndims = [20, 24, 28]\ndtype = \"u16\"\n",
        ),
        ("expr", "source = \"expr\"\nexpression = \"x + 2*y - z*t\"\nresolution = [3, 4, 5]\n"),
        ("mesh", "source = \"mesh\"\npath = \"data/torus.ply\"\nresolution = 8\n"),
        ("file", "source = \"file\"\npath = \"data/EMD-3197.map\"\n"),
    ];
    assert_eq!(
        SourceKind::ALL.iter().map(|k| k.name()).collect::<Vec<_>>(),
        fields.iter().map(|f| f.0).collect::<Vec<_>>()
    );
    for (name, field) in fields {
        let s = load(&root, field).unwrap_or_else(|e| panic!("{name}: {e}"));
        let kind = s.field.source.kind().unwrap();
        assert_eq!(kind.name(), name);
        let supports = s.field.source.supports();
        assert_eq!(supports, kind.supports(), "{name}");
        assert_eq!(supports.point, ["sdf", "corners", "expr", "mesh"].contains(&name), "{name}");
        assert_eq!(supports.time, name == "expr", "{name}");
        assert_eq!(s.field.is_time_varying(), name == "expr", "{name}");
        let point = s.field.source.point(&s.field.bounds, 0.0);
        assert_eq!(point.is_some(), supports.point, "{name}");
        if let Some(point) = point {
            let g = sample(&s).unwrap();
            for (i, j, k) in [(0, 0, 0), (1, 1, 1), (g.dims[0] - 1, g.dims[1] - 1, g.dims[2] - 1)] {
                let want = (point.eval)(g.point(i, j, k));
                assert!((f64::from(g.at(i, j, k)) - want).abs() < 1e-6, "{name} ({i}, {j}, {k})");
            }
        }
        let with_sample = load(&root, &format!("{field}[slice]\nambiguity = \"sample\"\n"));
        assert_eq!(with_sample.is_ok(), supports.point, "{name}: {with_sample:?}");
        if let Err(e) = with_sample {
            assert_eq!(
                e.to_string(),
                "t.toml:8:13: slice.ambiguity: \"sample\" evaluates the field's source at cell \
                 centres, which needs an sdf, corners, expr or mesh source (this field is \
                 sampled data); use \"average\" or \"saddle\""
                    .replace("8:13", &format!("{}:13", field.lines().count() + 3)),
            );
        }
    }
    let grid = FieldSpec::from_grid(sample(&load(&root, fields[0].1).unwrap()).unwrap());
    assert_eq!(grid.source.kind(), None);
    assert!(!grid.source.supports().point && grid.source.point(&grid.bounds, 0.0).is_none());
}
