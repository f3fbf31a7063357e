//! `source = "mesh"`: the signed distance to a triangle mesh file (`path`: STL, OBJ or PLY),
//! negative inside, on a grid of `resolution` points along the mesh's longest axis with cubic
//! cells. It takes no `bounds`: its box is the mesh's bounding box grown by 5% of its longest
//! side on every side ([`crate::field::mesh_sdf::grid_for`]). The distance is
//! [`crate::field::MeshSdf`]'s (`field/mesh_sdf.rs`).

use super::params::{self, Need, Params};
use super::{fill, FieldSource, Info, Parsed, PointField, Supports};
use crate::field::{mesh_sdf, Grid, MeshSdf, MeshSource};

pub(super) const INFO: Info = Info {
    name: "mesh",
    keys: &["path", "resolution"],
    own_box: Some(
        "its box is the mesh's bounding box grown by 5% of its longest side on every side",
    ),
    supports: Supports { point: true, time: false },
};

/// Most grid points along the longest axis of a mesh field (the memory cap is checked too).
const MAX_RESOLUTION: i64 = 1 << 16;

pub(super) fn parse<P: Params>(p: &P) -> Result<Parsed, P::Error> {
    let (named, path) = params::data_path_named(p)?;
    let n = p.integer(
        "resolution",
        Need::Required("grid points along the mesh's longest axis, e.g. 64"),
        2,
        MAX_RESOLUTION,
    )? as usize;
    let mesh = MeshSource::open(&path, &named, p.access()).map_err(|e| p.data_error("path", e))?;
    let (lo, hi) = mesh.mesh.bounds();
    let (dims, bounds) = mesh_sdf::grid_for(lo, hi, n);
    p.limits()
        .check(dims.map(|d| d as u64), "field.resolution")
        .map_err(|e| p.data_error("resolution", e))?;
    Ok(Parsed {
        source: FieldSource::Mesh(mesh),
        resolution: dims,
        bounds: Some(bounds),
        placement: None,
    })
}

pub(super) fn sample(
    m: &MeshSource,
    grid: &Grid,
) -> Result<Vec<f32>, crate::field::samples::Overflow> {
    let sdf = MeshSdf::new(&m.mesh);
    fill(grid, |p| sdf.distance(p))
}

pub(super) fn point(m: &MeshSource) -> PointField<'static> {
    // Not 1-Lipschitz in general: the winding-number sign of an open mesh can flip away from
    // the surface.
    let sdf = MeshSdf::new(&m.mesh);
    PointField { eval: Box::new(move |p| sdf.distance(p)), lipschitz: None }
}

pub(super) fn describe(m: &MeshSource) -> String {
    format!(
        "mesh {} ({} triangles) signed distance",
        crate::field::raw::file_name(&m.path),
        m.mesh.triangles.len()
    )
}
