use std::ffi::c_void;
use std::mem::ManuallyDrop;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use ash::{ext, vk};
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

use super::error::{GpuError, VkContext};
use super::guard::Cleanup;

/// How to pick and set up the device.
#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// Case-insensitive substring of the device name (`--device` / `ISOVIEW_DEVICE`); None
    /// picks a discrete GPU, else an integrated one, else anything (lavapipe).
    pub device: Option<String>,
    /// Enable `VK_LAYER_KHRONOS_validation` and print its warnings and errors to stderr.
    pub validation: bool,
}

/// Facts about the chosen device, for `isoview info` and output headers.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    pub name: String,
    pub device_type: String,
    pub driver_name: String,
    pub driver_info: String,
    pub api_version: String,
    pub max_storage_buffer_range: u64,
    pub max_image_dimension_3d: u32,
    pub max_compute_work_group_count: [u32; 3],
    pub max_compute_work_group_invocations: u32,
    pub max_push_constants_size: u32,
    pub max_memory_allocation_size: u64,
    pub timestamp_period_ns: f32,
    pub timestamps: bool,
    /// Size of the largest device-local heap in bytes.
    pub device_local_heap: u64,
    /// 64-bit integer atomics on storage buffers (`shaderInt64` + `shaderBufferInt64Atomics`),
    /// enabled on the device when supported; the mesh render's visibility buffer needs them.
    pub int64_atomics: bool,
    /// `shaderFloat64`: the mc33 extraction passes decide topology in f64 like the CPU
    /// reference, and need it.
    pub float64: bool,
    /// `R32_SFLOAT` images can be sampled with a linear filter (optimal tiling's
    /// `SAMPLED_IMAGE_FILTER_LINEAR`, optional in Vulkan for 32-bit floats): what
    /// [`crate::Image3d::linear_sampler`] needs.
    pub r32f_linear_filter: bool,
    /// `subTexelPrecisionBits`: the fractional bits of the texture unit's filter weights
    /// (Vulkan requires at least 4).
    pub sub_texel_precision_bits: u32,
    /// Subgroup ballots in compute shaders (`VkPhysicalDeviceSubgroupProperties`: the compute
    /// stage and `SUBGROUP_FEATURE_BALLOT`): passes that list work use one atomic per subgroup.
    pub subgroup_ballot: bool,
}

/// Instance, device, queue and allocator. Shared by `Arc`; resources keep it alive.
pub struct Context {
    _entry: ash::Entry,
    pub(crate) instance: ash::Instance,
    debug: Option<(ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    pub(crate) debug_device: Option<ext::debug_utils::Device>,
    pub(crate) device: ash::Device,
    pub(crate) queue: Mutex<vk::Queue>,
    pub(crate) queue_family: u32,
    /// Dropped before the device (see `Drop`).
    pub(crate) allocator: ManuallyDrop<Mutex<Allocator>>,
    pub info: DeviceInfo,
}

/// Warnings and errors reported by the validation layer in this process (tests assert 0).
static VALIDATION_MESSAGES: AtomicUsize = AtomicUsize::new(0);

/// Number of validation warnings and errors reported so far in this process.
pub fn validation_messages() -> usize {
    VALIDATION_MESSAGES.load(Ordering::SeqCst)
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    _user: *mut c_void,
) -> vk::Bool32 {
    VALIDATION_MESSAGES.fetch_add(1, Ordering::SeqCst);
    // SAFETY: the loader passes a valid callback-data pointer whose message is a C string.
    let message = unsafe { (*data).message_as_c_str() }
        .map(|m| m.to_string_lossy().into_owned())
        .unwrap_or_default();
    // Not eprintln!: it panics on a closed stderr, and a panic cannot unwind out of this
    // extern "C" callback (it would abort the process).
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "vulkan validation [{severity:?}]: {message}");
    vk::FALSE
}

fn type_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

fn type_name(t: vk::PhysicalDeviceType) -> &'static str {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
        vk::PhysicalDeviceType::CPU => "CPU (software)",
        _ => "other",
    }
}

