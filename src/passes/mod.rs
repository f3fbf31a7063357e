//! GPU passes: each owns its compute shader (named alike in `shaders/`) and records its
//! dispatch. A pass reads as name → shader → bindings → push constants → dispatch: it is bound
//! once from typed inputs, then records itself into a `gpu::Recorder` with its workgroups and
//! push constants; its pipeline's `gpu::Binding`s say what it reads and writes, from which the
//! recorder derives the barriers. [`Bands`] runs the per-pixel passes (ray, mesh, slice) band by band.

pub mod analytic;
pub mod band;
pub use band::{band_rows, Band, Bands, Rounds, MAX_BAND_PIXELS};

pub mod bricks;
pub mod extract;
pub mod listed;
pub mod mesh_render;
pub mod occupancy;
pub mod raymarch;
pub mod slice;
pub mod tricubic;
pub mod voxels;
