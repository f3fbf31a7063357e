//! Bounded memory for meshes (issue 29, item 4): `extract` streams a PLY of one surface slab by
//! slab with a bounded peak; what must be held whole (other formats, several surfaces, clips,
//! `--stats`, mc33, the methods not cut into slabs, `render.method = "mesh"`) is refused past
//! the cap of `ISOVIEW_MAX_MESH_MIB` in one line with the numbers (exit 2, no file written);
//! `--stats` does not double the peak; the files are still the library's meshes byte for byte.

use std::path::{Path, PathBuf};
use std::process::Command;

use isoview::mesh::export::{self, Format};
use isoview::mesh::{self, stats, ExtractOptions, Mesh};
use isoview::scene;

use crate::common::{assert_fails, isoview, scratch, stderr, write};

fn shipped(name: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name).display().to_string()
}

/// A field with many small closed surfaces on `n`³ points, `surface` the `[surface]` lines.
fn egg_crate(n: usize, surface: &str, extra: &str) -> String {
    format!(
        "[field]\nsource = \"expr\"\nexpression = \"sin(40*x)*sin(40*y)*sin(40*z)\"\n\
         resolution = [{n}, {n}, {n}]\nbounds = {{ min = [-1.0, -1.0, -1.0], max = [1.0, 1.0, 1.0] }}\n\
         [surface]\n{surface}\n{extra}"
    )
}

const ISO: &str = "isovalue = 0.1";

/// What `extract --device cpu` writes, from the library: every surface's reference mesh, placed,
/// clipped and merged as the CLI does, in `format`.
fn library_bytes(scene_path: &str, format: Format) -> Vec<u8> {
    let s = scene::load(Path::new(scene_path), &[]).unwrap();
    let grid = s.field.sample(0.0).unwrap();
    let mut meshes = Vec::new();
    for k in 0..s.surface.count {
        let one = s.single_surface(k);
        let (algo, opts) = (one.render.mesh, ExtractOptions::default());
        let mut m = mesh::reference(
            &grid,
            &mesh::Request::new(one.surface.isovalue, one.surface.inside, algo).with_opts(opts),
        )
        .unwrap();
        m.place(&s.field.placement);
        if s.clip.count > 0 {
            m = m.clipped(&s.clip);
        }
        meshes.push(m);
    }
    let (m, labels): (Mesh, Option<Vec<u32>>) = match meshes.len() {
        1 => (meshes.pop().unwrap(), None),
        _ => {
            let (m, l) = mesh::merge(&meshes);
            (m, Some(l))
        }
    };
    let mut bytes = Vec::new();
    export::write_labelled(&m, labels.as_deref(), format, &mut bytes).unwrap();
    bytes
}

#[test]
fn files_are_the_library_s_meshes_byte_for_byte() {
    let dir = scratch("extract-memory-bytes");
    // One surface; three surfaces with labels and a clip; a raw file.
    for name in ["gyroid.toml", "blobs-layers.toml", "raw.toml"] {
        let scene_path = shipped(name);
        for (ext, format) in [("ply", Format::Ply), ("obj", Format::Obj), ("stl", Format::Stl)] {
            let out = dir.join(format!("{name}.{ext}"));
            let o = isoview(
                &["extract", &scene_path, "-o", &out.display().to_string(), "--device", "cpu"],
                &[],
            );
            assert!(o.status.success(), "{name}: {}", stderr(&o));
            let got = std::fs::read(&out).unwrap();
            assert!(got == library_bytes(&scene_path, format), "{name} as {ext}");
        }
    }
}

