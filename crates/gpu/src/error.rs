use ash::vk;

/// What went wrong on the Vulkan side. Display is one line saying what failed or what to install.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "no Vulkan loader found ({0}); install it with `apt-get install libvulkan1 mesa-vulkan-drivers`"
    )]
    NoLoader(String),
    #[error(
        "no Vulkan device with a compute queue found; install a driver (`apt-get install mesa-vulkan-drivers` gives lavapipe)"
    )]
    NoDevice,
    #[error("no Vulkan device matches {wanted:?}; available: {available}")]
    DeviceNotFound { wanted: String, available: String },
    #[error("validation requested but the layer VK_LAYER_KHRONOS_validation is not installed (`apt-get install vulkan-validationlayers`)")]
    NoValidationLayer,
    #[error("Vulkan call {call} failed: {result:?}")]
    Vk { call: &'static str, result: vk::Result },
    #[error("the device was lost while running pass `{pass}`")]
    DeviceLost { pass: String },
    #[error("GPU memory allocation for `{name}` failed: {source}")]
    Alloc {
        name: String,
        #[source]
        source: gpu_allocator::AllocationError,
    },
    #[error("{0}")]
    Limit(String),
}

/// Adds the name of the failing call to a raw `vk::Result`.
pub(crate) trait VkContext<T> {
    fn vk(self, call: &'static str) -> Result<T, GpuError>;
}

impl<T> VkContext<T> for Result<T, vk::Result> {
    fn vk(self, call: &'static str) -> Result<T, GpuError> {
        self.map_err(|result| GpuError::Vk { call, result })
    }
}
