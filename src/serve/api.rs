//! The routes: the page and its assets, and the JSON/binary API (docs/serve.md).
//! Every route but the assets needs the token; every route needs an allowed `Host`.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicUsize;
use std::sync::mpsc::{Receiver, Sender, TryRecvError};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use serde_json::{json, Value};

use super::access;
use super::http::{Body, Head, Reply, Target, Wire};
use super::mailbox::Mailbox;
use super::progressive::{Board, Failed, Level, Published, Rendered, Sampled, Task};
use super::server::Place;
use super::state::{self, Policy, ViewState};
use crate::field::interpolant::Reader;
use crate::frame::Channel;
use crate::output;
use crate::probe::{self, PixelProbe};
use crate::slice::{self, export, Axis, SliceImage};

const INDEX_HTML: &str = include_str!("page/index.html");
const APP_JS: &str = include_str!("page/app.js");
const STYLE_CSS: &str = include_str!("page/style.css");

/// Every path [`App::route`] answers: another method on one of them is 405, any other path 404.
const ROUTES: &[&str] = &[
    "/",
    "/index.html",
    "/app.js",
    "/style.css",
    "/api/state",
    "/api/frame",
    "/api/aov",
    "/api/probe",
    "/api/slice",
    "/api/exr",
    "/api/tev",
    "/api/scene.toml",
    "/api/stats",
];

/// How long a request waits for a frame, a slice or the sampled field before answering 503.
pub const WAIT: Duration = Duration::from_secs(120);
/// How long a long-poll (`/api/frame?after=`) waits before answering 204 No Content.
pub const LONG_POLL: Duration = Duration::from_secs(25);
/// States loaded at once (`POST /api/state`); a post beside them is answered 503 with
/// `Retry-After: 1`. Loading reads a volume file whole (the scene holds its samples), on the
/// request's worker: 16 posts of a 400^3 volume held every worker for 5 s and took a grid's
/// memory on each, 2.4 GB; at the grid cap that would be 8 GiB.
pub const MAX_LOADING: usize = 1;

/// Everything the request threads share.
pub struct App {
    pub scene_path: PathBuf,
    pub token: String,
    pub device: String,
    /// What the page's states may ask for.
    pub policy: Policy,
    pub mailbox: Arc<Mailbox<ViewState>>,
    pub board: Arc<Board>,
    pub tasks: Mutex<Sender<Task>>,
    /// States being loaded ([`MAX_LOADING`]).
    pub loading: Arc<AtomicUsize>,
}

/// What becomes of a request: a reply now, or a wait on the board that holds no thread
/// (`server` parks it).
pub enum Outcome {
    Reply(Reply),
    Park(Wait),
}

/// What a parked request waits for. Every request that waits for a frame, a slice or the
/// field parks: a wait of seconds (a slow frame, a costly expression) holds a connection slot
/// and a parking place, never one of the workers, so eight downloads of a frame being drawn,
/// or a dozen probes of a field being sampled, do not stop the page's other requests.
pub enum Wait {
    /// `/api/frame?after=G&level=L`: anything newer than (G, L); 204 after [`LONG_POLL`].
    Newer(u64, Level),
    /// `/api/frame`: the full frame (or failure) of generation G or later; 503 after [`WAIT`].
    Full(u64),
    /// The full frame (or failure) of generation G or later, made into `Then`'s answer;
    /// 503 after [`WAIT`].
    Use(u64, Then),
    /// A slice picture from the render thread (which pokes the board when it sends one);
    /// 503 after [`WAIT`].
    Slice(Receiver<Result<SliceImage, String>>),
    /// The field of generation G or later as the render thread sampled it (or a later
    /// failure), for `Need`; 503 after [`WAIT`]. The field is never sampled on a worker.
    Field(u64, Need),
}

