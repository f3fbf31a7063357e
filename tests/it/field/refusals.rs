//! Issue 29, the volume readers: inputs that crashed or misled isoview, each refused with one
//! line (or read as it should be). Nested XML and npy headers (stack overflow), a file that
//! shrinks while it is read on demand (SIGBUS), a TIFF stack over the cap (decoded before the
//! cap refused it), header geometry that puts the box at infinity, a bad ASCII token reported
//! as truncation, and `field.residency` defaulting to `"auto"`.

use std::path::Path;

use isoview::field::formats::{self, Format, ReadOptions};
use isoview::field::mapped::MappedGrid;
use isoview::field::{DataAccess, FieldError, GridLimits, Residency};
use isoview::scene;

use crate::common::*;

fn opts() -> ReadOptions {
    ReadOptions {
        limits: GridLimits::default(),
        spacing: None,
        access: DataAccess::Any,
        grid: None,
        has_bounds: false,
    }
}

/// The error reading `path` (its format from the extension) as one line.
fn refusal(path: &Path, opts: &ReadOptions) -> String {
    let format = Format::from_path(path).unwrap();
    let e = formats::read(path, format, opts).err().unwrap_or_else(|| panic!("{path:?} read"));
    let m = e.to_string();
    assert!(!m.contains('\n') && m.contains(&path.display().to_string()), "{m}");
    m
}

/// A `.vti` of 2x2x2 ASCII samples with `depth` elements nested inside its `PointData`.
fn nested_vti(depth: usize) -> String {
    format!(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\">\n<ImageData WholeExtent=\"0 1 0 1 0 1\">\
         <Piece Extent=\"0 1 0 1 0 1\"><PointData>{}{}<DataArray type=\"Float32\" format=\"ascii\">\
         0 1 2 3 4 5 6 7</DataArray></PointData></Piece></ImageData></VTKFile>\n",
        "<a x=\"1>2\">".repeat(depth),
        "</a>".repeat(depth)
    )
}

#[test]
fn deeply_nested_xml_is_refused_with_its_place() {
    let dir = scratch("rel-xml");
    // 20,000 deep overflowed roxmltree's recursive descent (abort, rc 134). Test threads have
    // a 2 MiB stack, less than the main thread's: the refusal must come before any recursion.
    let p = dir.join("deep.vti");
    std::fs::write(&p, nested_vti(20_000)).unwrap();
    let m = refusal(&p, &opts());
    assert!(m.contains("line 3, column ") && m.contains("the XML nests deeper than 64"), "{m}");
    // The bound is on nesting only: comments, CDATA and `>` in attribute values do not count,
    // and a file nested within it reads.
    let p = dir.join("ok.vti");
    let text =
        nested_vti(40).replace("<PointData>", "<PointData><!-- <b><b><b> --><![CDATA[<c>]]>");
    std::fs::write(&p, text).unwrap();
    let v = formats::read(&p, Format::Vti, &opts()).unwrap();
    assert_eq!(v.values, (0..8).map(|v| v as f32).collect::<Vec<_>>());
}

/// 60,000 attributes on one element took roxmltree 4.8 s (300,000 over a minute: it checks
/// each against the ones before): 60,000 are refused by the scan before it, at once, naming
/// the element's place, the count and the limit; 256 still read.
#[test]
fn a_vti_element_with_too_many_attributes_is_refused_before_parsing() {
    let dir = scratch("rel-vti-attributes");
    let p = dir.join("crowded.vti");
    let crowded = |n: usize| {
        let attrs: Vec<String> = (0..n).map(|i| format!("a{i}=\"1\"")).collect();
        nested_vti(0).replace("<ImageData ", &format!("<ImageData {} ", attrs.join(" ")))
    };
    std::fs::write(&p, crowded(60_000)).unwrap();
    let started = std::time::Instant::now();
    let m = refusal(&p, &opts());
    assert!(started.elapsed().as_secs_f64() < 5.0, "{:?}", started.elapsed());
    assert!(m.contains("line 3, column 1: an element has 60001 attributes, over the 256"), "{m}");
    // ImageData's own WholeExtent makes 257 here: over by one.
    std::fs::write(&p, crowded(256)).unwrap();
    assert!(refusal(&p, &opts()).contains("has 257 attributes, over the 256"));
    std::fs::write(&p, crowded(255)).unwrap();
    assert_eq!(formats::read(&p, Format::Vti, &opts()).unwrap().dims, [2, 2, 2]);
}

/// A `.vti` of 2x2x2 ASCII samples whose `WholeExtent` (and piece `Extent`) is `extent`.
fn vti_with_extent(extent: &str) -> String {
    format!(
        "<VTKFile type=\"ImageData\" byte_order=\"LittleEndian\"><ImageData WholeExtent=\"{extent}\" \
         Origin=\"0 0 0\" Spacing=\"1 1 1\"><Piece Extent=\"{extent}\"><PointData Scalars=\"s\">\
         <DataArray type=\"Float32\" Name=\"s\" format=\"ascii\">0 1 2 3 4 5 6 7</DataArray>\
         </PointData></Piece></ImageData></VTKFile>"
    )
}

