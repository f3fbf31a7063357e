//! Scene files: defaults, every error class (one line, `file:line:col: key: what`), `--set`
//! overrides, and the scenes shipped in `scenes/`.

use std::path::{Path, PathBuf};

use glam::DVec3;
use isoview::field::{FieldSource, GridLimits};
use isoview::scene::{self, *};

/// Loads `text` as `t.toml` with `overrides`.
fn parse(text: &str, overrides: &[&str]) -> Result<Scene, SceneError> {
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    scene::from_str_with(text, "t.toml", Path::new("."), &overrides, &GridLimits::default())
}

/// The error `text` (with `overrides`) gives, checked to be one line.
fn error(text: &str, overrides: &[&str]) -> String {
    match parse(text, overrides) {
        Ok(_) => panic!("expected an error for:\n{text}\nwith {overrides:?}"),
        Err(e) => {
            let s = e.to_string();
            assert!(!s.contains('\n') && !s.contains('\r'), "not one line: {s:?}");
            s
        }
    }
}

const CELL: &str = "[field]\nsource = \"corners\"\nvalues = [-1, 1, 1, 1, 1, 1, 1, 1]\n";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

// ---- defaults ---------------------------------------------------------------------------------

#[test]
fn absent_keys_take_the_contract_defaults() {
    let s = parse(CELL, &[]).unwrap();
    assert_eq!(s.path, None);
    assert_eq!((s.image.width, s.image.height), (512, 512));
    assert_eq!(s.camera.eye, DVec3::new(2.2, 1.6, 2.4));
    assert_eq!(s.camera.target, DVec3::ZERO);
    assert_eq!(s.camera.up, DVec3::Y);
    assert_eq!(s.camera.fov_y_deg, 40.0);
    assert_eq!(s.surface.isovalue, 0.0);
    assert_eq!(s.surface.inside, Inside::Below);
    assert_eq!(s.render.method, Method::Analytic);
    assert_eq!(s.render.steps, 200);
    assert_eq!(s.render.newton_steps, 10);
    assert_eq!(s.render.mesh, MeshAlgorithm::MarchingCubes);
    assert_eq!(s.render.shading, Shading::Lambert);
    assert_eq!(s.render.background, [0.0, 0.0, 0.0, 0.0]);
    assert_eq!(s.render.color, [0.85, 0.65, 0.45]);
    // corners: one cell over the unit cube.
    assert_eq!(s.field.resolution, [2, 2, 2]);
    assert_eq!(s.field.bounds, Bounds::UNIT);
    assert_eq!(s.image, ImageSettings::default());
    assert_eq!(s.camera, CameraSettings::default());
    assert_eq!(s.surface, SurfaceSettings::default());
    assert_eq!(s.render, RenderSettings::default());
}

#[test]
fn bounds_default_to_the_index_space() {
    let s = parse(
        "[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = 2\nresolution = [5, 6, 7]",
        &[],
    )
    .unwrap();
    assert_eq!(s.field.bounds.min, DVec3::ZERO);
    assert_eq!(s.field.bounds.max, DVec3::new(4.0, 5.0, 6.0));
    let FieldSource::Sdf { shape, center } = s.field.source else { panic!() };
    assert_eq!(shape, SdfShape::Sphere { radius: 2.0 });
    assert_eq!(center, DVec3::ZERO);
}

#[test]
fn every_key_is_read() {
    let text = r#"
[image]
width = 320
height = 200
[camera]
eye = [1, 2, 3]
target = [0.5, 0.25, 0]
up = [0, 0, 1]
fov_y_deg = 55.5
[field]
source = "expr"
expression = "x*x + y*y + z*z - 0.5"
resolution = [10, 11, 12]
[field.bounds]
min = [-1, -2, -3]
max = [1, 2, 3.5]
[surface]
isovalue = 0.25
inside = "above"
[render]
method = "mesh"
steps = 64
newton_steps = 0
mesh = "surface-nets"
shading = "cells"
background = [0.1, 0.2, 0.3, 1]
color = [1, 0.5, 0]
"#;
    let s = parse(text, &[]).unwrap();
    assert_eq!((s.image.width, s.image.height), (320, 200));
    assert_eq!(s.camera.eye, DVec3::new(1.0, 2.0, 3.0));
    assert_eq!(s.camera.target, DVec3::new(0.5, 0.25, 0.0));
    assert_eq!(s.camera.up, DVec3::Z);
    assert_eq!(s.camera.fov_y_deg, 55.5);
    assert_eq!(s.field.resolution, [10, 11, 12]);
    assert_eq!(s.field.bounds.min, DVec3::new(-1.0, -2.0, -3.0));
    assert_eq!(s.field.bounds.max, DVec3::new(1.0, 2.0, 3.5));
    assert_eq!(
        s.surface,
        SurfaceSettings {
            isovalue: 0.25,
            inside: Inside::Above,
            rule: IsoRule::Value,
            ..Default::default()
        }
    );
    let r = s.render;
    assert_eq!((r.method, r.steps, r.newton_steps), (Method::Mesh, 64, 0));
    assert_eq!((r.mesh, r.shading), (MeshAlgorithm::SurfaceNets, Shading::Cells));
    assert_eq!(r.background, [0.1, 0.2, 0.3, 1.0]);
    assert_eq!(r.color, [1.0, 0.5, 0.0]);
    for (name, m) in
        [("analytic", Method::Analytic), ("fixed-step", Method::FixedStep), ("mesh", Method::Mesh)]
    {
        assert_eq!(parse(CELL, &[&format!("render.method=\"{name}\"")]).unwrap().render.method, m);
    }
    for m in MeshAlgorithm::ALL {
        assert_eq!(parse(CELL, &[&format!("render.mesh={}", m.name())]).unwrap().render.mesh, m);
    }
    for sh in Shading::ALL {
        assert_eq!(
            parse(CELL, &[&format!("render.shading={}", sh.name())]).unwrap().render.shading,
            sh
        );
    }
}

