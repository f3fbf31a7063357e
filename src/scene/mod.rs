//! Scene files: TOML → parsed → validated → an immutable [`Scene`].
//!
//! The keys, their defaults and their meaning are the interface contract
//! (`README.md`, "Scene format"). Errors name `file:line:col` and the key.

mod types;

pub use types::*;
