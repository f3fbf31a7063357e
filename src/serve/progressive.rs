//! The render thread, the one thread that uses Vulkan, and the board where it pins its frames.
//!
//! ```text
//!   POST /api/state ──> Mailbox<ViewState> (latest wins) ──┐ Task::Wake
//!   GET /api/slice  ──> Task::Slice ───────────────────────┴──> render thread ──> Board
//!                                                                                 │
//!   GET /api/frame, /aov, /exr, /tev <── parked on the Board for the generation ──┤
//!   GET /api/state, /probe, /slice   <── parked on the Board for the sampled field ┘
//!   (a slice's picture goes back on its channel; the board is poked to wake its parked request)
//! ```
//!
//! The field is sampled here and nowhere else: a state's field is pinned to the board
//! ([`Sampled`]) as soon as it is sampled, before its frame is drawn, for the requests that
//! read it. Sampling can take minutes (an expression within its 4096 bytes can sum 2048
//! terms at every grid point), which on a request's worker held the worker for as long.
//!
//! For each new state: with `preview` (the page is dragging), a coarse frame first: every
//! [`COARSE_STRIDE`]-th pixel of every [`COARSE_STRIDE`]-th row, the same rays as the full
//! image's pixels (s i, s j), in one band; then, once [`REFINE_AFTER`] has passed since the
//! state arrived with nothing newer, the full frame in bands of [`FULL_BAND_ROWS`] rows.
//! Between bands the thread looks at the mailbox: a newer state abandons the frame (counted in
//! [`Stats::abandoned`]), so stale work never delays the latest.

use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use super::mailbox::Mailbox;
use super::state::{field_error_for_page, scene_error_for_page, ViewState};
use crate::field::Grid;
use crate::frame::Frame;
use crate::gpu::Context;
use crate::output;
use crate::render::{GpuGrid, Progressive, RenderError, Renderer};
use crate::slice::{Planned, SliceImage, SliceRenderer};

/// Time without a newer state after which a preview is refined to the full frame.
pub const REFINE_AFTER: Duration = Duration::from_millis(150);
/// Pixel stride of the coarse frame.
pub const COARSE_STRIDE: u32 = 4;
/// Rows per band of the full frame: how often the thread checks for a newer state.
pub const FULL_BAND_ROWS: u32 = 32;
/// Dispatches (bands and slice pictures) after which the thread releases its pipelines
/// ([`Renderer::release_ray_pipelines`], the slice renderer): lavapipe keeps a compiled variant
/// per dispatch until its pipeline goes (about 1 MiB each), so a server that never released
/// them grew by ~1 MiB per band, for good (measured: +4.3 MiB per 128x128 state, now +0.27:
/// the driver still keeps ~70 KiB per dispatch that no release returns). A rebuild costs one
/// pipeline build per shader used next, a fraction of what the variants cost anyway.
pub const RENEW_AFTER_DISPATCHES: u64 = 16;

/// How much of the image a frame holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// Every [`COARSE_STRIDE`]-th pixel.
    Coarse,
    Full,
}

impl Level {
    pub fn name(self) -> &'static str {
        match self {
            Level::Coarse => "coarse",
            Level::Full => "full",
        }
    }

    pub fn parse(s: &str) -> Option<Level> {
        [Level::Coarse, Level::Full].into_iter().find(|l| l.name() == s)
    }
}

/// A frame pinned to the board.
pub struct Rendered {
    pub generation: u64,
    pub level: Level,
    pub state: Arc<ViewState>,
    /// The field sampled for `state` (what probes of this frame trace).
    pub grid: Arc<Grid>,
    pub frame: Frame,
    /// The beauty as PNG (what `render --png` writes, for a full frame).
    pub png: Vec<u8>,
    /// GPU time of the ray passes (None without timestamps).
    pub gpu_ms: Option<f64>,
    /// Wall time of the render, readback included, PNG excluded.
    pub render_ms: f64,
}