// ---- malformed TOML, unknown keys, types ------------------------------------------------------

#[test]
fn malformed_toml_names_line_and_column() {
    let e = error("[image]\nwidth = \n", &[]);
    assert!(e.starts_with("t.toml:2:9: invalid TOML: "), "{e}");
    let e = error(&format!("{CELL}[render]\nsteps = 3\nsteps = 4\n"), &[]);
    assert_eq!(e, "t.toml:6:1: invalid TOML: duplicate key");
    let e = error("[camera]\neye = [1, 2,\n", &[]);
    assert!(e.starts_with("t.toml:2:13: invalid TOML: unclosed array"), "{e}");
}

#[test]
fn unknown_keys_are_errors_naming_key_and_line() {
    let e = error(&format!("{CELL}[render]\nmethod = \"analytic\"\nstepz = 3\n"), &[]);
    assert_eq!(e, "t.toml:6:1: render.stepz: unknown key (did you mean \"steps\"?)");
    let e = error(&format!("{CELL}[camera]\nposition = [1, 2, 3]\n"), &[]);
    assert_eq!(
        e,
        "t.toml:5:1: camera.position: unknown key ([camera] has eye, target, up, fov_y_deg, \
         projection, ortho_height, fit)"
    );
    let e = error(&format!("[imag]\nwidth = 4\n{CELL}"), &[]);
    assert_eq!(e, "t.toml:1:2: imag: unknown table or key (did you mean \"image\"?)");
    let e = error(&format!("{CELL}colour = 3\n"), &[]);
    assert_eq!(
        e,
        "t.toml:4:1: field.colour: unknown key ([field] has source, bounds, nan, interpolation, values)"
    );
    let e = error("[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradus = 1\n", &[]);
    assert_eq!(e, "t.toml:4:1: field.radus: unknown key (did you mean \"radius\"?)");
    let e = error("[field]\nradius = 1\nvalue = 3\n", &[]);
    assert_eq!(e, "t.toml:3:1: field.value: unknown key (did you mean \"values\"?)");
    let e =
        error(&format!("{CELL}bounds = {{ min = [0, 0, 0], max = [1, 1, 1], center = 3 }}\n"), &[]);
    assert_eq!(e, "t.toml:4:46: field.bounds.center: unknown key ([field.bounds] has min, max)");
    // Dotted keys inside a table are keys of that table.
    let e = error(&format!("{CELL}[surface]\ninside.x = 1\n"), &[]);
    assert!(e.starts_with("t.toml:5:1: surface.inside: expected one of"), "{e}");
}

#[test]
fn keys_of_other_sources_and_shapes_are_errors() {
    let sdf = "[field]\nsource = \"sdf\"\nshape = \"torus\"\nmajor_radius = 0.6\nminor_radius = 0.2\nresolution = [8, 8, 8]\n";
    let e = error(&format!("{sdf}path = \"x.npy\"\n"), &[]);
    assert_eq!(
        e,
        "t.toml:7:1: field.path: not a key of source \"sdf\" (it belongs to \"npy\", \"raw\", \"mesh\", \"file\"; \"sdf\" \
         takes source, bounds, nan, interpolation, shape, center, resolution, radius, half_extents, major_radius, \
         minor_radius, scale, thickness)"
    );
    let e = error(&format!("{sdf}radius = 0.5\n"), &[]);
    assert_eq!(e, "t.toml:7:1: field.radius: not a parameter of shape \"torus\" (torus takes major_radius, minor_radius)");
    let e = error(&format!("{CELL}resolution = [2, 2, 2]\n"), &[]);
    assert!(e.starts_with("t.toml:4:1: field.resolution: not a key of source \"corners\" (it belongs to \"sdf\", \"expr\""), "{e}");
    let e = error("[field]\nsource = \"npy\"\npath = \"a.npy\"\ndims = [2, 2, 2]\n", &[]);
    assert!(
        e.starts_with(
            "t.toml:4:1: field.dims: not a key of source \"npy\" (it belongs to \"raw\";"
        ),
        "{e}"
    );
}

