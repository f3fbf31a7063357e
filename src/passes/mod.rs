//! GPU passes: each owns its compute shader (named alike in `shaders/`) and records its
//! dispatch. A pass reads as name → shader → bindings → push constants → dispatch.

pub mod extract;
pub mod raymarch;
