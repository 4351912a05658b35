//! A time history streamed to disk as the solver produces it, in constant memory: CSV (the
//! [`history_schema`]) or NPY (`FILE.npy`, shape `(rows, 7)`, same columns). The NPY header
//! needs the row count first, so the caller announces it ([`sample_count`] of the output grid)
//! and [`HistoryWriter::finish`] refuses a file whose count differs. Bytes are identical to the
//! whole-array writers ([`crate::csv::write_history_csv`], [`crate::npy::write_f64`]).

use crate::atomic::AtomicFile;
use crate::csv::{
    cutting_history_schema, cutting_history_values, history_schema, history_values, Schema, Value,
};
use crate::error::{IoError, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use vibrobar_core::solver::CutSample;
use vibrobar_core::State;

/// Columns of a history row.
pub const HISTORY_COLUMNS: usize = 7;
/// Columns of a cutting run's history row ([`crate::csv::cutting_history_schema`]).
pub const CUTTING_HISTORY_COLUMNS: usize = 10;

/// Samples on the grid `t0 + k·interval` (k = 0, 1, …) that are ≤ `t_end`, evaluated exactly
/// as the core's `Sampler` evaluates them (a run's last segment ends at `t_end`).
pub fn sample_count(t0_s: f64, interval_s: f64, t_end_s: f64) -> u64 {
    let at = |k: u64| t0_s + k as f64 * interval_s;
    let valid = interval_s > 0.0 && t_end_s >= t0_s && t_end_s.is_finite();
    if !valid {
        return u64::from(t_end_s >= t0_s);
    }
    let mut k = ((t_end_s - t0_s) / interval_s)
        .floor()
        .min(u64::MAX as f64 / 2.0) as u64;
    while k > 0 && at(k) > t_end_s {
        k -= 1;
    }
    while at(k + 1) <= t_end_s {
        k += 1;
    }
    k + 1
}

/// Whether `path` is written as NPY (by its extension).
pub fn is_npy(path: &Path) -> bool {
    path.extension().is_some_and(|e| e == "npy")
}

/// Streams history rows into an [`AtomicFile`].
pub struct HistoryWriter {
    file: AtomicFile,
    path: PathBuf,
    npy: bool,
    schema: Schema,
    expected: u64,
    rows: u64,
    line: String,
    error: Option<std::io::Error>,
}

impl HistoryWriter {
    /// Start `path` (NPY if it ends in `.npy`, else CSV) for `rows` rows.
    pub fn create(path: &Path, rows: u64) -> Result<HistoryWriter> {
        Self::create_with(path, rows, false)
    }

    /// Start `path` for `rows` rows of a cutting run ([`crate::csv::cutting_history_schema`];
    /// rows through [`HistoryWriter::push_cut`]) when `cutting`, else as [`HistoryWriter::create`].
    pub fn create_with(path: &Path, rows: u64, cutting: bool) -> Result<HistoryWriter> {
        let npy = is_npy(path);
        let schema = if cutting {
            cutting_history_schema()
        } else {
            history_schema()
        };
        let cols = schema.columns.len();
        let mut file = AtomicFile::create(path)?;
        let head = if npy {
            crate::npy::header(&[rows as usize, cols])
        } else {
            format!("{}\n", schema.header()).into_bytes()
        };
        let error = file.write_all(&head).err();
        Ok(HistoryWriter {
            file,
            path: path.to_path_buf(),
            npy,
            schema,
            expected: rows,
            rows: 0,
            line: String::with_capacity(160),
            error,
        })
    }

    /// Append one sample. The first write error is kept (and later samples dropped) until
    /// [`finish`](Self::finish) reports it, so an observer can call this without a `Result`.
    pub fn push(&mut self, s: &State) {
        if self.error.is_some() {
            return;
        }
        let v = history_values(s);
        let res = if self.npy {
            let mut b = [0u8; 8 * HISTORY_COLUMNS];
            for (chunk, x) in b.chunks_exact_mut(8).zip(v) {
                chunk.copy_from_slice(&x.to_le_bytes());
            }
            self.file.write_all(&b)
        } else {
            self.line.clear();
            self.schema.format_into(&v.map(Value::F), &mut self.line);
            self.line.push('\n');
            self.file.write_all(self.line.as_bytes())
        };
        match res {
            Ok(()) => self.rows += 1,
            Err(e) => self.error = Some(e),
        }
    }

    /// Append one sample of a cutting run (a writer from [`HistoryWriter::create_with`] with
    /// `cutting`).
    pub fn push_cut(&mut self, s: &State, c: &CutSample) {
        if self.error.is_some() {
            return;
        }
        debug_assert_eq!(self.schema.columns.len(), CUTTING_HISTORY_COLUMNS);
        let v = cutting_history_values(s, c);
        let res = if self.npy {
            let mut b = [0u8; 8 * CUTTING_HISTORY_COLUMNS];
            for (chunk, x) in b.chunks_exact_mut(8).zip(&v) {
                chunk.copy_from_slice(&x.f().to_le_bytes());
            }
            self.file.write_all(&b)
        } else {
            self.line.clear();
            self.schema.format_into(&v, &mut self.line);
            self.line.push('\n');
            self.file.write_all(self.line.as_bytes())
        };
        match res {
            Ok(()) => self.rows += 1,
            Err(e) => self.error = Some(e),
        }
    }

    /// Rows written so far.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Commit the file and return its row count. On a write error or a row count other than
    /// announced (NPY), the partial file is removed and the error names the file.
    pub fn finish(self) -> Result<u64> {
        if let Some(e) = self.error {
            let err = self.file.error(e);
            self.file.discard();
            return Err(err);
        }
        if self.npy && self.rows != self.expected {
            self.file.discard();
            return Err(IoError::RowCount {
                path: self.path,
                expected: self.expected as usize,
                got: self.rows as usize,
            });
        }
        self.file.commit()?;
        Ok(self.rows)
    }

    /// Give up (a failed run): remove the partial file.
    pub fn discard(self) {
        self.file.discard();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atomic::partial_path;
    use std::os::unix::fs::FileTypeExt;

    fn states(n: usize) -> Vec<State> {
        (0..n)
            .map(|i| State {
                t_s: i as f64 * 1e-5,
                u_m: (i as f64).sin() * 1e-5,
                du_m_s: 0.1 / (i as f64 + 1.0),
                v_m: -3e-6,
                dv_m_s: 0.0,
                cavity: None,
            })
            .collect()
    }

    #[test]
    fn streamed_files_equal_the_whole_array_writers() {
        let dir = tempfile::tempdir().unwrap();
        let s = states(257);
        let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.csv"));
        crate::csv::write_history_csv(&a, &s).unwrap();
        let mut w = HistoryWriter::create(&b, s.len() as u64).unwrap();
        s.iter().for_each(|x| w.push(x));
        assert_eq!(w.finish().unwrap(), 257);
        assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
        let (a, b) = (dir.path().join("a.npy"), dir.path().join("b.npy"));
        let flat: Vec<f64> = s.iter().flat_map(history_values).collect();
        crate::npy::write_f64(&a, &[s.len(), 7], &flat).unwrap();
        let mut w = HistoryWriter::create(&b, s.len() as u64).unwrap();
        s.iter().for_each(|x| w.push(x));
        w.finish().unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    }

    #[test]
    fn wrong_npy_row_count_keeps_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("h.npy");
        let mut w = HistoryWriter::create(&p, 5).unwrap();
        states(4).iter().for_each(|x| w.push(x));
        let e = w.finish().unwrap_err().to_string();
        assert!(e.contains("h.npy: 4 rows written, 5 announced"), "{e}");
        assert!(!p.exists() && !partial_path(&p).exists());
    }

    #[test]
    fn regression_npy_to_a_full_disk_names_the_file_and_leaves_no_partial() {
        // A FIFO whose reader has gone: every write fails (EPIPE), as on a full device. (Not
        // /dev/full: CI runs as root, and a regression would rename a file over it.)
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("pipe");
        crate::target::test_fifo(&p);
        let reader = {
            let p = p.clone();
            std::thread::spawn(move || drop(std::fs::File::open(p).unwrap()))
        };
        let mut w = HistoryWriter::create(&p, 100_000).unwrap();
        reader.join().unwrap();
        states(100_000).iter().for_each(|x| w.push(x));
        let e = w.finish().unwrap_err().to_string();
        assert!(e.contains("pipe"), "{e}");
        assert!(std::fs::symlink_metadata(&p).unwrap().file_type().is_fifo());
        assert!(!partial_path(&p).exists());
    }

    #[test]
    fn sample_count_matches_the_grid() {
        for (t0, dt, end) in [
            (0.0, 1e-5, 0.01),
            (0.0, 1e-6 * 10.0, 2.0),
            (0.0, 3e-6, 0.1),
            (0.5, 0.1, 0.5),
            (0.0, 0.3, 1.0),
        ] {
            let n = sample_count(t0, dt, end);
            let mut k = 0u64;
            while t0 + k as f64 * dt <= end {
                k += 1;
            }
            assert_eq!(n, k, "{t0} {dt} {end}");
        }
    }
}
