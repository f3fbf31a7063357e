//! Compiles every `shaders/**/*.comp` to SPIR-V with shaderc and writes
//! `$OUT_DIR/shaders.rs`: one `pub const NAME: &[u8]` per shader, named after its path
//! (`shaders/extract/mc.comp` -> `EXTRACT_MC`), `ALL` listing them, and `consts`: the
//! constants Rust and GLSL share ([`SHARED`]: workgroup sizes, the brick size, method,
//! interpolant, shading and mode codes), which every shader receives as `#define`s. Written here once, a
//! Rust/GLSL mismatch cannot happen. Includes resolve against the including file's folder,
//! then `shaders/include/`. SPIR-V is never committed.

use shaderc_link as _; // links the static glslang/SPIRV-Tools archives (see that crate)

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// How a shared constant is written in GLSL.
#[derive(Clone, Copy)]
enum Glsl {
    /// A plain integer literal (`8`): usable in `layout(local_size_x = ...)`.
    Int,
    /// A `uint` literal (`8u`), for codes compared with `uint` members.
    Uint,
}

/// The constants shared by Rust (`isoview::shaders::consts::NAME: u32`) and every shader
/// (`#define NAME value`): name, value, GLSL form, meaning.
const SHARED: &[(&str, u32, Glsl, &str)] = &[
    // Workgroup sizes (`local_size_*`), which the Rust side divides dispatches by.
    (
        "RAY_GROUP",
        8,
        Glsl::Int,
        "Workgroup side (x and y) of the ray passes: raymarch, analytic and mesh_resolve.",
    ),
    (
        "SLICE_GROUP",
        8,
        Glsl::Int,
        "Workgroup side of slice.comp, also the side of its contour tiles in pixels.",
    ),
    ("BRICKS_GROUP", 4, Glsl::Int, "Workgroup side (x, y, z) of bricks.comp."),
    ("OCCUPANCY_GROUP", 64, Glsl::Int, "Workgroup size of the occupancy passes (shaders/occupancy/)."),
    ("EXTRACT_GROUP", 64, Glsl::Int, "Workgroup size of the extraction passes (shaders/extract/)."),
    ("RASTER_GROUP", 64, Glsl::Int, "Workgroup size of mesh_raster.comp."),
    // One row of workgroups of the raster's second stage per listed triangle: the most rows a
    // dispatch may have (maxComputeWorkGroupCount's guaranteed minimum).
    (
        "LARGE_CAPACITY",
        65535,
        Glsl::Uint,
        "Triangles mesh_raster.comp lists for its second stage, per band.",
    ),
    ("SCAN_PER", 16, Glsl::Uint, "Elements each invocation of scan.comp / scan_add.comp handles."),
    (
        "SCAN_BLOCK",
        1024,
        Glsl::Uint,
        "Elements one workgroup of scan.comp scans: EXTRACT_GROUP * SCAN_PER.",
    ),
    // The empty-space skipping's bricks.
    (
        "BRICK",
        8,
        Glsl::Int,
        "Cells per side of a brick of the min/max grid (empty-space skipping).",
    ),
    ("SUPER", 4, Glsl::Int, "Bricks per side of a superbrick, the min/max grid's coarser level."),
    (
        "MASK_WORDS",
        16,
        Glsl::Int,
        "32-bit words of a brick's cell mask (BRICK^3 bits), the occupancy structure's.",
    ),
    (
        "REACH_CAP",
        7,
        Glsl::Int,
        "Largest distance in bricks the occupancy structure resolves (larger reads as CAP + 1).",
    ),
    (
        "FINE",
        2,
        Glsl::Int,
        "Cells per side of a fine brick, the tricubic min/max grids' finer level (their per-cell test).",
    ),
    // The interpolant's stencil (Rust: `field::interpolant::STENCIL`, asserted equal in
    // passes/bricks.rs): the points a cell reads before its lower corner and after it.
    ("STENCIL_BELOW", 0, Glsl::Int, "Points a cell reads before its lower corner, per axis."),
    ("STENCIL_ABOVE", 1, Glsl::Int, "Points a cell reads after its lower corner, per axis."),
    // The tricubic interpolants' stencil (Rust: `cubic::Cubic`'s `Kernel::STENCIL`, asserted
    // equal in passes/bricks.rs), which their brick ranges (bricks.comp's BRICKS_CUBIC
    // variants) cover.
    ("CUBIC_STENCIL_BELOW", 1, Glsl::Int, "Points a tricubic cell reads before its lower corner, per axis."),
    ("CUBIC_STENCIL_ABOVE", 2, Glsl::Int, "Points a tricubic cell reads after its lower corner, per axis."),
    // Catmull-Rom's overshoot bound `cubic::CatmullRomWeights::KAPPA` = 37/54 as f32 bits
    // (0.68518519, rounded up; passes/bricks.rs asserts it), for bricks.comp's widening.
    (
        "CATMULL_ROM_KAPPA_BITS",
        0x3f2f_684c,
        Glsl::Uint,
        "f32 bits of Catmull-Rom's overshoot bound 37/54: values leave the samples' range by at most this times its width.",
    ),
    // The tricubic interpolants' root isolation (src/reference/analytic/bernstein.rs, which
    // explains both caps): the walk's deepest level and its node budget per root isolation.
    (
        "BERNSTEIN_DEPTH",
        16,
        Glsl::Uint,
        "Deepest level of the Bernstein root isolation: leaves are no shorter than 2^-16 of a segment.",
    ),
    (
        "BERNSTEIN_NODES",
        129,
        Glsl::Uint,
        "Node budget of one Bernstein root isolation (a node past it is a leaf).",
    ),
    // The interpolants (Rust: `field::interpolant::Interpolant::code`, one arm per variant, so
    // a new interpolant does not compile without its code here). Named `INTERPOLANT_*` so the
    // variant macros (`VARIANTS`, e.g. `INTERP_NEAREST`) stay free to be `#ifdef`ed.
    ("INTERPOLANT_TRILINEAR", 0, Glsl::Uint, "Interpolant code: trilinear."),
    ("INTERPOLANT_CUBIC_BSPLINE", 1, Glsl::Uint, "Interpolant code: the uniform cubic B-spline."),
    ("INTERPOLANT_CATMULL_ROM", 2, Glsl::Uint, "Interpolant code: Catmull-Rom."),
    ("INTERPOLANT_NEAREST", 3, Glsl::Uint, "Interpolant code: the nearest point's value."),
    ("INTERPOLANT_DEVICE", 4, Glsl::Uint, "Interpolant code: the texture unit's linear filter."),
    // llvmpipe (lavapipe) ends every loop of an invocation after 65,535 back-edges in all
    // (gallivm's LP_MAX_TGSI_LOOP_ITERATIONS), silently: a march of more samples than that
    // stopped short and lost its surface. raymarch.comp takes this many samples per back-edge
    // (an unrolled block), so 2^20 samples (scene::MAX_STEPS) take 61,681 back-edges.
    (
        "MARCH_UNROLL",
        17,
        Glsl::Int,
        "Samples raymarch.comp takes per loop back-edge (llvmpipe's 65,535 cap x 17 > 2^20).",
    ),
    // `RenderParams.shading`.
    ("SHADE_LAMBERT", 0, Glsl::Uint, "RenderParams.shading: lambert shading."),
    ("SHADE_NORMAL", 1, Glsl::Uint, "RenderParams.shading: normal shading."),
    ("SHADE_DEPTH", 2, Glsl::Uint, "RenderParams.shading: depth shading."),
    ("SHADE_STEPS", 3, Glsl::Uint, "RenderParams.shading: steps shading."),
    ("SHADE_CELLS", 4, Glsl::Uint, "RenderParams.shading: cells shading."),
    ("SHADE_SOLID", 5, Glsl::Uint, "RenderParams.shading: solid shading."),
    // `RenderParams.clip` (Rust: `vocab::Clip::MAX_PLANES`).
    ("CLIP_PLANES", 12, Glsl::Uint, "Clip planes RenderParams holds."),
    // `RenderParams.surfaces` (Rust: `scene::MAX_SURFACES`).
    ("SURFACES", 8, Glsl::Uint, "Surfaces (isovalues) RenderParams holds."),
    // `RenderParams.normals`.
    ("NORMALS_TRILINEAR", 0, Glsl::Uint, "RenderParams.normals: the trilinear gradient."),
    ("NORMALS_SMOOTH", 1, Glsl::Uint, "RenderParams.normals: interpolated point gradients."),
    // `SlabPush.mode` of classify.comp.
    ("MODE_MC", 0, Glsl::Uint, "classify.comp mode: marching cubes."),
    ("MODE_MT", 1, Glsl::Uint, "classify.comp mode: marching tetrahedra."),
    ("MODE_DUAL", 2, Glsl::Uint, "classify.comp mode: surface nets and dual contouring."),
    ("MODE_MC33", 3, Glsl::Uint, "classify.comp mode: MC33."),
    // The brick pool of `field.residency = "active"` (render/pool.rs, field.glsl).
    ("POOL_APRON", 1, Glsl::Int, "Points a pool slot holds around its brick's points, per side."),
    ("NO_PAGE", 0xffff_ffff, Glsl::Uint, "Page table entry of a brick not in the pool."),
];

