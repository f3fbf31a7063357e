//! Recording work whose barriers follow from what each command declares it reads and writes.
//!
//! A pass hands [`Recorder::dispatch`] its pipeline, bound set, push constants and workgroups;
//! what the shader reads and writes follows from the set and the pipeline's
//! [`Binding`](crate::Binding)s, declared once with the pipeline. Fills and copies declare
//! theirs by their arguments. The [`Tracker`] remembers, per buffer, the stage of the last write and which
//! stages have read it since; before each command the recorder inserts the one global memory
//! barrier the command needs, or none:
//!
//! ```text
//!   read or write after a write (RAW, WAW)   writer stage/write access -> this stage/read+write
//!   write after a read (WAR)                 reader stage -> this stage (execution only)
//!   read after a read                        nothing
//! ```
//!
//! Stages are compute, transfer, the host (reads only: [`Recorder::host_read`]) and the
//! indirect-command read of [`Recorder::dispatch_indirect`] (reads only). A tracker
//! may span several submissions (each submission waits for its fence, but a write is not
//! visible to a later submission's commands without a barrier); [`Recorder::release`] makes
//! every tracked write visible to whatever runs next, tracked or not. Buffers are keyed by their
//! raw handle; a handle reused after a buffer is dropped can only cost an extra barrier, never
//! a missing one. Images are read-only here: their uploads make themselves visible.
//!
//! Group math also lives here: [`grid_groups`] for work laid out on a 2D/3D grid of items,
//! [`spread_groups`] for 1D work spread over x and y within the 65535-groups-per-axis minimum.

use ash::vk;
use std::collections::HashMap;

use super::{Buffer, ComputePipeline, Context, Dispatch, GpuError, Timer};

/// Most workgroups along one dispatch axis that every Vulkan device accepts.
pub const MAX_GROUPS_X: u32 = 65535;

/// Where an access happens.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    Compute,
    Transfer,
    Host,
    /// A dispatch reading its workgroup counts from a buffer.
    Indirect,
}

/// How many [`Stage`]s there are.
const STAGES: usize = 4;

impl Stage {
    const ALL: [Stage; STAGES] = [Stage::Compute, Stage::Transfer, Stage::Host, Stage::Indirect];

    fn index(self) -> usize {
        self as usize
    }

    fn stage(self) -> vk::PipelineStageFlags {
        match self {
            Stage::Compute => vk::PipelineStageFlags::COMPUTE_SHADER,
            Stage::Transfer => vk::PipelineStageFlags::TRANSFER,
            Stage::Host => vk::PipelineStageFlags::HOST,
            Stage::Indirect => vk::PipelineStageFlags::DRAW_INDIRECT,
        }
    }

    fn read(self) -> vk::AccessFlags {
        match self {
            Stage::Compute => vk::AccessFlags::SHADER_READ,
            Stage::Transfer => vk::AccessFlags::TRANSFER_READ,
            Stage::Host => vk::AccessFlags::HOST_READ,
            Stage::Indirect => vk::AccessFlags::INDIRECT_COMMAND_READ,
        }
    }

    fn write(self) -> vk::AccessFlags {
        match self {
            Stage::Compute => vk::AccessFlags::SHADER_WRITE,
            Stage::Transfer => vk::AccessFlags::TRANSFER_WRITE,
            Stage::Host => vk::AccessFlags::HOST_WRITE,
            // Never written there (only read).
            Stage::Indirect => vk::AccessFlags::empty(),
        }
    }
}

/// What is known of one buffer since its last write.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct State {
    /// Stage of the last write.
    writer: Option<Stage>,
    /// Stages the last write has been made visible to, by [`Stage::index`].
    visible: [bool; STAGES],
    /// Stages that read the buffer since the last write.
    readers: [bool; STAGES],
}

/// One barrier: source and destination stages and accesses (empty: none needed).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Barrier {
    pub src_stages: vk::PipelineStageFlags,
    pub src_access: vk::AccessFlags,
    pub dst_stages: vk::PipelineStageFlags,
    pub dst_access: vk::AccessFlags,
}

impl Barrier {
    pub fn is_empty(&self) -> bool {
        self.src_stages.is_empty()
    }
}

/// One access of a command to a buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Access {
    pub buffer: vk::Buffer,
    pub stage: Stage,
    /// Whether the command writes the buffer (it may read it too).
    pub write: bool,
}

/// The last writer and the readers since of every buffer a recording touched. Pure
/// bookkeeping: [`Tracker::before`] says which barrier a command needs, the [`Recorder`]
/// records it.
#[derive(Debug, Default)]
pub struct Tracker {
    states: HashMap<vk::Buffer, State>,
}

