//! Shading and whole-image rendering on the CPU (GPU: `shaders/include/shade.glsl` and the
//! ray passes), so references produce the same `Pixel` records as the GPU.

use glam::DVec3;

use crate::camera::Camera;
use crate::field::interpolant::Interpolant;
use crate::field::Grid;
use crate::frame::Pixel;
use crate::reference::field::smooth_gradient_at;
use crate::render::colormap;
use crate::render::params::{depth_range, steps_scale};
use crate::scene::{Inside, Normals, Scene, Shading};

const AMBIENT: f64 = 0.15;
const CELL_BORDER: f64 = 0.03;

/// What a ray found, in the form every method's reference returns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// Distance along the unit ray.
    pub t: f64,
    pub position: DVec3,
    /// Unit normal, inside to outside.
    pub normal: DVec3,
    /// Continuous grid coordinates of the hit.
    pub grid_coords: DVec3,
    pub cell: [usize; 3],
    /// Which surface (index into `surface.isovalues`); 0 with one isovalue.
    pub surface: usize,
}

/// What one ray found among several surfaces, from what it found on each alone (in surface
/// order: hit, steps, crossings), by the rule every method follows: the nearest hit wins
/// (ties: the lower surface index) and keeps its `steps` (a miss: surface 0's, which every
/// surface shares: each walked the whole ray); crossings are summed (-1: not counted).
pub fn nearest_surface(
    per_surface: impl IntoIterator<Item = (Option<RayHit>, u32, i32)>,
) -> (Option<RayHit>, u32, i32) {
    let mut best: Option<(RayHit, u32)> = None;
    let (mut miss_steps, mut crossings) = (None, 0i32);
    for (k, (hit, steps, c)) in per_surface.into_iter().enumerate() {
        miss_steps.get_or_insert(steps);
        crossings = if c < 0 || crossings < 0 { -1 } else { crossings + c };
        if let Some(h) = hit {
            if best.as_ref().map_or(true, |(b, _)| h.t < b.t) {
                best = Some((RayHit { surface: k, ..h }, steps));
            }
        }
    }
    match best {
        Some((h, steps)) => (Some(h), steps, crossings),
        None => (None, miss_steps.unwrap_or(0), crossings),
    }
}

/// Shading inputs that do not change per pixel.
pub struct Shader {
    mode: Shading,
    /// Each surface's colour.
    colors: Vec<DVec3>,
    /// Whether the `iso_index` channel is written (several surfaces).
    several: bool,
    near: f64,
    far: f64,
    steps_scale: f64,
    colormap: Vec<[f32; 4]>,
    /// `nearest`: `cells` shades voxels, not cells (see [`Shader::shade`]).
    voxels: bool,
}

impl Shader {
    /// The shader of a trilinear render (every scene's interpolant until the
    /// `[field] interpolation` key exists).
    pub fn new(scene: &Scene, grid: &Grid) -> Self {
        Self::for_interpolant(scene, grid, Interpolant::Trilinear)
    }

    /// The shader of a render of the field read with `interp`.
    pub fn for_interpolant(scene: &Scene, grid: &Grid, interp: Interpolant) -> Self {
        let (near, far) = depth_range(Camera::for_scene(scene).eye, grid);
        let colors = (0..scene.surface.count)
            .map(|k| DVec3::from(scene.surface.color(k, scene.render.color).map(f64::from)))
            .collect();
        Shader {
            mode: scene.render.shading,
            colors,
            several: scene.surface.several(),
            near,
            far,
            steps_scale: steps_scale(scene, grid),
            colormap: colormap(),
            voxels: interp == Interpolant::Nearest,
        }
    }

    /// Colour of a hit seen along unit direction `dir` after visiting `steps` samples or cells.
    ///
    /// `cells` is a checker of the hit's cell, darkened near the cell's borders. For
    /// `nearest` the cell is the inside voxel (`hit.cell`, the point at its centre): the
    /// checker is over voxels, the local coordinates are `u + ½ - cell`, and the face's own
    /// axis (the normal's) is left out of the border test, since every hit lies on a voxel
    /// wall along it.
    pub fn shade(&self, hit: &RayHit, dir: DVec3, steps: f64) -> DVec3 {
        let lambert = AMBIENT + (1.0 - AMBIENT) * hit.normal.dot(dir).abs();
        let color = self.colors[hit.surface];
        match self.mode {
            Shading::Normal => hit.normal * 0.5 + 0.5,
            Shading::Depth => {
                DVec3::splat(1.0 - ((hit.t - self.near) / (self.far - self.near)).clamp(0.0, 1.0))
            }
            Shading::Steps => {
                let i = ((steps / self.steps_scale).clamp(0.0, 1.0) * 255.0 + 0.5) as usize;
                let c = self.colormap[i];
                DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64)
            }
            Shading::Cells => {
                let c = hit.cell;
                let mut f = hit.grid_coords - DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
                if self.voxels {
                    f += 0.5;
                }
                let mut edge = f.min(DVec3::ONE - f);
                if self.voxels {
                    edge[hit.normal.abs().max_position()] = f64::INFINITY;
                }
                let mut tone = if (c[0] + c[1] + c[2]) % 2 == 0 { 1.0 } else { 0.6 };
                if edge.min_element() < CELL_BORDER {
                    tone *= 0.25;
                }
                color * tone * lambert
            }
            Shading::Solid => color,
            Shading::Lambert => color * lambert,
        }
    }
}

