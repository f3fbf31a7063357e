//! (in progress)

pub mod compare;
