//! The view: a scene file, the `--set` overrides in force and the field's time. Every change
//! arrives whole (`POST /api/state`), is loaded and validated exactly like the command line's
//! `--set` (same messages), and only then posted to the render thread.

use std::path::Path;
use std::time::Instant;

use serde_json::{json, Value};

use crate::field::{DataAccess, FieldError, FieldSource, FieldSpec, Grid};
use crate::scene::{self, PickIsovalue, Scene, SceneError, Unpicked};

/// What a state may ask for: which data files it may name, how large an image.
#[derive(Clone, Debug)]
pub struct Policy {
    pub access: DataAccess,
    pub max_pixels: u64,
    /// The device's largest 3D image, points per axis, once the device is open (None before:
    /// `prepare` runs before the GPU is touched). serve uploads every grid whole, as one
    /// image: a state over it is refused when posted, with the line `render` exits 2 with,
    /// rather than accepted and answered 500 on its frame.
    pub max_image_extent: Option<u32>,
    /// When an isovalue picked from the samples (`isovalue_sigma`, `isovalue_percentile`) is
    /// picked: the command line's state on load (a bad one exits 2 before serving), the
    /// page's by the render thread once it has sampled the field ([`ViewState::unpicked`]),
    /// since a load on the request's worker sampled the whole field there.
    pub pick: PickIsovalue,
}

impl Policy {
    /// The command line's own state: any file (the user named them), the image cap.
    pub fn command_line(max_pixels: u64) -> Policy {
        let pick = PickIsovalue::OnLoad;
        Policy { access: DataAccess::Any, max_pixels, max_image_extent: None, pick }
    }

    /// The page's states: files within the scene's folder, each of `allow_dirs`, and the data
    /// files `first` (the command line's state) reads.
    pub fn page(
        scene_path: &Path,
        allow_dirs: &[std::path::PathBuf],
        first: &Scene,
        max_pixels: u64,
    ) -> Result<Policy, String> {
        let folder = match scene_path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => std::path::PathBuf::from("."),
        };
        let own = [Some(&first.field), first.field2.as_ref()]
            .into_iter()
            .flatten()
            .filter_map(|spec: &FieldSpec| spec.source.data_path())
            .map(Path::to_path_buf);
        // `--allow-dir` names a folder: a file, FIFO or device given by mistake is refused
        // rather than taken silently (a missing one is `DataAccess::within`'s "file not found").
        for dir in allow_dirs {
            let kind = std::fs::metadata(dir).ok().and_then(|m| {
                if m.is_file() {
                    Some("a regular file")
                } else {
                    crate::vocab::special_file(&m).filter(|_| !m.is_dir())
                }
            });
            if let Some(kind) = kind {
                let shown = crate::vocab::echo(&dir.display().to_string());
                return Err(format!("--allow-dir {shown}: is {kind}, not a folder"));
            }
        }
        let roots = std::iter::once(folder).chain(allow_dirs.iter().cloned()).chain(own);
        let access = DataAccess::within(roots).map_err(|e| format!("--allow-dir {e}"))?;
        let pick = PickIsovalue::WhenSampled;
        Ok(Policy { access, max_pixels, max_image_extent: None, pick })
    }
}

/// Why a state was refused: the command line's one-line message in full (`Display`), or as
/// the page may see it ([`StateError::for_page`]).
#[derive(Debug)]
pub enum StateError {
    Scene(SceneError),
    Other(String),
}

impl std::fmt::Display for StateError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StateError::Scene(e) => e.fmt(f),
            StateError::Other(m) => f.write_str(m),
        }
    }
}

impl StateError {
    /// The message for the page (see [`scene_error_for_page`]).
    pub fn for_page(&self) -> String {
        match self {
            StateError::Scene(e) => scene_error_for_page(e),
            StateError::Other(m) => m.clone(),
        }
    }
}

impl From<String> for StateError {
    fn from(m: String) -> Self {
        StateError::Other(m)
    }
}

impl From<&str> for StateError {
    fn from(m: &str) -> Self {
        StateError::Other(m.to_string())
    }
}

/// A data error as the page may see it: errors that quote what a file holds (a reader's
/// complaint about a header line, a dtype string, a mesh line) only name the file and say it
/// could not be read; the whole message goes to the server's terminal. Sizes, I/O errors,
/// caps, a reader's own limits (XML nesting) and expressions (the page's own text) pass
/// unchanged.
pub fn field_error_for_page(e: &FieldError) -> String {
    match redacted(e) {
        Some(short) => {
            server_note(&e);
            short
        }
        None => e.to_string(),
    }
}