/// The field as sampled for a state: pinned when it is sampled, before the state's frame.
pub struct Sampled {
    pub generation: u64,
    pub state: Arc<ViewState>,
    pub grid: Arc<Grid>,
}

/// A state that could not be drawn: the command line's message and exit-status class.
pub struct Failed {
    pub generation: u64,
    pub message: String,
    /// A GPU failure (exit status 3) rather than bad input (2).
    pub gpu: bool,
}

/// Counts since the server started.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Stats {
    pub coarse_frames: u64,
    pub full_frames: u64,
    /// Frames given up between bands because a newer state arrived.
    pub abandoned: u64,
}

/// What the board shows: the latest frame of each level, the latest sampled field, the latest
/// failure, the counts.
#[derive(Default)]
pub struct Published {
    pub coarse: Option<Arc<Rendered>>,
    pub full: Option<Arc<Rendered>>,
    pub sampled: Option<Arc<Sampled>>,
    pub failed: Option<Arc<Failed>>,
    pub stats: Stats,
    /// Counts the updates (and pokes), for [`Board::wait_change`].
    version: u64,
}

/// The render thread's results, for the request threads to wait on.
#[derive(Default)]
pub struct Board {
    inner: Mutex<Published>,
    changed: Condvar,
}

impl Board {
    fn lock(&self) -> MutexGuard<'_, Published> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn update(&self, f: impl FnOnce(&mut Published)) {
        let mut board = self.lock();
        f(&mut board);
        board.version += 1;
        self.changed.notify_all();
    }

    /// Wakes every waiter as an update would, changing nothing (a new waiter arrived).
    pub fn poke(&self) {
        self.update(|_| {});
    }

    /// Runs `f` on the board as it is now.
    pub fn look<T>(&self, f: impl FnOnce(&Published) -> T) -> T {
        f(&self.lock())
    }

    /// Waits up to `timeout` for an update after version `seen`; returns the version then.
    pub fn wait_change(&self, seen: u64, timeout: Duration) -> u64 {
        let deadline = Instant::now() + timeout;
        let mut board = self.lock();
        while board.version == seen {
            let Some(left) = deadline.checked_duration_since(Instant::now()) else { break };
            board = self.changed.wait_timeout(board, left).unwrap_or_else(|e| e.into_inner()).0;
        }
        board.version
    }

    pub fn stats(&self) -> Stats {
        self.lock().stats
    }
}

/// Work for the render thread besides new states.
pub enum Task {
    /// A new state was posted (look at the mailbox).
    Wake,
    /// Draw a slice picture of `state`'s field.
    Slice {
        state: Arc<ViewState>,
        planned: Box<Planned>,
        reply: Sender<Result<SliceImage, String>>,
    },
}

/// The render thread's own resources.
pub struct RenderThread {
    ctx: Arc<Context>,
    renderer: Renderer,
    slicer: Option<SliceRenderer>,
    /// Dispatches since `renderer` and `slicer` were built ([`RENEW_AFTER_DISPATCHES`]).
    dispatches: u64,
    /// The last sampled grid, its key ([`grid_key`]) and its upload.
    grid: Option<(String, Arc<Grid>, GpuGrid)>,
    mailbox: Arc<Mailbox<ViewState>>,
    board: Arc<Board>,
    tasks: Receiver<Task>,
}

/// What decides a sampled grid: the field and, for a time-varying one, the time.
fn grid_key(state: &ViewState) -> String {
    let f = &state.scene.field;
    let time = if f.is_time_varying() { state.time } else { 0.0 };
    format!("{} {:?} t={time:?}", f.describe(), f.placement)
}

/// A render error as the page may see it, and whether it is the GPU's.
fn failure(e: RenderError) -> (String, bool) {
    match e {
        RenderError::Gpu(g) => (g.to_string(), true),
        RenderError::Field2(f) => (format!("[field2]: {}", field_error_for_page(&f)), false),
        other => (other.to_string(), false),
    }
}