/// Extents past what an integer holds panicked in the reader ("attempt to add with
/// overflow" on `x1 - x0 + 1`, issue 29): each is one line naming the file and the number.
#[test]
fn vti_extents_beyond_an_int_are_refused() {
    let dir = scratch("rel-vti-extent");
    let p = dir.join("e.vti");
    for (extent, number) in [
        ("0 1e300 0 1 0 1", "1e300"),
        ("0 9223372036854775807 0 1 0 1", "9223372036854775807"),
        ("-9223372036854775808 9223372036854775807 0 1 0 1", "-9223372036854775808"),
        ("0 1 0 3e9 0 1", "3e9"),
        // Whole numbers past an int but within an i64: the cap's early check read them as
        // an extent ("needs 1525879 MiB") before the parse could say they are none.
        ("0 99999999999 0 1 0 1", "99999999999"),
        ("0 1 -3000000000 1 0 1", "-3000000000"),
        ("0 1.5 0 1 0 1", "1.5"),
    ] {
        std::fs::write(&p, vti_with_extent(extent)).unwrap();
        let m = refusal(&p, &opts());
        assert!(m.contains("WholeExtent") && m.contains("32-bit ints"), "{extent}: {m}");
        let shown: f64 = number.parse().unwrap();
        assert!(m.contains(&format!("WholeExtent: {} is not", shown_short(shown))), "{m}");
    }
    // The whole range of an int is an extent: refused only by the memory cap.
    std::fs::write(&p, vti_with_extent("-2147483648 2147483647 0 1 0 1")).unwrap();
    assert!(matches!(formats::read(&p, Format::Vti, &opts()), Err(FieldError::TooLarge { .. })));
    std::fs::write(&p, vti_with_extent("5 6 -1 0 0 1")).unwrap();
    let v = formats::read(&p, Format::Vti, &opts()).unwrap();
    assert_eq!(v.dims, [2, 2, 2]);
}

