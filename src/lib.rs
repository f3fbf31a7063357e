//! isoview: isosurfaces of trilinearly interpolated scalar fields, rendered with Vulkan compute.
//!
//! The pipeline, and the one direction dependencies run (no cycle: `tests/it/project/modules.rs`):
//!
//! ```text
//!   vocab (Bounds, Inside, ...: plain types every stage speaks)
//!     <- field (sources -> Grid of f32 samples)
//!     <- mesh (the extraction methods' registry, CPU extraction references, export)
//!     <- scene (TOML -> validated Scene)
//!     <- passes (one GPU pass per file with its shader; extract/driver: the mesh on the GPU)
//!     <- extract (a scene's surfaces: CPU or GPU chosen once, one context, one upload)
//!     <- render (Renderer: uploads the grid, runs passes in bands, reads back a Frame)
//!     <- slice, probe (a pixel's ray through the f64 references)
//!     <- serve (the live page: HTTP, render thread) <- cli
//!   gpu = the isoview-gpu crate (Vulkan: device, buffers, images, pipelines; no isosurfaces)
//!   reference (f64 CPU versions of every method, for tests)
//!   output (Frame -> EXR / PNG, atomic writes)     compare (EXR vs EXR)
//!   cluster (the processes of a run: one, or MPI ranks; render and extract across them)
//! ```

pub mod bench;
pub mod camera;
pub mod cli;
pub mod cluster;
pub mod compare;
pub mod extract;
pub mod field;
pub mod frame;
/// The Vulkan backend, a crate of its own (`crates/gpu`): it cannot use isoview's modules.
pub use isoview_gpu as gpu;
pub mod mesh;
pub mod output;
pub mod passes;
pub mod probe;
pub mod reference;
pub mod render;
pub mod scene;
pub mod serve;
pub mod slice;
pub mod vocab;

/// SPIR-V for every shader in `shaders/`, compiled by `build.rs`.
pub mod shaders {
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}

/// The isoview version, as recorded in output headers.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
