//! Resumable row store for sweeps and maps.
//!
//! Rows are appended to `FILE.journal` as they finish (any order, one `write` call per row, so
//! a kill leaves at most one torn last line). The journal starts with a fingerprint of the job;
//! `--resume` accepts only a journal of the same job, drops a torn last line, and runs only the
//! missing grid indices. A new journal is created with its first row, so a job refused or
//! stopped before any row is done leaves no journal behind. When every row is in, the rows are written sorted by grid index to
//! `FILE` (atomically, via `FILE.partial`) and the journal is removed. So the final file is
//! byte-identical whether or not the run was interrupted, and no file that looks complete is
//! ever half written.

use crate::atomic::{ensure_parent, partial_path, write_atomic};
use crate::csv::Schema;
use crate::error::{IoError, Result};
use crate::lock::LockFile;
use crate::target::resolve_output;
use std::collections::BTreeMap;
use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

const MAGIC: &str = "# vibrobar journal v1";

/// `FILE.journal` for an output `FILE`.
pub fn journal_path(out: &Path) -> PathBuf {
    let mut name = out
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".journal");
    out.with_file_name(name)
}

/// The key columns a grid index must have: the text its row starts with (e.g. `0.95,0.1`).
pub type KeyFn<'a> = &'a (dyn Fn(usize) -> String + Sync);

/// An open journal for one output file. It holds the journal's lock until it is finished or
/// dropped, so two processes never work on one journal.
pub struct Journal {
    out: PathBuf,
    journal: PathBuf,
    schema: Schema,
    expected: Vec<usize>,
    /// The journal file (`None` until the first row of a new journal) and the rows done.
    rows: Mutex<(Option<File>, BTreeMap<usize, String>)>,
    /// Preamble of a journal not yet created.
    preamble: String,
    _open: Registered,
    _lock: LockFile,
}

/// Journals open in this process, for an interrupt handler to name ([`open_journals`]).
static OPEN: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Membership of [`OPEN`] for as long as a [`Journal`] lives.
struct Registered(PathBuf);

impl Registered {
    fn new(journal: &Path) -> Self {
        OPEN.lock()
            .unwrap_or_else(|p| p.into_inner())
            .push(journal.to_path_buf());
        Registered(journal.to_path_buf())
    }
}

impl Drop for Registered {
    fn drop(&mut self) {
        OPEN.lock()
            .unwrap_or_else(|p| p.into_inner())
            .retain(|p| p != &self.0);
    }
}

/// Journals this process has open that exist on disk (an interrupted job keeps them for
/// `--resume`).
pub fn open_journals() -> Vec<PathBuf> {
    let g = OPEN.lock().unwrap_or_else(|p| p.into_inner());
    g.iter().filter(|p| p.exists()).cloned().collect()
}

/// For a SIGINT/SIGTERM handler about to exit: remove the lock files of the open journals (this
/// process holds their locks; the kernel releases them with it, and a later holder would only
/// overwrite them) and return the journals kept for `--resume`.
pub fn close_for_exit() -> Vec<PathBuf> {
    let g = OPEN.lock().unwrap_or_else(|p| p.into_inner());
    for j in g.iter() {
        let _ = fs::remove_file(crate::lock::lock_path(j));
    }
    g.iter().filter(|p| p.exists()).cloned().collect()
}

/// Write the preamble to `journal.partial` and rename it into place, so that a journal exists
/// only with a whole preamble (a full disk leaves no empty journal that looks like progress).
fn create_journal(journal: &Path, preamble: &str) -> Result<File> {
    let partial = partial_path(journal);
    let mut f = crate::atomic::create_tracked(&partial)?;
    let res = (|| -> std::io::Result<()> {
        f.write_all(preamble.as_bytes())?;
        f.sync_all()?;
        fs::rename(&partial, journal)
    })();
    crate::atomic::forget(&partial);
    if let Err(e) = res {
        let _ = fs::remove_file(&partial);
        return Err(IoError::os(journal)(e));
    }
    OpenOptions::new()
        .append(true)
        .open(journal)
        .map_err(IoError::os(journal))
}

