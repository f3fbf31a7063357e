//! The slice pass (`shaders/slice.comp`): one invocation per pixel of a band of rows of a
//! slice picture, writing the field's value on the plane, its colour from a diverging colormap
//! centred on the isovalue, and the contour lines over it. `slice::image` runs it;
//! `slice::reference` is its f64 mirror.

use std::sync::Arc;

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::Band;
use crate::gpu::{ComputePipeline, Context, GpuError};
use crate::shaders;

/// Workgroup size (`local_size_x/y`), also the side of the contour tiles in pixels.
pub const GROUP: u32 = shaders::consts::SLICE_GROUP;

/// params (uniform), grid (3D image), pixels, colormap, tile starts, tile segment lists,
/// segments (storage).
pub const BINDINGS: [vk::DescriptorType; 7] = [
    vk::DescriptorType::UNIFORM_BUFFER,
    vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
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

pub fn pipeline(ctx: &Arc<Context>) -> Result<ComputePipeline, GpuError> {
    ComputePipeline::new(
        ctx,
        "slice",
        shaders::SLICE,
        &BINDINGS,
        std::mem::size_of::<Band>() as u32,
    )
}
