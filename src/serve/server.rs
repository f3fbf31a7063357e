//! The connections: one acceptor thread, a fixed pool of [`WORKERS`] threads that read, route
//! and answer requests, and one thread that watches the parked requests.
//!
//! ```text
//!   accept ── over MAX_CONNECTIONS open: 503, closed ──> (nothing queued)
//!     │
//!     ▼ Job::Serve                      Job::Answer (a parked request and what it found)
//!   queue ─────────> WORKERS threads <──────────────────────── parker thread
//!     ▲                │ read the head for one HEAD_TURN              ▲
//!     └── not yet ─────┤ (bounded; deadline from accept), route       │
//!                      │ waits for a frame or slice not there yet:    │
//!                      │ park ────────────────────────────────────────┘ (MAX_PARKED; over
//!                      ▼                                               it: 503 at once)
//!                    reply, close
//! ```
//!
//! A connection whose head has not all arrived after a turn goes to the back of the queue,
//! so connections that send nothing (or a byte at a time) hold a worker one turn each and
//! never for their whole timeout: a request beside 60 of them is answered at once. A parked
//! request (a long-poll, or an EXR, channels, tev send or slice picture waiting for its frame
//! or picture) holds no thread: the parker waits on the board (or the earliest deadline, or
//! its next look for clients that hung up) and hands each request whose wait is over back to
//! the queue, where a worker makes its reply and sends it, so neither an EXR's encoding nor a
//! slow client's socket stalls the others. Every open connection (queued, being served or
//! parked) holds one of the [`MAX_CONNECTIONS`] slots, so memory and threads stay bounded
//! whatever clients do.

use std::io::{ErrorKind, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use super::api::{App, Found, Outcome, Wait};
use super::http::{self, HeadProgress, HeadReader, Reply};
use super::progressive::Board;

/// Threads that read and answer requests.
pub const WORKERS: usize = 8;
/// Connections open at once (queued, being answered or parked); more are answered 503.
pub const MAX_CONNECTIONS: usize = 64;
/// Requests parked at once (long-polls and requests waiting for a frame or a slice); more are
/// answered 503 with `Retry-After: 1`.
pub const MAX_PARKED: usize = 32;
/// How often the parker looks for parked clients that closed their connection (a tab
/// closed or reloaded), to free their places before their timeout.
pub const HANGUP_CHECK: Duration = Duration::from_secs(1);

/// An accepted connection, its request head as read so far, and its slot among
/// [`MAX_CONNECTIONS`] (freed when dropped).
pub struct Conn {
    pub stream: TcpStream,
    head: HeadReader,
    _slot: Place,
}

/// One of a bounded number of places (an open connection, a state being loaded), freed when
/// dropped.
pub struct Place(Arc<AtomicUsize>);

impl Place {
    /// A place among `max`, counted in `taken`; None when all are taken.
    pub fn take(taken: &Arc<AtomicUsize>, max: usize) -> Option<Place> {
        let more = |n: usize| (n < max).then_some(n + 1);
        taken.fetch_update(Ordering::AcqRel, Ordering::Acquire, more).ok()?;
        Some(Place(taken.clone()))
    }
}

impl Drop for Place {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::AcqRel);
    }
}

enum Job {
    /// Read a request from the connection and answer it.
    Serve(Conn),
    /// Make a parked request's reply from what it found (none: its deadline passed) and send
    /// it.
    Answer(Parked, Option<Found>),
}

/// A request waiting for the board.
struct Parked {
    conn: Conn,
    wait: Wait,
    deadline: Instant,
    /// Body bytes announced and not read (drained after the reply, as for any request).
    unread: u64,
}

/// The parked requests.
#[derive(Default)]
struct Parking {
    parked: Mutex<Vec<Parked>>,
}

