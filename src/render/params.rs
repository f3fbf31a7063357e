//! The per-render constants block shared with GLSL (`shaders/include/params.glsl`).

use bytemuck::{Pod, Zeroable};
use glam::DVec3;

use crate::camera::Camera;
use crate::field::Grid;
use crate::scene::{Inside, Method, Normals, Scene, Shading, MAX_SURFACES};
use crate::shaders::consts;
use crate::vocab::Clip;

/// std140 mirror of `struct RenderParams` (vec4 members only, so std140 = C layout).
/// Field meanings are documented on the GLSL side.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RenderParams {
    pub eye: [f32; 4],
    pub forward: [f32; 4],
    pub right: [f32; 4],
    pub up: [f32; 4],
    pub box_min: [f32; 4],
    pub box_max: [f32; 4],
    pub inv_spacing: [f32; 4],
    pub background: [f32; 4],
    pub color: [f32; 4],
    pub dims: [i32; 4],
    pub image: [u32; 4],
    pub method: [u32; 4],
    pub surface: [f32; 4],
    pub debug: [f32; 4],
    pub eye_grid: [f32; 4],
    pub analytic: [u32; 4],
    pub view: [u32; 4],
    /// xyz: the first cell this process traces; the others are walked but not evaluated
    /// (an MPI rank's block, `render::block`); 0 for the whole grid.
    pub block_lo: [i32; 4],
    /// xyz: one past the last cell this process traces (the grid's cells for the whole grid).
    pub block_hi: [i32; 4],
    /// xyz: the grid point held in texel (0, 0, 0) of the uploaded grid (0 for the whole grid).
    pub block_origin: [i32; 4],
    pub clip: [[f32; 4]; Clip::MAX_PLANES],
    pub thresholds: [[f32; 4]; MAX_SURFACES / 4],
    pub surface_color: [[f32; 4]; MAX_SURFACES],
}

const _: () = {
    assert!(consts::CLIP_PLANES as usize == Clip::MAX_PLANES);
    assert!(consts::SURFACES as usize == MAX_SURFACES && MAX_SURFACES % 4 == 0);
    assert!(
        std::mem::size_of::<RenderParams>()
            == (20 + Clip::MAX_PLANES + MAX_SURFACES / 4 + MAX_SURFACES) * 16
    );
    assert!(std::mem::offset_of!(RenderParams, dims) == 9 * 16);
    assert!(std::mem::offset_of!(RenderParams, debug) == 13 * 16);
    assert!(std::mem::offset_of!(RenderParams, eye_grid) == 14 * 16);
    assert!(std::mem::offset_of!(RenderParams, analytic) == 15 * 16);
};

fn v4(v: DVec3, w: f32) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w]
}

/// `RenderParams.method.x`: the shaders' `METHOD_*` (one definition, in build.rs).
pub fn method_code(m: Method) -> u32 {
    match m {
        Method::FixedStep => consts::METHOD_FIXED_STEP,
        Method::Analytic => consts::METHOD_ANALYTIC,
        Method::Mesh => consts::METHOD_MESH,
    }
}

/// `RenderParams.method.y`: the shaders' `SHADE_*` (one definition, in build.rs).
pub fn shading_code(s: Shading) -> u32 {
    match s {
        Shading::Lambert => consts::SHADE_LAMBERT,
        Shading::Normal => consts::SHADE_NORMAL,
        Shading::Depth => consts::SHADE_DEPTH,
        Shading::Steps => consts::SHADE_STEPS,
        Shading::Cells => consts::SHADE_CELLS,
        Shading::Solid => consts::SHADE_SOLID,
    }
}

/// `RenderParams.view.y`: the shaders' `NORMALS_*` (one definition, in build.rs).
pub fn normals_code(n: Normals) -> u32 {
    match n {
        Normals::Trilinear => consts::NORMALS_TRILINEAR,
        Normals::Smooth => consts::NORMALS_SMOOTH,
    }
}

/// `RenderParams.surface.x`, what the ray passes compare samples with: the exact f32 inside
/// threshold `t` (`passes::extract::inside_threshold`, the one place it is computed), so
/// that `v < t` (inside = below) or `v > t` (above) equals the f64 comparison of every f32
/// `v` with the isovalue, as in extraction and the f64 references (docs/methods.md "Conventions").
/// Where the isovalue is an f32 (every shipped scene) it is the isovalue itself.
pub fn surface_threshold(isovalue: f64, inside: Inside) -> f32 {
    crate::passes::extract::inside_threshold(isovalue, inside == Inside::Below)
}

/// Surface `k`'s colour as the shaders take it (linear RGB, 1).
fn surface_color(scene: &Scene, k: usize) -> [f32; 4] {
    let [r, g, b] = scene.surface.color(k, scene.render.color);
    [r, g, b, 1.0]
}

