//! From the value tree to a [`Scene`]: defaults for absent keys, types and ranges for present
//! ones, then the cross-key checks (eye != target, up not along the view).

use std::path::Path;

use super::error::{SceneError, SceneErrorKind};
use super::read::{self, choice, integer, number_where, numbers, vec3, Result, View};
use super::tree::{Node, Origin, Source, Value};
use super::{
    Ambiguity, CameraSettings, ColorBy, ColorSettings, HermiteNormals, ImageSettings, Inside,
    IsoRule, MeshAlgorithm, Method, Normals, Projection, RenderSettings, Scene, Shading,
    SharpSettings, SliceSettings, SurfaceSettings, COLORMAPS, MAX_SURFACES,
};
use crate::field::stats::{self, Stats};
use crate::field::{DataAccess, FieldSpec, GridLimits, SourceKind};
use crate::vocab::Clip;
use glam::DVec3;

/// Largest image side.
pub const MAX_IMAGE_SIDE: i64 = 16384;
/// The default of `--max-pixels` (`serve`, `slice`): the largest picture, width x height, a
/// command holds whole in memory, 4096 x 4096. `serve` keeps a frame's records (80 bytes a
/// pixel) for the EXR, tev and the channels the page reads; a slice picture is drawn whole
/// (32 bytes a pixel, then its channel planes). `render` streams its bands and needs no cap.
pub const DEFAULT_MAX_PIXELS: u64 = 4096 * 4096;
/// Most fixed-step samples per ray.
pub const MAX_STEPS: i64 = 1 << 20;
/// Most Newton refinements per root.
pub const MAX_NEWTON_STEPS: i64 = 64;
/// Largest `render.crossing` (far beyond any ray: a cell holds at most 3 crossings).
pub const MAX_CROSSING: i64 = 1 << 20;
/// Deepest quadtree refinement of a slice below the grid's cells.
pub const MAX_SLICE_DEPTH: i64 = 10;

const TABLES: [&str; 9] =
    ["image", "camera", "field", "surface", "render", "slice", "clip", "color", "field2"];

/// When an isovalue picked from the samples (`isovalue_sigma`, `isovalue_percentile`) is
/// picked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PickIsovalue {
    /// While the scene is loaded: the whole field is sampled for it (every verb).
    OnLoad,
    /// By whoever samples the field next, with [`Unpicked::pick`]: `serve`'s page states,
    /// loaded on a request's worker, leave it to the render thread, which samples the field
    /// anyway (a costly field held the worker for as long as its sampling took).
    WhenSampled,
}

/// An isovalue still to be picked from the samples ([`PickIsovalue::WhenSampled`]), and where
/// its key is, for the messages.
#[derive(Clone, Debug)]
pub struct Unpicked {
    /// The key's location and name; the message is the pick's.
    at: SceneError,
}

impl Unpicked {
    /// `surface` with its isovalue picked from `values`, the field's samples (the rule needs
    /// a field that does not depend on the time): the value and the message the load gives.
    pub fn pick(&self, surface: SurfaceSettings, values: &[f32]) -> Result<SurfaceSettings> {
        pick_from(surface, values).map_err(|why| SceneError { message: why, ..self.at.clone() })
    }
}

