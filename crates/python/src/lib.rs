//! `isoview._isoview`: the native half of the `isoview` Python package (PyO3, abi3). The
//! Python half (`python/isoview/__init__.py`) holds the public API, its keyword arguments and
//! docstrings; this module holds what it calls, each entry point the library request the CLI's
//! verb makes (`src/cli/*.rs`), nothing run through a subprocess or a temporary file:
//!
//! ```text
//!   scene_from_toml(path, sets)        scene::load                  (every verb's --set)
//!   scene_from_array(array, sets, n)   field::from_memory + scene::from_str_with_grid
//!   render(scene, time)                render::pool / FieldSpec::sample, GpuGrid::upload,
//!                                      Renderer::render_to            (isoview render)
//!   Image.save_exr(path)               render::scene_files            (its EXR, byte for byte)
//!   extract(scene, device, time)       extract::Probe, extract::surfaces (isoview extract)
//!   probe / slice / stats / compare    probe::PixelProbe, slice::plan, field::stats,
//!                                      cli::compare::run_with
//! ```
//!
//! The GIL is released (`Python::detach`) around every piece of work that does not touch a
//! Python object: sampling, uploads, renders, extraction, writing files. A numpy array's
//! samples are converted into the grid's `f32` (a copy) while the GIL is held, so nothing
//! borrowed from numpy is read once it is released. One Vulkan device is opened on the first
//! render and kept for the life of the process ([`GPU`]). A panic inside the library is caught
//! and raised as `RuntimeError`, never taken down the interpreter with it.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use isoview::field::{Grid, GridLimits, StorageOrder};
use isoview::frame::{Channel, Frame};
use isoview::gpu::{Context, ContextOptions, GpuError as VkError};
use isoview::render::{Collect, GpuGrid, Renderer};
use isoview::scene::Scene;
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;

pyo3::create_exception!(
    isoview,
    GpuError,
    PyRuntimeError,
    "The GPU failed (the CLI's exit status 3): a Vulkan call, an allocation, a lost device."
);
pyo3::create_exception!(
    isoview,
    NoDeviceError,
    GpuError,
    "No usable Vulkan device: the message says what to install (on Debian/Ubuntu \
     `apt-get install libvulkan1 mesa-vulkan-drivers` gives lavapipe, a CPU Vulkan driver)."
);

/// How a call failed, by the CLI's exit status.
enum Fail {
    /// Bad input (exit 2): `ValueError` with the CLI's one line.
    Input(String),
    /// No Vulkan loader or device (exit 3): `NoDeviceError`.
    NoDevice(String),
    /// A GPU failure (exit 3): `GpuError`.
    Gpu(String),
    /// A panic in the library: `RuntimeError`.
    Bug(String),
}

impl From<Fail> for PyErr {
    fn from(f: Fail) -> PyErr {
        // The CLI's line as its stderr shows it: one line, and cut in the middle past 16K
        // characters (a scene naming a 2 MB path made a 2 MB message; vocab::message_line).
        let line = |m: &str| isoview::vocab::message_line(m).into_owned();
        match f {
            Fail::Input(m) => PyValueError::new_err(line(&m)),
            Fail::NoDevice(m) => NoDeviceError::new_err(line(&m)),
            Fail::Gpu(m) => GpuError::new_err(line(&m)),
            Fail::Bug(m) => {
                PyRuntimeError::new_err(format!("internal error in isoview: {}", line(&m)))
            }
        }
    }
}

fn input(e: impl std::fmt::Display) -> Fail {
    Fail::Input(e.to_string())
}

fn gpu(e: VkError) -> Fail {
    match e {
        VkError::NoLoader(_) | VkError::NoDevice | VkError::DeviceNotFound { .. } => {
            Fail::NoDevice(e.to_string())
        }
        e => Fail::Gpu(e.to_string()),
    }
}

fn render_failure(e: isoview::render::RenderError) -> Fail {
    match e {
        isoview::render::RenderError::Gpu(g) => gpu(g),
        other => input(other),
    }
}

