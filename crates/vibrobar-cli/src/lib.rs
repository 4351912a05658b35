//! # vibrobar-cli
//!
//! The command-line front end of vibrobar: the subcommand table ([`app`]), argument types
//! ([`cli`]), scenario files ([`scenario`]), figures ([`plot`]), the reproduction report
//! ([`report`]), design-map figures ([`figures`]), progress bars ([`progress`]) and one module
//! per command ([`commands`]). Result files (atomic writes, journals, CSV schemas, NPY, metadata,
//! shards) are written by `vibrobar-io`.
//! The physics is in `vibrobar-core`; this crate never re-implements it.

#![warn(missing_docs)]

pub mod app;
pub mod cli;
pub mod commands;
pub mod figures;
pub mod plot;
pub mod progress;
pub mod report;
pub mod scenario;

/// The default solver's name as a literal, so help texts can `concat!` it. Switching the default
/// solver is this one line.
#[macro_export]
macro_rules! default_solver {
    () => {
        "exact"
    };
}

/// Solver used when none is given.
pub const DEFAULT_SOLVER: &str = default_solver!();

/// Version of this tool, written into every report.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
