//! # vibrobar-io
//!
//! Persistence of vibrobar results that users can trust: atomic files ([`atomic`]) under one
//! output-path policy ([`target`]: links followed, devices and FIFOs written through, outputs
//! that are inputs refused), resumable row journals with a lock ([`journal`], [`lock`]), CSV
//! schemas defined once ([`csv`]), time histories streamed in constant memory ([`history`]),
//! NPY arrays ([`npy`]), measured FRFs in and out ([`frf`]: universal files, [`uff`], and plain columns), typed JSON metadata ([`meta`], [`params`]), shards and merging ([`shard`]).
//! No command line, no progress bars, no physics: the types stored come from `vibrobar-core`.

#![warn(missing_docs)]

pub mod atomic;
pub mod csv;
pub mod error;
pub mod frf;
pub mod frf_csv;
pub mod history;
pub mod journal;
pub mod lock;
pub mod meta;
pub mod npy;
pub mod params;
pub mod shard;
pub mod target;
pub mod two_plane_csv;
pub mod uff;

pub use atomic::{
    close_for_exit, ensure_parent, partial_path, publish, remove_live_partials, track_partial,
    write_atomic, write_with, AtomicFile,
};
pub use error::IoError;
pub use journal::Journal;
pub use meta::{GridInfo, Metadata, ShardInfo};
pub use target::{
    check_not_input, refuse_input, register_input, resolve_output, Output, OutputKind,
};
