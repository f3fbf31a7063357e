//! Ctrl-C (SIGINT), SIGTERM and SIGHUP: the run ends as it would on the signal, but first
//! removes the temporary files of outputs it had not finished (`output::atomic`), so an
//! interrupted `render` leaves the previous files as they were and no `.NAME.<pid>.<n>.tmp`.
//!
//! The signals are blocked in the main thread before any other thread starts (every thread,
//! llvmpipe's included, inherits the mask) and taken by one thread with `sigwait`: the
//! clean-up runs as ordinary code, not in a signal handler, where removing files and taking
//! a lock are not allowed. It then restores the default action and raises the signal again,
//! so the exit status is the signal's, as before (a shell reads 130 for Ctrl-C). A signal the
//! parent set to be ignored (`nohup`) stays ignored: an ignored signal is discarded, blocked
//! or not.

use std::io::Write;

const SIGNALS: [(libc::c_int, &str); 3] =
    [(libc::SIGINT, "SIGINT"), (libc::SIGTERM, "SIGTERM"), (libc::SIGHUP, "SIGHUP")];

/// Installs the clean-up; call first thing in `main`, before any thread starts. Where the
/// signals cannot be blocked or the thread cannot start, they keep their default action.
pub fn install() {
    // SAFETY: sigset_t is plain data, filled by sigemptyset/sigaddset before use.
    let mut set: libc::sigset_t = unsafe { std::mem::zeroed() };
    // SAFETY: `set` is a valid sigset_t; the masks are this thread's.
    unsafe {
        libc::sigemptyset(&mut set);
        for (s, _) in SIGNALS {
            libc::sigaddset(&mut set, s);
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
        let _ = writeln!(
            std::io::stderr(),
            "isoview: interrupted by {name}; outputs not yet written were removed, earlier files \
             are as they were"
        );
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
