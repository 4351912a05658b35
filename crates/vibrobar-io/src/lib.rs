//! # vibrobar-io
//!
//! Output storage that users can trust: atomic files, resumable row journals, JSON metadata,
//! NPY arrays, shards and merging. Everything that touches the file system for results lives here.

pub mod atomic;
pub mod csv;
pub mod journal;
pub mod meta;
pub mod npy;
pub mod shard;

pub use atomic::{partial_path, write_atomic, AtomicFile};
pub use journal::{Journal, StoreError};
pub use meta::{GridInfo, Metadata, ShardInfo};