/// Shaders compiled again with `#define`s: (file under `shaders/`, suffix of the variant's
/// SPIR-V name, the macros, each defined to `1`). `GRID_POOL`: the ray passes reading the grid
/// from the brick pool instead of a 3D image (`field.residency = "active"`); `GRID_BUFFER`: the
/// ray passes reading a whole grid from a storage buffer (their default, faster on llvmpipe).
const VARIANTS: &[(&str, &str, &[&str])] = &[
    ("analytic.comp", "pool", &["GRID_POOL"]),
    ("analytic.comp", "buffer", &["GRID_BUFFER"]),
    // ... and walking with the occupancy structure (passes/occupancy.rs): its default.
    ("analytic.comp", "occupancy", &["GRID_BUFFER", "OCCUPANCY"]),
    // ... in two passes: the empty bricks from every ray's start, then the listed rays' walk.
    ("analytic.comp", "occupancy_skip", &["GRID_BUFFER", "OCCUPANCY", "OCC_SKIP"]),
    ("analytic.comp", "occupancy_resume", &["GRID_BUFFER", "OCCUPANCY", "OCC_RESUME"]),
    ("raymarch.comp", "pool", &["GRID_POOL"]),
    // ... and trilinear's from a whole grid in a storage buffer, as the analytic pass's default.
    ("raymarch.comp", "buffer", &["GRID_BUFFER"]),
    // Fixed-step through the other interpolants (`field.interpolation`; field.glsl): one
    // variant each, so the trilinear march keeps its code.
    ("raymarch.comp", "bspline", &["INTERP_BSPLINE"]),
    ("raymarch.comp", "catmull_rom", &["INTERP_CATMULL_ROM"]),
    ("raymarch.comp", "nearest", &["INTERP_NEAREST"]),
    ("raymarch.comp", "device", &["INTERP_DEVICE"]),
    // The tricubic walk: B-spline as it is, Catmull-Rom with its macro.
    ("tricubic.comp", "catmull_rom", &["INTERP_CATMULL_ROM"]),
    // ... and reading a whole grid from a storage buffer, as analytic.comp's default.
    ("tricubic.comp", "buffer", &["GRID_BUFFER"]),
    ("tricubic.comp", "catmull_rom_buffer", &["INTERP_CATMULL_ROM", "GRID_BUFFER"]),
    // The tricubic walks' brick ranges: over the 4x4x4 stencils of a brick's cells, and for
    // Catmull-Rom widened by its overshoot bound (passes/bricks.rs, `Bound`).
    ("bricks.comp", "cubic", &["BRICKS_CUBIC"]),
    ("bricks.comp", "catmull_rom", &["BRICKS_CUBIC", "BRICKS_WIDEN"]),
    // Slices through the other interpolants (`slice::image`).
    ("slice.comp", "bspline", &["INTERP_BSPLINE"]),
    ("slice.comp", "catmull_rom", &["INTERP_CATMULL_ROM"]),
    ("slice.comp", "nearest", &["INTERP_NEAREST"]),
];