/// Runs `work` without the GIL, a panic in it caught and returned as [`Fail::Bug`].
fn detached<T: Send>(py: Python<'_>, work: impl FnOnce() -> Result<T, Fail> + Send) -> PyResult<T> {
    py.detach(|| {
        catch_unwind(AssertUnwindSafe(work)).unwrap_or_else(|panic| {
            let why = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "a panic".to_string());
            Err(Fail::Bug(why))
        })
    })
    .map_err(PyErr::from)
}

/// The Vulkan device and the renderer on it, opened on the first render of the process and
/// reused by every later one (the device named by `ISOVIEW_DEVICE`, else isoview's pick: a
/// discrete GPU, an integrated one, lavapipe). A failure to open it is not kept: the next call
/// tries again.
static GPU: Mutex<Option<Renderer>> = Mutex::new(None);

fn with_renderer<T>(work: impl FnOnce(&mut Renderer) -> Result<T, Fail>) -> Result<T, Fail> {
    // A panic while the lock was held left the renderer in an unknown state: open a new one.
    let mut held = GPU.lock().unwrap_or_else(|poisoned| {
        let mut g = poisoned.into_inner();
        *g = None;
        g
    });
    if held.is_none() {
        let device = std::env::var("ISOVIEW_DEVICE").ok().filter(|d| !d.trim().is_empty());
        let ctx = Context::new(&ContextOptions { device, validation: false }).map_err(gpu)?;
        *held = Some(Renderer::new(&ctx).map_err(render_failure)?);
    }
    let renderer = held.as_mut().ok_or_else(|| Fail::Bug("no renderer".into()))?;
    work(renderer)
}

/// `extract(device="auto")`'s answer from `extract::Probe`: for the Vulkan device asked for
/// (`ISOVIEW_DEVICE`), the name of the device when it is a CPU.
type Probed = (Option<String>, Option<String>);
static PROBED: Mutex<Option<Probed>> = Mutex::new(None);

/// Where a [`PyScene`] came from, so that keyword arguments can be applied to it as `--set`
/// overrides and the scene validated again.
#[derive(Clone)]
enum Origin {
    /// A scene file (or a scene text over a data file) and its `--set` overrides.
    File { path: PathBuf, sets: Vec<String> },
    /// Scene text written by the Python layer over a data file (no scene file), its folder.
    Text { text: String, base: PathBuf, sets: Vec<String> },
    /// An array's samples and the overrides.
    Array { grid: Arc<Grid>, sets: Vec<String> },
}

impl Origin {
    fn sets(&self) -> &[String] {
        match self {
            Origin::File { sets, .. } | Origin::Text { sets, .. } | Origin::Array { sets, .. } => {
                sets
            }
        }
    }

    /// This origin with `more` overrides after its own.
    fn with(&self, more: &[String]) -> Origin {
        let sets = [self.sets(), more].concat();
        match self {
            Origin::File { path, .. } => Origin::File { path: path.clone(), sets },
            Origin::Text { text, base, .. } => {
                Origin::Text { text: text.clone(), base: base.clone(), sets }
            }
            Origin::Array { grid, .. } => Origin::Array { grid: grid.clone(), sets },
        }
    }
}

/// A validated scene (`isoview.Scene` wraps it).
#[pyclass(name = "_Scene", module = "isoview._isoview", frozen)]
struct PyScene {
    scene: Scene,
    origin: Origin,
}

/// The text the array scenes start from: an empty `[field]` (the samples are the source).
const ARRAY_SCENE: &str = "[field]\n";
/// What error messages call an array.
const ARRAY: &str = "the array";

/// Validates the scene of `origin`. `keyword` are the overrides made from keyword arguments:
/// an error in one of them names its key and what is wrong (the CLI's line after the `--set`
/// it would name); every other error is the CLI's line as it is.
fn load(origin: Origin, keyword: &[String]) -> Result<PyScene, Fail> {
    let loaded = match &origin {
        Origin::File { path, sets } => isoview::scene::load(path, sets),
        Origin::Text { text, base, sets } => isoview::scene::from_str(text, "scene", base, sets),
        Origin::Array { grid, sets } => {
            let base = std::env::current_dir().unwrap_or_default();
            isoview::scene::from_str_with_grid(ARRAY_SCENE, "array", &base, sets, grid)
        }
    };
    let scene = loaded.map_err(|e| {
        let ours = keyword.iter().any(|s| e.location == format!("--set {s}"));
        match (&e.key, ours) {
            (Some(key), true) => Fail::Input(format!("{key}: {}", e.message)),
            _ => input(e),
        }
    })?;
    Ok(PyScene { scene, origin })
}