#[test]
fn wrong_types_say_what_was_expected_and_found() {
    let e = error(&format!("{CELL}[image]\nwidth = \"512\"\n"), &[]);
    assert_eq!(e, "t.toml:5:9: image.width: expected an integer, got a string \"512\"");
    let e = error(&format!("{CELL}[image]\nwidth = 512.0\n"), &[]);
    assert_eq!(e, "t.toml:5:9: image.width: expected an integer, got a float 512.0");
    let e = error(&format!("{CELL}[camera]\neye = [1, 2]\n"), &[]);
    assert_eq!(e, "t.toml:5:7: camera.eye: expected an array of 3 numbers, got 2 ([1, 2])");
    let e = error(&format!("{CELL}[camera]\neye = [1, \"2\", 3]\n"), &[]);
    assert_eq!(e, "t.toml:5:11: camera.eye: expected a number at index 1, got a string \"2\"");
    let e = error(&format!("{CELL}[camera]\neye = 3\n"), &[]);
    assert_eq!(e, "t.toml:5:7: camera.eye: expected an array of 3 numbers, got an integer 3");
    let e = error(&format!("{CELL}camera = 3\n"), &[]);
    assert_eq!(
        e,
        "t.toml:4:1: field.camera: unknown key ([field] has source, bounds, nan, interpolation, values)"
    );
    let e = error(&format!("camera = 3\n{CELL}"), &[]);
    assert_eq!(e, "t.toml:1:10: camera: expected a table, got an integer 3");
    let e = error(&format!("{CELL}[render]\nmethod = \"fixed_step\"\n"), &[]);
    assert_eq!(
        e,
        "t.toml:5:10: render.method: unknown value \"fixed_step\" (expected \"analytic\", \
         \"fixed-step\" or \"mesh\"); did you mean \"fixed-step\"?"
    );
    let e = error(&format!("{CELL}[render]\nmethod = 1\n"), &[]);
    assert_eq!(e, "t.toml:5:10: render.method: expected one of \"analytic\", \"fixed-step\" or \"mesh\", got an integer 1");
    let e = error(&format!("{CELL}[surface]\ninside = \"outside\"\n"), &[]);
    assert_eq!(
        e,
        "t.toml:5:10: surface.inside: unknown value \"outside\" (expected \"below\" or \"above\")"
    );
    let e = error("[field]\nsource = \"corners\"\nvalues = [1, 2, 3]\n", &[]);
    assert_eq!(e, "t.toml:3:10: field.values: expected an array of 8 numbers, got 3 ([1, 2, 3])");
    let e = error(&format!("{CELL}[image]\nwidth = 99999999999999999999\n"), &[]);
    assert_eq!(e, "t.toml:5:9: image.width: integer 99999999999999999999 is out of range");
}

// ---- ranges -----------------------------------------------------------------------------------

#[test]
fn out_of_range_values_are_errors() {
    let cases: &[(&str, &str)] = &[
        ("[image]\nwidth = 0", "t.toml:5:9: image.width: must be at least 1, got 0"),
        ("[image]\nheight = 16385", "t.toml:5:10: image.height: must be at most 16384, got 16385"),
        ("[camera]\nfov_y_deg = 0", "t.toml:5:13: camera.fov_y_deg: must be between 0 and 180 degrees (exclusive), got 0"),
        ("[camera]\nfov_y_deg = 180.0", "t.toml:5:13: camera.fov_y_deg: must be between 0 and 180 degrees (exclusive), got 180.0"),
        ("[render]\nsteps = 1", "t.toml:5:9: render.steps: must be at least 2, got 1"),
        ("[render]\nnewton_steps = -1", "t.toml:5:16: render.newton_steps: must be at least 0, got -1"),
        ("[render]\nnewton_steps = 65", "t.toml:5:16: render.newton_steps: must be at most 64, got 65"),
        ("[surface]\nisovalue = nan", "t.toml:5:12: surface.isovalue: must be a finite number, got nan"),
        ("[surface]\nisovalue = -inf", "t.toml:5:12: surface.isovalue: must be a finite number, got -inf"),
        ("[camera]\neye = [1, inf, 2]", "t.toml:5:11: camera.eye: every number must be finite, got inf at index 1"),
        ("[render]\ncolor = [1, nan, 0]", "t.toml:5:13: render.color: every number must be finite, got nan at index 1"),
        ("[render]\nbackground = [0, 0, 0]", "t.toml:5:14: render.background: expected an array of 4 numbers, got 3 ([0, 0, 0])"),
        ("[render]\ncolor = [1e39, 0, 0]", "t.toml:5:9: render.color: colour components must fit a 32-bit float, got [1e39, 0, 0]"),
    ];
    for (extra, want) in cases {
        assert_eq!(&error(&format!("{CELL}{extra}\n"), &[]), want);
    }
}

