//! `field.residency = "active"`: a raw/npy grid read from its file in parts, only the bricks its isovalues
//! need uploaded into the brick pool. The mapped reads equal the in-memory readers, the brick
//! scan equals the GPU's min/max grid, and every ray render from the pool is **bit for bit** the
//! whole grid's (every channel), over random fields, cameras and settings, with bricks left out.

use std::path::Path;

use glam::DVec3;
use isoview::field::mapped::MappedGrid;
use isoview::field::{
    DataAccess, Endian, FieldSource, FieldSpec, Grid, GridLimits, NpySource, RawSource, Residency,
    SampleType,
};
use isoview::frame::Pixel;
use isoview::render::pool;
use isoview::render::{Collect, Renderer};
use isoview::scene::{Inside, Method, Normals, Scene};
use isoview::vocab::{Bounds, Placement};

use crate::common::*;

/// `grid` written as a little-endian f32 raw file, x fastest.
fn write_raw(path: &Path, grid: &Grid) {
    let bytes: Vec<u8> = grid.values.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(path, bytes).unwrap();
}

/// The spec of a raw file holding `grid`, with the given residency.
fn raw_spec(path: &Path, grid: &Grid, residency: Residency) -> FieldSpec {
    FieldSpec {
        source: FieldSource::Raw(RawSource {
            path: path.to_path_buf(),
            dims: grid.dims,
            dtype: SampleType::F32,
            endian: Endian::Little,
            access: DataAccess::Any,
        }),
        resolution: grid.dims,
        bounds: Bounds { min: grid.min, max: grid.max },
        placement: Placement::IDENTITY,
        residency,
        nan: Default::default(),
        interpolation: Default::default(),
    }
}

/// A wavy field whose level sets are closed shells through several bricks, on a box that is not
/// a cube and dims that leave partial bricks.
fn shells(rng: &mut Rng, dims: [usize; 3]) -> Grid {
    let k = rng.unit_vector() * rng.range(4.0, 9.0);
    let c = DVec3::new(rng.range(-0.2, 0.2), rng.range(-0.2, 0.2), rng.range(-0.2, 0.2));
    grid_from(dims, DVec3::new(-1.0, -0.9, -1.1), DVec3::new(1.0, 1.2, 0.9), |p| {
        (p - c).length() + 0.06 * k.dot(p).sin()
    })
}

/// Renders `scene` from the whole grid and from the pool of the same grid in a raw file; both
/// frames' pixels, and the residency used.
fn both(
    ctx: &std::sync::Arc<isoview::gpu::Context>,
    renderer: &mut Renderer,
    scene: &Scene,
    grid: &Grid,
    file: &Path,
) -> (Vec<Pixel>, Vec<Pixel>, pool::Residency) {
    // The pool walks brick by brick; so does the whole grid's render here (`steps` compares;
    // the occupancy walk's equality with it is render::analytic's test).
    let accel = std::mem::replace(&mut renderer.accel, isoview::render::Accel::Plain);
    let whole = renderer.render(scene, grid, 0.0).unwrap().pixels;
    renderer.accel = accel;
    let mut mapped_scene = scene.clone();
    mapped_scene.field = raw_spec(file, grid, Residency::Active);
    let mapped = pool::mapped_for(&mapped_scene, &GridLimits::default()).unwrap().unwrap();
    let pooled = pool::upload_for(ctx, &mapped_scene, &*mapped, &GridLimits::default()).unwrap();
    let residency = pooled.gpu.residency().unwrap().clone();
    let mut sink = Collect::default();
    renderer.render_to(&mapped_scene, &pooled.shape, &pooled.gpu, 0.0, &mut sink).unwrap();
    (whole, sink.into_frame().unwrap().pixels, residency)
}

fn same_bits(a: &[Pixel], b: &[Pixel]) -> Option<usize> {
    a.iter().zip(b).position(|(x, y)| bytemuck::bytes_of(x) != bytemuck::bytes_of(y))
}