/// Validates the whole tree into a scene. `base_dir` resolves relative data paths, `access`
/// says which of them may be read, `when` when an isovalue is picked from the samples (the
/// rule left to pick comes back beside the scene).
pub(crate) fn scene(
    src: &Source,
    root: &Node,
    base_dir: &Path,
    limits: &GridLimits,
    access: &DataAccess,
    memory: Option<&std::sync::Arc<crate::field::Grid>>,
    when: PickIsovalue,
) -> Result<(Scene, Option<Unpicked>)> {
    let Value::Table(t) = &root.value else {
        return Err(src.err(SceneErrorKind::Type, root.at, "", "the scene must be a TOML table"));
    };
    let root = View { src, path: String::new(), table: Some(t), at: root.at };
    root.check_keys(&TABLES)?;
    // [field] first: a scene without a field is the most basic mistake.
    let field = super::field::field(&root, base_dir, limits, access, memory)?;
    let slice = slice(&root.table("slice")?, &field)?;
    let image = image(&root.table("image")?)?;
    let camera = camera(&root.table("camera")?, &field, &image)?;
    let surface_table = root.table("surface")?;
    let surface = surface(&surface_table)?;
    let render_table = root.table("render")?;
    let render = render(&render_table)?;
    check_hermite(&render_table, &render, &field)?;
    check_normals(&render_table, &render, &field)?;
    let clip = clip(&root)?;
    // Last: an isovalue picked from the data samples the whole field.
    let (surface, unpicked) = resolve_isovalue(&surface_table, surface, &field, limits, when)?;
    if surface.several() && render.crossing > 1 {
        return Err(root.table("render")?.err(
            SceneErrorKind::Value,
            "crossing",
            "must be 1 with several isovalues (the nearest crossing of any surface is shown)",
        ));
    }
    let field2 = super::field::field2(&root, base_dir, limits, access)?;
    let color = color(&root.table("color")?, field2.is_some())?;
    if field2.is_some() && color.by != ColorBy::Field2 {
        return Err(root.src.err(
            SceneErrorKind::Value,
            root.get("field2").map_or(root.at, |n| n.at),
            "field2",
            "is only read by [color] by = \"field2\"; add that or remove [field2]",
        ));
    }
    let scene =
        Scene { path: None, image, camera, field, surface, render, slice, clip, color, field2 };
    Ok((scene, unpicked))
}

/// `[color]`: `by`, `colormap`, `range`.
fn color(t: &View, has_field2: bool) -> Result<ColorSettings> {
    t.check_keys(&["by", "colormap", "range"])?;
    let d = ColorSettings::default();
    let bys = ColorBy::ALL.map(|b| (b.name(), b));
    let by = t.or("by", d.by, |s, k, n| choice(s, k, n, &bys))?;
    let maps: Vec<(&str, usize)> =
        COLORMAPS.iter().enumerate().map(|(i, (n, _))| (*n, i)).collect();
    let colormap = t.or("colormap", d.colormap, |s, k, n| choice(s, k, n, &maps))?;
    let range = match t.get("range") {
        None => None,
        Some(_) => {
            let [lo, hi] = t.required("range", "[lo, hi]", numbers::<2>)?;
            if lo >= hi {
                return Err(t.err(SceneErrorKind::Value, "range", "needs lo < hi"));
            }
            Some([lo, hi])
        }
    };
    if by == ColorBy::Field2 && !has_field2 {
        return Err(t.err(
            SceneErrorKind::Missing,
            "by",
            "\"field2\" needs a [field2] table (the keys of [field])",
        ));
    }
    Ok(ColorSettings { by, colormap, range })
}

/// `[[clip]]`: an array of tables, each a plane (`normal`, `offset`: removes
/// `dot(normal, p) > offset`) or a box (`box = { min, max }`: removes what lies outside it).
fn clip(root: &View) -> Result<Clip> {
    let mut out = Clip::NONE;
    let Some(node) = root.get("clip") else { return Ok(out) };
    let entries: Vec<&Node> = match &node.value {
        Value::Array(items) => items.iter().collect(),
        Value::Table(_) => vec![node],
        _ => return Err(read::type_error(root.src, "clip", node, "an array of tables ([[clip]])")),
    };
    for (i, entry) in entries.into_iter().enumerate() {
        let path = format!("clip[{i}]");
        let Value::Table(t) = &entry.value else {
            return Err(read::type_error(root.src, &path, entry, "a table ([[clip]])"));
        };
        let t = View { src: root.src, path, table: Some(t), at: entry.at };
        t.check_keys(&["normal", "offset", "box"])?;
        let full = |t: &View, key: &str| {
            t.err(
                SceneErrorKind::Value,
                key,
                format!("more than {} clip planes (a box takes 6)", Clip::MAX_PLANES),
            )
        };
        if t.get("box").is_some() {
            if let Some(k) = ["normal", "offset"].into_iter().find(|k| t.get(k).is_some()) {
                return Err(t.err(
                    SceneErrorKind::Value,
                    k,
                    "a clip entry is a plane or a box, not both",
                ));
            }
            let b = super::field::bounds(&t.table("box")?)?;
            for a in 0..3 {
                let mut n = DVec3::ZERO;
                n[a] = 1.0;
                if !(out.push(n, b.max[a]) && out.push(-n, -b.min[a])) {
                    return Err(full(&t, "box"));
                }
            }
            continue;
        }
        let normal = t.required("normal", "[nx, ny, nz]", vec3)?;
        if normal.length() == 0.0 {
            return Err(t.err(SceneErrorKind::Value, "normal", "must not be the zero vector"));
        }
        let offset = t.or("offset", 0.0, read::number)?;
        if !out.push(normal, offset) {
            return Err(full(&t, "normal"));
        }
    }
    Ok(out)
}