/// A scene error as the page may see it (see [`field_error_for_page`]).
pub fn scene_error_for_page(e: &SceneError) -> String {
    match e.field_error.as_deref().and_then(redacted) {
        Some(short) => {
            server_note(&e);
            let key = e.key.as_ref().map(|k| format!("{k}: ")).unwrap_or_default();
            format!("{}: {key}{short}", e.location)
        }
        None => e.to_string(),
    }
}

/// The whole message on the server's stderr, ignoring a closed stderr (eprintln! would panic
/// the request's thread).
fn server_note(e: &dyn std::fmt::Display) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "{}", server_line(e));
}

/// The server's line for `e`, escaped as every `isoview:` line on stderr is: the reason can
/// quote the file (a MetaImage ElementType, OpenVDB's text), whose ESC or BEL reached the
/// terminal raw.
fn server_line(e: &dyn std::fmt::Display) -> String {
    format!("isoview: {}", crate::vocab::message_line(&e.to_string()))
}

/// The short form of an error that quotes a file's contents; None for the others.
fn redacted(e: &FieldError) -> Option<String> {
    let (path, what) = match e {
        FieldError::NotNpy { path, .. } => (path, "a .npy file"),
        FieldError::UnsupportedDtype { path, .. } => (path, "a .npy file of a supported dtype"),
        FieldError::BadShape { path, .. } => (path, "a 3-D grid"),
        FieldError::BadMesh { path, .. } => (path, "a mesh"),
        FieldError::Format { path, format, .. } => (path, *format),
        // The value is 8 bytes of the file (a text file read as f64 leaks its letters): the
        // page is told where, not what.
        FieldError::OutOfRange { what, index, .. } => {
            return Some(format!(
                "{what}: the value at grid point [{}, {}, {}] is beyond ±{:e}, the range of the \
                 32-bit floats samples are kept in",
                index[0],
                index[1],
                index[2],
                f32::MAX
            ))
        }
        FieldError::Io { .. }
        | FieldError::ReaderLimit { .. }
        | FieldError::Outside { .. }
        | FieldError::Truncated { .. }
        | FieldError::SizeMismatch { .. }
        | FieldError::TooLarge { .. }
        | FieldError::Unaddressable { .. }
        | FieldError::OverMemory { .. }
        | FieldError::PoolTooLarge { .. }
        | FieldError::TablesTooLarge { .. }
        | FieldError::SuperTablesTooLarge { .. }
        | FieldError::NonFinite { .. }
        | FieldError::OverDevice { .. }
        | FieldError::Shrank { .. }
        | FieldError::Expr { .. }
        | FieldError::BadLimit { .. } => return None,
    };
    Some(format!(
        "{}: cannot be read as {what} (the reason is printed where isoview serve runs; the \
         page is not shown what files hold)",
        path.display()
    ))
}

/// One state of the view, validated.
#[derive(Clone, Debug)]
pub struct ViewState {
    /// The overrides, in order, as `render --set` takes them.
    pub sets: Vec<String>,
    /// Time of the field in seconds (`render --time`).
    pub time: f64,
    /// Draw a coarse frame first and the full one after [`super::progressive::REFINE_AFTER`]
    /// without a newer state (the page sets it while the user drags).
    pub preview: bool,
    pub scene: Scene,
    /// The rule of an isovalue still to be picked from the samples, when the state was
    /// loaded under [`PickIsovalue::WhenSampled`] (`scene.surface.isovalue` is not picked
    /// then): the render thread picks it ([`ViewState::picked`]) before it draws the state.
    pub unpicked: Option<Unpicked>,
    /// When it arrived (the refine delay counts from here).
    pub posted: Instant,
}