#[test]
fn camera_must_have_a_direction_and_a_usable_up() {
    let e = error(&format!("{CELL}[camera]\neye = [1, 1, 1]\ntarget = [1, 1, 1]\n"), &[]);
    assert_eq!(
        e,
        "t.toml:6:10: camera.target: camera.eye and camera.target are the same point [1.0, 1.0, 1.0]; \
         the camera needs a direction"
    );
    let e = error(&format!("{CELL}[camera]\neye = [0, 3, 0]\n"), &[]);
    assert_eq!(
        e,
        "t.toml:5:7: camera.eye: camera.up [0.0, 1.0, 0.0] is parallel to the view direction \
         [0.0, -3.0, 0.0] (target - eye); pick an up vector across the view"
    );
    let e = error(&format!("{CELL}[camera]\nup = [0, 0, 0]\n"), &[]);
    assert_eq!(e, "t.toml:5:6: camera.up: must not be the zero vector");
    let e = error(&format!("{CELL}[camera]\neye = [2, 2, 2]\nup = [-1, -1, -1]\n"), &[]);
    assert!(
        e.starts_with("t.toml:6:6: camera.up: camera.up [-1.0, -1.0, -1.0] is parallel"),
        "{e}"
    );
}

#[test]
fn grid_errors_name_the_resolution_or_bounds() {
    let sdf = "[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = 0.5\n";
    let e = error(&format!("{sdf}\n\n\n\n\n\n\nresolution = [1, 48, 48]\n"), &[]);
    assert_eq!(
        e,
        "t.toml:12:14: field.resolution: every axis needs at least 2 points, got [1, 48, 48]"
    );
    let e = error(&format!("{sdf}resolution = [4, 4.5, 4]\n"), &[]);
    assert_eq!(e, "t.toml:5:18: field.resolution: expected an integer at index 1, got a float 4.5");
    let e = error(&format!("{sdf}resolution = [4, 4]\n"), &[]);
    assert_eq!(e, "t.toml:5:14: field.resolution: expected an array of 3 integers, got 2 ([4, 4])");
    let e = error(sdf, &[]);
    assert_eq!(
        e,
        "t.toml:1:1: field.resolution: missing (grid points along x, y, z, e.g. [48, 48, 48])"
    );
    let e = error(
        &format!("{sdf}resolution = [4, 4, 4]\nbounds = {{ min = [0, 0, 1], max = [1, 1, 1] }}\n"),
        &[],
    );
    assert_eq!(
        e,
        "t.toml:6:10: field.bounds: min must be below max on every axis, got min = [0.0, 0.0, 1.0], \
         max = [1.0, 1.0, 1.0] (z axis)"
    );
    let e = error(&format!("{sdf}resolution = [4, 4, 4]\n[field.bounds]\nmin = [0, 0, 0]\n"), &[]);
    assert_eq!(e, "t.toml:6:1: field.bounds.max: missing (the grid box's corner [x, y, z])");
    let e = error(&format!("{sdf}resolution = [4, 4, 4]\nbounds = [0, 1]\n"), &[]);
    assert_eq!(e, "t.toml:6:10: field.bounds: expected a table, got an array [0, 1]");
}

#[test]
fn field_table_source_and_shape_are_checked() {
    let e = error("[image]\nwidth = 8\n", &[]);
    assert_eq!(
        e,
        "t.toml:1:1: field: missing table; add [field] with source = \"sdf\", \"corners\", \"npy\", \"raw\", \"expr\", \"mesh\" or \"file\""
    );
    let e = error("[field]\nvalues = [1, 2, 3, 4, 5, 6, 7, 8]\n", &[]);
    assert_eq!(e, "t.toml:1:1: field.source: missing (one of \"sdf\", \"corners\", \"npy\", \"raw\", \"expr\", \"mesh\", \"file\")");
    let e = error("[field]\nsource = \"volume\"\n", &[]);
    assert!(
        e.starts_with("t.toml:2:10: field.source: unknown value \"volume\" (expected \"sdf\""),
        "{e}"
    );
    let e = error("[field]\nsource = \"sdf\"\nresolution = [4, 4, 4]\n", &[]);
    assert_eq!(
        e,
        "t.toml:1:1: field.shape: missing (\"sphere\", \"box\", \"torus\" or \"gyroid\")"
    );
    let e = error("[field]\nsource = \"sdf\"\nshape = \"cone\"\nresolution = [4, 4, 4]\n", &[]);
    assert!(e.starts_with("t.toml:3:9: field.shape: unknown value \"cone\""), "{e}");
    let e = error(
        "[field]\nsource = \"sdf\"\nshape = \"torus\"\nmajor_radius = 1\nresolution = [4, 4, 4]\n",
        &[],
    );
    assert_eq!(e, "t.toml:1:1: field.minor_radius: missing (shape \"torus\" needs minor_radius)");
    let e = error(
        "[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = -1\nresolution = [4, 4, 4]\n",
        &[],
    );
    assert_eq!(e, "t.toml:4:10: field.radius: must be positive, got -1");
    let e = error("[field]\nsource = \"sdf\"\nshape = \"box\"\nhalf_extents = [1, 0, 1]\nresolution = [4, 4, 4]\n", &[]);
    assert_eq!(
        e,
        "t.toml:4:16: field.half_extents: every half extent must be positive, got [1.0, 0.0, 1.0]"
    );
    let e = error("[field]\nsource = \"sdf\"\nshape = \"gyroid\"\nscale = 3\nthickness = -0.1\nresolution = [4, 4, 4]\n", &[]);
    assert_eq!(e, "t.toml:5:13: field.thickness: must not be negative, got -0.1");
    let e = error("[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = 1\ncenter = [0, 0]\nresolution = [4, 4, 4]\n", &[]);
    assert_eq!(e, "t.toml:5:10: field.center: expected an array of 3 numbers, got 2 ([0, 0])");
}

