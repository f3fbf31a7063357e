//! Runs a read in a child process, so that no file can crash, hang or exhaust the caller.
//!
//! OpenVDB trusts its input: a flipped byte in a metadata length made it allocate 17 GB in a
//! minute (found by fuzzing a sphere written by pyopenvdb), and a C++ library can fault on
//! what it does not check. [`isolated`] forks, runs the closure in the child under limits of
//! address space and CPU time, and hands back the bytes it wrote to a pipe. A child that dies
//! (signal, limit) or runs past the wall-clock limit is an [`Error`] naming what happened;
//! the caller's process is never touched.
//!
//! The child runs only the closure and leaves with `_exit`: no destructor, no atexit handler,
//! no stdio buffer of the parent runs twice. The parent never initializes OpenVDB (or TBB)
//! itself, so the child starts with no lock held by a thread it did not inherit; glibc's
//! malloc is safe after fork.

use std::io::Read;
use std::os::fd::FromRawFd;
use std::time::{Duration, Instant};

use crate::Error;

/// The limits of one isolated read.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// Address space of the child (RLIMIT_AS), bytes.
    pub address_space: u64,
    /// CPU seconds of the child (RLIMIT_CPU).
    pub cpu_seconds: u64,
    /// Wall-clock time the parent waits for the child's reply.
    pub wall: Duration,
    /// The most bytes the reply may hold.
    pub max_reply: u64,
}

/// The bytes a child's `work` returned (behind the reply's tag byte, kept: no copy).
pub struct Reply(Vec<u8>);

impl Reply {
    pub fn bytes(&self) -> &[u8] {
        &self.0[1..]
    }

    /// The reply's buffer, to keep without a copy: [`Reply::bytes`] from byte 1 on.
    pub fn into_buffer(self) -> Vec<u8> {
        self.0
    }
}

/// Runs `work` in a forked child under `limits`; its `Ok` bytes or `Err` message come back.
pub fn isolated<F>(limits: Limits, work: F) -> Result<Reply, Error>
where
    F: FnOnce() -> Result<Vec<u8>, String>,
{
    let mut fds = [0i32; 2];
    // SAFETY: fds has room for the two descriptors.
    if unsafe { libc::pipe2(fds.as_mut_ptr(), libc::O_CLOEXEC) } != 0 {
        return Err(Error(format!("pipe: {}", std::io::Error::last_os_error())));
    }
    let (rd, wr) = (fds[0], fds[1]);
    // SAFETY: fork; the child runs only `child` below and leaves with _exit.
    let pid = unsafe { libc::fork() };
    if pid < 0 {
        let e = std::io::Error::last_os_error();
        // SAFETY: both descriptors are ours.
        unsafe {
            libc::close(rd);
            libc::close(wr);
        }
        return Err(Error(format!("fork: {e}")));
    }
    if pid == 0 {
        // SAFETY: the read end is the parent's.
        unsafe { libc::close(rd) };
        child(wr, limits, work);
    }
    // SAFETY: the write end is the child's.
    unsafe { libc::close(wr) };
    let got = receive(rd, pid, limits);
    let status = reap(pid, got.is_err());
    match (got, status) {
        (Ok(reply), Ok(())) => decode(reply),
        (Ok(_), Err(e)) | (Err(e), _) => Err(e),
    }
}

/// The reply on the pipe: a tag byte (0 ok, 1 error) and the bytes or the message.
fn child<F>(wr: i32, limits: Limits, work: F) -> !
where
    F: FnOnce() -> Result<Vec<u8>, String>,
{
    // The hard limit a little above the soft one: at the soft CPU limit the child gets
    // SIGXCPU (said as such), at the hard one SIGKILL.
    let set = |what, n: u64| {
        let r = libc::rlimit { rlim_cur: n, rlim_max: n.saturating_add(5) };
        // SAFETY: a plain rlimit struct.
        unsafe { libc::setrlimit(what, &r) };
    };
    set(libc::RLIMIT_AS, limits.address_space);
    set(libc::RLIMIT_CPU, limits.cpu_seconds);
    set(libc::RLIMIT_CORE, 0);
    // The caller may block SIGINT/SIGTERM/SIGHUP for its own clean-up thread (isoview's
    // `cli::interrupt`), which the child does not have: it takes them as a process does, and
    // dies with its parent rather than read on for a caller that is gone.
    // SAFETY: an empty signal set; prctl with a signal number.
    unsafe {
        let mut none: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut none);
        libc::pthread_sigmask(libc::SIG_SETMASK, &none, std::ptr::null_mut());
        libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL);
    }
    // The child says nothing on the caller's terminal (an allocation failure's message, a
    // library's warnings): what it has to say comes back through the pipe, as one line.
    // SAFETY: a NUL-terminated path; dup2 onto the standard descriptors.
    unsafe {
        let null = libc::open(c"/dev/null".as_ptr(), libc::O_WRONLY);
        if null >= 0 {
            libc::dup2(null, 1);
            libc::dup2(null, 2);
            libc::close(null);
        }
    }
    let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(work));
    let (tag, body) = match out {
        Ok(Ok(bytes)) => (0u8, bytes),
        Ok(Err(m)) => (1u8, m.into_bytes()),
        Err(_) => (1u8, b"the reader panicked".to_vec()),
    };
    let mut all = Vec::with_capacity(body.len() + 1);
    all.push(tag);
    all.extend_from_slice(&body);
    let mut rest: &[u8] = &all;
    while !rest.is_empty() {
        // SAFETY: rest is a valid buffer; wr is the pipe's write end.
        let n = unsafe { libc::write(wr, rest.as_ptr().cast(), rest.len()) };
        if n < 0 {
            if std::io::Error::last_os_error().kind() == std::io::ErrorKind::Interrupted {
                continue;
            }
            // SAFETY: leaving the child without running anything of the parent's.
            unsafe { libc::_exit(3) };
        }
        rest = &rest[n as usize..];
    }
    // SAFETY: as above.
    unsafe { libc::_exit(0) }
}

