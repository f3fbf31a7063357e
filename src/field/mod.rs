//! Scalar fields sampled on a regular grid.
//!
//! A [`Grid`] holds `f32` samples at the points of a regular lattice over an axis-aligned box.
//! Inside each cell the field is the trilinear interpolant of the cell's 8 corner values; outside
//! the box there is no field. Every source (`sdf`, `corners`, `npy`, `raw`, `expr`) produces a
//! `Grid`; the renderer, the CPU references and the mesh extractors only ever see a `Grid`.

mod grid;
mod spec;

pub use grid::Grid;
pub use spec::{FieldSource, FieldSpec};
