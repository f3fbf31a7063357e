//! isoview: isosurfaces of trilinearly interpolated scalar fields, rendered with Vulkan compute.
//!
//! The pipeline, and the direction dependencies run:
//!
//! ```text
//!   scene (TOML -> validated Scene)   field (sources -> Grid of f32 samples)
//!            \                          /
//!             render (Renderer: uploads the grid, runs passes, reads back a Frame)
//!                 |            \
//!              passes           reference (f64 CPU versions of every method, for tests)
//!                 |
//!               gpu (Vulkan: device, buffers, images, pipelines; knows no isosurfaces)
//!
//!   output (Frame -> EXR / PNG, atomic writes)     compare (EXR vs EXR)
//! ```

pub mod camera;
pub mod cli;
pub mod compare;
pub mod field;
pub mod frame;
pub mod gpu;
pub mod mesh;
pub mod output;
pub mod passes;
pub mod reference;
pub mod render;
pub mod scene;
pub mod slice;

/// SPIR-V for every shader in `shaders/`, compiled by `build.rs`.
pub mod shaders {
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}

/// The isoview version, as recorded in output headers.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