/// A physical device with a compute queue: what [`Context::new`] and [`probe`] choose among.
#[derive(Clone)]
struct Candidate {
    pd: vk::PhysicalDevice,
    props: vk::PhysicalDeviceProperties,
    /// Its first queue family with compute.
    family: u32,
    name: String,
    timestamp_bits: u32,
}

/// Every physical device of `instance` that has a compute queue (the others cannot run a
/// pass). Err(NoDevice) when there is none.
fn candidates(instance: &ash::Instance) -> Result<Vec<Candidate>, GpuError> {
    // SAFETY: valid instance.
    let physicals =
        unsafe { instance.enumerate_physical_devices() }.vk("vkEnumeratePhysicalDevices")?;
    let mut candidates = Vec::new();
    for &pd in &physicals {
        // SAFETY: pd comes from this instance.
        let props = unsafe { instance.get_physical_device_properties(pd) };
        // SAFETY: as above.
        let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        let Some(family) =
            families.iter().position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE))
        else {
            continue;
        };
        let name = props
            .device_name_as_c_str()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let timestamp_bits = families[family].timestamp_valid_bits;
        candidates.push(Candidate { pd, props, family: family as u32, name, timestamp_bits });
    }
    if candidates.is_empty() {
        return Err(GpuError::NoDevice);
    }
    Ok(candidates)
}

/// The one device selection: the first candidate whose name contains `wanted`
/// (case-insensitively), else the best-ranked type (discrete, integrated, virtual, CPU).
fn choose<'c>(
    candidates: &'c [Candidate],
    wanted: Option<&str>,
) -> Result<&'c Candidate, GpuError> {
    match wanted {
        Some(wanted) => {
            let w = wanted.to_lowercase();
            candidates.iter().find(|c| c.name.to_lowercase().contains(&w)).ok_or_else(|| {
                GpuError::DeviceNotFound {
                    wanted: wanted.to_string(),
                    available: candidates
                        .iter()
                        .map(|c| c.name.clone())
                        .collect::<Vec<_>>()
                        .join(", "),
                }
            })
        }
        None => candidates
            .iter()
            .min_by_key(|c| type_rank(c.props.device_type))
            .ok_or(GpuError::NoDevice),
    }
}

/// What [`probe`] found out about the device [`Context::new`] would open.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Probed {
    pub name: String,
    /// As [`DeviceInfo::device_type`] words it.
    pub device_type: &'static str,
    /// Its type is CPU (a software implementation such as lavapipe).
    pub cpu: bool,
}

/// The device that [`Context::new`] would open for `wanted` (the same selection: a device
/// with a compute queue, named by `wanted` or else the best-ranked type), found with an
/// instance only, no device: a few tens of ms on lavapipe, where opening the device costs
/// 150–300 ms. None when Vulkan cannot say (no loader, no instance, no such device); the
/// context then reports why when it is opened.
pub fn probe(wanted: Option<&str>) -> Option<Probed> {
    // SAFETY: loading the system's libvulkan, as `Context::new` does.
    let entry = unsafe { ash::Entry::load() }.ok()?;
    let app = vk::ApplicationInfo::default()
        .application_name(c"isoview")
        .api_version(vk::API_VERSION_1_2);
    let create = vk::InstanceCreateInfo::default().application_info(&app);
    // SAFETY: the create info and the strings it points to outlive the call.
    let instance = unsafe { entry.create_instance(&create, None) }.ok()?;
    let probed = candidates(&instance).ok().and_then(|all| {
        let c = choose(&all, wanted).ok()?;
        let t = c.props.device_type;
        Some(Probed {
            name: c.name.clone(),
            device_type: type_name(t),
            cpu: t == vk::PhysicalDeviceType::CPU,
        })
    });
    // SAFETY: nothing was created from the instance, and the physical devices' handles are
    // not used after this.
    unsafe { instance.destroy_instance(None) };
    probed
}

fn version_string(v: u32) -> String {
    format!(
        "{}.{}.{}",
        vk::api_version_major(v),
        vk::api_version_minor(v),
        vk::api_version_patch(v)
    )
}