/// Reads the child's reply until it closes the pipe, within the wall-clock and size limits.
fn receive(rd: i32, pid: i32, limits: Limits) -> Result<Vec<u8>, Error> {
    // SAFETY: rd is the pipe's read end, owned from here on.
    let mut file = unsafe { std::fs::File::from_raw_fd(rd) };
    let start = Instant::now();
    let mut reply = Vec::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let left = limits.wall.saturating_sub(start.elapsed());
        if left.is_zero() {
            // SAFETY: pid is our child, not yet reaped.
            unsafe { libc::kill(pid, libc::SIGKILL) };
            return Err(Error(format!(
                "the reader ran past its limit of {} s and was stopped",
                limits.wall.as_secs()
            )));
        }
        let mut p = libc::pollfd { fd: rd, events: libc::POLLIN, revents: 0 };
        let ms = left.as_millis().min(1000) as i32;
        // SAFETY: one pollfd.
        let r = unsafe { libc::poll(&mut p, 1, ms) };
        if r < 0 {
            let e = std::io::Error::last_os_error();
            if e.kind() == std::io::ErrorKind::Interrupted {
                continue;
            }
            return Err(Error(format!("poll: {e}")));
        }
        if r == 0 {
            continue;
        }
        match file.read(&mut buf) {
            Ok(0) => return Ok(reply),
            Ok(n) => {
                if reply.len() as u64 + n as u64 > limits.max_reply + 1 {
                    // SAFETY: as above.
                    unsafe { libc::kill(pid, libc::SIGKILL) };
                    return Err(Error(format!(
                        "the reader's reply is over {} bytes",
                        limits.max_reply
                    )));
                }
                reply.extend_from_slice(&buf[..n]);
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(Error(format!("reading the reader's reply: {e}"))),
        }
    }
}

/// Waits for the child; a signal or a non-zero exit is an error (unless one was already seen).
fn reap(pid: i32, killed: bool) -> Result<(), Error> {
    let mut status = 0;
    loop {
        // SAFETY: pid is our child.
        let r = unsafe { libc::waitpid(pid, &mut status, 0) };
        if r == pid {
            break;
        }
        if r < 0 && std::io::Error::last_os_error().kind() != std::io::ErrorKind::Interrupted {
            return Err(Error(format!("waitpid: {}", std::io::Error::last_os_error())));
        }
    }
    if killed {
        return Ok(());
    }
    if libc::WIFSIGNALED(status) {
        let sig = libc::WTERMSIG(status);
        let why = match sig {
            libc::SIGXCPU => "it ran past its CPU-time limit".to_string(),
            libc::SIGKILL => {
                "it was killed (out of memory, or past its CPU-time limit)".to_string()
            }
            libc::SIGBUS => "it read past the end of a mapped file (SIGBUS)".to_string(),
            libc::SIGSEGV => "it crashed (SIGSEGV)".to_string(),
            libc::SIGABRT => "it aborted (SIGABRT)".to_string(),
            s => format!("signal {s}"),
        };
        return Err(Error(format!("the reader stopped: {why}")));
    }
    match libc::WEXITSTATUS(status) {
        0 => Ok(()),
        c => Err(Error(format!("the reader stopped with exit status {c}"))),
    }
}

fn decode(reply: Vec<u8>) -> Result<Reply, Error> {
    match reply.first() {
        Some(0) => Ok(Reply(reply)),
        Some(1) => Err(Error(String::from_utf8_lossy(&reply[1..]).into_owned())),
        _ => Err(Error("the reader stopped without a reply".into())),
    }
}
