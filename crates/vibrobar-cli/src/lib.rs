//! # vibrobar-cli
//!
//! The command-line front end of vibrobar. Everything with I/O lives here: argument parsing
//! ([`cli`]), scenario files ([`scenario`]), CSV/JSON writers ([`output`]), figures ([`plot`]),
//! the reproduction report ([`report`]) and one module per command ([`commands`]).
//! The physics is in `vibrobar-core`; this crate never re-implements it.

#![warn(missing_docs)]

pub mod cli;
pub mod commands;
pub mod output;
pub mod plot;
pub mod report;
pub mod scenario;

/// Solver used when none is given. One constant, so switching the default is a one-line change.
pub const DEFAULT_SOLVER: &str = "rk4";

/// Version of this tool, written into every report.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
