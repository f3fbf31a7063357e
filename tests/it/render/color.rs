//! `[color] by`: every method's hits coloured through the colormap by the hit's world x/y/z,
//! the surface's isovalue or `[field2]` sampled trilinearly; `color.value` holds the value,
//! the colour is the colormap's entry lit as the scene's shading lights `render.color`; the
//! PNG preview grows a colour bar; scene errors are one line.

use glam::DVec3;
use isoview::camera::Camera;
use isoview::frame::Pixel;
use isoview::render::Renderer;
use isoview::scene::{Method, Scene};

use crate::common::*;

const BASE: &str = "[image]\nwidth = 40\nheight = 40\n\
    [camera]\neye = [2.2, 1.6, 2.4]\ntarget = [0.0, 0.0, 0.0]\n\
    [field]\nsource = \"sdf\"\nshape = \"torus\"\nmajor_radius = 0.6\nminor_radius = 0.25\n\
    resolution = [24, 24, 24]\nbounds = { min = [-1.0, -1.0, -1.0], max = [1.0, 1.0, 1.0] }\n";

fn load(dir: &std::path::Path, name: &str, extra: &str, sets: &[&str]) -> Scene {
    let path = write(dir, name, &format!("{BASE}{extra}"));
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    isoview::scene::load(std::path::Path::new(&path), &sets).unwrap()
}

/// The colormap entry the module doc promises for value `v` over [lo, hi], lit by the headlight
/// along the pixel's world ray.
fn expected_rgb(scene: &Scene, p: &Pixel, px: u32, py: u32, v: f64, lo: f64, hi: f64) -> DVec3 {
    let (_, gradient) = isoview::scene::COLORMAPS[scene.color.colormap];
    let s = ((v - lo) / (hi - lo)).clamp(0.0, 1.0);
    let c = gradient.eval_continuous((s * 255.0 + 0.5).floor() / 255.0);
    let lin = |u: u8| isoview::scene::srgb_to_linear(u as f32 / 255.0) as f64;
    let (_, dir) = Camera::new(&scene.camera, &scene.image).ray(px, py);
    let lambert = 0.15 + 0.85 * v3(p.normal).dot(dir).abs();
    DVec3::new(lin(c.r), lin(c.g), lin(c.b)) * lambert
}

/// Every method coloured by z: `color.value` is the hit's own P.Z, the colour the colormap's
/// entry over the box's world z range, lit; misses untouched (value NaN).
#[gpu_test]
fn colour_by_z_maps_each_hits_height() {
    let ctx = gpu();
    let dir = scratch("color-z");
    let mut renderer = Renderer::new(&ctx).unwrap();
    for method in Method::ALL {
        let m = format!("render.method=\"{}\"", method.name());
        let scene = load(&dir, "z.toml", "[color]\nby = \"z\"\ncolormap = \"turbo\"\n", &[&m]);
        let grid = scene.field.sample(0.0).unwrap();
        let frame = renderer.render(&scene, &grid, 0.0).unwrap();
        let legend = frame.info.legend.clone().expect("a legend");
        assert_eq!((legend.lo, legend.hi, legend.colormap), (-1.0, 1.0, "turbo"));
        let mut hits = 0;
        for (i, p) in frame.pixels.iter().enumerate() {
            if !p.is_hit() {
                assert!(p.value.is_nan(), "{method:?}");
                continue;
            }
            hits += 1;
            assert_eq!(p.value, p.position[2], "{method:?} pixel {i}");
            let (px, py) = (i as u32 % 40, i as u32 / 40);
            let want = expected_rgb(&scene, p, px, py, p.position[2] as f64, -1.0, 1.0);
            assert!((v3([p.rgba[0], p.rgba[1], p.rgba[2]]) - want).length() < 1e-5, "{method:?}");
        }
        assert!(hits > 200, "{method:?}: {hits}");
    }
}

