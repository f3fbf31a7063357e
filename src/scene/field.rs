//! The `[field]` table: which keys each source takes, and building its [`FieldSpec`].
//!
//! ```text
//!   source    keys (besides source, bounds)                       grid size from
//!   sdf       shape, center, resolution, + the shape's parameters  resolution
//!   corners   values (8 numbers, v000 v100 v010 v110 v001 ...)     2x2x2
//!   npy       path                                                 the array's shape
//!   raw       path, dims, dtype, endian                            dims
//!   expr      expression, resolution                               resolution
//!   mesh      path, resolution (points on the longest axis)         the mesh's box + 5%
//! ```
//!
//! `mesh` takes no `bounds`: its box is the mesh's bounding box grown by 5% of its longest side
//! on every side, with cubic cells (`field::mesh_sdf::grid_for`).
//!
//! A key of another source (or another shape) is an error that says whose key it is. Data
//! files are opened here, but only their headers and lengths are read: the memory cap and
//! truncation are caught at load time, the samples are read by [`FieldSpec::sample`].

use std::path::Path;

use glam::DVec3;

use super::error::{SceneError, SceneErrorKind};
use super::read::{self, choice, integer, number_where, points3, string, vec3, Result, View};
use super::tree::{Node, Origin, Source};
use super::validate::show_vec;
use super::{Bounds, SdfShape};
use crate::field::{
    mesh_sdf, Endian, ExprSource, FieldError, FieldSource, FieldSpec, GridLimits, MeshSource,
    NpySource, RawSource, SampleType,
};

const SOURCES: [&str; 6] = ["sdf", "corners", "npy", "raw", "expr", "mesh"];
/// Most grid points along the longest axis of a mesh field (the memory cap is checked too).
const MAX_MESH_RESOLUTION: i64 = 1 << 16;
const COMMON: [&str; 2] = ["source", "bounds"];
const SHAPES: [&str; 4] = ["sphere", "box", "torus", "gyroid"];
const SHAPE_PARAMS: [&str; 6] =
    ["radius", "half_extents", "major_radius", "minor_radius", "scale", "thickness"];

/// Keys of each source, besides `source` and `bounds`.
fn source_keys(source: &str) -> &'static [&'static str] {
    match source {
        "sdf" => &[
            "shape",
            "center",
            "resolution",
            "radius",
            "half_extents",
            "major_radius",
            "minor_radius",
            "scale",
            "thickness",
        ],
        "corners" => &["values"],
        "npy" => &["path"],
        "raw" => &["path", "dims", "dtype", "endian"],
        "expr" => &["expression", "resolution"],
        "mesh" => &["path", "resolution"],
        _ => &[],
    }
}

/// Position of a key in the listing of every `[field]` key (first mention wins).
fn all_keys_order(key: &str) -> usize {
    COMMON
        .iter()
        .chain(SOURCES.iter().flat_map(|s| source_keys(s)))
        .position(|k| *k == key)
        .unwrap_or(usize::MAX)
}

/// Parameters of each shape.
fn shape_params(shape: &str) -> &'static [&'static str] {
    match shape {
        "sphere" => &["radius"],
        "box" => &["half_extents"],
        "torus" => &["major_radius", "minor_radius"],
        "gyroid" => &["scale", "thickness"],
        _ => &[],
    }
}