/// Analytic and fixed-step, with and without skipping, counting crossings or not, the second
/// crossing, smooth normals, several isovalues, inside above: every pixel of the pool render has
/// the whole grid's bits, and each case leaves bricks out of the pool.
#[gpu_test]
fn pool_renders_equal_whole_grid_renders_bit_for_bit() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let dir = scratch("residency-renders");
    let mut rng = Rng::new(1414);
    let mut left_out = 0;
    for c in 0..10 {
        let method = if c % 3 == 2 { Method::FixedStep } else { Method::Analytic };
        // Fixed-step keeps the neighbours of active bricks too: a finer grid, so some are
        // left out.
        let dims = match method {
            Method::FixedStep => [57 + c, 53, 61 - c],
            _ => [33 + 3 * c, 29 + c, 41 - 2 * c],
        };
        let grid = shells(&mut rng, dims);
        let file = dir.join(format!("g{c}.raw"));
        write_raw(&file, &grid);
        let eye = random_eye(&mut rng, &grid, c == 4);
        let mut scene = scene_for(&grid, eye, 48, method);
        scene.surface.isovalue = rng.range(0.35, 0.6);
        scene.render.skip = c % 2 == 0;
        scene.render.count_crossings = c % 4 < 2;
        scene.render.steps = 96;
        if c == 3 {
            scene.render.count_crossings = false;
            scene.render.crossing = 2;
        }
        if c % 3 == 1 || c == 8 {
            scene.render.normals = Normals::Smooth;
        }
        if c == 5 || c == 8 {
            scene.surface.inside = Inside::Above;
        }
        if c >= 6 {
            let isos = [rng.range(0.3, 0.4), rng.range(0.45, 0.55), rng.range(0.6, 0.7)];
            scene.surface.isovalue = isos[1];
            scene.surface.more[..2].copy_from_slice(&[isos[0], isos[2]]);
            scene.surface.count = 3;
        }
        let (whole, pooled, residency) = both(&ctx, &mut renderer, &scene, &grid, &file);
        assert!(whole.iter().filter(|p| p.is_hit()).count() > 100, "case {c}: too few hits");
        assert!(
            residency.resident.len() < residency.bricks(),
            "case {c}: every brick resident, nothing tested"
        );
        left_out += residency.bricks() - residency.resident.len();
        if let Some(i) = same_bits(&whole, &pooled) {
            panic!(
                "case {c} ({method:?}): pixel {i} differs: whole {:?}, pool {:?}",
                whole[i], pooled[i]
            );
        }
    }
    assert!(left_out > 100, "only {left_out} bricks left out over all cases");
}