/// What is made of the sampled field.
#[derive(Clone)]
pub enum Need {
    /// `GET /api/state`
    State,
    /// `GET /api/probe?x=&y=`: the query's words as given.
    Probe { x: String, y: String },
    /// `GET /api/slice`, its query checked: `at_arg` is the `at=` word as the messages show it.
    Slice { axis: Axis, at: f64, at_arg: String, format: SliceFormat },
}

/// `/api/slice?format=`.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum SliceFormat {
    Png,
    Json,
    Svg,
    Cells,
}

impl SliceFormat {
    fn parse(s: &str) -> Option<SliceFormat> {
        let all = [
            ("png", SliceFormat::Png),
            ("json", SliceFormat::Json),
            ("svg", SliceFormat::Svg),
            ("cells", SliceFormat::Cells),
        ];
        all.into_iter().find(|(name, _)| *name == s).map(|(_, f)| f)
    }
}

/// What is made of a full frame once it is drawn.
pub enum Then {
    /// `GET /api/exr`
    Exr,
    /// `GET /api/aov`: these channels, each once.
    Aov(Vec<Channel>),
    /// `POST /api/tev`: sent to this address.
    Tev(String),
}

/// What a wait found: taken from the board (a few `Arc`s) or the slice's channel, cheap to
/// take under the board's lock. The reply is made of it by [`App::answer`] on a worker, not on
/// the parker: encoding an EXR or a PNG, copying the channels or sending the frame to tev (a
/// network write that can take seconds) on the parker would delay every other parked
/// request's answer and deadline behind it.
pub enum Found {
    Frame(Arc<Rendered>),
    Failed(Arc<Failed>),
    Slice(Result<SliceImage, String>),
    /// The sampled field and what the request makes of it.
    Field(Arc<Sampled>, Need),
}

impl Wait {
    pub fn timeout(&self) -> Duration {
        match self {
            Wait::Newer(..) => LONG_POLL,
            Wait::Full(_) | Wait::Use(..) | Wait::Slice(_) | Wait::Field(..) => WAIT,
        }
    }

    /// What the request waits for, once the board (or the render thread) has it.
    pub fn pick(&self, b: &Published) -> Option<Found> {
        let found = match self {
            Wait::Newer(after, have) => newer(b, (*after, *have)),
            Wait::Full(target) | Wait::Use(target, _) => full_of(b, *target),
            Wait::Slice(answer) => {
                return match answer.try_recv() {
                    Ok(picture) => Some(Found::Slice(picture)),
                    Err(TryRecvError::Empty) => None,
                    Err(TryRecvError::Disconnected) => {
                        Some(Found::Slice(Err("the render thread is gone".into())))
                    }
                }
            }
            Wait::Field(target, need) => {
                return sampled_of(b, *target).map(|f| match f {
                    Ok(s) => Found::Field(s, need.clone()),
                    Err(f) => Found::Failed(f),
                })
            }
        };
        found.map(|f| match f {
            Ok(r) => Found::Frame(r),
            Err(f) => Found::Failed(f),
        })
    }

    /// The reply when the wait is over without one.
    pub fn timed_out(&self) -> Reply {
        match self {
            Wait::Newer(..) => Reply::bytes("text/plain", Vec::new()).with_status(204),
            Wait::Full(_) | Wait::Use(..) => {
                Reply::error(503, "the frame is not ready yet; ask again")
            }
            Wait::Slice(_) => Reply::error(503, "the slice is not ready yet; ask again"),
            Wait::Field(..) => Reply::error(503, "the field is not sampled yet; ask again"),
        }
    }
}

impl App {
    fn scene_name(&self) -> String {
        self.scene_path.display().to_string()
    }

