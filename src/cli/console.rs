//! Where the command line's words go, and what happens when nobody reads them.
//!
//! `println!` and `eprintln!` panic when a write fails, and a write fails whenever stdout or
//! stderr is a pipe whose reader has gone: Rust ignores SIGPIPE, so the write returns EPIPE
//! (`isoview probe S --pixel 32,32 | head -1`, or `2>&1 | true`). Every verb prints through
//! here instead:
//!
//! - [`say!`] (stdout): a verb's report, what a script reads. When the reader has gone
//!   (EPIPE) the verb stops there, quietly, with exit status 0: the reader took what it wanted
//!   (`head -1` ending a pipeline is a normal end, not a failure; a 141 would fail every
//!   `set -o pipefail` script that pipes isoview into `head`), as ripgrep does. Any other
//!   write error (a full disk behind `>`) is a failure: one line on stderr, exit 2.
//!   `--help` and `--version`, which clap writes, follow the same rule ([`print_clap`]).
//! - [`note!`] (stderr): the one-line `isoview: ...` notes and failures. Write errors are
//!   ignored: what a verb does and its exit status never depend on whether anyone reads its
//!   diagnostics, so a closed stderr never turns a success into a failure.

use std::fmt;
use std::io::Write;

use super::Failure;

/// Writes one line (`args` and a newline) to stdout; see the module docs for a failed write.
pub fn say_line(args: fmt::Arguments) -> Result<(), Failure> {
    let mut stdout = std::io::stdout().lock();
    let written = stdout
        .write_fmt(args)
        .and_then(|()| stdout.write_all(b"\n"))
        // Surface the error on this line rather than at a later one (or never, at exit).
        .and_then(|()| stdout.flush());
    stdout_written(written)
}

/// What a write to stdout that ended with `written` means for the verb: go on, stop quietly
/// (the reader has gone) or fail (see the module docs).
fn stdout_written(written: std::io::Result<()>) -> Result<(), Failure> {
    match written {
        Ok(()) => Ok(()),
        Err(e) => Err(stdout_failure(&e).map_or_else(Failure::stopped, Failure::input)),
    }
}

/// The failure line for a write to stdout that failed with `e`, or `None` when the reader
/// has gone (stop quietly; see the module docs). `compare`, which prints through a writer
/// it is given, uses it too.
pub(super) fn stdout_failure(e: &std::io::Error) -> Option<String> {
    (e.kind() != std::io::ErrorKind::BrokenPipe).then(|| format!("cannot write to stdout: {e}"))
}

/// Prints what clap stopped the command line with and returns the exit status. `--help` and
/// `--version` go to stdout under [`say!`]'s rule (clap's own `exit` ignores every write
/// error, so `isoview --help > /dev/full` exited 0 with nothing written); a usage error goes
/// to stderr, whose write errors are ignored as [`note!`]'s are, with clap's status (2),
/// quoting what the user wrote through [`crate::vocab::echo`] as every message does.
pub fn print_clap(mut e: clap::Error) -> i32 {
    if e.use_stderr() {
        echo_clap_values(&mut e);
        let _ = e.print();
        return e.exit_code();
    }
    // clap writes through stdout's line buffer: flush it, or the failure of the last line
    // would surface only at exit, where it is ignored.
    let written = e.print().and_then(|()| std::io::stdout().lock().flush());
    match stdout_written(written) {
        Ok(()) => e.exit_code(),
        Err(f) => f.report(),
    }
}

/// Writes `isoview: ` and `args` as one line to stderr, ignoring write errors (see the module
/// docs).
pub fn note_line(args: fmt::Arguments) {
    // Every note and failure is one line whatever path or value it prints (an output named
    // with ESC or a newline was printed raw): escaped here once rather than at each caller.
    // Cut in the middle past 16K characters, too: a path is shown whole wherever it is
    // named, and a scene can name a 2 MB one (vocab::message_line).
    let line = args.to_string();
    let line = crate::vocab::message_line(&line);
    let mut stderr = std::io::stderr().lock();
    let _ = writeln!(stderr, "isoview: {line}");
}

/// Replaces the user's words in a clap error (the refused value, the unknown argument or
/// subcommand) with their [`crate::vocab::echo`]: clap quotes them whole, so a 100 kB
/// `--at` value made a 100 kB message and a newline in it split the line. clap formats its
/// message from these when it prints.
fn echo_clap_values(e: &mut clap::Error) {
    use crate::vocab::echo;
    use clap::error::{ContextKind, ContextValue};
    for kind in [ContextKind::InvalidValue, ContextKind::InvalidArg, ContextKind::InvalidSubcommand]
    {
        let echoed = match e.get(kind) {
            Some(ContextValue::String(s)) => ContextValue::String(echo(s)),
            Some(ContextValue::Strings(v)) => {
                ContextValue::Strings(v.iter().map(|s| echo(s)).collect())
            }
            _ => continue,
        };
        e.insert(kind, echoed);
    }
}

/// `say!("...", args)`: one line on stdout, `Result<(), Failure>` (`?` it: a reader that has
/// gone stops the verb with exit 0). `say!()` writes an empty line.
macro_rules! say {
    () => {
        $crate::cli::console::say_line(format_args!(""))
    };
    ($($arg:tt)*) => {
        $crate::cli::console::say_line(format_args!($($arg)*))
    };
}

/// `note!("...", args)`: the line `isoview: ...` on stderr; never fails.
macro_rules! note {
    ($($arg:tt)*) => {
        $crate::cli::console::note_line(format_args!($($arg)*))
    };
}

pub(crate) use {note, say};
