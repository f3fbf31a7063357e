//! The volume readers of `source = "file"` against the reference readers: for every file in
//! `tests/data/formats/`, dims, geometry and sample checksums equal what nibabel, mrcfile,
//! pynrrd, SimpleITK, VTK or tifffile read (recorded in `reference.json` by
//! `make_reference.py`, so the tests need no Python). Then malformed, truncated and oversized
//! files: one located error line each, never a panic.

use std::path::{Path, PathBuf};

use glam::DVec3;
use isoview::field::formats::{self, Format, ReadOptions, Volume};
use isoview::field::{DataAccess, FieldError, GridLimits};
use isoview::scene;
use serde_json::Value;

fn data() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/formats")
}

fn opts() -> ReadOptions {
    ReadOptions {
        limits: GridLimits::default(),
        spacing: None,
        access: DataAccess::Any,
        grid: None,
        has_bounds: false,
    }
}

fn read(path: &Path) -> Result<Volume, FieldError> {
    let format = Format::from_path(path).unwrap_or_else(|| panic!("no format for {path:?}"));
    formats::read(path, format, &opts())
}

fn vec3(v: &Value) -> DVec3 {
    let a: Vec<f64> = v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    DVec3::new(a[0], a[1], a[2])
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + b.abs())
}

#[test]
fn every_reader_matches_its_reference_reader() {
    let text = std::fs::read_to_string(data().join("reference.json")).unwrap();
    let reference: serde_json::Map<String, Value> = serde_json::from_str(&text).unwrap();
    let mut formats_seen = Vec::new();
    assert!(reference.len() >= 20, "{} reference files", reference.len());
    for (name, r) in &reference {
        let path = data().join(name);
        let format = Format::from_path(&path).unwrap();
        assert_eq!(format.name(), r["format"].as_str().unwrap(), "{name}");
        formats_seen.push(format);
        let v = read(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        let dims: Vec<usize> =
            r["dims"].as_array().unwrap().iter().map(|d| d.as_u64().unwrap() as usize).collect();
        assert_eq!(v.dims.to_vec(), dims, "{name}: dims");
        // Headers store geometry as f32 or decimal text: compare to 1e-5.
        let (origin, spacing) = (vec3(&r["origin"]), vec3(&r["spacing"]));
        for k in 0..3 {
            assert!(close(v.origin[k], origin[k], 1e-5), "{name}: origin {} vs {origin}", v.origin);
            assert!(
                close(v.spacing[k], spacing[k], 1e-5),
                "{name}: spacing {} vs {spacing}",
                v.spacing
            );
            let axis = vec3(&r["axes"][k]);
            assert!((v.axes[k] - axis).length() < 1e-5, "{name}: axis {k} {} vs {axis}", v.axes[k]);
        }
        let (min, max) =
            v.values.iter().fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
        // The reference values are f32s: compare as f32 (serde_json's f64 parse may be off by
        // an ulp of f64, never of f32).
        assert_eq!(min, r["min"].as_f64().unwrap() as f32, "{name}: min");
        assert_eq!(max, r["max"].as_f64().unwrap() as f32, "{name}: max");
        let sum: f64 = v.values.iter().map(|&x| x as f64).sum();
        assert!(close(sum, r["sum"].as_f64().unwrap(), 1e-9), "{name}: sum {sum} vs {}", r["sum"]);
        for s in r["samples"].as_array().unwrap() {
            let p: Vec<usize> =
                s[0].as_array().unwrap().iter().map(|d| d.as_u64().unwrap() as usize).collect();
            let got = v.values[p[0] + v.dims[0] * (p[1] + v.dims[1] * p[2])];
            assert_eq!(got, s[1].as_f64().unwrap() as f32, "{name}: value at {p:?}");
        }
    }
    // OpenVDB and NanoVDB have their own reference files, from pyopenvdb (field::vdb).
    for f in Format::ALL.into_iter().filter(|f| !matches!(f, Format::Vdb | Format::Nvdb)) {
        assert!(formats_seen.contains(&f), "no reference file for {}", f.name());
    }
}

/// The scene reading of a file: the box from the header, the orientation as the placement,
/// and `bounds` overriding both.
#[test]
fn a_file_places_its_grid_and_bounds_override_it() {
    let dir = data();
    let load = |extra: &str| {
        let text = format!("[field]\nsource = \"file\"\npath = \"sitk_oblique.mha\"\n{extra}");
        scene::from_str_with(&text, "t.toml", &dir, &[], &GridLimits::default())
    };
    let s = load("").unwrap();
    let v = read(&dir.join("sitk_oblique.mha")).unwrap();
    assert_eq!(s.field.bounds.min, v.origin);
    assert!(
        (s.field.bounds.max - (v.origin + v.spacing * DVec3::new(11.0, 9.0, 7.0))).length() < 1e-12
    );
    assert!(!s.field.placement.is_identity());
    let world =
        s.field.placement.point_to_world(s.field.bounds.min + DVec3::new(v.spacing.x, 0.0, 0.0));
    assert!((world - (v.origin + v.axes[0] * v.spacing.x)).length() < 1e-9);
    let s = load("bounds = { min = [0, 0, 0], max = [1, 1, 1] }\n").unwrap();
    assert!(s.field.placement.is_identity());
    assert_eq!(s.field.bounds.max, DVec3::ONE);
    // An axis-aligned header leaves the placement the identity.
    let text = "[field]\nsource = \"file\"\npath = \"EMD-3197.map\"\n";
    let s = scene::from_str_with(text, "t.toml", &dir, &[], &GridLimits::default()).unwrap();
    assert!(s.field.placement.is_identity());
    assert!((s.field.bounds.min - DVec3::new(-22.8, 0.0, 0.0)).length() < 1e-9);
}

#[test]
fn format_comes_from_the_key_or_the_extension() {
    let dir = crate::common::scratch("formats-ext");
    std::fs::copy(data().join("EMD-3197.map"), dir.join("map.bin")).unwrap();
    let load = |field: &str| {
        scene::from_str_with(
            &format!("[field]\nsource = \"file\"\n{field}"),
            "t.toml",
            &dir,
            &[],
            &GridLimits::default(),
        )
    };
    let e = load("path = \"map.bin\"\n").unwrap_err().to_string();
    assert!(e.contains("field.path") && e.contains("format = "), "{e}");
    assert!(load("path = \"map.bin\"\nformat = \"mrc\"\n").is_ok());
    let e = load("path = \"map.bin\"\nformat = \"nrrd\"\n").unwrap_err().to_string();
    assert!(e.contains("map.bin: NRRD:"), "{e}");
    let e = load("path = \"map.bin\"\nformat = \"mrc\"\nspacing = [1, 1, 1]\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("field.spacing") && e.contains("only TIFF"), "{e}");
    assert_eq!(Format::from_path(Path::new("a/B.NII.GZ")), Some(Format::Nifti));
    assert_eq!(Format::from_path(Path::new("x.nhdr")), Some(Format::Nrrd));
    assert_eq!(Format::from_path(Path::new("gz")), None);
}

#[test]
fn tiff_spacing_comes_from_the_scene() {
    let text = "[field]\nsource = \"file\"\npath = \"tifffile_f32.tif\"\nspacing = [0.5, 0.5, 2]\n";
    let s = scene::from_str_with(text, "t.toml", &data(), &[], &GridLimits::default()).unwrap();
    assert_eq!(s.field.bounds.max, DVec3::new(5.5, 4.5, 14.0));
}

/// Every file cut short, and its first bytes damaged, is an error that names the file on one
/// line (or, for damage a format cannot see, a volume), never a panic.
#[test]
fn truncated_and_damaged_files_are_located_errors() {
    let dir = crate::common::scratch("formats-bad");
    let mut checked = 0;
    for entry in std::fs::read_dir(data()).unwrap() {
        let path = entry.unwrap().path();
        let Some(format) = Format::from_path(&path) else { continue };
        let bytes = std::fs::read(&path).unwrap();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        if name.ends_with(".nhdr") || name.ends_with(".mhd") {
            continue; // their data is in another file, checked below
        }
        let cut = dir.join(&name);
        for len in [0, 7, bytes.len() / 2, bytes.len() - 40] {
            std::fs::write(&cut, &bytes[..len]).unwrap();
            let e = formats::read(&cut, format, &opts())
                .err()
                .unwrap_or_else(|| panic!("{name} cut to {len} read"));
            let msg = e.to_string();
            assert!(msg.contains(&name) && !msg.contains('\n'), "{name} cut to {len}: {msg}");
            checked += 1;
        }
        for at in (0..bytes.len().min(400)).step_by(13) {
            let mut damaged = bytes.clone();
            damaged[at] ^= 0x5a;
            std::fs::write(&cut, &damaged).unwrap();
            if let Err(e) = formats::read(&cut, format, &opts()) {
                let msg = e.to_string();
                assert!(msg.contains(&name) && !msg.contains('\n'), "{name} byte {at}: {msg}");
            }
        }
    }
    assert!(checked >= 80, "{checked}");
}

#[test]
fn malformed_headers_say_what_is_wrong() {
    let dir = crate::common::scratch("formats-headers");
    let cases: &[(&str, &str, &str)] = &[
        ("a.nrrd", "NRRD0004\ntype: float\ndimension: 2\nsizes: 3 3\nencoding: raw\n\n", "dimension 2"),
        ("b.nrrd", "NRRD0004\ntype: complex\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n", "type \"complex\""),
        ("c.nrrd", "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nencoding: bzip2\nendian: little\n\n", "encoding \"bzip2\""),
        ("d.nrrd", "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n", "no endian"),
        ("e.nrrd", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: ascii\n\n1 2 3\n", "holds 3 of the 8"),
        ("g.mha", "NDims = 3\nDimSize = 2 2 2\nElementType = MET_FLOAT\nElementDataFile = LOCAL\n\0\0\0\0", "truncated data"),
        ("h.mha", "NDims = 3\nDimSize = 2 2 2\nElementType = MET_STRING\nElementDataFile = LOCAL\n", "MET_STRING"),
        ("i.mhd", "NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nElementDataFile = missing.raw\n", "missing.raw: file not found"),
        ("j.vtk", "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n", "POLYDATA"),
        ("k.vtk", "# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\nPOINT_DATA 7\nSCALARS s float\n1 2 3 4 5 6 7\n", "POINT_DATA 7"),
        ("l.vti", "<VTKFile type=\"ImageData\"><ImageData WholeExtent=\"0 1 0 1 0 1\"><Piece Extent=\"0 1 0 1 0 1\"><PointData><DataArray type=\"Float32\" format=\"ascii\">1 2 3</DataArray></PointData></Piece></ImageData></VTKFile>", "holds 3 of the 8"),
        ("m.vti", "<VTKFile type=\"PolyData\"></VTKFile>", "not a VTKFile of type ImageData"),
    ];
    for (name, text, needle) in cases {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        let e = read(&p).expect_err(name).to_string();
        assert!(e.contains(needle) && e.contains(name) && !e.contains('\n'), "{name}: {e}");
    }
}

#[test]
fn sheared_axes_are_refused_with_the_file_named() {
    let dir = crate::common::scratch("formats-sheared");
    let header = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nspace: RAS\n\
                  space directions: (1,0,0) (1,1,0) (0,0,1)\n\n";
    std::fs::write(dir.join("s.nrrd"), [header.as_bytes(), &[0u8; 8]].concat()).unwrap();
    let text = "[field]\nsource = \"file\"\npath = \"s.nrrd\"\n";
    let e = scene::from_str_with(text, "t.toml", &dir, &[], &GridLimits::default()).unwrap_err();
    let e = e.to_string();
    assert!(e.contains("s.nrrd: NRRD:") && e.contains("sheared") && !e.contains('\n'), "{e}");
    // As the message says, bounds place it axis-aligned instead.
    let text = format!("{text}bounds = {{ min = [0, 0, 0], max = [1, 1, 1] }}\n");
    let s = scene::from_str_with(&text, "t.toml", &dir, &[], &GridLimits::default()).unwrap();
    assert!(s.field.placement.is_identity());
}

#[test]
fn the_memory_cap_refuses_before_reading() {
    let dir = crate::common::scratch("formats-cap");
    // A header that declares 10^12 points and holds 8 bytes.
    let p = dir.join("huge.nrrd");
    std::fs::write(&p, "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 10000 10000 10000\nencoding: gzip\n\n\0\0\0\0\0\0\0\0").unwrap();
    let e = read(&p).unwrap_err();
    assert!(matches!(e, FieldError::TooLarge { .. }), "{e}");
    // A real map under a cap smaller than its grid.
    let small = ReadOptions {
        limits: GridLimits { max_bytes: 1 << 14 },
        spacing: None,
        access: DataAccess::Any,
        grid: None,
        has_bounds: false,
    };
    let e = formats::read(&data().join("EMD-3197.map"), Format::Mrc, &small).unwrap_err();
    assert!(matches!(e, FieldError::TooLarge { .. }), "{e}");
}

/// MetaImage's byte-order flag and `HeaderSize = -1` (SimpleITK writes neither): the int16
/// file's samples byte-swapped behind a 100-byte preamble read back the same.
#[test]
fn metaimage_big_endian_and_header_size() {
    let dir = crate::common::scratch("formats-mha-msb");
    let raw = std::fs::read(data().join("sitk_int16.raw")).unwrap();
    let mut swapped = vec![7u8; 100];
    swapped.extend(raw.chunks(2).flat_map(|c| [c[1], c[0]]));
    std::fs::write(dir.join("be.raw"), &swapped).unwrap();
    let header = std::fs::read_to_string(data().join("sitk_int16.mhd")).unwrap();
    let header = header
        .replace("BinaryDataByteOrderMSB = False", "BinaryDataByteOrderMSB = True\nHeaderSize = -1")
        .replace("ElementDataFile = sitk_int16.raw", "ElementDataFile = be.raw");
    assert!(header.contains("HeaderSize = -1") && header.contains("be.raw"), "{header}");
    std::fs::write(dir.join("be.mhd"), header).unwrap();
    let a = read(&data().join("sitk_int16.mhd")).unwrap();
    let b = read(&dir.join("be.mhd")).unwrap();
    assert_eq!(a.values, b.values);
    assert_eq!((a.origin, a.spacing), (b.origin, b.spacing));
}