#[test]
fn sdf_shapes_and_centre_are_read() {
    let base = "[field]\nsource = \"sdf\"\nresolution = [4, 4, 4]\n";
    let shape = |extra: &str| {
        let s = parse(&format!("{base}{extra}"), &[]).unwrap();
        let FieldSource::Sdf { shape, center } = s.field.source else { panic!() };
        (shape, center)
    };
    assert_eq!(shape("shape = \"sphere\"\nradius = 0.5").0, SdfShape::Sphere { radius: 0.5 });
    assert_eq!(
        shape("shape = \"box\"\nhalf_extents = [0.5, 0.25, 1]").0,
        SdfShape::Box { half_extents: DVec3::new(0.5, 0.25, 1.0) }
    );
    assert_eq!(
        shape("shape = \"torus\"\nmajor_radius = 0.6\nminor_radius = 0.25").0,
        SdfShape::Torus { major_radius: 0.6, minor_radius: 0.25 }
    );
    assert_eq!(
        shape("shape = \"gyroid\"\nscale = 6\nthickness = 0"),
        (SdfShape::Gyroid { scale: 6.0, thickness: 0.0 }, DVec3::ZERO)
    );
    assert_eq!(
        shape("shape = \"sphere\"\nradius = 1\ncenter = [1, 2, 3]").1,
        DVec3::new(1.0, 2.0, 3.0)
    );
}

#[test]
fn expression_errors_point_at_the_expression() {
    let base = "[field]\nsource = \"expr\"\nresolution = [4, 4, 4]\n";
    let e = error(&format!("{base}expression = \"sin(x) + w\"\n"), &[]);
    assert_eq!(
        e,
        "t.toml:4:14: field.expression: unknown variable \"w\" (the variables are x, y, z and t; \
         constants are PI, E and TAU)"
    );
    let e = error(&format!("{base}expression = \"sinus(x)\"\n"), &[]);
    assert!(
        e.starts_with("t.toml:4:14: field.expression: unknown function \"sinus\" (functions: "),
        "{e}"
    );
    let e = error(&format!("{base}expression = \"(x + 1\"\n"), &[]);
    assert!(e.starts_with("t.toml:4:14: field.expression: cannot parse: "), "{e}");
    let e = error(&format!("{base}expression = \"\"\n"), &[]);
    assert_eq!(e, "t.toml:4:14: field.expression: the expression is empty");
    let e = error(&format!("{base}expression = 3\n"), &[]);
    assert_eq!(e, "t.toml:4:14: field.expression: expected a string, got an integer 3");
    let e = error(base, &[]);
    assert_eq!(e, "t.toml:1:1: field.expression: missing (e.g. \"sin(3*x)*cos(3*y) + z - 0.2*t\")");
}

#[test]
fn memory_cap_is_checked_at_load() {
    let text = "[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = 1\nresolution = [2048, 2048, 2048]\n";
    let e = error(text, &[]);
    assert_eq!(
        e,
        "t.toml:5:14: field.resolution: a grid of 2048x2048x2048 points needs 32768 MiB of f32 \
         samples, over the cap of 1024 MiB; raise the cap with ISOVIEW_MAX_GRID_MIB=32768 (or \
         GridLimits::max_bytes)"
    );
    let small = GridLimits { max_bytes: 4 * 10 * 10 * 10 };
    let ok =
        "[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = 1\nresolution = [10, 10, 10]\n";
    assert!(scene::from_str_with(ok, "t.toml", Path::new("."), &[], &small).is_ok());
    let over = ok.replace("[10, 10, 10]", "[10, 10, 11]");
    let e = scene::from_str_with(&over, "t.toml", Path::new("."), &[], &small).unwrap_err();
    assert_eq!(e.kind, SceneErrorKind::Data);
    assert!(e.to_string().contains("needs 4.3 KiB of f32 samples, over the cap of 3.9 KiB"), "{e}");
    assert_eq!(GridLimits::default().max_bytes, 1 << 30);
    assert_eq!(GridLimits::from_mib_str("16").unwrap().max_bytes, 16 << 20);
    assert!(GridLimits::from_mib_str("0").is_err());
    assert_eq!(
        GridLimits::from_mib_str("lots").unwrap_err().to_string(),
        "ISOVIEW_MAX_GRID_MIB=\"lots\": expected a positive whole number of MiB"
    );
}

