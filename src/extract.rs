//! The extraction of a scene's surfaces (`isoview extract`, and any binding that asks for
//! meshes): where it runs, CPU or GPU, decided once for all surfaces, and each surface's mesh
//! placed and clipped in world space ([`Mesh::in_world`]).
//!
//! ```text
//!   Job (scene, device, Vulkan options, budget)
//!     Probe::start ──(its own thread, while the field is sampled)──> the device is a CPU?
//!     surfaces(job, grid, probed):
//!       device: cpu ─────────────────────────────────────────────> CPU
//!               auto ─ --quads, or the probe says CPU ───────────> CPU ("; auto: ...")
//!                    ─ no Vulkan device / its type is CPU ───────> CPU ("; auto: ...")
//!               gpu  ─ --quads ──────────────────────────────────> CPU (a note)
//!       on the opened device: the method's passes do not run it
//!         (Method::cpu_instead), or the grid is over its 3D image extent ──> CPU (a note)
//!       else: one Vulkan context, one upload of the grid, one Extractor, every surface
//! ```
//!
//! The CPU extraction is `mesh::extract` on all cores, the f64 reference's mesh bit for bit;
//! the GPU extraction is `passes::extract`. Notes are returned, in order, for the caller to
//! print ([`Surfaces::notes`]); a decision is made once, so a note appears once, however many
//! surfaces there are.

use std::sync::Arc;

use crate::field::{Grid, PointField};
use crate::gpu::{Context, ContextOptions, DeviceInfo, GpuError, Image3d};
use crate::mesh::{self, ExtractOptions, Mesh, MeshBudget};
use crate::passes::extract::{Extractor, GpuExtractOptions, GpuMeshError};
use crate::scene::Scene;

/// Where the extraction runs (`isoview extract --device auto|gpu|cpu`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Device {
    /// The CPU when the Vulkan device is a CPU or missing, else the GPU (the default).
    Auto,
    /// Vulkan compute (`passes::extract`).
    Gpu,
    /// The multi-threaded CPU extraction (`mesh::extract`), equal to the f64 reference
    /// `mesh::reference` bit for bit.
    Cpu,
}

impl Device {
    pub fn name(self) -> &'static str {
        match self {
            Device::Auto => "auto",
            Device::Gpu => "gpu",
            Device::Cpu => "cpu",
        }
    }
}

/// One extraction of every surface of a scene.
pub struct Job<'a> {
    pub scene: &'a Scene,
    /// Time of the field in seconds (`hermite = "source"` evaluates the source then).
    pub time: f64,
    pub device: Device,
    /// The Vulkan device and validation, for the GPU.
    pub vulkan: ContextOptions,
    pub opts: ExtractOptions,
    /// The count of the meshes held so far, which refuses a mesh past the cap.
    pub budget: &'a MeshBudget,
}

/// The surfaces' meshes, in `surface.isovalues` order, in world space, and where they ran.
pub struct Surfaces {
    pub meshes: Vec<Mesh>,
    /// [`Device::Cpu`] or [`Device::Gpu`].
    pub ran_on: Device,
    /// Why, worded to follow where it ran on the summary line ("; auto: ..."; "" when asked).
    pub why: String,
    /// Notes for stderr ("note: ..."), in order.
    pub notes: Vec<String>,
}

/// Why an extraction failed.
#[derive(Debug, thiserror::Error)]
pub enum ExtractError {
    /// The scene's input (its mesh over the cap, a source off the grid missing): one line
    /// naming the scene; exit status 2.
    #[error("{0}")]
    Input(String),
    /// The GPU failed: exit status 3.
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// `--device auto` asks Vulkan, on a thread of its own while the field is read or sampled,
/// whether the device it would open is a CPU (`gpu::probe`: loading the drivers, 50–150 ms on
/// lavapipe, and no device opened).
pub struct Probe(Option<std::thread::JoinHandle<Option<String>>>);

impl Probe {
    /// Starts the probe when it can settle anything: `auto`, without `--quads`.
    pub fn start(job: &Job) -> Probe {
        if job.device != Device::Auto || job.opts.keep_quads {
            return Probe(None);
        }
        let wanted = job.vulkan.device.clone();
        let probe = move || crate::gpu::probe(wanted.as_deref()).filter(|p| p.cpu).map(|p| p.name);
        Probe(Some(std::thread::spawn(probe)))
    }

