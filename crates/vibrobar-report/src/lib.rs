//! # vibrobar-report
//!
//! What a person reads: the paper reproduction report (`REPORT.md`: claims, the rules that
//! decide each verdict, the tables), the paper's figures ([`plot`]) and the design-map heat maps
//! ([`figures`]). Plots use plotters without system libraries and an embedded DejaVu Sans.
//!
//! Inputs are the core's result types ([`vibrobar_core::analysis`]) and the tables read back by
//! `vibrobar-io`; files are published through `vibrobar-io`'s output policy. Nothing here runs a
//! simulation or parses a command line.

#![warn(missing_docs)]

pub mod figures;
pub mod plot;
pub mod report;

/// Version of this tool, written into every report.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
