//! [`DataAccess`]: which data files a scene may name. The command line reads whatever the
//! scene names (the user wrote it); `isoview serve` lets its page change the scene, but not
//! which files the server reads, so there a data path must resolve into the scene's folder, a
//! folder given with `--allow-dir`, or be one of the files the scene itself names. The same
//! rule admits the data file a detached volume header names (`formats::Located::detached`).
//!
//! [`DataAccess::admit`] judges a path when the scene is loaded; the readers open it later
//! (a raw or npy grid when it is sampled, again for each brick read). A folder on the admitted
//! path swapped for a link in between (by someone who can write in an allowed folder) would
//! lead the open out of the roots, so every reader opens through [`DataAccess::open`], which
//! judges the file it opened by the path the kernel holds for it (`/proc/self/fd/N`), not by
//! the name it was given.

use std::path::{Path, PathBuf};

/// Why a path was refused (after the path, or the header key that names it).
pub const OUTSIDE: &str = "outside the folders isoview serve may read (the scene's folder and \
                           each --allow-dir); start the server with --allow-dir FOLDER to allow it";

/// Where a data path (`path` keys of `[field]`, `[field2]`) may point.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum DataAccess {
    /// Any file (the command line).
    #[default]
    Any,
    /// Only files at or under these canonical paths (folders, or single files).
    Within(Vec<PathBuf>),
}

impl DataAccess {
    /// Access to `roots` (folders or files), each resolved to its canonical path; the error
    /// names the root that does not exist.
    pub fn within<I: IntoIterator<Item = PathBuf>>(roots: I) -> Result<DataAccess, String> {
        let roots = roots
            .into_iter()
            .map(|r| {
                std::fs::canonicalize(&r).map_err(|e| super::FieldError::io(&r, &e).to_string())
            })
            .collect::<Result<_, _>>()?;
        Ok(DataAccess::Within(roots))
    }

    /// The path to open for `path`: `path` itself under [`DataAccess::Any`]; under
    /// [`DataAccess::Within`], its canonical form (links and `..` resolved, so nothing escapes
    /// between this check and the read) when that lies within a root, else the refusal.
    ///
    /// A file that does not exist is judged by its nearest folder that does (canonical, with
    /// the missing names below it: `nodir/x.npy` in an allowed folder passes and the reader
    /// says the file is missing), and a path that cannot be resolved so (a `..` below a
    /// missing folder) is refused with the same words as one outside the roots, so the answer
    /// does not tell which files exist outside them.
    pub fn admit(&self, path: &Path) -> Result<PathBuf, String> {
        let DataAccess::Within(roots) = self else {
            return Ok(path.to_path_buf());
        };
        let refused = || format!("{}: {OUTSIDE}", path.display());
        let resolved = match std::fs::canonicalize(path) {
            Ok(p) => p,
            Err(_) => {
                // Up to the nearest folder that resolves, keeping the names below it.
                let mut missing = Vec::new();
                let mut at = path;
                loop {
                    let (Some(parent), Some(name)) = (at.parent(), at.file_name()) else {
                        return Err(refused());
                    };
                    missing.push(name);
                    at = if parent.as_os_str().is_empty() { Path::new(".") } else { parent };
                    if let Ok(folder) = std::fs::canonicalize(at) {
                        break missing.iter().rev().fold(folder, |p, name| p.join(name));
                    }
                }
            }
        };
        if roots.iter().any(|root| resolved.starts_with(root)) {
            Ok(resolved)
        } else {
            Err(refused())
        }
    }

    /// Opens an admitted data file for reading ([`open_data`]); under [`DataAccess::Within`],
    /// the file opened must still lie within a root, judged by its own path (links already
    /// followed by the open), else the open is refused with [`Escaped`].
    pub fn open(&self, path: &Path) -> std::io::Result<std::fs::File> {
        let file = open_data(path)?;
        match self {
            DataAccess::Any => Ok(file),
            DataAccess::Within(roots) => confirm(file, roots),
        }
    }
}

