//! The one rule for where isoview may write, checked by every verb for all of its output
//! paths together before it writes (`render`, `extract`, `slice`, `compare`):
//!
//! - an output must not be one of the files the run reads (the scene, its data files,
//!   `compare`'s A and B): same file means same device and inode after following links (so a
//!   symbolic or hard link to an input is the input), because the whole-or-nothing write
//!   ([`super::atomic`]) renames a new file over the path and the input would be gone;
//! - two outputs of one run must not be the same file (`compare --diff d.exr --png d.exr`):
//!   the second write would replace the first, and the run would report both as written.
//!   Same file means the same path once its folder is resolved (`d.exr`, `./d.exr`,
//!   `sub/../d.exr`, a linked folder), or, for files that exist, the same file after
//!   following links, as for inputs;
//! - an output must not be a device node, a FIFO or a socket (nor a directory): the rename
//!   would replace the special file with a regular one (`-o /dev/null` would delete
//!   /dev/null when run as root), and a FIFO's reader would never see the data.
//!
//! A path that does not exist yet, or a symbolic link to a regular file that is not an
//! input, is allowed; the write replaces the link itself with the new file (the link's
//! target is left as it was, see [`super::atomic`]).

use std::path::Path;

use super::OutputError;

/// Fails with one line when one of `outputs` (each given as its flag, e.g. `-o` or `--diff`,
/// and its path) may not be written: it is one of `inputs` (what each is, e.g. "the scene
/// file", and its path), an earlier output names the same file, or it is not a regular file
/// (see the module docs). Anything the checks cannot look at (a missing folder, no
/// permission) is left to the write, which reports it.
pub fn check(outputs: &[(&str, &Path)], inputs: &[(&str, &Path)]) -> Result<(), OutputError> {
    for (n, &(flag, output)) in outputs.iter().enumerate() {
        let refuse = |reason: String| OutputError::Refused {
            flag: flag.to_string(),
            path: output.to_path_buf(),
            reason,
        };
        for &(earlier_flag, earlier) in &outputs[..n] {
            if same_output(output, earlier) {
                return Err(refuse(format!(
                    "is also the output of {earlier_flag} ({}); give each output its own file",
                    earlier.display()
                )));
            }
        }
        // Follows links: what the path names is what matters.
        let Ok(meta) = std::fs::metadata(output) else {
            continue;
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
    }
    Ok(())
}

/// Whether two output paths name one file: the same entry in the same folder (outputs that do
/// not exist yet included), or two existing paths that are one file after following links.
fn same_output(a: &Path, b: &Path) -> bool {
    if entry(a) == entry(b) {
        return true;
    }
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(ma), Ok(mb)) => same_file(&ma, &mb, a, b),
        _ => false,
    }
}

/// Where a write of `path` puts its file: the path's folder with its links and `..` resolved,
/// joined with the name. A folder that cannot be resolved (it does not exist: the write will
/// fail anyway) leaves the path as written, in its normal form.
fn entry(path: &Path) -> std::path::PathBuf {
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    match (path.file_name(), folder.canonicalize()) {
        (Some(name), Ok(folder)) => folder.join(name),
        _ => path.components().collect(),
    }
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
        let msg = check(&[("--diff", &a)], &inputs).unwrap_err().to_string();
        assert!(msg.starts_with("--diff ") && msg.contains("is A ("), "{msg}");
        // The same file under another name: a relative path, a symbolic link, a hard link.
        let dotted = dir.join(".").join("a.exr");
        assert!(check(&[("--diff", &dotted)], &inputs).is_err());
        #[cfg(unix)]
        {
            let link = dir.join("link.exr");
            std::os::unix::fs::symlink(&a, &link).unwrap();
            assert!(check(&[("--png", &link)], &inputs).is_err());
            let hard = dir.join("hard.exr");
            std::fs::hard_link(&a, &hard).unwrap();
            assert!(check(&[("--png", &hard)], &inputs).is_err());
        }
        // Another file, or one not there yet, is fine.
        let other = dir.join("b.exr");
        assert!(check(&[("-o", &other)], &inputs).is_ok());
        std::fs::write(&other, b"previous output").unwrap();
        assert!(check(&[("-o", &other)], &inputs).is_ok());
        assert_eq!(std::fs::read(&a).unwrap(), b"reference");
    }

    #[test]
    fn special_files_are_refused() {
        let dir = scratch("special");
        let msg = check(&[("-o", &dir)], &[]).unwrap_err().to_string();
        assert!(msg.contains("is a directory"), "{msg}");
        #[cfg(unix)]
        {
            let msg = check(&[("-o", Path::new("/dev/null"))], &[]).unwrap_err().to_string();
            assert!(msg.contains("/dev/null: is a character device"), "{msg}");
            // A link to a regular file is allowed (the write replaces the link).
            let target = dir.join("target.exr");
            std::fs::write(&target, b"x").unwrap();
            let link = dir.join("link.exr");
            std::os::unix::fs::symlink(&target, &link).unwrap();
            assert!(check(&[("-o", &link)], &[]).is_ok());
            // A link to a device is not.
            let dev = dir.join("null.exr");
            std::os::unix::fs::symlink("/dev/null", &dev).unwrap();
            assert!(check(&[("-o", &dev)], &[]).is_err());
        }
    }

    #[test]
    fn two_outputs_may_not_be_one_file() {
        let dir = scratch("twice");
        let d = dir.join("d.exr");
        // Not there yet: the same name, or another spelling of it.
        let msg = check(&[("--diff", &d), ("--png", &d)], &[]).unwrap_err().to_string();
        assert!(
            msg.starts_with("--png ") && msg.contains("is also the output of --diff ("),
            "{msg}"
        );
        std::fs::create_dir(dir.join("sub")).unwrap();
        let dotted = dir.join("sub").join("..").join(".").join("d.exr");
        assert!(check(&[("--diff", &d), ("--png", &dotted)], &[]).is_err());
        assert!(check(&[("--diff", &d), ("--png", &dir.join("e.exr"))], &[]).is_ok());
        #[cfg(unix)]
        {
            // A linked folder, and once it exists, links to the file.
            let folder_link = dir.join("here");
            std::os::unix::fs::symlink(&dir, &folder_link).unwrap();
            assert!(check(&[("-o", &d), ("--png", &folder_link.join("d.exr"))], &[]).is_err());
            std::fs::write(&d, b"previous").unwrap();
            let link = dir.join("link.png");
            std::os::unix::fs::symlink(&d, &link).unwrap();
            assert!(check(&[("-o", &d), ("--png", &link)], &[]).is_err());
            let hard = dir.join("hard.png");
            std::fs::hard_link(&d, &hard).unwrap();
            assert!(check(&[("-o", &d), ("--png", &hard)], &[]).is_err());
        }
        // Relative and absolute spellings of one name in the working folder.
        let here = std::env::current_dir().unwrap();
        let name = format!("isoview-guard-twice-{}.exr", std::process::id());
        assert!(check(&[("-o", Path::new(&name)), ("--png", &here.join(&name))], &[]).is_err());
        assert!(check(
            &[("-o", Path::new(&name)), ("--png", Path::new(&format!("./{name}")))],
            &[]
        )
        .is_err());
    }
}