/// Runs in a child process (see `env_cap_is_read_by_load`), where it may set the variable.
#[test]
fn env_cap_child() {
    let Ok(cap) = std::env::var("ISOVIEW_MAX_GRID_MIB") else {
        return;
    };
    let text =
        "[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = 1\nresolution = [64, 64, 65]\n";
    let r = scene::from_str(text, "t.toml", Path::new("."), &[]);
    match cap.as_str() {
        "1" => assert!(r.unwrap_err().to_string().contains("over the cap of 1 MiB"), "cap 1"),
        "2" => assert!(r.is_ok()),
        _ => assert_eq!(
            r.unwrap_err().to_string(),
            format!("ISOVIEW_MAX_GRID_MIB={cap:?}: expected a positive whole number of MiB")
        ),
    }
}

#[test]
fn env_cap_is_read_by_load() {
    for cap in ["1", "2", "x"] {
        let out = std::process::Command::new(std::env::current_exe().unwrap())
            // The child's path from this module's, so moving the file cannot leave it pointing
            // at no test ("0 passed" fails below).
            .args([
                "--exact",
                &format!("{}::env_cap_child", module_path!().split_once("::").map_or("", |p| p.1)),
                "--test-threads=1",
            ])
            .env("ISOVIEW_MAX_GRID_MIB", cap)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success() && stdout.contains("1 passed"), "cap {cap}: {stdout}");
    }
}

// ---- overrides --------------------------------------------------------------------------------

#[test]
fn overrides_replace_and_add_keys() {
    let s = parse(
        CELL,
        &[
            "render.method=\"fixed-step\"",
            "render.steps=64",
            "surface.isovalue=0.25",
            "camera.eye=[1,2,3]",
            "image.width = 100",
        ],
    )
    .unwrap();
    assert_eq!(s.render.method, Method::FixedStep);
    assert_eq!(s.render.steps, 64);
    assert_eq!(s.surface.isovalue, 0.25);
    assert_eq!(s.camera.eye, DVec3::new(1.0, 2.0, 3.0));
    assert_eq!(s.image.width, 100);
    // A plain word is a string; later overrides win; nested tables are created.
    let s =
        parse(CELL, &["render.method=fixed-step", "render.shading=normal", "render.shading=depth"])
            .unwrap();
    assert_eq!((s.render.method, s.render.shading), (Method::FixedStep, Shading::Depth));
    let s = parse(CELL, &["field.bounds.min=[-1,-1,-1]", "field.bounds.max=[1,1,1]"]).unwrap();
    assert_eq!(s.field.bounds, Bounds { min: DVec3::splat(-1.0), max: DVec3::ONE });
    let s = parse(CELL, &["field.bounds={min=[0,0,0], max=[2,2,2]}"]).unwrap();
    assert_eq!(s.field.bounds.max, DVec3::splat(2.0));
    let s = parse(CELL, &["field.values=[1,1,1,1,1,1,1,-1]"]).unwrap();
    let FieldSource::Corners(v) = s.field.source else { panic!() };
    assert_eq!(v[7], -1.0);
    // An override can switch the source, as long as the remaining keys fit it.
    let s = parse(
        "[field]\nsource = \"expr\"\nexpression = \"x\"\nresolution = [3, 3, 3]\n",
        &["field.expression=\"y + t\""],
    )
    .unwrap();
    assert!(s.field.is_time_varying());
}