fn image(t: &View) -> Result<ImageSettings> {
    t.check_keys(&["width", "height"])?;
    let d = ImageSettings::default();
    let side = |src: &Source, key: &str, n: &Node| integer(src, key, n, 1, MAX_IMAGE_SIDE);
    Ok(ImageSettings {
        width: t.or("width", d.width as i64, side)? as u32,
        height: t.or("height", d.height as i64, side)? as u32,
    })
}

fn camera(t: &View, field: &FieldSpec, image: &ImageSettings) -> Result<CameraSettings> {
    t.check_keys(&["eye", "target", "up", "fov_y_deg", "projection", "ortho_height", "fit"])?;
    let d = CameraSettings::default();
    let projections = Projection::ALL.map(|p| (p.name(), p));
    let mut c = CameraSettings {
        eye: t.or("eye", d.eye, vec3)?,
        target: t.or("target", d.target, vec3)?,
        up: t.or("up", d.up, vec3)?,
        fov_y_deg: t.or("fov_y_deg", d.fov_y_deg, |s, k, n| {
            number_where(
                s,
                k,
                n,
                |f| f > 0.0 && f < 180.0,
                "must be between 0 and 180 degrees (exclusive)",
            )
        })?,
        projection: t.or("projection", d.projection, |s, k, n| choice(s, k, n, &projections))?,
        ortho_height: 0.0, // resolved below, once the view is known
    };
    for (key, v) in [("eye", c.eye), ("target", c.target), ("up", c.up)] {
        if !super::within_coordinate_range(v) {
            return Err(t.err(
                SceneErrorKind::Value,
                key,
                format!("{} is too large: {}", show_vec(v), super::coordinate_rule()),
            ));
        }
    }
    // Blame the last-written of the keys involved (a --set counts as written after the file).
    let blame = |keys: &[&'static str]| {
        keys.iter().filter_map(|k| t.get(k).map(|n| (n.at, *k))).max().map_or(keys[0], |(_, k)| k)
    };
    let forward = c.target - c.eye;
    if forward.length() <= 1e-12 * c.eye.length().max(1.0) {
        return Err(t.err(
            SceneErrorKind::Value,
            blame(&["target", "eye"]),
            format!(
                "camera.eye and camera.target are the same point {}; the camera needs a direction",
                show_vec(c.eye)
            ),
        ));
    }
    if c.up.length() == 0.0 {
        return Err(t.err(SceneErrorKind::Value, "up", "must not be the zero vector"));
    }
    if forward.normalize().cross(c.up.normalize()).length() < 1e-6 {
        return Err(t.err(
            SceneErrorKind::Value,
            blame(&["up", "target", "eye"]),
            format!(
                "camera.up {} is parallel to the view direction {} (target - eye); pick an up \
                 vector across the view",
                show_vec(c.up),
                show_vec(forward)
            ),
        ));
    }
    let fitted = t.or("fit", false, read::boolean)?;
    if fitted {
        fit(&mut c, field, image);
        // The grid box is within range (scene/field.rs), but backing off to see all of it
        // can put the eye past it: a box 1e30 wide is seen from 2e30 away.
        if !super::within_coordinate_range(c.eye) {
            return Err(t.err(
                SceneErrorKind::Value,
                "fit",
                format!(
                    "puts the eye at {} to see the whole grid box, which is too far: {}; give \
                     camera.eye and camera.target instead",
                    show_vec(c.eye),
                    super::coordinate_rule()
                ),
            ));
        }
    }
    c.ortho_height = match t.get("ortho_height") {
        Some(_) => t.required("ortho_height", "a positive number", |s, k, n| {
            number_where(s, k, n, |f| f > 0.0 && f.is_finite(), "must be a positive number")
        })?,
        None if fitted => c.ortho_height,
        None => 2.0 * (c.target - c.eye).length() * (c.fov_y_deg.to_radians() * 0.5).tan(),
    };
    Ok(c)
}