    /// Answers one request whose head was read; the body is read only past the Host and
    /// token checks, by the routes that take one.
    pub fn route<W: Wire>(&self, head: &Head, body: &mut Body<'_, W>) -> Outcome {
        let host = head.header("Host").unwrap_or_default();
        if !access::host_allowed(host) {
            // The header is the client's: shown escaped and cut short.
            let shown: String = host.escape_default().take(100).collect();
            return Outcome::Reply(Reply::error(
                403,
                format!("Host \"{shown}\" is not this machine (localhost or an IP address)"),
            ));
        }
        let target = Target::parse(&head.url);
        let method = head.method.to_ascii_uppercase();
        match (method.as_str(), target.path.as_str()) {
            ("GET", "/app.js") => {
                return Outcome::Reply(Reply::text("text/javascript; charset=utf-8", APP_JS))
            }
            ("GET", "/style.css") => {
                return Outcome::Reply(Reply::text("text/css; charset=utf-8", STYLE_CSS))
            }
            _ => {}
        }
        // One token: with two, a check of one would let the other pass unseen (the query's
        // last one was checked, so `?token=bad&token=GOOD` was let in), and two that agree
        // are no request the page sends.
        let headers =
            head.headers.iter().filter(|(k, _)| k.eq_ignore_ascii_case("X-Isoview-Token"));
        if target.count("token") + headers.count() > 1 {
            return Outcome::Reply(Reply::error(
                403,
                "token: given more than once; send it once (?token= or X-Isoview-Token)",
            ));
        }
        let given = target.get("token").or_else(|| head.header("X-Isoview-Token")).unwrap_or("");
        if !access::token_matches(&self.token, given) {
            return Outcome::Reply(Reply::error(
                403,
                "wrong or missing token: open the URL that `isoview serve` printed (it ends in ?token=...)",
            ));
        }
        let result = match (method.as_str(), target.path.as_str()) {
            ("GET", "/") | ("GET", "/index.html") => {
                Ok(Reply::text("text/html; charset=utf-8", INDEX_HTML))
            }
            // The routes that read the field: it is sampled on the render thread.
            ("GET", "/api/state") => return self.wait_for(Wait::Field(self.latest(), Need::State)),
            ("POST", "/api/state") => body.read().and_then(|b| self.post_state(&b)),
            // The routes that may wait for a frame or a slice.
            ("GET", "/api/frame") => return self.frame(&target).unwrap_or_else(Outcome::Reply),
            ("GET", "/api/aov") => return self.aov(&target).unwrap_or_else(Outcome::Reply),
            ("GET", "/api/slice") => return self.slice(&target).unwrap_or_else(Outcome::Reply),
            ("GET", "/api/exr") => return self.wait_for(Wait::Use(self.latest(), Then::Exr)),
            ("POST", "/api/tev") => {
                return body.read().and_then(|b| self.tev(&b)).unwrap_or_else(Outcome::Reply)
            }
            ("GET", "/api/probe") => {
                let (x, y) = (target.get("x").unwrap_or(""), target.get("y").unwrap_or(""));
                let need = Need::Probe { x: x.to_string(), y: y.to_string() };
                return self.wait_for(Wait::Field(self.latest(), need));
            }
            ("GET", "/api/scene.toml") => self.scene_toml(),
            ("GET", "/api/stats") => Ok(Reply::json(&json!(self.board.stats()))),
            (_, path) if ROUTES.contains(&path) => {
                Err(Reply::error(405, format!("{} {path}: not supported", shorten(&method))))
            }
            (_, path) => Err(Reply::error(404, format!("{}: no such page", shorten(path)))),
        };
        Outcome::Reply(result.unwrap_or_else(|e| e))
    }

    /// The generation of the latest state: what a request for "the frame" waits for.
    fn latest(&self) -> u64 {
        self.mailbox.generation()
    }

    /// Answers `wait` now when the board has what it waits for, else parks it.
    fn wait_for(&self, wait: Wait) -> Outcome {
        match self.board.look(|b| wait.pick(b)) {
            Some(found) => self.answer(wait, found),
            None => Outcome::Park(wait),
        }
    }

