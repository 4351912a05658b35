//! An exclusive lock on a journal, so that two processes (two `--resume` runs, say) never work on
//! one journal. The lock is `flock(2)` on `JOURNAL.lock`, which holds who took it (pid, host,
//! start time) so that the loser can say who is working. The kernel drops the lock when its
//! holder exits or is killed, so a stale lock file never blocks anyone: its content is simply
//! overwritten by the next holder.

use crate::error::{IoError, Result};
use std::fs::{self, File, OpenOptions};
use std::io::{Read, Seek, Write};
use std::os::unix::fs::MetadataExt;
use std::os::unix::io::AsRawFd;
use std::path::{Path, PathBuf};

/// `JOURNAL.lock` beside a journal.
pub fn lock_path(journal: &Path) -> PathBuf {
    let mut name = journal
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".lock");
    journal.with_file_name(name)
}

/// A held lock; released (and its file removed) on drop.
#[derive(Debug)]
pub struct LockFile {
    path: PathBuf,
    file: File,
}

fn host_name() -> String {
    let mut buf = [0u8; 256];
    // SAFETY: the buffer is valid for its length; gethostname NUL-terminates within it or
    // truncates, and we stop at the first NUL.
    let rc = unsafe { libc::gethostname(buf.as_mut_ptr().cast(), buf.len()) };
    if rc != 0 {
        return "unknown host".into();
    }
    let end = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
    String::from_utf8_lossy(&buf[..end]).into_owned()
}

impl LockFile {
    /// Take the lock of `journal`, or say who holds it.
    pub fn acquire(journal: &Path) -> Result<LockFile> {
        let path = lock_path(journal);
        loop {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(IoError::os(&path))?;
            // SAFETY: flock on a file descriptor we own.
            let rc = unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) };
            if rc != 0 {
                let e = std::io::Error::last_os_error();
                if e.kind() == std::io::ErrorKind::WouldBlock {
                    let mut holder = String::new();
                    let _ = file.read_to_string(&mut holder);
                    let holder = holder.trim();
                    return Err(IoError::Locked {
                        journal: journal.to_path_buf(),
                        holder: if holder.is_empty() {
                            "a process that has not said who it is yet".into()
                        } else {
                            holder.to_string()
                        },
                    });
                }
                return Err(IoError::os(&path)(e));
            }
            // The previous holder may have removed the file between our open and our lock:
            // then we locked an orphan and must start again on the new file.
            let same = match fs::metadata(&path) {
                Ok(md) => {
                    let mine = file.metadata().map_err(IoError::os(&path))?;
                    md.ino() == mine.ino() && md.dev() == mine.dev()
                }
                Err(_) => false,
            };
            if !same {
                continue;
            }
            let who = format!(
                "pid {} on {}, since {}",
                std::process::id(),
                host_name(),
                crate::meta::utc_now_rfc3339()
            );
            // Best effort: on a full disk the lock still holds, only the name of its holder is
            // missing (and the journal's own write then fails with the real error).
            let _ = file
                .set_len(0)
                .and_then(|_| file.rewind())
                .and_then(|_| file.write_all(who.as_bytes()))
                .and_then(|_| file.flush());
            return Ok(LockFile { path, file });
        }
    }
}

impl Drop for LockFile {
    fn drop(&mut self) {
        // Remove while still holding the lock; a waiter that opened the old file notices (inode
        // check above) and retries on a fresh one.
        let _ = fs::remove_file(&self.path);
        let _ = &self.file;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stale_lock_file_of_a_dead_process_does_not_block() {
        let dir = tempfile::tempdir().unwrap();
        let journal = dir.path().join("m.csv.journal");
        // Left by a process killed with SIGKILL: the file stays, its flock died with it.
        fs::write(
            lock_path(&journal),
            "pid 4000000 on gone, since 2000-01-01T00:00:00Z",
        )
        .unwrap();
        let l = LockFile::acquire(&journal).unwrap();
        let text = fs::read_to_string(lock_path(&journal)).unwrap();
        assert!(
            text.starts_with(&format!("pid {} on ", std::process::id())),
            "{text}"
        );
        drop(l);
        assert!(!lock_path(&journal).exists());
    }
}
