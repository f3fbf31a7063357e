//! `isoview serve`: a local web page over a live render (README "isoview serve").
//!
//! ```text
//!   request threads (tiny_http) ── access (token, Host) ── api (routes)
//!        │ POST /api/state: load + validate like --set ──> mailbox (latest state wins)
//!        │ GET /api/frame, /aov, /exr, /tev: wait on the board
//!        ▼
//!   render thread (progressive): owns the Renderer, the slice renderer and the uploaded grid;
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
pub mod state;

use std::io::Write;
use std::net::IpAddr;
use std::path::PathBuf;
use std::sync::{mpsc, Arc, Mutex};

use crate::gpu::Context;
use api::App;
use mailbox::Mailbox;
use progressive::{Board, RenderThread};
use state::ViewState;

/// Request threads (each long-poll holds one while it waits).
pub const REQUEST_THREADS: usize = 8;

/// What `isoview serve` was asked for.
pub struct Options {
    pub scene: PathBuf,
    pub sets: Vec<String>,
    pub time: f64,
    pub bind: IpAddr,
    /// 0: any free port.
    pub port: u16,
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

/// Loads the scene, starts the render thread on `ctx`, listens, writes the URL as the first
/// line of `out` (flushed), then serves until the process ends.
pub fn run(options: &Options, ctx: Arc<Context>, out: &mut dyn Write) -> Result<(), ServeError> {
    let first = ViewState::load(&options.scene, options.sets.clone(), options.time, false)
        .map_err(ServeError::Input)?;
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

    let server = tiny_http::Server::http((options.bind, options.port)).map_err(|e| {
        ServeError::Input(format!(
            "--bind {} --port {}: cannot listen: {e}",
            options.bind, options.port
        ))
    })?;
    let port = server.server_addr().to_ip().map(|a| a.port()).unwrap_or(options.port);
    let app = Arc::new(App {
        scene_path: options.scene.clone(),
        token: token.clone(),
        device: device.clone(),
        mailbox,
        board,
        tasks: Mutex::new(tasks),
    });
    writeln!(out, "{}", url(options.bind, port, &token))
        .and_then(|_| out.flush())
        .map_err(|e| ServeError::Input(format!("cannot write the URL: {e}")))?;
    eprintln!(
        "isoview: serving {} on {} (open the URL above; Ctrl-C stops)",
        options.scene.display(),
        device
    );

    let server = Arc::new(server);
    let workers: Vec<_> = (0..REQUEST_THREADS)
        .map(|i| {
            let (server, app) = (server.clone(), app.clone());
            std::thread::Builder::new().name(format!("isoview-http-{i}")).spawn(move || {
                while let Ok(request) = server.recv() {
                    app.handle(request);
                }
            })
        })
        .collect::<Result<_, _>>()
        .map_err(|e| ServeError::Input(format!("cannot start the request threads: {e}")))?;
    for w in workers {
        let _ = w.join();
    }
    Ok(())
}