    /// The reply to a request that waited for `found`, made on a worker (see [`Found`]); or a
    /// new wait: a slice picture, once the field it is planned on is there, waits for the
    /// render thread to draw it.
    pub fn answer(&self, wait: Wait, found: Found) -> Outcome {
        let reply = match (wait, found) {
            (_, Found::Field(sampled, need)) => {
                return self.use_field(&sampled, need).unwrap_or_else(Outcome::Reply)
            }
            (_, Found::Failed(f)) => failed_reply(&f),
            (_, Found::Slice(Err(e))) => Reply::error(500, format!("isoview: {e}")),
            (_, Found::Slice(Ok(picture))) => export::encode_png(Path::new("slice.png"), &picture)
                .map(|png| Reply::bytes("image/png", png))
                .unwrap_or_else(|e| Reply::error(500, e)),
            (Wait::Use(_, Then::Exr), Found::Frame(r)) => exr_reply(&r),
            (Wait::Use(_, Then::Aov(channels)), Found::Frame(r)) => aov_reply(&r, &channels),
            (Wait::Use(_, Then::Tev(address)), Found::Frame(r)) => self.tev_reply(&r, &address),
            // `/api/frame` (a slice's wait finds a picture, never a frame).
            (_, Found::Frame(r)) => frame_reply(&r),
        };
        Outcome::Reply(reply)
    }

    /// What a request that needs the field makes of it.
    fn use_field(&self, sampled: &Sampled, need: Need) -> Result<Outcome, Reply> {
        match need {
            Need::State => Ok(Outcome::Reply(self.get_state(sampled))),
            Need::Probe { x, y } => self.probe(sampled, &x, &y).map(Outcome::Reply),
            Need::Slice { axis, at, at_arg, format } => {
                self.slice_of(sampled, axis, at, &at_arg, format)
            }
        }
    }

    fn get_state(&self, s: &Sampled) -> Reply {
        let (name, device) = (self.scene_name(), &self.device);
        let mut v = state::describe(s.generation, &s.state, &name, &s.grid, device);
        v["command"] = json!(state::command_line(&self.scene_path, &s.state));
        Reply::json(&v)
    }

    fn post_state(&self, body: &[u8]) -> Result<Reply, Reply> {
        let Some(_loading) = Place::take(&self.loading, MAX_LOADING) else {
            let busy =
                format!("another state is being loaded ({MAX_LOADING} at a time); ask again");
            return Err(Reply::error(503, busy).header("Retry-After", 1));
        };
        let state = ViewState::from_request(&self.scene_path, body, &self.policy)
            .map_err(|e| Reply::error(400, format!("isoview: {}", e.for_page())))?;
        let generation = self.mailbox.post(state);
        // A send cannot leave the sender half-changed: a poisoned lock is still usable.
        let _ = self.tasks.lock().unwrap_or_else(|e| e.into_inner()).send(Task::Wake);
        Ok(Reply::json(&json!({ "generation": generation })))
    }

    /// `GET /api/frame`: the full frame of the latest state; with `after=G` (and `level=`
    /// what the client has of G, default full), whatever is newer than that, or 204. Answered
    /// at once when the board has it, else parked ([`Wait`]).
    fn frame(&self, target: &Target) -> Result<Outcome, Reply> {
        let wait = match target.get("after") {
            None => Wait::Full(self.latest()),
            Some(after) => {
                let after: u64 = after.parse().map_err(|_| {
                    Reply::error(400, format!("after={}: not a generation number", shorten(after)))
                })?;
                let have = match target.get("level") {
                    None => Level::Full,
                    Some(l) => Level::parse(l).ok_or_else(|| {
                        Reply::error(400, format!("level={}: expected coarse or full", shorten(l)))
                    })?,
                };
                Wait::Newer(after, have)
            }
        };
        Ok(self.wait_for(wait))
    }