/// The brick scan of the mapped file equals the GPU's min/max grid's CPU reference, and reading
/// boxes through the map equals the in-memory reader for C-order npy of another dtype and a
/// big-endian raw file.
#[test]
fn mapped_reads_equal_the_in_memory_readers() {
    let dir = scratch("residency-reads");
    let mut rng = Rng::new(5);
    let dims = [19, 11, 26];
    // An i16 C-order npy: element [i, j, k] at k + nz (j + ny i).
    let n: usize = dims.iter().product();
    let values: Vec<i16> = (0..n).map(|_| rng.range(-3000.0, 3000.0) as i16).collect();
    let mut npy = b"\x93NUMPY\x01\x00".to_vec();
    let mut header = format!(
        "{{'descr': '<i2', 'fortran_order': False, 'shape': ({}, {}, {}), }}",
        dims[0], dims[1], dims[2]
    );
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    npy.extend((header.len() as u16).to_le_bytes());
    npy.extend(header.as_bytes());
    for v in &values {
        npy.extend(v.to_le_bytes());
    }
    let path = dir.join("c.npy");
    std::fs::write(&path, npy).unwrap();
    let source = NpySource::open(&path, &GridLimits::default(), &DataAccess::Any).unwrap();
    let whole = source.read(&GridLimits::default()).unwrap();
    let spec = FieldSpec {
        source: FieldSource::Npy(source),
        resolution: dims,
        bounds: Bounds { min: DVec3::ZERO, max: DVec3::ONE },
        placement: Placement::IDENTITY,
        residency: Residency::Active,
        nan: Default::default(),
        interpolation: Default::default(),
    };
    let grid = Grid { dims, min: DVec3::ZERO, max: DVec3::ONE, values: whole };
    let mapped = MappedGrid::open(&spec).unwrap().unwrap();
    assert_eq!(mapped.read_box([0, 0, 0], dims).unwrap(), grid.values);
    let part = mapped.read_box([3, 2, 5], [7, 4, 9]).unwrap();
    for k in 0..9 {
        for j in 0..4 {
            for i in 0..7 {
                assert_eq!(part[i + 7 * (j + 4 * k)], grid.at(3 + i, 2 + j, 5 + k));
            }
        }
    }
    let brick = isoview::passes::bricks::BRICK;
    assert_eq!(mapped.brick_ranges(brick).unwrap(), isoview::passes::bricks::reference(&grid));

    // Big-endian f64 raw, x fastest.
    let g = random_grid(&mut rng, [10, 17, 9]);
    let bytes: Vec<u8> = g.values.iter().flat_map(|&v| (v as f64).to_be_bytes()).collect();
    let raw = dir.join("b.raw");
    std::fs::write(&raw, bytes).unwrap();
    let mut spec = raw_spec(&raw, &g, Residency::Active);
    if let FieldSource::Raw(r) = &mut spec.source {
        (r.dtype, r.endian) = (SampleType::F64, Endian::Big);
    }
    let mapped = MappedGrid::open(&spec).unwrap().unwrap();
    assert_eq!(mapped.read_box([0, 0, 0], g.dims).unwrap(), g.values);
    assert_eq!(mapped.brick_ranges(brick).unwrap(), isoview::passes::bricks::reference(&g));
}

/// A slot holds its brick's points and one more on every side, clamped at the grid's faces.
#[test]
fn slots_hold_the_brick_and_its_apron() {
    let dir = scratch("residency-slots");
    let mut rng = Rng::new(9);
    let g = random_grid(&mut rng, [21, 12, 18]);
    let file = dir.join("s.raw");
    write_raw(&file, &g);
    let mapped = MappedGrid::open(&raw_spec(&file, &g, Residency::Active)).unwrap().unwrap();
    let (b, s) = (isoview::passes::bricks::BRICK as i64, pool::SLOT);
    for brick in [[0, 0, 0], [1, 1, 2], [2, 0, 1]] {
        let slot = pool::slot(&mapped, brick).unwrap();
        assert_eq!(slot.len(), s * s * s);
        for (n, &v) in slot.iter().enumerate() {
            let l = [n % s, (n / s) % s, n / (s * s)];
            let p = [0, 1, 2].map(|a| {
                (brick[a] as i64 * b - pool::APRON as i64 + l[a] as i64)
                    .clamp(0, g.dims[a] as i64 - 1) as usize
            });
            assert_eq!(v, g.at(p[0], p[1], p[2]), "brick {brick:?} slot point {l:?}");
        }
    }
}

/// Residency: a brick is left out only when clear of every isovalue by the margin; fixed-step
/// keeps every neighbour of an active brick.
#[test]
fn residency_keeps_active_bricks_and_fixed_step_neighbours() {
    let dims = [8 * 4 + 1, 9, 9]; // 4 x 1 x 1 bricks
    let ranges =
        pool::BrickRanges::from_dense(dims, &[[0.0, 1.0], [2.0, 3.0], [2.0, 3.0], [2.0, 3.0]]);
    let r = pool::Residency::select(&ranges, &[0.5], false);
    assert_eq!((r.active, r.resident.clone()), (1, vec![[0, 0, 0]]));
    let pages: Vec<u32> = (0..4).map(|x| r.page([x, 0, 0])).collect();
    assert_eq!(pages, vec![0, pool::NO_PAGE, pool::NO_PAGE, pool::NO_PAGE]);
    let r = pool::Residency::select(&ranges, &[0.5], true);
    assert_eq!(r.resident, vec![[0, 0, 0], [1, 0, 0]]);
    // Two isovalues: the second makes brick 2.. active.
    let r = pool::Residency::select(&ranges, &[0.5, 2.5], false);
    assert_eq!(r.active, 4);
    // Within the margin of the isovalue counts as active: 2.0 - 1.999 < 2/1024 (2 + 1.999).
    let r = pool::Residency::select(&ranges, &[1.999], false);
    assert_eq!(r.active, 3);
    // A superbrick clear of the isovalue holds no block: its bricks read as its range.
    let r = pool::Residency::select(&ranges, &[5.0], false);
    assert_eq!((r.active, r.pages.len(), r.ranges.len()), (0, 1, 1));
    assert_eq!(r.page([0, 0, 0]), pool::NO_PAGE);
    assert!(pool::clear([2.0, 3.0], 1.99));
}