/// `file` when the path the kernel holds for it (`/proc/self/fd/N`: every link resolved, as
/// it was opened) lies within one of `roots`. A file whose path cannot be read is refused.
#[cfg(target_os = "linux")]
fn confirm(file: std::fs::File, roots: &[PathBuf]) -> std::io::Result<std::fs::File> {
    use std::os::fd::AsRawFd;
    let real = std::fs::read_link(format!("/proc/self/fd/{}", file.as_raw_fd()))?;
    match roots.iter().any(|root| real.starts_with(root)) {
        true => Ok(file),
        false => Err(std::io::Error::other(Escaped)),
    }
}

/// Elsewhere an open file's path cannot be asked portably: [`DataAccess::admit`]'s check
/// (links resolved when the scene was loaded) is the only one.
#[cfg(not(target_os = "linux"))]
fn confirm(file: std::fs::File, _: &[PathBuf]) -> std::io::Result<std::fs::File> {
    Ok(file)
}

/// What [`DataAccess::open`] refuses: a file admitted inside the roots that, opened, lies
/// outside them (a folder or the file on its path was replaced by a link after the check).
#[derive(Debug)]
pub struct Escaped;

impl std::fmt::Display for Escaped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{OUTSIDE} (it was replaced by a link after it was checked)")
    }
}

impl std::error::Error for Escaped {}

/// Opens a data file for reading; a path that is not a regular file (a FIFO, a device, a
/// socket, a folder) is refused with `is a FIFO (named pipe), not a data file`, whatever
/// names it (`path` keys, a detached header's data file, a mesh source). The rule is
/// [`crate::vocab::open_regular`]'s (a FIFO hung the command line and wedged `serve` workers).
pub fn open_data(path: &Path) -> std::io::Result<std::fs::File> {
    crate::vocab::open_regular(path, "a data file")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_resolve_into_the_roots_or_are_refused() {
        let dir = std::env::temp_dir().join(format!("isoview-access-{}", std::process::id()));
        let inside = dir.join("in");
        std::fs::create_dir_all(inside.join("sub")).unwrap();
        std::fs::write(inside.join("sub/a.raw"), b"x").unwrap();
        std::fs::write(dir.join("secret.raw"), b"x").unwrap();
        let access = DataAccess::within([inside.clone()]).unwrap();
        let canon = std::fs::canonicalize(&inside).unwrap();
        assert_eq!(access.admit(&inside.join("sub/a.raw")).unwrap(), canon.join("sub/a.raw"));
        // A missing file in an allowed folder passes (the reader then says it is missing).
        assert_eq!(access.admit(&inside.join("nope.raw")).unwrap(), canon.join("nope.raw"));
        // So does one in a missing folder inside it (fifth attack pass: "outside the folders
        // ... start the server with --allow-dir", which could not help).
        for missing in ["nodir/x.raw", "nodir/deeper/x.raw", "sub/nodir/x.raw"] {
            assert_eq!(access.admit(&inside.join(missing)).unwrap(), canon.join(missing));
        }
        for bad in [
            dir.join("secret.raw"),
            inside.join("../secret.raw"),
            inside.join("sub/../../secret.raw"),
            inside.join("../missing.raw"),
            inside.join("nodir/../../secret.raw"),
            PathBuf::from("/etc/passwd"),
        ] {
            let e = access.admit(&bad).unwrap_err();
            assert!(e.contains("--allow-dir"), "{e}");
        }
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(dir.join("secret.raw"), inside.join("link.raw")).unwrap();
            assert!(access.admit(&inside.join("link.raw")).is_err(), "a link out is refused");
        }
        assert_eq!(
            DataAccess::Any.admit(Path::new("/etc/passwd")).unwrap(),
            Path::new("/etc/passwd")
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
