//! Several isovalues (`surface.isovalues`): every method draws, pixel by pixel, what the
//! one-surface renders of each isovalue give composited by one rule (the nearest hit, ties to
//! the lower surface; `iso_index` says which), on the GPU bit for bit and against the f64
//! references; scene errors; extract's merged, labelled mesh.

use glam::DVec3;
use isoview::frame::Pixel;
use isoview::render::Renderer;
use isoview::scene::{Inside, Method, Scene};

use crate::common::*;

/// A wavy sphere-like field and three isovalues inside its range: nested shells, the half
/// facing the eye clipped away.
fn case(rng: &mut Rng, dims: [usize; 3], method: Method) -> (isoview::field::Grid, Scene) {
    let k = rng.unit_vector() * 3.0;
    let grid =
        grid_from(dims, DVec3::splat(-1.0), DVec3::ONE, |p| p.length() + 0.08 * k.dot(p).sin());
    let eye = random_eye(rng, &grid, false);
    let mut scene = scene_for(&grid, eye, 36, method);
    // The half facing the eye cut away, so that every shell shows.
    scene.clip.push(eye.normalize(), rng.range(-0.1, 0.1));
    let isos = [rng.range(0.3, 0.45), rng.range(0.55, 0.7), rng.range(0.75, 0.9)];
    scene.surface.isovalue = isos[1];
    scene.surface.more[..2].copy_from_slice(&[isos[0], isos[2]]);
    scene.surface.count = 3;
    (grid, scene)
}

/// For each pixel, the single-surface layer that the rule picks: the nearest hit, the lower
/// surface on a tie; None on a miss of every layer.
fn winner(layers: &[Vec<Pixel>], i: usize) -> Option<usize> {
    let mut best: Option<usize> = None;
    for (k, l) in layers.iter().enumerate() {
        if l[i].is_hit() && best.map_or(true, |b| l[i].depth < layers[b][i].depth) {
            best = Some(k);
        }
    }
    best
}

/// The ray methods: a render with several isovalues equals, bit for bit in every hit channel,
/// the nearest of the one-surface renders (each in its surface's colour), with `iso_index`
/// naming it, `steps` the winner's (a miss: the whole ray's, as every layer), `crossings` the
/// sum. Skipping off, so that `steps` counts the same cells as one surface's walk.
#[gpu_test]
fn several_surfaces_are_the_nearest_of_each_alone_on_the_gpu() {
    let ctx = gpu();
    let mut rng = Rng::new(71);
    for method in [Method::Analytic, Method::FixedStep] {
        let mut renderer = Renderer::new(&ctx).unwrap();
        for c in 0..4 {
            let (grid, mut scene) = case(&mut rng, [9 + c, 10, 8], method);
            scene.surface.inside = [Inside::Below, Inside::Above][c % 2];
            scene.render.skip = false;
            scene.render.count_crossings = c >= 2;
            let all = renderer.render(&scene, &grid, 0.0).unwrap();
            let layers: Vec<Vec<Pixel>> = (0..3)
                .map(|k| renderer.render(&scene.single_surface(k), &grid, 0.0).unwrap().pixels)
                .collect();
            let mut seen = [0usize; 3];
            for (i, p) in all.pixels.iter().enumerate() {
                let what = format!("{method:?} case {c} pixel {i}");
                let want_crossings = match scene.render.count_crossings {
                    true if method == Method::Analytic => {
                        layers.iter().map(|l| l[i].crossings).sum()
                    }
                    _ => -1, // not counted (fixed-step never counts)
                };
                match winner(&layers, i) {
                    None => {
                        assert!(!p.is_hit(), "{what}");
                        assert_eq!(p.surface, -1, "{what}");
                        assert_eq!(p.steps, layers[0][i].steps, "{what}");
                    }
                    Some(k) => {
                        let w = layers[k][i];
                        seen[k] += 1;
                        assert_eq!(p.surface, k as i32, "{what}");
                        let bits =
                            |q: &Pixel| (q.rgba.map(f32::to_bits), q.normal.map(f32::to_bits));
                        assert_eq!(bits(p), bits(&w), "{what}");
                        assert_eq!(p.depth.to_bits(), w.depth.to_bits(), "{what}");
                        assert_eq!(p.position.map(f32::to_bits), w.position.map(f32::to_bits));
                        assert_eq!((p.cell, p.steps), (w.cell, w.steps), "{what}");
                    }
                }
                assert_eq!(p.crossings, want_crossings, "{what}");
            }
            assert!(seen.iter().filter(|&&n| n > 0).count() >= 2, "{method:?} case {c}: {seen:?}");
        }
    }
}