#[pymethods]
impl PyScene {
    /// The scene with `keyword` and then `sets` (`KEY=VALUE`, TOML values) applied after its
    /// own overrides, validated again; `keyword` are those made from keyword arguments.
    fn with_sets(
        &self,
        py: Python<'_>,
        keyword: Vec<String>,
        sets: Vec<String>,
    ) -> PyResult<PyScene> {
        let origin = self.origin.with(&[keyword.clone(), sets].concat());
        detached(py, || load(origin, &keyword))
    }

    /// The scene file's text with its overrides written in (`serve`'s "save scene").
    fn to_toml(&self) -> PyResult<String> {
        match &self.origin {
            Origin::File { path, sets } => {
                let text = isoview::serve::state::scene_toml(path, sets, 0.0).map_err(input)?;
                // serve's header line, worded for where this text comes from.
                let by = "# Written by isoview.Scene.to_toml from";
                Ok(text.replacen("# Saved by isoview serve from", by, 1))
            }
            Origin::Text { .. } | Origin::Array { .. } => Err(input(
                "a scene over an array or a data file has no scene file: save the array with numpy.save and write \
                 [field] source = \"npy\", path = ... (docs/python.md)",
            )
            .into()),
        }
    }

    #[getter]
    fn path(&self) -> Option<PathBuf> {
        match &self.origin {
            Origin::File { path, .. } => Some(path.clone()),
            Origin::Text { .. } | Origin::Array { .. } => None,
        }
    }

    #[getter]
    fn sets(&self) -> Vec<String> {
        self.origin.sets().to_vec()
    }

    #[getter]
    fn width(&self) -> u32 {
        self.scene.image.width
    }

    #[getter]
    fn height(&self) -> u32 {
        self.scene.image.height
    }

    #[getter]
    fn isovalue(&self) -> f64 {
        self.scene.surface.isovalue
    }

    #[getter]
    fn isovalues(&self) -> Vec<f64> {
        self.scene.surface.isovalues().to_vec()
    }

    #[getter]
    fn method(&self) -> &'static str {
        self.scene.render.method.name()
    }

    #[getter]
    fn mesh(&self) -> &'static str {
        self.scene.render.mesh.name()
    }

    #[getter]
    fn inside(&self) -> &'static str {
        self.scene.surface.inside.name()
    }

    #[getter]
    fn resolution(&self) -> [usize; 3] {
        self.scene.field.resolution
    }

    #[getter]
    fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let b = &self.scene.field.bounds;
        (b.min.to_array(), b.max.to_array())
    }

    /// The field as the EXR header describes it.
    #[getter]
    fn field(&self) -> String {
        self.scene.field.describe()
    }

    /// The names of the EXR channels a render of this scene writes, in the file's order.
    #[getter]
    fn channels(&self) -> Vec<&'static str> {
        isoview::render::scene_channels(&self.scene).iter().map(|c| c.name()).collect()
    }
}

/// `isoview.Scene.from_toml`: the scene file at `path` with `sets` as `--set` overrides.
#[pyfunction]
fn scene_from_toml(py: Python<'_>, path: PathBuf, sets: Vec<String>) -> PyResult<PyScene> {
    detached(py, || load(Origin::File { path, sets }, &[]))
}

/// A scene from `text` (written by the Python layer: a `[field]` over a data file), relative
/// paths resolved against `base`; `keyword` and `sets` as for `_Scene.with_sets`.
#[pyfunction]
fn scene_from_text(
    py: Python<'_>,
    text: String,
    base: PathBuf,
    keyword: Vec<String>,
    sets: Vec<String>,
) -> PyResult<PyScene> {
    let origin = Origin::Text { text, base, sets: [keyword.clone(), sets].concat() };
    detached(py, || load(origin, &keyword))
}