/// Reads and checks `[field]`.
pub(crate) fn field(root: &View, base_dir: &Path, limits: &GridLimits) -> Result<FieldSpec> {
    let t = root.table("field")?;
    if t.table.is_none() {
        return Err(root.src.err(
            SceneErrorKind::Missing,
            root.at,
            "field",
            "missing table; add [field] with source = \"sdf\", \"corners\", \"npy\", \"raw\", \"expr\" or \"mesh\"",
        ));
    }
    let mut all: Vec<&str> =
        COMMON.iter().chain(SOURCES.iter().flat_map(|s| source_keys(s))).copied().collect();
    all.sort_by_key(|k| all_keys_order(k));
    all.dedup();
    let sources = SOURCES.map(|s| (s, s));
    let Some(source_node) = t.get("source") else {
        t.check_keys(&all)?;
        return Err(t.missing(
            "source",
            "one of \"sdf\", \"corners\", \"npy\", \"raw\", \"expr\", \"mesh\"",
        ));
    };
    let source = choice(t.src, "field.source", source_node, &sources)?;
    let common: &[&str] = if source == "mesh" { &COMMON[..1] } else { &COMMON };
    let allowed: Vec<&str> = common.iter().chain(source_keys(source)).copied().collect();
    t.check_keys_with(&allowed, |key| {
        if source == "mesh" && key == "bounds" {
            return Some(
                "not a key of source \"mesh\" (its box is the mesh's bounding box grown by 5% \
                 of its longest side on every side)"
                    .to_string(),
            );
        }
        let owners: Vec<&str> =
            SOURCES.iter().filter(|s| source_keys(s).contains(&key)).copied().collect();
        (!owners.is_empty()).then(|| {
            format!(
                "not a key of source \"{source}\" (it belongs to {}; \"{source}\" takes {})",
                owners.iter().map(|o| format!("\"{o}\"")).collect::<Vec<_>>().join(", "),
                allowed.join(", ")
            )
        })
    })?;

    let mut mesh_bounds = None;
    let (source_value, resolution) = match source {
        "sdf" => {
            let shape = sdf_shape(&t)?;
            let center = t.or("center", DVec3::ZERO, vec3)?;
            let res = resolution(&t, limits)?;
            (FieldSource::Sdf { shape, center }, res)
        }
        "corners" => {
            let v = t.required(
                "values",
                "8 corner values v000, v100, v010, v110, v001, v101, v011, v111",
                read::numbers::<8>,
            )?;
            (FieldSource::Corners(v), [2, 2, 2])
        }
        "npy" => {
            let (node, path) = data_path(&t, base_dir)?;
            let npy = NpySource::open(&path, limits)
                .map_err(|e| data_error(t.src, "field.path", node, e))?;
            let dims = npy.dims;
            (FieldSource::Npy(npy), dims)
        }
        "raw" => {
            let (path_node, path) = data_path(&t, base_dir)?;
            let dims =
                t.required("dims", "grid points along x, y, z, e.g. [64, 64, 64]", points3)?;
            let types = SampleType::ALL.map(|ty| (ty.name(), ty));
            let dtype =
                t.required("dtype", "\"u8\", \"u16\", \"i16\", \"f32\" or \"f64\"", |s, k, n| {
                    choice(s, k, n, &types)
                })?;
            let endians = [("little", Endian::Little), ("big", Endian::Big)];
            let endian = t.or("endian", Endian::Little, |s, k, n| choice(s, k, n, &endians))?;
            let raw = RawSource { path, dims, dtype, endian };
            raw.check(limits).map_err(|e| match e {
                FieldError::Io { .. } => data_error(t.src, "field.path", path_node, e),
                // Too large, truncated or too long: the dims are the likeliest mistake.
                _ => data_error(t.src, "field.dims", t.get("dims").unwrap_or(path_node), e),
            })?;
            (FieldSource::Raw(raw), dims)
        }
        "mesh" => {
            let (path_node, path) = data_path(&t, base_dir)?;
            let res_node = t.get("resolution").ok_or_else(|| {
                t.missing("resolution", "grid points along the mesh's longest axis, e.g. 64")
            })?;
            let n = integer(t.src, "field.resolution", res_node, 2, MAX_MESH_RESOLUTION)? as usize;
            let mesh = MeshSource::open(&path)
                .map_err(|e| data_error(t.src, "field.path", path_node, e))?;
            let (lo, hi) = mesh.mesh.bounds();
            let (dims, bounds) = mesh_sdf::grid_for(lo, hi, n);
            limits
                .check(dims.map(|d| d as u64), "field.resolution")
                .map_err(|e| data_error(t.src, "field.resolution", res_node, e))?;
            mesh_bounds = Some(bounds);
            (FieldSource::Mesh(mesh), dims)
        }
        _ => {
            let node = t
                .get("expression")
                .ok_or_else(|| t.missing("expression", "e.g. \"sin(3*x)*cos(3*y) + z - 0.2*t\""))?;
            let text = string(t.src, "field.expression", node)?;
            let expr = ExprSource::parse(text).map_err(|e| match e {
                FieldError::Expr { message, .. } => {
                    t.src.err(SceneErrorKind::Value, node.at, "field.expression", message)
                }
                other => data_error(t.src, "field.expression", node, other),
            })?;
            (FieldSource::Expr(expr), resolution(&t, limits)?)
        }
    };

    let bounds = match (mesh_bounds, t.get("bounds")) {
        (Some(b), _) => b,
        (None, None) => Bounds::index_space(resolution),
        (None, Some(_)) => bounds(&t.table("bounds")?)?,
    };
    Ok(FieldSpec { source: source_value, resolution, bounds })
}