impl Context {
    /// Loads Vulkan, picks a device with a compute queue and creates the allocator.
    pub fn new(options: &ContextOptions) -> Result<std::sync::Arc<Self>, GpuError> {
        // SAFETY: loading the system's libvulkan; nothing else touches the loader concurrently
        // in a way that matters to this handle.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::NoLoader(e.to_string()))?;

        let validation_name = c"VK_LAYER_KHRONOS_validation";
        let mut layers = Vec::new();
        let mut extensions = Vec::new();
        if options.validation {
            // SAFETY: plain enumeration call on a loaded entry.
            let available = unsafe { entry.enumerate_instance_layer_properties() }
                .vk("vkEnumerateInstanceLayerProperties")?;
            let found =
                available.iter().any(|l| l.layer_name_as_c_str().ok() == Some(validation_name));
            if !found {
                return Err(GpuError::NoValidationLayer);
            }
            layers.push(validation_name.as_ptr());
            extensions.push(ext::debug_utils::NAME.as_ptr());
        }

        let app = vk::ApplicationInfo::default()
            .application_name(c"isoview")
            .engine_name(c"isoview")
            .api_version(vk::API_VERSION_1_2);
        let create = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        // SAFETY: the create info and the strings it points to outlive the call.
        let instance = unsafe { entry.create_instance(&create, None) }.map_err(|r| match r {
            vk::Result::ERROR_INCOMPATIBLE_DRIVER => GpuError::NoDevice,
            result => GpuError::Vk { call: "vkCreateInstance", result },
        })?;
        // Until the Context owns them, an error destroys what was created so far, in reverse
        // order: allocator (dropped as a value), device, messenger, instance.
        // SAFETY: nothing created from the instance outlives it: the guards below go first.
        let instance_guard = Cleanup::new(|| unsafe { instance.destroy_instance(None) });

        let debug = if options.validation {
            let loader = ext::debug_utils::Instance::new(&entry, &instance);
            let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                        | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                        | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
                )
                .pfn_user_callback(Some(debug_callback));
            // SAFETY: valid instance with the debug-utils extension enabled.
            let messenger = unsafe { loader.create_debug_utils_messenger(&info, None) }
                .vk("vkCreateDebugUtilsMessengerEXT")?;
            Some((loader, messenger))
        } else {
            None
        };
        let debug_guard = Cleanup::new(|| {
            if let Some((loader, messenger)) = &debug {
                // SAFETY: created above from this instance, which is still alive.
                unsafe { loader.destroy_debug_utils_messenger(*messenger, None) };
            }
        });

