//! The shared vocabulary of the pipeline: plain types that the scene, the field sources, the
//! mesh extractors and the passes all speak. It depends on nothing else in the crate, so every
//! module may use it without creating a cycle (README "Layout"); `scene` re-exports it.

use glam::DVec3;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Inside {
    /// Values below the isovalue are inside (signed distance fields).
    Below,
    /// Values above the isovalue are inside.
    Above,
}

impl Inside {
    /// Both conventions.
    pub const ALL: [Inside; 2] = [Inside::Below, Inside::Above];

    /// The name as written in scene files.
    pub fn name(self) -> &'static str {
        match self {
            Inside::Below => "below",
            Inside::Above => "above",
        }
    }

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

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshAlgorithm {
    MarchingCubes,
    Mc33,
    SurfaceNets,
    DualContouring,
    MarchingTetrahedra,
}

impl MeshAlgorithm {
    /// Every algorithm, in the order the contract lists them.
    pub const ALL: [MeshAlgorithm; 5] = [
        MeshAlgorithm::MarchingCubes,
        MeshAlgorithm::Mc33,
        MeshAlgorithm::SurfaceNets,
        MeshAlgorithm::DualContouring,
        MeshAlgorithm::MarchingTetrahedra,
    ];

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

/// Axis-aligned world-space box of the grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: DVec3,
    pub max: DVec3,
}

impl Bounds {
    /// The unit cube `[0, 1]^3`.
    pub const UNIT: Bounds = Bounds { min: DVec3::ZERO, max: DVec3::ONE };

    /// The grid's own index space, `[0, 0, 0]..[nx - 1, ny - 1, nz - 1]`: the default when a
    /// scene gives no `bounds` (for one cell, the unit cube).
    pub fn index_space(resolution: [usize; 3]) -> Bounds {
        let [nx, ny, nz] = resolution.map(|n| n.saturating_sub(1) as f64);
        Bounds { min: DVec3::ZERO, max: DVec3::new(nx, ny, nz) }
    }
}

/// Signed-distance shapes of `source = "sdf"`; `center` is subtracted before evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SdfShape {
    Sphere { radius: f64 },
    Box { half_extents: DVec3 },
    Torus { major_radius: f64, minor_radius: f64 },
    Gyroid { scale: f64, thickness: f64 },
}
