//! GPU passes: each owns its compute shader (named alike in `shaders/`) and records its
//! dispatch. A pass reads as name → shader → bindings → push constants → dispatch.

pub mod analytic;
mod band;
pub use band::Band;

pub mod bricks;
pub mod extract;
pub mod mesh_render;
pub mod raymarch;
pub mod slice;