/// `camera.fit = true`: keeps the view direction and `up`, aims at the centre of the grid's
/// box (in world space, through its placement) and backs off until the box's bounding sphere
/// fills the narrower side of the picture: the distance at which the sphere's silhouette
/// touches the field of view (perspective), or an `ortho_height` of its diameter (over the
/// aspect ratio when the picture is taller than wide) with the eye as far as perspective's.
fn fit(c: &mut CameraSettings, field: &FieldSpec, image: &ImageSettings) {
    let b = &field.bounds;
    let centre = field.placement.point_to_world(0.5 * (b.min + b.max));
    let radius = 0.5 * (b.max - b.min).length();
    let forward = (c.target - c.eye).normalize();
    let aspect = image.width as f64 / image.height as f64;
    let half_y = (c.fov_y_deg.to_radians() * 0.5).tan();
    let half = half_y.min(half_y * aspect).atan();
    let distance = radius / half.sin();
    c.target = centre;
    c.eye = centre - forward * distance;
    c.ortho_height = 2.0 * radius * (1.0f64).max(1.0 / aspect);
}

/// The isovalue keys: at most one may be given.
const ISO_KEYS: [&str; 4] = ["isovalue", "isovalues", "isovalue_sigma", "isovalue_percentile"];

fn surface(t: &View) -> Result<SurfaceSettings> {
    t.check_keys(&[
        "isovalue",
        "isovalues",
        "isovalue_sigma",
        "isovalue_percentile",
        "inside",
        "colors",
    ])?;
    let d = SurfaceSettings::default();
    let insides = Inside::ALL.map(|i| (i.name(), i));
    let given: Vec<&str> = ISO_KEYS.into_iter().filter(|k| t.get(k).is_some()).collect();
    // A `--set` of one of the keys replaces the file's (the last such override wins), as any
    // override replaces what the file says; two in the file itself are an error.
    let overridden = given
        .iter()
        .filter_map(|k| match t.get(k)?.at {
            Origin::Override(i) => Some((i, *k)),
            Origin::File { .. } => None,
        })
        .max();
    let given: Vec<&str> = match overridden {
        Some((_, k)) => vec![k],
        None => given,
    };
    if let [first, second, ..] = given.as_slice() {
        return Err(t.err(
            SceneErrorKind::Value,
            second,
            format!(
                "give one of isovalue, isovalues, isovalue_sigma and isovalue_percentile, not \
                 both {first} and {second}"
            ),
        ));
    }
    let inside = t.or("inside", d.inside, |s, k, n| choice(s, k, n, &insides))?;
    let isovalue = match given.first() {
        Some(&"isovalue") | None => t.or("isovalue", d.isovalue, level)?,
        Some(_) => d.isovalue, // resolved from the samples
    };
    let percent = |s: &Source, k: &str, n: &Node| {
        number_where(s, k, n, |p| (0.0..=100.0).contains(&p), "must be in 0..=100")
    };
    let rule = match given.first().copied() {
        Some("isovalue_sigma") => {
            IsoRule::Sigma { k: t.or("isovalue_sigma", 0.0, read::number)?, mean: 0.0, sigma: 0.0 }
        }
        Some("isovalue_percentile") => {
            IsoRule::Percentile { p: t.or("isovalue_percentile", 0.0, percent)? }
        }
        _ => IsoRule::Value,
    };
    let mut out = SurfaceSettings { isovalue, inside, rule, ..d };
    if given.first() == Some(&"isovalues") {
        let values = list(t, "isovalues", "numbers", level)?;
        out.isovalue = values[0];
        out.more[..values.len() - 1].copy_from_slice(&values[1..]);
        out.count = values.len();
    }
    if t.get("colors").is_some() {
        let mut colors = list(t, "colors", "[r, g, b] colours", colour::<3>)?;
        // An override of the isovalues keeps the file's colours for the surfaces it keeps.
        if overridden.is_some() && colors.len() > out.count {
            colors.truncate(out.count);
        }
        if colors.len() != out.count {
            return Err(t.err(
                SceneErrorKind::Value,
                "colors",
                format!(
                    "needs one colour per surface: {} for {} isovalue(s)",
                    colors.len(),
                    out.count
                ),
            ));
        }
        let mut all = [[0.0; 3]; MAX_SURFACES];
        all[..colors.len()].copy_from_slice(&colors);
        out.colors = Some(all);
    }
    Ok(out)
}

