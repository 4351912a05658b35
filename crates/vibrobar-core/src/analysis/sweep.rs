//! Frequency sweeps: damped bar beside the solid bar, through the batch runner.

use super::batch::{Batch, BatchError, Runner};
use super::case::{run_one, Case, RunResult};
use crate::error::SimError;
use crate::params::RunSettings;
use crate::solver::Solver;
use serde::{Deserialize, Serialize};

pub use super::batch::{SolidRatios, SweepBase, SweepPoint};
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

/// Result of one sweep point: a row of the sweep table.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepRow {
    /// The point.
    pub point: SweepPoint,
    /// Name of the solver that ran it.
    pub solver: String,
    /// Solid bar.
    pub solid: RunResult,
    /// Impact-damped bar.
    pub damped: RunResult,
    /// Friction work in the damped run, J (0 unless the run was audited).
    pub friction_work_j: f64,
}

impl SweepRow {
    /// `100·(1 − rms_damped / rms_solid)`: positive when the damper helps.
    pub fn reduction_pct(&self) -> f64 {
        100.0 * (1.0 - self.damped.rms_m / self.solid.rms_m)
    }
}

/// A damped run of a sweep failed: which point, and what the solver said.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("run at ratio {:.4}, gap {} mm failed: {source}", point.ratio, point.gap_m * 1e3)]
pub struct PointFailed {
    /// The point.
    pub point: SweepPoint,
    /// The error.
    pub source: SimError,
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
) -> Result<Vec<SweepRow>, BatchError<PointFailed>> {
    sweep_audited(
        points,
        base,
        settings,
        solver,
        Runner::default().with_progress(progress),
        false,
    )
}

/// [`sweep`] on a given runner; with `energy_audit` every damped run carries the energy audit
/// and its friction work goes into the row (the audit observes the run, it does not change it).
pub fn sweep_audited(
    points: &[SweepPoint],
    base: &SweepBase,
    settings: &RunSettings,
    solver: &dyn Solver,
    runner: Runner<'_>,
    energy_audit: bool,
) -> Result<Vec<SweepRow>, BatchError<PointFailed>> {
    sweep_audited_at(
        points,
        &SolidRatios::default(),
        base,
        settings,
        solver,
        runner,
        energy_audit,
    )
}

/// [`sweep_audited`] with the solid bar at `solid.of(ratio)` of each point (both bars at one
/// `Ω` for a sweep in absolute frequencies, [`SolidRatios::at_hz`]).
pub fn sweep_audited_at(
    points: &[SweepPoint],
    solid: &SolidRatios,
    base: &SweepBase,
    settings: &RunSettings,
    solver: &dyn Solver,
    runner: Runner<'_>,
    energy_audit: bool,
) -> Result<Vec<SweepRow>, BatchError<PointFailed>> {
    Batch::new(base, settings, solver).on(runner).run(
        points,
        |p| solid.of(p.ratio),
        |p, solid| {
            let case = Case {
                system: base.damped_system(p),
                init: base.init,
                sample_interval_s: None,
                energy_audit,
            };
            let damped = run_one(&case, settings, solver)
                .map_err(|source| PointFailed { point: *p, source })?;
            Ok(SweepRow {
                point: *p,
                solver: solver.name().to_string(),
                solid: *solid,
                damped: damped.result,
                friction_work_j: damped.friction_work_j,
            })
        },
    )
}
