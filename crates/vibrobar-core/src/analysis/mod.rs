//! Analyses built on the observer protocol. They work with every solver.
//!
//! Module dependencies point one way (this file only declares and re-exports; no child imports
//! it): `case` (one run and its observers) and `grid` (ranges, axes, grids) are leaves; `batch`
//! (the batch runner: pool, cancellation, progress, solid runs shared per ratio) uses `case`;
//! `sweep` and `poincare` use `batch`; `regime` uses `poincare`; `map` uses `regime` and
//! `batch`; `placement` uses `regime`, `batch` and `case`; `ensemble` uses `map`; `lobes` is a leaf (receptances only); `lobes_frf` uses `lobes` (its root finder's pieces); `time_domain` uses `batch`, `lobes` and `regime`; `lobe_design` uses `time_domain`, `placement` and `batch`; `frf` uses `batch` and `case`; `variational` (the one variational layer, with each bar's arithmetic in `variational/lumped` and `variational/modal`) is used by `lyapunov_spectrum` and `orbit`; `two_plane` (ensembles of the bar that bends in two planes and its one-plane counterpart) uses `case` and `ensemble`. `scripts/module_deps.py` lists the edges.

pub mod batch;
pub mod case;
pub mod contact_test;
pub mod energy;
pub mod ensemble;
pub mod frf;
pub mod grid;
pub mod lobe_design;
pub mod lobes;
pub mod lobes_frf;
pub mod lyapunov;
pub mod lyapunov_spectrum;
pub mod map;
pub mod orbit;
pub mod placement;
pub mod poincare;
pub mod regime;
pub mod sweep;
pub mod time_domain;
pub mod two_plane;
pub mod two_plane_orbit;
pub mod variational;

/// The N-mode bar's side of the variational layer, under its own name too.
pub use variational::modal as variational_modal;

pub use batch::{par_map_with_progress, Batch, BatchError, Runner, SolidRatios, SweepBase};
pub use case::{run_case, ImpactCounter, RmsObserver, RunResult, Sampler};
pub use grid::{checked_linspace_inclusive, linspace_inclusive, MAX_GRID_POINTS};
pub use sweep::{sweep, SweepPoint, SweepRow};
