//! Resumable row store for sweeps and maps.
//!
//! Rows are appended to `FILE.journal` as they finish (any order, one `write` call per row, so
//! a kill leaves at most one torn last line). The journal starts with a fingerprint of the job;
//! `--resume` accepts only a journal of the same job, drops a torn last line, and runs only the
//! missing grid indices. When every row is in, the rows are written sorted by grid index to
//! `FILE` (atomically, via `FILE.partial`) and the journal is removed. So the final file is
//! byte-identical whether or not the run was interrupted, and no file that looks complete is
//! ever half written.

use super::atomic::{ensure_parent, write_atomic};
use std::collections::BTreeMap;
use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

const MAGIC: &str = "# vibrobar journal v1";

/// Errors of the row store.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// Underlying I/O error, with the file.
    #[error("{path}: {source}")]
    Io {
        /// File.
        path: String,
        /// Cause.
        source: io::Error,
    },
    /// A journal exists and `--resume` was not given.
    #[error("{journal} holds an interrupted run of this output; rerun with --resume to complete it, or delete it to start over")]
    JournalExists {
        /// Journal path.
        journal: String,
    },
    /// The journal belongs to another job.
    #[error("{journal} was written for different parameters (fingerprint {found}, this run {expected}); use another --out or delete the journal")]
    Mismatch {
        /// Journal path.
        journal: String,
        /// Fingerprint in the file.
        found: String,
        /// Fingerprint of this run.
        expected: String,
    },
    /// The journal is damaged somewhere other than its last line.
    #[error("{journal}: line {line} is damaged ({why}); the journal cannot be resumed safely")]
    Corrupt {
        /// Journal path.
        journal: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        why: String,
    },
    /// `finish` was called with rows missing.
    #[error("{missing} of {total} rows are missing; the output stays incomplete in {journal}")]
    Incomplete {
        /// Journal path.
        journal: String,
        /// Rows missing.
        missing: usize,
        /// Rows expected.
        total: usize,
    },
}

fn io_err(path: &Path) -> impl FnOnce(io::Error) -> StoreError + '_ {
    move |source| StoreError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// `FILE.journal` for an output `FILE`.
pub fn journal_path(out: &Path) -> PathBuf {
    let mut name = out
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".journal");
    out.with_file_name(name)
}

/// An open journal for one output file.
pub struct Journal {
    out: PathBuf,
    journal: PathBuf,
    header: String,
    expected: Vec<usize>,
    rows: Mutex<(File, BTreeMap<usize, String>)>,
}

impl Journal {
    /// Open the journal of `out` for a job with `header` (CSV header without the index column),
    /// `fingerprint` (identifies the job's parameters) and the grid indices it must produce.
    /// With `resume`, an existing journal of the same job is continued; without it, an existing
    /// journal is an error (nothing is silently thrown away).
    pub fn open(
        out: &Path,
        header: &str,
        fingerprint: &str,
        expected: &[usize],
        resume: bool,
    ) -> Result<Journal, StoreError> {
        let journal = journal_path(out);
        ensure_parent(out).map_err(io_err(out))?;
        let first = format!("{MAGIC} fingerprint={fingerprint}\n");
        let second = format!("index,{header}\n");
        let mut done = BTreeMap::new();
        let file = if journal.exists() {
            if !resume {
                return Err(StoreError::JournalExists {
                    journal: journal.display().to_string(),
                });
            }
            let text = fs::read(&journal).map_err(io_err(&journal))?;
            let good = parse(
                &text, &journal, &first, &second, header, expected, &mut done,
            )?;
            let f = OpenOptions::new()
                .write(true)
                .open(&journal)
                .map_err(io_err(&journal))?;
            // Drop a torn last line so appends start on a clean line.
            f.set_len(good as u64).map_err(io_err(&journal))?;
            let mut f = OpenOptions::new()
                .append(true)
                .open(&journal)
                .map_err(io_err(&journal))?;
            if good == 0 {
                f.write_all(format!("{first}{second}").as_bytes())
                    .map_err(io_err(&journal))?;
            }
            f
        } else {
            let mut f = File::create(&journal).map_err(io_err(&journal))?;
            f.write_all(format!("{first}{second}").as_bytes())
                .map_err(io_err(&journal))?;
            f
        };
        let mut expected = expected.to_vec();
        expected.sort_unstable();
        expected.dedup();
        Ok(Journal {
            out: out.to_path_buf(),
            journal,
            header: header.to_string(),
            expected,
            rows: Mutex::new((file, done)),
        })
    }

