//! `isoview serve`: a local web page over a live render (docs/serve.md).
//!
//! ```text
//!   server (acceptor, WORKERS threads, parked long-polls) ── http (bounded requests)
//!        │   ── access (Host, token) ── api (routes)
//!        │ POST /api/state: load + validate like --set, data files confined ──> mailbox
//!        │ GET /api/frame, /aov, /exr, /tev, slice PNGs: parked until the board has them
//!        │ GET /api/state, /probe, /slice: parked until the board has the sampled field
//!        ▼
//!   render thread (progressive): owns the Renderer, the slice renderer and the uploaded grid;
//!   samples each state's field (the only thread that does) and pins it to the board;
//!   coarse frame while the page drags, full frame after a pause, stale frames abandoned
//!   between bands; pins frames and failures to the board.
//! ```
//!
//! The server writes no files; the page (`page/`, embedded) is plain HTML, CSS and JavaScript.

pub mod access;
pub mod api;
pub mod http;
pub mod mailbox;
pub mod progressive;
pub mod server;
pub mod state;

use std::io::Write;
use std::net::{IpAddr, TcpListener};
use std::path::PathBuf;
use std::sync::{mpsc, Arc, Mutex};

use crate::gpu::Context;
use api::App;
use mailbox::Mailbox;
use progressive::{Board, RenderThread};
use state::{Policy, ViewState};

/// What `isoview serve` was asked for.
pub struct Options {
    pub scene: PathBuf,
    pub sets: Vec<String>,
    pub time: f64,
    pub bind: IpAddr,
    /// 0: any free port.
    pub port: u16,
    /// Folders besides the scene's whose files the page may name (`--allow-dir`).
    pub allow_dirs: Vec<PathBuf>,
    /// Largest image (width x height) a state may ask for (`--max-pixels`).
    pub max_pixels: u64,
}

/// Why the server could not start: bad input (exit 2) or the GPU (exit 3).
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    #[error("{0}")]
    Input(String),
    #[error("{0}")]
    Gpu(String),
}

/// The URL the server prints: `http://HOST:PORT/?token=TOKEN`.
pub fn url(bind: IpAddr, port: u16, token: &str) -> String {
    match bind {
        IpAddr::V4(a) => format!("http://{a}:{port}/?token={token}"),
        IpAddr::V6(a) => format!("http://[{a}]:{port}/?token={token}"),
    }
}

/// The command line's state and what the page's states may ask for: every input mistake
/// `serve` can find before it touches the GPU.
pub fn prepare(options: &Options) -> Result<(ViewState, Policy), ServeError> {
    let own = Policy::command_line(options.max_pixels);
    let first = ViewState::load(&options.scene, options.sets.clone(), options.time, false, &own)
        .map_err(|e| ServeError::Input(e.to_string()))?;
    let policy =
        Policy::page(&options.scene, &options.allow_dirs, &first.scene, options.max_pixels)
            .map_err(ServeError::Input)?;
    Ok((first, policy))
}

/// Loads the scene, starts the render thread on `ctx`, listens, writes the URL as the first
/// line of `out` (flushed), then serves until the process ends.
pub fn run(options: &Options, ctx: Arc<Context>, out: &mut dyn Write) -> Result<(), ServeError> {
    let (first, mut policy) = prepare(options)?;
    // Checked here for the command line's state (the device is open now) and on every post.
    let max = ctx.info.max_image_dimension_3d;
    first.scene.field.check_image_extent(max).map_err(|e| ServeError::Input(e.to_string()))?;
    policy.max_image_extent = Some(max);
    let token = access::new_token().map_err(ServeError::Input)?;
    let device = ctx.info.name.clone();

    let mailbox = Arc::new(Mailbox::default());
    let board = Arc::new(Board::default());
    let (tasks, inbox) = mpsc::channel();
    mailbox.post(first);
    // The render thread builds its pipelines first and says whether that worked.
    let (ready_tx, ready) = mpsc::channel();
    {
        let (mailbox, board) = (mailbox.clone(), board.clone());
        std::thread::Builder::new()
            .name("isoview-render".into())
            .spawn(move || match RenderThread::new(ctx, mailbox, board, inbox) {
                Ok(thread) => {
                    let _ = ready_tx.send(Ok(()));
                    thread.run();
                }
                Err(e) => {
                    let _ = ready_tx.send(Err(e.to_string()));
                }
            })
            .map_err(|e| ServeError::Gpu(format!("cannot start the render thread: {e}")))?;
    }
    ready
        .recv()
        .map_err(|_| ServeError::Gpu("the render thread stopped while starting".into()))?
        .map_err(ServeError::Gpu)?;

    let listener = TcpListener::bind((options.bind, options.port)).map_err(|e| {
        ServeError::Input(format!(
            "--bind {} --port {}: cannot listen: {e}",
            options.bind, options.port
        ))
    })?;
    let port = listener.local_addr().map(|a| a.port()).unwrap_or(options.port);
    let app = Arc::new(App {
        scene_path: options.scene.clone(),
        token: token.clone(),
        device: device.clone(),
        policy,
        mailbox,
        board,
        tasks: Mutex::new(tasks),
        loading: Default::default(),
    });
    writeln!(out, "{}", url(options.bind, port, &token))
        .and_then(|_| out.flush())
        .map_err(|e| ServeError::Input(format!("cannot write the URL: {e}")))?;
    // A closed stderr must not stop the server (eprintln! would panic): the line is a note.
    let _ = writeln!(
        std::io::stderr(),
        "isoview: serving {} on {} (open the URL above; Ctrl-C stops)",
        options.scene.display(),
        device
    );

    server::run(listener, app)
        .map_err(|e| ServeError::Input(format!("cannot start the request threads: {e}")))
}