#[test]
fn a_mesh_past_the_cap_is_refused_with_the_numbers() {
    let dir = scratch("extract-memory-cap");
    let scene_path = write(&dir, "crate.toml", &egg_crate(64, ISO, ""));
    // OBJ: written from the whole mesh.
    let out = dir.join("crate.obj");
    let out_arg = out.display().to_string();
    // Under the default cap it is written (530,084 triangles, 12 MiB).
    let o = isoview(&["extract", &scene_path, "-o", &out_arg, "--device", "cpu"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let before = std::fs::read(&out).unwrap();
    assert!(before.len() > 1 << 20, "{}", before.len());
    let cap = [("ISOVIEW_MAX_MESH_MIB", "1")];
    let methods = ["marching-cubes", "surface-nets", "mc33", "extended-mc"];
    for (method, ext) in methods.iter().flat_map(|m| [(m, "obj"), (m, "stl")]) {
        let set = format!("render.mesh={method}");
        let out_arg = dir.join(format!("crate.{ext}")).display().to_string();
        let args = ["extract", &scene_path, "-o", &out_arg, "--device", "cpu", "--set", &set];
        let o = isoview(&args, &cap);
        // extended-mc's working tables pass the cap before its mesh does (see below).
        let passed = match *method {
            "extended-mc" => "crate.toml: render.mesh = \"extended-mc\" would hold ",
            _ => "crate.toml: the mesh passed ",
        };
        assert_fails(
            &o,
            2,
            &[passed, "over the cap of 1 MiB; raise the cap with ISOVIEW_MAX_MESH_MIB="],
        );
        // The previous file is left as it was, no file is made, and no temporary beside them.
        assert!(std::fs::read(&out).unwrap() == before, "{method}");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2, "{method}");
    }
    // For a PLY too: `--stats` holds the positions (12 bytes a vertex), mc33 the whole mesh.
    let ply = dir.join("crate.ply").display().to_string();
    let stats = ["extract", &scene_path, "-o", &ply, "--device", "cpu", "--stats"];
    assert_fails(&isoview(&stats, &cap), 2, &["crate.toml: the mesh passed "]);
    let mc33 = ["extract", &scene_path, "-o", &ply, "--device", "cpu", "--set", "render.mesh=mc33"];
    assert_fails(&isoview(&mc33, &cap), 2, &["crate.toml: the mesh passed "]);
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);
    // The surfaces of one scene count together: each of these three is under 1 MiB alone.
    // (17,100, 12,316 and 12,316 triangles: 0.42, 0.33 and 0.33 MiB.)
    let three = write(&dir, "three.toml", &egg_crate(20, "isovalues = [0.1, 0.2, 0.3]", ""));
    for iso in ["[0.1]", "[0.2]", "[0.3]"] {
        let set = format!("surface.isovalues={iso}");
        let args = ["extract", &three, "-o", &out_arg, "--device", "cpu", "--set", &set];
        let one = isoview(&args, &cap);
        assert!(one.status.success(), "{}", stderr(&one));
    }
    let o = isoview(&["extract", &three, "-o", &out_arg, "--device", "cpu"], &cap);
    assert_fails(&o, 2, &["three.toml: the mesh passed ", "over the cap of 1 MiB"]);
    // A cap that is not a number of MiB.
    let o = isoview(&["extract", &scene_path, "-o", &out_arg], &[("ISOVIEW_MAX_MESH_MIB", "lots")]);
    assert_fails(
        &o,
        2,
        &["ISOVIEW_MAX_MESH_MIB=\"lots\": expected a positive whole number of MiB"],
    );
}