/// An isovalue: a number within f32's range, as the GPU compares samples with it in f32
/// (1e308 would become inf there and no sample would reach it).
fn level(s: &Source, k: &str, n: &Node) -> Result<f64> {
    number_where(s, k, n, |v| v.abs() <= f32::MAX as f64, &f32_range())
}

/// What [`level`] requires, for messages (also the isovalue resolved from `isovalue_sigma`).
fn f32_range() -> String {
    format!("must be within ±{:e} (isovalues are compared in 32-bit floats)", f32::MAX)
}

/// An array of 1 to [`MAX_SURFACES`] items, each read by `item`.
fn list<T>(
    t: &View,
    key: &str,
    what: &str,
    item: impl Fn(&Source, &str, &Node) -> Result<T>,
) -> Result<Vec<T>> {
    let node = t.get(key).expect("the caller checked the key is there");
    let Value::Array(items) = &node.value else {
        return Err(read::type_error(t.src, &t.key(key), node, &format!("an array of {what}")));
    };
    if items.is_empty() || items.len() > MAX_SURFACES {
        return Err(t.err(
            SceneErrorKind::Value,
            key,
            format!("must hold 1 to {MAX_SURFACES} {what}, got {}", items.len()),
        ));
    }
    items.iter().map(|n| item(t.src, &t.key(key), n)).collect()
}

/// The isovalue of `isovalue_sigma` or `isovalue_percentile`, resolved once from the samples
/// every verb will see (the field at time 0); or, `when` it is picked later, the rule to pick
/// it by.
fn resolve_isovalue(
    t: &View,
    surface: SurfaceSettings,
    field: &FieldSpec,
    limits: &GridLimits,
    when: PickIsovalue,
) -> Result<(SurfaceSettings, Option<Unpicked>)> {
    let key = match surface.rule {
        IsoRule::Value => return Ok((surface, None)),
        IsoRule::Sigma { .. } => "isovalue_sigma",
        IsoRule::Percentile { .. } => "isovalue_percentile",
    };
    if field.is_time_varying() {
        return Err(t.err(
            SceneErrorKind::Value,
            key,
            "needs a field that does not depend on the time t; give isovalue instead",
        ));
    }
    let unpicked = Unpicked { at: t.err(SceneErrorKind::Value, key, "") };
    if when == PickIsovalue::WhenSampled {
        return Ok((surface, Some(unpicked)));
    }
    let grid = field
        .sample_with(0.0, limits)
        .map_err(|e| t.err(SceneErrorKind::Data, key, format!("cannot sample the field: {e}")))?;
    Ok((unpicked.pick(surface, &grid.values)?, None))
}

/// `surface` with its isovalue picked from `values` by its rule, or why the value cannot be
/// an isovalue.
fn pick_from(
    surface: SurfaceSettings,
    values: &[f32],
) -> std::result::Result<SurfaceSettings, String> {
    // A grid whose every sample is missing data has no mean or percentile: picking 0 there
    // rendered nothing and said nothing.
    let none = || {
        format!(
            "the field has no finite sample to pick the isovalue from (all {} are NaN or \
             ±inf: missing data); give isovalue instead",
            values.len()
        )
    };
    let (isovalue, rule) = match surface.rule {
        IsoRule::Sigma { k, .. } => {
            let (mean, sigma) = stats::moments(values).ok_or_else(none)?;
            (mean + k * sigma, IsoRule::Sigma { k, mean, sigma })
        }
        // Only percentiles need the sorted copy Stats keeps.
        IsoRule::Percentile { p } => {
            (Stats::of(values).percentile(p).ok_or_else(none)?, surface.rule)
        }
        IsoRule::Value => (surface.isovalue, surface.rule),
    };
    // mean + k sigma of f32 samples may pass f32's range for a large k (a percentile cannot).
    if isovalue.abs() > f32::MAX as f64 {
        return Err(format!(
            "gives the isovalue {}, which {}",
            super::tree::show_float(isovalue),
            f32_range()
        ));
    }
    Ok(SurfaceSettings { isovalue, rule, ..surface })
}