    /// Grid indices still to compute, ascending.
    pub fn pending(&self) -> Vec<usize> {
        let g = self.rows.lock().expect("journal lock");
        self.expected
            .iter()
            .copied()
            .filter(|i| !g.1.contains_key(i))
            .collect()
    }

    /// Rows already present (after a resume).
    pub fn done_count(&self) -> usize {
        self.rows.lock().expect("journal lock").1.len()
    }

    /// Append one finished row (CSV fields without the index, no newline). One `write` call, so
    /// a kill cannot interleave rows; a torn last row is dropped on resume.
    pub fn append(&self, index: usize, row: &str) -> Result<(), StoreError> {
        let line = format!("{index},{row}\n");
        let mut g = self.rows.lock().expect("journal lock");
        g.0.write_all(line.as_bytes())
            .map_err(io_err(&self.journal))?;
        g.1.insert(index, row.to_string());
        Ok(())
    }

    /// All rows sorted by grid index (for summaries and figures).
    pub fn rows(&self) -> Vec<(usize, String)> {
        let g = self.rows.lock().expect("journal lock");
        g.1.iter().map(|(i, r)| (*i, r.clone())).collect()
    }

    /// Write the final file sorted by grid index and remove the journal. Fails, leaving the
    /// journal in place, if rows are missing.
    pub fn finish(self) -> Result<PathBuf, StoreError> {
        let (file, rows) = self.rows.into_inner().expect("journal lock");
        file.sync_all().map_err(io_err(&self.journal))?;
        let missing = self
            .expected
            .iter()
            .filter(|i| !rows.contains_key(i))
            .count();
        if missing > 0 {
            return Err(StoreError::Incomplete {
                journal: self.journal.display().to_string(),
                missing,
                total: self.expected.len(),
            });
        }
        let mut text = String::with_capacity(64 * (rows.len() + 1));
        text.push_str(&self.header);
        text.push('\n');
        for i in &self.expected {
            text.push_str(&rows[i]);
            text.push('\n');
        }
        write_atomic(&self.out, text.as_bytes()).map_err(io_err(&self.out))?;
        fs::remove_file(&self.journal).map_err(io_err(&self.journal))?;
        Ok(self.out)
    }
}