/// A scene over a numpy array's samples (shape (nx, ny, nz), element [i, j, k] at grid point
/// (i, j, k); C or Fortran contiguous: the caller copies any other layout first); `keyword`
/// and `sets` as for `_Scene.with_sets`.
/// The grid cap's check of an array's `shape`, before Python copies a strided view (or a
/// broadcast one, tiny in memory and huge in samples) into one block: the same line as
/// [`scene_from_array`]'s, without the copy. Shapes that are not 3-D pass: the scene refuses
/// them with scikit-image's line.
#[pyfunction]
fn check_array_shape(shape: Vec<u64>) -> PyResult<()> {
    if let [nx, ny, nz] = shape[..] {
        let limits = GridLimits::from_env().map_err(input)?;
        limits.check([nx, ny, nz], ARRAY).map_err(input)?;
    }
    Ok(())
}

#[pyfunction]
fn scene_from_array(
    py: Python<'_>,
    array: &Bound<'_, numpy::PyUntypedArray>,
    keyword: Vec<String>,
    sets: Vec<String>,
) -> PyResult<PyScene> {
    let what = Path::new(ARRAY);
    let shape = array.shape().to_vec();
    let bad_shape = |message: String| isoview::field::FieldError::BadShape {
        path: what.to_path_buf(),
        message,
    };
    let shown = shape.iter().map(usize::to_string).collect::<Vec<_>>().join(", ");
    if shape.len() != 3 {
        let m = format!("expected a 3-D array of shape (nx, ny, nz), got shape ({shown})");
        return Err(input(bad_shape(m)).into());
    }
    let dims = [shape[0], shape[1], shape[2]];
    if dims.iter().any(|&d| d < 2) {
        let m = format!("every axis needs at least 2 points, got shape ({shown})");
        return Err(input(bad_shape(m)).into());
    }
    let descr: String = array.dtype().getattr("str")?.extract()?;
    let (ty, endian) = isoview::field::sample_type_of_descr(what, &descr).map_err(input)?;
    let limits = GridLimits::from_env().map_err(input)?;
    limits.check(dims.map(|d| d as u64), ARRAY).map_err(input)?;
    let order = if array.is_c_contiguous() {
        StorageOrder::ZFastest
    } else if array.is_fortran_contiguous() {
        StorageOrder::XFastest
    } else {
        return Err(Fail::Bug(
            "the array reached the module neither C nor Fortran contiguous".into(),
        )
        .into());
    };
    // The samples' bytes in memory order, viewed (not copied) as bytes, then converted into
    // the grid (the copy) before the GIL is released.
    let bytes = array.call_method1("ravel", ("K",))?.call_method1("view", ("u1",))?;
    let bytes: PyReadonlyArray1<'_, u8> = bytes.extract()?;
    let values = isoview::field::from_memory(bytes.as_slice()?, what, ty, endian, dims, order)
        .map_err(input)?;
    drop(bytes);
    let zero = glam::DVec3::ZERO;
    let grid = Arc::new(Grid { dims, min: zero, max: zero, values });
    let origin = Origin::Array { grid, sets: [keyword.clone(), sets].concat() };
    detached(py, || load(origin, &keyword))
}

/// A rendered frame and the scene it was rendered from (`isoview.Image` wraps it).
#[pyclass(name = "_Image", module = "isoview._isoview", frozen)]
struct PyImage {
    frame: Frame,
    scene: Scene,
    /// Milliseconds: the whole render, and the GPU's share (None without timestamps).
    ms: f64,
    gpu_ms: Option<f64>,
    device: String,
}

#[pymethods]
impl PyImage {
    #[getter]
    fn width(&self) -> u32 {
        self.frame.width
    }

    #[getter]
    fn height(&self) -> u32 {
        self.frame.height
    }