fn render(t: &View) -> Result<RenderSettings> {
    t.check_keys(&[
        "method",
        "steps",
        "newton_steps",
        "skip",
        "occupancy",
        "crossing",
        "count_crossings",
        "mesh",
        "mesh_refine",
        "shading",
        "normals",
        "background",
        "color",
        "hermite",
        "qef_threshold",
        "qef_clamp",
        "feature_angle",
        "mesh_error",
    ])?;
    let d = RenderSettings::default();
    let methods = Method::ALL.map(|m| (m.name(), m));
    let meshes = MeshAlgorithm::ALL.map(|m| (m.name(), m));
    let shadings = Shading::ALL.map(|m| (m.name(), m));
    let normals = Normals::ALL.map(|m| (m.name(), m));
    Ok(RenderSettings {
        method: t.or("method", d.method, |s, k, n| choice(s, k, n, &methods))?,
        steps: t.or("steps", d.steps as i64, |s, k, n| integer(s, k, n, 2, MAX_STEPS))? as u32,
        newton_steps: t.or("newton_steps", d.newton_steps as i64, |s, k, n| {
            integer(s, k, n, 0, MAX_NEWTON_STEPS)
        })? as u32,
        skip: t.or("skip", d.skip, read::boolean)?,
        occupancy: t.or("occupancy", d.occupancy, read::boolean)?,
        crossing: t
            .or("crossing", d.crossing as i64, |s, k, n| integer(s, k, n, 1, MAX_CROSSING))?
            as u32,
        count_crossings: t.or("count_crossings", d.count_crossings, read::boolean)?,
        mesh: t.or("mesh", d.mesh, |s, k, n| choice(s, k, n, &meshes))?,
        mesh_refine: t.or("mesh_refine", d.mesh_refine as i64, |s, k, n| {
            integer(s, k, n, 1, crate::mesh::refine::MAX_REFINE as i64)
        })? as u32,
        sharp: sharp(t)?,
        shading: t.or("shading", d.shading, |s, k, n| choice(s, k, n, &shadings))?,
        normals: t.or("normals", d.normals, |s, k, n| choice(s, k, n, &normals))?,
        background: t.or("background", d.background, colour::<4>)?,
        color: t.or("color", d.color, colour::<3>)?,
    })
}

/// The sharp-feature meshes' keys of `[render]` (`SharpSettings`).
fn sharp(t: &View) -> Result<SharpSettings> {
    let d = SharpSettings::default();
    let hermites = HermiteNormals::ALL.map(|h| (h.name(), h));
    Ok(SharpSettings {
        hermite: t.or("hermite", d.hermite, |s, k, n| choice(s, k, n, &hermites))?,
        qef_threshold: t.or("qef_threshold", d.qef_threshold, |s, k, n| {
            number_where(s, k, n, |x| x > 0.0 && x < 1.0, "must be in (0, 1)")
        })?,
        qef_clamp: t.or("qef_clamp", d.qef_clamp, read::boolean)?,
        feature_angle_deg: t.or("feature_angle", d.feature_angle_deg, |s, k, n| {
            number_where(s, k, n, |x| x > 0.0 && x < 180.0, "must be in (0, 180) degrees")
        })?,
        mesh_error: t.or("mesh_error", d.mesh_error, |s, k, n| {
            number_where(s, k, n, |x| x > 0.0, "must be a positive length (world units)").map(Some)
        })?,
    })
}

