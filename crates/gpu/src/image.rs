use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use super::error::{GpuError, VkContext};
use super::{Buffer, Context};

/// Largest staging buffer used for an upload; bigger data goes up in z-slabs.
const STAGING_BYTES: u64 = 64 << 20;

/// A 3D `R32_SFLOAT` image read with `texelFetch` (exact values, no filtering), with its view and
/// a nearest-filter sampler, in `SHADER_READ_ONLY_OPTIMAL` layout once uploaded; and a
/// linear-filter sampler for the shaders that ask the texture unit to filter it
/// ([`crate::Resource::Filtered`], on devices with [`crate::DeviceInfo::r32f_linear_filter`]).
pub struct Image3d {
    pub raw: vk::Image,
    pub view: vk::ImageView,
    pub sampler: vk::Sampler,
    pub linear_sampler: vk::Sampler,
    pub extent: [u32; 3],
    allocation: Option<Allocation>,
    ctx: Arc<Context>,
}

impl Image3d {
    /// Creates the image and uploads `values` (x fastest, `extent` texels) through a staging
    /// buffer in slabs of at most 64 MiB.
    pub fn upload(
        ctx: &Arc<Context>,
        name: &str,
        extent: [u32; 3],
        values: &[f32],
    ) -> Result<Self, GpuError> {
        let max = ctx.info.max_image_dimension_3d;
        if extent.iter().any(|&e| e > max) {
            return Err(GpuError::TooLarge {
                what: format!("a grid of {}x{}x{} points", extent[0], extent[1], extent[2]),
                limit: format!("the device's 3D images (at most {max} points per axis)"),
            });
        }
        let texels = extent.iter().map(|&e| e as usize).product::<usize>();
        if values.len() != texels {
            return Err(GpuError::Bug(format!(
                "image `{name}` needs {texels} values, got {}",
                values.len()
            )));
        }
        let device = &ctx.device;
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_3D)
            .format(vk::Format::R32_SFLOAT)
            .extent(vk::Extent3D { width: extent[0], height: extent[1], depth: extent[2] })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(
                vk::ImageUsageFlags::SAMPLED
                    | vk::ImageUsageFlags::TRANSFER_DST
                    | vk::ImageUsageFlags::TRANSFER_SRC,
            )
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid device; destroyed below if the allocation fails, then by the `Image3d`
        // that owns it (in Drop, also on every error path after that).
        let raw = unsafe { device.create_image(&info, None) }.vk("vkCreateImage")?;
        let requirements = unsafe { device.get_image_memory_requirements(raw) };
        let allocation = ctx.allocator.lock().unwrap_or_else(|p| p.into_inner()).allocate(
            &AllocationCreateDesc {
                name,
                requirements,
                location: MemoryLocation::GpuOnly,
                linear: false,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            },
        );
        let allocation = match allocation {
            Ok(a) => a,
            Err(source) => {
                // SAFETY: created above, never used.
                unsafe { device.destroy_image(raw, None) };
                return Err(GpuError::Alloc { name: name.to_string(), source });
            }
        };
        // SAFETY: the memory handle is only bound below; the allocation stays its owner.
        let (memory, offset) = (unsafe { allocation.memory() }, allocation.offset());
        // Owned from here: an error below drops it, destroying what was created so far (the null
        // view and sampler are ignored by their destroy calls) and freeing the memory.
        let mut image = Image3d {
            raw,
            view: vk::ImageView::null(),
            sampler: vk::Sampler::null(),
            linear_sampler: vk::Sampler::null(),
            extent,
            allocation: Some(allocation),
            ctx: ctx.clone(),
        };
        // SAFETY: memory from the allocation made for this image.
        unsafe { device.bind_image_memory(raw, memory, offset) }.vk("vkBindImageMemory")?;
        ctx.set_name(raw, name);

        let range = vk::ImageSubresourceRange::default()
            .aspect_mask(vk::ImageAspectFlags::COLOR)
            .level_count(1)
            .layer_count(1);
        let view_info = vk::ImageViewCreateInfo::default()
            .image(raw)
            .view_type(vk::ImageViewType::TYPE_3D)
            .format(vk::Format::R32_SFLOAT)
            .subresource_range(range);
        // SAFETY: image is valid; the view is destroyed in Drop.
        image.view =
            unsafe { device.create_image_view(&view_info, None) }.vk("vkCreateImageView")?;
        let sampler_info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .unnormalized_coordinates(false);
        // SAFETY: valid device; destroyed in Drop.
        image.sampler =
            unsafe { device.create_sampler(&sampler_info, None) }.vk("vkCreateSampler")?;
        let linear_info =
            sampler_info.mag_filter(vk::Filter::LINEAR).min_filter(vk::Filter::LINEAR);
        // SAFETY: valid device; destroyed in Drop. Creating it needs no format feature; only
        // sampling the image through it does (the callers check `r32f_linear_filter`).
        image.linear_sampler =
            unsafe { device.create_sampler(&linear_info, None) }.vk("vkCreateSampler")?;

