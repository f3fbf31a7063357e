//! The validated scene as plain data. Defaults (the contract's example values) are the
//! `Default` impls here; the loader only ever starts from them.

use std::path::PathBuf;

use crate::vocab::echo_number;
use glam::DVec3;

pub use crate::mesh::MeshAlgorithm;
pub use crate::vocab::{Bounds, HermiteNormals, Inside, SdfShape, SharpSettings};

/// A validated scene: everything a render or an extraction needs, nothing unchecked.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The scene file (None for scenes built in code); relative data paths were resolved
    /// against its folder.
    pub path: Option<PathBuf>,
    pub image: ImageSettings,
    pub camera: CameraSettings,
    pub field: crate::field::FieldSpec,
    pub surface: SurfaceSettings,
    pub render: RenderSettings,
    pub slice: SliceSettings,
    /// `[[clip]]` planes and boxes, world space.
    pub clip: crate::vocab::Clip,
    /// `[color]`: what colours the surface.
    pub color: ColorSettings,
    /// `[field2]`: the second scalar field `[color] by = "field2"` samples at the hit.
    pub field2: Option<crate::field::FieldSpec>,
}

impl Scene {
    /// This scene with surface `k` of `surface.isovalues` as its only surface, in that
    /// surface's colour (how the mesh method draws several surfaces, and how tests check the
    /// several-surface rule).
    pub fn single_surface(&self, k: usize) -> Scene {
        let mut one = self.clone();
        let color = self.surface.color(k, self.render.color);
        one.surface.isovalue = self.surface.isovalues()[k];
        one.surface.count = 1;
        one.surface.colors = Some([color; MAX_SURFACES]);
        one
    }

    /// Why `reader` does not read this scene's field ([`Interpolant::refusal`]), as one line
    /// naming the scene file and `field.interpolation`; `None` where it does.
    ///
    /// [`Interpolant::refusal`]: crate::field::interpolant::Interpolant::refusal
    pub fn interpolation_refusal(
        &self,
        reader: crate::field::interpolant::Reader,
    ) -> Option<String> {
        let interp = self.field.interpolation;
        let why = interp.refusal(reader)?;
        let file = self
            .path
            .as_ref()
            .map(|p| format!("{}: ", crate::vocab::echo(&p.display().to_string())));
        Some(format!(
            "{}field.interpolation = \"{}\": {why}",
            file.unwrap_or_default(),
            interp.name()
        ))
    }

    /// What `render` reads the field as: its method's reader.
    pub fn render_reader(&self) -> crate::field::interpolant::Reader {
        use crate::field::interpolant::Reader;
        match self.render.method {
            Method::Analytic => Reader::Analytic,
            Method::FixedStep => Reader::FixedStep,
            Method::Mesh => Reader::Mesh,
        }
    }

