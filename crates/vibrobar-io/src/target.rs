//! The output-path policy, in one place: every writer of this crate asks [`resolve_output`] what
//! a path is before it writes.
//!
//! * An absent path or a regular file is written atomically (`NAME.partial`, then rename).
//! * A symbolic link is followed: the file it points to is written, atomically beside it; the
//!   link stays a link.
//! * A character or block device, a FIFO or a socket is never replaced: it is written through
//!   directly (no rename) and gets no sidecar files (`.meta.json`, journals). Commands that need
//!   sidecars (the journaled `map` and `sweep`) refuse such a path ([`Output::require_regular`]).
//! * A directory is refused.
//!
//! * A path that is the same file as an input of this process (registered with
//!   [`register_input`] where it is read: scenario files, merge shards) is refused, whatever file
//!   of the command it is (the data, its `.npy`, sidecars, figures): one check for every command.
//!
//! [`check_not_input`] refuses an output that is the same file as one of a given list of inputs.

use crate::error::{IoError, Result};
use std::fs;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Inputs of this process: (device, inode, path as given).
static INPUTS: Mutex<Vec<(u64, u64, PathBuf)>> = Mutex::new(Vec::new());

/// Record `path` as an input of this process: from now on [`resolve_output`] (and so every
/// writer of this crate) refuses to write it, under any name or link. Only regular files are
/// inputs that an output could destroy: an absent path, a terminal or a pipe (`--scenario
/// /dev/stdin` with `--out /dev/stdout` on one terminal) is ignored.
pub fn register_input(path: &Path) {
    if let Some(md) = fs::metadata(path).ok().filter(fs::Metadata::is_file) {
        let mut g = INPUTS.lock().unwrap_or_else(|p| p.into_inner());
        // Forget inputs deleted since (their inode may be this file's now).
        g.retain(|(d, i, p)| fs::metadata(p).is_ok_and(|m| m.dev() == *d && m.ino() == *i));
        if !g.iter().any(|(d, i, _)| *d == md.dev() && *i == md.ino()) {
            g.push((md.dev(), md.ino(), path.to_path_buf()));
        }
    }
}

/// Refuse `out` if it is a registered input ([`register_input`]); for a command to fail before
/// it computes anything (every writer checks again when it writes).
pub fn refuse_input(out: &Path) -> Result<()> {
    match fs::metadata(out) {
        Ok(md) => refuse_registered_input(out, &md),
        Err(_) => Ok(()),
    }
}

/// Refuse `out` (whose metadata, links followed, is `md`) if it is a registered input.
fn refuse_registered_input(out: &Path, md: &fs::Metadata) -> Result<()> {
    let g = INPUTS.lock().unwrap_or_else(|p| p.into_inner());
    // The input must still be that file: a deleted input's inode may be reused by a new file.
    let same = |d: u64, i: u64, p: &Path| {
        d == md.dev()
            && i == md.ino()
            && fs::metadata(p).is_ok_and(|m| m.dev() == d && m.ino() == i)
    };
    match g.iter().find(|(d, i, p)| same(*d, *i, p)) {
        Some((_, _, input)) => Err(IoError::OutputIsInput {
            out: out.to_path_buf(),
            input: input.clone(),
        }),
        None => Ok(()),
    }
}

/// Most symbolic links followed for one path (as Linux's `MAXSYMLINKS`).
const MAX_LINKS: usize = 40;

/// What the policy decided for a path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputKind {
    /// Absent or a regular file: written atomically.
    Regular,
    /// A device, FIFO or socket (the name says which): written through, no sidecars.
    Special(&'static str),
}

/// An output path after the policy.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Output {
    /// The path as given.
    pub requested: PathBuf,
    /// The file to write: `requested` with symbolic links followed.
    pub target: PathBuf,
    /// How to write it.
    pub kind: OutputKind,
}

impl Output {
    /// True when the output gets sidecar files and an atomic rename.
    pub fn is_regular(&self) -> bool {
        self.kind == OutputKind::Regular
    }

