//! Whole-or-nothing file writes.
//!
//! ```text
//!   dir/.out.exr.<pid>.<n>.tmp   <- create_new, write, flush, fsync (a hash for a long NAME)
//!            |  rename (atomic on one filesystem)
//!            v
//!   dir/out.exr                  <- readers see the old file or the new one, never a mix
//! ```
//!
//! The temporary file sits in the destination's folder so that the rename never crosses a
//! filesystem. On any error (or a panic in the caller's writer) the temporary file is removed
//! and whatever was at the destination before is left untouched. After the rename the folder
//! is fsynced (best effort) so that the new name survives a crash.
//!
//! A destination that is a symbolic link is replaced by a regular file (the link's target is
//! not written); permissions of a replaced file are not carried over.
//!
//! Every temporary file not yet renamed or removed is listed ([`remove_live_temps`]): an
//! interrupted run (Ctrl-C, SIGTERM, SIGHUP: `cli::interrupt`) removes them before it ends,
//! so it leaves no `.NAME.<pid>.<n>.tmp` behind (the EXR's is created before the render
//! starts, and could hold most of the image).

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard};

use super::OutputError;

/// Distinguishes temporary files of concurrent writers in one process.
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// The temporary files that exist now: created, not yet renamed into place or removed.
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// [`LIVE`], also after a panic elsewhere held it (the list itself is always whole).
fn live() -> MutexGuard<'static, Vec<PathBuf>> {
    LIVE.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Drops `temp` from [`LIVE`] (its last entry first: the newest is usually the one done).
fn forget(list: &mut Vec<PathBuf>, temp: &Path) {
    if let Some(at) = list.iter().rposition(|t| t == temp) {
        list.swap_remove(at);
    }
}

/// Removes every temporary file of this process that is not yet renamed into place, and
/// keeps the list locked, so that no writer renames or creates one after it: for a process
/// about to end on a signal (the guard is held until it has).
pub fn remove_live_temps() -> MutexGuard<'static, Vec<PathBuf>> {
    let mut list = live();
    for temp in list.drain(..) {
        let _ = std::fs::remove_file(temp);
    }
    list
}

/// Writes `path` atomically: `write` fills a buffered temporary file in the same folder,
/// which is then flushed, fsynced and renamed over `path`.
///
/// If `write` (or any step after it) fails, the temporary file is removed, `path` is left as
/// it was, and the error names `path`. A writer that needs to fail with an error of its own
/// can wrap it with [`std::io::Error::other`]; its message is kept.
pub fn write_with<F>(path: &Path, write: F) -> Result<(), OutputError>
where
    F: FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
{
    let temp = TempFile::create(path)?;
    let mut out = BufWriter::new(temp.file().try_clone().map_err(|e| temp.error("write", e))?);
    write(&mut out).map_err(|e| temp.error("write", e))?;
    out.flush().map_err(|e| temp.error("write", e))?;
    drop(out);
    temp.commit()
}

/// A temporary file next to its destination, for writers that fill it piece by piece (the
/// streaming EXR and PNG writers): [`TempFile::commit`] fsyncs it and renames it over the
/// destination; dropping it uncommitted (an error, a panic) removes it and leaves the
/// destination as it was.
pub struct TempFile {
    path: PathBuf,
    file: File,
    guard: TempGuard,
}

impl TempFile {
    /// Creates a fresh temporary file in `path`'s folder.
    pub fn create(path: &Path) -> Result<Self, OutputError> {
        let (file, temp) = create_temp(path)?;
        Ok(TempFile { path: path.to_path_buf(), file, guard: TempGuard(Some(temp)) })
    }

    /// The open temporary file (write through a clone, `try_clone`, or a `&File`).
    pub fn file(&self) -> &File {
        &self.file
    }

    /// The destination.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// An I/O error while writing this file, naming the destination.
    pub fn error(&self, action: &'static str, e: std::io::Error) -> OutputError {
        OutputError::io(&self.path, action, e)
    }

    /// Syncs the temporary file and renames it over the destination. The caller has flushed
    /// every buffer it wrote through.
    pub fn commit(mut self) -> Result<(), OutputError> {
        let path = &self.path;
        self.file.sync_all().map_err(|e| OutputError::io(path, "sync", e))?;
        let temp =
            self.guard.0.clone().ok_or_else(|| OutputError::invalid(path, "committed twice"))?;
        {
            // Renamed and unlisted under the lock: an interrupt removes it before or not at all.
            let mut list = live();
            std::fs::rename(&temp, path)
                .map_err(|e| OutputError::io(path, "rename into place", e))?;
            forget(&mut list, &temp);
        }
        self.guard.0 = None;
        sync_parent(path);
        Ok(())
    }
}

/// A scratch file next to `path` (a temporary file's name, on the destination's filesystem,
/// not in a memory-backed temp folder), as a writer and a reader from its start, already
/// unlinked: it takes no name and vanishes when both are closed, whatever ends the process.
/// For writers that gather pieces before the destination's header can be written.
pub fn scratch(path: &Path) -> Result<(File, File), OutputError> {
    let (write, temp) = create_temp(path)?;
    let read = File::open(&temp);
    // Unix: the open handles keep the data until they close.
    {
        let mut list = live();
        let _ = std::fs::remove_file(&temp);
        forget(&mut list, &temp);
    }
    Ok((write, read.map_err(|e| OutputError::io(path, "create", e))?))
}

