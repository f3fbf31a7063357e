//! The band of image rows one dispatch of a ray, mesh or slice pass covers: images are
//! rendered in bands so that each band's output fits one storage-buffer binding.

use bytemuck::{Pod, Zeroable};

/// Push constants of the ray passes: the band of rows being rendered.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Band {
    pub row_offset: u32,
    pub rows: u32,
}
