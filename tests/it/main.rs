//! isoview's integration tests: one binary, topics as modules. GPU tests run on whatever Vulkan
//! device isoview picks (lavapipe in CI) and fail when none is found. Built with
//! `ISOVIEW_SKIP_GPU_TESTS=1` (a machine without Vulkan; CI never sets it), they are reported as
//! ignored: each is declared `#[gpu_test]` (crates/test-macros; see `common::gpu`), and
//! `#[gpu_test(float64)]` for the tests that need `shaderFloat64`, ignored likewise under
//! `ISOVIEW_NO_FLOAT64_TESTS=1` (see `common::need_float64`).

#[macro_use]
extern crate isoview_test_macros;

mod analytic;
mod cli;
mod clip;
mod cluster;
mod color;
mod common;
mod compare;
mod compare_stream;
mod docs;
mod extract_cli;
mod extract_gpu;
mod extract_memory;
mod formats;
mod fuzz;
mod golden;
mod gpu_errors;
mod gpu_skips;
mod layout;
mod mesh;
mod mesh_content;
mod mesh_field;
mod mesh_parallel;
mod mesh_render;
mod methods;
mod modules;
mod nan;
mod normals;
mod one_copy;
mod output;
mod physical;
mod placement;
mod projection;
mod ranks;
mod reliability_formats;
mod reliability_io;
mod render;
mod residency;
mod scene;
mod serve;
mod serve_attacks;
mod sharp;
mod slice;
mod sources;
mod stats;
mod stream;
mod surfaces;