    /// `GET /api/aov?ch=Z[,N.X,...]`: the channels of the full frame as little-endian f32
    /// planes, one after the other, row 0 at the top. Each channel is sent once (a name
    /// repeated is dropped), and more names than there are channels are refused before any
    /// work: each plane is the image's size.
    fn aov(&self, target: &Target) -> Result<Outcome, Reply> {
        let names: Vec<&str> = target.get("ch").unwrap_or("Z").split(',').collect();
        if names.len() > Channel::ALL.len() {
            return Err(Reply::error(
                400,
                format!(
                    "ch: {} channel names; at most {}, each channel once",
                    names.len(),
                    Channel::ALL.len()
                ),
            ));
        }
        let mut channels = Vec::with_capacity(names.len());
        for n in names {
            let c = Channel::from_name(n.trim()).ok_or_else(|| {
                let all: Vec<&str> = Channel::ALL.iter().map(|c| c.name()).collect();
                Reply::error(
                    400,
                    format!("ch={}: no such channel (one of {})", shorten(n), all.join(", ")),
                )
            })?;
            if !channels.contains(&c) {
                channels.push(c);
            }
        }
        Ok(self.wait_for(Wait::Use(self.latest(), Then::Aov(channels))))
    }

    /// `GET /api/probe?x=&y=`: `probe --json --pixel X,Y` of the latest state.
    fn probe(&self, sampled: &Sampled, x: &str, y: &str) -> Result<Reply, Reply> {
        let (state, grid) = (&sampled.state, &sampled.grid);
        if let Some(why) = state.scene.interpolation_refusal(Reader::Probe) {
            return Err(Reply::error(400, format!("isoview: {why}")));
        }
        let image = &state.scene.image;
        let (px, py) = probe::parse_pixel(&format!("{x},{y}"), image.width, image.height)
            .map_err(|e| Reply::error(400, format!("isoview: {e}")))?;
        let report =
            PixelProbe::new(&state.scene, grid, px, py).json(&state.scene, &self.scene_name());
        let text = serde_json::to_string_pretty(&report).map_err(|e| Reply::error(500, e))?;
        Ok(Reply::text("application/json", text + "\n"))
    }

    /// `GET /api/slice?axis=&at=&format=png|json|svg|cells`: the query checked, then a wait
    /// for the latest state's field ([`App::slice_of`]).
    fn slice(&self, target: &Target) -> Result<Outcome, Reply> {
        let axis_arg = target.get("axis").unwrap_or("");
        let axis = Axis::parse(axis_arg).ok_or_else(|| {
            Reply::error(400, format!("isoview: --axis {}: expected x, y or z", shorten(axis_arg)))
        })?;
        let at_arg = shorten(target.get("at").unwrap_or(""));
        let at: f64 = target
            .get("at")
            .unwrap_or("")
            .parse()
            .ok()
            .filter(|a: &f64| a.is_finite())
            .ok_or_else(|| {
            Reply::error(400, format!("isoview: --at {at_arg}: must be a finite number"))
        })?;
        let format_arg = target.get("format").unwrap_or("png");
        let format = SliceFormat::parse(format_arg).ok_or_else(|| {
            Reply::error(
                400,
                format!("format={}: expected png, json, svg or cells", shorten(format_arg)),
            )
        })?;
        let need = Need::Slice { axis, at, at_arg, format };
        Ok(self.wait_for(Wait::Field(self.latest(), need)))
    }