/// Every method with several isovalues against its f64 reference (the references compose the
/// one-surface references by the same rule), at the tolerances of the one-surface tests.
#[gpu_test]
fn several_surfaces_gpu_equals_reference() {
    let ctx = gpu();
    let mut rng = Rng::new(73);
    for method in Method::ALL {
        let mut renderer = Renderer::new(&ctx).unwrap();
        for c in 0..3 {
            let (grid, mut scene) = case(&mut rng, [10, 9 + c, 11], method);
            scene.surface.inside = [Inside::Below, Inside::Above][c % 2];
            let gpu = renderer.render(&scene, &grid, 0.0).unwrap();
            let reference = reference_pixels(&scene, &grid);
            let ag = Agreement::same(&reference, &gpu.pixels);
            assert!(ag.hits > 100, "{method:?} case {c}: {} hits", ag.hits);
            assert!(ag.mismatched * 50 <= ag.hits, "{method:?} case {c}: {ag:?}");
            let tol = if method == Method::FixedStep { 5e-2 } else { 3e-5 };
            assert!(ag.depth < tol, "{method:?} case {c}: depth {:e}", ag.depth);
            // The same surface wherever both hit at the same place.
            let (mut same, mut both) = (0, 0);
            for (g, r) in gpu.pixels.iter().zip(&reference) {
                if g.is_hit() && r.is_hit() {
                    both += 1;
                    same += (g.surface == r.surface) as usize;
                }
            }
            assert!(same * 50 >= both * 49, "{method:?} case {c}: iso_index {same}/{both}");
            let used: std::collections::BTreeSet<i32> =
                gpu.pixels.iter().map(|p| p.surface).collect();
            assert!(used.len() >= 3, "{method:?} case {c}: surfaces {used:?}");
        }
    }
}