/// Writes `bytes` to `path` atomically (see [`write_with`]).
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    write_with(path, |w| w.write_all(bytes))
}

/// The folder `path` is in (`.` for a bare file name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Creates a fresh temporary file next to `path`.
fn create_temp(path: &Path) -> Result<(File, PathBuf), OutputError> {
    let name = path.file_name().ok_or_else(|| OutputError::invalid(path, "not a file name"))?;
    let dir = parent_dir(path);
    let pid = std::process::id();
    loop {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let temp = dir.join(temp_name(name, pid, n));
        // Created and listed under the lock: an interrupt sees every file made before it.
        let mut list = live();
        match OpenOptions::new().write(true).create_new(true).open(&temp) {
            Ok(file) => {
                list.push(temp.clone());
                return Ok((file, temp));
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(OutputError::io(path, "create", e)),
        }
    }
}

/// The longest file name most filesystems take (NAME_MAX on Linux, macOS and Windows).
const MAX_NAME_BYTES: usize = 255;

/// The temporary file's name for destination file name `name`: `.NAME.<pid>.<n>.tmp`, or,
/// when that would be longer than [`MAX_NAME_BYTES`] (a legal name of 244 bytes or more),
/// `.isoview.<hash of NAME>.<pid>.<n>.tmp`, so that every legal output name can be written.
fn temp_name(name: &std::ffi::OsStr, pid: u32, n: u64) -> std::ffi::OsString {
    let tail = format!(".{pid}.{n}.tmp");
    let mut temp = std::ffi::OsString::from(".");
    if 1 + name.len() + tail.len() <= MAX_NAME_BYTES {
        temp.push(name);
    } else {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        name.hash(&mut h);
        temp.push(format!("isoview.{:016x}", h.finish()));
    }
    temp.push(tail);
    temp
}

/// Removes the temporary file unless it was renamed into place.
struct TempGuard(Option<PathBuf>);

impl Drop for TempGuard {
    fn drop(&mut self) {
        if let Some(temp) = self.0.take() {
            let mut list = live();
            // Best effort: the original error is what the caller needs to see.
            let _ = std::fs::remove_file(&temp);
            forget(&mut list, &temp);
        }
    }
}

/// Makes the rename durable by fsyncing the folder (a no-op where folders cannot be opened).
fn sync_parent(path: &Path) {
    #[cfg(unix)]
    if let Ok(dir) = File::open(parent_dir(path)) {
        let _ = dir.sync_all();
    }
    #[cfg(not(unix))]
    let _ = path;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("isoview-atomic-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn writes_and_replaces() {
        let dir = scratch("replace");
        let p = dir.join("a.txt");
        write_bytes(&p, b"one").unwrap();
        write_bytes(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert_eq!(entries(&dir), vec!["a.txt"]);
    }

    #[test]
    fn failed_write_keeps_previous_file_and_leaves_no_temp() {
        let dir = scratch("fail");
        let p = dir.join("a.txt");
        write_bytes(&p, b"previous").unwrap();
        let err = write_with(&p, |w| {
            w.write_all(&[7u8; 100_000])?;
            Err(std::io::Error::other("encoder gave up"))
        })
        .unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("a.txt") && msg.contains("encoder gave up"), "{msg}");
        assert_eq!(std::fs::read(&p).unwrap(), b"previous");
        assert_eq!(entries(&dir), vec!["a.txt"]);
    }

    #[test]
    fn panicking_writer_leaves_no_temp() {
        let dir = scratch("panic");
        let p = dir.join("a.txt");
        let r = std::panic::catch_unwind(|| {
            let _ = write_with(&p, |_| panic!("boom"));
        });
        assert!(r.is_err());
        assert!(entries(&dir).is_empty());
    }

    #[test]
    fn missing_folder_is_an_error_naming_the_file() {
        let dir = scratch("missing");
        let p = dir.join("no/such/folder/a.txt");
        let msg = write_bytes(&p, b"x").unwrap_err().to_string();
        assert!(msg.contains("a.txt"), "{msg}");
    }

    #[test]
    fn longest_legal_names_can_be_written() {
        let dir = scratch("long");
        for len in [240, 244, 250, 255] {
            let name = format!("{}.exr", "n".repeat(len - 4));
            let p = dir.join(&name);
            write_bytes(&p, b"x").unwrap_or_else(|e| panic!("{len} bytes: {e}"));
            assert_eq!(std::fs::read(&p).unwrap(), b"x");
            write_bytes(&p, b"y").unwrap();
            assert_eq!(std::fs::read(&p).unwrap(), b"y");
        }
        assert_eq!(entries(&dir).len(), 4, "no temporary file left");
        let t = temp_name(std::ffi::OsStr::new(&"n".repeat(255)), u32::MAX, u64::MAX);
        assert!(t.len() <= MAX_NAME_BYTES, "{t:?}");
    }

    #[test]
    fn destination_that_is_a_folder_fails_cleanly() {
        let dir = scratch("isdir");
        let p = dir.join("out");
        std::fs::create_dir(&p).unwrap();
        assert!(write_bytes(&p, b"x").is_err());
        assert_eq!(entries(&dir), vec!["out"]);
        assert!(p.is_dir());
    }
}