    /// Surface `k` of `surface.isovalues` as `render.mesh` extracts it: its isovalue, the
    /// inside rule, the method and its sharp-feature settings; `source` is the field's source
    /// off the grid, for `hermite = "source"`.
    pub fn mesh_request<'a>(
        &self,
        k: usize,
        source: Option<&'a crate::field::PointField<'a>>,
    ) -> crate::mesh::Request<'a> {
        let iso = self.surface.isovalues()[k];
        crate::mesh::Request::new(iso, self.surface.inside, self.render.mesh)
            .with_sharp(self.render.sharp)
            .with_source(source)
            .with_lattice(self.field.interpolation, self.render.mesh_refine as usize)
    }

    /// A scene over `field` with every other key at the contract's default (for scenes built
    /// in code; files go through [`super::load`]).
    pub fn new(field: crate::field::FieldSpec) -> Scene {
        Scene {
            path: None,
            image: ImageSettings::default(),
            camera: CameraSettings::default(),
            field,
            surface: SurfaceSettings::default(),
            render: RenderSettings::default(),
            slice: SliceSettings::default(),
            clip: crate::vocab::Clip::NONE,
            color: ColorSettings::default(),
            field2: None,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageSettings {
    pub width: u32,
    pub height: u32,
}

impl Default for ImageSettings {
    /// 512 x 512.
    fn default() -> Self {
        ImageSettings { width: 512, height: 512 }
    }
}

/// The largest size a coordinate of `camera.eye`, `camera.target` or `camera.up` may have
/// (the scene refuses more, naming the key). The GPU traces in f32 (largest 3.4e38), and
/// `target - eye` and its length must stay finite in f64 (the length of `[1e308, ...]`
/// overflows to inf, which once read as "eye and target are the same point"); 1e30 leaves
/// room for both.
pub const MAX_COORDINATE: f64 = 1e30;

/// Whether every coordinate of `v` is within ±[`MAX_COORDINATE`] (NaN is not): the one test
/// for the camera's points and the grid box's corners, which rays meet in the same f32 space.
pub fn within_coordinate_range(v: DVec3) -> bool {
    v.abs().max_element() <= MAX_COORDINATE && !v.is_nan()
}

/// The rule [`within_coordinate_range`] checks, for messages.
pub fn coordinate_rule() -> String {
    format!(
        "every coordinate must be within ±{MAX_COORDINATE:e} (rays are traced in 32-bit floats)"
    )
}

/// The camera, world space: a pinhole (the contract's) or an orthographic view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSettings {
    pub eye: DVec3,
    pub target: DVec3,
    pub up: DVec3,
    /// Full vertical field of view, degrees (perspective).
    pub fov_y_deg: f64,
    pub projection: Projection,
    /// Orthographic: the view's height in world units. Resolved at load time: without the key,
    /// the height the perspective view has at `target` (`2 |target - eye| tan(fov_y / 2)`), so
    /// switching the projection keeps the target's plane framed alike.
    pub ortho_height: f64,
}

/// `camera.projection`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Projection {
    /// Rays from `eye` through each pixel centre (the contract's pinhole).
    Perspective,
    /// Parallel rays along the view direction, starting on the plane through `eye`
    /// perpendicular to it: pixel centres spread over `ortho_height` (times the aspect ratio).
    Orthographic,
}

impl Projection {
    pub const ALL: [Projection; 2] = [Projection::Perspective, Projection::Orthographic];

    pub fn name(self) -> &'static str {
        match self {
            Projection::Perspective => "perspective",
            Projection::Orthographic => "orthographic",
        }
    }
}

impl Default for CameraSettings {
    /// Eye at (2.2, 1.6, 2.4) looking at the origin, y up, 40 degrees.
    fn default() -> Self {
        CameraSettings {
            eye: DVec3::new(2.2, 1.6, 2.4),
            target: DVec3::ZERO,
            up: DVec3::Y,
            fov_y_deg: 40.0,
            projection: Projection::Perspective,
            ortho_height: 2.0 * DVec3::new(2.2, 1.6, 2.4).length() * 20f64.to_radians().tan(),
        }
    }
}

/// `[color] by`: the quantity mapped through the colormap at each hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorBy {
    /// Each surface in its own colour (`surface.colors` / `render.color`): no `[color]`.
    Surface,
    /// The isovalue of the surface hit (several isovalues through one colormap).
    Value,
    /// `[field2]` sampled trilinearly at the hit.
    Field2,
    /// The hit's world x, y or z.
    X,
    Y,
    Z,
}

impl ColorBy {
    pub const ALL: [ColorBy; 6] =
        [ColorBy::Surface, ColorBy::Value, ColorBy::Field2, ColorBy::X, ColorBy::Y, ColorBy::Z];

    pub fn name(self) -> &'static str {
        match self {
            ColorBy::Surface => "surface",
            ColorBy::Value => "value",
            ColorBy::Field2 => "field2",
            ColorBy::X => "x",
            ColorBy::Y => "y",
            ColorBy::Z => "z",
        }
    }
}

