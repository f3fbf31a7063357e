//! (in progress)
pub mod analytic;
pub mod trilinear;
