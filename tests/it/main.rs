//! isoview's integration tests: one binary, topics as modules. GPU tests run on whatever Vulkan
//! device isoview picks (lavapipe in CI) and fail when none is found; set
//! `ISOVIEW_SKIP_GPU_TESTS=1` to skip them on a machine without Vulkan (CI never does).

mod analytic;
mod cli;
mod common;
mod compare;
mod extract_cli;
mod extract_gpu;
mod fuzz;
mod golden;
mod layout;
mod mesh;
mod mesh_field;
mod mesh_parallel;
mod mesh_render;
mod modules;
mod output;
mod render;
mod scene;
mod slice;
mod sources;