    /// The name of the Vulkan device if it is a CPU; None: not a CPU, not known, or not asked.
    pub fn cpu_device(self) -> Option<String> {
        self.0.and_then(|p| p.join().ok().flatten())
    }
}

/// The scene's name in messages: its file (control characters escaped, so the message stays
/// one line), or "scene". Extract's refusals of a mesh name the scene first and then what
/// they refuse, which may be the data file ("s.toml: far.vdb: an xy layer ...").
pub fn scene_name(scene: &Scene) -> String {
    scene.path.as_ref().map_or_else(|| "scene".to_string(), |p| crate::field::shown(p))
}

/// `--device auto`: the reason to extract on the CPU when it is settled without opening a
/// Vulkan device (`--quads`, or the probe found the device to be a CPU), worded for the
/// summary line; None when the device must be opened to know.
pub fn settled_on_cpu(opts: ExtractOptions, probed_cpu: Option<&str>) -> Option<String> {
    if opts.keep_quads {
        return Some("; auto: --quads needs the CPU extraction".to_string());
    }
    probed_cpu.map(|name| format!("; auto: the Vulkan device {name} is a CPU"))
}

/// `--device auto` once the device is opened (or failed to open): Err(the reason to extract
/// on the CPU), Ok(the reason to use it), worded for the summary line.
fn auto_on(device: Result<&DeviceInfo, &GpuError>) -> Result<String, String> {
    match device {
        Err(e) => Err(format!("; auto: no usable Vulkan device ({e})")),
        // `DeviceInfo::device_type` is the gpu crate's wording of `vk::PhysicalDeviceType::CPU`.
        Ok(info) if info.device_type.starts_with("CPU") => {
            Err(format!("; auto: the Vulkan device {} is a CPU", info.name))
        }
        Ok(info) => {
            Ok(format!("; auto: the Vulkan device {} is a {}", info.name, info.device_type))
        }
    }
}

/// On an opened device: the note saying why `scene`'s surfaces are extracted on the CPU
/// instead (the method's passes do not run it there, or the grid is over the device's 3D
/// image extent, which the passes read it as); None: the GPU extracts them.
fn cpu_instead_on(scene: &Scene, info: &DeviceInfo) -> Option<String> {
    if let Some(note) = off_grid_note(scene) {
        return Some(note);
    }
    let method = scene.render.mesh.method();
    if let Some(why) = method.cpu_instead(&scene.render.sharp, info.float64) {
        return Some(why.note(method, &info.name));
    }
    // Rather than a GPU failure (exit 3) naming no key.
    let e = scene.field.check_image_extent(info.max_image_dimension_3d).err()?;
    Some(format!("note: extracted on the CPU ({e})"))
}

/// The note saying why a scene's surfaces are extracted on the CPU whatever the device: its
/// meshes are not of the grid's trilinear cells (`mesh::Request::on_grid`), which are all
/// the GPU passes mesh. None: they are.
pub fn off_grid_note(scene: &Scene) -> Option<String> {
    let x = scene.mesh_request(0, None);
    (!x.on_grid()).then(|| {
        format!(
            "note: extracted on the CPU (the GPU extraction passes mesh trilinear cells at \
             render.mesh_refine = 1, not field.interpolation = \"{}\" at {})",
            x.interp.name(),
            x.refine
        )
    })
}

/// Where the CPU writes one surface to a PLY piece by piece (`mesh::extract_streamed`): `ply`
/// and one surface, unclipped, by a method whose slabs are handed out one by one
/// (`mesh::not_streamed`), extracted on the CPU as settled before any Vulkan device is opened.
/// Some(the summary line's reason) when it does.
pub fn streams_on_cpu(job: &Job, ply: bool, probed_cpu: Option<&str>) -> Option<String> {
    let scene = job.scene;
    let x = scene.mesh_request(0, None).with_opts(job.opts);
    let one_piece_at_a_time = ply
        && scene.surface.count == 1
        && scene.clip.count == 0
        && mesh::not_streamed(&x).is_none();
    match job.device {
        _ if !one_piece_at_a_time => None,
        Device::Cpu => Some(String::new()),
        Device::Auto => settled_on_cpu(job.opts, probed_cpu),
        Device::Gpu => None,
    }
}

/// Every surface of `job.scene` over `grid` (its samples at `job.time`), extracted where the
/// rule of the module documentation says; `probed_cpu` is what [`Probe::cpu_device`] said.
pub fn surfaces(
    job: &Job,
    grid: &Grid,
    probed_cpu: Option<&str>,
) -> Result<Surfaces, ExtractError> {
    surfaces_on(job, grid, probed_cpu, None)
}

/// [`surfaces`] on `opened`, a Vulkan context the caller keeps (a binding's one device per
/// process), where it would open one from `job.vulkan`; None: as [`surfaces`]. The decision
/// is the same either way.
pub fn surfaces_on(
    job: &Job,
    grid: &Grid,
    probed_cpu: Option<&str>,
    opened: Option<&Arc<Context>>,
) -> Result<Surfaces, ExtractError> {
    let open = || match opened {
        Some(ctx) => Ok(ctx.clone()),
        None => Context::new(&job.vulkan),
    };
    if let Some(why) = job.scene.interpolation_refusal(crate::field::interpolant::Reader::Mesh) {
        return Err(ExtractError::Input(why));
    }
    let mut notes = Vec::new();
    let (ctx, why) = match job.device {
        Device::Cpu => (None, String::new()),
        Device::Auto => match settled_on_cpu(job.opts, probed_cpu) {
            Some(why) => (None, why),
            // Knowing the device type costs opening the device (instance, device and
            // allocator: tens of milliseconds on lavapipe), which the GPU path needs anyway.
            None => {
                let ctx = open();
                match auto_on(ctx.as_ref().map(|c| &c.info)) {
                    Ok(why) => (ctx.ok(), why),
                    Err(why) => (None, why),
                }
            }
        },
        Device::Gpu if job.opts.keep_quads => {
            notes.push(
                "note: --quads extracts on the CPU (the GPU extraction has no quads)".to_string(),
            );
            (None, String::new())
        }
        Device::Gpu => (Some(open().map_err(ExtractError::Gpu)?), String::new()),
    };
    let ctx = ctx.filter(|ctx| match cpu_instead_on(job.scene, &ctx.info) {
        Some(note) => {
            notes.push(note);
            false
        }
        None => true,
    });
    let (meshes, ran_on) = match ctx {
        Some(ctx) => (on_gpu(job, grid, &ctx)?, Device::Gpu),
        None => (on_cpu(job, grid)?, Device::Cpu),
    };
    Ok(Surfaces { meshes, ran_on, why, notes })
}

/// Every surface on all cores: the f64 reference's meshes, bit for bit, each slab counted
/// into the budget as it is done.
fn on_cpu(job: &Job, grid: &Grid) -> Result<Vec<Mesh>, ExtractError> {
    let scene = job.scene;
    let source = PointField::from_spec(&scene.field, job.time);
    let input = |e: mesh::MeshError| ExtractError::Input(format!("{}: {e}", scene_name(scene)));
    (0..scene.surface.count)
        .map(|k| {
            let x = scene.mesh_request(k, source.as_ref()).with_opts(job.opts);
            let mesh = mesh::extract(grid, &x, job.budget).map_err(input)?;
            Ok(mesh.in_world(&scene.field.placement, &scene.clip))
        })
        .collect()
}

/// Every surface on the GPU of `ctx`: the grid uploaded once, one [`Extractor`] for all;
/// each mesh's counts go into the budget before it is read back.
fn on_gpu(job: &Job, grid: &Grid, ctx: &Arc<Context>) -> Result<Vec<Mesh>, ExtractError> {
    let scene = job.scene;
    let name = scene_name(scene);
    let gpu = |e: GpuMeshError| match e {
        GpuMeshError::Gpu(g) => ExtractError::Gpu(g),
        other => ExtractError::Input(format!("{name}: {other}")),
    };
    let dims = grid.dims.map(|d| d as u32);
    let image = Image3d::upload(ctx, "grid", dims, &grid.values).map_err(ExtractError::Gpu)?;
    let mut extractor = Extractor::new(ctx).map_err(gpu)?;
    let opts = GpuExtractOptions {
        split: job.opts.split,
        sharp: Some(scene.render.sharp),
        ..Default::default()
    };
    let mut meshes = Vec::with_capacity(scene.surface.count);
    for iso in scene.surface.isovalues() {
        let (inside, algo) = (scene.surface.inside, scene.render.mesh);
        let gpu_mesh = extractor.extract(grid, &image, iso, inside, algo, &opts).map_err(gpu)?;
        let counts = (gpu_mesh.vertex_count as usize, gpu_mesh.triangle_count as usize);
        job.budget
            .add(counts.0, counts.1, 0)
            .map_err(|e| ExtractError::Input(format!("{name}: {e}")))?;
        let mesh = gpu_mesh.read().map_err(ExtractError::Gpu)?;
        meshes.push(mesh.in_world(&scene.field.placement, &scene.clip));
    }
    Ok(meshes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info(device_type: &str, float64: bool, max_3d: u32) -> DeviceInfo {
        DeviceInfo {
            r32f_linear_filter: true,
            sub_texel_precision_bits: 8,
            subgroup_ballot: true,
            name: "dev".into(),
            device_type: device_type.into(),
            driver_name: String::new(),
            driver_info: String::new(),
            api_version: "1.3.0".into(),
            max_storage_buffer_range: 1 << 30,
            max_image_dimension_3d: max_3d,
            max_compute_work_group_count: [65535; 3],
            max_compute_work_group_invocations: 1024,
            max_push_constants_size: 128,
            max_memory_allocation_size: 1 << 32,
            timestamp_period_ns: 1.0,
            timestamps: true,
            device_local_heap: 1 << 34,
            int64_atomics: true,
            float64,
        }
    }

    fn scene(mesh: &str) -> Scene {
        let text = format!(
            "[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = 0.6\n\
             resolution = [16, 16, 16]\n[render]\nmesh = \"{mesh}\"\n"
        );
        crate::scene::from_str(&text, "test", std::path::Path::new("."), &[]).expect("scene")
    }

    /// The decision order, without a device: `--quads` and the probe settle `auto` before
    /// any device is opened; then no device, a CPU device, and the device's type; on the
    /// device, the method's passes (none, or no float64) before the grid's extent.
    #[test]
    fn the_device_decision_order() {
        let quads = ExtractOptions { keep_quads: true, ..Default::default() };
        let plain = ExtractOptions::default();
        let settled = settled_on_cpu(quads, Some("llvmpipe")).unwrap();
        assert_eq!(settled, "; auto: --quads needs the CPU extraction");
        let settled = settled_on_cpu(plain, Some("llvmpipe")).unwrap();
        assert_eq!(settled, "; auto: the Vulkan device llvmpipe is a CPU");
        assert_eq!(settled_on_cpu(plain, None), None);

        let cpu = info("CPU (software)", true, 2048);
        let gpu = info("discrete GPU", false, 2048);
        assert_eq!(auto_on(Ok(&cpu)), Err("; auto: the Vulkan device dev is a CPU".into()));
        assert_eq!(auto_on(Ok(&gpu)), Ok("; auto: the Vulkan device dev is a discrete GPU".into()));
        let none = auto_on(Err(&GpuError::NoDevice)).unwrap_err();
        assert!(none.starts_with("; auto: no usable Vulkan device ("), "{none}");

        assert_eq!(cpu_instead_on(&scene("marching-cubes"), &gpu), None);
        let note = cpu_instead_on(&scene("mc33"), &gpu).unwrap();
        assert!(note.contains("dev has no 64-bit floats"), "{note}");
        assert_eq!(cpu_instead_on(&scene("mc33"), &cpu), None);
        let note = cpu_instead_on(&scene("extended-mc"), &gpu).unwrap();
        assert!(note.contains("no GPU extraction passes for it)"), "{note}");
        // The grid's extent after the method: mc33 without float64 names float64.
        let small = info("discrete GPU", false, 8);
        let note = cpu_instead_on(&scene("mc33"), &small).unwrap();
        assert!(note.contains("64-bit floats"), "{note}");
        let note = cpu_instead_on(&scene("marching-cubes"), &small).unwrap();
        assert!(note.starts_with("note: extracted on the CPU ("), "{note}");
    }
}
