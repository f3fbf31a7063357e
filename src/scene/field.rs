//! The `[field]` table: which source, its keys, its box. The keys of each source are read by
//! the source itself (`field/source/`, one module per kind, through [`Params`]); this file
//! checks the keys against the kind's list, implements [`Params`] over the table (so every
//! error keeps its `file:line:col` and full key path), and adds `bounds`.
//!
//! A key of another source (or another shape) is an error that says whose key it is. Data
//! files are opened by their sources, but only their headers and lengths are read: the memory
//! cap and truncation are caught at load time, the samples are read by
//! [`crate::field::FieldSpec::sample`].

use std::path::Path;
use std::sync::Arc;

use crate::field::DataAccess;
use glam::DVec3;

use super::error::{SceneError, SceneErrorKind};
use super::read::{self, choice, integer, number_where, points3, string, vec3, Result, View};
use super::tree::{Origin, Source};
use super::validate::show_vec;
use super::Bounds;
use crate::field::interpolant::{Interpolant, Reader};
use crate::field::{
    FieldError, FieldSource, FieldSpec, Grid, GridLimits, NanPolicy, Need, Params, Residency, Rule,
    SourceKind,
};
use crate::vocab::Placement;

use crate::field::COMMON_KEYS as COMMON;

/// Every `[field]` key, each once, in the order of first mention (common keys, then each
/// kind's).
fn all_keys() -> Vec<&'static str> {
    let mut all: Vec<&str> = Vec::new();
    for key in COMMON.iter().chain(SourceKind::ALL.iter().flat_map(|k| k.keys())) {
        if !all.contains(key) {
            all.push(key);
        }
    }
    all
}

/// Reads and checks `[field]`; with `memory`, a field of samples in memory
/// ([`super::from_str_with_grid`]).
pub(crate) fn field(
    root: &View,
    base_dir: &Path,
    limits: &GridLimits,
    access: &DataAccess,
    memory: Option<&Arc<Grid>>,
) -> Result<FieldSpec> {
    match memory {
        Some(grid) => field_in_memory(root, grid, limits),
        None => field_named(root, "field", base_dir, limits, access),
    }
}

/// `[field]` over samples already in memory: no `source`, only the keys every source takes;
/// the grid's dims are the resolution, the box `bounds` or the index space.
fn field_in_memory(root: &View, grid: &Arc<Grid>, limits: &GridLimits) -> Result<FieldSpec> {
    let t = root.table("field")?;
    let allowed: Vec<&str> = COMMON.iter().copied().filter(|&k| k != "source").collect();
    t.check_keys_with(&allowed, |key| {
        (key == "source").then(|| {
            "not a key here: the field is the array passed in (its samples are the source)"
                .to_string()
        })
    })?;
    let dims = grid.dims;
    let what = "the array";
    limits.check(dims.map(|d| d as u64), what).map_err(|e| data_error(t.src, &t.path, t.at, e))?;
    let (nan, interpolation) = (nan_of(&t)?, interpolation_of(&t, "field")?);
    let source = FieldSource::Grid(grid.clone());
    let bounds = match t.get("bounds") {
        Some(_) => bounds(&t.table("bounds")?)?,
        None => Bounds::index_space(dims),
    };
    check_box(&t, &source, &bounds, &Placement::IDENTITY)?;
    Ok(FieldSpec {
        source,
        resolution: dims,
        bounds,
        placement: Placement::IDENTITY,
        residency: Residency::Whole,
        nan,
        interpolation,
    })
}

/// `[field2]`, the second scalar field `[color] by = "field2"` samples: the keys of `[field]`.
pub(crate) fn field2(
    root: &View,
    base_dir: &Path,
    limits: &GridLimits,
    access: &DataAccess,
) -> Result<Option<FieldSpec>> {
    match root.get("field2") {
        None => Ok(None),
        Some(_) => field_named(root, "field2", base_dir, limits, access).map(Some),
    }
}