impl ViewState {
    /// Loads `path` with `sets` under `policy`; the error is the command line's one-line
    /// message.
    pub fn load(
        path: &Path,
        sets: Vec<String>,
        time: f64,
        preview: bool,
        policy: &Policy,
    ) -> Result<Self, StateError> {
        if !time.is_finite() {
            return Err(format!("--time {time}: must be a finite number").into());
        }
        let (scene, unpicked) =
            scene::load_confined_picking(path, &sets, &policy.access, policy.pick)
                .map_err(StateError::Scene)?;
        let (w, h) = (scene.image.width as u64, scene.image.height as u64);
        if w * h > policy.max_pixels {
            return Err(format!(
                "image.width x image.height: {w}x{h} = {} pixels, over isoview serve's cap of {} \
                 pixels; raise it with --max-pixels",
                w * h,
                policy.max_pixels
            )
            .into());
        }
        // A state is rendered: its method must read its interpolant (the page's method switch
        // then answers 400 with the command line's line, and the shown state stays).
        if let Some(why) = scene.interpolation_refusal(scene.render_reader()) {
            return Err(why.into());
        }
        if let Some(max) = policy.max_image_extent {
            scene.field.check_image_extent(max).map_err(|e| e.to_string())?;
        }
        Ok(ViewState { sets, time, preview, scene, unpicked, posted: Instant::now() })
    }

    /// The state with its isovalue picked from `grid`, the field sampled for it (the state
    /// itself when there was nothing to pick); the load's message when the pick gives no
    /// isovalue.
    pub fn picked(&self, grid: &Grid) -> Result<ViewState, SceneError> {
        let mut state = self.clone();
        if let Some(rule) = state.unpicked.take() {
            state.scene.surface = rule.pick(state.scene.surface, &grid.values)?;
        }
        Ok(state)
    }

    /// The state a `POST /api/state` body asks for:
    /// `{"set": ["KEY=VALUE", ...], "time": T, "preview": true|false}` (`time` and `preview`
    /// optional: 0 and false).
    pub fn from_request(path: &Path, body: &[u8], policy: &Policy) -> Result<Self, StateError> {
        let v: Value = serde_json::from_slice(body)
            .map_err(|e| format!("the request body is not JSON: {e}"))?;
        let Some(obj) = v.as_object() else {
            return Err("the request body must be a JSON object {\"set\": [...]}".into());
        };
        if let Some(k) = obj.keys().find(|k| !["set", "time", "preview"].contains(&k.as_str())) {
            let k: String = k.escape_default().take(100).collect();
            return Err(format!("unknown key \"{k}\" in the request (set, time, preview)").into());
        }
        let sets = match obj.get("set") {
            None => Vec::new(),
            Some(Value::Array(items)) => items
                .iter()
                .map(|s| s.as_str().map(str::to_string))
                .collect::<Option<Vec<_>>>()
                .ok_or("\"set\" must be a list of \"KEY=VALUE\" strings")?,
            Some(_) => return Err("\"set\" must be a list of \"KEY=VALUE\" strings".into()),
        };
        let time = match obj.get("time") {
            None => 0.0,
            Some(t) => t.as_f64().ok_or("\"time\" must be a number")?,
        };
        let preview = match obj.get("preview") {
            None => false,
            Some(p) => p.as_bool().ok_or("\"preview\" must be true or false")?,
        };
        Self::load(path, sets, time, preview, policy)
    }
}

fn v3(v: glam::DVec3) -> Value {
    json!([v.x, v.y, v.z])
}

/// What the page needs to build its controls: the state, the scene's effective values, the
/// field's kind and value range (over `grid`, the field sampled at the state's time).
pub fn describe(
    generation: u64,
    state: &ViewState,
    scene_name: &str,
    grid: &Grid,
    device: &str,
) -> Value {
    let s = &state.scene;
    let (lo, hi) = grid
        .values
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v as f64), b.max(v as f64)));
    let corners = match &s.field.source {
        FieldSource::Corners(c) => json!(c),
        _ => Value::Null,
    };
    let r = &s.render;
    json!({
        "generation": generation,
        "set": state.sets,
        "time": state.time,
        "scene": scene_name,
        "device": device,
        "image": [s.image.width, s.image.height],
        "camera": {
            "eye": v3(s.camera.eye), "target": v3(s.camera.target), "up": v3(s.camera.up),
            "fov_y_deg": s.camera.fov_y_deg, "projection": s.camera.projection.name(),
            "ortho_height": s.camera.ortho_height,
        },
        "surface": {"isovalue": s.surface.isovalue, "inside": s.surface.inside.name()},
        "render": {
            "method": r.method.name(), "shading": r.shading.name(), "steps": r.steps,
            "newton_steps": r.newton_steps, "crossing": r.crossing, "skip": r.skip,
            "occupancy": r.occupancy,
            "normals": r.normals.name(),
            "mesh": r.mesh.name(),
        },
        "field": {
            "describe": s.field.describe(),
            "interpolation": s.field.interpolation.name(),
            "corners": corners,
            "time_varying": s.field.is_time_varying(),
            "resolution": s.field.resolution,
            "bounds": {"min": v3(grid.min), "max": v3(grid.max)},
            "range": if lo <= hi { json!([lo, hi]) } else { Value::Null },
        },
    })
}