/// Over the cap: one line naming what the pool would need; the mesh method is refused; both from
/// the command line, exit 2.
#[gpu_test]
fn pool_errors_are_one_line() {
    let dir = scratch("residency-cli");
    let mut rng = Rng::new(3);
    let g = shells(&mut rng, [40, 40, 40]);
    write_raw(&dir.join("f.raw"), &g);
    let scene = write(
        &dir,
        "s.toml",
        "[image]\nwidth = 16\nheight = 16\n[field]\nsource = \"raw\"\npath = \"f.raw\"\n\
         dims = [40, 40, 40]\ndtype = \"f32\"\nresidency = \"active\"\n[surface]\nisovalue = 0.5\n",
    );
    let out = dir.join("o.exr");
    let o =
        isoview(&["render", &scene, "-o", out.to_str().unwrap()], &[("ISOVIEW_MAX_GRID_MIB", "1")]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("40x40x40 grid read from the file in parts"), "{}", stderr(&o));
    let o = isoview(
        &["render", &scene, "-o", out.to_str().unwrap(), "--set", "render.method=\"mesh\""],
        &[],
    );
    assert_fails(
        &o,
        2,
        &["field.residency = \"active\": render.method = \"mesh\" needs the whole grid"],
    );
    // A small grid the user put in the pool: the refusal names the key that did it (it
    // said "a grid over the memory cap", which this grid is not) and how to read it whole.
    let o = isoview(
        &[
            "render",
            &scene,
            "-o",
            out.to_str().unwrap(),
            "--set",
            "field.interpolation=\"cubic-bspline\"",
        ],
        &[],
    );
    assert_fails(
        &o,
        2,
        &["the brick pool (field.residency = \"active\", or a grid over the memory cap) holds \
           trilinear cells only, not \"cubic-bspline\" ones; read the grid whole: under the \
           memory cap (ISOVIEW_MAX_GRID_MIB) with field.residency = \"auto\" (the default) or \
           \"whole\""],
    );
    let one = pool::BrickRanges::from_dense([9, 9, 9], &[[0.0, 1.0]]);
    let e = pool::Residency::select(&one, &[0.5], false)
        .check(&GridLimits { max_bytes: 1024 }, "f.raw")
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "f.raw: the bricks the isovalues need (1 of 1 bricks of 8^3 cells) and the brick tables \
         take 6.0 KiB on the device, over the cap of 1 KiB; raise the cap with \
         ISOVIEW_MAX_GRID_MIB=1 (or GridLimits::max_bytes)"
    );
    // An 8192^3 grid's tables alone (2^30 bricks, 12 GiB) are refused before any scan.
    let e = pool::check_tables([8193, 8193, 8193], &GridLimits::default(), "big.raw")
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "big.raw: a grid of 8193x8193x8193 points has 1073741824 bricks of 8^3 cells, whose \
         tables (min/max and page table, 12 bytes a brick) take 12288 MiB on the device, over \
         the cap of 1024 MiB; raise the cap with ISOVIEW_MAX_GRID_MIB=12288 (or \
         GridLimits::max_bytes)"
    );
}

