//! Files that are either complete or visibly incomplete: written to `NAME.partial` and renamed to
//! `NAME` only by [`AtomicFile::commit`]. A crash or a kill leaves `NAME.partial`, never a
//! truncated `NAME`; an error ([`AtomicFile::discard`], [`write_atomic`]) or a signal handled by
//! the caller ([`remove_live_partials`]) leaves nothing. What a path is (regular, link, device,
//! FIFO) is decided by the policy in [`crate::target`]: special files are written through.

use crate::error::{IoError, Result};
use crate::target::{resolve_output, Output};
use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// `path` with `.partial` appended to its file name.
pub fn partial_path(path: &Path) -> PathBuf {
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".partial");
    path.with_file_name(name)
}

/// Create the parent directory of `path` if it has one.
pub fn ensure_parent(path: &Path) -> Result<()> {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => fs::create_dir_all(p).map_err(IoError::os(p)),
        _ => Ok(()),
    }
}

/// Partial files being written by this process, so that a signal handler can remove them; and
/// whether the process is closing (after which no new partial file is started).
struct Live {
    partials: Vec<PathBuf>,
    closing: bool,
}

static LIVE: Mutex<Live> = Mutex::new(Live {
    partials: Vec::new(),
    closing: false,
});

fn live() -> std::sync::MutexGuard<'static, Live> {
    LIVE.lock().unwrap_or_else(|p| p.into_inner())
}

/// Create the partial file `partial` and register it, in one step under the registry's lock,
/// so that [`close_for_exit`] sees every partial file that exists. Once the process is closing,
/// the calling thread waits for the exit instead (no partial file appears after the cleanup).
pub(crate) fn create_tracked(partial: &Path) -> Result<File> {
    let mut g = live();
    if g.closing {
        drop(g);
        loop {
            std::thread::park();
        }
    }
    let f = File::create(partial).map_err(IoError::os(partial))?;
    g.partials.push(partial.to_path_buf());
    Ok(f)
}

/// Forget a partial file that was renamed into place or removed.
pub(crate) fn forget(partial: &Path) {
    live().partials.retain(|p| p != partial);
}

/// Remove every partial file this process is writing and return their names; for a
/// SIGINT/SIGTERM handler. Journals are not partial files and survive, so `--resume` works.
pub fn remove_live_partials() -> Vec<PathBuf> {
    remove_live_partials_if(|_| true)
}

/// Register a temporary file that a library writes itself (e.g. a bitmap encoder, before
/// [`publish`]), so that an interrupt removes it like a partial file. [`publish`] forgets it.
pub fn track_partial(tmp: &Path) {
    let mut g = live();
    if !g.partials.iter().any(|p| p == tmp) {
        g.partials.push(tmp.to_path_buf());
    }
}

/// For a SIGINT/SIGTERM handler about to exit: from now on no partial file is started (a thread
/// that tries waits for the exit), and every partial file is removed; returns their names.
pub fn close_for_exit() -> Vec<PathBuf> {
    live().closing = true;
    remove_live_partials()
}

fn remove_live_partials_if(pick: impl Fn(&Path) -> bool) -> Vec<PathBuf> {
    let mut g = live();
    let (gone, keep): (Vec<PathBuf>, Vec<PathBuf>) = g.partials.drain(..).partition(|p| pick(p));
    g.partials = keep;
    gone.into_iter()
        .filter(|p| fs::remove_file(p).is_ok())
        .collect()
}

/// A buffered writer to `NAME.partial` that becomes `NAME` on [`commit`](Self::commit); for a
/// device or FIFO, a writer straight to it.
pub struct AtomicFile {
    output: Output,
    /// `None` when writing through a special file.
    partial: Option<PathBuf>,
    out: BufWriter<File>,
}

impl AtomicFile {
    /// Start writing `path` (parent directories are created).
    pub fn create(path: &Path) -> Result<AtomicFile> {
        let output = resolve_output(path)?;
        if !output.is_regular() {
            let f = OpenOptions::new()
                .write(true)
                .open(&output.target)
                .map_err(IoError::os(path))?;
            return Ok(AtomicFile {
                output,
                partial: None,
                out: BufWriter::new(f),
            });
        }
        ensure_parent(&output.target)?;
        let partial = partial_path(&output.target);
        let f = create_tracked(&partial)?;
        Ok(AtomicFile {
            output,
            partial: Some(partial),
            out: BufWriter::with_capacity(1 << 16, f),
        })
    }

    /// The policy's decision for this file.
    pub fn output(&self) -> &Output {
        &self.output
    }

    /// Flush, sync and rename into place. On failure the partial file is removed.
    pub fn commit(mut self) -> Result<()> {
        let res = self.finish();
        if res.is_err() {
            self.remove_partial();
        }
        res
    }

    fn finish(&mut self) -> Result<()> {
        let name = self.partial.clone().unwrap_or(self.output.target.clone());
        self.out.flush().map_err(IoError::os(&name))?;
        if let Some(partial) = &self.partial {
            self.out
                .get_ref()
                .sync_all()
                .map_err(IoError::os(partial))?;
            fs::rename(partial, &self.output.target).map_err(IoError::os(&self.output.target))?;
            forget(partial);
        }
        Ok(())
    }