/// `resolution`, required, checked against the memory cap.
fn resolution(t: &View, limits: &GridLimits) -> Result<[usize; 3]> {
    let node = t
        .get("resolution")
        .ok_or_else(|| t.missing("resolution", "grid points along x, y, z, e.g. [48, 48, 48]"))?;
    let res = points3(t.src, "field.resolution", node)?;
    limits
        .check(res.map(|n| n as u64), "field.resolution")
        .map_err(|e| data_error(t.src, "field.resolution", node, e))?;
    Ok(res)
}

/// The shape and its parameters; parameters of other shapes are errors.
fn sdf_shape(t: &View) -> Result<SdfShape> {
    let shapes = SHAPES.map(|s| (s, s));
    let shape =
        t.required("shape", "\"sphere\", \"box\", \"torus\" or \"gyroid\"", |s, k, n| {
            choice(s, k, n, &shapes)
        })?;
    let params = shape_params(shape);
    let allowed: Vec<&str> = ["source", "bounds", "shape", "center", "resolution"]
        .into_iter()
        .chain(params.iter().copied())
        .collect();
    t.check_keys_with(&allowed, |key| {
        SHAPE_PARAMS.contains(&key).then(|| {
            format!("not a parameter of shape \"{shape}\" ({shape} takes {})", params.join(", "))
        })
    })?;
    let hint = |key: &str| format!("shape \"{shape}\" needs {key}");
    let positive = |key: &str| {
        t.required(key, &hint(key), |s, k, n| {
            number_where(s, k, n, |x| x > 0.0, "must be positive")
        })
    };
    Ok(match shape {
        "sphere" => SdfShape::Sphere { radius: positive("radius")? },
        "box" => SdfShape::Box {
            half_extents: t.required(
                "half_extents",
                &hint("half_extents = [bx, by, bz]"),
                |s, k, n| {
                    let v = vec3(s, k, n)?;
                    if v.min_element() > 0.0 {
                        Ok(v)
                    } else {
                        Err(s.err(
                            SceneErrorKind::Value,
                            n.at,
                            k,
                            format!("every half extent must be positive, got {}", show_vec(v)),
                        ))
                    }
                },
            )?,
        },
        "torus" => SdfShape::Torus {
            major_radius: positive("major_radius")?,
            minor_radius: positive("minor_radius")?,
        },
        _ => SdfShape::Gyroid {
            scale: positive("scale")?,
            thickness: t.required("thickness", &hint("thickness"), |s, k, n| {
                number_where(s, k, n, |x| x >= 0.0, "must not be negative")
            })?,
        },
    })
}

/// `bounds = { min = [...], max = [...] }` with `min < max` on every axis.
fn bounds(t: &View) -> Result<Bounds> {
    t.check_keys(&["min", "max"])?;
    let min = t.required("min", "the grid box's corner [x, y, z]", vec3)?;
    let max = t.required("max", "the grid box's corner [x, y, z]", vec3)?;
    if let Some(axis) = (0..3).find(|&a| min[a] >= max[a]) {
        // At the table, unless an override set min or max.
        let at = ["min", "max"]
            .iter()
            .filter_map(|k| t.get(k).map(|n| n.at))
            .filter(|at| matches!(at, Origin::Override(_)))
            .max()
            .unwrap_or(t.at);
        return Err(t.src.err(
            SceneErrorKind::Value,
            at,
            &t.path,
            format!(
                "min must be below max on every axis, got min = {}, max = {} ({} axis)",
                show_vec(min),
                show_vec(max),
                ["x", "y", "z"][axis]
            ),
        ));
    }
    Ok(Bounds { min, max })
}

/// `path`, resolved against the scene file's folder.
fn data_path<'n>(t: &View<'n>, base_dir: &Path) -> Result<(&'n Node, std::path::PathBuf)> {
    let node = t
        .get("path")
        .ok_or_else(|| t.missing("path", "the data file, relative to the scene file"))?;
    let p = string(t.src, "field.path", node)?;
    if p.is_empty() {
        return Err(t.src.err(SceneErrorKind::Value, node.at, "field.path", "must not be empty"));
    }
    Ok((node, base_dir.join(p)))
}

/// A data error at `key`. The message is the field error's own line (it names the file).
fn data_error(src: &Source, key: &str, node: &Node, e: FieldError) -> SceneError {
    let text = e.to_string();
    let text = text.strip_prefix(&format!("{key}: ")).unwrap_or(&text).to_string();
    let mut err = src.err(SceneErrorKind::Data, node.at, key, text);
    err.field_error = Some(Box::new(e));
    err
}