        // Upload in z-slabs through one staging buffer.
        let slice_texels = extent[0] as u64 * extent[1] as u64;
        let slab_depth = (STAGING_BYTES / (slice_texels * 4)).clamp(1, extent[2] as u64) as u32;
        let mut staging = Buffer::new(
            ctx,
            &format!("{name} staging"),
            slice_texels * 4 * slab_depth as u64,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        let mut z = 0;
        while z < extent[2] {
            let depth = slab_depth.min(extent[2] - z);
            let start = (z as u64 * slice_texels) as usize;
            let end = start + (depth as u64 * slice_texels) as usize;
            staging.write(&values[start..end])?;
            let first = z == 0;
            let last = z + depth == extent[2];
            ctx.submit(&format!("upload {name}"), |cmd| {
                // SAFETY: cmd is recording; image and staging are alive until the fence wait.
                unsafe {
                    if first {
                        barrier(
                            device,
                            cmd,
                            raw,
                            range,
                            (vk::ImageLayout::UNDEFINED, vk::ImageLayout::TRANSFER_DST_OPTIMAL),
                            (vk::AccessFlags::empty(), vk::AccessFlags::TRANSFER_WRITE),
                            (vk::PipelineStageFlags::TOP_OF_PIPE, vk::PipelineStageFlags::TRANSFER),
                        );
                    }
                    let region = vk::BufferImageCopy::default()
                        .image_subresource(
                            vk::ImageSubresourceLayers::default()
                                .aspect_mask(vk::ImageAspectFlags::COLOR)
                                .layer_count(1),
                        )
                        .image_offset(vk::Offset3D { x: 0, y: 0, z: z as i32 })
                        .image_extent(vk::Extent3D { width: extent[0], height: extent[1], depth });
                    device.cmd_copy_buffer_to_image(
                        cmd,
                        staging.raw,
                        raw,
                        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                        &[region],
                    );
                    if last {
                        barrier(
                            device,
                            cmd,
                            raw,
                            range,
                            (
                                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                                vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                            ),
                            (vk::AccessFlags::TRANSFER_WRITE, vk::AccessFlags::SHADER_READ),
                            (
                                vk::PipelineStageFlags::TRANSFER,
                                vk::PipelineStageFlags::COMPUTE_SHADER,
                            ),
                        );
                    }
                }
                Ok(())
            })?;
            z += depth;
        }
        Ok(image)
    }
}

impl Image3d {
    /// A device-local storage buffer holding the image's texels, x fastest (the layout
    /// `upload` took them in), copied on the device. The image stays in
    /// `SHADER_READ_ONLY_OPTIMAL`; the buffer is ready for compute shaders to read.
    pub fn copy_to_buffer(&self, name: &str) -> Result<Buffer, GpuError> {
        let ctx = &self.ctx;
        let device = &ctx.device;
        let texels = self.extent.iter().map(|&e| e as u64).product::<u64>();
        let buffer = Buffer::new(
            ctx,
            name,
            texels * 4,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        let range = vk::ImageSubresourceRange::default()
            .aspect_mask(vk::ImageAspectFlags::COLOR)
            .level_count(1)
            .layer_count(1);
        let [width, height, depth] = self.extent;
        ctx.submit(&format!("copy to {name}"), |cmd| {
            // SAFETY: cmd is recording; image and buffer are alive until the fence wait.
            unsafe {
                barrier(
                    device,
                    cmd,
                    self.raw,
                    range,
                    (
                        vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                        vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    ),
                    (vk::AccessFlags::SHADER_READ, vk::AccessFlags::TRANSFER_READ),
                    (vk::PipelineStageFlags::COMPUTE_SHADER, vk::PipelineStageFlags::TRANSFER),
                );
                let region = vk::BufferImageCopy::default()
                    .image_subresource(
                        vk::ImageSubresourceLayers::default()
                            .aspect_mask(vk::ImageAspectFlags::COLOR)
                            .layer_count(1),
                    )
                    .image_extent(vk::Extent3D { width, height, depth });
                device.cmd_copy_image_to_buffer(
                    cmd,
                    self.raw,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    buffer.raw,
                    &[region],
                );
                barrier(
                    device,
                    cmd,
                    self.raw,
                    range,
                    (
                        vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                        vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                    ),
                    (vk::AccessFlags::TRANSFER_READ, vk::AccessFlags::SHADER_READ),
                    (vk::PipelineStageFlags::TRANSFER, vk::PipelineStageFlags::COMPUTE_SHADER),
                );
                let written = vk::BufferMemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                    .dst_access_mask(vk::AccessFlags::SHADER_READ)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .buffer(buffer.raw)
                    .size(vk::WHOLE_SIZE);
                device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::COMPUTE_SHADER,
                    vk::DependencyFlags::empty(),
                    &[],
                    &[written],
                    &[],
                );
            }
            Ok(())
        })?;
        Ok(buffer)
    }
}

/// Records one image layout transition.
///
/// # Safety
/// `cmd` must be recording and `image` valid.
unsafe fn barrier(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    image: vk::Image,
    range: vk::ImageSubresourceRange,
    layouts: (vk::ImageLayout, vk::ImageLayout),
    access: (vk::AccessFlags, vk::AccessFlags),
    stages: (vk::PipelineStageFlags, vk::PipelineStageFlags),
) {
    let b = vk::ImageMemoryBarrier::default()
        .old_layout(layouts.0)
        .new_layout(layouts.1)
        .src_access_mask(access.0)
        .dst_access_mask(access.1)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(range);
    // SAFETY: per this function's contract.
    unsafe {
        device.cmd_pipeline_barrier(
            cmd,
            stages.0,
            stages.1,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &[b],
        )
    };
}

impl Drop for Image3d {
    fn drop(&mut self) {
        // SAFETY: submissions wait on their fence, so the GPU no longer uses these objects.
        unsafe {
            self.ctx.device.destroy_sampler(self.sampler, None);
            self.ctx.device.destroy_sampler(self.linear_sampler, None);
            self.ctx.device.destroy_image_view(self.view, None);
            self.ctx.device.destroy_image(self.raw, None);
        }
        if let Some(a) = self.allocation.take() {
            let _ = self.ctx.allocator.lock().unwrap_or_else(|p| p.into_inner()).free(a);
        }
    }
}
