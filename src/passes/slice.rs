//! The slice pass (`shaders/slice.comp`): one invocation per pixel of a band of rows of a
//! slice picture, writing the field's value on the plane, its colour from a diverging colormap
//! centred on the isovalue, and the contour lines over it. `slice::image` runs it ([`SlicePass`]);
//! `slice::reference` is its f64 mirror.

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};

use super::Band;
use crate::field::interpolant::Interpolant;
use crate::gpu::{
    grid_groups, Binding, Buffer, ComputePipeline, Context, Dispatch, GpuError, Image3d, Recorder,
    Resource,
};
use crate::shaders;

/// Workgroup size (`local_size_x/y`), also the side of the contour tiles in pixels.
pub const GROUP: u32 = shaders::consts::SLICE_GROUP;

/// params (uniform), grid (3D image), pixels, colormap, tile starts, tile segment lists,
/// segments (storage).
pub const BINDINGS: [Binding; 7] = [
    Binding::Uniform,
    Binding::Sampled,
    Binding::Write,
    Binding::Read,
    Binding::Read,
    Binding::Read,
    Binding::Read,
];

/// std140 mirror of `struct SliceParams` in the shader (vec4 members only, so std140 = C
/// layout). Field meanings are documented on the GLSL side.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SliceParams {
    pub axes: [u32; 4],
    pub dims: [i32; 4],
    pub image: [u32; 4],
    pub plane: [f32; 4],
    pub scale: [f32; 4],
    pub line: [f32; 4],
}

/// std430 mirror of `struct SlicePixel` (32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SlicePixel {
    /// Linear RGBA: the colormap with the contour lines over it; A = 1.
    pub rgba: [f32; 4],
    /// The field on the plane.
    pub value: f32,
    /// Coverage of the contour lines, [0, 1].
    pub contour: f32,
    pub pad: [f32; 2],
}

const _: () = {
    assert!(std::mem::size_of::<SliceParams>() == 6 * 16);
    assert!(std::mem::offset_of!(SliceParams, plane) == 3 * 16);
    assert!(std::mem::offset_of!(SliceParams, line) == 5 * 16);
    assert!(std::mem::size_of::<SlicePixel>() == 32);
    assert!(std::mem::offset_of!(SlicePixel, value) == 16);
    assert!(std::mem::offset_of!(SlicePixel, contour) == 20);
};

/// The pass for `interp` (its variant of `slice.comp`, `Interpolant::slice_shader`).
pub fn pipeline(ctx: &Arc<Context>, interp: Interpolant) -> Result<ComputePipeline, GpuError> {
    let (name, spirv) = interp.slice_shader().ok_or_else(|| {
        GpuError::Bug(format!("no slice pass reads \"{}\" fields", interp.name()))
    })?;
    ComputePipeline::new(ctx, name, spirv, &BINDINGS, std::mem::size_of::<Band>() as u32)
}

/// What the slice pass reads, and the band of pixels it writes.
pub struct SliceInputs<'a> {
    /// [`SliceParams`] (uniform).
    pub params: &'a Buffer,
    pub grid: &'a Image3d,
    /// The band's [`SlicePixel`]s, written.
    pub pixels: &'a Buffer,
    pub colormap: &'a Buffer,
    /// The contour segments bucketed by tile (CSR): tile starts, tile segment lists, segments.
    pub tile_starts: &'a Buffer,
    pub tile_segments: &'a Buffer,
    pub segments: &'a Buffer,
}

/// The slice pass bound to its inputs; records one band at a time.
pub struct SlicePass<'a> {
    pipeline: &'a ComputePipeline,
    set: Dispatch,
    /// Keeps the bound buffers borrowed while the set refers to them.
    _inputs: SliceInputs<'a>,
}

impl<'a> SlicePass<'a> {
    pub fn new(pipeline: &'a ComputePipeline, inputs: SliceInputs<'a>) -> Result<Self, GpuError> {
        let i = &inputs;
        let set = pipeline.bind(&[
            Resource::Uniform(i.params),
            Resource::Sampled(i.grid),
            Resource::Storage(i.pixels),
            Resource::Storage(i.colormap),
            Resource::Storage(i.tile_starts),
            Resource::Storage(i.tile_segments),
            Resource::Storage(i.segments),
        ])?;
        Ok(SlicePass { pipeline, set, _inputs: inputs })
    }

    /// The pass's name (its pipeline's).
    pub fn name(&self) -> &str {
        &self.pipeline.name
    }

    /// Records the band: one invocation per pixel, [`GROUP`]² pixels (one contour tile) per
    /// workgroup, the band as push constants.
    pub fn record(&self, rec: &mut Recorder, width: u32, band: Band) {
        let groups = grid_groups([width, band.rows, 1], [GROUP, GROUP, 1]);
        rec.dispatch(self.pipeline, &self.set, bytemuck::bytes_of(&band), groups);
    }
}