impl Tracker {
    /// The barrier needed before a command with `accesses`, and the bookkeeping of that
    /// barrier and of the command (so call it once per command, then record both).
    pub fn before(&mut self, accesses: &[Access]) -> Barrier {
        let mut b = Barrier::default();
        for a in accesses {
            let st = self.states.get(&a.buffer).copied().unwrap_or_default();
            if let Some(w) = st.writer.filter(|_| !st.visible[a.stage.index()]) {
                b.src_stages |= w.stage();
                b.src_access |= w.write();
                b.dst_stages |= a.stage.stage();
                b.dst_access |= a.stage.read() | a.stage.write();
            }
            if a.write {
                for r in Stage::ALL.into_iter().filter(|r| st.readers[r.index()]) {
                    b.src_stages |= r.stage();
                    b.dst_stages |= a.stage.stage();
                }
            }
        }
        self.apply(&b);
        for a in accesses {
            let st = self.states.entry(a.buffer).or_default();
            if a.write {
                *st = State { writer: Some(a.stage), ..State::default() };
            } else {
                st.readers[a.stage.index()] = true;
            }
        }
        b
    }

    /// The barrier that makes every tracked write visible to all later commands.
    pub fn release(&mut self) -> Barrier {
        let mut b = Barrier::default();
        for st in self.states.values() {
            if let Some(w) = st.writer.filter(|_| st.visible.contains(&false)) {
                b.src_stages |= w.stage();
                b.src_access |= w.write();
            }
        }
        if !b.is_empty() {
            b.dst_stages = vk::PipelineStageFlags::ALL_COMMANDS;
            b.dst_access = vk::AccessFlags::MEMORY_READ | vk::AccessFlags::MEMORY_WRITE;
            for st in self.states.values_mut() {
                st.visible = [true; STAGES];
                st.readers = [false; STAGES];
            }
        }
        b
    }

    /// Records that `buffer` was written at `stage` by work this tracker did not see (for
    /// example an upload submitted on its own).
    pub fn written(&mut self, buffer: &Buffer, stage: Stage) {
        self.states.insert(buffer.raw, State { writer: Some(stage), ..State::default() });
    }

    /// A global memory barrier orders every buffer's accesses: mark what `b` made visible and
    /// which reads it waited for.
    fn apply(&mut self, b: &Barrier) {
        if b.is_empty() {
            return;
        }
        for st in self.states.values_mut() {
            if let Some(w) = st.writer {
                if b.src_stages.contains(w.stage()) && b.src_access.contains(w.write()) {
                    for s in Stage::ALL {
                        if b.dst_stages.contains(s.stage()) {
                            st.visible[s.index()] = true;
                        }
                    }
                }
            }
            if Stage::ALL.iter().all(|s| b.dst_stages.contains(s.stage())) {
                st.readers = [false; STAGES];
            }
        }
    }
}

/// Records commands into one command buffer with the barriers their declared accesses need.
pub struct Recorder<'a> {
    ctx: &'a Context,
    cmd: vk::CommandBuffer,
    tracker: &'a mut Tracker,
}

impl<'a> Recorder<'a> {
    pub(crate) fn new(ctx: &'a Context, cmd: vk::CommandBuffer, tracker: &'a mut Tracker) -> Self {
        Recorder { ctx, cmd, tracker }
    }

    /// Records `record` between the two timestamps of `timer` (none: just `record`); read the
    /// time with [`Timer::elapsed_ms`] once the submission completed.
    pub fn timed<F>(&mut self, timer: Option<&Timer>, record: F) -> Result<(), GpuError>
    where
        F: FnOnce(&mut Recorder) -> Result<(), GpuError>,
    {
        if let Some(t) = timer {
            t.begin(self.cmd);
        }
        record(self)?;
        if let Some(t) = timer {
            t.end(self.cmd);
        }
        Ok(())
    }

    fn barrier(&mut self, accesses: &[Access]) {
        let b = self.tracker.before(accesses);
        self.record_barrier(&b);
    }

    fn record_barrier(&self, b: &Barrier) {
        if b.is_empty() {
            return;
        }
        let m = [vk::MemoryBarrier::default()
            .src_access_mask(b.src_access)
            .dst_access_mask(b.dst_access)];
        // SAFETY: cmd is recording.
        unsafe {
            self.ctx.device.cmd_pipeline_barrier(
                self.cmd,
                b.src_stages,
                b.dst_stages,
                vk::DependencyFlags::empty(),
                &m,
                &[],
                &[],
            )
        };
    }