/// Fifth attack pass: `extended-mc` and `dual-contouring-qef` with `mesh_error` (not cut into
/// slabs) were counted against the mesh cap once done, but hold 5 to 7 times their mesh while
/// they work (extended-mc: an edge table, 48 bytes of Hermite data a crossing, a table of
/// every directed edge for the flips; the octree: a QEF in every leaf). A 256^3 noise grid's
/// meshes, under the 1 GiB cap, peaked at 4 GB and 2.6 GB, and a grid at the grid cap would
/// run the machine out of memory before any refusal. Their tables are checked against the cap
/// as they grow: these 128^3 egg crates' meshes fit the caps below (72 and 29 MiB), their
/// work (460 and 380 MiB) does not.
#[test]
fn the_sharp_methods_working_memory_is_under_the_cap() {
    let dir = scratch("extract-memory-sharp");
    let out = dir.join("crate.ply").display().to_string();
    let cases = [
        ("[render]\nmesh = \"extended-mc\"\n", "100", "extended-mc"),
        (
            "[render]\nmesh = \"dual-contouring-qef\"\nmesh_error = 0.01\n",
            "40",
            "dual-contouring-qef",
        ),
    ];
    for (render, cap, method) in cases {
        let scene_path = write(&dir, "crate.toml", &egg_crate(128, ISO, render));
        let args = ["extract", &scene_path, "-o", &out, "--device", "cpu"];
        let o = isoview(&args, &[("ISOVIEW_MAX_MESH_MIB", cap)]);
        let would = format!("crate.toml: render.mesh = \"{method}\" would hold ");
        assert_fails(&o, 2, &[&would, &format!("over the cap of {cap} MiB")]);
        assert!(!Path::new(&out).exists());
        // Under the cap the mesh is the library's, byte for byte (the checks change nothing).
        let small = write(&dir, "small.toml", &egg_crate(40, ISO, render));
        let o = isoview(&["extract", &small, "-o", &out, "--device", "cpu"], &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        let s = scene::load(Path::new(&small), &[]).unwrap();
        let grid = s.field.sample(0.0).unwrap();
        let mut x = mesh::Request::new(s.surface.isovalue, s.surface.inside, s.render.mesh);
        x.sharp = s.render.sharp;
        let mut m = mesh::reference(&grid, &x).unwrap();
        m.place(&s.field.placement);
        let mut bytes = Vec::new();
        export::write_labelled(&m, None, Format::Ply, &mut bytes).unwrap();
        assert!(std::fs::read(&out).unwrap() == bytes, "{method}: not the library's mesh");
        std::fs::remove_file(&out).unwrap();
    }
}

/// `field.residency = "active"`: the mapped file's windows are counted as they are joined.
#[test]
fn a_mapped_grid_s_mesh_past_the_cap_is_refused() {
    let dir = scratch("extract-memory-mapped");
    let n = 64usize;
    let mut bytes = Vec::with_capacity(4 * n * n * n);
    let at = |i: usize| -1.0 + 2.0 * i as f64 / (n - 1) as f64;
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let v = ((40.0 * at(i)).sin() * (40.0 * at(j)).sin() * (40.0 * at(k)).sin()) as f32;
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    std::fs::write(dir.join("crate.raw"), bytes).unwrap();
    let scene_path = write(
        &dir,
        "mapped.toml",
        &format!(
            "[field]\nsource = \"raw\"\npath = \"crate.raw\"\ndims = [{n}, {n}, {n}]\n\
             dtype = \"f32\"\nendian = \"little\"\nresidency = \"active\"\n[surface]\nisovalue = 0.1\n"
        ),
    );
    let out = dir.join("m.ply").display().to_string();
    let o = isoview(&["extract", &scene_path, "-o", &out], &[]);
    assert!(o.status.success() && stderr(&o).contains("memory-mapped"), "{}", stderr(&o));
    let o = isoview(&["extract", &scene_path, "-o", &out], &[("ISOVIEW_MAX_MESH_MIB", "1")]);
    assert_fails(&o, 2, &["mapped.toml: the mesh passed ", "over the cap of 1 MiB"]);
}

#[gpu_test]
fn render_mesh_past_the_cap_is_refused() {
    let dir = scratch("extract-memory-render");
    let extra = "[image]\nwidth = 16\nheight = 16\n[render]\nmethod = \"mesh\"\n";
    let scene_path = write(&dir, "crate.toml", &egg_crate(64, ISO, extra));
    let out = dir.join("crate.exr").display().to_string();
    let cap = [("ISOVIEW_MAX_MESH_MIB", "1")];
    // marching-cubes is extracted on the device, extended-mc on the CPU.
    for method in ["marching-cubes", "extended-mc"] {
        let set = format!("render.mesh={method}");
        let o = isoview(&["render", &scene_path, "-o", &out, "--set", &set], &[]);
        assert!(o.status.success(), "{method}: {}", stderr(&o));
        std::fs::remove_file(&out).unwrap();
        let o = isoview(&["render", &scene_path, "-o", &out, "--set", &set], &cap);
        // extended-mc's working tables pass the cap before its mesh does.
        let passed = match method {
            "extended-mc" => "render.method = \"mesh\": render.mesh = \"extended-mc\" would hold ",
            _ => "render.method = \"mesh\": the mesh passed ",
        };
        assert_fails(&o, 2, &[passed, "over the cap of 1 MiB"]);
        assert!(!Path::new(&out).exists(), "{method}");
    }
}

/// The GPU extraction is counted on the device's counts, before the mesh is read back.
#[gpu_test]
fn gpu_extraction_past_the_cap_is_refused() {
    let dir = scratch("extract-memory-gpu");
    let scene_path = write(&dir, "crate.toml", &egg_crate(64, ISO, ""));
    let out = dir.join("crate.ply").display().to_string();
    let args = ["extract", &scene_path, "-o", &out, "--device", "gpu"];
    let o = isoview(&args, &[]);
    assert!(o.status.success() && stderr(&o).contains("on gpu"), "{}", stderr(&o));
    std::fs::remove_file(&out).unwrap();
    let o = isoview(&args, &[("ISOVIEW_MAX_MESH_MIB", "1")]);
    assert_fails(&o, 2, &["crate.toml: the mesh passed 530084 triangles and 253668 vertices"]);
    assert!(!Path::new(&out).exists());
}

/// A PLY of one surface is streamed: not held whole, so not capped, and the same bytes.
#[test]
fn a_ply_of_one_surface_streams_past_the_cap() {
    let dir = scratch("extract-memory-stream");
    let scene_path = write(&dir, "crate.toml", &egg_crate(64, ISO, ""));
    let out = dir.join("crate.ply");
    let out_arg = out.display().to_string();
    let cap = [("ISOVIEW_MAX_MESH_MIB", "1")];
    for (method, quads) in
        [("marching-cubes", ""), ("surface-nets", "--quads"), ("dual-contouring", "")]
    {
        let set = format!("render.mesh={method}");
        let mut args =
            vec!["extract", &scene_path, "-o", &out_arg, "--device", "cpu", "--set", &set];
        args.extend((!quads.is_empty()).then_some(quads));
        let o = isoview(&args, &cap);
        assert!(o.status.success(), "{method}: {}", stderr(&o));
        assert!(stderr(&o).contains(&format!("triangles ({method} on cpu) in")), "{}", stderr(&o));
        let s = scene::load(Path::new(&scene_path), std::slice::from_ref(&set)).unwrap();
        let grid = s.field.sample(0.0).unwrap();
        let opts = ExtractOptions { keep_quads: !quads.is_empty(), ..Default::default() };
        let m = mesh::reference(
            &grid,
            &mesh::Request::new(0.1, s.surface.inside, s.render.mesh).with_opts(opts),
        )
        .unwrap();
        assert!(m.triangle_count() > 100_000, "{method}");
        let mut want = Vec::new();
        export::write(&m, Format::Ply, &mut want).unwrap();
        assert!(std::fs::read(&out).unwrap() == want, "{method}");
        // The scratch files are gone.
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2, "{method}");
    }
}