fn field_named(
    root: &View,
    name: &str,
    base_dir: &Path,
    limits: &GridLimits,
    access: &DataAccess,
) -> Result<FieldSpec> {
    let t = root.table(name)?;
    let names: Vec<String> = SourceKind::ALL.iter().map(|k| format!("\"{}\"", k.name())).collect();
    if t.table.is_none() {
        let listed = match names.split_last() {
            Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
            None => String::new(),
        };
        return Err(root.src.err(
            SceneErrorKind::Missing,
            root.at,
            "field",
            format!("missing table; add [field] with source = {listed}"),
        ));
    }
    let Some(source_node) = t.get("source") else {
        t.check_keys(&all_keys())?;
        return Err(t.missing("source", &format!("one of {}", names.join(", "))));
    };
    let kinds: Vec<(&str, SourceKind)> = SourceKind::ALL.iter().map(|k| (k.name(), *k)).collect();
    let kind = choice(t.src, &t.key("source"), source_node, &kinds)?;
    // Kinds with their own box take no `bounds`.
    let common = COMMON.iter().filter(|&&k| k != "bounds" || kind.own_box().is_none());
    let allowed: Vec<&str> = common.chain(kind.keys()).copied().collect();
    let source = kind.name();
    t.check_keys_with(&allowed, |key| {
        if let (Some(why), "bounds") = (kind.own_box(), key) {
            return Some(format!("not a key of source \"{source}\" ({why})"));
        }
        let owners: Vec<&str> =
            SourceKind::ALL.iter().filter(|k| k.keys().contains(&key)).map(|k| k.name()).collect();
        (!owners.is_empty()).then(|| {
            format!(
                "not a key of source \"{source}\" (it belongs to {}; \"{source}\" takes {})",
                owners.iter().map(|o| format!("\"{o}\"")).collect::<Vec<_>>().join(", "),
                allowed.join(", ")
            )
        })
    })?;

    // `residency` (npy and raw: the kinds listing it): with "active" or "auto" the whole grid
    // may be over the cap (the cap then applies to the bricks a render uploads).
    let residency = match t.get("residency") {
        Some(node) => choice(t.src, &t.key("residency"), node, &Residency::NAMES)?,
        // Only the kinds that take the key can be read in parts; the others are sampled whole.
        None if kind.keys().contains(&"residency") => Residency::default(),
        None => Residency::Whole,
    };
    let (nan, interpolation) = (nan_of(&t)?, interpolation_of(&t, name)?);
    let unlimited = GridLimits { max_bytes: u64::MAX };
    let limits = if residency == Residency::Whole { limits } else { &unlimited };
    let parsed = kind.parse(&FieldParams { t: &t, base_dir, limits, access })?;
    // A `bounds` key wins over a file header's box and orientation (kinds that set their own
    // box refuse the key above); without either, the grid's index space.
    let (bounds, placement) = match (t.get("bounds"), parsed.bounds) {
        (Some(_), _) => (bounds(&t.table("bounds")?)?, Placement::IDENTITY),
        (None, Some(b)) => (b, parsed.placement.unwrap_or_default()),
        (None, None) => (Bounds::index_space(parsed.resolution), Placement::IDENTITY),
    };
    check_box(&t, &parsed.source, &bounds, &placement)?;
    Ok(FieldSpec {
        source: parsed.source,
        resolution: parsed.resolution,
        bounds,
        placement,
        residency,
        nan,
        interpolation,
    })
}

/// The `[field]` table as a source's [`Params`].
struct FieldParams<'v, 'a> {
    t: &'v View<'a>,
    base_dir: &'v Path,
    limits: &'v GridLimits,
    access: &'v DataAccess,
}

impl FieldParams<'_, '_> {
    fn read<T>(
        &self,
        key: &str,
        need: Need<T>,
        read: impl FnOnce(&Source, &str, &super::tree::Node) -> Result<T>,
    ) -> Result<T> {
        match need {
            Need::Required(hint) => self.t.required(key, hint, read),
            Need::Or(default) => self.t.or(key, default, read),
        }
    }
}

impl Params for FieldParams<'_, '_> {
    type Error = SceneError;

    fn base_dir(&self) -> &Path {
        self.base_dir
    }

    fn limits(&self) -> &GridLimits {
        self.limits
    }

    fn access(&self) -> &DataAccess {
        self.access
    }

    fn number(&self, key: &str, need: Need<f64>, rule: Option<Rule<f64>>) -> Result<f64> {
        self.read(key, need, |s, k, n| match rule {
            None => read::number(s, k, n),
            Some(r) => number_where(s, k, n, r.ok, r.message),
        })
    }

    fn vec3(&self, key: &str, need: Need<DVec3>, rule: Option<Rule<DVec3>>) -> Result<DVec3> {
        self.read(key, need, |s, k, n| {
            let v = vec3(s, k, n)?;
            match rule {
                Some(r) if !(r.ok)(v) => Err(s.err(
                    SceneErrorKind::Value,
                    n.at,
                    k,
                    format!("{}, got {}", r.message, show_vec(v)),
                )),
                _ => Ok(v),
            }
        })
    }

    fn numbers8(&self, key: &str, need: Need<[f64; 8]>) -> Result<[f64; 8]> {
        self.read(key, need, read::numbers::<8>)
    }

    fn points3(&self, key: &str, need: Need<[usize; 3]>) -> Result<[usize; 3]> {
        self.read(key, need, points3)
    }

    fn integer(&self, key: &str, need: Need<i64>, lo: i64, hi: i64) -> Result<i64> {
        self.read(key, need, |s, k, n| integer(s, k, n, lo, hi))
    }

