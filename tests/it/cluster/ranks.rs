//! `cluster::Ranks`, the processes of a run as the verbs see them: one process
//! (`Ranks::Single`, every build) answers as the single-process path always did: rank 0 of 1,
//! nothing refused, the whole grid uploaded, the frame drawn straight into the sink, and its
//! extraction (the z-range path with one range) the one-process CPU mesh. The MPI side is
//! `tests/it/cluster/mpi.rs` (`--features mpi`, under `mpirun`).

use std::path::Path;
use std::sync::Arc;

use glam::DVec3;
use isoview::cluster::{Extracted, Points, Ranks};
use isoview::field::mapped::MappedGrid;
use isoview::field::{
    DataAccess, Endian, FieldSource, FieldSpec, Grid, RawSource, Residency, SampleType,
};
use isoview::mesh::MeshAlgorithm;
use isoview::mesh::{self, ExtractOptions, Mesh, MeshBudget, MeshLimits};
use isoview::render::{Collect, GpuGrid, Renderer};
use isoview::scene::Method;
use isoview::vocab::{Bounds, Inside, Placement, SharpSettings};

use crate::common::{gpu, grid_from, scene_for, scratch, Rng};

/// Rank 0 of 1, the root; its barrier returns at once.
#[test]
fn one_process_is_rank_0_of_1() {
    let r = Ranks::Single;
    assert_eq!((r.rank(), r.size()), (0, 1));
    assert!(r.is_root() && r.is_single());
    r.barrier();
}

/// Outside an MPI launcher (as `cargo test` runs), a run is one process, with or without
/// `--features mpi`.
#[test]
fn a_run_without_a_launcher_is_one_process() {
    for k in ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE", "SLURM_NTASKS"] {
        assert!(std::env::var_os(k).is_none(), "the tests run outside an MPI launcher ({k})");
    }
    let r = Ranks::from_launcher();
    assert!(r.is_single() && r.is_root(), "rank {} of {}", r.rank(), r.size());
}

/// What several ranks cannot split (fixed-step, the second crossing, extended-mc, the GPU
/// extraction) one process does: nothing is refused.
#[test]
fn one_process_refuses_nothing_the_ranks_refuse() {
    let grid = sphere([9, 9, 9]);
    let mut scene = scene_for(&grid, DVec3::new(0.0, 0.0, 4.0), 8, Method::FixedStep);
    scene.render.crossing = 2;
    scene.render.mesh = MeshAlgorithm::ExtendedMc;
    assert_eq!(Ranks::Single.refuses(&scene), None);
    assert_eq!(Ranks::Single.refuses_extract(&scene, true), None);
}

/// One process's extraction through `Ranks` (one z-range holding every cell layer, from the
/// sampled grid or read from the mapped file) is the multi-threaded CPU mesh bit for bit:
/// positions, normals, numbering, triangle order, quads kept or not.
#[test]
fn one_process_extracts_the_one_process_mesh() {
    let dir = scratch("ranks-extract");
    let mut rng = Rng::new(24);
    let sharp = SharpSettings::default();
    let methods = [
        MeshAlgorithm::MarchingCubes,
        MeshAlgorithm::Mc33,
        MeshAlgorithm::SurfaceNets,
        MeshAlgorithm::DualContouring,
        MeshAlgorithm::MarchingTetrahedra,
        MeshAlgorithm::DualContouringQef,
    ];
    for (c, algo) in methods.into_iter().enumerate() {
        let grid = grid_from([14 + c, 11, 9 + 2 * c], DVec3::splat(-1.0), DVec3::ONE, |p| {
            (p - DVec3::new(0.1, -0.05, 0.2)).length() + 0.1 * (3.0 * p.x).sin()
        });
        let file = dir.join(format!("g{c}.raw"));
        write_raw(&file, &grid);
        let mapped = MappedGrid::open(&raw_spec(&file, &grid)).unwrap().unwrap();
        let iso = rng.range(0.5, 0.75);
        let inside = [Inside::Below, Inside::Above][c % 2];
        let opts = ExtractOptions { keep_quads: c % 2 == 0, ..Default::default() };
        let whole = mesh::extract(
            &grid,
            &mesh::Request::new(iso, inside, algo).with_opts(opts).with_sharp(sharp),
            &mesh::MeshBudget::unlimited(),
        )
        .unwrap();
        assert!(whole.triangle_count() > 50, "{algo:?}: too few triangles");
        let x = mesh::Request::new(iso, inside, algo).with_opts(opts).with_sharp(sharp);
        for points in [Points::Sampled(&grid), Points::Mapped(&mapped)] {
            let budget = Arc::new(MeshBudget::unlimited());
            let mesh = whole_mesh(Ranks::Single.extract(points, &x, &budget));
            assert_eq!(mesh, whole, "{algo:?}");
        }
    }
}