/// `render.hermite = "source"` needs a source that can be evaluated off the grid;
/// `render.mesh_error` is the adaptive `dual-contouring-qef`'s.
fn check_hermite(t: &View, render: &RenderSettings, field: &FieldSpec) -> Result<()> {
    if render.sharp.mesh_error.is_some() && !render.mesh.method().adaptive {
        return Err(t.err(
            SceneErrorKind::Value,
            "mesh_error",
            format!(
                "the adaptive octree is built for mesh = {}, not \"{}\"",
                crate::mesh::method::Method::names_where(|m| m.adaptive),
                render.mesh.name()
            ),
        ));
    }
    if render.sharp.hermite == HermiteNormals::Source && !field.source.supports().point {
        return Err(t.err(
            SceneErrorKind::Value,
            "hermite",
            format!(
                "\"source\" takes crossings and normals from the field's source, which needs \
                 an {} source (this field is sampled data); use \"trilinear\"",
                SourceKind::names_where(|k| k.supports().point)
            ),
        ));
    }
    Ok(())
}

/// `render.normals = "smooth"` stands in for the gradient of a trilinear field (and of the
/// device's filtering of one); the cubic interpolants have their exact smooth gradient and
/// nearest has its voxel faces, so it is refused with those (`reference::shade::smoothed`).
fn check_normals(t: &View, render: &RenderSettings, field: &FieldSpec) -> Result<()> {
    use crate::field::interpolant::Interpolant;
    let interp = field.interpolation;
    let own = match interp {
        Interpolant::Trilinear | Interpolant::Device => return Ok(()),
        Interpolant::CubicBspline | Interpolant::CatmullRom => {
            "their exact gradient, smooth already"
        }
        Interpolant::Nearest => "the voxels' faces",
    };
    if render.normals != Normals::Smooth {
        return Ok(());
    }
    Err(t.err(
        SceneErrorKind::Value,
        "normals",
        format!(
            "\"smooth\" interpolates point gradients in place of a trilinear field's; \
             field.interpolation = \"{}\" fields have {own} (use \"trilinear\": the \
             interpolant's own normal)",
            interp.name()
        ),
    ))
}

fn slice(t: &View, field: &FieldSpec) -> Result<SliceSettings> {
    t.check_keys(&["ambiguity", "max_depth", "width", "height"])?;
    let d = SliceSettings::default();
    let rules = Ambiguity::ALL.map(|a| (a.name(), a));
    let side = |src: &Source, key: &str, n: &Node| integer(src, key, n, 1, MAX_IMAGE_SIDE);
    let s = SliceSettings {
        ambiguity: t.or("ambiguity", d.ambiguity, |s, k, n| choice(s, k, n, &rules))?,
        max_depth: t
            .or("max_depth", d.max_depth as i64, |s, k, n| integer(s, k, n, 0, MAX_SLICE_DEPTH))?
            as u32,
        width: t.or("width", None, |s, k, n| side(s, k, n).map(|w| Some(w as u32)))?,
        height: t.or("height", None, |s, k, n| side(s, k, n).map(|h| Some(h as u32)))?,
    };
    // Asked of the source: "sample" needs one that can be evaluated off the grid.
    if s.ambiguity == Ambiguity::Sample && !field.source.supports().point {
        return Err(t.err(
            SceneErrorKind::Value,
            "ambiguity",
            format!(
                "\"sample\" evaluates the field's source at cell centres, which needs an {} \
                 source (this field is sampled data); use \"average\" or \"saddle\"",
                SourceKind::names_where(|k| k.supports().point)
            ),
        ));
    }
    Ok(s)
}

/// A linear colour: `N` finite numbers that fit an `f32`.
fn colour<const N: usize>(src: &Source, key: &str, node: &Node) -> Result<[f32; N]> {
    let c = numbers::<N>(src, key, node)?;
    if c.iter().any(|x| x.abs() > f32::MAX as f64) {
        return Err(src.err(
            SceneErrorKind::Value,
            node.at,
            key,
            format!("colour components must fit a 32-bit float, got {}", super::tree::show(node)),
        ));
    }
    Ok(c.map(|x| x as f32))
}

pub(crate) fn show_vec(v: glam::DVec3) -> String {
    use super::tree::show_float;
    format!("[{}, {}, {}]", show_float(v.x), show_float(v.y), show_float(v.z))
}
