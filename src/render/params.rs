//! The per-render constants block shared with GLSL (`shaders/include/params.glsl`).

use bytemuck::{Pod, Zeroable};
use glam::DVec3;

use crate::camera::Camera;
use crate::field::Grid;
use crate::scene::{Inside, Method, Normals, Scene, Shading, MAX_SURFACES};
use crate::shaders::consts;
use crate::vocab::Clip;

/// std140 mirror of `struct RenderParams` (`shaders/include/params.glsl`, where each member is
/// documented): every `[f32; 3]`/`[i32; 3]` is followed by a 4-byte scalar so it fills its 16
/// bytes, and scalars come in fours, so std140 is the C layout here. The `padN` fields are
/// never read (zero). Offsets: the asserts below and the SPIR-V and GPU checks of
/// `tests/it/gpu/layout.rs`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RenderParams {
    pub eye: [f32; 3],
    pub pad0: f32,
    pub forward: [f32; 3],
    pub pad1: f32,
    /// right * tan(fov/2) * aspect.
    pub right: [f32; 3],
    pub pad2: f32,
    /// up' * tan(fov/2).
    pub up: [f32; 3],
    pub pad3: f32,
    pub box_min: [f32; 3],
    pub pad4: f32,
    pub box_max: [f32; 3],
    pub pad5: f32,
    pub inv_spacing: [f32; 3],
    pub pad6: f32,
    /// The eye in index space, computed in f64.
    pub eye_grid: [f32; 3],
    pub pad7: f32,
    pub dims: [i32; 3],
    pub pad8: i32,
    /// The first cell this process traces; the others are walked but not evaluated (an MPI
    /// rank's block, `render::block`); 0 for the whole grid.
    pub block_lo: [i32; 3],
    pub pad9: i32,
    /// One past the last cell this process traces (the grid's cells for the whole grid).
    pub block_hi: [i32; 3],
    pub pad10: i32,
    /// The grid point held in texel (0, 0, 0) of the uploaded grid (0 for the whole grid).
    pub block_origin: [i32; 3],
    pub pad11: i32,
    pub background: [f32; 4],
    pub color: [f32; 3],
    pub pad12: f32,
    pub width: u32,
    pub height: u32,
    /// Picture pixel (i, j) is image pixel (stride i, stride j).
    pub stride: u32,
    /// ceil(width / stride).
    pub picture_width: u32,
    pub shading: u32,
    pub steps: u32,
    pub newton_steps: u32,
    pub normals: u32,
    /// Surface 0's inside threshold ([`surface_threshold`]).
    pub threshold: f32,
    /// +1 if below is inside, -1 if above.
    pub inside_sign: f32,
    pub depth_near: f32,
    pub depth_far: f32,
    pub steps_scale: f32,
    pub crossing: u32,
    pub skip: u32,
    pub count_crossings: u32,
    pub orthographic: u32,
    pub clip_count: u32,
    pub surfaces: u32,
    pub pad13: u32,
    pub clip: [[f32; 4]; Clip::MAX_PLANES],
    pub thresholds: [[f32; 4]; MAX_SURFACES / 4],
    pub surface_color: [[f32; 4]; MAX_SURFACES],
}

/// `offsets!(T { field: bytes, .. })`: a compile-time assert of each field's offset.
macro_rules! offsets {
    ($t:ty { $($field:ident: $at:expr),+ $(,)? }) => {
        $(assert!(std::mem::offset_of!($t, $field) == $at);)+
    };
}