/// Parse a journal; returns the byte length of its valid prefix (0 if even the preamble is torn).
fn parse(
    text: &[u8],
    path: &Path,
    first: &str,
    second: &str,
    header: &str,
    expected: &[usize],
    done: &mut BTreeMap<usize, String>,
) -> Result<usize, StoreError> {
    let name = path.display().to_string();
    let fields = header.split(',').count() + 1;
    let expected: std::collections::HashSet<usize> = expected.iter().copied().collect();
    let mut pos = 0usize;
    let mut line_no = 0usize;
    while pos < text.len() {
        let Some(nl) = text[pos..].iter().position(|&b| b == b'\n') else {
            break; // torn last line: dropped
        };
        let line = &text[pos..pos + nl];
        line_no += 1;
        let corrupt = |why: &str| StoreError::Corrupt {
            journal: name.clone(),
            line: line_no,
            why: why.to_string(),
        };
        let line = std::str::from_utf8(line).map_err(|_| corrupt("not UTF-8"))?;
        match line_no {
            1 => {
                if !line.starts_with(MAGIC) {
                    return Err(corrupt("not a vibrobar journal"));
                }
                let want = first.trim_end();
                if line != want {
                    return Err(StoreError::Mismatch {
                        journal: name,
                        found: line.rsplit('=').next().unwrap_or("").to_string(),
                        expected: want.rsplit('=').next().unwrap_or("").to_string(),
                    });
                }
            }
            2 => {
                if line != second.trim_end() {
                    return Err(corrupt("header differs from this run's"));
                }
            }
            _ => {
                if line.split(',').count() != fields {
                    return Err(corrupt("wrong number of fields"));
                }
                let (idx, row) = line.split_once(',').ok_or_else(|| corrupt("no index"))?;
                let idx: usize = idx.parse().map_err(|_| corrupt("bad index"))?;
                if !expected.contains(&idx) {
                    return Err(corrupt("index outside this job's grid"));
                }
                if let Some(prev) = done.insert(idx, row.to_string()) {
                    if prev != row {
                        return Err(corrupt("index written twice with different rows"));
                    }
                }
            }
        }
        pos += nl + 1;
    }
    Ok(if line_no >= 2 { pos } else { 0 })
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "a,b";

    fn row(i: usize) -> String {
        format!("{},{}", i as f64 * 0.5, (i as f64).sqrt())
    }

    fn run_all(out: &Path, order: &[usize], resume: bool) -> Journal {
        let j = Journal::open(out, HEADER, "abc", &(0..10).collect::<Vec<_>>(), resume).unwrap();
        for &i in order {
            j.append(i, &row(i)).unwrap();
        }
        j
    }

    #[test]
    fn final_file_is_sorted_and_journal_removed() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("o.csv");
        let j = run_all(&out, &[3, 1, 9, 0, 2, 8, 4, 7, 6, 5], false);
        j.finish().unwrap();
        let text = fs::read_to_string(&out).unwrap();
        let want: String = std::iter::once(HEADER.to_string())
            .chain((0..10).map(row))
            .map(|l| l + "\n")
            .collect();
        assert_eq!(text, want);
        assert!(!journal_path(&out).exists());
    }

    #[test]
    fn torn_last_row_is_dropped_and_resume_is_byte_identical() {
        let dir = tempfile::tempdir().unwrap();
        let full = dir.path().join("full.csv");
        run_all(&full, &(0..10).collect::<Vec<_>>(), false)
            .finish()
            .unwrap();
        let out = dir.path().join("o.csv");
        drop(run_all(&out, &[5, 2, 7], false));
        // Simulate a kill in the middle of a write.
        let mut f = OpenOptions::new()
            .append(true)
            .open(journal_path(&out))
            .unwrap();
        f.write_all(b"4,2.0,1.9").unwrap();
        drop(f);
        assert!(!out.exists(), "an interrupted run must not look complete");
        assert!(matches!(
            Journal::open(&out, HEADER, "abc", &(0..10).collect::<Vec<_>>(), false),
            Err(StoreError::JournalExists { .. })
        ));
        let j = Journal::open(&out, HEADER, "abc", &(0..10).collect::<Vec<_>>(), true).unwrap();
        assert_eq!(j.pending(), vec![0, 1, 3, 4, 6, 8, 9]);
        for i in j.pending() {
            j.append(i, &row(i)).unwrap();
        }
        j.finish().unwrap();
        assert_eq!(fs::read(&out).unwrap(), fs::read(&full).unwrap());
    }

    #[test]
    fn other_job_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("o.csv");
        drop(run_all(&out, &[1], false));
        let e = Journal::open(&out, HEADER, "zzz", &(0..10).collect::<Vec<_>>(), true);
        assert!(matches!(e, Err(StoreError::Mismatch { .. })));
    }

    #[test]
    fn damage_before_the_last_line_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("o.csv");
        drop(run_all(&out, &[1, 2], false));
        let jp = journal_path(&out);
        let text = fs::read_to_string(&jp)
            .unwrap()
            .replacen("1,0.5,1", "1,0.5", 1);
        fs::write(&jp, text).unwrap();
        let e = Journal::open(&out, HEADER, "abc", &(0..10).collect::<Vec<_>>(), true);
        assert!(
            matches!(e, Err(StoreError::Corrupt { line: 3, .. })),
            "{:?}",
            e.err()
        );
    }

    #[test]
    fn finish_with_missing_rows_keeps_the_journal() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("o.csv");
        let j = run_all(&out, &[1, 2], false);
        assert!(matches!(
            j.finish(),
            Err(StoreError::Incomplete {
                missing: 8,
                total: 10,
                ..
            })
        ));
        assert!(journal_path(&out).exists());
        assert!(!out.exists());
    }
}