impl RenderThread {
    pub fn new(
        ctx: Arc<Context>,
        mailbox: Arc<Mailbox<ViewState>>,
        board: Arc<Board>,
        tasks: Receiver<Task>,
    ) -> Result<Self, RenderError> {
        let renderer = Renderer::new(&ctx)?;
        Ok(RenderThread {
            ctx,
            renderer,
            slicer: None,
            dispatches: 0,
            grid: None,
            mailbox,
            board,
            tasks,
        })
    }

    /// Releases the pipelines once they have run [`RENEW_AFTER_DISPATCHES`] dispatches.
    fn renew_if_worn(&mut self) {
        if self.dispatches >= RENEW_AFTER_DISPATCHES {
            self.slicer = None;
            self.renderer.release_ray_pipelines();
            self.dispatches = 0;
        }
    }

    /// Runs until every task sender is gone.
    pub fn run(mut self) {
        let mut done = 0;
        loop {
            if let Some((generation, state)) = self.mailbox.latest() {
                if generation > done {
                    self.draw(generation, &state);
                    done = generation;
                    continue;
                }
            }
            match self.tasks.recv() {
                Ok(task) => self.handle(task),
                Err(_) => return,
            }
        }
    }

    fn handle(&mut self, task: Task) {
        match task {
            Task::Wake => {}
            Task::Slice { state, planned, reply } => {
                let picture = self.slice(&state, &planned);
                // The requester may have given up waiting; nothing to do then.
                let _ = reply.send(picture);
                // The request is parked: the poke makes the parker look at its channel.
                self.board.poke();
            }
        }
    }

    /// Samples and uploads `state`'s field into `self.grid` unless the grid there has the same
    /// key; returns the sampled grid.
    fn grid_for(&mut self, state: &ViewState) -> Result<Arc<Grid>, (String, bool)> {
        let key = grid_key(state);
        match &self.grid {
            Some((k, grid, _)) if *k == key => Ok(grid.clone()),
            _ => {
                self.grid = None;
                let grid = Arc::new(
                    state
                        .scene
                        .field
                        .sample(state.time)
                        .map_err(|e| (field_error_for_page(&e), false))?,
                );
                let gpu = GpuGrid::upload(&self.ctx, &grid).map_err(|e| (e.to_string(), true))?;
                self.grid = Some((key, grid.clone(), gpu));
                Ok(grid)
            }
        }
    }

    /// Pins `grid` as generation `generation`'s field, unless it is pinned already (the full
    /// frame after a coarse one).
    fn pin_sampled(&self, generation: u64, state: &Arc<ViewState>, grid: &Arc<Grid>) {
        if self.board.look(|b| b.sampled.as_ref().is_some_and(|s| s.generation == generation)) {
            return;
        }
        let sampled = Arc::new(Sampled { generation, state: state.clone(), grid: grid.clone() });
        self.board.update(|b| b.sampled = Some(sampled));
    }

    fn slice(&mut self, state: &ViewState, planned: &Planned) -> Result<SliceImage, String> {
        self.renew_if_worn();
        self.dispatches += 1;
        if self.slicer.is_none() {
            self.slicer = Some(SliceRenderer::new(&self.ctx).map_err(|e| e.to_string())?);
        }
        self.grid_for(state).map_err(|(m, _)| m)?;
        let (Some(slicer), Some((_, _, gpu))) = (&mut self.slicer, &self.grid) else {
            return Err("the slice renderer or the grid is missing".into());
        };
        slicer
            .render(gpu, &planned.plane, &planned.set.contours, &planned.style)
            .map_err(|e| e.to_string())
    }

