use std::sync::Arc;

use ash::vk;

use super::error::{GpuError, VkContext};
use super::guard::Cleanup;
use super::{Buffer, Context, Image3d};

/// What a shader does with one binding, declared once when its pipeline is made. The
/// descriptor type follows from it, and so do the accesses each dispatch reports to the
/// barrier tracker, so a pass cannot bind a buffer without its barriers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Binding {
    /// A uniform buffer, read.
    Uniform,
    /// A 3D image with its sampler, read (images are read-only here).
    Sampled,
    /// A storage buffer the shader only reads.
    Read,
    /// A storage buffer the shader only writes.
    Write,
    /// A storage buffer the shader reads and writes.
    ReadWrite,
}

impl Binding {
    fn descriptor(self) -> vk::DescriptorType {
        match self {
            Binding::Uniform => vk::DescriptorType::UNIFORM_BUFFER,
            Binding::Sampled => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
            Binding::Read | Binding::Write | Binding::ReadWrite => {
                vk::DescriptorType::STORAGE_BUFFER
            }
        }
    }

    /// Whether the shader may write what is bound here.
    fn writes(self) -> bool {
        matches!(self, Binding::Write | Binding::ReadWrite)
    }
}

/// A compute pipeline: shader module, descriptor set layout (one set, bindings 0..n in order,
/// each with its [`Binding`]) and push-constant range.
pub struct ComputePipeline {
    pub name: String,
    pub raw: vk::Pipeline,
    pub layout: vk::PipelineLayout,
    set_layout: vk::DescriptorSetLayout,
    bindings: Vec<Binding>,
    push_bytes: u32,
    ctx: Arc<Context>,
}

