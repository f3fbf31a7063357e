//! The one rule for where isoview may write, checked by every verb for every output path
//! before it writes (`render`, `extract`, `slice`, `compare`):
//!
//! - an output must not be one of the files the run reads (the scene, its data files,
//!   `compare`'s A and B): same file means same device and inode after following links (so a
//!   symbolic or hard link to an input is the input), because the whole-or-nothing write
//!   ([`super::atomic`]) renames a new file over the path and the input would be gone;
//! - an output must not be a device node, a FIFO or a socket (nor a directory): the rename
//!   would replace the special file with a regular one (`-o /dev/null` would delete
//!   /dev/null when run as root), and a FIFO's reader would never see the data.
//!
//! A path that does not exist yet, or a symbolic link to a regular file that is not an
//! input, is allowed; the write replaces the link itself with the new file (the link's
//! target is left as it was, see [`super::atomic`]).

use std::path::Path;

use super::OutputError;

/// Fails with one line when `output` (given as `flag`, e.g. `-o` or `--diff`) may not be
/// written: it is one of `inputs` (what each is, e.g. "the scene file", and its path), or
/// it is not a regular file (see the module docs). Anything the checks cannot look at (a
/// missing folder, no permission) is left to the write, which reports it.
pub fn check(flag: &str, output: &Path, inputs: &[(&str, &Path)]) -> Result<(), OutputError> {
    // Follows links: what the path names is what matters.
    let Ok(meta) = std::fs::metadata(output) else {
        return Ok(());
    };
    let refuse = |reason: String| OutputError::Refused {
        flag: flag.to_string(),
        path: output.to_path_buf(),
        reason,
    };
    if let Some(kind) = crate::vocab::special_file(&meta) {
        return Err(refuse(format!(
            "is {kind}, not a regular file; isoview writes outputs as new regular files and \
             will not replace it"
        )));
    }
    for (what, input) in inputs {
        if let Ok(input_meta) = std::fs::metadata(input) {
            if same_file(&meta, &input_meta, output, input) {
                return Err(refuse(format!(
                    "is {what} ({}), which this run reads; write the output to another file",
                    input.display()
                )));
            }
        }
    }
    Ok(())
}

/// Whether two existing paths are one file.
fn same_file(a: &std::fs::Metadata, b: &std::fs::Metadata, pa: &Path, pb: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let _ = (pa, pb);
        a.dev() == b.dev() && a.ino() == b.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (a, b);
        matches!((pa.canonicalize(), pb.canonicalize()), (Ok(x), Ok(y)) if x == y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("isoview-guard-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn an_input_is_refused_also_through_a_link() {
        let dir = scratch("input");
        let a = dir.join("a.exr");
        std::fs::write(&a, b"reference").unwrap();
        let inputs = [("A", a.as_path())];
        let msg = check("--diff", &a, &inputs).unwrap_err().to_string();
        assert!(msg.starts_with("--diff ") && msg.contains("is A ("), "{msg}");
        // The same file under another name: a relative path, a symbolic link, a hard link.
        let dotted = dir.join(".").join("a.exr");
        assert!(check("--diff", &dotted, &inputs).is_err());
        #[cfg(unix)]
        {
            let link = dir.join("link.exr");
            std::os::unix::fs::symlink(&a, &link).unwrap();
            assert!(check("--png", &link, &inputs).is_err());
            let hard = dir.join("hard.exr");
            std::fs::hard_link(&a, &hard).unwrap();
            assert!(check("--png", &hard, &inputs).is_err());
        }
        // Another file, or one not there yet, is fine.
        let other = dir.join("b.exr");
        assert!(check("-o", &other, &inputs).is_ok());
        std::fs::write(&other, b"previous output").unwrap();
        assert!(check("-o", &other, &inputs).is_ok());
        assert_eq!(std::fs::read(&a).unwrap(), b"reference");
    }

    #[test]
    fn special_files_are_refused() {
        let dir = scratch("special");
        let msg = check("-o", &dir, &[]).unwrap_err().to_string();
        assert!(msg.contains("is a directory"), "{msg}");
        #[cfg(unix)]
        {
            let msg = check("-o", Path::new("/dev/null"), &[]).unwrap_err().to_string();
            assert!(msg.contains("/dev/null: is a character device"), "{msg}");
            // A link to a regular file is allowed (the write replaces the link).
            let target = dir.join("target.exr");
            std::fs::write(&target, b"x").unwrap();
            let link = dir.join("link.exr");
            std::os::unix::fs::symlink(&target, &link).unwrap();
            assert!(check("-o", &link, &[]).is_ok());
            // A link to a device is not.
            let dev = dir.join("null.exr");
            std::os::unix::fs::symlink("/dev/null", &dev).unwrap();
            assert!(check("-o", &dev, &[]).is_err());
        }
    }
}