    /// Records a dispatch of `pipeline` with `set` (bound for it), `push` constants and
    /// `groups` workgroups, after the barrier it needs: every buffer in `set` is accessed as
    /// its binding says ([`Binding`](crate::Binding), declared with the pipeline).
    pub fn dispatch(
        &mut self,
        pipeline: &ComputePipeline,
        set: &Dispatch,
        push: &[u8],
        groups: [u32; 3],
    ) {
        assert!(
            set.pipeline == pipeline.raw,
            "pass `{}` dispatched with a set bound for another pipeline",
            pipeline.name
        );
        let accesses: Vec<Access> = (set.buffers.iter())
            .map(|&(buffer, write)| Access { buffer, stage: Stage::Compute, write })
            .collect();
        self.barrier(&accesses);
        pipeline.record(self.cmd, set, push, groups);
    }

    /// [`Recorder::dispatch`] with its workgroup counts read on the device from `args` at
    /// `offset` (three `u32`: x, y, z, as `VkDispatchIndirectCommand`), typically written by an
    /// earlier pass: work sized by what the GPU found, with no host round trip. `args` needs
    /// `INDIRECT_BUFFER` usage.
    pub fn dispatch_indirect(
        &mut self,
        pipeline: &ComputePipeline,
        set: &Dispatch,
        push: &[u8],
        args: &Buffer,
        offset: u64,
    ) {
        assert!(
            set.pipeline == pipeline.raw,
            "pass `{}` dispatched with a set bound for another pipeline",
            pipeline.name
        );
        let mut accesses: Vec<Access> = (set.buffers.iter())
            .map(|&(buffer, write)| Access { buffer, stage: Stage::Compute, write })
            .collect();
        accesses.push(Access { buffer: args.raw, stage: Stage::Indirect, write: false });
        self.barrier(&accesses);
        pipeline.record_indirect(self.cmd, set, push, args, offset);
    }

    /// Records a fill of `bytes` bytes of `dst` from `offset` with the 32-bit word `value`
    /// (offset and size multiples of 4, inside the buffer).
    pub fn fill(&mut self, dst: &Buffer, offset: u64, bytes: u64, value: u32) {
        self.barrier(&[Access { buffer: dst.raw, stage: Stage::Transfer, write: true }]);
        super::fill_buffer(self.ctx, self.cmd, dst, offset, bytes, value);
    }

    /// Records a copy of `bytes` bytes from `src` at `src_offset` to `dst` at `dst_offset`.
    pub fn copy(
        &mut self,
        src: &Buffer,
        src_offset: u64,
        dst: &Buffer,
        dst_offset: u64,
        bytes: u64,
    ) {
        self.barrier(&[
            Access { buffer: src.raw, stage: Stage::Transfer, write: false },
            Access { buffer: dst.raw, stage: Stage::Transfer, write: true },
        ]);
        super::copy_buffer(self.ctx, self.cmd, src, src_offset, dst, dst_offset, bytes);
    }

    /// Makes `buffer`'s last write visible to the host once the submission's fence signals.
    pub fn host_read(&mut self, buffer: &Buffer) {
        self.barrier(&[Access { buffer: buffer.raw, stage: Stage::Host, write: false }]);
    }

    /// Copies the first `bytes` of `src` into the host-visible `dst` and makes them visible to
    /// the host.
    pub fn readback(&mut self, src: &Buffer, dst: &Buffer, bytes: u64) {
        self.copy(src, 0, dst, 0, bytes);
        self.host_read(dst);
    }

    /// Makes every tracked write visible to whatever runs next (later submissions, untracked
    /// work).
    pub fn release(&mut self) {
        let b = self.tracker.release();
        self.record_barrier(&b);
    }
}

impl Context {
    /// Records and submits one command buffer through a [`Recorder`] over `tracker` (a fresh
    /// `Tracker::default()` for a self-contained submission), then waits for it.
    pub fn record<F>(&self, pass: &str, tracker: &mut Tracker, record: F) -> Result<(), GpuError>
    where
        F: FnOnce(&mut Recorder) -> Result<(), GpuError>,
    {
        self.submit(pass, |cmd| record(&mut Recorder::new(self, cmd, tracker)))
    }
}

/// Workgroups covering `items` laid out on a grid with workgroups of `local` items per axis.
pub fn grid_groups(items: [u32; 3], local: [u32; 3]) -> [u32; 3] {
    [0, 1, 2].map(|a| items[a].div_ceil(local[a]))
}

