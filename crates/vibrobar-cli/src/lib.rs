//! # vibrobar-cli
//!
//! The command line of vibrobar, and only that: the subcommand table ([`app`]), argument types
//! ([`cli`]), scenario flags ([`scenario`]; the scenario type is `vibrobar-scenario`), progress bars ([`progress`]) and one module per
//! command ([`commands`]) that turns flags into calls of the other crates. The physics and the
//! batch runner are in `vibrobar-core`, result files (atomic writes, journals, CSV schemas, NPY,
//! metadata, shards) in `vibrobar-io`, the paper report and every figure in `vibrobar-report`.

#![warn(missing_docs)]

pub mod app;
pub mod cli;
pub mod commands;
pub mod progress;
pub mod scenario;

// The default solver is a fact of the scenario (its `[run] solver` default): one definition there.
pub use vibrobar_scenario::{default_solver, DEFAULT_SOLVER};

/// Version of this tool (the report crate's, the workspace's one version).
pub const VERSION: &str = vibrobar_report::VERSION;