impl Parking {
    fn lock(&self) -> MutexGuard<'_, Vec<Parked>> {
        // Every change is one push, one swap_remove or a retain: a panic leaves a consistent
        // list.
        self.parked.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// Serves `listener` with `app` until the process ends.
pub fn run(listener: TcpListener, app: Arc<App>) -> std::io::Result<()> {
    // Each connection is queued at most once at a time, so the queue never fills.
    let (jobs, queue) = sync_channel::<Job>(MAX_CONNECTIONS);
    let queue = Arc::new(Mutex::new(queue));
    let parking = Arc::new(Parking::default());
    for i in 0..WORKERS {
        let (queue, jobs, app, parking) =
            (queue.clone(), jobs.clone(), app.clone(), parking.clone());
        std::thread::Builder::new()
            .name(format!("isoview-http-{i}"))
            .spawn(move || work(&queue, &jobs, &app, &parking))?;
    }
    {
        let (board, parking, jobs) = (app.board.clone(), parking.clone(), jobs.clone());
        std::thread::Builder::new()
            .name("isoview-longpoll".into())
            .spawn(move || answer_parked(&board, &parking, &jobs))?;
    }
    let open = Arc::new(AtomicUsize::new(0));
    for stream in listener.incoming() {
        let Ok(mut stream) = stream else {
            // Out of file descriptors or a connection reset before accept: try again shortly.
            std::thread::sleep(Duration::from_millis(10));
            continue;
        };
        let Some(slot) = Place::take(&open, MAX_CONNECTIONS) else {
            // The answer fits in the socket's buffer: this write does not wait for the client.
            let _ = stream.set_write_timeout(Some(Duration::from_millis(100)));
            let busy =
                Reply::error(503, format!("over {MAX_CONNECTIONS} open connections; try again"))
                    .header("Retry-After", 1);
            let _ = stream.write_all(&busy.encode());
            continue;
        };
        // The head's deadline counts from here, not from when a worker takes the connection.
        let conn = Conn { stream, head: HeadReader::new(Instant::now()), _slot: slot };
        // Cannot fail while the workers live (see the queue's size); if it does, the
        // connection is dropped, which the client sees as a closed connection.
        let _ = jobs.try_send(Job::Serve(conn));
    }
    Ok(())
}

fn work(queue: &Mutex<Receiver<Job>>, jobs: &SyncSender<Job>, app: &App, parking: &Parking) {
    loop {
        let job = match queue.lock().unwrap_or_else(|e| e.into_inner()).recv() {
            Ok(job) => job,
            Err(_) => return,
        };
        match job {
            Job::Answer(p, found) => {
                let (wait, unread) = (p.wait, p.unread);
                let outcome = survive(
                    || match found {
                        Some(found) => app.answer(wait, found),
                        None => Outcome::Reply(wait.timed_out()),
                    },
                    Outcome::Reply,
                );
                finish(app, parking, p.conn, outcome, unread);
            }
            Job::Serve(mut conn) => match conn.head.read(&mut conn.stream, http::HEAD_TURN) {
                Ok(HeadProgress::Done(head)) => {
                    let mut body = http::Body::new(&mut conn.stream, &head);
                    let outcome = survive(|| app.route(&head, &mut body), Outcome::Reply);
                    let unread = body.unread();
                    finish(app, parking, conn, outcome, unread);
                }
                // To the back of the queue: the connections behind it get their turn. Cannot
                // fail (see `run`); if it did, the connection would close unanswered.
                Ok(HeadProgress::Pending) => {
                    let _ = jobs.try_send(Job::Serve(conn));
                }
                Ok(HeadProgress::Closed) => {}
                Err(reply) => reply.send(conn.stream, 0),
            },
        }
    }
}

/// Sends the reply, or parks the request (a slice picture waits for its field, then for the
/// render thread to draw it: two waits).
fn finish(app: &App, parking: &Parking, conn: Conn, outcome: Outcome, unread: u64) {
    match outcome {
        Outcome::Reply(reply) => reply.send(conn.stream, unread),
        Outcome::Park(wait) => park(app, parking, conn, wait, unread),
    }
}

/// What `answer` makes of a request, or, when it panics (a bug: bad input is refused with
/// 400 before it gets that far), `reply` of a 500 that says only that. Without this a
/// panic ended its worker for good, and after [`WORKERS`] such requests the server answered
/// nothing (issue 29). The panic's own message goes to the server's stderr (the default
/// hook), never to the client: it may quote what a file holds. The locks the handlers take
/// recover from poisoning (`unwrap_or_else(|e| e.into_inner())`), so later requests go on.
fn survive<T>(answer: impl FnOnce() -> T, reply: impl FnOnce(Reply) -> T) -> T {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(answer)).unwrap_or_else(|_| {
        reply(Reply::error(
            500,
            "isoview: an internal error stopped this request (a bug in isoview; the server goes on)",
        ))
    })
}