    fn remove_partial(&self) {
        if let Some(p) = &self.partial {
            let _ = fs::remove_file(p);
            forget(p);
        }
    }

    /// Give up: remove the partial file (nothing is left that looks like a result).
    pub fn discard(self) {
        self.remove_partial();
    }

    /// An I/O error of this file, naming it.
    pub fn error(&self, e: io::Error) -> IoError {
        IoError::Os {
            path: self
                .partial
                .clone()
                .unwrap_or(self.output.requested.clone()),
            source: e,
        }
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.out.write(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }
}

/// Put a finished temporary file `tmp` (written beside `path` by a library that insists on
/// writing files itself, e.g. a bitmap encoder) in place under the output-path policy: renamed
/// over a regular file or a link's target, copied through into a device or FIFO. `tmp` is gone
/// afterwards, also on failure.
pub fn publish(tmp: &Path, path: &Path) -> Result<()> {
    forget(tmp);
    let res = (|| {
        let output = resolve_output(path)?;
        if output.is_regular() {
            fs::rename(tmp, &output.target).map_err(IoError::os(&output.target))
        } else {
            let bytes = fs::read(tmp).map_err(IoError::os(tmp))?;
            let mut f = OpenOptions::new()
                .write(true)
                .open(&output.target)
                .map_err(IoError::os(path))?;
            f.write_all(&bytes).map_err(IoError::os(path))
        }
    })();
    let _ = fs::remove_file(tmp);
    res
}

/// Write a whole file atomically; nothing is left behind on failure.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_with(path, |w| w.write_all(bytes))
}

/// Write `path` atomically: `fill` writes into `path.partial`, renamed on success. On failure the
/// partial file is removed and the error names the file.
pub fn write_with(path: &Path, fill: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> Result<()> {
    let mut f = AtomicFile::create(path)?;
    match fill(&mut f) {
        Ok(()) => f.commit(),
        Err(e) => {
            let err = f.error(e);
            f.discard();
            Err(err)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uncommitted_file_stays_partial() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sub/out.csv");
        {
            let mut f = AtomicFile::create(&p).unwrap();
            f.write_all(b"a,b\n1,2\n").unwrap();
        }
        assert!(!p.exists(), "an uncommitted file must not appear complete");
        assert!(partial_path(&p).exists());
        let mut f = AtomicFile::create(&p).unwrap();
        f.write_all(b"a,b\n").unwrap();
        f.commit().unwrap();
        assert_eq!(fs::read(&p).unwrap(), b"a,b\n");
        assert!(!partial_path(&p).exists());
    }

    #[test]
    fn failed_write_leaves_neither_file_nor_partial_and_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("a/b.csv");
        let err = write_with(&target, |w| {
            writeln!(w, "half a file")?;
            Err(io::Error::other("simulated failure"))
        })
        .unwrap_err()
        .to_string();
        assert!(err.contains("b.csv"), "{err}");
        assert!(!target.exists());
        assert!(!partial_path(&target).exists());
        write_atomic(&target, b"ok\n").unwrap();
        assert_eq!(fs::read_to_string(&target).unwrap(), "ok\n");
        assert!(!partial_path(&target).exists());
    }

    #[test]
    fn regression_symlink_out_stays_a_link_and_its_target_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.csv");
        fs::write(&real, "old\n").unwrap();
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink("real.csv", &link).unwrap();
        write_atomic(&link, b"new\n").unwrap();
        assert!(fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(fs::read_to_string(&real).unwrap(), "new\n");
        assert!(!partial_path(&link).exists() && !partial_path(&real).exists());
    }

    #[test]
    fn publish_follows_links_and_removes_the_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.png");
        let link = dir.path().join("fig.png");
        std::os::unix::fs::symlink("real.png", &link).unwrap();
        let tmp = dir.path().join("fig.partial.png");
        fs::write(&tmp, b"png").unwrap();
        publish(&tmp, &link).unwrap();
        assert!(fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(fs::read(&real).unwrap(), b"png");
        assert!(!tmp.exists());
    }

    #[test]
    fn live_partials_are_removed_on_request() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("big.csv");
        let mut f = AtomicFile::create(&p).unwrap();
        f.write_all(b"t_s\n").unwrap();
        f.flush().unwrap();
        assert!(partial_path(&p).exists());
        let removed = remove_live_partials_if(|q| q.starts_with(dir.path()));
        assert!(removed.contains(&partial_path(&p)), "{removed:?}");
        assert!(!partial_path(&p).exists());
        drop(f);
    }

    #[test]
    fn tracked_temporaries_are_removed_on_request_and_forgotten_when_published() {
        let dir = tempfile::tempdir().unwrap();
        let tmp = dir.path().join("fig.partial.png");
        track_partial(&tmp);
        fs::write(&tmp, b"png").unwrap();
        let removed = remove_live_partials_if(|q| q.starts_with(dir.path()));
        assert_eq!(removed, vec![tmp.clone()]);
        assert!(!tmp.exists());
        track_partial(&tmp);
        fs::write(&tmp, b"png").unwrap();
        publish(&tmp, &dir.path().join("fig.png")).unwrap();
        assert!(remove_live_partials_if(|q| q.starts_with(dir.path())).is_empty());
        assert_eq!(fs::read(dir.path().join("fig.png")).unwrap(), b"png");
    }
}
