//! isoview's integration tests: one binary, topics as modules.

mod mesh;