    /// The EXR channels the CLI writes for this scene, in the file's order.
    #[getter]
    fn channels(&self) -> Vec<&'static str> {
        isoview::render::scene_channels(&self.scene).iter().map(|c| c.name()).collect()
    }

    /// Channel `name` (an EXR channel name: `R`, `Z`, `N.X`, `cell.Y`, ...) as a float32
    /// array of shape (height, width), row 0 at the top: the EXR's values.
    fn channel<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let c = Channel::from_name(name).ok_or_else(|| {
            let names: Vec<&str> = Channel::ALL.iter().map(|c| c.name()).collect();
            input(format!("no channel {name:?}; the channels are {}", names.join(", ")))
        })?;
        let values: Vec<f32> = self.frame.pixels.iter().map(|p| c.get(p)).collect();
        let (h, w) = (self.frame.height as usize, self.frame.width as usize);
        PyArray1::from_vec(py, values).reshape([h, w])
    }

    /// Writes the frame as the CLI's EXR for this scene, byte for byte (atomically).
    fn save_exr(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
            return Err(input(format!("{}: the file name must end in .exr", path.display())).into());
        }
        detached(py, || {
            isoview::cli::check_outputs(&[("save_exr", &path)], &self.scene)
                .map_err(|f| Fail::Input(f.message))?;
            let mut files = isoview::render::scene_files(&self.scene, &path, None);
            let (w, h) = (self.frame.width, self.frame.height);
            files.begin(w, h, &self.frame.info).map_err(input)?;
            files.band(0, &self.frame.pixels).map_err(input)?;
            files.finish().map_err(input)
        })
    }

    /// The PNG preview the CLI's `--png` writes, as bytes.
    fn png<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let bytes = detached(py, || {
            isoview::output::png::encode_preview(Path::new("preview.png"), &self.frame)
                .map_err(input)
        })?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// What the render's summary line says: device, method, times.
    fn summary(&self) -> (String, String, f64, Option<f64>) {
        (self.device.clone(), self.scene.render.method.name().to_string(), self.ms, self.gpu_ms)
    }
}

/// `isoview render`'s frame of `scene` at `time`, in one process: the brick pool when the
/// field's residency asks for it, else the whole grid sampled and uploaded; then the render.
#[pyfunction]
fn render(py: Python<'_>, scene: &PyScene, time: f64) -> PyResult<PyImage> {
    let scene = scene.scene.clone();
    if !time.is_finite() {
        return Err(input(format!("time {time}: must be a finite number")).into());
    }
    detached(py, move || {
        let started = std::time::Instant::now();
        if let Some(why) = scene.interpolation_refusal(scene.render_reader()) {
            return Err(Fail::Input(why));
        }
        with_renderer(|renderer| {
            let ctx = renderer.context().clone();
            let limits = GridLimits::from_env().map_err(input)?;
            let pool_failure = |e| match e {
                isoview::render::pool::PoolError::Gpu(g) => gpu(g),
                other => input(other),
            };
            let mapped =
                isoview::render::pool::mapped_for(&scene, &limits).map_err(pool_failure)?;
            let (grid, gpu_grid) = match mapped {
                Some(mapped) => {
                    let pooled = isoview::render::pool::upload_for(&ctx, &scene, &*mapped, &limits)
                        .map_err(pool_failure)?;
                    (pooled.shape, pooled.gpu)
                }
                None => {
                    let max = ctx.info.max_image_dimension_3d;
                    scene.field.check_image_extent(max).map_err(input)?;
                    let grid = scene.field.sample(time).map_err(input)?;
                    let uploaded = GpuGrid::upload(&ctx, &grid).map_err(gpu)?;
                    (grid, uploaded)
                }
            };
            let mut sink = Collect::default();
            renderer
                .render_to(&scene, &grid, &gpu_grid, time, &mut sink)
                .map_err(render_failure)?;
            let frame = sink.into_frame().map_err(render_failure)?;
            Ok(PyImage {
                frame,
                ms: started.elapsed().as_secs_f64() * 1e3,
                gpu_ms: renderer.last_gpu_ms,
                device: ctx.info.name.clone(),
                scene: scene.clone(),
            })
        })
    })
}

type MeshArrays<'py> = (
    Bound<'py, PyArray2<f32>>,
    Bound<'py, PyArray2<i32>>,
    Bound<'py, PyArray2<f32>>,
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyArray1<u32>>,
    String,
);