/// Distances from the eye that map to white and black in `depth` shading: the near and far
/// side of the grid box's bounding sphere.
pub fn depth_range(eye: DVec3, grid: &Grid) -> (f64, f64) {
    let centre = 0.5 * (grid.min + grid.max);
    let radius = 0.5 * (grid.max - grid.min).length();
    let dist = (eye - centre).length();
    ((dist - radius).max(0.0), dist + radius)
}

/// Triangles tested per pixel at the top of the `steps` colormap of the mesh render.
pub const MESH_STEPS_SCALE: f64 = 64.0;

/// The step count shown at the top of the `steps` colormap: the sample count for fixed-step,
/// the most cells a ray can cross (nx + ny + nz - 3 + 1) for analytic, [`MESH_STEPS_SCALE`]
/// triangles tested for mesh.
pub fn steps_scale(scene: &Scene, grid: &Grid) -> f64 {
    match scene.render.method {
        Method::FixedStep => scene.render.steps as f64,
        Method::Mesh => MESH_STEPS_SCALE,
        Method::Analytic => (grid.cells().iter().sum::<usize>() + 1) as f64,
    }
}

impl RenderParams {
    /// Every surface's inside threshold exactly as the shaders get it (`thresholds`, surface 0
    /// first, `view.w` of them): for the CPU decisions that must agree with the shaders' tests.
    pub fn surface_thresholds(&self) -> Vec<f32> {
        (0..self.view[3] as usize).map(|k| self.thresholds[k / 4][k % 4]).collect()
    }

    pub fn new(scene: &Scene, grid: &Grid) -> Self {
        let cam = Camera::for_scene(scene);
        let clip = scene.clip.in_grid_frame(&scene.field.placement);
        let (near, far) = depth_range(cam.eye, grid);
        let inv = DVec3::ONE / grid.spacing();
        let r = &scene.render;
        let [nx, ny, nz] = grid.dims;
        RenderParams {
            eye: v4(cam.eye, 1.0),
            forward: v4(cam.forward, 0.0),
            right: v4(cam.right_scaled, 0.0),
            up: v4(cam.up_scaled, 0.0),
            box_min: v4(grid.min, 0.0),
            box_max: v4(grid.max, 0.0),
            inv_spacing: v4(inv, 0.0),
            background: r.background,
            color: surface_color(scene, 0),
            dims: [nx as i32, ny as i32, nz as i32, 0],
            // The whole image (stride 1); `Renderer::render_progressive` draws every s-th pixel.
            image: [scene.image.width, scene.image.height, 1, scene.image.width],
            method: [method_code(r.method), shading_code(r.shading), r.steps, r.newton_steps],
            surface: [
                surface_threshold(scene.surface.isovalue, scene.surface.inside),
                if scene.surface.inside == Inside::Below { 1.0 } else { -1.0 },
                near as f32,
                far as f32,
            ],
            debug: [steps_scale(scene, grid) as f32, 0.0, 0.0, 0.0],
            eye_grid: v4((cam.eye - grid.min) / grid.spacing(), 0.0),
            analytic: [
                r.crossing.max(1),
                r.skip as u32,
                crate::passes::bricks::BRICK as u32,
                r.count_crossings as u32,
            ],
            view: [
                cam.orthographic as u32,
                normals_code(r.normals),
                clip.count as u32,
                scene.surface.count as u32,
            ],
            block_lo: [0; 4],
            block_hi: [nx as i32 - 1, ny as i32 - 1, nz as i32 - 1, 0],
            block_origin: [0; 4],
            clip: std::array::from_fn(|i| {
                let (n, offset) = clip.planes[i];
                [n.x as f32, n.y as f32, n.z as f32, offset as f32]
            }),
            thresholds: {
                let mut t = [[0.0; 4]; MAX_SURFACES / 4];
                for (k, iso) in scene.surface.isovalues().into_iter().enumerate() {
                    t[k / 4][k % 4] = surface_threshold(iso, scene.surface.inside);
                }
                t
            },
            surface_color: std::array::from_fn(|k| surface_color(scene, k)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ray_passes_threshold_is_the_exact_inside_rule() {
        // 0.7 rounds down to f32 (0.69999999 < 0.7), 0.3 rounds up; 0.25 is exact.
        for iso in [0.7, 0.3, 0.25, -0.7, 1e-40, 0.0] {
            for inside in [Inside::Below, Inside::Above] {
                let t = surface_threshold(iso, inside);
                let near = iso as f32;
                for v in [
                    near,
                    f32::from_bits(near.to_bits() + 1),
                    f32::from_bits(near.to_bits().wrapping_sub(1)),
                ] {
                    let gpu = if inside == Inside::Below { v < t } else { v > t };
                    assert_eq!(gpu, inside.contains(f64::from(v), iso), "{iso} {inside:?} {v}");
                }
                if iso == 0.25 || iso == 0.0 {
                    assert_eq!(t, near, "an f32 isovalue is its own threshold");
                }
            }
        }
    }
}