fn shared(name: &str) -> u32 {
    SHARED.iter().find(|c| c.0 == name).map(|c| c.1).unwrap()
}

fn collect(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            collect(&p, out);
        } else {
            out.push(p);
        }
    }
}

/// `ISOVIEW_SKIP_GPU_TESTS=1` sets the cfg `isoview_skip_gpu`, under which the GPU tests are
/// declared `#[ignore]`d: libtest reports them as ignored (with the reason), not as passed.
/// `ISOVIEW_NO_FLOAT64_TESTS=1` sets `isoview_no_float64`, which does the same for the tests
/// that need `shaderFloat64` (on a device without it they fail otherwise).
fn gpu_test_cfg() {
    for (var, cfg) in [
        ("ISOVIEW_SKIP_GPU_TESTS", "isoview_skip_gpu"),
        ("ISOVIEW_NO_FLOAT64_TESTS", "isoview_no_float64"),
    ] {
        println!("cargo::rustc-check-cfg=cfg({cfg})");
        println!("cargo::rerun-if-env-changed={var}");
        if std::env::var(var).as_deref() == Ok("1") {
            println!("cargo::rustc-cfg={cfg}");
        }
    }
}

fn main() {
    gpu_test_cfg();
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap()).join("shaders");
    let out_dir = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    println!("cargo:rerun-if-changed={}", root.display());

    let mut files = Vec::new();
    collect(&root, &mut files);

    let compiler = shaderc::Compiler::new().expect("shaderc compiler");
    let include_dir = root.join("include");
    assert_eq!(
        shared("SCAN_BLOCK"),
        shared("EXTRACT_GROUP") * shared("SCAN_PER"),
        "SCAN_BLOCK must be EXTRACT_GROUP * SCAN_PER"
    );
    for (file, suffix, defines) in VARIANTS {
        for d in *defines {
            // A variant macro that is also a shared constant would be defined in every shader,
            // so its `#ifdef` would always hold.
            assert!(
                SHARED.iter().all(|c| c.0 != *d),
                "variant {file} {suffix}: {d} is also a shared constant"
            );
        }
    }
    let mut generated = String::from("// @generated by build.rs from shaders/\n");
    generated +=
        "/// Constants shared with every shader, which receives each as a `#define` (build.rs).\n";
    generated += "pub mod consts {\n";
    for (name, value, _, doc) in SHARED {
        writeln!(generated, "    /// {doc}\n    pub const {name}: u32 = {value};").unwrap();
    }
    generated += "}\n";
    let mut all = Vec::new();
    for path in &files {
        println!("cargo:rerun-if-changed={}", path.display());
        if path.extension().and_then(|e| e.to_str()) != Some("comp") {
            continue;
        }
        let rel = path.strip_prefix(&root).unwrap().to_path_buf();
        let mut builds: Vec<(PathBuf, &[&str])> = vec![(rel.with_extension(""), &[])];
        for (file, suffix, defines) in VARIANTS {
            if rel == Path::new(file) {
                let stem = rel.with_extension("").display().to_string();
                builds.push((PathBuf::from(format!("{stem}_{suffix}")), defines));
            }
        }
        for (rel, defines) in builds {
            let name =
                compile(&compiler, path, &include_dir, &out_dir, &rel, defines, &mut generated);
            all.push((path.strip_prefix(&root).unwrap().display().to_string(), name));
        }
    }
    generated += "/// Every shader: (path under `shaders/`, SPIR-V).\npub const ALL: &[(&str, &[u8])] = &[\n";
    for (path, name) in &all {
        writeln!(generated, "    ({path:?}, {name}),").unwrap();
    }
    generated += "];\n";
    std::fs::write(out_dir.join("shaders.rs"), generated).unwrap();
}