/// The colormaps `[color] colormap` names (colorous's gradients).
pub const COLORMAPS: [(&str, colorous::Gradient); 12] = [
    ("viridis", colorous::VIRIDIS),
    ("inferno", colorous::INFERNO),
    ("magma", colorous::MAGMA),
    ("plasma", colorous::PLASMA),
    ("cividis", colorous::CIVIDIS),
    ("turbo", colorous::TURBO),
    ("spectral", colorous::SPECTRAL),
    ("red-blue", colorous::RED_BLUE),
    ("cool", colorous::COOL),
    ("warm", colorous::WARM),
    ("greys", colorous::GREYS),
    ("blues", colorous::BLUES),
];

/// `[color]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColorSettings {
    pub by: ColorBy,
    /// An index into [`COLORMAPS`] (`colormap = "viridis"`, the default).
    pub colormap: usize,
    /// `range = [lo, hi]`: the values at the colormap's ends; None: from the data (the
    /// isovalues, the box's world extent, or `[field2]`'s samples).
    pub range: Option<[f64; 2]>,
}

impl Default for ColorSettings {
    fn default() -> Self {
        ColorSettings { by: ColorBy::Surface, colormap: 0, range: None }
    }
}

impl ColorSettings {
    pub fn colormap_name(&self) -> &'static str {
        COLORMAPS[self.colormap].0
    }
}

/// Most surfaces one scene renders (`surface.isovalues`).
pub const MAX_SURFACES: usize = 8;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceSettings {
    /// The isovalue every method uses: `isovalue`, or resolved from the samples at load time
    /// by [`SurfaceSettings::rule`]; with `isovalues`, the first of them (surface 0).
    pub isovalue: f64,
    pub inside: Inside,
    /// How the isovalue was chosen.
    pub rule: IsoRule,
    /// `isovalues = [a, b, ...]`: the surfaces after the first (`a` is `isovalue`), in order;
    /// `count` is how many surfaces there are in all (1: a single isovalue).
    pub more: [f64; MAX_SURFACES - 1],
    pub count: usize,
    /// `colors = [[r, g, b], ...]`, one linear RGB per surface; None: surface 0 is
    /// `render.color` and surface k > 0 the k-th colour of [`SURFACE_PALETTE`].
    pub colors: Option<[[f32; 3]; MAX_SURFACES]>,
}

impl Default for SurfaceSettings {
    /// Isovalue 0, values below it inside (signed distance convention).
    fn default() -> Self {
        SurfaceSettings {
            isovalue: 0.0,
            inside: Inside::Below,
            rule: IsoRule::Value,
            more: [0.0; MAX_SURFACES - 1],
            count: 1,
            colors: None,
        }
    }
}

/// The colours of surfaces 1, 2, ... when `surface.colors` is not given: colorous's Tableau10
/// from its second entry (its first, blue, stays for 0 if a scene asks), sRGB decoded to linear.
pub const SURFACE_PALETTE: usize = 10;

impl SurfaceSettings {
    /// Every surface's isovalue, surface 0 first.
    pub fn isovalues(&self) -> Vec<f64> {
        std::iter::once(self.isovalue).chain(self.more[..self.count - 1].iter().copied()).collect()
    }

    /// Whether the scene has more than one surface.
    pub fn several(&self) -> bool {
        self.count > 1
    }

    /// Surface `k`'s linear RGB, given the scene's `render.color`.
    pub fn color(&self, k: usize, render_color: [f32; 3]) -> [f32; 3] {
        match (&self.colors, k) {
            (Some(c), _) => c[k],
            (None, 0) => render_color,
            (None, k) => {
                let c = colorous::TABLEAU10[k % SURFACE_PALETTE];
                [c.r, c.g, c.b].map(|u| srgb_to_linear(u as f32 / 255.0))
            }
        }
    }
}