/// Workgroups for `groups` groups of 1D work, spread over x and y: `[x, y, 1]` with `x * y >=
/// groups` and `x <= 65535`; the shader rebuilds its item index from `x`.
pub fn spread_groups(groups: u64) -> Result<[u32; 3], GpuError> {
    let x = groups.clamp(1, u64::from(MAX_GROUPS_X));
    let y = groups.div_ceil(x).max(1);
    let y =
        u32::try_from(y).ok().filter(|&y| y <= MAX_GROUPS_X).ok_or_else(|| GpuError::TooLarge {
            what: format!("a pass of {groups} workgroups"),
            limit: format!("one dispatch ({MAX_GROUPS_X} x {MAX_GROUPS_X} workgroups)"),
        })?;
    Ok([x as u32, y, 1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use ash::vk::Handle;

    fn buf(n: u64) -> vk::Buffer {
        vk::Buffer::from_raw(n)
    }
    fn acc(n: u64, stage: Stage, write: bool) -> Access {
        Access { buffer: buf(n), stage, write }
    }

    #[test]
    fn read_after_compute_write_waits_for_it() {
        let mut t = Tracker::default();
        assert!(t.before(&[acc(1, Stage::Compute, true)]).is_empty());
        let b = t.before(&[acc(1, Stage::Compute, false)]);
        assert_eq!(b.src_stages, vk::PipelineStageFlags::COMPUTE_SHADER);
        assert_eq!(b.src_access, vk::AccessFlags::SHADER_WRITE);
        assert_eq!(b.dst_stages, vk::PipelineStageFlags::COMPUTE_SHADER);
        // Already visible to compute: a second reader needs nothing.
        assert!(t.before(&[acc(1, Stage::Compute, false)]).is_empty());
    }

    #[test]
    fn reads_of_unrelated_buffers_need_nothing() {
        let mut t = Tracker::default();
        t.before(&[acc(1, Stage::Compute, true)]);
        assert!(t
            .before(&[acc(2, Stage::Compute, false), acc(3, Stage::Compute, true)])
            .is_empty());
    }

    #[test]
    fn transfer_fill_then_compute_then_readback() {
        let mut t = Tracker::default();
        t.before(&[acc(1, Stage::Transfer, true)]);
        let b = t.before(&[acc(1, Stage::Compute, true)]);
        assert_eq!(b.src_stages, vk::PipelineStageFlags::TRANSFER);
        assert_eq!(b.src_access, vk::AccessFlags::TRANSFER_WRITE);
        let b = t.before(&[acc(1, Stage::Transfer, false), acc(2, Stage::Transfer, true)]);
        assert_eq!(b.src_stages, vk::PipelineStageFlags::COMPUTE_SHADER);
        assert_eq!(b.dst_stages, vk::PipelineStageFlags::TRANSFER);
        let b = t.before(&[acc(2, Stage::Host, false)]);
        assert_eq!(b.src_access, vk::AccessFlags::TRANSFER_WRITE);
        assert_eq!(b.dst_stages, vk::PipelineStageFlags::HOST);
        assert_eq!(b.dst_access & vk::AccessFlags::HOST_READ, vk::AccessFlags::HOST_READ);
    }

    #[test]
    fn write_after_read_waits_for_the_reader() {
        let mut t = Tracker::default();
        t.before(&[acc(1, Stage::Compute, false)]);
        let b = t.before(&[acc(1, Stage::Transfer, true)]);
        assert_eq!(b.src_stages, vk::PipelineStageFlags::COMPUTE_SHADER);
        assert_eq!(b.dst_stages, vk::PipelineStageFlags::TRANSFER);
        assert!(b.src_access.is_empty());
    }

    #[test]
    fn one_barrier_covers_every_buffer_it_orders() {
        let mut t = Tracker::default();
        t.before(&[acc(1, Stage::Compute, true), acc(2, Stage::Compute, true)]);
        assert!(!t.before(&[acc(1, Stage::Compute, false)]).is_empty());
        // The global barrier before the read of 1 also made 2 visible to compute.
        assert!(t.before(&[acc(2, Stage::Compute, false)]).is_empty());
    }

    #[test]
    fn release_makes_everything_visible_once() {
        let mut t = Tracker::default();
        t.before(&[acc(1, Stage::Compute, true), acc(2, Stage::Transfer, true)]);
        let b = t.release();
        assert_eq!(
            b.src_stages,
            vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER
        );
        assert_eq!(b.dst_stages, vk::PipelineStageFlags::ALL_COMMANDS);
        assert!(t.release().is_empty());
        assert!(t.before(&[acc(1, Stage::Transfer, false)]).is_empty());
    }

    #[test]
    fn groups_cover_the_items() {
        assert_eq!(grid_groups([17, 8, 1], [8, 8, 1]), [3, 1, 1]);
        assert_eq!(spread_groups(1).unwrap(), [1, 1, 1]);
        assert_eq!(spread_groups(65535).unwrap(), [65535, 1, 1]);
        assert_eq!(spread_groups(65536).unwrap(), [65535, 2, 1]);
        assert!(spread_groups(65535u64 * 65535 + 1).is_err());
    }
}