/// Compiles one shader (with `defines` set, for a variant) into `out_dir`, adds its constant to
/// `generated` and returns the constant's name (from `rel`, the path under `shaders/` without
/// the extension).
fn compile(
    compiler: &shaderc::Compiler,
    path: &Path,
    include_dir: &Path,
    out_dir: &Path,
    rel: &Path,
    defines: &[&str],
    generated: &mut String,
) -> String {
    let source = std::fs::read_to_string(path).unwrap();
    let mut options = shaderc::CompileOptions::new().unwrap();
    options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_2 as u32);
    options.set_optimization_level(shaderc::OptimizationLevel::Performance);
    options.set_generate_debug_info();
    for (name, value, glsl, _) in SHARED {
        let literal = match glsl {
            Glsl::Int => value.to_string(),
            Glsl::Uint => format!("{value}u"),
        };
        options.add_macro_definition(name, Some(&literal));
    }
    for d in defines {
        options.add_macro_definition(d, Some("1"));
    }
    let inc = include_dir.to_path_buf();
    options.set_include_callback(move |name, _ty, from, _depth| {
        let from_dir = Path::new(from).parent().map(Path::to_path_buf).unwrap_or_default();
        for dir in [from_dir, inc.clone()] {
            let candidate = dir.join(name);
            if let Ok(content) = std::fs::read_to_string(&candidate) {
                return Ok(shaderc::ResolvedInclude {
                    resolved_name: candidate.display().to_string(),
                    content,
                });
            }
        }
        Err(format!("include {name} not found (from {from})"))
    });
    let artifact = compiler
        .compile_into_spirv(
            &source,
            shaderc::ShaderKind::Compute,
            &path.display().to_string(),
            "main",
            Some(&options),
        )
        .unwrap_or_else(|e| panic!("{e}"));
    let name: String = rel
        .to_string_lossy()
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_uppercase() } else { '_' })
        .collect();
    let spv = out_dir.join(format!("{name}.spv"));
    std::fs::write(&spv, artifact.as_binary_u8()).unwrap();
    writeln!(
        generated,
        "/// SPIR-V of `shaders/{}`.\npub const {name}: &[u8] = include_bytes!(\"{}\");",
        rel.with_extension("comp").display(),
        spv.display()
    )
    .unwrap();
    name
}
