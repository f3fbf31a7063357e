use std::path::PathBuf;

use glam::DVec3;

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
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageSettings {
    pub width: u32,
    pub height: u32,
}

/// Pinhole camera, world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSettings {
    pub eye: DVec3,
    pub target: DVec3,
    pub up: DVec3,
    /// Full vertical field of view, degrees.
    pub fov_y_deg: f64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Inside {
    /// Values below the isovalue are inside (signed distance fields).
    Below,
    /// Values above the isovalue are inside.
    Above,
}

impl Inside {
    /// The one inside test every method follows (GPU: `is_inside` in `shaders/include/field.glsl`):
    /// strictly below (or above) the isovalue is inside; a value equal to the isovalue is
    /// outside. A crossing is a change of this predicate between two points.
    pub fn contains(self, value: f64, isovalue: f64) -> bool {
        match self {
            Inside::Below => value < isovalue,
            Inside::Above => value > isovalue,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceSettings {
    pub isovalue: f64,
    pub inside: Inside,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    Analytic,
    FixedStep,
    Mesh,
}

impl Method {
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
pub enum MeshAlgorithm {
    MarchingCubes,
    Mc33,
    SurfaceNets,
    DualContouring,
    MarchingTetrahedra,
}

impl MeshAlgorithm {
    /// The name as written in scene files.
    pub fn name(self) -> &'static str {
        match self {
            MeshAlgorithm::MarchingCubes => "marching-cubes",
            MeshAlgorithm::Mc33 => "mc33",
            MeshAlgorithm::SurfaceNets => "surface-nets",
            MeshAlgorithm::DualContouring => "dual-contouring",
            MeshAlgorithm::MarchingTetrahedra => "marching-tetrahedra",
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

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    pub method: Method,
    /// Fixed-step: samples over the ray's span inside the grid box (at least 2).
    pub steps: u32,
    /// Analytic: Newton-Raphson refinements of each root.
    pub newton_steps: u32,
    pub mesh: MeshAlgorithm,
    pub shading: Shading,
    /// Linear RGBA of pixels whose ray misses.
    pub background: [f32; 4],
    /// Linear RGB of the surface.
    pub color: [f32; 3],
}

/// Axis-aligned world-space box of the grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: DVec3,
    pub max: DVec3,
}

/// Signed-distance shapes of `source = "sdf"`; `center` is subtracted before evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SdfShape {
    Sphere { radius: f64 },
    Box { half_extents: DVec3 },
    Torus { major_radius: f64, minor_radius: f64 },
    Gyroid { scale: f64, thickness: f64 },
}