        let (physical, device, queue_family, info) = Self::open_device(&instance, options)?;
        // SAFETY: nothing was created from the device yet but the allocator, which is dropped
        // (as a value) before this guard runs.
        let device_guard = Cleanup::new(|| unsafe { device.destroy_device(None) });
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })
        .map_err(|source| GpuError::Alloc { name: "allocator".into(), source })?;
        // SAFETY: queue family and index 0 were requested at device creation.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let debug_device =
            options.validation.then(|| ext::debug_utils::Device::new(&instance, &device));
        // The Context owns them from here (its Drop destroys them).
        device_guard.disarm();
        debug_guard.disarm();
        instance_guard.disarm();
        Ok(std::sync::Arc::new(Context {
            _entry: entry,
            instance,
            debug,
            debug_device,
            device,
            queue: Mutex::new(queue),
            queue_family,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            info,
        }))
    }

    fn open_device(
        instance: &ash::Instance,
        options: &ContextOptions,
    ) -> Result<(vk::PhysicalDevice, ash::Device, u32, DeviceInfo), GpuError> {
        let candidates = candidates(instance)?;
        let chosen = choose(&candidates, options.device.as_deref())?;
        let Candidate { pd, props, family, name, timestamp_bits: ts_bits } = chosen.clone();

        let mut driver = vk::PhysicalDeviceDriverProperties::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver);
        // SAFETY: pd is valid and the chain is well formed.
        unsafe { instance.get_physical_device_properties2(pd, &mut props2) };
        let driver_name = driver
            .driver_name_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let driver_info = driver
            .driver_info_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        // SAFETY: pd is valid.
        let memory = unsafe { instance.get_physical_device_memory_properties(pd) };
        let device_local_heap = memory.memory_heaps[..memory.memory_heap_count as usize]
            .iter()
            .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
            .map(|h| h.size)
            .max()
            .unwrap_or(0);
        let mut maint3 = vk::PhysicalDeviceMaintenance3Properties::default();
        let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
        let mut props2b = vk::PhysicalDeviceProperties2::default()
            .push_next(&mut maint3)
            .push_next(&mut subgroup);
        // SAFETY: as above.
        unsafe { instance.get_physical_device_properties2(pd, &mut props2b) };
        let subgroup_ballot = subgroup.supported_stages.contains(vk::ShaderStageFlags::COMPUTE)
            && subgroup.supported_operations.contains(vk::SubgroupFeatureFlags::BALLOT)
            && props.api_version >= vk::API_VERSION_1_1;

        let mut features12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut features12);
        // SAFETY: pd is valid and the chain is well formed (Vulkan 1.2 instance).
        unsafe { instance.get_physical_device_features2(pd, &mut features2) };
        let float64 = features2.features.shader_float64 == vk::TRUE;
        let int64_atomics = features2.features.shader_int64 == vk::TRUE
            && features12.shader_buffer_int64_atomics == vk::TRUE
            && props.api_version >= vk::API_VERSION_1_2;

        // SAFETY: pd is valid.
        let r32f =
            unsafe { instance.get_physical_device_format_properties(pd, vk::Format::R32_SFLOAT) };
        let r32f_linear_filter = r32f
            .optimal_tiling_features
            .contains(vk::FormatFeatureFlags::SAMPLED_IMAGE_FILTER_LINEAR);
        let limits = props.limits;
        let info = DeviceInfo {
            name,
            device_type: type_name(props.device_type).to_string(),
            driver_name,
            driver_info,
            api_version: version_string(props.api_version),
            max_storage_buffer_range: limits.max_storage_buffer_range as u64,
            max_image_dimension_3d: limits.max_image_dimension3_d,
            max_compute_work_group_count: limits.max_compute_work_group_count,
            max_compute_work_group_invocations: limits.max_compute_work_group_invocations,
            max_push_constants_size: limits.max_push_constants_size,
            max_memory_allocation_size: maint3.max_memory_allocation_size,
            timestamp_period_ns: limits.timestamp_period,
            timestamps: ts_bits > 0 && limits.timestamp_compute_and_graphics == vk::TRUE,
            device_local_heap,
            int64_atomics,
            float64,
            r32f_linear_filter,
            sub_texel_precision_bits: limits.sub_texel_precision_bits,
            subgroup_ballot,
        };

        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(family)
            .queue_priorities(&priorities)];
        let enabled = vk::PhysicalDeviceFeatures::default()
            .shader_int64(int64_atomics)
            .shader_float64(float64);
        let mut enabled12 = vk::PhysicalDeviceVulkan12Features::default()
            .shader_buffer_int64_atomics(int64_atomics);
        let create = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_features(&enabled)
            .push_next(&mut enabled12);
        // SAFETY: pd is valid and the create info outlives the call.
        let device = unsafe { instance.create_device(pd, &create, None) }.vk("vkCreateDevice")?;
        Ok((pd, device, family, info))
    }

    /// Gives a Vulkan object a debug name (shown by validation and capture tools).
    pub(crate) fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        if let Some(debug) = &self.debug_device {
            if let Ok(cname) = std::ffi::CString::new(name) {
                let info = vk::DebugUtilsObjectNameInfoEXT::default()
                    .object_handle(handle)
                    .object_name(&cname);
                // SAFETY: handle belongs to this device; naming failures are harmless.
                let _ = unsafe { debug.set_debug_utils_object_name(&info) };
            }
        }
    }

    /// Records commands with `record`, submits them and waits. `pass` names the work in errors
    /// (a lost device is reported with the name of the pass that was running). Crate-private:
    /// outside it, work is recorded through [`Context::record`], whose tracker adds barriers.
    pub(crate) fn submit<F>(&self, pass: &str, record: F) -> Result<(), GpuError>
    where
        F: FnOnce(vk::CommandBuffer) -> Result<(), GpuError>,
    {
        let device = &self.device;
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(self.queue_family)
            .flags(vk::CommandPoolCreateFlags::TRANSIENT);
        // SAFETY: every object created below is destroyed before returning, after the fence
        // wait (or on the error path, after nothing was submitted).
        unsafe {
            let pool = device.create_command_pool(&pool_info, None).vk("vkCreateCommandPool")?;
            let result = (|| {
                let cmd = device
                    .allocate_command_buffers(
                        &vk::CommandBufferAllocateInfo::default()
                            .command_pool(pool)
                            .level(vk::CommandBufferLevel::PRIMARY)
                            .command_buffer_count(1),
                    )
                    .vk("vkAllocateCommandBuffers")?[0];
                device
                    .begin_command_buffer(
                        cmd,
                        &vk::CommandBufferBeginInfo::default()
                            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                    )
                    .vk("vkBeginCommandBuffer")?;
                record(cmd)?;
                device.end_command_buffer(cmd).vk("vkEndCommandBuffer")?;
                let fence = device
                    .create_fence(&vk::FenceCreateInfo::default(), None)
                    .vk("vkCreateFence")?;
                let cmds = [cmd];
                let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
                let lost = |result| match result {
                    vk::Result::ERROR_DEVICE_LOST => {
                        GpuError::DeviceLost { pass: pass.to_string() }
                    }
                    result => GpuError::Vk { call: "vkQueueSubmit", result },
                };
                let submitted = {
                    let queue = self.queue.lock().unwrap_or_else(|p| p.into_inner());
                    device.queue_submit(*queue, &submit, fence)
                };
                let waited = submitted
                    .and_then(|_| device.wait_for_fences(&[fence], true, u64::MAX))
                    .map_err(lost);
                device.destroy_fence(fence, None);
                waited
            })();
            device.destroy_command_pool(pool, None);
            result
        }
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        // SAFETY: all resources hold an Arc<Context>, so none is alive now. The allocator must
        // go before the device it allocates from, the device before the instance.
        unsafe {
            let _ = self.device.device_wait_idle();
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
            if let Some((loader, messenger)) = self.debug.take() {
                loader.destroy_debug_utils_messenger(messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn candidate(name: &str, t: vk::PhysicalDeviceType) -> Candidate {
        let props = vk::PhysicalDeviceProperties { device_type: t, ..Default::default() };
        let (pd, family, timestamp_bits) = (vk::PhysicalDevice::null(), 0, 0);
        Candidate { pd, props, family, name: name.to_string(), timestamp_bits }
    }

    /// The selection `Context::new` and `probe` share: a name contained case-insensitively,
    /// else the best-ranked type; an unknown name lists what there is.
    #[test]
    fn choose_takes_the_named_device_else_the_best_ranked_type() {
        let all = [
            candidate("llvmpipe (LLVM 15)", vk::PhysicalDeviceType::CPU),
            candidate("Intel UHD", vk::PhysicalDeviceType::INTEGRATED_GPU),
            candidate("NVIDIA H200", vk::PhysicalDeviceType::DISCRETE_GPU),
        ];
        assert_eq!(choose(&all, None).unwrap().name, "NVIDIA H200");
        assert_eq!(choose(&all, Some("LLVMPIPE")).unwrap().name, "llvmpipe (LLVM 15)");
        assert_eq!(choose(&all, Some("i")).unwrap().name, "llvmpipe (LLVM 15)");
        match choose(&all, Some("radeon")) {
            Err(GpuError::DeviceNotFound { wanted, available }) => {
                assert_eq!(wanted, "radeon");
                assert_eq!(available, "llvmpipe (LLVM 15), Intel UHD, NVIDIA H200");
            }
            _ => panic!("an unknown name is refused"),
        }
        assert!(matches!(choose(&[], None), Err(GpuError::NoDevice)));
    }
}