/// `isoview extract`'s meshes of every surface of `scene` (`device`: auto, cpu or gpu), merged:
/// positions (world), triangles, normals (inside to outside), each vertex's isovalue and
/// surface index, and where it ran.
#[pyfunction]
fn extract<'py>(
    py: Python<'py>,
    scene: &PyScene,
    device: &str,
    time: f64,
) -> PyResult<MeshArrays<'py>> {
    use isoview::extract::{Device, Job, Probe};
    let device = match device {
        "auto" => Device::Auto,
        "cpu" => Device::Cpu,
        "gpu" => Device::Gpu,
        other => {
            let m = format!("device {other:?}: expected \"auto\", \"cpu\" or \"gpu\"");
            return Err(input(m).into());
        }
    };
    if !time.is_finite() {
        return Err(input(format!("time {time}: must be a finite number")).into());
    }
    let scene = &scene.scene;
    let (mesh, labels, values, ran_on) = detached(py, || {
        let limits = isoview::mesh::MeshLimits::from_env().map_err(input)?;
        let budget = isoview::mesh::MeshBudget::new(limits);
        let vulkan = std::env::var("ISOVIEW_DEVICE").ok().filter(|d| !d.trim().is_empty());
        let job = Job {
            scene,
            time,
            device,
            vulkan: ContextOptions { device: vulkan, validation: false },
            opts: Default::default(),
            budget: &budget,
        };
        if let Some(why) = scene.interpolation_refusal(isoview::field::interpolant::Reader::Mesh) {
            return Err(Fail::Input(why));
        }
        // `auto` asks Vulkan once per process whether its device is a CPU (as `Probe` does for
        // each CLI run: 50-150 ms of loading drivers on lavapipe), then reuses the answer.
        let cpu_device = match (device, PROBED.lock().ok().and_then(|p| p.clone())) {
            (Device::Auto, Some((wanted, answer))) if wanted == job.vulkan.device => answer,
            (Device::Auto, _) => {
                let answer = Probe::start(&job).cpu_device();
                if let Ok(mut p) = PROBED.lock() {
                    *p = Some((job.vulkan.device.clone(), answer.clone()));
                }
                answer
            }
            _ => None,
        };
        let grid = scene.field.sample(time).map_err(input)?;
        let failed = |e| match e {
            isoview::extract::ExtractError::Input(m) => Fail::Input(m),
            isoview::extract::ExtractError::Gpu(g) => gpu(g),
        };
        // On the CPU (asked, or `auto` with the device a CPU) no device is opened; else the
        // extraction runs on the process's one device, held while it runs.
        let done = match (device, &cpu_device) {
            (Device::Cpu, _) | (Device::Auto, Some(_)) => {
                isoview::extract::surfaces(&job, &grid, cpu_device.as_deref()).map_err(failed)?
            }
            _ => with_renderer(|r| {
                isoview::extract::surfaces_on(&job, &grid, None, Some(r.context())).map_err(failed)
            })?,
        };
        let (mesh, labels) = isoview::mesh::merge(&done.meshes);
        let isovalues = scene.surface.isovalues();
        let levels: Vec<f32> = labels.iter().map(|&k| isovalues[k as usize] as f32).collect();
        let values = local_ranges(&grid, &scene.field.placement, &mesh.positions, &levels);
        Ok((mesh, labels, values, format!("{}{}", done.ran_on.name(), done.why)))
    })?;
    let n = mesh.positions.len();
    let flat = |v: &[[f32; 3]]| v.iter().flatten().copied().collect::<Vec<f32>>();
    let verts = PyArray1::from_vec(py, flat(&mesh.positions)).reshape([n, 3])?;
    let normals = PyArray1::from_vec(py, flat(&mesh.normals)).reshape([n, 3])?;
    let faces: Vec<i32> = mesh.indices.iter().map(|&i| i as i32).collect();
    let m = faces.len() / 3;
    let faces = PyArray1::from_vec(py, faces).reshape([m, 3])?;
    let values = PyArray1::from_vec(py, values);
    let labels = PyArray1::from_vec(py, labels);
    Ok((verts, faces, normals, values, labels, ran_on))
}