    /// What `isoview slice` writes (`--png`, `--json`, `--svg`) for the sampled state;
    /// `cells`: the plane's grid values. The PNG is drawn by the render thread: a new wait.
    fn slice_of(
        &self,
        sampled: &Sampled,
        axis: Axis,
        at: f64,
        at_arg: &str,
        format: SliceFormat,
    ) -> Result<Outcome, Reply> {
        let (state, grid) = (&sampled.state, &sampled.grid);
        let scene = &state.scene;
        let planned = slice::plan(scene, grid, axis, at, state.time).map_err(|e| {
            Reply::error(400, format!("isoview: {}", e.located(&format!("--at {at_arg}"))))
        })?;
        let (plane, iso) = (&planned.plane, scene.surface.isovalue);
        let reply = match format {
            SliceFormat::Json => Ok(Reply::text(
                "application/json",
                export::json(plane, &scene.field.placement, iso, &planned.set.contours),
            )),
            SliceFormat::Svg => {
                let title = slice::svg_title(plane, &self.scene_name(), iso);
                let (w, h) = (planned.style.width, planned.style.height);
                Ok(Reply::text(
                    "image/svg+xml",
                    export::svg(plane, &planned.set.contours, w, h, &title),
                ))
            }
            SliceFormat::Cells => {
                let names = ["x", "y", "z"];
                Ok(Reply::json(&json!({
                    "axis": axis.name(), "at": at, "isovalue": iso,
                    "plane_axes": [names[plane.axes.0], names[plane.axes.1]],
                    "dims": plane.dims, "min": [plane.min.x, plane.min.y], "max": [plane.max.x, plane.max.y],
                    "layer": plane.layer, "weight": plane.weight,
                    "values": plane.values,
                    "picture": [planned.style.width, planned.style.height],
                })))
            }
            SliceFormat::Png => {
                // The picture is drawn in memory: its size counts against the same cap as the
                // image's.
                slice::check_picture(scene, &planned.style, self.policy.max_pixels, "serve")
                    .map_err(|e| Reply::error(400, format!("isoview: {e}")))?;
                let (reply, answer) = std::sync::mpsc::channel();
                let task = Task::Slice { state: state.clone(), planned: Box::new(planned), reply };
                self.tasks
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .send(task)
                    .map_err(|_| Reply::error(500, "the render thread is gone"))?;
                return Ok(self.wait_for(Wait::Slice(answer)));
            }
        };
        reply.map(Outcome::Reply)
    }

    /// `POST /api/tev` (body optional: `{"address": "HOST:PORT"}`): sends the full frame to tev.
    fn tev(&self, body: &[u8]) -> Result<Outcome, Reply> {
        let address = if body.iter().all(u8::is_ascii_whitespace) {
            output::tev::DEFAULT_ADDRESS.to_string()
        } else {
            let v: Value = serde_json::from_slice(body)
                .map_err(|e| Reply::error(400, format!("the request body is not JSON: {e}")))?;
            match v.get("address") {
                None => output::tev::DEFAULT_ADDRESS.to_string(),
                Some(Value::String(a)) => a.clone(),
                Some(_) => {
                    return Err(Reply::error(400, "\"address\" must be a \"HOST:PORT\" string"))
                }
            }
        };
        Ok(self.wait_for(Wait::Use(self.latest(), Then::Tev(address))))
    }

    /// The full frame sent to tev at `address`.
    fn tev_reply(&self, r: &Rendered, address: &str) -> Reply {
        let name = format!("isoview serve {} #{}", self.scene_name(), r.generation);
        match output::tev::send_frame(address, &name, &r.frame) {
            Ok(()) => Reply::json(
                &json!({ "generation": r.generation, "image": name, "address": address }),
            ),
            Err(e) => Reply::error(502, format!("isoview: {e}")),
        }
    }

    /// `GET /api/scene.toml`: the scene file with the state's overrides written in.
    fn scene_toml(&self) -> Result<Reply, Reply> {
        let (_, state) = self.mailbox.latest().ok_or_else(|| Reply::error(503, "no state yet"))?;
        let text = state::scene_toml(&self.scene_path, &state.sets, state.time)
            .map_err(|e| Reply::error(500, format!("isoview: {e}")))?;
        Ok(Reply::text("application/toml; charset=utf-8", text)
            .header("Content-Disposition", "attachment; filename=\"scene.toml\""))
    }
}

/// The full frame of generation `target` or later, or a later failure.
fn full_of(b: &Published, target: u64) -> Option<Result<Arc<Rendered>, Arc<Failed>>> {
    or_failure(b.full.as_ref().map(|r| (r.generation, r)), b, target)
}