const _: () = {
    assert!(consts::CLIP_PLANES as usize == Clip::MAX_PLANES);
    assert!(consts::SURFACES as usize == MAX_SURFACES && MAX_SURFACES % 4 == 0);
    // raymarch.comp's marches fit llvmpipe's cap of 65,535 loop back-edges per invocation
    // (passes::raymarch::LOOP_STEPS), with room for its other loops (the bisections): the
    // longest, MARCH_UNROLL samples a back-edge (build.rs), and the loop's.
    assert!((crate::scene::MAX_STEPS as u64).div_ceil(consts::MARCH_UNROLL as u64) < 62_000);
    assert!(crate::passes::raymarch::LOOP_STEPS < 62_000);
    // std140: a vec3 at a multiple of 16, then the scalar that fills its slot.
    offsets!(RenderParams {
        eye: 0,
        pad0: 12,
        forward: 16,
        pad1: 28,
        right: 32,
        pad2: 44,
        up: 48,
        pad3: 60,
        box_min: 64,
        pad4: 76,
        box_max: 80,
        pad5: 92,
        inv_spacing: 96,
        pad6: 108,
        eye_grid: 112,
        pad7: 124,
        dims: 128,
        pad8: 140,
        block_lo: 144,
        pad9: 156,
        block_hi: 160,
        pad10: 172,
        block_origin: 176,
        pad11: 188,
        background: 192,
        color: 208,
        pad12: 220,
        width: 224,
        height: 228,
        stride: 232,
        picture_width: 236,
        shading: 240,
        steps: 244,
        newton_steps: 248,
        normals: 252,
        threshold: 256,
        inside_sign: 260,
        depth_near: 264,
        depth_far: 268,
        steps_scale: 272,
        crossing: 276,
        skip: 280,
        count_crossings: 284,
        orthographic: 288,
        clip_count: 292,
        surfaces: 296,
        pad13: 300,
        clip: 304,
        thresholds: 304 + Clip::MAX_PLANES * 16,
        surface_color: 304 + (Clip::MAX_PLANES + MAX_SURFACES / 4) * 16,
    });
    assert!(
        std::mem::size_of::<RenderParams>()
            == (19 + Clip::MAX_PLANES + MAX_SURFACES / 4 + MAX_SURFACES) * 16
    );
};

fn v3(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// `RenderParams.shading`: the shaders' `SHADE_*` (one definition, in build.rs).
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

/// `RenderParams.normals`: the shaders' `NORMALS_*` (one definition, in build.rs).
pub fn normals_code(n: Normals) -> u32 {
    match n {
        Normals::Trilinear => consts::NORMALS_TRILINEAR,
        Normals::Smooth => consts::NORMALS_SMOOTH,
    }
}

/// `RenderParams.threshold`, what the ray passes compare samples with: the exact f32 inside
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
    /// first, `surfaces` of them): for the CPU decisions that must agree with the shaders' tests.
    pub fn surface_thresholds(&self) -> Vec<f32> {
        (0..self.surfaces as usize).map(|k| self.thresholds[k / 4][k % 4]).collect()
    }

    pub fn new(scene: &Scene, grid: &Grid) -> Self {
        let cam = Camera::for_scene(scene);
        let clip = scene.clip.in_grid_frame(&scene.field.placement);
        let (near, far) = depth_range(cam.eye, grid);
        let inv = DVec3::ONE / grid.spacing();
        let r = &scene.render;
        let [nx, ny, nz] = grid.dims;
        RenderParams {
            eye: v3(cam.eye),
            forward: v3(cam.forward),
            right: v3(cam.right_scaled),
            up: v3(cam.up_scaled),
            box_min: v3(grid.min),
            box_max: v3(grid.max),
            inv_spacing: v3(inv),
            eye_grid: v3((cam.eye - grid.min) / grid.spacing()),
            dims: [nx as i32, ny as i32, nz as i32],
            block_lo: [0; 3],
            block_hi: [nx as i32 - 1, ny as i32 - 1, nz as i32 - 1],
            block_origin: [0; 3],
            background: r.background,
            color: scene.surface.color(0, r.color),
            // The whole image (stride 1); `Renderer::render_progressive` draws every s-th pixel.
            width: scene.image.width,
            height: scene.image.height,
            stride: 1,
            picture_width: scene.image.width,
            shading: shading_code(r.shading),
            steps: r.steps,
            newton_steps: r.newton_steps,
            normals: normals_code(r.normals),
            threshold: surface_threshold(scene.surface.isovalue, scene.surface.inside),
            inside_sign: if scene.surface.inside == Inside::Below { 1.0 } else { -1.0 },
            depth_near: near as f32,
            depth_far: far as f32,
            steps_scale: steps_scale(scene, grid) as f32,
            crossing: r.crossing.max(1),
            skip: r.skip as u32,
            count_crossings: r.count_crossings as u32,
            orthographic: cam.orthographic as u32,
            clip_count: clip.count as u32,
            surfaces: scene.surface.count as u32,
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
            ..RenderParams::default()
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
