//! Link-only crate: see build.rs.