/// scikit-image's `values` (its `marching_cubes`' "a measure for the maximum value of the data
/// in the local region near each vertex"), measured against scikit-image 0.2x on random
/// volumes (every vertex of both of its methods): the largest range `(max - level) -
/// (min - level)` (f32) of the 8 corner samples over the grid cells that hold the vertex.
/// A vertex on a grid plane (to within 1e-6 of its coordinate, in cells: its f32 position's
/// rounding is about 6e-8 of it) along an axis is held by the cells on both sides
/// (an edge vertex: the 4 cells around its edge); missing samples are left out of a range.
fn local_ranges(
    grid: &isoview::field::Grid,
    placement: &isoview::vocab::Placement,
    positions: &[[f32; 3]],
    levels: &[f32],
) -> Vec<f32> {
    let spacing = grid.spacing();
    let cells = grid.cells();
    positions
        .iter()
        .zip(levels)
        .map(|(p, &level)| {
            let world = glam::DVec3::from(p.map(f64::from));
            let u = (placement.point_to_grid(world) - grid.min) / spacing;
            let around = |a: usize| -> std::ops::RangeInclusive<usize> {
                let last = cells[a] - 1;
                let r = u[a].round();
                // On the plane to within the f32 position's rounding (about 6e-8 of it, in cells).
                if (u[a] - r).abs() <= 1e-6 * u[a].abs().max(1.0) {
                    let r = r.clamp(0.0, cells[a] as f64) as usize;
                    r.saturating_sub(1).min(last)..=r.min(last)
                } else {
                    let c = (u[a].floor().max(0.0) as usize).min(last);
                    c..=c
                }
            };
            let mut best = f32::NAN;
            for k in around(2) {
                for j in around(1) {
                    for i in around(0) {
                        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                        for v in grid.corners(i, j, k) {
                            let d = v - level;
                            if d.is_finite() {
                                (lo, hi) = (lo.min(d), hi.max(d));
                            }
                        }
                        if lo <= hi {
                            best = best.max(hi - lo);
                        }
                    }
                }
            }
            best
        })
        .collect()
}

/// `isoview probe --pixel X,Y --json`'s report of `scene`, as JSON text (one report per
/// surface with several isovalues).
#[pyfunction]
fn probe(py: Python<'_>, scene: &PyScene, x: u32, y: u32, time: f64) -> PyResult<String> {
    let scene = &scene.scene;
    detached(py, || {
        if let Some(why) = scene.interpolation_refusal(isoview::field::interpolant::Reader::Probe) {
            return Err(Fail::Input(why));
        }
        let (px, py_) =
            isoview::probe::parse_pixel(&format!("{x},{y}"), scene.image.width, scene.image.height)
                .map_err(input)?;
        let grid = scene.field.sample(time).map_err(input)?;
        let name = isoview::extract::scene_name(scene);
        let reports: Vec<serde_json::Value> = (0..scene.surface.count)
            .map(|k| {
                let one =
                    if scene.surface.several() { scene.single_surface(k) } else { scene.clone() };
                isoview::probe::PixelProbe::new(&one, &grid, px, py_).json(&one, &name)
            })
            .collect();
        let out = match reports.len() {
            1 => reports.into_iter().next().unwrap_or_default(),
            _ => serde_json::Value::Array(reports),
        };
        serde_json::to_string(&out).map_err(input)
    })
}

type Contours<'py> = Vec<(Bound<'py, PyArray2<f64>>, bool)>;

/// `isoview slice`'s contours of `scene` on the plane `axis = at` (world): each contour's
/// points in the plane's two other world coordinates (x, y, z order), and whether it is closed.
#[pyfunction]
fn slice<'py>(
    py: Python<'py>,
    scene: &PyScene,
    axis: &str,
    at: f64,
    time: f64,
) -> PyResult<Contours<'py>> {
    use isoview::slice::Axis;
    let scene = &scene.scene;
    let axis = Axis::parse(axis)
        .ok_or_else(|| input(format!("axis {axis:?}: expected \"x\", \"y\" or \"z\"")))?;
    if !at.is_finite() {
        return Err(input(format!("at {at}: must be a finite number")).into());
    }
    let lines = detached(py, || {
        let grid = scene.field.sample(time).map_err(input)?;
        let planned = isoview::slice::plan(scene, &grid, axis, at, time).map_err(input)?;
        let (a, b) = axis.plane_axes();
        Ok(planned
            .set
            .contours
            .iter()
            .map(|c| {
                let points = isoview::slice::contour::world_points(&planned.plane, c);
                let flat: Vec<f64> = points.iter().flat_map(|p| [p[a], p[b]]).collect();
                (flat, c.closed)
            })
            .collect::<Vec<_>>())
    })?;
    lines
        .into_iter()
        .map(|(flat, closed)| {
            let n = flat.len() / 2;
            Ok((PyArray1::from_vec(py, flat).reshape([n, 2])?, closed))
        })
        .collect()
}

