//! Frequency sweeps: damped bar beside the solid bar, through the batch runner.

use super::batch::{Batch, BatchError, Runner};
use super::case::{run_case, RunResult};
use crate::error::SimError;
use crate::params::RunSettings;
use crate::solver::Solver;
use serde::{Deserialize, Serialize};

pub use super::batch::{SweepBase, SweepPoint};
pub use super::grid::{checked_linspace_inclusive, linspace_inclusive, MAX_GRID_POINTS};

/// Frequency ratios (an inclusive range) and gaps of a sweep: the `[sweep]` section of a
/// scenario. Missing fields deserialise to [`SweepRange::paper`]; unknown fields are errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SweepRange {
    /// First ratio.
    pub ratio_start: f64,
    /// Last ratio (included).
    pub ratio_stop: f64,
    /// Ratio step.
    pub ratio_step: f64,
    /// Total clearances.
    pub gaps_m: Vec<f64>,
}

impl SweepRange {
    /// The paper's sweep: ratios 0.95 to 1.05 in steps of 0.01 (11 points), gaps 0.1 and 1.0 mm.
    pub fn paper() -> Self {
        SweepRange {
            ratio_start: 0.95,
            ratio_stop: 1.05,
            ratio_step: 0.01,
            gaps_m: vec![0.1e-3, 1.0e-3],
        }
    }
}

impl Default for SweepRange {
    fn default() -> Self {
        Self::paper()
    }
}

/// Result of one sweep point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepRow {
    /// The point.
    pub point: SweepPoint,
    /// Solid bar.
    pub solid: RunResult,
    /// Impact-damped bar.
    pub damped: RunResult,
}

impl SweepRow {
    /// `100·(1 − rms_damped / rms_solid)`: positive when the damper helps.
    pub fn reduction_pct(&self) -> f64 {
        100.0 * (1.0 - self.damped.rms_m / self.solid.rms_m)
    }
}

/// Run a sweep: for each point the damped bar (with the ball) and the solid bar (no ball), each
/// forced at the point's ratio of its own natural frequency, both from `base.init`. Solid-bar
/// runs are shared between points with the same ratio ([`Batch::run`]).
pub fn sweep(
    points: &[SweepPoint],
    base: &SweepBase,
    settings: &RunSettings,
    solver: &dyn Solver,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<SweepRow>, BatchError<SimError>> {
    let batch = Batch::new(base, settings, solver).on(Runner::default().with_progress(progress));
    batch.run(
        points,
        |p| p.ratio,
        |p, solid| {
            let damped = run_case(
                &base.damped_system(p),
                &base.init,
                settings,
                solver,
                &mut (),
            )?;
            Ok(SweepRow {
                point: *p,
                solid: *solid,
                damped,
            })
        },
    )
}
