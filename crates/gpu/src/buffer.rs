use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use super::error::{GpuError, VkContext};
use super::Context;

/// A buffer and its memory. Host access (`write`, `read`) is only for `CpuToGpu` / `GpuToCpu`
/// buffers: GPU-only memory is not host-visible on real GPUs (it is on lavapipe), so uploads and
/// readbacks go through such staging buffers.
pub struct Buffer {
    pub raw: vk::Buffer,
    pub size: u64,
    pub name: String,
    allocation: Option<Allocation>,
    ctx: Arc<Context>,
}

impl Buffer {
    pub fn new(
        ctx: &Arc<Context>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Result<Self, GpuError> {
        let size = size.max(4);
        let device = &ctx.device;
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device; the buffer is destroyed below if the allocation fails, then by
        // the `Buffer` that owns it from there on (in Drop, also on the error paths below).
        let raw = unsafe { device.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
        let requirements = unsafe { device.get_buffer_memory_requirements(raw) };
        let allocation = ctx.allocator.lock().unwrap_or_else(|p| p.into_inner()).allocate(
            &AllocationCreateDesc {
                name,
                requirements,
                location,
                linear: true,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            },
        );
        let allocation = match allocation {
            Ok(a) => a,
            Err(source) => {
                // SAFETY: the buffer was created above and never used.
                unsafe { device.destroy_buffer(raw, None) };
                return Err(GpuError::Alloc { name: name.to_string(), source });
            }
        };
        // SAFETY: the memory handle is only bound below; the allocation stays its owner.
        let (memory, offset) = (unsafe { allocation.memory() }, allocation.offset());
        // Owned from here: an error below drops it, destroying the buffer and freeing its memory.
        let buffer = Buffer {
            raw,
            size,
            name: name.to_string(),
            allocation: Some(allocation),
            ctx: ctx.clone(),
        };
        // SAFETY: memory and offset come from the allocation made for this buffer.
        unsafe { device.bind_buffer_memory(raw, memory, offset) }.vk("vkBindBufferMemory")?;
        ctx.set_name(raw, name);
        Ok(buffer)
    }

    /// A device-local buffer holding `data`, uploaded through a staging buffer (one submission
    /// that waits). `usage` gets `TRANSFER_DST` added.
    pub fn upload<T: bytemuck::Pod>(
        ctx: &Arc<Context>,
        name: &str,
        data: &[T],
        usage: vk::BufferUsageFlags,
    ) -> Result<Self, GpuError> {
        let bytes = std::mem::size_of_val(data) as u64;
        let mut staging = Buffer::new(
            ctx,
            &format!("{name} staging"),
            bytes,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(data)?;
        let buffer = Buffer::new(
            ctx,
            name,
            bytes,
            usage | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        if bytes > 0 {
            ctx.record(&format!("upload {name}"), &mut super::Tracker::default(), |rec| {
                rec.copy(&staging, 0, &buffer, 0, bytes);
                // Later submissions read the buffer without knowing of this copy.
                rec.release();
                Ok(())
            })?;
        }
        Ok(buffer)
    }

    fn mapped(&self) -> Result<&[u8], GpuError> {
        self.allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .ok_or_else(|| GpuError::Bug(format!("buffer `{}` is not host-visible", self.name)))
    }

    /// Copies `data` to the start of a host-visible buffer.
    pub fn write<T: bytemuck::Pod>(&mut self, data: &[T]) -> Result<(), GpuError> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let name = self.name.clone();
        let slice = self
            .allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .ok_or_else(|| GpuError::Bug(format!("buffer `{name}` is not host-visible")))?;
        if bytes.len() > slice.len() {
            return Err(GpuError::Bug(format!(
                "{} bytes do not fit buffer `{name}` of {} bytes",
                bytes.len(),
                slice.len()
            )));
        }
        slice[..bytes.len()].copy_from_slice(bytes);
        Ok(())
    }

    /// Reads `count` elements from the start of a host-visible buffer.
    pub fn read<T: bytemuck::Pod>(&self, count: usize) -> Result<Vec<T>, GpuError> {
        let slice = self.mapped()?;
        let bytes = count * std::mem::size_of::<T>();
        if bytes > slice.len() {
            return Err(GpuError::Bug(format!("read past the end of buffer `{}`", self.name)));
        }
        // pod_collect_to_vec copies, so the mapped slice's alignment does not matter.
        Ok(bytemuck::pod_collect_to_vec(&slice[..bytes]))
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // SAFETY: submissions wait on their fence, so the GPU no longer uses the buffer.
        unsafe { self.ctx.device.destroy_buffer(self.raw, None) };
        if let Some(a) = self.allocation.take() {
            let _ = self.ctx.allocator.lock().unwrap_or_else(|p| p.into_inner()).free(a);
        }
    }
}
