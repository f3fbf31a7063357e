//! What a render produces: one [`Pixel`] record per image pixel, and the facts that say how it
//! was made. `Pixel` is written by the compute shaders (`shaders/include/pixel.glsl`) and read
//! back as is, so its layout is fixed, asserted here and tested on the GPU.

use bytemuck::{Pod, Zeroable};
use glam::DVec3;

/// One pixel of every output channel (the EXR channels of the interface contract).
///
/// std430 layout, 64 bytes; mirrored by `struct Pixel` in `shaders/include/pixel.glsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Pixel {
    /// Shaded colour, linear; A is coverage (1 on a hit). The background on a miss.
    pub rgba: [f32; 4],
    /// World-space unit normal, inside to outside; 0 on a miss.
    pub normal: [f32; 3],
    /// Distance along the (unit) ray from the eye to the hit; +inf on a miss.
    pub depth: f32,
    /// World-space hit position; 0 on a miss.
    pub position: [f32; 3],
    /// Samples (fixed-step) or cells (analytic) the ray visited, hit or miss.
    pub steps: f32,
    /// Index of the grid cell that was hit; -1 on a miss.
    pub cell: [i32; 3],
    /// Number of isovalue crossings along the ray inside the box, where the method counts them
    /// (analytic); -1 where it does not.
    pub crossings: i32,
}

const _: () = {
    assert!(std::mem::size_of::<Pixel>() == 64);
    assert!(std::mem::offset_of!(Pixel, normal) == 16);
    assert!(std::mem::offset_of!(Pixel, depth) == 28);
    assert!(std::mem::offset_of!(Pixel, position) == 32);
    assert!(std::mem::offset_of!(Pixel, steps) == 44);
    assert!(std::mem::offset_of!(Pixel, cell) == 48);
    assert!(std::mem::offset_of!(Pixel, crossings) == 60);
};

impl Pixel {
    /// The record of a ray that hit nothing, over `background`.
    pub fn miss(background: [f32; 4], steps: f32) -> Self {
        Pixel {
            rgba: background,
            normal: [0.0; 3],
            depth: f32::INFINITY,
            position: [0.0; 3],
            steps,
            cell: [-1; 3],
            crossings: -1,
        }
    }

    /// Whether the ray hit the surface.
    pub fn is_hit(&self) -> bool {
        self.depth.is_finite()
    }
}

/// A rendered image: `width * height` pixels, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Pixel>,
    /// How the frame was made, for the output headers.
    pub info: FrameInfo,
}

impl Frame {
    /// The pixel at column `x`, row `y` (0 = top).
    pub fn pixel(&self, x: u32, y: u32) -> &Pixel {
        &self.pixels[(y * self.width + x) as usize]
    }
}

/// Provenance of a frame, written into the EXR header so that a file alone says how it was made.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameInfo {
    /// The scene file, as given on the command line (empty for scenes built in code).
    pub scene: String,
    pub eye: DVec3,
    pub target: DVec3,
    pub up: DVec3,
    pub fov_y_deg: f64,
    pub isovalue: f64,
    /// `render.method` as written in scenes (`analytic`, `fixed-step`, `mesh`).
    pub method: String,
    /// Time of the field (`--time`), 0 when not time-varying.
    pub time: f64,
    /// Vulkan device name and driver string the frame was rendered on.
    pub device: String,
    pub driver: String,
    /// Further `key = value` facts (method parameters, colormap scales).
    pub extra: Vec<(String, String)>,
}