/// The sRGB transfer function's inverse (IEC 61966-2-1).
pub fn srgb_to_linear(s: f32) -> f32 {
    if s <= 0.04045 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// Where the isovalue comes from: `[surface] isovalue`, `isovalue_sigma` or
/// `isovalue_percentile` (exactly one of them; `isovalue = 0` when none is given). The last two
/// are resolved from the samples when the scene is loaded (`field::stats`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IsoRule {
    /// Written in the scene.
    Value,
    /// `isovalue_sigma = k`: mean + k σ of the samples (the cryo-EM convention); `mean` and
    /// `sigma` are the samples'.
    Sigma { k: f64, mean: f64, sigma: f64 },
    /// `isovalue_percentile = p`: the p-th percentile of the samples (NumPy's linear rule).
    Percentile { p: f64 },
}

impl IsoRule {
    /// How the isovalue was resolved, for headers and messages; None when it was written.
    pub fn describe(self, isovalue: f64) -> Option<String> {
        match self {
            IsoRule::Value => None,
            // Short numbers: isovalue_sigma = 1e308 printed 300-digit isovalues.
            IsoRule::Sigma { k, mean, sigma } => {
                let [v, mean, k, sigma] = [isovalue, mean, k, sigma].map(echo_number);
                Some(format!(
                    "isovalue {v} = mean {mean} + {k} sigma (sigma {sigma}), from isovalue_sigma = {k}"
                ))
            }
            IsoRule::Percentile { p } => {
                let [v, p] = [isovalue, p].map(echo_number);
                Some(format!(
                    "isovalue {v} = percentile {p} of the samples, from isovalue_percentile = {p}"
                ))
            }
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    Analytic,
    FixedStep,
    Mesh,
}

impl Method {
    /// Every method, in the order the contract lists them.
    pub const ALL: [Method; 3] = [Method::Analytic, Method::FixedStep, Method::Mesh];

    /// The name as written in scene files.
    pub fn name(self) -> &'static str {
        match self {
            Method::Analytic => "analytic",
            Method::FixedStep => "fixed-step",
            Method::Mesh => "mesh",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shading {
    Lambert,
    Normal,
    Depth,
    Steps,
    Cells,
    Solid,
}

impl Shading {
    /// Every shading mode, in the order the contract lists them.
    pub const ALL: [Shading; 6] = [
        Shading::Lambert,
        Shading::Normal,
        Shading::Depth,
        Shading::Steps,
        Shading::Cells,
        Shading::Solid,
    ];

    /// The name as written in scene files.
    pub fn name(self) -> &'static str {
        match self {
            Shading::Lambert => "lambert",
            Shading::Normal => "normal",
            Shading::Depth => "depth",
            Shading::Steps => "steps",
            Shading::Cells => "cells",
            Shading::Solid => "solid",
        }
    }
}

/// `render.normals`: which normal the hit records and shading uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Normals {
    /// The exact gradient of the trilinear interpolant (the contract's): continuous inside a
    /// cell, jumping across cell faces, so coarse grids look faceted. With another
    /// `field.interpolation`, that interpolant's own normal (the cubic ones' exact gradient,
    /// nearest's voxel faces, the device's differences of its lookups).
    Trilinear,
    /// The trilinear interpolation of per-point central-difference gradients (one-sided at
    /// the box's faces): the volume-rendering convention, continuous across cell faces.
    Smooth,
}

impl Normals {
    pub const ALL: [Normals; 2] = [Normals::Trilinear, Normals::Smooth];

    pub fn name(self) -> &'static str {
        match self {
            Normals::Trilinear => "trilinear",
            Normals::Smooth => "smooth",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    pub method: Method,
    /// Fixed-step: samples over the ray's span inside the grid box (at least 2).
    pub steps: u32,
    /// Analytic: Newton-Raphson refinements of each root.
    pub newton_steps: u32,
    /// Analytic: cross bricks of the min/max grid that cannot hold a crossing in one step
    /// (images are identical either way; only `steps` changes).
    pub skip: bool,
    /// Analytic, with `skip`: walk a whole grid with the occupancy structure (per-cell masks
    /// and distances over bricks: `passes::occupancy`). The same image; `steps` counts this
    /// walk's work. Off: the brick-by-brick walk that MPI blocks and brick pools walk, so that
    /// `steps` compares across them.
    pub occupancy: bool,
    /// Analytic: which isovalue crossing along the ray is shown (1 = the first hit).
    pub crossing: u32,
    /// Analytic and mesh: count every crossing along the whole ray for the `crossings` channel.
    /// Off by default: the analytic walk then stops at the shown crossing (about twice as
    /// fast), and the EXR has no `crossings` channel.
    pub count_crossings: bool,
    pub mesh: MeshAlgorithm,
    /// Sub-cells per cell along each axis for extraction (`mesh::refine`); 1: the grid's cells.
    pub mesh_refine: u32,
    /// Settings of the sharp-feature meshes (`hermite`, `qef_threshold`, `qef_clamp`).
    pub sharp: SharpSettings,
    pub shading: Shading,
    pub normals: Normals,
    /// Linear RGBA of pixels whose ray misses.
    pub background: [f32; 4],
    /// Linear RGB of the surface.
    pub color: [f32; 3],
}

impl Default for RenderSettings {
    /// Analytic, 200 fixed steps, 10 Newton steps, skipping on, first crossing, no whole-ray crossing count, marching cubes,
    /// Lambert shading, transparent black background, colour (0.85, 0.65, 0.45).
    fn default() -> Self {
        RenderSettings {
            method: Method::Analytic,
            steps: 200,
            newton_steps: 10,
            skip: true,
            occupancy: true,
            crossing: 1,
            count_crossings: false,
            mesh: MeshAlgorithm::MarchingCubes,
            mesh_refine: 1,
            sharp: SharpSettings::default(),
            shading: Shading::Lambert,
            normals: Normals::Trilinear,
            background: [0.0, 0.0, 0.0, 0.0],
            color: [0.85, 0.65, 0.45],
        }
    }
}

/// How marching squares decides its two ambiguous cases (5 and 10: inside corners on one
/// diagonal, outside corners on the other): by the inside test of a value at the cell's centre.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ambiguity {
    /// The mean of the 4 corner values (which is the bilinear interpolant at the centre).
    Average,
    /// The field's source evaluated at the centre (sdf, expr and corners sources).
    Sample,
    /// The bilinear interpolant's saddle value (the asymptotic decider): the contours then have
    /// the topology of the bilinear zero set itself.
    Saddle,
}

impl Ambiguity {
    /// Every rule, the default first.
    pub const ALL: [Ambiguity; 3] = [Ambiguity::Average, Ambiguity::Sample, Ambiguity::Saddle];

    /// The name as written in scene files.
    pub fn name(self) -> &'static str {
        match self {
            Ambiguity::Average => "average",
            Ambiguity::Sample => "sample",
            Ambiguity::Saddle => "saddle",
        }
    }
}

/// `[slice]`: settings of `isoview slice` (the plane itself comes from the command line).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SliceSettings {
    /// Rule for marching squares' ambiguous cases.
    pub ambiguity: Ambiguity,
    /// Quadtree levels below the grid's cells (0: contours on the grid's cells only).
    pub max_depth: u32,
    /// Picture width in pixels; None: `image.width`, or from `height` and the cross-section's
    /// aspect ratio.
    pub width: Option<u32>,
    /// Picture height in pixels; None: from the width and the cross-section's aspect ratio.
    pub height: Option<u32>,
}

impl Default for SliceSettings {
    /// Average rule, no refinement, size from `[image]` and the cross-section.
    fn default() -> Self {
        SliceSettings { ambiguity: Ambiguity::Average, max_depth: 0, width: None, height: None }
    }
}