    /// Refuse a special file for an output that needs sidecar files (`what` names them).
    pub fn require_regular(&self, what: &str) -> Result<()> {
        match self.kind {
            OutputKind::Regular => Ok(()),
            OutputKind::Special(k) => Err(IoError::NotRegular {
                path: self.requested.clone(),
                why: format!("is a {k}; {what} needs a regular file beside which it can keep its journal and metadata"),
            }),
        }
    }
}

/// Classify a file type; `None` for a regular file.
fn special_kind(ft: fs::FileType) -> Option<&'static str> {
    use std::os::unix::fs::FileTypeExt;
    if ft.is_char_device() {
        Some("character device")
    } else if ft.is_block_device() {
        Some("block device")
    } else if ft.is_fifo() {
        Some("FIFO")
    } else if ft.is_socket() {
        Some("socket")
    } else {
        None
    }
}

/// Decide how to write `path`: follow symbolic links, and tell regular files (or absent ones)
/// from special files. Refuses directories and link loops. Reads metadata only.
pub fn resolve_output(path: &Path) -> Result<Output> {
    // The kernel follows the links (also the magic ones of /proc, as /dev/stdout's).
    match fs::metadata(path) {
        Ok(md) => {
            refuse_registered_input(path, &md)?;
            let ft = md.file_type();
            if ft.is_dir() {
                return Err(IoError::NotRegular {
                    path: path.to_path_buf(),
                    why: "is a directory; give a file name".into(),
                });
            }
            if let Some(k) = special_kind(ft) {
                return Ok(Output {
                    requested: path.to_path_buf(),
                    target: path.to_path_buf(),
                    kind: OutputKind::Special(k),
                });
            }
            let is_link = fs::symlink_metadata(path)
                .map(|m| m.file_type().is_symlink())
                .unwrap_or(false);
            let target = if is_link {
                fs::canonicalize(path).map_err(IoError::os(path))?
            } else {
                path.to_path_buf()
            };
            return Ok(Output {
                requested: path.to_path_buf(),
                target,
                kind: OutputKind::Regular,
            });
        }
        Err(e) if e.raw_os_error() == Some(libc::ELOOP) => {
            return Err(IoError::NotRegular {
                path: path.to_path_buf(),
                why: format!("more than {MAX_LINKS} symbolic links (a loop?)"),
            })
        }
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(IoError::os(path)(e)),
        Err(_) => {}
    }
    // Absent, or a chain of links ending in an absent file: create the file the chain names.
    let mut target = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        let md = match fs::symlink_metadata(&target) {
            Ok(md) => md,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Ok(Output {
                    requested: path.to_path_buf(),
                    target,
                    kind: OutputKind::Regular,
                })
            }
            Err(e) => return Err(IoError::os(path)(e)),
        };
        let ft = md.file_type();
        if ft.is_symlink() {
            let link = fs::read_link(&target).map_err(IoError::os(&target))?;
            target = match target.parent() {
                Some(dir) if link.is_relative() => dir.join(link),
                _ => link,
            };
            continue;
        }
        if ft.is_dir() {
            return Err(IoError::NotRegular {
                path: path.to_path_buf(),
                why: "is a directory; give a file name".into(),
            });
        }
        let kind = match special_kind(ft) {
            Some(k) => OutputKind::Special(k),
            None => OutputKind::Regular,
        };
        return Ok(Output {
            requested: path.to_path_buf(),
            target,
            kind,
        });
    }
    Err(IoError::NotRegular {
        path: path.to_path_buf(),
        why: format!("more than {MAX_LINKS} symbolic links (a loop?)"),
    })
}

/// Refuse an output that is the same file (same device and inode, links followed) as one of
/// `inputs`. Absent files clash with nothing.
pub fn check_not_input(out: &Path, inputs: &[&Path]) -> Result<()> {
    let Ok(o) = fs::metadata(out) else {
        return Ok(());
    };
    for input in inputs {
        if let Ok(i) = fs::metadata(input) {
            if i.dev() == o.dev() && i.ino() == o.ino() {
                return Err(IoError::OutputIsInput {
                    out: out.to_path_buf(),
                    input: input.to_path_buf(),
                });
            }
        }
    }
    Ok(())
}

