use ash::vk;

/// What went wrong on the Vulkan side, by cause: no Vulkan or no device (install something), a
/// failed Vulkan call or allocation, an input too large for the device, a missing device feature,
/// or a bug. Display is one line saying what failed, what to install or what to change.
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
    /// A size or count over what the device, one binding or one dispatch takes: the input is
    /// too large for this device (a smaller grid, image or mesh, or another device, works).
    /// `what` names the thing and its size, `limit` the limit and its value.
    #[error("{what} does not fit {limit}")]
    TooLarge { what: String, limit: String },
    /// The device lacks a feature that `what` needs; `instead` says what to do.
    #[error("{what} needs {feature}, which {device} does not offer; {instead}")]
    Unsupported { what: String, feature: String, device: String, instead: String },
    /// An internal invariant was violated (a caller broke a documented contract): a bug, not
    /// something the user can change.
    #[error("internal error (a bug in isoview): {0}")]
    Bug(String),
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