/// The budget counts the one process's range as it is joined: past the cap, the one-line
/// message of `MeshError::OverCap`.
#[test]
fn one_process_extraction_keeps_the_mesh_cap() {
    let grid = sphere([24, 24, 24]);
    let x = mesh::Request::new(0.6, Inside::Below, MeshAlgorithm::MarchingCubes);
    let budget = Arc::new(MeshBudget::new(MeshLimits { max_bytes: 1024 }));
    match Ranks::Single.extract(Points::Sampled(&grid), &x, &budget) {
        Err(e) => assert!(e.contains("over the cap of"), "{e}"),
        Ok(_) => panic!("a mesh of {} bytes at most was allowed to grow past it", 1024),
    }
}

/// One process uploads the whole grid, reads no block of a mapped file (it samples the field
/// or pools its bricks), and draws straight into the sink: the frame of `Renderer::render_to`
/// on `GpuGrid::upload`, bit for bit, with no compositing time.
#[gpu_test]
fn one_process_renders_straight_into_the_sink() {
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let grid = sphere([12, 10, 11]);
    let mut scene = scene_for(&grid, DVec3::new(0.4, 0.7, 3.5), 24, Method::Analytic);
    scene.surface.isovalue = 0.6;

    let direct = GpuGrid::upload(&ctx, &grid).unwrap();
    let mut expected = Collect::default();
    renderer.render_to(&scene, &grid, &direct, 0.0, &mut expected).unwrap();
    let expected = expected.into_frame().unwrap();

    let ranks = Ranks::Single;
    let file = scratch("ranks-render").join("g.raw");
    write_raw(&file, &grid);
    let block = ranks.upload_mapped_block(&ctx, &raw_spec(&file, &grid)).unwrap();
    assert!(block.is_none(), "one process read a block of the mapped file");
    let uploaded = ranks.upload(&ctx, &grid).unwrap();
    let mut sink = Collect::default();
    let compositing =
        ranks.render_to(&mut renderer, &scene, (&grid, &uploaded), 0.0, &mut sink).unwrap();
    assert_eq!(compositing, None);
    let frame = sink.into_frame().unwrap();
    assert!(frame.pixels.iter().any(|p| p.depth.is_finite()), "the sphere was not hit");
    // Bits, not `==`: a miss's `value` is NaN.
    let bits = |f: &isoview::frame::Frame| bytemuck::cast_slice::<_, u8>(&f.pixels).to_vec();
    assert!(bits(&frame) == bits(&expected), "the frames differ");
    assert_eq!((frame.width, frame.height, &frame.info), (24, 24, &expected.info));
}

/// A sphere-like field over [-1, 1]³.
fn sphere(dims: [usize; 3]) -> Grid {
    grid_from(dims, DVec3::splat(-1.0), DVec3::ONE, |p| p.length())
}

fn whole_mesh(done: Result<Extracted, String>) -> Mesh {
    match done {
        Ok(Extracted::Whole(mesh, _, _)) => *mesh,
        Ok(Extracted::Sent) => panic!("one process sent its mesh away"),
        Ok(Extracted::FailedElsewhere) => panic!("one process failed elsewhere"),
        Err(e) => panic!("{e}"),
    }
}

fn write_raw(path: &Path, grid: &Grid) {
    let bytes: Vec<u8> = grid.values.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(path, bytes).unwrap();
}

/// The spec of a raw file holding `grid`.
fn raw_spec(path: &Path, grid: &Grid) -> FieldSpec {
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
        residency: Residency::Whole,
        nan: Default::default(),
        interpolation: Default::default(),
    }
}