/// A FIFO at `path`, for tests that need a special file they may safely write (CI runs as
/// root: a test that regressed to replacing `/dev/null` would destroy it).
#[cfg(test)]
pub(crate) fn test_fifo(path: &Path) {
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(path.as_os_str().as_bytes()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fifo_is_special() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("pipe");
        test_fifo(&p);
        assert_eq!(
            resolve_output(&p).unwrap().kind,
            OutputKind::Special("FIFO")
        );
    }

    #[test]
    fn regression_out_dev_null_is_written_through_not_replaced() {
        // Only metadata is read: the decision, not a write, is what is checked.
        let o = resolve_output(Path::new("/dev/null")).unwrap();
        assert_eq!(o.kind, OutputKind::Special("character device"));
        assert!(!o.is_regular());
        assert!(o.require_regular("map").is_err());
        let o = resolve_output(Path::new("/dev/full")).unwrap();
        assert!(!o.is_regular());
    }

    #[test]
    fn absent_and_regular_files_are_regular_and_directories_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.csv");
        assert!(resolve_output(&p).unwrap().is_regular());
        fs::write(&p, "x").unwrap();
        let o = resolve_output(&p).unwrap();
        assert!(o.is_regular());
        assert_eq!(o.target, p);
        let e = resolve_output(dir.path()).unwrap_err().to_string();
        assert!(e.contains("is a directory"), "{e}");
    }

    #[test]
    fn symlinks_are_followed_to_their_target_and_loops_refused() {
        let dir = tempfile::tempdir().unwrap();
        let sub = dir.path().join("sub");
        fs::create_dir(&sub).unwrap();
        let real = sub.join("real.csv");
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink("sub/real.csv", &link).unwrap();
        // Dangling link: the target is created.
        let o = resolve_output(&link).unwrap();
        assert_eq!(o.target, dir.path().join("sub/real.csv"));
        assert!(o.is_regular());
        fs::write(&real, "x").unwrap();
        assert_eq!(
            resolve_output(&link).unwrap().target,
            fs::canonicalize(&real).unwrap()
        );
        let a = dir.path().join("a");
        let b = dir.path().join("b");
        std::os::unix::fs::symlink(&b, &a).unwrap();
        std::os::unix::fs::symlink(&a, &b).unwrap();
        let e = resolve_output(&a).unwrap_err().to_string();
        assert!(e.contains("symbolic links"), "{e}");
    }

    #[test]
    fn regression_out_equal_to_an_input_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let s = dir.path().join("s.toml");
        fs::write(&s, "[bar]\n").unwrap();
        let link = dir.path().join("l.toml");
        std::os::unix::fs::symlink(&s, &link).unwrap();
        let other = dir.path().join("o.csv");
        assert!(check_not_input(&other, &[&s]).is_ok());
        let e = check_not_input(&s, &[&s]).unwrap_err().to_string();
        assert!(e.contains("is also an input"), "{e}");
        assert!(
            check_not_input(&link, &[&s]).is_err(),
            "a link to the input"
        );
        let rel = dir.path().join("sub/../s.toml");
        fs::create_dir(dir.path().join("sub")).unwrap();
        assert!(check_not_input(&rel, &[&s]).is_err(), "another spelling");
    }

    #[test]
    fn regression_registered_input_is_refused_as_any_output() {
        let dir = tempfile::tempdir().unwrap();
        let s = dir.path().join("in.toml");
        fs::write(&s, "[bar]\n").unwrap();
        let link = dir.path().join("in.npy");
        std::os::unix::fs::symlink(&s, &link).unwrap();
        assert!(resolve_output(&s).is_ok(), "not an input yet");
        register_input(&s);
        for out in [&s, &link] {
            let e = resolve_output(out).unwrap_err().to_string();
            assert!(
                e.contains("is also an input") && e.contains("in.toml"),
                "{e}"
            );
        }
        // Every writer asks the policy: nothing is written.
        assert!(crate::write_atomic(&link, b"x").is_err());
        assert_eq!(fs::read_to_string(&s).unwrap(), "[bar]\n");
        assert!(resolve_output(&dir.path().join("other.csv")).is_ok());
    }
}