/// The field sampled for generation `target` or later, or a later failure.
fn sampled_of(b: &Published, target: u64) -> Option<Result<Arc<Sampled>, Arc<Failed>>> {
    or_failure(b.sampled.as_ref().map(|s| (s.generation, s)), b, target)
}

/// `item` (with its generation) when it is of generation `target` or later, or the board's
/// failure when that is later still (or there is no such item). A failure of the item's own
/// generation came after it (the state's field was sampled and its frame failed): the item.
fn or_failure<T>(
    item: Option<(u64, &Arc<T>)>,
    b: &Published,
    target: u64,
) -> Option<Result<Arc<T>, Arc<Failed>>> {
    let failed = b.failed.as_ref().filter(|f| f.generation >= target);
    match (item.filter(|(g, _)| *g >= target), failed) {
        (Some((g, _)), Some(f)) if f.generation > g => Some(Err(f.clone())),
        (Some((_, r)), _) => Some(Ok(r.clone())),
        (None, Some(f)) => Some(Err(f.clone())),
        (None, None) => None,
    }
}

/// Text from a request, for a message: escaped, cut at 100 characters.
fn shorten(s: &str) -> String {
    let escaped: String = s.escape_default().collect();
    match escaped.char_indices().nth(100) {
        Some((end, _)) => format!("{}...", &escaped[..end]),
        None => escaped,
    }
}

/// The newest of the board's frames and failure that is newer than `have` (generation, level).
fn newer(b: &Published, have: (u64, Level)) -> Option<Result<Arc<Rendered>, Arc<Failed>>> {
    let frames = [&b.coarse, &b.full]
        .into_iter()
        .flatten()
        .map(|r| ((r.generation, r.level), Ok(r.clone())));
    let failed = b.failed.iter().map(|f| ((f.generation, Level::Full), Err(f.clone())));
    frames.chain(failed).filter(|(key, _)| *key > have).max_by_key(|(key, _)| *key).map(|(_, v)| v)
}

fn failed_reply(f: &Failed) -> Reply {
    Reply::error(if f.gpu { 500 } else { 400 }, format!("isoview: {}", f.message))
        .header("X-Isoview-Generation", f.generation)
}

/// `GET /api/exr`: the full frame as the EXR `render -o` writes.
fn exr_reply(r: &Rendered) -> Reply {
    match output::exr::encode_frame(Path::new("frame.exr"), &r.frame) {
        Ok(bytes) => Reply::bytes("image/x-exr", bytes)
            .header("X-Isoview-Generation", r.generation)
            .header("Content-Disposition", "attachment; filename=\"isoview.exr\""),
        Err(e) => Reply::error(500, e),
    }
}

/// `GET /api/aov`: `channels` of the frame as little-endian f32 planes.
fn aov_reply(r: &Rendered, channels: &[Channel]) -> Reply {
    let mut body = Vec::with_capacity(channels.len() * r.frame.pixels.len() * 4);
    for c in channels {
        for p in &r.frame.pixels {
            body.extend_from_slice(&c.get(p).to_le_bytes());
        }
    }
    Reply::bytes("application/octet-stream", body)
        .header("X-Isoview-Generation", r.generation)
        .header("X-Isoview-Width", r.frame.width)
        .header("X-Isoview-Height", r.frame.height)
        .header(
            "X-Isoview-Channels",
            channels.iter().map(|c| c.name()).collect::<Vec<_>>().join(","),
        )
}

fn frame_reply(r: &Rendered) -> Reply {
    let image = &r.state.scene.image;
    let mut reply = Reply::bytes("image/png", r.png.clone())
        .header("X-Isoview-Generation", r.generation)
        .header("X-Isoview-Level", r.level.name())
        .header("X-Isoview-Image", format!("{}x{}", image.width, image.height))
        .header("X-Isoview-Render-Ms", format!("{:.3}", r.render_ms));
    if let Some(ms) = r.gpu_ms {
        reply = reply.header("X-Isoview-Gpu-Ms", format!("{ms:.3}"));
    }
    reply
}
