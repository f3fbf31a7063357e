//! isoview's integration tests: one binary, one folder per feature (the modules below). GPU tests run on whatever Vulkan
//! device isoview picks (lavapipe in CI) and fail when none is found. Built with
//! `ISOVIEW_SKIP_GPU_TESTS=1` (a machine without Vulkan; CI never sets it), they are reported as
//! ignored: each is declared `#[gpu_test]` (crates/test-macros; see `common::gpu`), and
//! `#[gpu_test(float64)]` for the tests that need `shaderFloat64`, ignored likewise under
//! `ISOVIEW_NO_FLOAT64_TESTS=1` (see `common::need_float64`).

#[macro_use]
extern crate isoview_test_macros;

mod common;

/// Rendering: every method against its f64 reference and answers known in closed form.
mod render {
    mod analytic;
    mod clip;
    mod color;
    mod fixed_step;
    mod interpolants;
    mod mesh;
    mod methods;
    mod nan;
    mod normals;
    mod placement;
    mod projection;
    pub(crate) mod stream;
    mod surfaces;
}

/// Mesh extraction: the methods on the CPU and the GPU, threads, sharp features, memory, the
/// `extract` verb, and the content every refactor must keep.
mod mesh {
    mod cli;
    mod content;
    mod extract;
    mod gpu;
    mod interpolants;
    mod memory;
    mod parallel;
    mod sharp;
}

/// Field sources and volume formats: readers, physical space, residency, stats, refusals.
mod field {
    mod formats;
    mod mesh_source;
    mod physical;
    mod refusals;
    mod residency;
    mod sources;
    mod stats;
    mod vdb;
}

/// `compare`, goldens, and the one-copy checks of the streamed writers.
mod compare {
    mod golden;
    mod one_copy;
    mod rules;
    pub(crate) mod stream;
}

/// `serve`: its API as a user's page sees it, and the attacks it must survive.
mod serve {
    pub(crate) mod api;
    mod attacks;
}

/// The binary as a user sees it: scenes, outputs, exit codes, refusals, fuzzing.
mod cli {
    mod binary;
    mod fuzz;
    pub(crate) mod output;
    mod refusals;
    mod scene;
}

/// Several processes: `cluster::Ranks` and MPI runs.
mod cluster {
    mod mpi;
    mod ranks;
}

/// The GPU backend: error paths, struct layouts, and that unrunnable GPU tests show as ignored.
mod gpu {
    mod errors;
    mod layout;
    mod skips;
}

/// The project's own rules: documentation links and the module graph.
mod project {
    mod bench_gpu;
    mod docs;
    mod modules;
}

mod slice;
