//! CPU references in f64 of every GPU method. They read the same `f32` grid values (widened)
//! and follow the same steps as the shaders, so tests can compare GPU output to them on random
//! inputs with stated tolerances.

pub mod analytic;
pub mod field;
pub mod fixed_step;
pub mod mesh;
pub mod shade;
pub mod skipping;
pub mod trilinear;
pub mod voxels;