impl Journal {
    /// Open the journal of `out` for a job whose rows follow `schema`, identified by
    /// `fingerprint`, that must produce the grid indices `expected`; `key(i)` is the text of
    /// index `i`'s key columns. With `resume`, an existing journal of the same job is continued
    /// (every row is checked: field count, finite numbers, key matching its index); without it,
    /// an existing journal is an error (nothing is silently thrown away). Special files
    /// (devices, FIFOs) are refused: a journal needs a regular file beside it.
    pub fn open(
        out: &Path,
        schema: &Schema,
        fingerprint: &str,
        expected: &[usize],
        key: KeyFn,
        resume: bool,
    ) -> Result<Journal> {
        resolve_output(out)?.require_regular("a journaled map or sweep")?;
        let journal = journal_path(out);
        ensure_parent(out)?;
        let lock = LockFile::acquire(&journal)?;
        let header = schema.header();
        let first = format!("{MAGIC} fingerprint={fingerprint}\n");
        let second = format!("index,{header}\n");
        let mut done = BTreeMap::new();
        let preamble = format!("{first}{second}");
        let file = if journal.exists() {
            if !resume {
                return Err(IoError::JournalExists { journal });
            }
            let text = fs::read(&journal).map_err(IoError::os(&journal))?;
            let good = parse(
                &text, &journal, &first, &second, schema, expected, key, &mut done,
            )?;
            if good == 0 {
                Some(create_journal(&journal, &preamble)?)
            } else {
                let f = OpenOptions::new()
                    .write(true)
                    .open(&journal)
                    .map_err(IoError::os(&journal))?;
                // Drop a torn last line so appends start on a clean line.
                f.set_len(good as u64).map_err(IoError::os(&journal))?;
                Some(
                    OpenOptions::new()
                        .append(true)
                        .open(&journal)
                        .map_err(IoError::os(&journal))?,
                )
            }
        } else {
            // Created with the first row ([`Journal::append`]).
            None
        };
        let mut expected = expected.to_vec();
        expected.sort_unstable();
        expected.dedup();
        Ok(Journal {
            out: out.to_path_buf(),
            _open: Registered::new(&journal),
            journal,
            schema: schema.clone(),
            expected,
            rows: Mutex::new((file, done)),
            preamble,
            _lock: lock,
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

    /// Append one finished row (CSV fields without the index, no newline). The row is checked
    /// against the schema first (no NaN or inf reaches a result file). One `write` call, so a
    /// kill cannot interleave rows; a torn last row is dropped on resume.
    pub fn append(&self, index: usize, row: &str) -> Result<()> {
        if let Err(why) = self.schema.parse(row) {
            return Err(IoError::BadRow {
                path: self.out.clone(),
                index,
                why,
            });
        }
        let line = format!("{index},{row}\n");
        let mut g = self.rows.lock().expect("journal lock");
        if g.0.is_none() {
            g.0 = Some(create_journal(&self.journal, &self.preamble)?);
        }
        g.0.as_mut()
            .expect("journal created")
            .write_all(line.as_bytes())
            .map_err(IoError::os(&self.journal))?;
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
    pub fn finish(self) -> Result<PathBuf> {
        let Journal {
            out,
            journal,
            schema,
            expected,
            rows,
            _lock,
            _open,
            ..
        } = self;
        let (file, rows) = rows.into_inner().expect("journal lock");
        if let Some(file) = &file {
            file.sync_all().map_err(IoError::os(&journal))?;
        }
        let missing = expected.iter().filter(|i| !rows.contains_key(i)).count();
        if missing > 0 {
            return Err(IoError::Incomplete {
                journal,
                missing,
                total: expected.len(),
            });
        }
        let mut text = String::with_capacity(64 * (rows.len() + 1));
        text.push_str(&schema.header());
        text.push('\n');
        for i in &expected {
            text.push_str(&rows[i]);
            text.push('\n');
        }
        write_atomic(&out, text.as_bytes())?;
        if file.is_some() {
            fs::remove_file(&journal).map_err(IoError::os(&journal))?;
        }
        drop(_lock);
        Ok(out)
    }
}

/// Parse a journal; returns the byte length of its valid prefix (0 if even the preamble is torn).
#[allow(clippy::too_many_arguments)]
fn parse(
    text: &[u8],
    path: &Path,
    first: &str,
    second: &str,
    schema: &Schema,
    expected: &[usize],
    key: KeyFn,
    done: &mut BTreeMap<usize, String>,
) -> Result<usize> {
    let expected: std::collections::HashSet<usize> = expected.iter().copied().collect();
    let mut pos = 0usize;
    let mut line_no = 0usize;
    while pos < text.len() {
        let Some(nl) = text[pos..].iter().position(|&b| b == b'\n') else {
            break; // torn last line: dropped
        };
        let line = &text[pos..pos + nl];
        line_no += 1;
        let corrupt = |why: String| IoError::Corrupt {
            path: path.to_path_buf(),
            line: line_no,
            why,
        };
        let line = std::str::from_utf8(line).map_err(|_| corrupt("not UTF-8".into()))?;
        match line_no {
            1 => {
                if !line.starts_with(MAGIC) {
                    return Err(corrupt("not a vibrobar journal".into()));
                }
                let want = first.trim_end();
                if line != want {
                    return Err(IoError::Mismatch {
                        journal: path.to_path_buf(),
                        found: line.rsplit('=').next().unwrap_or("").to_string(),
                        expected: want.rsplit('=').next().unwrap_or("").to_string(),
                    });
                }
            }
            2 => {
                if line != second.trim_end() {
                    return Err(corrupt("header differs from this run's".into()));
                }
            }
            _ => {
                let (idx, row) = line
                    .split_once(',')
                    .ok_or_else(|| corrupt("no index".into()))?;
                schema.parse(row).map_err(corrupt)?;
                let idx: usize = idx
                    .parse()
                    .map_err(|_| corrupt(format!("bad index {idx:?}")))?;
                if !expected.contains(&idx) {
                    return Err(corrupt(format!("index {idx} outside this job's grid")));
                }
                let k = key(idx);
                if row.len() <= k.len() || !row.starts_with(&k) || row.as_bytes()[k.len()] != b',' {
                    return Err(corrupt(format!(
                        "index {idx} is the grid point {k}, but the row is at {}",
                        row.split(',')
                            .take(k.split(',').count())
                            .collect::<Vec<_>>()
                            .join(",")
                    )));
                }
                if let Some(prev) = done.insert(idx, row.to_string()) {
                    if prev != row {
                        return Err(corrupt(format!(
                            "index {idx} written twice with different rows"
                        )));
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
    use crate::csv::{Column, Format};

    const HEADER: &str = "a,b";

    fn schema() -> Schema {
        Schema {
            columns: vec![
                Column {
                    name: "a".into(),
                    format: Format::Plain,
                    optional: false,
                },
                Column {
                    name: "b".into(),
                    format: Format::Plain,
                    optional: false,
                },
            ],
        }
    }

    fn key(i: usize) -> String {
        format!("{}", i as f64 * 0.5)
    }

    fn row(i: usize) -> String {
        format!("{},{}", i as f64 * 0.5, (i as f64).sqrt())
    }

    fn open(out: &Path, fp: &str, resume: bool) -> Result<Journal> {
        Journal::open(
            out,
            &schema(),
            fp,
            &(0..10).collect::<Vec<_>>(),
            &key,
            resume,
        )
    }

    fn run_all(out: &Path, order: &[usize], resume: bool) -> Journal {
        let j = open(out, "abc", resume).unwrap();
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
        assert!(!crate::lock::lock_path(&journal_path(&out)).exists());
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
            open(&out, "abc", false),
            Err(IoError::JournalExists { .. })
        ));
        let j = open(&out, "abc", true).unwrap();
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
        let e = open(&out, "zzz", true);
        assert!(matches!(e, Err(IoError::Mismatch { .. })));
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
        let e = open(&out, "abc", true);
        assert!(
            matches!(e, Err(IoError::Corrupt { line: 3, .. })),
            "{:?}",
            e.err()
        );
    }

    /// Edit line 4 of a journal holding rows 1, 2, 3 and return the resume error.
    fn resume_after_edit(from: &str, to: &str) -> String {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("o.csv");
        drop(run_all(&out, &[1, 2, 3], false));
        let jp = journal_path(&out);
        let text = fs::read_to_string(&jp).unwrap();
        assert!(text.contains(from), "{text}");
        fs::write(&jp, text.replacen(from, to, 1)).unwrap();
        let e = open(&out, "abc", true).err().expect("refused").to_string();
        assert!(e.contains("o.csv.journal: line 4"), "{e}");
        e
    }

    #[test]
    fn regression_nan_edited_into_a_journal_row_is_refused_with_its_line() {
        let e = resume_after_edit("2,1,1.4142135623730951", "2,1,NaN");
        assert!(e.contains("b = NaN is not a finite number"), "{e}");
        let e = resume_after_edit("2,1,1.4142135623730951", "2,1,-inf");
        assert!(e.contains("not a finite number"), "{e}");
    }

    #[test]
    fn regression_journal_index_not_matching_its_coordinates_is_refused() {
        // Row of grid point 3 filed under index 2: the map would lose 2 and double 3.
        let e = resume_after_edit("2,1,1.4142135623730951", "2,1.5,1.7320508075688772");
        assert!(
            e.contains("index 2 is the grid point 1, but the row is at 1.5"),
            "{e}"
        );
    }

    #[test]
    fn regression_nan_result_row_is_not_journaled() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("o.csv");
        let j = open(&out, "abc", false).unwrap();
        let e = j.append(4, "2,NaN").unwrap_err().to_string();
        assert!(e.contains("grid index 4") && e.contains("NaN"), "{e}");
        assert_eq!(j.done_count(), 0);
    }

    #[test]
    fn regression_second_process_on_one_journal_is_told_who_holds_it() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("o.csv");
        let first = run_all(&out, &[1], false);
        let e = open(&out, "abc", true).err().expect("locked").to_string();
        assert!(
            e.contains("in use by another vibrobar process")
                && e.contains(&format!("pid {}", std::process::id())),
            "{e}"
        );
        drop(first);
        // Released on drop (as on exit or a kill: the kernel drops the lock with the process).
        let j = open(&out, "abc", true).unwrap();
        assert_eq!(j.done_count(), 1);
    }

    #[test]
    fn regression_journal_of_a_special_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        crate::target::test_fifo(&fifo);
        let e = open(&fifo, "abc", false)
            .err()
            .expect("refused")
            .to_string();
        assert!(e.contains("is a FIFO"), "{e}");
        assert!(!journal_path(&fifo).exists());
    }

    #[test]
    fn finish_with_missing_rows_keeps_the_journal() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("o.csv");
        let j = run_all(&out, &[1, 2], false);
        assert!(matches!(
            j.finish(),
            Err(IoError::Incomplete {
                missing: 8,
                total: 10,
                ..
            })
        ));
        assert!(journal_path(&out).exists());
        assert!(!out.exists());
    }
}