/// `[field2]` on its own grid: a linear field is interpolated exactly, so `color.value` is
/// the field's own value at the hit; the default range is field2's sample range.
#[gpu_test]
fn colour_by_field2_samples_the_second_field_at_the_hit() {
    let ctx = gpu();
    let dir = scratch("color-field2");
    let extra = "[color]\nby = \"field2\"\n[field2]\nsource = \"expr\"\n\
        expression = \"2*x - y + 0.5*z\"\nresolution = [5, 7, 6]\n\
        bounds = { min = [-1.2, -1.1, -1.3], max = [1.1, 1.2, 1.0] }\n";
    let scene = load(&dir, "f2.toml", extra, &[]);
    let grid = scene.field.sample(0.0).unwrap();
    let frame = Renderer::new(&ctx).unwrap().render(&scene, &grid, 0.0).unwrap();
    let legend = frame.info.legend.clone().unwrap();
    // The samples' range: the box corners of 2x - y + 0.5z.
    assert!((legend.lo - (-2.4 - 1.2 - 0.65)).abs() < 1e-5, "{}", legend.lo);
    assert!((legend.hi - (2.2 + 1.1 + 0.5)).abs() < 1e-5, "{}", legend.hi);
    let mut hits = 0;
    for p in frame.pixels.iter().filter(|p| p.is_hit()) {
        hits += 1;
        let q = v3(p.position);
        let want = 2.0 * q.x - q.y + 0.5 * q.z;
        assert!((p.value as f64 - want).abs() < 1e-5, "{} vs {want}", p.value);
    }
    assert!(hits > 200);
}

/// With several isovalues, `by = "value"` colours each surface by its isovalue through the map.
#[gpu_test]
fn colour_by_value_gives_each_surface_its_isovalue() {
    let ctx = gpu();
    let dir = scratch("color-value");
    let extra = "[surface]\nisovalues = [-0.1, 0.0, 0.1]\n[color]\nby = \"value\"\n\
        range = [-0.2, 0.2]\n[[clip]]\nnormal = [1.0, 0.0, 1.0]\noffset = 0.0\n";
    let scene = load(&dir, "v.toml", extra, &[]);
    let grid = scene.field.sample(0.0).unwrap();
    let frame = Renderer::new(&ctx).unwrap().render(&scene, &grid, 0.0).unwrap();
    let isos = [-0.1f32, 0.0, 0.1];
    let mut seen = [false; 3];
    for p in frame.pixels.iter().filter(|p| p.is_hit()) {
        assert_eq!(p.value, isos[p.surface as usize]);
        seen[p.surface as usize] = true;
    }
    assert!(seen.iter().filter(|&&s| s).count() >= 2, "{seen:?}");
}

/// Through the CLI: the EXR has `color.value` and the header says how it was coloured; the
/// PNG preview is taller by the colour bar; a render without `[color]` has neither.
#[gpu_test]
fn the_exr_records_the_value_and_the_png_shows_the_bar() {
    let dir = scratch("color-cli");
    let with = write(&dir, "with.toml", &format!("{BASE}[color]\nby = \"y\"\n"));
    let without = write(&dir, "without.toml", BASE);
    for (scene, colored) in [(&with, true), (&without, false)] {
        let (exr, png) = (dir.join("o.exr"), dir.join("o.png"));
        let (e, p) = (exr.display().to_string(), png.display().to_string());
        let o = isoview(&["render", scene, "-o", &e, "--png", &p], &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        let img = isoview::output::exr::read(&exr).unwrap();
        assert_eq!(img.channel("color.value").is_some(), colored);
        assert_eq!(img.attribute("isoview/extra/color.by").is_some(), colored);
        let decoded = image::open(&png).unwrap();
        let bar = if colored { isoview::output::legend::ROWS } else { 0 };
        assert_eq!((decoded.width(), decoded.height()), (40, 40 + bar));
    }
}

#[test]
fn color_keys_are_checked() {
    let dir = scratch("color-keys");
    let bad = [
        ("[color]\nby = \"field2\"\n", "needs a [field2]"),
        ("[color]\nby = \"pressure\"\n", "color.by"),
        ("[color]\nby = \"x\"\ncolormap = \"jet\"\n", "color.colormap"),
        ("[color]\nby = \"x\"\nrange = [1.0, 1.0]\n", "lo < hi"),
        ("[field2]\nsource = \"expr\"\nexpression = \"x\"\nresolution = [4, 4, 4]\n", "field2"),
        (
            "[color]\nby = \"field2\"\n[field2]\nsource = \"expr\"\nresolution = [4, 4, 4]\n",
            "field2.expression",
        ),
    ];
    for (i, (text, needle)) in bad.iter().enumerate() {
        let path = write(&dir, &format!("c{i}.toml"), &format!("{BASE}{text}"));
        let e = isoview::scene::load(std::path::Path::new(&path), &[]).unwrap_err().to_string();
        assert!(e.contains(needle), "{text}: {e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}
