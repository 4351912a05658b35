//! Frequency sweeps: damped bar beside the solid bar, in parallel with rayon.

use super::{run_case, RunResult};
use crate::error::{ParamError, SimError};
use crate::params::{
    Bar, Damper, Forcing, Frequency, FrictionModel, RunSettings, State, System,
    STANDARD_GRAVITY_M_S2,
};
use crate::solver::Solver;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// `start + i·step` for `i = 0..=n`, where `n` is the number of whole steps to `stop` (inclusive,
/// with a tolerance of 1e-9 steps for the rounding of decimal input). Computed from `i`, so no
/// rounding drift builds up.
///
/// Input that [`checked_linspace_inclusive`] rejects (non-finite, `step ≤ 0`, `stop < start`,
/// more than [`MAX_GRID_POINTS`] points) gives an empty vector instead of a hang or an
/// out-of-memory abort; use the checked version to report why.
pub fn linspace_inclusive(start: f64, stop: f64, step: f64) -> Vec<f64> {
    checked_linspace_inclusive(start, stop, step).unwrap_or_default()
}

/// Largest grid [`checked_linspace_inclusive`] builds (defined in [`crate::limits`]).
pub const MAX_GRID_POINTS: usize = crate::limits::MAX_GRID_POINTS;

/// [`linspace_inclusive`] with an error naming the bad argument.
pub fn checked_linspace_inclusive(
    start: f64,
    stop: f64,
    step: f64,
) -> Result<Vec<f64>, ParamError> {
    crate::params::finite("grid.start", start)?;
    crate::params::finite("grid.stop", stop)?;
    crate::params::positive("grid.step", step)?;
    if stop < start {
        return Err(ParamError::OutOfRange {
            field: "grid.stop",
            value: stop,
            allowed: "[start, ∞)",
        });
    }
    let n = ((stop - start) / step + 1e-9).floor();
    if n >= MAX_GRID_POINTS as f64 {
        return Err(ParamError::OutOfRange {
            field: "grid.step",
            value: step,
            allowed: "[(stop − start)/1e7, ∞) (at most 1e7 points)",
        });
    }
    let n = n as i64;
    Ok((0..=n).map(|i| start + i as f64 * step).collect())
}

/// Parallel, order-preserving map with a progress callback `(done, total)`.
/// Results do not depend on the thread count: each item is computed independently.
pub fn par_map_with_progress<T, R, F>(
    items: &[T],
    f: F,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Vec<R>
where
    T: Sync,
    R: Send,
    F: Fn(&T) -> R + Sync,
{
    let done = AtomicUsize::new(0);
    let total = items.len();
    items
        .par_iter()
        .map(|it| {
            let r = f(it);
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
            r
        })
        .collect()
}

/// One point of a paper-style sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepPoint {
    /// Frequency ratio (against each bar's own `√(K/M)`).
    pub ratio: f64,
    /// Total clearance.
    pub gap_m: f64,
    /// Friction model.
    pub friction: FrictionModel,
    /// Override of the friction force level.
    pub friction_force_n: Option<f64>,
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

/// The bars, ball and forcing a sweep varies the points of.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepBase {
    /// Bar with the cavity.
    pub damped_bar: Bar,
    /// Reference bar without ball.
    pub solid_bar: Bar,
    /// Ball template; each point sets gap, friction model and friction override.
    pub ball: Damper,
    /// Forcing template; each point sets the frequency ratio.
    pub forcing: Forcing,
}

impl SweepBase {
    /// The paper's bars, ball and 15 N forcing.
    pub fn paper() -> Self {
        SweepBase {
            damped_bar: Bar::PAPER_CAVITY,
            solid_bar: Bar::PAPER_SOLID,
            ball: Damper::paper(1e-3, FrictionModel::None),
            forcing: Forcing::paper(1.0),
        }
    }

    /// The damped system of a point.
    pub fn damped_system(&self, p: &SweepPoint) -> System {
        System {
            bar: self.damped_bar,
            damper: Some(Damper {
                gap_m: p.gap_m,
                friction: p.friction,
                friction_force_n: p.friction_force_n,
                ..self.ball
            }),
            forcing: Forcing {
                frequency: Frequency::Ratio(p.ratio),
                ..self.forcing
            },
            gravity_m_s2: STANDARD_GRAVITY_M_S2,
        }
    }

    /// The solid-bar system at a ratio.
    pub fn solid_system(&self, ratio: f64) -> System {
        System {
            bar: self.solid_bar,
            damper: None,
            forcing: Forcing {
                frequency: Frequency::Ratio(ratio),
                ..self.forcing
            },
            gravity_m_s2: STANDARD_GRAVITY_M_S2,
        }
    }
}

/// Run a sweep: for each point the damped bar (with the ball) and the solid bar (no ball), each
/// forced at the point's ratio of its own natural frequency. Solid-bar runs are shared between
/// points with the same ratio. All runs start from rest with the ball centred.
pub fn sweep(
    points: &[SweepPoint],
    base: &SweepBase,
    settings: &RunSettings,
    solver: &dyn Solver,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<SweepRow>, SimError> {
    // Jobs: unique ratios for the solid bar, then every damped point.
    let mut ratios: Vec<f64> = points.iter().map(|p| p.ratio).collect();
    ratios.sort_by(f64::total_cmp);
    ratios.dedup();
    enum Job {
        Solid(f64),
        Damped(SweepPoint),
    }
    let jobs: Vec<Job> = ratios
        .iter()
        .map(|&r| Job::Solid(r))
        .chain(points.iter().map(|&p| Job::Damped(p)))
        .collect();
    let results = par_map_with_progress(
        &jobs,
        |job| match job {
            Job::Solid(r) => run_case(
                &base.solid_system(*r),
                &State::REST,
                settings,
                solver,
                &mut (),
            ),
            Job::Damped(p) => run_case(
                &base.damped_system(p),
                &State::REST,
                settings,
                solver,
                &mut (),
            ),
        },
        progress,
    );
    let mut results = results.into_iter();
    let mut solid = Vec::with_capacity(ratios.len());
    for _ in 0..ratios.len() {
        solid.push(results.next().expect("one result per job")?);
    }
    let mut rows = Vec::with_capacity(points.len());
    for p in points {
        let damped = results.next().expect("one result per job")?;
        let i = ratios
            .iter()
            .position(|r| r.total_cmp(&p.ratio).is_eq())
            .expect("ratio listed");
        rows.push(SweepRow {
            point: *p,
            solid: solid[i],
            damped,
        });
    }
    Ok(rows)
}
