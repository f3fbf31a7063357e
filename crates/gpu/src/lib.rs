//! A small Vulkan compute backend on ash + gpu-allocator. It knows nothing of isosurfaces:
//! a [`Context`] (instance, device, queue, allocator), RAII [`Buffer`]s and [`Image3d`]s with
//! debug names, [`ComputePipeline`]s from SPIR-V, one-shot command submission with timestamp
//! queries, and a [`Recorder`] that derives barriers from the buffers each command reads and
//! writes (a dispatch's from its pipeline's [`Binding`]s), plus the workgroup arithmetic,
//! [`grid_groups`] and [`spread_groups`].
//! [`Context::record`] is the only public way to record GPU work: every command goes through
//! the recorder's barrier tracker (raw command buffers, copies and fills stay inside the crate).
//!
//! Ownership and drop order: every resource holds an `Arc<Context>` and frees its own
//! allocation in `Drop`; the context drops the allocator, then the device, then the instance,
//! so it is always the last to go. A constructor that fails half-way destroys what it had
//! created (the guards of `guard.rs`), so no error path leaks a Vulkan object.

mod buffer;
mod context;
mod error;
mod guard;
mod image;
mod pipeline;
mod record;

pub use buffer::Buffer;
pub use context::{probe, validation_messages, Context, ContextOptions, DeviceInfo, Probed};
pub use error::GpuError;
pub use gpu_allocator::MemoryLocation;
pub use image::Image3d;
pub(crate) use pipeline::{copy_buffer, fill_buffer};
pub use pipeline::{Binding, ComputePipeline, Dispatch, Resource, Timer};
pub use record::{
    grid_groups, spread_groups, Access, Barrier, Recorder, Stage, Tracker, MAX_GROUPS_X,
};

pub use ash::vk;