impl Shader {
    /// The record every reference writes for a ray along `dir` that found `hit` after
    /// `steps` samples, cells or triangles and counted `crossings` (-1: not counted): the
    /// channels of the channel table (`crate::frame::Channel`). A struct literal, so a new
    /// `Pixel` member is a compile error here until the references fill it.
    pub fn pixel(
        &self,
        hit: Option<&RayHit>,
        dir: DVec3,
        steps: u32,
        crossings: i32,
        background: [f32; 4],
    ) -> Pixel {
        match hit {
            None => Pixel { crossings, ..Pixel::miss(background, steps as f32) },
            Some(h) => {
                let c = self.shade(h, dir, steps as f64);
                Pixel {
                    rgba: [c.x as f32, c.y as f32, c.z as f32, 1.0],
                    normal: h.normal.as_vec3().to_array(),
                    depth: h.t as f32,
                    position: h.position.as_vec3().to_array(),
                    steps: steps as f32,
                    cell: h.cell.map(|c| c as i32),
                    crossings,
                    surface: if self.several { h.surface as i32 } else { -1 },
                    value: f32::NAN,
                    pad: [0; 2],
                }
            }
        }
    }
}

/// `hit` with the normal `scene.render.normals` asks for (GPU: `scene_normal` in
/// `shaders/include/field.glsl`): the exact one for "trilinear"; for "smooth" the interpolated
/// point gradients at the hit, inside to outside, keeping the exact one where they vanish.
pub fn scene_normal(scene: &Scene, grid: &Grid, mut hit: RayHit) -> RayHit {
    if scene.render.normals == Normals::Smooth {
        let sign = if scene.surface.inside == Inside::Below { 1.0 } else { -1.0 };
        let g = smooth_gradient_at(grid, hit.grid_coords) * sign;
        let len = g.length();
        if len > 0.0 && len.is_finite() {
            hit.normal = g / len;
        }
    }
    hit
}

/// Whether `render.normals = "smooth"` replaces `interp`'s normals: the point gradients
/// approximate the trilinear interpolant's (and the device's filter of it); the cubic ones have
/// their exact gradients and `nearest` its faces (the scene refuses "smooth" with those).
fn smoothed(interp: Interpolant) -> bool {
    match interp {
        Interpolant::Trilinear | Interpolant::Device => true,
        Interpolant::CubicBspline | Interpolant::CatmullRom | Interpolant::Nearest => false,
    }
}

/// Renders every pixel with `trace(origin, dir) -> (hit, steps, crossings)`.
pub fn render_with<F>(scene: &Scene, grid: &Grid, trace: F) -> Vec<Pixel>
where
    F: FnMut(DVec3, DVec3) -> (Option<RayHit>, u32, i32),
{
    render_with_interp(scene, grid, Interpolant::Trilinear, trace)
}

/// [`render_with`] for a field read with `interp`.
pub fn render_with_interp<F>(
    scene: &Scene,
    grid: &Grid,
    interp: Interpolant,
    mut trace: F,
) -> Vec<Pixel>
where
    F: FnMut(DVec3, DVec3) -> (Option<RayHit>, u32, i32),
{
    let cam = Camera::for_scene(scene);
    let shader = Shader::for_interpolant(scene, grid, interp);
    let mut out = Vec::with_capacity((scene.image.width * scene.image.height) as usize);
    for py in 0..scene.image.height {
        for px in 0..scene.image.width {
            let (origin, dir) = cam.ray(px, py);
            let (hit, steps, crossings) = trace(origin, dir);
            let hit = hit.map(|h| if smoothed(interp) { scene_normal(scene, grid, h) } else { h });
            let mut pixel =
                shader.pixel(hit.as_ref(), dir, steps, crossings, scene.render.background);
            pixel.place(&scene.field.placement);
            out.push(pixel);
        }
    }
    out
}