/// The scene file's text with `sets` written into it (comments dropped, keys sorted within
/// tables): a file that loads to the same scene as `path` with `--set` each of `sets`.
/// Relative data paths stay relative to `path`'s folder, so save it next to the original.
pub fn scene_toml(path: &Path, sets: &[String], time: f64) -> Result<String, String> {
    let name = path.display();
    // As the scene is loaded, not `read_to_string`: the file may have been replaced since the
    // server started, and a FIFO there held the worker for good (8 such requests, every
    // worker), `/dev/zero` grew it without end.
    let text = scene::read_text(path).map_err(|e| e.to_string())?;
    let mut root: toml::Table =
        toml::from_str(&text).map_err(|e| format!("{name}: invalid TOML: {e}"))?;
    for s in sets {
        let (key, value) =
            s.split_once('=').ok_or_else(|| format!("--set {s}: expected KEY=VALUE"))?;
        let value = value.trim();
        // As `--set`: TOML syntax, else a plain string.
        let parsed = toml::from_str::<toml::Table>(&format!("v = {value}"))
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| toml::Value::String(value.to_string()));
        let segments: Vec<&str> = key.trim().split('.').map(str::trim).collect();
        let (last, parents) =
            segments.split_last().ok_or_else(|| format!("--set {s}: empty key"))?;
        let mut table = &mut root;
        for seg in parents {
            let entry = table
                .entry(seg.to_string())
                .or_insert_with(|| toml::Value::Table(Default::default()));
            table =
                entry.as_table_mut().ok_or_else(|| format!("--set {s}: {seg} is not a table"))?;
        }
        table.insert(last.to_string(), parsed);
    }
    let body = toml::to_string(&root).map_err(|e| format!("cannot write TOML: {e}"))?;
    let mut header = format!("# Saved by isoview serve from {name}");
    if !sets.is_empty() {
        header += " with --set ";
        header += &sets.join(" --set ");
    }
    if time != 0.0 {
        header += &format!(" (render with --time {})", crate::vocab::echo_number(time));
    }
    Ok(format!("{header}\n\n{body}"))
}

/// `isoview render SCENE -o OUT.exr --set ...` of a state, shell-quoted.
pub fn command_line(path: &Path, state: &ViewState) -> String {
    let mut words =
        vec!["isoview".to_string(), "render".into(), quote(&path.display().to_string())];
    words.extend(["-o".into(), "out.exr".into()]);
    for s in &state.sets {
        words.push("--set".into());
        words.push(quote(s));
    }
    if state.time != 0.0 {
        words.push(format!("--time {}", crate::vocab::echo_number(state.time)));
    }
    words.join(" ")
}

/// A word quoted for a POSIX shell when it needs it.
fn quote(s: &str) -> String {
    if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=,:+@%".contains(c)) {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shell_quoting() {
        assert_eq!(quote("surface.isovalue=0.25"), "surface.isovalue=0.25");
        assert_eq!(quote("render.method=\"fixed-step\""), "'render.method=\"fixed-step\"'");
        assert_eq!(quote("a'b"), "'a'\\''b'");
    }

    /// Second #29 pass on the sparse work: a file's reason quoted its ESC and BEL raw on the
    /// server's stderr (the page gets the redacted line).
    #[test]
    fn the_servers_own_lines_are_escaped() {
        let line = server_line(&"f.mhd: ElementType \u{1b}[31mred\u{7} is not supported");
        assert_eq!(line, "isoview: f.mhd: ElementType \\u{1b}[31mred\\u{7} is not supported");
    }

    /// Fifth attack pass M7: `time: 1e308` wrote a 309-digit `--time` into the saved scene's
    /// header comment.
    #[test]
    fn the_saved_scene_names_a_time_in_short() {
        let dir = std::env::temp_dir().join(format!("isoview-state-time-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("s.toml");
        std::fs::write(&path, "[field]\nsource = \"sdf\"\nshape = \"sphere\"\n").unwrap();
        let text = scene_toml(&path, &[], 1e308).unwrap();
        let first = text.lines().next().unwrap();
        assert!(first.ends_with("(render with --time 1e308)"), "{first}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
