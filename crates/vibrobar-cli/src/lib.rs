//! # vibrobar-cli
//!
//! The command-line front end of vibrobar. Everything with I/O lives here: the subcommand table
//! ([`app`]), argument types ([`cli`]), scenario files ([`scenario`]), CSV/JSON writers
//! ([`output`]), figures ([`plot`]), the reproduction report ([`report`]), design-map figures
//! ([`figures`]), progress bars ([`progress`]), result storage (atomic files, journals, NPY,
//! shards: [`store`]) and one module per command ([`commands`]).
//! The physics is in `vibrobar-core`; this crate never re-implements it.

#![warn(missing_docs)]

pub mod app;
pub mod cli;
pub mod commands;
pub mod figures;
pub mod output;
pub mod plot;
pub mod progress;
pub mod report;
pub mod scenario;
pub mod store;

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