/// How the readers print a header number: `1e300`, `2147483648`.
fn shown_short(v: f64) -> String {
    if v.abs() >= 1e16 {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

#[test]
fn deeply_nested_npy_header_is_refused() {
    let dir = scratch("rel-npy");
    // npyz parses the header's Python literal by recursive descent.
    let nest = 200_000;
    let dict = format!(
        "{{'descr': '<f4', 'fortran_order': False, 'shape': (2, 2, 2), 'x': {}{}}}",
        "[".repeat(nest),
        "]".repeat(nest)
    );
    let mut header = dict.into_bytes();
    header.push(b'\n');
    let mut bytes = b"\x93NUMPY\x02\x00".to_vec();
    bytes.extend((header.len() as u32).to_le_bytes());
    bytes.extend(&header);
    bytes.extend([0u8; 32]);
    std::fs::write(dir.join("deep.npy"), &bytes).unwrap();
    let text = "[field]\nsource = \"npy\"\npath = \"deep.npy\"\n";
    let e = scene::from_str_with(text, "t.toml", &dir, &[], &GridLimits::default()).unwrap_err();
    let m = e.to_string();
    assert!(m.contains("deep.npy") && m.contains("nests brackets deeper than 16"), "{m}");
}

#[test]
fn a_file_that_shrinks_while_read_on_demand_is_one_line() {
    let dir = scratch("rel-shrink");
    let path = dir.join("v.raw");
    let dims = [20usize, 20, 20];
    let bytes: Vec<u8> = (0..8000).flat_map(|i| (i as f32).to_le_bytes()).collect();
    std::fs::write(&path, &bytes).unwrap();
    let text =
        "[field]\nsource = \"raw\"\npath = \"v.raw\"\ndims = [20, 20, 20]\ndtype = \"f32\"\n\
                residency = \"active\"\n";
    let s = scene::from_str_with(text, "t.toml", &dir, &[], &GridLimits::default()).unwrap();
    let grid = MappedGrid::open(&s.field).unwrap().unwrap();
    assert_eq!(grid.dims, dims);
    // Truncated by "another process" after it was opened and its size checked: a mapped read
    // of the lost pages died of SIGBUS (rc 135); the checked reads say what happened.
    std::fs::OpenOptions::new().write(true).open(&path).unwrap().set_len(1000).unwrap();
    let want = format!("{}: shrank to 1000 bytes while being read", path.display());
    let e = grid.brick_ranges(8).unwrap_err();
    assert_eq!(e.to_string(), want);
    assert!(matches!(e, FieldError::Shrank { len: Some(1000), .. }));
    assert_eq!(grid.read_box([0, 0, 10], [20, 20, 5]).unwrap_err().to_string(), want);
    // What is still there reads as before.
    assert_eq!(grid.read_box([0, 0, 0], [5, 2, 1]).unwrap()[5..], [20.0, 21.0, 22.0, 23.0, 24.0]);
}

/// A little-endian TIFF of `pages` 8-bit pages of `w` x `h`, whose strips point past the end
/// of the file: decoding any page fails, reading its header does not.
fn tiff_without_data(w: u32, h: u32, pages: u32) -> Vec<u8> {
    let mut b = b"II\x2a\x00\x08\x00\x00\x00".to_vec();
    let entries: [(u16, u16, u32); 8] = [
        (256, 4, w),       // ImageWidth
        (257, 4, h),       // ImageLength
        (258, 3, 8),       // BitsPerSample
        (259, 3, 1),       // Compression: none
        (262, 3, 1),       // PhotometricInterpretation: black is zero
        (273, 4, 1 << 30), // StripOffsets: far past the end
        (278, 4, h),       // RowsPerStrip
        (279, 4, w * h),   // StripByteCounts
    ];
    for page in 0..pages {
        let ifd_len = 2 + 12 * entries.len() as u32 + 4;
        b.extend((entries.len() as u16).to_le_bytes());
        for (tag, ty, value) in entries {
            b.extend(tag.to_le_bytes());
            b.extend(ty.to_le_bytes());
            b.extend(1u32.to_le_bytes());
            match ty {
                3 => b.extend((value as u16).to_le_bytes().iter().chain(&[0, 0])),
                _ => b.extend(value.to_le_bytes()),
            }
        }
        let next = if page + 1 < pages { b.len() as u32 + 4 } else { 0 };
        debug_assert_eq!(b.len() as u32 + 4, 8 + ifd_len * (page + 1));
        b.extend(next.to_le_bytes());
    }
    b
}

#[test]
fn a_tiff_stack_over_the_cap_is_refused_from_its_headers() {
    let dir = scratch("rel-tiff");
    // 3 pages of 1024^2: each page (4 MiB of f32) fits a 10 MiB cap, the stack (12 MiB) does
    // not. The pages were decoded one by one until the cap refused the next; now the page
    // headers are counted first, so not one page is decoded (here decoding would fail).
    let p = dir.join("stack.tif");
    std::fs::write(&p, tiff_without_data(1024, 1024, 3)).unwrap();
    let capped = ReadOptions {
        limits: GridLimits { max_bytes: 10 << 20 },
        spacing: None,
        access: DataAccess::Any,
        grid: None,
        has_bounds: false,
    };
    let m = refusal(&p, &capped);
    assert!(m.contains("a grid of 1024x1024x3 points needs 12 MiB"), "{m}");
    // Under the cap the same file gets as far as decoding, and says what is wrong there.
    let m = refusal(&p, &opts());
    assert!(!m.contains("over the cap"), "{m}");
}

#[test]
fn a_tiff_stack_over_the_cap_is_refused_with_its_page_count() {
    let dir = scratch("rel-tiff-count");
    // The case from the attack: 3 pages of 16384^2 under the default 1024 MiB cap. One page
    // fits exactly, two do not; the message must count all three, so that the cap it
    // suggests is one the stack fits under.
    let p = dir.join("stack.tif");
    std::fs::write(&p, tiff_without_data(16384, 16384, 3)).unwrap();
    let m = refusal(&p, &opts());
    assert!(m.contains("a grid of 16384x16384x3 points needs 3072 MiB"), "{m}");
    assert!(m.contains("ISOVIEW_MAX_GRID_MIB=3072 "), "{m}");
    // A chain of pages longer than isoview counts says the count is a floor.
    let many = formats::MAX_TIFF_PAGES_COUNTED as u32 + 5;
    std::fs::write(&p, tiff_without_data(1024, 1024, many)).unwrap();
    let capped =
        ReadOptions { limits: GridLimits { max_bytes: 10 << 20 }, spacing: None, ..opts() };
    let m = refusal(&p, &capped);
    let floor = format!("1024x1024x{} points", formats::MAX_TIFF_PAGES_COUNTED);
    assert!(
        m.contains(&floor)
            && m.ends_with("has more pages than that (isoview stopped counting them)"),
        "{m}"
    );
}

#[test]
fn header_geometry_must_be_finite_and_positive() {
    let dir = scratch("rel-geometry");
    let nrrd = |name: &str, field: &str| {
        let p = dir.join(name);
        let head = format!(
            "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n{field}\n\n"
        );
        std::fs::write(&p, [head.as_bytes(), &[0u8; 8]].concat()).unwrap();
        p
    };
    // `inf` was read as "unknown" (1), 1e308 put the box at infinity.
    let m = refusal(&nrrd("inf.nrrd", "spacings: 1 inf 1"), &opts());
    assert!(m.contains("line 6: spacings \"1 inf 1\": axis 1 spacing inf"), "{m}");
    let m = refusal(&nrrd("zero.nrrd", "spacings: 0 1 1"), &opts());
    assert!(m.contains("axis 0 spacing 0; a spacing must be a finite number over 0"), "{m}");
    let m =
        refusal(&nrrd("huge.nrrd", "spacings: 1e308 1e308 1e308\naxis mins: 1e308 0 0"), &opts());
    assert!(m.contains("spacings, axis mins: origin (1e308, 0, 0) and spacing (1e308"), "{m}");
    assert!(m.contains("box out of range"), "{m}");
    let m = refusal(
        &nrrd("dirs.nrrd", "space: RAS\nspace directions: (inf,0,0) (0,1,0) (0,0,1)"),
        &opts(),
    );
    assert!(m.contains("space directions: axis x steps by (inf, 0, 0)"), "{m}");
    let m = refusal(
        &nrrd(
            "origin.nrrd",
            "space: RAS\nspace directions: (1,0,0) (0,1,0) (0,0,1)\nspace origin: (nan,0,0)",
        ),
        &opts(),
    );
    assert!(m.contains("space origin (NaN, 0, 0) is not a finite point"), "{m}");
    // `nan` stays NRRD's "unknown": spacing 1.
    let v = formats::read(&nrrd("nan.nrrd", "spacings: nan 2 nan"), Format::Nrrd, &opts()).unwrap();
    assert_eq!(v.spacing, glam::DVec3::new(1.0, 2.0, 1.0));

    // MRC: a zero or NaN cell was read as spacing 1 without a word.
    let mrc = |name: &str, cell: [f32; 3]| {
        let mut h = vec![0u8; 1024];
        let mut word = |i: usize, v: [u8; 4]| h[4 * i..4 * i + 4].copy_from_slice(&v);
        for (i, c) in cell.iter().enumerate() {
            word(i, 2i32.to_le_bytes()); // NX, NY, NZ
            word(7 + i, 2i32.to_le_bytes()); // MX, MY, MZ
            word(10 + i, c.to_le_bytes()); // cell dimensions
            word(16 + i, (i as i32 + 1).to_le_bytes()); // MAPC, MAPR, MAPS
        }
        word(3, 2i32.to_le_bytes()); // mode 2, float32
        h[208..212].copy_from_slice(b"MAP ");
        h[212] = 0x44;
        h.extend([0u8; 32]);
        let p = dir.join(name);
        std::fs::write(&p, h).unwrap();
        p
    };
    let m = refusal(&mrc("zero.mrc", [0.0, 2.0, 2.0]), &opts());
    assert!(m.contains("cell dimensions (CELLA) 0 2 2 over MX, MY, MZ = 2 2 2: axis x"), "{m}");
    let m = refusal(&mrc("nan.mrc", [2.0, f32::NAN, 2.0]), &opts());
    assert!(m.contains("axis y has voxel size NaN"), "{m}");
    let v = formats::read(&mrc("ok.mrc", [3.0, 2.0, 2.0]), Format::Mrc, &opts()).unwrap();
    assert_eq!(v.spacing, glam::DVec3::new(1.5, 1.0, 1.0));

    // Legacy VTK and VTI name their own fields.
    let vtk = |name: &str, geometry: &str| {
        let p = dir.join(name);
        let text = format!(
            "# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\n\
             {geometry}\nPOINT_DATA 8\nSCALARS s float\nLOOKUP_TABLE default\n0 1 2 3 4 5 6 7\n"
        );
        std::fs::write(&p, text).unwrap();
        p
    };
    let m = refusal(&vtk("s.vtk", "SPACING 1 nan 1"), &opts());
    assert!(m.contains("SPACING 1 NaN 1: a spacing must be a finite number over 0"), "{m}");
    let m = refusal(&vtk("o.vtk", "ORIGIN 0 0 inf"), &opts());
    assert!(m.contains("ORIGIN (0, 0, inf) is not a finite point"), "{m}");
    let p = dir.join("s.vti");
    std::fs::write(&p, nested_vti(0).replace("WholeExtent=", "Spacing=\"1 1e400 1\" WholeExtent="))
        .unwrap();
    let m = refusal(&p, &opts());
    assert!(m.contains("Spacing (1, inf, 1): axis y spacing inf; a spacing must be"), "{m}");
}

#[test]
fn legacy_vtk_ascii_names_the_bad_token() {
    let dir = scratch("rel-vtk-ascii");
    let vtk = |name: &str, data: &str| {
        let p = dir.join(name);
        let text = format!(
            "# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\n\
             POINT_DATA 8\nSCALARS s float\nLOOKUP_TABLE default\n{data}\n"
        );
        std::fs::write(&p, text).unwrap();
        p
    };
    // Both were "truncated data: the ASCII data holds 3 of the 8 values".
    let m = refusal(&vtk("abc.vtk", "0 1 2 abc 4 5 6 7"), &opts());
    assert!(m.contains("ASCII value 3 is not a number: \"abc\""), "{m}");
    let v = formats::read(&vtk("nan.vtk", "0 1 2 nan 4 5 6 7"), Format::Vtk, &opts()).unwrap();
    assert!(v.values[3].is_nan() && v.values[7] == 7.0, "{:?}", v.values);
    // Real truncation and a following array are still told apart.
    let m = refusal(&vtk("short.vtk", "0 1 2"), &opts());
    assert!(m.contains("holds 3 of the 8 values"), "{m}");
    let v = formats::read(
        &vtk("next.vtk", "0 1 2 3 4 5 6 7\nSCALARS t float\nLOOKUP_TABLE default\n9 9 9 9 9 9 9 9"),
        Format::Vtk,
        &opts(),
    )
    .unwrap();
    assert_eq!(v.values[7], 7.0);
}

#[test]
fn residency_defaults_to_auto() {
    let dir = scratch("rel-auto");
    std::fs::write(dir.join("v.raw"), vec![0u8; 4 * 16 * 16 * 17]).unwrap();
    let text =
        "[field]\nsource = \"raw\"\npath = \"v.raw\"\ndims = [16, 16, 17]\ndtype = \"f32\"\n";
    // A 16 KiB cap: the grid (17 KiB) is over it. With "whole" the default, the scene was
    // refused until the user set "auto"; now it loads and renders from the brick pool.
    let cap = GridLimits { max_bytes: 16 << 10 };
    let s = scene::from_str_with(text, "t.toml", &dir, &[], &cap).unwrap();
    assert_eq!(s.field.residency, Residency::Auto);
    assert!(MappedGrid::for_residency(&s.field, &cap).unwrap().is_some());
    // A command that needs it whole (slice, probe, stats) says so, and which ones do not.
    let e = s.field.sample_with(0.0, &cap).unwrap_err().to_string();
    assert!(
        e.contains("over the cap of 16 KiB")
            && e.ends_with(
                "; this command needs the whole grid (the ray methods of `render` and `extract` \
                 read one over the cap in parts)"
            ),
        "{e}"
    );
    // Under the cap it is read whole, as before.
    assert!(MappedGrid::for_residency(&s.field, &GridLimits::default()).unwrap().is_none());
    // Asking for "whole" keeps today's refusal, with the hint.
    let whole = format!("{text}residency = \"whole\"\n");
    let e = scene::from_str_with(&whole, "t.toml", &dir, &[], &cap).unwrap_err().to_string();
    assert!(e.contains("over the cap") && e.contains("field.residency = \"auto\""), "{e}");
}

#[test]
fn a_grid_over_the_device_extent_names_its_key() {
    use glam::DVec3;
    use isoview::field::FieldSpec;
    use isoview::vocab::{Bounds, SdfShape};
    let unit = Bounds { min: DVec3::ZERO, max: DVec3::ONE };
    let sphere = |res| FieldSpec::sdf(SdfShape::Sphere { radius: 1.0 }, DVec3::ZERO, res, unit);
    assert_eq!(
        sphere([2, 4097, 2]).check_image_extent(4096).unwrap_err().to_string(),
        "field.resolution [2, 4097, 2]: 4097 points along y are over this device's limit of 4096 \
         per axis (its largest 3D image; `isoview info` shows it)"
    );
    assert!(sphere([4096, 4096, 2]).check_image_extent(4096).is_ok());
}

/// The render verb: exit 2 naming the key (it was exit 3, "a grid of ... points", from the
/// device's image limit).
#[gpu_test]
fn render_over_the_device_extent_exits_2_naming_the_key() {
    let max = gpu().info.max_image_dimension_3d;
    let dir = scratch("rel-extent");
    let scene = write(
        &dir,
        "wide.toml",
        &format!(
            "[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = 0.5\n\
             resolution = [{}, 2, 2]\n[image]\nwidth = 8\nheight = 8\n",
            max + 1
        ),
    );
    let out = dir.join("wide.exr").display().to_string();
    let o = isoview(&["render", &scene, "-o", &out], &[]);
    let limit = format!("limit of {max} per axis");
    assert_fails(&o, 2, &["field.resolution [", &limit]);
    assert!(!Path::new(&out).exists());
}

#[test]
fn a_mesh_render_of_a_grid_over_the_cap_says_which_paths_read_it() {
    let dir = scratch("rel-auto-mesh");
    std::fs::write(dir.join("v.raw"), vec![0u8; 4 * 16 * 16 * 17]).unwrap();
    let text =
        "[field]\nsource = \"raw\"\npath = \"v.raw\"\ndims = [16, 16, 17]\ndtype = \"f32\"\n\
                [render]\nmethod = \"mesh\"\n";
    let cap = GridLimits { max_bytes: 16 << 10 };
    let s = scene::from_str_with(text, "t.toml", &dir, &[], &cap).unwrap();
    let e = isoview::render::pool::mapped_for(&s, &cap).err().unwrap().to_string();
    assert!(
        e.contains("over the cap of 16 KiB") && e.contains("a ray method or `isoview extract`"),
        "{e}"
    );
    assert!(!e.contains("\"active\""), "the user set no residency: {e}");
}

/// VTI and legacy VTK are read whole (their header is text before binary data): the declared
/// dims are checked against the cap from the file's first bytes, before the rest is read or
/// parsed (here the rest is malformed, which used to be the error).
#[test]
fn whole_file_readers_check_the_declared_dims_first() {
    let dir = scratch("rel-peek");
    let small = ReadOptions {
        limits: GridLimits { max_bytes: 1 << 20 },
        spacing: None,
        access: DataAccess::Any,
        grid: None,
        has_bounds: false,
    };
    let p = dir.join("big.vti");
    let text = "<VTKFile type=\"ImageData\"><ImageData WholeExtent=\"0 999 0 999 0 999\">\
                <Piece><PointData><DataArray <<< not xml";
    std::fs::write(&p, text).unwrap();
    let m = refusal(&p, &small);
    assert!(m.contains("a grid of 1000x1000x1000 points needs 3815 MiB"), "{m}");
    let p = dir.join("big.vtk");
    let text = "# vtk DataFile Version 3.0\nt\nBINARY\nDATASET STRUCTURED_POINTS\n\
                DIMENSIONS 1000 1000 1000\nPOINT_DATA lots\n";
    std::fs::write(&p, text).unwrap();
    let m = refusal(&p, &small);
    assert!(m.contains("a grid of 1000x1000x1000 points needs 3815 MiB"), "{m}");
}

/// Under MPI each rank reads its block of a raw/npy file: the default residency ("auto") must
/// not turn a grid over the cap into the single-process brick pool, which MPI refuses (it did
/// once "auto" became the default: "field.residency = \"active\" is not available under MPI").
#[gpu_test]
#[cfg_attr(not(feature = "mpi"), ignore = "MPI test: build with --features mpi")]
fn mpi_renders_a_grid_over_the_cap_by_blocks_under_the_default_residency() {
    let dir = scratch("rel-mpi-auto");
    // 72^3 f32 samples: 1.4 MiB, over a 1 MiB cap.
    let n = 72usize;
    let values: Vec<u8> = (0..n * n * n)
        .flat_map(|i| {
            let p = [i % n, (i / n) % n, i / (n * n)].map(|c| c as f32 - 35.5);
            ((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 20.0).to_le_bytes()
        })
        .collect();
    std::fs::write(dir.join("ball.raw"), values).unwrap();
    let scene = write(
        &dir,
        "ball.toml",
        "[image]\nwidth = 24\nheight = 24\n[camera]\neye = [150, 120, 100]\ntarget = [35.5, 35.5, 35.5]\n\
         [field]\nsource = \"raw\"\npath = \"ball.raw\"\ndims = [72, 72, 72]\ndtype = \"f32\"\n",
    );
    let out = dir.join("ball.exr").display().to_string();
    let o =
        crate::common::mpirun(2, &["render", &scene, "-o", &out], &[("ISOVIEW_MAX_GRID_MIB", "1")]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(Path::new(&out).exists());
}

/// `extract --device gpu` on a grid over the device's 3D image extent: extracted on the CPU
/// with a note naming the key and the limit (it was exit 3, "a grid of ... points does not fit
/// the device's 3D images").
#[gpu_test]
fn extract_over_the_device_extent_falls_back_to_the_cpu() {
    let max = gpu().info.max_image_dimension_3d;
    let dir = scratch("rel-extract-extent");
    let scene = write(
        &dir,
        "wide.toml",
        &format!(
            "[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = 0.5\nresolution = [{}, 2, 2]\n",
            max + 1
        ),
    );
    let out = dir.join("wide.ply").display().to_string();
    let o = isoview(&["extract", &scene, "-o", &out, "--device", "gpu"], &[]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("note: extracted on the CPU (field.resolution ["), "{err}");
    assert!(err.contains(&format!("limit of {max} per axis")), "{err}");
    assert!(Path::new(&out).exists());
}

/// NRRD ASCII data is read a block at a time (the text may be many times the samples' size):
/// words cut by the 64 KiB block boundaries read whole, and the errors are the same.
#[test]
fn nrrd_ascii_data_streams_across_blocks() {
    let dir = scratch("rel-ascii-stream");
    let n = 40usize;
    let words: Vec<String> = (0..n * n * n).map(|i| format!("{}.25", i as f32 - 7.0)).collect();
    let head =
        format!("NRRD0004\ntype: float\ndimension: 3\nsizes: {n} {n} {n}\nencoding: ascii\n\n");
    let body = words.join(" \n,\t");
    assert!(body.len() > 4 * (1 << 16));
    let p = dir.join("a.nrrd");
    std::fs::write(&p, format!("{head}{body}\n")).unwrap();
    let v = formats::read(&p, Format::Nrrd, &opts()).unwrap();
    let want: Vec<f32> = words.iter().map(|w| w.parse::<f64>().unwrap() as f32).collect();
    assert_eq!(v.values, want);
    let bad = body.replacen("100.25", "1o0.25", 1);
    std::fs::write(&p, format!("{head}{bad}")).unwrap();
    assert!(refusal(&p, &opts()).contains("ASCII value 107 is not a number: \"1o0.25\""));
    std::fs::write(&p, format!("{head}{body} 1")).unwrap();
    assert!(refusal(&p, &opts()).contains("holds more than the 64000 values"));
}

/// Fifth attack pass: two refusals that said what was not so. A gzip stream that inflates
/// far past the samples its header declares (256 MiB of zeros behind `sizes: 4 4 4`, read
/// only to one byte past them) was "the file has 65" bytes, and a VTI block likewise
/// "inflates to 33 bytes, not 32"; ASCII data cut by the reader's bound (64 bytes a value)
/// was "truncated data: the ASCII data holds 0 of the 8 values" although the file holds them.
#[test]
fn refusals_of_overlong_data_say_what_was_read() {
    use std::io::Write;
    let dir = scratch("rel-overlong");
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    gz.write_all(&vec![0u8; 64 << 20]).unwrap();
    let stream = gz.finish().unwrap();
    let p = dir.join("bomb.nrrd");
    let mut nrrd =
        b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: gzip\n\n".to_vec();
    nrrd.extend(&stream);
    std::fs::write(&p, &nrrd).unwrap();
    let e = refusal(&p, &opts());
    assert!(e.contains("the compressed data holds more than the 64 bytes of samples"), "{e}");
    // The path holds the test's pid (once 21655): judge the words after it.
    let said = e.strip_prefix(&format!("{}: ", p.display())).expect(&e);
    assert!(!said.contains("65"), "{e}");

    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    z.write_all(&vec![0u8; 1 << 20]).unwrap();
    let block = z.finish().unwrap();
    let mut vti = b"<VTKFile type=\"ImageData\" byte_order=\"LittleEndian\" \
        compressor=\"vtkZLibDataCompressor\"><ImageData WholeExtent=\"0 1 0 1 0 1\" \
        Origin=\"0 0 0\" Spacing=\"1 1 1\"><Piece Extent=\"0 1 0 1 0 1\"><PointData \
        Scalars=\"s\"><DataArray type=\"Float32\" Name=\"s\" format=\"appended\" \
        offset=\"0\"/></PointData></Piece></ImageData><AppendedData encoding=\"raw\">_"
        .to_vec();
    vti.extend([1u32, 32, 32, block.len() as u32].iter().flat_map(|v| v.to_le_bytes()));
    vti.extend(&block);
    vti.extend(b"</AppendedData></VTKFile>");
    let p = dir.join("bomb.vti");
    std::fs::write(&p, vti).unwrap();
    let e = refusal(&p, &opts());
    assert!(e.contains("compressed block 0 inflates to more than its 32 bytes"), "{e}");

    let p = dir.join("spaced.nrrd");
    let head = "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nencoding: ascii\n\n";
    std::fs::write(&p, format!("{head}{}1 2 3 4 5 6 7 8\n", " ".repeat(1 << 16))).unwrap();
    let e = refusal(&p, &opts());
    assert!(e.contains("the ASCII data takes more than 4608 bytes before its 8 values end"), "{e}");
    assert!(!e.contains("truncated"), "{e}");
}

/// `serve` judges a page's data path when the state is loaded (links resolved) and reads a raw
/// or npy grid when it is sampled, later and again: a folder on the admitted path swapped for
/// a link out in between (by anyone who can write in an allowed folder) led the read out of
/// the allowed folders. The file opened is judged again by its own path; the command line
/// (any file) still follows the link.
#[test]
fn a_folder_swapped_for_a_link_after_the_check_is_not_read() {
    let dir = scratch("rel-swap-after-admit");
    for sub in ["scene/sub", "outside"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
    }
    std::fs::write(dir.join("scene/sub/v.raw"), [0u8, 10, 20, 30, 40, 50, 60, 70]).unwrap();
    std::fs::write(dir.join("outside/v.raw"), b"SECRET!!").unwrap();
    let mut npy = b"\x93NUMPY\x01\x00".to_vec();
    let dict = "{'descr': '|u1', 'fortran_order': False, 'shape': (2, 2, 2), }";
    let header = format!("{dict:<117}\n");
    npy.extend((header.len() as u16).to_le_bytes());
    npy.extend(header.as_bytes());
    std::fs::write(dir.join("scene/sub/v.npy"), [&npy[..], &[1u8; 8]].concat()).unwrap();
    std::fs::write(dir.join("outside/v.npy"), [&npy[..], b"SECRET!!"].concat()).unwrap();
    let scene_path = dir.join("scene/s.toml");
    let raw = "[field]\nsource = \"raw\"\npath = \"sub/v.raw\"\ndims = [2, 2, 2]\ndtype = \"u8\"\n";
    let npy = "[field]\nsource = \"npy\"\npath = \"sub/v.npy\"\n";
    let access = DataAccess::within([dir.join("scene")]).unwrap();
    let mut loaded = Vec::new();
    for (text, residency) in [(raw, "whole"), (raw, "active"), (npy, "whole"), (npy, "active")] {
        let what = format!("{} {residency}", if text == raw { "raw" } else { "npy" });
        std::fs::write(&scene_path, format!("{text}residency = \"{residency}\"\n")).unwrap();
        let confined = scene::load_confined(&scene_path, &[], &access).unwrap();
        let anywhere = scene::load_confined(&scene_path, &[], &DataAccess::Any).unwrap();
        assert!(confined.field.sample(0.0).is_ok(), "{what}: read before the swap");
        loaded.push((what, residency, confined, anywhere));
    }
    std::fs::rename(dir.join("scene/sub"), dir.join("scene/old")).unwrap();
    std::os::unix::fs::symlink(dir.join("outside"), dir.join("scene/sub")).unwrap();
    for (what, residency, confined, anywhere) in &loaded {
        let e = match confined.field.sample(0.0) {
            Ok(g) => panic!("{what}: read outside after the swap: {:?}", g.values),
            Err(e) => e.to_string(),
        };
        assert!(e.contains("outside the folders isoview serve may read"), "{what}: {e}");
        assert!(e.contains("replaced by a link") && !e.contains("SECRET"), "{what}: {e}");
        if *residency == "active" {
            let opened = MappedGrid::open(&confined.field).map(|g| g.is_some());
            assert!(opened.is_err(), "{what}: mapped outside after the swap");
        }
        let read = anywhere.field.sample(0.0).unwrap();
        assert_eq!(read.values[0], b'S' as f32, "{what}: the command line follows the link");
    }
}

/// An MRC map whose cell (3e38 Å per voxel, start indices 2^31 - 1) puts its 2x2x2 grid at
/// 6.4e47: the reader's own checks pass (every corner is finite), and rays in f32 cannot
/// reach it. The box from the header, and one from `field.bounds`, must be within the
/// camera's ±1e30, naming what set it; a box at exactly ±1e30 is still taken.
#[test]
fn a_grid_box_beyond_the_traced_range_is_refused_naming_what_set_it() {
    let dir = scratch("rel-box-range");
    let mut h = vec![0u8; 1024];
    let mut word = |i: usize, v: [u8; 4]| h[4 * i..4 * i + 4].copy_from_slice(&v);
    for i in 0..3 {
        word(i, 2i32.to_le_bytes()); // NX, NY, NZ
        word(4 + i, i32::MAX.to_le_bytes()); // NXSTART, NYSTART, NZSTART
        word(7 + i, 1i32.to_le_bytes()); // MX, MY, MZ
        word(10 + i, 3e38f32.to_le_bytes()); // cell dimensions
        word(13 + i, 90f32.to_le_bytes()); // cell angles
        word(16 + i, (i as i32 + 1).to_le_bytes()); // MAPC, MAPR, MAPS
    }
    word(3, 2i32.to_le_bytes()); // mode 2, float32
    h[208..212].copy_from_slice(b"MAP ");
    h[212] = 0x44;
    h.extend([0u8; 32]);
    std::fs::write(dir.join("o.mrc"), h).unwrap();
    let scene = write(
        &dir,
        "o.toml",
        "[image]\nwidth = 16\nheight = 16\n[camera]\nfit = true\n[field]\nsource = \"file\"\n\
         path = \"o.mrc\"\n",
    );
    for verb in [vec!["stats", &scene], vec!["render", &scene, "-o", "o.exr"]] {
        let o = isoview(&verb, &[]);
        assert_fails(
            &o,
            2,
            &[
                "o.toml:8:8: field.path: ",
                "o.mrc: MRC: ORIGIN, cell dimensions and MX, MY, MZ: the grid box from its \
                 header, [6.44245095280634e47",
                "is too large: every coordinate must be within ±1e30 (rays are traced in 32-bit \
                 floats)",
            ],
        );
    }
    assert!(!dir.join("o.exr").exists());

    let expr = |bounds: &str| {
        let text = format!(
            "[field]\nsource = \"expr\"\nexpression = \"x\"\nresolution = [2, 2, 2]\n\
             bounds = {bounds}\n"
        );
        write(&dir, "b.toml", &text)
    };
    let o = isoview(&["stats", &expr("{ min = [-1e35, 0, 0], max = [1e35, 1, 1] }")], &[]);
    assert_fails(
        &o,
        2,
        &["b.toml:5:10: field.bounds: the grid box [-1e35, 0.0, 0.0]..[1e35, 1.0, 1.0] is too \
           large: every coordinate must be within ±1e30"],
    );
    let o = isoview(&["stats", &expr("{ min = [-1e30, 0, 0], max = [1e30, 1, 1] }")], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// A finite f64 sample beyond f32's range became ±inf in the grid without a word, and
/// `field.nan = "empty"` (the default) then took it for missing data: it is refused, naming
/// its grid point, under either policy; 3e38 is kept, and an infinity in the file is still
/// missing data.
#[test]
fn a_finite_sample_beyond_f32_is_refused_not_taken_for_missing_data() {
    let dir = scratch("rel-sample-range");
    for nan in ["empty", "error"] {
        let scene = write(
            &dir,
            "c.toml",
            &format!(
                "[field]\nsource = \"corners\"\nvalues = [0, 0, 0, 0, 0, 0, 0, 1e308]\n\
                 nan = \"{nan}\"\n"
            ),
        );
        let o = isoview(&["stats", &scene], &[]);
        assert_fails(
            &o,
            2,
            &["field.values: value 1e308 at grid point [1, 1, 1] is beyond ±3.4028235e38, the \
               range of the 32-bit floats samples are kept in"],
        );
    }
    // Raw f64, x fastest: sample 3 is point [1, 1, 0].
    let raw = |values: [f64; 8]| {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        std::fs::write(dir.join("d.raw"), bytes).unwrap();
        let text =
            "[field]\nsource = \"raw\"\npath = \"d.raw\"\ndims = [2, 2, 2]\ndtype = \"f64\"\n";
        isoview(&["stats", &write(&dir, "d.toml", text)], &[])
    };
    let o = raw([0.0, 0.0, 0.0, -1e300, 0.0, 0.0, 0.0, 0.0]);
    assert_fails(&o, 2, &["d.raw: value -1e300 at grid point [1, 1, 0] is beyond ±3.4028235e38"]);
    let o = raw([0.0, 0.0, 0.0, 3e38, 0.0, 0.0, 0.0, f64::INFINITY]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // A C-order npy: storage index 1 is element [0, 0, 1].
    let mut npy = b"\x93NUMPY\x01\x00".to_vec();
    let mut header = "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 2, 2), }".to_string();
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    npy.extend((header.len() as u16).to_le_bytes());
    npy.extend(header.as_bytes());
    for v in [0.0, 5e38, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0f64] {
        npy.extend(v.to_le_bytes());
    }
    std::fs::write(dir.join("c.npy"), npy).unwrap();
    let o = isoview(
        &["stats", &write(&dir, "n.toml", "[field]\nsource = \"npy\"\npath = \"c.npy\"\n")],
        &[],
    );
    assert_fails(&o, 2, &["c.npy: value 5e38 at grid point [0, 0, 1] is beyond ±3.4028235e38"]);
}

/// A compressed MetaImage whose HeaderSize skips past the file's end said only "cannot
/// read: Invalid argument (os error 22)" (the seek failed): the line names the file, the
/// header line and the key.
#[test]
fn a_metaimage_header_size_past_the_end_names_the_key() {
    let dir = scratch("rel-mha-header-size");
    let p = dir.join("m.mha");
    let head = b"NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nCompressedData = True\n\
        HeaderSize = 9223372036854775807\nElementDataFile = LOCAL\n";
    let mut bytes = head.to_vec();
    // zlib's stored block of 8 zero bytes, so the data itself is valid.
    bytes.extend([0x78, 0x01, 0x01, 0x08, 0x00, 0xf7, 0xff]);
    bytes.extend([0u8; 8]);
    bytes.extend([0x00, 0x08, 0x00, 0x01]);
    std::fs::write(&p, &bytes).unwrap();
    let m = refusal(&p, &opts());
    let start = head.len() as u64 + i64::MAX as u64;
    let want = format!(
        "MetaImage: line 5: HeaderSize = 9223372036854775807 puts the data at byte {start} of \
         the file, past its end ({} bytes)",
        bytes.len()
    );
    assert!(m.contains(&want), "{m}");
    // Uncompressed, the same key is named rather than "truncated data".
    let text = b"NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nHeaderSize = 100\n\
        ElementDataFile = LOCAL\n";
    std::fs::write(&p, [&text[..], &[0u8; 8]].concat()).unwrap();
    let m = refusal(&p, &opts());
    assert!(m.contains("line 4: HeaderSize = 100 puts the data at byte"), "{m}");
}

/// A grid cap raised past the machine's memory let the samples' allocation fail, which aborts
/// the process (exit 134, `memory allocation of ... failed`, the attack pass's F2): the grid is
/// refused with one line naming the machine's memory, every verb that samples it.
#[test]
fn a_grid_over_the_machine_s_memory_is_refused_whatever_the_cap() {
    let dir = crate::common::scratch("over-memory");
    let scene = crate::common::write(
        &dir,
        "s.toml",
        "[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = 0.5\nresolution = [8, 8, 8]\n",
    );
    let out = dir.join("o.ply").display().to_string();
    let huge = "field.resolution=[1000000,1000000,1000000]";
    for args in [vec!["extract", &scene, "-o", &out], vec!["stats", &scene]] {
        let mut a = args.clone();
        a.extend(["--set", huge]);
        let o = crate::common::isoview(&a, &[("ISOVIEW_MAX_GRID_MIB", "4000000000000")]);
        crate::common::assert_fails(&o, 2, &["field.resolution", "more than this machine's"]);
    }
    assert!(!std::path::Path::new(&out).exists());
}