#[test]
fn override_errors_name_the_override() {
    assert_eq!(
        error(CELL, &["render.steps=abc"]),
        "--set render.steps=abc: render.steps: expected an integer, got a string \"abc\""
    );
    assert_eq!(
        error(CELL, &["render.steps=1"]),
        "--set render.steps=1: render.steps: must be at least 2, got 1"
    );
    assert_eq!(
        error(CELL, &["render.stpes=64"]),
        "--set render.stpes=64: render.stpes: unknown key (did you mean \"steps\"?)"
    );
    assert_eq!(
        error(CELL, &["lighting=1"]),
        "--set lighting=1: lighting: unknown table or key (a scene has the tables [image], \
         [camera], [field], [surface], [render], [slice], [clip], [color], [field2])"
    );
    assert_eq!(
        error(CELL, &["render.steps"]),
        "--set render.steps: expected KEY=VALUE, e.g. --set render.steps=64"
    );
    assert_eq!(
        error(CELL, &["render..steps=3"]),
        "--set render..steps=3: \"render..steps\" is not a key path like render.steps or field.bounds.min"
    );
    assert_eq!(
        error(&format!("{CELL}[render]\nsteps = 10\n"), &["render.steps.max=3"]),
        "--set render.steps.max=3: render.steps: is an integer, not a table"
    );
    // A quoted value TOML refuses: one syntax line, not the value's quotes inside the
    // message's (`unknown value ""bo\u{1b}g""`), the control character escaped.
    for bad in ["render.method=\"bo\u{1b}g\"", "render.method=\"fixed-step", "render.method='x"] {
        let e = error(CELL, &[bad]);
        assert!(e.ends_with(": the value is quoted but not a TOML string (a quote left open, or a control character that TOML strings must escape, e.g. \\u001b)"), "{e}");
        assert!(!e.contains('\u{1b}') && !e.contains("\"\""), "{e}");
    }
    // A key path of 60,000 segments built as many nested tables and overflowed the stack
    // (rc 134; through serve's /api/state, 20,000 killed the server).
    let deep = format!("{}=1", vec!["a"; 60_000].join("."));
    let e = error(CELL, &[&deep]);
    assert!(e.ends_with(": a key path of 60000 segments; scene keys have at most 16"), "{e}");
    assert!(e.len() < 400, "{e}");
    assert_eq!(
        error(CELL, &["camera.eye=[1,2"]),
        "--set camera.eye=[1,2: camera.eye: expected an array of 3 numbers, got a string \"[1,2\""
    );
    assert_eq!(
        error(CELL, &["camera.eye=[0,0,0]", "camera.target=[0,0,0]"]),
        "--set camera.target=[0,0,0]: camera.target: camera.eye and camera.target are the same point \
         [0.0, 0.0, 0.0]; the camera needs a direction"
    );
    assert_eq!(
        error(&format!("{CELL}[camera]\neye = [1, 1, 1]\n"), &["camera.target=[1,1,1]"]),
        "--set camera.target=[1,1,1]: camera.target: camera.eye and camera.target are the same \
         point [1.0, 1.0, 1.0]; the camera needs a direction"
    );
    assert_eq!(
        error(&format!("{CELL}[camera]\ntarget = [1, 1, 1]\n"), &["camera.eye=[1,1,1]"]),
        "--set camera.eye=[1,1,1]: camera.eye: camera.eye and camera.target are the same \
         point [1.0, 1.0, 1.0]; the camera needs a direction"
    );
    assert_eq!(
        error(
            &format!("{CELL}bounds = {{ min = [0, 0, 0], max = [1, 1, 1] }}\n"),
            &["field.bounds.min=[0,2,0]"]
        ),
        "--set field.bounds.min=[0,2,0]: field.bounds: min must be below max on every axis, got \
         min = [0.0, 2.0, 0.0], max = [1.0, 1.0, 1.0] (y axis)"
    );
    // The file's own errors still point into the file.
    assert_eq!(
        error(&format!("{CELL}[image]\nwidth = 0\n"), &["render.steps=8"]),
        "t.toml:5:9: image.width: must be at least 1, got 0"
    );
    // An override can fix a bad file value (overrides apply before validation).
    assert!(parse(&format!("{CELL}[image]\nwidth = 0\n"), &["image.width=8"]).is_ok());
}

// ---- files ------------------------------------------------------------------------------------