#[test]
fn surface_keys_are_checked() {
    let dir = scratch("surfaces-keys");
    let base =
        "[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = 0.5\nresolution = [8, 8, 8]\n";
    let bad = [
        ("[surface]\nisovalues = [0.1, 0.2]\nisovalue = 0.3\n", "not both"),
        ("[surface]\nisovalues = []\n", "1 to 8"),
        ("[surface]\nisovalues = [0, 1, 2, 3, 4, 5, 6, 7, 8]\n", "1 to 8"),
        ("[surface]\nisovalues = [0.1, \"a\"]\n", "surface.isovalues"),
        ("[surface]\nisovalues = [0.1, 0.2]\ncolors = [[1, 0, 0]]\n", "one colour per surface"),
        ("[surface]\nisovalues = [0.1, 0.2]\n[render]\ncrossing = 2\n", "render.crossing"),
    ];
    for (i, (text, needle)) in bad.iter().enumerate() {
        let path = write(&dir, &format!("s{i}.toml"), &format!("{base}{text}"));
        let e = isoview::scene::load(std::path::Path::new(&path), &[]).unwrap_err().to_string();
        assert!(e.contains(needle), "{text}: {e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
    let path = write(
        &dir,
        "ok.toml",
        &format!("{base}[surface]\nisovalues = [-0.1, 0.1]\ncolors = [[1, 0, 0], [0, 0, 1]]\n"),
    );
    let s = isoview::scene::load(std::path::Path::new(&path), &[]).unwrap();
    assert_eq!(s.surface.isovalues(), vec![-0.1, 0.1]);
    assert_eq!(s.surface.color(1, s.render.color), [0.0, 0.0, 1.0]);
    // A --set of isovalue replaces the list (one surface).
    let s = isoview::scene::load(std::path::Path::new(&path), &["surface.isovalue=0.2".into()]);
    let s = s.unwrap();
    assert_eq!((s.surface.count, s.surface.isovalue), (1, 0.2));
    assert_eq!(s.surface.color(0, s.render.color), [1.0, 0.0, 0.0], "the file's first colour");
}

/// `extract` with several isovalues: one mesh per surface, merged, the PLY's vertices labelled
/// with their surface; each part is the one-surface extraction.
#[test]
fn extract_merges_one_mesh_per_surface_with_labels() {
    let dir = scratch("surfaces-extract");
    let scene = write(
        &dir,
        "s.toml",
        "[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = 0.6\nresolution = [12, 12, 12]\n\
         [surface]\nisovalues = [-0.2, 0.1]\n",
    );
    let out = |name: &str, sets: &[&str]| {
        let path = dir.join(name).display().to_string();
        let mut args = vec!["extract", &scene, "-o", &path, "--device", "cpu"];
        for s in sets {
            args.extend(["--set", s]);
        }
        let o = isoview(&args, &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read(&path).unwrap()
    };
    let both = out("both.ply", &[]);
    let a = out("a.ply", &["surface.isovalue=-0.2"]);
    let b = out("b.ply", &["surface.isovalue=0.1"]);
    let (head, body) = split_ply(&both);
    assert!(head.contains("property uchar surface"), "{head}");
    let count = |h: &str, what: &str| -> usize {
        let line = h.lines().find(|l| l.starts_with(&format!("element {what} "))).unwrap();
        line.rsplit(' ').next().unwrap().parse().unwrap()
    };
    let (ha, _) = split_ply(&a);
    let (hb, _) = split_ply(&b);
    let (va, vb) = (count(&ha, "vertex"), count(&hb, "vertex"));
    assert!(va > 0 && vb > 0);
    assert_eq!(count(&head, "vertex"), va + vb);
    assert_eq!(count(&head, "face"), count(&ha, "face") + count(&hb, "face"));
    // Vertex records: 6 floats and the label; the first va are surface 0's.
    let labels: Vec<u8> = (0..va + vb).map(|i| body[i * 25 + 24]).collect();
    assert!(labels[..va].iter().all(|&l| l == 0) && labels[va..].iter().all(|&l| l == 1));
}

fn split_ply(bytes: &[u8]) -> (String, &[u8]) {
    let end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    (String::from_utf8_lossy(&bytes[..end]).into_owned(), &bytes[end..])
}

/// `probe` with several isovalues reports each surface alone and the one shown: the render's
/// `iso_index` at that pixel.
#[gpu_test]
fn probe_names_the_surface_the_render_shows() {
    let dir = scratch("surfaces-probe");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/blobs-layers.toml");
    let sets = ["--set", "image.width=32", "--set", "image.height=32"];
    let exr = dir.join("b.exr").display().to_string();
    let mut args = vec!["render", scene, "-o", &exr];
    args.extend(sets);
    let o = isoview(&args, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = isoview::output::exr::read(std::path::Path::new(&exr)).unwrap();
    let index = &img.channel("iso_index").unwrap().values;
    let mut checked = std::collections::BTreeSet::new();
    for (i, &k) in index.iter().enumerate().step_by(7) {
        let pixel = format!("{},{}", i % 32, i / 32);
        let mut args = vec!["probe", scene, "--pixel", &pixel, "--json"];
        args.extend(sets);
        let o = isoview(&args, &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(report["surfaces"].as_array().unwrap().len(), 3);
        let shown = report["shown_surface"].as_i64().unwrap_or(-1);
        assert_eq!(shown, k as i64, "pixel {pixel}");
        checked.insert(k as i64);
    }
    assert!(checked.len() >= 3, "{checked:?}");
}

/// `slice` with several isovalues: the JSON holds one contour set per surface, each the
/// one-surface slice's; the picture draws them all.
#[gpu_test]
fn slice_writes_one_contour_set_per_surface() {
    let dir = scratch("surfaces-slice");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/blobs-layers.toml");
    let run = |name: &str, sets: &[&str]| -> serde_json::Value {
        let (exr, json) = (dir.join(format!("{name}.exr")), dir.join(format!("{name}.json")));
        let (e, j) = (exr.display().to_string(), json.display().to_string());
        let mut args = vec!["slice", scene, "--axis", "z", "--at", "0.05", "-o", &e, "--json", &j];
        for s in sets {
            args.extend(["--set", s]);
        }
        let o = isoview(&args, &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap()
    };
    let all = run("all", &[]);
    let surfaces = all["surfaces"].as_array().unwrap();
    assert_eq!(all["isovalues"], serde_json::json!([0.25, 0.5, 0.8]));
    assert_eq!(surfaces.len(), 3);
    for (k, iso) in ["0.25", "0.5", "0.8"].iter().enumerate() {
        let one = run(&format!("s{k}"), &[&format!("surface.isovalue={iso}")]);
        assert!(!one["contours"].as_array().unwrap().is_empty(), "surface {k}");
        assert_eq!(surfaces[k], one, "surface {k}");
    }
}