/// A resource for one binding slot.
pub enum Resource<'a> {
    Storage(&'a Buffer),
    Uniform(&'a Buffer),
    Sampled(&'a Image3d),
    /// The image through its linear sampler (a `Binding::Sampled` binding whose shader asks the
    /// texture unit to filter it: `texture()`), on a device with `r32f_linear_filter`.
    Filtered(&'a Image3d),
}

/// A descriptor set filled for one pipeline, with its own small pool; keep it alive until the
/// submission that uses it has completed.
pub struct Dispatch {
    set: vk::DescriptorSet,
    pool: vk::DescriptorPool,
    /// The pipeline it was bound for.
    pub(crate) pipeline: vk::Pipeline,
    /// Each buffer bound, once, and whether the shader may write it (through any of its
    /// bindings): the accesses of every dispatch with this set.
    pub(crate) buffers: Vec<(vk::Buffer, bool)>,
    ctx: Arc<Context>,
}

impl ComputePipeline {
    /// Builds a pipeline from SPIR-V bytes. `bindings[i]` is what the shader does with
    /// binding `i`.
    pub fn new(
        ctx: &Arc<Context>,
        name: &str,
        spirv: &[u8],
        bindings: &[Binding],
        push_bytes: u32,
    ) -> Result<Self, GpuError> {
        Self::with_constants(ctx, name, spirv, bindings, push_bytes, &[])
    }

    /// [`new`](Self::new) with specialization constants: `constants[i]` is the 32-bit value
    /// of `layout(constant_id = i)`. The driver compiles the shader with them folded in, so
    /// code they switch off costs nothing (unlike a branch on a uniform, which llvmpipe's
    /// register allocation still pays for).
    pub fn with_constants(
        ctx: &Arc<Context>,
        name: &str,
        spirv: &[u8],
        bindings: &[Binding],
        push_bytes: u32,
        constants: &[u32],
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let entries: Vec<vk::SpecializationMapEntry> = (0..constants.len() as u32)
            .map(|i| vk::SpecializationMapEntry { constant_id: i, offset: 4 * i, size: 4 })
            .collect();
        let spec = vk::SpecializationInfo::default()
            .map_entries(&entries)
            .data(bytemuck::cast_slice(constants));
        let code = ash::util::read_spv(&mut std::io::Cursor::new(spirv))
            .map_err(|e| GpuError::Bug(format!("shader `{name}` is not SPIR-V: {e}")))?;
        let layout_bindings: Vec<_> = bindings
            .iter()
            .enumerate()
            .map(|(i, b)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i as u32)
                    .descriptor_type(b.descriptor())
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        // SAFETY: valid device. Each object is guarded as soon as it exists: an error destroys
        // what was created so far (in reverse order); the module goes on every path (the
        // pipeline no longer needs it), the rest is owned by the returned pipeline's Drop.
        unsafe {
            let module = device
                .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&code), None)
                .vk("vkCreateShaderModule")?;
            let _module = Cleanup::new(|| device.destroy_shader_module(module, None));
            let set_layout = device
                .create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(&layout_bindings),
                    None,
                )
                .vk("vkCreateDescriptorSetLayout")?;
            let set_layout_guard =
                Cleanup::new(|| device.destroy_descriptor_set_layout(set_layout, None));
            let ranges = [vk::PushConstantRange::default()
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
                .size(push_bytes)];
            let set_layouts = [set_layout];
            let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
            if push_bytes > 0 {
                layout_info = layout_info.push_constant_ranges(&ranges);
            }
            let layout =
                device.create_pipeline_layout(&layout_info, None).vk("vkCreatePipelineLayout")?;
            let layout_guard = Cleanup::new(|| device.destroy_pipeline_layout(layout, None));
            let mut stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(c"main");
            if !constants.is_empty() {
                stage = stage.specialization_info(&spec);
            }
            let raw = device
                .create_compute_pipelines(
                    vk::PipelineCache::null(),
                    &[vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout)],
                    None,
                )
                .map_err(|(_, result)| GpuError::Vk { call: "vkCreateComputePipelines", result })?
                [0];
            layout_guard.disarm();
            set_layout_guard.disarm();
            ctx.set_name(raw, name);
            Ok(ComputePipeline {
                name: name.to_string(),
                raw,
                layout,
                set_layout,
                bindings: bindings.to_vec(),
                push_bytes,
                ctx: ctx.clone(),
            })
        }
    }

    /// What the shader does with each binding, in order.
    pub fn bindings(&self) -> &[Binding] {
        &self.bindings
    }

    /// Allocates and fills a descriptor set with `resources` (one per binding, in order), each
    /// checked against its binding's kind.
    pub fn bind(&self, resources: &[Resource]) -> Result<Dispatch, GpuError> {
        if resources.len() != self.bindings.len() {
            return Err(GpuError::Bug(format!(
                "pipeline `{}` takes {} bindings, got {}",
                self.name,
                self.bindings.len(),
                resources.len()
            )));
        }
        let kind = |r: &Resource| match r {
            Resource::Storage(_) => vk::DescriptorType::STORAGE_BUFFER,
            Resource::Uniform(_) => vk::DescriptorType::UNIFORM_BUFFER,
            Resource::Sampled(_) | Resource::Filtered(_) => {
                vk::DescriptorType::COMBINED_IMAGE_SAMPLER
            }
        };
        // Checked before anything is created.
        for (i, r) in resources.iter().enumerate() {
            if kind(r) != self.bindings[i].descriptor() {
                return Err(GpuError::Bug(format!(
                    "pipeline `{}` binding {i} is {:?} ({:?}), got {:?}",
                    self.name,
                    self.bindings[i],
                    self.bindings[i].descriptor(),
                    kind(r)
                )));
            }
        }
        let device = &self.ctx.device;
        let mut sizes: Vec<vk::DescriptorPoolSize> = Vec::new();
        for ty in self.bindings.iter().map(|b| b.descriptor()) {
            match sizes.iter_mut().find(|s| s.ty == ty) {
                Some(s) => s.descriptor_count += 1,
                None => sizes.push(vk::DescriptorPoolSize { ty, descriptor_count: 1 }),
            }
        }
        // SAFETY: valid device; the pool is destroyed with the Dispatch (built right after, so
        // also when allocating the set fails).
        let pool = unsafe {
            device.create_descriptor_pool(
                &vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(&sizes),
                None,
            )
        }
        .vk("vkCreateDescriptorPool")?;
        let buffers =
            accesses(resources.iter().zip(&self.bindings).filter_map(|(r, &binding)| match r {
                Resource::Storage(b) | Resource::Uniform(b) => Some((b.raw, binding)),
                Resource::Sampled(_) | Resource::Filtered(_) => None,
            }));
        let mut dispatch = Dispatch {
            set: vk::DescriptorSet::null(),
            pool,
            pipeline: self.raw,
            buffers,
            ctx: self.ctx.clone(),
        };
        let layouts = [self.set_layout];
        // SAFETY: pool and layout are valid.
        let set = unsafe {
            device.allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default()
                    .descriptor_pool(pool)
                    .set_layouts(&layouts),
            )
        }
        .vk("vkAllocateDescriptorSets")?[0];

        let buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = resources
            .iter()
            .map(|r| match r {
                Resource::Storage(b) | Resource::Uniform(b) => {
                    [vk::DescriptorBufferInfo { buffer: b.raw, offset: 0, range: vk::WHOLE_SIZE }]
                }
                Resource::Sampled(_) | Resource::Filtered(_) => {
                    [vk::DescriptorBufferInfo::default()]
                }
            })
            .collect();
        let image_infos: Vec<[vk::DescriptorImageInfo; 1]> = resources
            .iter()
            .map(|r| match r {
                Resource::Sampled(img) | Resource::Filtered(img) => [vk::DescriptorImageInfo {
                    sampler: match r {
                        Resource::Filtered(_) => img.linear_sampler,
                        _ => img.sampler,
                    },
                    image_view: img.view,
                    image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                }],
                _ => [vk::DescriptorImageInfo::default()],
            })
            .collect();
        let mut writes = Vec::new();
        for (i, r) in resources.iter().enumerate() {
            let w = vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(i as u32)
                .descriptor_type(kind(r));
            writes.push(if matches!(r, Resource::Sampled(_) | Resource::Filtered(_)) {
                w.image_info(&image_infos[i])
            } else {
                w.buffer_info(&buffer_infos[i])
            });
        }
        // SAFETY: the infos outlive the call; resources are valid.
        unsafe { device.update_descriptor_sets(&writes, &[]) };
        dispatch.set = set;
        Ok(dispatch)
    }

    /// Records a dispatch of `groups` workgroups with `push` constants (through
    /// [`Recorder::dispatch`](crate::Recorder::dispatch), which adds its barriers).
    pub(crate) fn record(
        &self,
        cmd: vk::CommandBuffer,
        set: &Dispatch,
        push: &[u8],
        groups: [u32; 3],
    ) {
        self.bind_for(cmd, set, push);
        // SAFETY: cmd is recording, with this pipeline bound.
        unsafe { self.ctx.device.cmd_dispatch(cmd, groups[0], groups[1], groups[2]) };
    }

    /// Binds the pipeline, `set` and the `push` constants for a dispatch.
    fn bind_for(&self, cmd: vk::CommandBuffer, set: &Dispatch, push: &[u8]) {
        let device = &self.ctx.device;
        debug_assert_eq!(push.len() as u32, self.push_bytes);
        // SAFETY: cmd is recording; pipeline, layout and set are valid.
        unsafe {
            device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.raw);
            device.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.layout,
                0,
                &[set.set],
                &[],
            );
            if !push.is_empty() {
                device.cmd_push_constants(cmd, self.layout, vk::ShaderStageFlags::COMPUTE, 0, push);
            }
        }
    }

    /// [`ComputePipeline::record`] with the workgroup counts in `args` at `offset` (through
    /// [`Recorder::dispatch_indirect`](crate::Recorder::dispatch_indirect)).
    pub(crate) fn record_indirect(
        &self,
        cmd: vk::CommandBuffer,
        set: &Dispatch,
        push: &[u8],
        args: &Buffer,
        offset: u64,
    ) {
        self.bind_for(cmd, set, push);
        // SAFETY: cmd is recording; args is a valid buffer with INDIRECT_BUFFER usage holding a
        // VkDispatchIndirectCommand at offset (callers size it).
        unsafe { self.ctx.device.cmd_dispatch_indirect(cmd, args.raw, offset) };
    }
}