/// Its peak: the grid and a few slabs' meshes, not the mesh (two threads: one slab of four
/// cell layers each at a time).
#[test]
fn a_streamed_ply_s_peak_is_not_the_mesh_s() {
    let dir = scratch("extract-memory-stream-peak");
    let threads = [("RAYON_NUM_THREADS", "2")];
    let run = |n: usize| {
        let scene_path = write(&dir, &format!("c{n}.toml"), &egg_crate(n, ISO, ""));
        let out = dir.join(format!("c{n}.ply")).display().to_string();
        peak_kib(&["extract", &scene_path, "-o", &out, "--device", "cpu"], &threads).0
    };
    let (small, large) = (run(8), run(128));
    let m = egg_crate_mesh(128);
    let mesh_kib = (24 * m.vertex_count() + 12 * m.triangle_count()) as i64 / 1024;
    let grid_kib = (128 * 128 * 128 * 4) / 1024;
    assert!(mesh_kib > 48 << 10, "{mesh_kib} KiB: too small a mesh to tell");
    assert!(
        large < small + grid_kib + mesh_kib / 4,
        "{large} KiB for a mesh of {mesh_kib} KiB and a grid of {grid_kib} KiB ({small} KiB for 8^3)"
    );
}

/// The mesh of `egg_crate(n, ISO, "")`, as `extract` makes it.
fn egg_crate_mesh(n: usize) -> Mesh {
    let s = scene::from_str(&egg_crate(n, ISO, ""), "crate.toml", Path::new("."), &[]).unwrap();
    let grid = s.field.sample(0.0).unwrap();
    mesh::extract(
        &grid,
        &mesh::Request::new(0.1, s.surface.inside, s.render.mesh),
        &mesh::MeshBudget::unlimited(),
    )
    .unwrap()
}

