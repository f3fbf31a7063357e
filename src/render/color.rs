//! `[color] by`: colouring the surface by a quantity through a colormap, on the host after the
//! ray or mesh pass, from the pixel records themselves (a deferred pass over the AOVs: world
//! position, normal, surface index), so every method and every band is coloured by the same
//! f64 code, and the GPU passes stay as they are.
//!
//! Per hit: the value `v` (the hit surface's isovalue, the world x/y/z, or `[field2]` sampled
//! trilinearly at the world position, clamped into field2's box), `s = clamp((v - lo) /
//! (hi - lo), 0, 1)`, the colormap's entry `round(255 s)` (linear RGB) as the base colour, lit as
//! the scene's shading lights `render.color` (`lambert`: ambient 0.15 plus the headlight;
//! `solid`: unlit). Other shadings (normal, depth, steps, cells) keep their colours; `v` goes
//! to the `color.value` channel in every case. Misses are untouched (`color.value` NaN).
//!
//! Also the colormaps as linear RGBA tables ([`linear_colormap`]), which the shaders read
//! (the `steps` heat map, [`colormap`]; the slice's diverging map) and the colouring above
//! uses.

use glam::DVec3;

use crate::camera::Camera;
use crate::field::{FieldError, Grid};
use crate::frame::{Legend, Pixel};
use crate::scene::{ColorBy, Scene, Shading, COLORMAPS};
use crate::vocab::Placement;

/// 256 linear RGBA entries of a colorous gradient (its sRGB colours decoded), for shaders.
pub fn linear_colormap(gradient: colorous::Gradient) -> Vec<[f32; 4]> {
    let linear = |u: u8| crate::scene::srgb_to_linear(u as f32 / 255.0);
    (0..256)
        .map(|i| {
            let c = gradient.eval_continuous(i as f64 / 255.0);
            [linear(c.r), linear(c.g), linear(c.b), 1.0]
        })
        .collect()
}

/// The `steps` heat map: colorous's inferno.
pub fn colormap() -> Vec<[f32; 4]> {
    linear_colormap(colorous::INFERNO)
}

/// The headlight's ambient term (as `shaders/include/shade.glsl` and `reference::shade`).
const AMBIENT: f64 = 0.15;

/// The colouring of one frame.
pub struct Colorer {
    by: ColorBy,
    shading: Shading,
    camera: Camera,
    isovalues: Vec<f64>,
    field2: Option<(Grid, Placement)>,
    pub legend: Legend,
}

impl Colorer {
    /// The colouring `scene` asks for at `time` over `grid` (whose box gives the default x/y/z
    /// range); None without `[color]` (each surface in its own colour).
    pub fn new(scene: &Scene, grid: &Grid, time: f64) -> Result<Option<Colorer>, FieldError> {
        let c = &scene.color;
        if c.by == ColorBy::Surface {
            return Ok(None);
        }
        let field2 = match (&scene.field2, c.by) {
            (Some(spec), ColorBy::Field2) => Some((spec.sample(time)?, spec.placement)),
            _ => None,
        };
        let isovalues = scene.surface.isovalues();
        let (lo, hi) = match c.range {
            Some([lo, hi]) => (lo, hi),
            None => default_range(c.by, &isovalues, grid, &scene.field.placement, &field2),
        };
        let (name, gradient) = COLORMAPS[c.colormap];
        let lut = linear_colormap(gradient).into_iter().map(|[r, g, b, _]| [r, g, b]).collect();
        Ok(Some(Colorer {
            by: c.by,
            shading: scene.render.shading,
            camera: Camera::new(&scene.camera, &scene.image),
            isovalues,
            field2,
            legend: Legend { by: c.by.name(), colormap: name, lo, hi, lut },
        }))
    }

    /// The value `[color] by` maps at a hit (world position `p` of surface `surface`).
    pub fn value(&self, p: DVec3, surface: usize) -> f64 {
        match self.by {
            ColorBy::Surface | ColorBy::Value => self.isovalues[surface],
            ColorBy::X => p.x,
            ColorBy::Y => p.y,
            ColorBy::Z => p.z,
            ColorBy::Field2 => {
                let (grid, placement) = self.field2.as_ref().expect("sampled for by = field2");
                grid.value_at(grid.to_grid(placement.point_to_grid(p)))
            }
        }
    }

    /// The colormap's linear RGB for value `v`.
    pub fn base(&self, v: f64) -> DVec3 {
        let Legend { lo, hi, lut, .. } = &self.legend;
        let s = ((v - lo) / (hi - lo)).clamp(0.0, 1.0);
        let s = if s.is_nan() { 0.0 } else { s };
        DVec3::from(lut[(s * 255.0 + 0.5) as usize].map(f64::from))
    }

    /// Colours the hits of `pixels`, row `j` of which is image row `stride (first_row + j)`
    /// and column `i` image column `stride i` (a whole frame: first_row 0, stride 1).
    pub fn apply(&self, pixels: &mut [Pixel], width: u32, first_row: u32, stride: u32) {
        for (n, p) in pixels.iter_mut().enumerate() {
            if !p.is_hit() {
                continue;
            }
            let (i, j) = (n as u32 % width, first_row + n as u32 / width);
            let position = DVec3::from(p.position.map(f64::from));
            let v = self.value(position, p.surface.max(0) as usize);
            p.value = v as f32;
            let base = self.base(v);
            let rgb = match self.shading {
                Shading::Solid => base,
                Shading::Lambert => {
                    let (_, dir) = self.camera.ray(i * stride, j * stride);
                    let n = DVec3::from(p.normal.map(f64::from));
                    base * (AMBIENT + (1.0 - AMBIENT) * n.dot(dir).abs())
                }
                _ => continue,
            };
            p.rgba[..3].copy_from_slice(&rgb.as_vec3().to_array());
        }
    }
}

/// The range without `range`: the isovalues' (one isovalue: ± 1 around it), the world box's
/// extent on the axis (the placed box's corners), or field2's sample range.
fn default_range(
    by: ColorBy,
    isovalues: &[f64],
    grid: &Grid,
    placement: &Placement,
    field2: &Option<(Grid, Placement)>,
) -> (f64, f64) {
    let spread = |lo: f64, hi: f64| if lo < hi { (lo, hi) } else { (lo - 1.0, hi + 1.0) };
    match by {
        ColorBy::Surface | ColorBy::Value => {
            let lo = isovalues.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = isovalues.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            spread(lo, hi)
        }
        ColorBy::X | ColorBy::Y | ColorBy::Z => {
            let a = match by {
                ColorBy::X => 0,
                ColorBy::Y => 1,
                _ => 2,
            };
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for k in 0..8 {
                let pick = |bit: usize, axis: usize| {
                    if k >> bit & 1 == 0 {
                        grid.min[axis]
                    } else {
                        grid.max[axis]
                    }
                };
                let corner = DVec3::new(pick(0, 0), pick(1, 1), pick(2, 2));
                let w = placement.point_to_world(corner)[a];
                (lo, hi) = (lo.min(w), hi.max(w));
            }
            spread(lo, hi)
        }
        ColorBy::Field2 => {
            let (lo, hi) = field2.as_ref().expect("sampled for by = field2").0.range();
            spread(lo as f64, hi as f64)
        }
    }
}
