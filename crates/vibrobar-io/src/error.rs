//! The one error type of the crate. Every variant names the file and, where a line or a count
//! went wrong, that number.

use std::path::PathBuf;

/// Errors of the persistence layer.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The operating system refused an operation on `path`.
    #[error("{}: {source}", path.display())]
    Os {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// An output is a directory or a special file where only a regular file will do.
    #[error("{}: {why}", path.display())]
    NotRegular {
        /// File as given.
        path: PathBuf,
        /// What it is and why that is refused.
        why: String,
    },
    /// An output is also one of the command's inputs.
    #[error("output {} is also an input ({}); writing it would destroy the input: choose another --out", out.display(), input.display())]
    OutputIsInput {
        /// Output as given.
        out: PathBuf,
        /// The input it is the same file as.
        input: PathBuf,
    },
    /// A journal exists and `--resume` was not given.
    #[error("{} holds an interrupted run of this output; rerun with --resume to complete it, or delete it to start over", journal.display())]
    JournalExists {
        /// Journal path.
        journal: PathBuf,
    },
    /// Another process is working on the same journal.
    #[error("{} is in use by another vibrobar process ({holder}); wait for it to finish or stop it", journal.display())]
    Locked {
        /// Journal path.
        journal: PathBuf,
        /// Who holds the lock (pid, host, start time), as the lock file says.
        holder: String,
    },
    /// The journal belongs to another job.
    #[error("{} was written for different parameters (fingerprint {found}, this run {expected}); use another --out or delete the journal", journal.display())]
    Mismatch {
        /// Journal path.
        journal: PathBuf,
        /// Fingerprint in the file.
        found: String,
        /// Fingerprint of this run.
        expected: String,
    },
    /// A line of a journal, shard or data file is damaged.
    #[error("{}: line {line} is damaged ({why}); the file cannot be used", path.display())]
    Corrupt {
        /// File.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        why: String,
    },
    /// A row of a whole file does not fit its schema (e.g. a NaN): the file is not written.
    #[error("{}: line {line} would not read back ({why}); the file was not written", path.display())]
    BadFileRow {
        /// Output file.
        path: PathBuf,
        /// 1-based line number the row would have had.
        line: usize,
        /// What is wrong.
        why: String,
    },
    /// A freshly computed row does not fit its schema (e.g. a NaN), so it is not stored.
    #[error("{}: the result row of grid index {index} is refused ({why})", path.display())]
    BadRow {
        /// Output file.
        path: PathBuf,
        /// Grid index.
        index: usize,
        /// What is wrong.
        why: String,
    },
    /// `finish` was called with rows missing.
    #[error("{missing} of {total} rows are missing; the output stays incomplete in {}", journal.display())]
    Incomplete {
        /// Journal path.
        journal: PathBuf,
        /// Rows missing.
        missing: usize,
        /// Rows expected.
        total: usize,
    },
    /// A streamed file received another number of rows than announced in its header.
    #[error("{}: {got} rows written, {expected} announced; the file was not kept", path.display())]
    RowCount {
        /// File.
        path: PathBuf,
        /// Rows announced.
        expected: usize,
        /// Rows written.
        got: usize,
    },
    /// Not an NPY file this crate can read.
    #[error("{}: not an f64 .npy file this tool can read ({why})", path.display())]
    NpyFormat {
        /// File.
        path: PathBuf,
        /// What was wrong.
        why: String,
    },
    /// Shape and data of an NPY array disagree.
    #[error("{}: shape {shape:?} needs {expected} values, got {got}", path.display())]
    NpyShape {
        /// File.
        path: PathBuf,
        /// Requested shape.
        shape: Vec<usize>,
        /// Product of the shape.
        expected: usize,
        /// Data length.
        got: usize,
    },
    /// A metadata file is missing a field or holds one of the wrong type.
    #[error("{}: {why}", path.display())]
    Metadata {
        /// The `.meta.json` file.
        path: PathBuf,
        /// What is wrong.
        why: String,
    },
    /// A measured FRF file (universal file or columns) that cannot be used: where and why.
    #[error("{}{}{why}", path.display(), if location.is_empty() { ": ".to_string() } else { format!(", {location}: ") })]
    FrfInput {
        /// File.
        path: PathBuf,
        /// Where in it: line, dataset and record, or byte offset (may be empty).
        location: String,
        /// What is wrong.
        why: String,
    },
    /// Bad `--shard` text.
    #[error("--shard must be K/N with whole numbers 1 ≤ K ≤ N, got {0:?}")]
    ShardSpec(String),
    /// The shards do not belong together or do not cover the grid.
    #[error("cannot merge: {0}")]
    Merge(String),
}

impl IoError {
    /// An OS error on `path`.
    pub fn os(path: &std::path::Path) -> impl FnOnce(std::io::Error) -> IoError + '_ {
        move |source| IoError::Os {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// Result with [`IoError`].
pub type Result<T, E = IoError> = std::result::Result<T, E>;
