//! Ctrl-C (SIGINT), SIGTERM, SIGHUP and the other signals whose default is to end the process
//! ([`SIGNALS`]): the run ends as it would on the signal, but first removes the temporary files
//! of outputs it had not finished (`output::atomic`), so an interrupted `render` leaves the
//! previous files as they were and no `.NAME.<pid>.<n>.tmp`.
//!
//! The signals are blocked in the main thread before any other thread starts (every thread,
//! llvmpipe's included, inherits the mask) and taken by one thread with `sigwait`: the
//! clean-up runs as ordinary code, not in a signal handler, where removing files and taking
//! a lock are not allowed. Its line goes to file descriptor 2 directly: a verb may hold Rust's
//! stderr lock for its whole run (`compare`), and waiting for it while holding the writer's
//! lock deadlocked. It then restores the default action and raises the signal again, so the
//! exit status is the signal's, as before (a shell reads 130 for Ctrl-C). A signal the parent
//! set to be ignored (`nohup`, `trap '' INT`) is left out: Linux queues a blocked signal even
//! when it is ignored, and `sigwait` would take it.

/// The signals that end a process by default and that a user or a system sends to stop one
/// (SIGPROF is left to profilers, SIGPIPE to the EPIPE handling of `console`).
const SIGNALS: [(libc::c_int, &str); 10] = [
    (libc::SIGINT, "SIGINT"),
    (libc::SIGTERM, "SIGTERM"),
    (libc::SIGHUP, "SIGHUP"),
    (libc::SIGQUIT, "SIGQUIT"),
    (libc::SIGALRM, "SIGALRM"),
    (libc::SIGUSR1, "SIGUSR1"),
    (libc::SIGUSR2, "SIGUSR2"),
    (libc::SIGXCPU, "SIGXCPU"),
    (libc::SIGXFSZ, "SIGXFSZ"),
    (libc::SIGVTALRM, "SIGVTALRM"),
];

/// Whether `sig` is set to be ignored (inherited from the parent: `nohup`, `trap ''`).
fn ignored(sig: libc::c_int) -> bool {
    // SAFETY: a query only (no new action); `old` is written by sigaction.
    unsafe {
        let mut old: libc::sigaction = std::mem::zeroed();
        libc::sigaction(sig, std::ptr::null(), &mut old) == 0 && old.sa_sigaction == libc::SIG_IGN
    }
}

/// Installs the clean-up; call first thing in `main`, before any thread starts. Where the
/// signals cannot be blocked or the thread cannot start, they keep their default action.
pub fn install() {
    // SAFETY: sigset_t is plain data, filled by sigemptyset/sigaddset before use.
    let mut set: libc::sigset_t = unsafe { std::mem::zeroed() };
    // SAFETY: `set` is a valid sigset_t; the masks are this thread's.
    unsafe {
        libc::sigemptyset(&mut set);
        for (s, _) in SIGNALS {
            if !ignored(s) {
                libc::sigaddset(&mut set, s);
            }
        }
        if libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut()) != 0 {
            return;
        }
    }
    let waiter = std::thread::Builder::new().name("isoview-signals".into()).spawn(move || loop {
        let mut sig: libc::c_int = 0;
        // SAFETY: `set` holds the blocked signals; sigwait writes the one taken into `sig`.
        if unsafe { libc::sigwait(&set, &mut sig) } != 0 {
            continue;
        }
        // Held until the process ends: no output is renamed into place after this.
        let _temps = crate::output::atomic::remove_live_temps();
        let name = SIGNALS.iter().find(|(s, _)| *s == sig).map_or("a signal", |(_, n)| n);
        let line = format!(
            "isoview: interrupted by {name}; outputs not yet written were removed, earlier files \
             are as they were\n"
        );
        // SAFETY: writes the line's bytes to fd 2 (a closed or broken stderr is ignored).
        unsafe { libc::write(2, line.as_ptr().cast(), line.len()) };
        // SAFETY: the default action restored and the signal unblocked in this thread, the
        // signal raised on it ends the process as the signal does; _exit if it did not.
        unsafe {
            libc::signal(sig, libc::SIG_DFL);
            libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
            libc::raise(sig);
            libc::_exit(128 + sig);
        }
    });
    if waiter.is_err() {
        // SAFETY: as above; the signals get their default action back.
        unsafe { libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut()) };
    }
}