/// Parks a request, or answers 503 when [`MAX_PARKED`] are parked already.
fn park(app: &App, parking: &Parking, conn: Conn, wait: Wait, unread: u64) {
    let deadline = Instant::now() + wait.timeout();
    {
        let mut parked = parking.lock();
        if parked.len() >= MAX_PARKED {
            drop(parked);
            Reply::error(503, format!("over {MAX_PARKED} requests waiting for frames; ask again"))
                .header("Retry-After", 1)
                .send(conn.stream, unread);
            return;
        }
        parked.push(Parked { conn, wait, deadline, unread });
    }
    // The frame (or slice) may have come between the route's look and now: wake the parker
    // so that it looks again.
    app.board.poke();
}

/// The parker: hands each parked request to a worker once the board has what it waits for,
/// or its deadline passed; every [`HANGUP_CHECK`], drops those whose client has gone. It only
/// looks (what a wait finds is a few `Arc`s or a slice already drawn): the replies are made
/// on the workers ([`Found`]).
fn answer_parked(board: &Board, parking: &Parking, jobs: &SyncSender<Job>) {
    let mut seen = 0;
    let mut checked = Instant::now();
    loop {
        let timeout = {
            let mut parked = parking.lock();
            let now = Instant::now();
            if now >= checked + HANGUP_CHECK {
                // Dropping a request closes its connection and frees its slot and place.
                parked.retain(|p| !hung_up(&p.conn.stream));
                checked = now;
            }
            let mut ready = Vec::new();
            board.look(|b| {
                let mut i = 0;
                while i < parked.len() {
                    let p = &parked[i];
                    match p.wait.pick(b) {
                        Some(found) => ready.push((parked.swap_remove(i), Some(found))),
                        None if p.deadline <= now => ready.push((parked.swap_remove(i), None)),
                        None => i += 1,
                    }
                }
            });
            for (p, found) in ready {
                // Cannot fail (see `run`); if it did, the connection would close unanswered.
                let _ = jobs.try_send(Job::Answer(p, found));
            }
            let earliest = parked.iter().map(|p| p.deadline).min();
            let next_check = (!parked.is_empty()).then_some(checked + HANGUP_CHECK);
            let wake = earliest.into_iter().chain(next_check).min();
            wake.map_or(Duration::from_secs(3600), |d| d.saturating_duration_since(now))
        };
        seen = board.wait_change(seen, timeout);
    }
}

/// Whether a parked request's client has closed its connection (or it broke): a look at the
/// socket that does not wait finds its end. A client that sent more bytes is still there.
fn hung_up(stream: &TcpStream) -> bool {
    if stream.set_nonblocking(true).is_err() {
        return false;
    }
    let mut byte = [0u8; 1];
    let gone = match stream.peek(&mut byte) {
        Ok(n) => n == 0,
        Err(e) => !matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::Interrupted),
    };
    // The reply is written blocking (with its timeout).
    let _ = stream.set_nonblocking(false);
    gone
}
