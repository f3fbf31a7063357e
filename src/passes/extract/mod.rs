//! Isosurface extraction passes (`shaders/extract/`): classify → scan → emit, one slab of z
//! layers at a time.
//!
//! | file | what |
//! | --- | --- |
//! | [`params`] | what the shaders read besides the buffers: the `Params` uniform, the push constants, the lookup tables, the f32 inside threshold |
//! | [`pass`] | the passes: shaders, their twelve bindings and what each writes, recording a dispatch |
//! | [`scan`] | the multi-level exclusive prefix sum |
//! | [`plan`] | the GPU-free slab arithmetic: slab sizes, counts, the steps of each method |
//! | [`driver`] | records and submits the passes slab by slab: [`Extractor`], [`extract`] |
//!
//! | pass | shader | one invocation per | writes |
//! | --- | --- | --- | --- |
//! | `values` | `values.comp` | padded point | the slab's samples, gathered from the grid image into a buffer |
//! | `classify` | `classify.comp` | padded point | point mask (inside bit, crossed families); counts: per point MC/MT vertices or dual quads, per cell MC/MT triangles or dual vertices |
//! | `scan`, `scan add` | `scan.comp`, `scan_add.comp` | 4 elements | exclusive prefix sums in place |
//! | `edge vertices` | `edge_vertices.comp` | vertex | MC/MT: the vertex of a crossed edge |
//! | `marching cubes` / `marching tetrahedra` | `mc.comp` / `mt.comp` | triangle | the triangle |
//! | `dual cells` | `dual_cells.comp` | vertex | SN/DC: the vertex of an active cell |
//! | `dual quads` | `dual_quads.comp` | quad | SN/DC: two triangles |
//! | `mc33 count` | `mc33_count.comp` | crossed cell | MC33: the cell's triangles and added vertices (f64) |
//! | `mc33 emit` | `mc33_emit.comp` | crossed cell | MC33: the cell's triangles and added vertices |
//! | `mc33 fixup` | `mc33_fixup.comp` | index | MC33: added-vertex placeholders → final ids |
//!
//! The emit passes (the last four) find the owner of their output item (the point or cell
//! whose scanned count range holds it) by bisection of the scan, so their work follows the
//! output, not the grid.
//!
//! Every extraction pass binds the same twelve resources ([`bindings`], given by
//! [`ExtractIo`]) and takes [`SlabPush`]; a pass that does not use a binding still gets a
//! (dummy) buffer there. Each [`ExtractPass`] declares with its pipeline which of them it
//! writes (the table above); it reads the others, and the recorder derives the barriers
//! between passes from that.

pub mod driver;
pub mod params;
pub mod pass;
pub mod plan;
pub mod scan;

pub use driver::{extract, ExtractStats, Extractor, GpuExtractOptions, GpuMesh};
pub use params::{classify_mode, inside_threshold, ExtractParams, ExtractTables, SlabPush};
pub use pass::{
    bindings, BoundExtract, ExtractIo, ExtractPass, ExtractPasses, Mc33Passes, Slot, GROUP,
};
pub use scan::{Scan, ScanPush, SCAN_BLOCK};

use crate::gpu::GpuError;
use crate::mesh::MeshError;

/// Why a GPU extraction failed.
#[derive(Debug, thiserror::Error)]
pub enum GpuMeshError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Mesh(#[from] MeshError),
    #[error(
        "render.mesh = \"{0}\" needs 64-bit floats (shaderFloat64) on the GPU, which this device \
         lacks; extract it on the CPU (--device cpu)"
    )]
    Unsupported(&'static str),
    #[error("render.mesh = \"{0}\" has no GPU extraction; extract it on the CPU (--device cpu)")]
    CpuOnly(&'static str),
}