/// The peak resident memory (KiB) of `isoview args` with `env`, and its stdout: the child's
/// `VmHWM` (its own high-water mark, which an exited child's `wait4` count is not: that
/// includes the test process's own, copied at the fork) read from `/proc/PID/status` every
/// millisecond until it has exited. A peak held for less than that before exiting could be
/// missed, which would make a measurement smaller, never larger.
fn peak_kib(args: &[&str], env: &[(&str, &str)]) -> (i64, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_isoview"))
        .args(args)
        .envs(env.iter().copied())
        .env_remove("ISOVIEW_DEVICE")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut text = String::new();
        std::io::Read::read_to_string(&mut stdout, &mut text).unwrap();
        text
    });
    let status_file = format!("/proc/{}/status", child.id());
    let mut peak = 0;
    // An exited child not yet waited for keeps its status file, without the memory lines.
    while let Some(kib) = std::fs::read_to_string(&status_file).ok().and_then(|s| vm_hwm(&s)) {
        peak = peak.max(kib);
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    let status = child.wait().unwrap();
    assert!(status.success(), "{args:?}: {status}");
    (peak, reader.join().unwrap())
}

/// The `VmHWM:   1234 kB` line's number.
fn vm_hwm(status: &str) -> Option<i64> {
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

#[test]
fn stats_do_not_double_the_peak() {
    let dir = scratch("extract-memory-stats");
    let scene_path = write(&dir, "crate.toml", &egg_crate(100, ISO, ""));
    // OBJ: the whole mesh is held with or without `--stats`.
    let out = dir.join("crate.obj").display().to_string();
    let plain = ["extract", scene_path.as_str(), "-o", &out, "--device", "cpu"];
    let (without, _) = peak_kib(&plain, &[]);
    let (with, text) = peak_kib(&[&plain[..], &["--stats"]].concat(), &[]);
    let m = egg_crate_mesh(100);
    // The content is the statistics of the mesh written.
    assert_eq!(text.trim_end(), stats::compute(&m).to_string());
    let mesh_kib = (24 * m.vertex_count() + 12 * m.triangle_count()) as i64 / 1024;
    assert!(mesh_kib > 20 << 10, "{mesh_kib} KiB: too small a mesh to tell");
    // A table of every edge took about three times the mesh on top of it; the passes take an
    // eighth of its half-edges (at least 8 MiB).
    assert!(
        with < without + mesh_kib / 2,
        "--stats peaked at {with} KiB, without at {without} KiB, the mesh is {mesh_kib} KiB"
    );
    // A streamed PLY's statistics hold the positions, not the mesh: the same text, under the
    // peak of the mesh held whole without statistics.
    let ply = dir.join("crate.ply").display().to_string();
    let args = ["extract", scene_path.as_str(), "-o", &ply, "--device", "cpu", "--stats"];
    let (streamed, streamed_text) = peak_kib(&args, &[]);
    assert_eq!(streamed_text, text);
    assert!(
        streamed < without,
        "a streamed PLY with --stats peaked at {streamed} KiB, {without} KiB held whole"
    );
}