    /// Draws generation `generation` (coarse first with `preview`), pinning what it finishes.
    fn draw(&mut self, generation: u64, state: &Arc<ViewState>) {
        let result = self.picked(state).and_then(|state| self.draw_levels(generation, &state));
        match result {
            Ok(()) => {}
            Err(Some((message, gpu))) => self.board.update(|b| {
                b.failed = Some(Arc::new(Failed { generation, message, gpu }));
            }),
            Err(None) => self.board.update(|b| b.stats.abandoned += 1),
        }
    }

    /// `state` with its isovalue picked from its field when the page's load left it to pick
    /// ([`ViewState::unpicked`]), the field sampled for it here.
    fn picked(&mut self, state: &Arc<ViewState>) -> Result<Arc<ViewState>, Option<(String, bool)>> {
        if state.unpicked.is_none() {
            return Ok(state.clone());
        }
        let grid = self.grid_for(state).map_err(Some)?;
        let picked = state.picked(&grid).map_err(|e| Some((scene_error_for_page(&e), false)))?;
        Ok(Arc::new(picked))
    }

    /// `Err(None)`: abandoned for a newer state.
    fn draw_levels(
        &mut self,
        generation: u64,
        state: &Arc<ViewState>,
    ) -> Result<(), Option<(String, bool)>> {
        if state.preview {
            self.draw_level(generation, state, Level::Coarse)?;
            // Refine once the state has stood for REFINE_AFTER; serve slices meanwhile.
            loop {
                if self.mailbox.generation() != generation {
                    return Err(None);
                }
                let Some(left) =
                    (state.posted + REFINE_AFTER).checked_duration_since(Instant::now())
                else {
                    break;
                };
                match self.tasks.recv_timeout(left) {
                    Ok(task) => self.handle(task),
                    Err(RecvTimeoutError::Timeout) => break,
                    Err(RecvTimeoutError::Disconnected) => return Err(None),
                }
            }
        }
        self.draw_level(generation, state, Level::Full)
    }

    fn draw_level(
        &mut self,
        generation: u64,
        state: &Arc<ViewState>,
        level: Level,
    ) -> Result<(), Option<(String, bool)>> {
        let started = Instant::now();
        self.renew_if_worn();
        let grid = self.grid_for(state).map_err(Some)?;
        self.pin_sampled(generation, state, &grid);
        let mailbox = self.mailbox.clone();
        let mut bands = 0;
        let mut still_latest = |_: crate::passes::Band, _: &[crate::frame::Pixel]| {
            bands += 1;
            mailbox.generation() == generation
        };
        let how = match level {
            Level::Coarse => Progressive {
                stride: COARSE_STRIDE,
                band_rows: u32::MAX,
                after_band: &mut still_latest,
            },
            Level::Full => {
                Progressive { stride: 1, band_rows: FULL_BAND_ROWS, after_band: &mut still_latest }
            }
        };
        // The upload lives in self.grid; borrow it again next to the renderer.
        let Some((_, _, gpu)) = self.grid.as_ref() else {
            return Err(Some(("no grid".into(), false)));
        };
        let drawn = self.renderer.render_progressive(&state.scene, &grid, gpu, state.time, how);
        self.dispatches += bands;
        let frame = match drawn {
            Ok(f) => f,
            Err(RenderError::Cancelled) => return Err(None),
            Err(e) => return Err(Some(failure(e))),
        };
        let render_ms = started.elapsed().as_secs_f64() * 1e3;
        let gpu_ms = self.renderer.last_gpu_ms;
        let png = output::png::encode_preview(std::path::Path::new("frame.png"), &frame)
            .map_err(|e| Some((e.to_string(), false)))?;
        let rendered = Arc::new(Rendered {
            generation,
            level,
            state: state.clone(),
            grid,
            frame,
            png,
            gpu_ms,
            render_ms,
        });
        self.board.update(|b| match level {
            Level::Coarse => {
                b.coarse = Some(rendered);
                b.stats.coarse_frames += 1;
            }
            Level::Full => {
                b.full = Some(rendered);
                b.stats.full_frames += 1;
            }
        });
        Ok(())
    }
}
