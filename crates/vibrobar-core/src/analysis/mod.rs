//! Analyses built on the observer protocol. They work with every solver.
//!
//! Module dependencies point one way: `case` (one run) ← `grid` ← `batch` (the batch runner:
//! pool, shared solid runs, cancellation, progress) ← `sweep`, `poincare` ← `regime` ← `map` ←
//! `ensemble`. This file only declares the modules and re-exports; no child imports it.

pub mod batch;
pub mod case;
pub mod energy;
pub mod ensemble;
pub mod grid;
pub mod lyapunov;
pub mod map;
pub mod poincare;
pub mod regime;
pub mod sweep;

pub use batch::{par_map_with_progress, Batch, BatchError, Runner, SweepBase};
pub use case::{run_case, ImpactCounter, RmsObserver, RunResult, Sampler};
pub use grid::{checked_linspace_inclusive, linspace_inclusive, MAX_GRID_POINTS};
pub use sweep::{sweep, SweepPoint, SweepRow};