/// `isoview stats`'s figures of `scene`'s samples: (dims, dtype, spacing, box min, box max,
/// count, non-finite, min, max, mean, sigma, percentiles [(p, value)], histogram counts).
#[pyfunction]
fn stats(py: Python<'_>, scene: &PyScene, bins: usize, time: f64) -> PyResult<Py<PyAny>> {
    if !(1..=200).contains(&bins) {
        return Err(input(format!("bins {bins}: must be in 1..=200")).into());
    }
    let scene = &scene.scene;
    let (grid, s) = detached(py, || {
        let grid = scene.field.sample(time).map_err(input)?;
        let s = isoview::field::stats::Stats::of(&grid.values);
        Ok((grid, s))
    })?;
    let d = pyo3::types::PyDict::new(py);
    d.set_item("dims", grid.dims)?;
    d.set_item("dtype", scene.field.source.dtype())?;
    d.set_item("spacing", grid.spacing().to_array())?;
    d.set_item("box", (grid.min.to_array(), grid.max.to_array()))?;
    d.set_item("count", s.count)?;
    d.set_item("non_finite", s.missing)?;
    // None, not 0, where no sample is finite: there is no range, mean or percentile.
    let some = |v: f64| (s.finite() > 0).then_some(v);
    d.set_item("min", some(s.min))?;
    d.set_item("max", some(s.max))?;
    d.set_item("mean", some(s.mean))?;
    d.set_item("sigma", some(s.sigma))?;
    let p: Vec<(f64, Option<f64>)> =
        isoview::cli::stats::PERCENTILES.iter().map(|&p| (p, s.percentile(p))).collect();
    d.set_item("percentiles", p)?;
    d.set_item("histogram", s.histogram(bins))?;
    d.set_item("isovalue", scene.surface.isovalue)?;
    Ok(d.into_any().unbind())
}

/// `isoview compare A B ARGS...`: (exit status, the report on stdout, the notes on stderr).
#[pyfunction]
fn compare(py: Python<'_>, args: Vec<String>) -> PyResult<(i32, String, String)> {
    #[derive(clap::Parser)]
    #[command(name = "compare")]
    struct Compare {
        #[command(flatten)]
        args: isoview::cli::compare::CompareArgs,
    }
    use clap::Parser;
    let parsed = Compare::try_parse_from(std::iter::once("compare".to_string()).chain(args))
        .map_err(|e| {
            let text = e.to_string();
            input(text.lines().next().unwrap_or("bad arguments").trim_start_matches("error: "))
        })?;
    detached(py, || {
        let (mut out, mut err) = (Vec::new(), Vec::new());
        let code = isoview::cli::compare::run_with(&parsed.args, &mut out, &mut err);
        let text = |b: Vec<u8>| String::from_utf8_lossy(&b).into_owned();
        Ok((code, text(out), text(err)))
    })
}

/// The isoview version, as output headers record it.
#[pyfunction]
fn version() -> &'static str {
    isoview::VERSION
}

#[pymodule]
fn _isoview(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("GpuError", m.py().get_type::<GpuError>())?;
    m.add("NoDeviceError", m.py().get_type::<NoDeviceError>())?;
    m.add_class::<PyScene>()?;
    m.add_class::<PyImage>()?;
    m.add_function(wrap_pyfunction!(scene_from_toml, m)?)?;
    m.add_function(wrap_pyfunction!(scene_from_array, m)?)?;
    m.add_function(wrap_pyfunction!(check_array_shape, m)?)?;
    m.add_function(wrap_pyfunction!(scene_from_text, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(extract, m)?)?;
    m.add_function(wrap_pyfunction!(probe, m)?)?;
    m.add_function(wrap_pyfunction!(slice, m)?)?;
    m.add_function(wrap_pyfunction!(stats, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(version, m)?)?;
    Ok(())
}
