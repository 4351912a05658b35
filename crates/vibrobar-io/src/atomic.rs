//! Files that are either complete or visibly incomplete: written to `NAME.partial` and renamed to
//! `NAME` only by [`AtomicFile::commit`]. A crash, a kill or an error leaves `NAME.partial`, never a
//! truncated `NAME`.

use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

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
pub fn ensure_parent(path: &Path) -> io::Result<()> {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => fs::create_dir_all(p),
        _ => Ok(()),
    }
}

/// A buffered writer to `NAME.partial` that becomes `NAME` on [`commit`](Self::commit).
pub struct AtomicFile {
    target: PathBuf,
    partial: PathBuf,
    out: BufWriter<File>,
}

impl AtomicFile {
    /// Start writing `path` (parent directories are created).
    pub fn create(path: &Path) -> io::Result<AtomicFile> {
        ensure_parent(path)?;
        let partial = partial_path(path);
        let out = BufWriter::new(File::create(&partial)?);
        Ok(AtomicFile {
            target: path.to_path_buf(),
            partial,
            out,
        })
    }

    /// Flush, sync and rename into place.
    pub fn commit(mut self) -> io::Result<()> {
        self.out.flush()?;
        self.out.get_ref().sync_all()?;
        fs::rename(&self.partial, &self.target)
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

/// Write a whole file atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes)?;
    f.commit()
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
}