/// Each bound buffer once, with whether the shader may write it: a buffer bound twice is
/// written if either binding writes it.
fn accesses(bound: impl Iterator<Item = (vk::Buffer, Binding)>) -> Vec<(vk::Buffer, bool)> {
    let mut out: Vec<(vk::Buffer, bool)> = Vec::new();
    for (raw, binding) in bound {
        match out.iter_mut().find(|(b, _)| *b == raw) {
            Some((_, write)) => *write |= binding.writes(),
            None => out.push((raw, binding.writes())),
        }
    }
    out
}

impl Drop for ComputePipeline {
    fn drop(&mut self) {
        // SAFETY: no submission is in flight (submissions wait on their fence).
        unsafe {
            self.ctx.device.destroy_pipeline(self.raw, None);
            self.ctx.device.destroy_pipeline_layout(self.layout, None);
            self.ctx.device.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

impl Drop for Dispatch {
    fn drop(&mut self) {
        // SAFETY: destroying the pool frees its set; no submission using it is in flight.
        unsafe { self.ctx.device.destroy_descriptor_pool(self.pool, None) };
    }
}

/// Records a copy of `bytes` bytes between buffers.
pub(crate) fn copy_buffer(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    src: &Buffer,
    src_offset: u64,
    dst: &Buffer,
    dst_offset: u64,
    bytes: u64,
) {
    let region = vk::BufferCopy { src_offset, dst_offset, size: bytes };
    // SAFETY: cmd is recording and both buffers are valid and large enough (callers size them).
    unsafe { ctx.device.cmd_copy_buffer(cmd, src.raw, dst.raw, &[region]) };
}

/// Records a fill of `bytes` bytes of `dst` from `offset` with the 32-bit word `value` (offset
/// and size multiples of 4).
pub(crate) fn fill_buffer(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    dst: &Buffer,
    offset: u64,
    bytes: u64,
    value: u32,
) {
    // SAFETY: cmd is recording and the buffer is valid; callers keep the range inside it.
    unsafe { ctx.device.cmd_fill_buffer(cmd, dst.raw, offset, bytes, value) };
}

/// A pair of timestamps around recorded work.
pub struct Timer {
    pool: vk::QueryPool,
    ctx: Arc<Context>,
}

impl Timer {
    pub fn new(ctx: &Arc<Context>) -> Result<Option<Self>, GpuError> {
        if !ctx.info.timestamps {
            return Ok(None);
        }
        let info =
            vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(2);
        // SAFETY: valid device; destroyed in Drop.
        let pool = unsafe { ctx.device.create_query_pool(&info, None) }.vk("vkCreateQueryPool")?;
        Ok(Some(Timer { pool, ctx: ctx.clone() }))
    }

    /// Writes the first timestamp (through [`Recorder::timed`](crate::Recorder::timed)).
    pub(crate) fn begin(&self, cmd: vk::CommandBuffer) {
        // SAFETY: cmd is recording; the pool has 2 queries.
        unsafe {
            self.ctx.device.cmd_reset_query_pool(cmd, self.pool, 0, 2);
            self.ctx.device.cmd_write_timestamp(
                cmd,
                vk::PipelineStageFlags::TOP_OF_PIPE,
                self.pool,
                0,
            );
        }
    }

    /// Writes the second timestamp.
    pub(crate) fn end(&self, cmd: vk::CommandBuffer) {
        // SAFETY: cmd is recording.
        unsafe {
            self.ctx.device.cmd_write_timestamp(
                cmd,
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                self.pool,
                1,
            )
        };
    }

    /// Milliseconds between begin and end, after the submission completed.
    pub fn elapsed_ms(&self) -> Result<f64, GpuError> {
        let mut ticks = [0u64; 2];
        // SAFETY: both queries were written by a completed submission.
        unsafe {
            self.ctx.device.get_query_pool_results(
                self.pool,
                0,
                &mut ticks,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .vk("vkGetQueryPoolResults")?;
        Ok(ticks[1].wrapping_sub(ticks[0]) as f64 * self.ctx.info.timestamp_period_ns as f64 * 1e-6)
    }
}

impl Drop for Timer {
    fn drop(&mut self) {
        // SAFETY: no submission using the pool is in flight.
        unsafe { self.ctx.device.destroy_query_pool(self.pool, None) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ash::vk::Handle;

    #[test]
    fn a_buffer_bound_twice_is_one_access_written_if_either_binding_writes() {
        let (a, b) = (vk::Buffer::from_raw(1), vk::Buffer::from_raw(2));
        let bound =
            [(a, Binding::Uniform), (b, Binding::Read), (a, Binding::Write), (b, Binding::Read)];
        assert_eq!(accesses(bound.into_iter()), [(a, true), (b, false)]);
        let bound = [(a, Binding::ReadWrite), (a, Binding::Read)];
        assert_eq!(accesses(bound.into_iter()), [(a, true)]);
    }
}