#[test]
fn load_reads_files_and_reports_io_errors() {
    let s = scene::load(&root().join("scenes/torus.toml"), &[]).unwrap();
    assert_eq!(s.path.as_deref(), Some(root().join("scenes/torus.toml").as_path()));
    let e = scene::load(Path::new("no/such/scene.toml"), &[]).unwrap_err();
    assert_eq!(e.to_string(), "no/such/scene.toml: cannot read scene: file not found");
    assert_eq!(e.kind, SceneErrorKind::Io);

    let dir = std::env::temp_dir().join(format!("isoview-scene-it-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("latin1.toml");
    std::fs::write(&bad, b"[image]\n# caf\xe9\n").unwrap();
    let e = scene::load(&bad, &[]).unwrap_err().to_string();
    assert_eq!(e, format!("{}:2: invalid TOML: the file is not UTF-8", bad.display()));
    let unknown = dir.join("unknown.toml");
    std::fs::write(&unknown, format!("{CELL}[render]\nfoo = 1\n")).unwrap();
    let e = scene::load(&unknown, &[]).unwrap_err().to_string();
    assert_eq!(e, format!("{}:5:1: render.foo: unknown key ([render] has method, steps, newton_steps, skip, occupancy, crossing, count_crossings, mesh, mesh_refine, shading, normals, background, color, hermite, qef_threshold, qef_clamp, feature_angle, mesh_error)", unknown.display()));
}

#[test]
fn the_torus_scene_is_the_interface_example() {
    let s = scene::load(&root().join("scenes/torus.toml"), &[]).unwrap();
    assert_eq!(s.camera, CameraSettings::default());
    assert_eq!(s.surface, SurfaceSettings::default());
    assert_eq!(s.render, RenderSettings::default());
    assert_eq!(s.field.resolution, [48, 48, 48]);
    assert_eq!(s.field.bounds, Bounds { min: DVec3::splat(-1.0), max: DVec3::ONE });
    assert_eq!(s.field.describe(), "sdf torus R=0.6 r=0.25 48x48x48 in [-1, -1, -1]..[1, 1, 1]");
}

#[test]
fn every_shipped_scene_loads_and_samples() {
    let mut names: Vec<PathBuf> = std::fs::read_dir(root().join("scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    names.sort();
    let expected = [
        "box",
        "cell-face-ambiguous",
        "cell-oscillating",
        "cell-tunnel",
        "expr-waves",
        "gyroid",
        "raw",
        "sphere",
        "torus",
        "volume-npy",
    ];
    for want in expected {
        assert!(names.iter().any(|p| p.file_stem().unwrap() == want), "scenes/{want}.toml missing");
    }
    for path in &names {
        let s = scene::load(path, &[]).unwrap_or_else(|e| panic!("{e}"));
        let grid = s.field.sample(0.0).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(grid.dims, s.field.resolution);
        assert_eq!(grid.values.len(), grid.dims.iter().product::<usize>());
        assert!(s.field.resolution.iter().all(|&n| n <= 64), "{}", path.display());
        assert!(s.image.width <= 256 && s.image.height <= 256, "{}", path.display());
        // Every scene shows a surface: the grid has values on both sides of the isovalue.
        let (lo, hi) = grid.range();
        assert!(
            (lo as f64) < s.surface.isovalue && (hi as f64) > s.surface.isovalue,
            "{}",
            path.display()
        );
        assert!(!s.field.describe().contains('\n'));
        let stem = path.file_stem().unwrap().to_string_lossy();
        let varying = stem == "expr-waves" || stem == "cell-oscillating";
        assert_eq!(s.field.is_time_varying(), varying, "{stem}");
        if varying {
            assert_ne!(s.field.sample(1.0).unwrap().values, grid.values, "{stem}");
        }
    }
}

#[test]
fn ambiguous_cells_are_what_they_claim() {
    let corners = |name: &str| {
        let s = scene::load(&root().join(format!("scenes/{name}.toml")), &[]).unwrap();
        let FieldSource::Corners(v) = s.field.source else { panic!() };
        v
    };
    let trilinear = |v: &[f64; 8], x: f64, y: f64, z: f64| {
        let l = |a: f64, b: f64, s: f64| a + (b - a) * s;
        l(l(l(v[0], v[1], x), l(v[2], v[3], x), y), l(l(v[4], v[5], x), l(v[6], v[7], x), y), z)
    };
    // Face z = 0: diagonal corners inside, saddle value above the isovalue (separated).
    let v = corners("cell-face-ambiguous");
    assert!(v[0] < 0.0 && v[3] < 0.0 && v[1] > 0.0 && v[2] > 0.0);
    let saddle = (v[0] * v[3] - v[1] * v[2]) / (v[0] + v[3] - v[1] - v[2]);
    assert!(saddle > 0.0);
    assert!(v[4..].iter().all(|&x| x > 0.0));
    // Tunnel: v000 and v111 inside, no face ambiguous, the diagonal stays inside.
    let v = corners("cell-tunnel");
    assert!(v[0] < 0.0 && v[7] < 0.0 && v[1..7].iter().all(|&x| x > 0.0));
    assert!((0..=100)
        .all(|s| trilinear(&v, s as f64 / 100.0, s as f64 / 100.0, s as f64 / 100.0) < 0.0));
}

/// Fifth attack pass: an unknown key of 15 MiB (under the 16 MiB a scene file may have) took
/// 10 s to refuse: its "did you mean" measured its edit distance to every key of the table,
/// the product of the lengths each. A name whose length differs by more than 2 cannot be
/// within 2 edits and is no longer measured.
#[test]
fn a_huge_unknown_key_is_refused_at_once() {
    let key = "k".repeat(15 << 20);
    let started = std::time::Instant::now();
    let e = error(&format!("{CELL}[render]\n{key} = 1\n"), &[]);
    let took = started.elapsed();
    assert!(e.contains("unknown key") && e.len() < 1000, "{}", &e[..e.len().min(300)]);
    // Generous: a fraction of a second now, seconds before (in the test build as in release).
    assert!(took < std::time::Duration::from_secs(3), "refused in {took:?}");
    // Near misses are still named.
    assert!(error(&format!("{CELL}[render]\nstepz = 1\n"), &[]).contains("did you mean \"steps\""));
}