/// Extraction from the map, a window of a few layers at a time, equals the whole grid's
/// multi-threaded extraction bit for bit (positions, normals, numbering, triangle order) for
/// every method it splits, with ranges wholly outside joined without being extracted.
#[test]
fn mapped_extraction_equals_the_whole_grids() {
    use isoview::mesh::MeshAlgorithm;
    use isoview::mesh::{self, ExtractOptions};
    use isoview::vocab::SharpSettings;
    let dir = scratch("residency-extract");
    let mut rng = Rng::new(77);
    let sharp = SharpSettings::default();
    for (c, algo) in [
        MeshAlgorithm::MarchingCubes,
        MeshAlgorithm::Mc33,
        MeshAlgorithm::SurfaceNets,
        MeshAlgorithm::DualContouring,
        MeshAlgorithm::MarchingTetrahedra,
    ]
    .into_iter()
    .enumerate()
    {
        // Shells in the lower part of a tall box: the upper layers are all outside.
        let grid =
            grid_from([23 + c, 19, 57], DVec3::splat(-1.0), DVec3::new(1.0, 1.0, 4.0), |p| {
                let k = DVec3::new(3.0, 4.0, 5.0);
                (p - DVec3::new(0.1, 0.0, 0.2)).length() + 0.05 * k.dot(p).sin()
            });
        let file = dir.join(format!("e{c}.raw"));
        write_raw(&file, &grid);
        let mapped = MappedGrid::open(&raw_spec(&file, &grid, Residency::Active)).unwrap().unwrap();
        let iso = rng.range(0.5, 0.8);
        let inside = [Inside::Below, Inside::Above][c % 2];
        let opts = ExtractOptions::default();
        let whole = mesh::extract(
            &grid,
            &mesh::Request::new(iso, inside, algo).with_opts(opts).with_sharp(sharp),
            &mesh::MeshBudget::unlimited(),
        )
        .unwrap();
        let x = mesh::Request::new(iso, inside, algo).with_opts(opts).with_sharp(sharp);
        // Windows of about 5 point layers: many ranges, most of the upper ones skipped.
        let window = 5 * grid.dims[0] * grid.dims[1] * 4;
        let from_map = isoview::mesh::mapped::extract_mapped(&mapped, &x, window).unwrap();
        assert!(whole.triangle_count() > 100, "{algo:?}: too few triangles");
        assert_eq!(from_map, whole, "{algo:?}");
    }
}

/// `isoview extract` with `field.residency = "active"` writes the whole-grid extraction's file
/// byte for byte (one surface and several), and says it streamed the file.
#[test]
fn extract_command_streams_the_mapped_file() {
    let dir = scratch("residency-extract-cli");
    let mut rng = Rng::new(12);
    let g = shells(&mut rng, [30, 26, 47]);
    write_raw(&dir.join("f.raw"), &g);
    let scene = write(
        &dir,
        "s.toml",
        "[field]\nsource = \"raw\"\npath = \"f.raw\"\ndims = [30, 26, 47]\ndtype = \"f32\"\n\
         [surface]\nisovalues = [0.45, 0.6]\n[render]\nmesh = \"mc33\"\n",
    );
    let path = |n: &str| dir.join(n).to_str().unwrap().to_string();
    let whole = isoview(&["--device", "cpu", "extract", &scene, "-o", &path("w.ply")], &[]);
    assert!(whole.status.success(), "{}", stderr(&whole));
    let set = "field.residency=\"active\"";
    let mapped = isoview(&["extract", &scene, "-o", &path("m.ply"), "--set", set], &[]);
    assert!(mapped.status.success(), "{}", stderr(&mapped));
    assert!(stderr(&mapped).contains("streamed from the 30x26x47 grid read from the file in parts"));
    let (w, m) = (std::fs::read(path("w.ply")).unwrap(), std::fs::read(path("m.ply")).unwrap());
    assert!(w.len() > 10_000 && w == m, "the PLY files differ ({} and {} bytes)", w.len(), m.len());
}