    fn string(&self, key: &str, need: Need<&str>) -> Result<String> {
        let need = match need {
            Need::Required(hint) => Need::Required(hint),
            Need::Or(default) => Need::Or(default.to_string()),
        };
        self.read(key, need, |s, k, n| string(s, k, n).map(str::to_string))
    }

    fn choice<T: Copy>(&self, key: &str, need: Need<T>, options: &[(&str, T)]) -> Result<T> {
        self.read(key, need, |s, k, n| choice(s, k, n, options))
    }

    fn check_keys(&self, allowed: &[&str], explain: &dyn Fn(&str) -> Option<String>) -> Result<()> {
        self.t.check_keys_with(allowed, explain)
    }

    fn has(&self, key: &str) -> bool {
        self.t.get(key).is_some()
    }

    fn value_error(&self, key: &str, message: String) -> SceneError {
        self.t.err(SceneErrorKind::Value, key, message)
    }

    fn data_error(&self, key: &str, e: FieldError) -> SceneError {
        let at = self.t.get(key).map_or(self.t.at, |n| n.at);
        data_error(self.t.src, &self.t.key(key), at, e)
    }
}

/// `bounds = { min = [...], max = [...] }` with `min < max` on every axis.
pub(super) fn bounds(t: &View) -> Result<Bounds> {
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

/// The one check of every source's grid box, once `bounds` or the source's own box and its
/// placement are known: rays meet its corners in f32, in the grid's frame and the world's, so
/// each must be within the camera's range ([`super::within_coordinate_range`]). The error
/// names what set the box: `field.bounds`, else the file whose header (or vertices) did.
/// `nan` (every kind): what a NaN or infinite sample means.
fn nan_of(t: &View) -> Result<NanPolicy> {
    match t.get("nan") {
        Some(node) => choice(t.src, &t.key("nan"), node, &NanPolicy::NAMES),
        None => Ok(NanPolicy::default()),
    }
}

/// `interpolation` (every kind) of the table `name`: how the field is evaluated between its
/// samples. Which readers take which is asked where each reads (`Interpolant::refusal`);
/// `[field2]` is sampled for colour, trilinearly.
fn interpolation_of(t: &View, name: &str) -> Result<Interpolant> {
    let Some(node) = t.get("interpolation") else {
        return Ok(Interpolant::default());
    };
    let names = Interpolant::ALL.map(|i| (i.name(), i));
    let chosen = choice(t.src, &t.key("interpolation"), node, &names)?;
    if name == "field2" {
        if let Some(why) = chosen.refusal(Reader::Colour) {
            return Err(t.err(SceneErrorKind::Value, "interpolation", why));
        }
    }
    Ok(chosen)
}

fn check_box(t: &View, source: &FieldSource, b: &Bounds, placement: &Placement) -> Result<()> {
    let corners = (0..8).map(|n| {
        DVec3::new(
            if n & 1 == 0 { b.min.x } else { b.max.x },
            if n & 2 == 0 { b.min.y } else { b.max.y },
            if n & 4 == 0 { b.min.z } else { b.max.z },
        )
    });
    let ok = corners.into_iter().all(|p| {
        super::within_coordinate_range(p)
            && super::within_coordinate_range(placement.point_to_world(p))
    });
    if ok {
        return Ok(());
    }
    let extent = format!("{}..{}", show_vec(b.min), show_vec(b.max));
    let rule = super::coordinate_rule();
    if t.get("bounds").is_some() {
        let why = format!("the grid box {extent} is too large: {rule}");
        return Err(t.err(SceneErrorKind::Value, "bounds", why));
    }
    let e = match source {
        FieldSource::File(f) => FieldError::Format {
            path: f.path.clone(),
            format: f.format.title(),
            message: format!(
                "{}: the grid box from its header, {extent}, is too large: {rule}",
                f.format.geometry_fields()
            ),
        },
        FieldSource::Mesh(m) => FieldError::BadMesh {
            path: m.path.clone(),
            message: format!("the grid box around its vertices, {extent}, is too large: {rule}"),
        },
        // The index space of any grid a file can declare is far inside the range; should a
        // source without a file or `bounds` ever give a box, the table is blamed.
        _ => {
            let why = format!("the grid box {extent} is too large: {rule}");
            return Err(t.src.err(SceneErrorKind::Value, t.at, &t.path, why));
        }
    };
    Err(data_error(t.src, &t.key("path"), t.get("path").map_or(t.at, |n| n.at), e))
}

/// A data error at `key`. The message is the field error's own line (it names the file).
fn data_error(src: &Source, key: &str, at: Origin, e: FieldError) -> SceneError {
    let text = e.to_string();
    let text = text.strip_prefix(&format!("{key}: ")).unwrap_or(&text).to_string();
    let mut err = src.err(SceneErrorKind::Data, at, key, text);
    err.field_error = Some(Box::new(e));
    err
}
