//! The batch runner: every analysis that runs many cases (sweeps, maps, and later placement,
//! ensembles, time-domain lobes, Python and cluster front ends) calls it and only stores its rows.
//!
//! The runner owns the loop over the points, the thread pool (rayon), cancellation and the progress
//! callback. It runs the solid (no-ball) reference bar once per distinct frequency ratio, then
//! hands each point and the solid result at its ratio to the caller's damped job. Every run is
//! independent and results come back in the order of the points, so they do not depend on the
//! thread count.

use super::case::{run_case, RunResult};
use crate::error::{ParamError, SimError};
use crate::params::{
    Bar, BarModel, Damper, Forcing, Frequency, FrictionModel, RunSettings, State, System,
    STANDARD_GRAVITY_M_S2,
};
use crate::solver::Solver;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

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
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepPoint {
    /// Frequency ratio (against each bar's own `ω₁`: `√(K/M)` of a lumped bar).
    pub ratio: f64,
    /// Total clearance.
    pub gap_m: f64,
    /// Friction model.
    pub friction: FrictionModel,
    /// Override of the friction force level.
    pub friction_force_n: Option<f64>,
}

/// Everything fixed across a batch: the bars, the ball and forcing templates the points vary,
/// gravity and the initial state of every run. Deserialised with missing fields from
/// [`SweepBase::paper`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SweepBase {
    /// Bar with the cavity (lumped, or a beam's modes with the ball at the cavity).
    pub damped_bar: BarModel,
    /// Reference bar without ball (a beam: the same bar without the cavity section; its own
    /// `ω₁`, so a ratio is `Ω/ω₁` of each bar).
    pub solid_bar: BarModel,
    /// Ball template; each point sets gap, friction model and friction override.
    pub ball: Damper,
    /// Forcing template; each point sets the frequency ratio.
    pub forcing: Forcing,
    /// Gravity for the derived friction force.
    pub gravity_m_s2: f64,
    /// Initial state of every run (solid and damped; the paper: at rest, ball centred).
    pub init: State,
}

impl Default for SweepBase {
    fn default() -> Self {
        Self::paper()
    }
}

impl SweepBase {
    /// The paper's bars, ball and 15 N forcing, from rest.
    pub fn paper() -> Self {
        SweepBase {
            damped_bar: Bar::PAPER_CAVITY.into(),
            solid_bar: Bar::PAPER_SOLID.into(),
            ball: Damper::paper(1e-3, FrictionModel::None),
            forcing: Forcing::paper(1.0),
            gravity_m_s2: STANDARD_GRAVITY_M_S2,
            init: State::REST,
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
            gravity_m_s2: self.gravity_m_s2,
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
            gravity_m_s2: self.gravity_m_s2,
        }
    }
}

/// The solid bar's ratio of each damped ratio of a job. In ratios (the default, empty) each
/// bar runs at its own `Ω/ω₁`, so the solid ratio is the damped one; in absolute frequencies
/// ([`SolidRatios::at_hz`]) both bars run at the same `Ω`, so the solid bar runs at
/// `Ω/ω₁,solid` while the points (and the `ratio` column) hold `Ω/ω₁,damped`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SolidRatios(std::collections::BTreeMap<u64, f64>);

impl SolidRatios {
    /// Both bars at the forcing frequencies `freqs_hz` (`Ω = 2πf`): the damped bar's ratios, in
    /// the order given, and the solid bar's ratio of each. Two frequencies too close to give
    /// distinct damped ratios are refused, naming `field`.
    pub fn at_hz(
        base: &SweepBase,
        freqs_hz: &[f64],
        field: &'static str,
    ) -> Result<(Vec<f64>, SolidRatios), ParamError> {
        let omega = |f: f64| 2.0 * std::f64::consts::PI * f;
        let mut ratios = Vec::with_capacity(freqs_hz.len());
        let mut solid = std::collections::BTreeMap::new();
        for &f in freqs_hz {
            let r = omega(f) / base.damped_bar.omega1_rad_s();
            if solid
                .insert(r.to_bits(), omega(f) / base.solid_bar.omega1_rad_s())
                .is_some()
            {
                return Err(ParamError::OutOfRange {
                    field,
                    value: f,
                    allowed: "distinct frequencies, each a distinct ratio Ω/ω₁ (use a larger STEP)",
                });
            }
            ratios.push(r);
        }
        Ok((ratios, SolidRatios(solid)))
    }

    /// True for a job in absolute frequencies.
    pub fn is_hz(&self) -> bool {
        !self.0.is_empty()
    }

    /// The solid bar's ratio at the damped ratio `ratio` (`ratio` itself in ratios, or for a
    /// ratio not given to [`SolidRatios::at_hz`]).
    pub fn of(&self, ratio: f64) -> f64 {
        self.0.get(&ratio.to_bits()).copied().unwrap_or(ratio)
    }
}

/// Why a batch stopped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BatchError<E> {
    /// The solid bar failed at a ratio.
    #[error("solid bar at ratio {ratio}: {source}")]
    Solid {
        /// The ratio.
        ratio: f64,
        /// What the run said.
        source: SimError,
    },
    /// The caller's job failed at a point.
    #[error(transparent)]
    Point(E),
    /// The cancel flag was raised; rows finished before it are kept by the caller's job.
    #[error("cancelled after {done} of {total} runs")]
    Cancelled {
        /// Runs finished.
        done: usize,
        /// Runs in the batch.
        total: usize,
    },
    /// No thread pool of the requested size.
    #[error("threads: {0}")]
    Threads(String),
    /// Invalid input (of the runner, or checked before any run).
    #[error(transparent)]
    Param(#[from] ParamError),
}

/// The runner's controls: the thread pool, cancellation and the progress callback. It runs
/// independent jobs in parallel ([`Runner::each`]); [`Batch`] adds the solid runs shared per
/// ratio on top of it.
#[derive(Clone, Copy)]
pub struct Runner<'a> {
    /// Worker threads: `None` uses rayon's global pool (`RAYON_NUM_THREADS`).
    pub threads: Option<usize>,
    /// Raised from outside (e.g. on SIGINT) to stop before the next run.
    pub cancel: Option<&'a AtomicBool>,
    /// `(done, total)` over every run (for a [`Batch`], solid runs first).
    pub progress: &'a (dyn Fn(usize, usize) + Sync),
}

impl Default for Runner<'_> {
    /// Rayon's global pool, no cancellation, no progress.
    fn default() -> Self {
        Runner {
            threads: None,
            cancel: None,
            progress: &|_, _| {},
        }
    }
}

impl<'a> Runner<'a> {
    /// With a progress callback.
    pub fn with_progress(self, progress: &'a (dyn Fn(usize, usize) + Sync)) -> Self {
        Runner { progress, ..self }
    }

    /// On a pool of `threads` workers (`None`: rayon's global pool).
    pub fn with_threads(self, threads: Option<usize>) -> Self {
        Runner { threads, ..self }
    }

    /// Stopped by `cancel`.
    pub fn with_cancel(self, cancel: &'a AtomicBool) -> Self {
        Runner {
            cancel: Some(cancel),
            ..self
        }
    }

    /// Run `job` for every item in parallel; results in the order of `items`, independent of
    /// the thread count. The first failure (in item order among those that ran) stops the
    /// batch: jobs not yet started are skipped; so does a raised cancel flag.
    pub fn each<T, R, E>(
        &self,
        items: &[T],
        job: impl Fn(&T) -> Result<R, E> + Sync,
    ) -> Result<Vec<R>, BatchError<E>>
    where
        T: Sync,
        R: Send,
        E: Send,
    {
        self.in_pool(|| {
            let failed = AtomicBool::new(false);
            self.phase(items, 0, items.len(), &failed, &job)
                .map_err(|(e, done)| match e {
                    Some(e) => BatchError::Point(e),
                    None => BatchError::Cancelled {
                        done,
                        total: items.len(),
                    },
                })
        })
    }

    /// `f` on the requested pool: `threads` workers, or rayon's global pool.
    fn in_pool<R: Send, E: Send>(
        &self,
        f: impl FnOnce() -> Result<R, BatchError<E>> + Send,
    ) -> Result<R, BatchError<E>> {
        match self.threads {
            None => f(),
            Some(n) => rayon::ThreadPoolBuilder::new()
                .num_threads(crate::limits::check_count(
                    "threads (--threads)",
                    n,
                    1,
                    crate::limits::MAX_THREADS,
                    "",
                )?)
                .build()
                .map_err(|e| BatchError::Threads(e.to_string()))?
                .install(f),
        }
    }

    /// One parallel phase: `f` on every item, in order, progress counted from `offset` of
    /// `total`. A failure sets `failed`, after which (or after a raised cancel flag) items not yet
    /// started are skipped. Errors: `(Some(e), index)` for the first failing item in order,
    /// `(None, finished)` when items were skipped without a failure.
    fn phase<T: Sync, R: Send, E: Send>(
        &self,
        items: &[T],
        offset: usize,
        total: usize,
        failed: &AtomicBool,
        f: impl Fn(&T) -> Result<R, E> + Sync,
    ) -> Result<Vec<R>, (Option<E>, usize)> {
        let stop = || {
            failed.load(Ordering::Relaxed) || self.cancel.is_some_and(|c| c.load(Ordering::Relaxed))
        };
        let results = par_map_with_progress(
            items,
            |it| {
                if stop() {
                    return None;
                }
                let r = f(it);
                if r.is_err() {
                    failed.store(true, Ordering::Relaxed);
                }
                Some(r)
            },
            &|d, _| (self.progress)(offset + d, total),
        );
        let mut out = Vec::with_capacity(items.len());
        let mut skipped = false;
        for (i, r) in results.into_iter().enumerate() {
            match r {
                Some(Ok(r)) => out.push(r),
                Some(Err(e)) => return Err((Some(e), i)),
                None => skipped = true,
            }
        }
        if skipped {
            return Err((None, out.len()));
        }
        Ok(out)
    }
}

/// A batch of damped runs beside solid (no-ball) runs shared per frequency ratio, on a
/// [`Runner`].
#[derive(Clone, Copy)]
pub struct Batch<'a> {
    /// Bars, ball and forcing templates, gravity and initial state.
    pub base: &'a SweepBase,
    /// Duration, step and RMS window of every run.
    pub settings: &'a RunSettings,
    /// The solver.
    pub solver: &'a dyn Solver,
    /// Pool, cancellation and progress.
    pub runner: Runner<'a>,
}

impl<'a> Batch<'a> {
    /// A batch on the default [`Runner`] (global pool, no cancellation, no progress).
    pub fn new(base: &'a SweepBase, settings: &'a RunSettings, solver: &'a dyn Solver) -> Self {
        Batch {
            base,
            settings,
            solver,
            runner: Runner::default(),
        }
    }

    /// On another runner.
    pub fn on(self, runner: Runner<'a>) -> Self {
        Batch { runner, ..self }
    }

    /// The solid bar at `ratio`, from the base's initial state. It is the reference of every
    /// reduction, so an RMS of 0 (a bar that does not move) is an error, not a 0/0 later.
    pub fn solid(&self, ratio: f64) -> Result<RunResult, SimError> {
        let r = run_case(
            &self.base.solid_system(ratio),
            &self.base.init,
            self.settings,
            self.solver,
            &mut (),
        )?;
        crate::limits::reference_rms(r.rms_m)?;
        Ok(r)
    }

    /// The ratios the solid bar runs at for `points`: each distinct `ratio(p)` once, ascending.
    pub fn distinct_ratios<P>(&self, points: &[P], ratio: impl Fn(&P) -> f64) -> Vec<f64> {
        let mut ratios: Vec<f64> = points.iter().map(ratio).collect();
        ratios.sort_by(f64::total_cmp);
        ratios.dedup_by(|a, b| a.total_cmp(b).is_eq());
        ratios
    }

    /// Run the solid bar once per distinct `ratio(p)` of `points`, then `damped(p, solid)` for
    /// every point, where `solid` is the solid run at the point's ratio. Rows come back in the
    /// order of `points`; failures and cancellation as in [`Runner::each`].
    pub fn run<P, R, E>(
        &self,
        points: &[P],
        ratio: impl Fn(&P) -> f64 + Sync,
        damped: impl Fn(&P, &RunResult) -> Result<R, E> + Sync,
    ) -> Result<Vec<R>, BatchError<E>>
    where
        P: Sync,
        R: Send,
        E: Send,
    {
        let run = &self.runner;
        run.in_pool(|| {
            let ratios = self.distinct_ratios(points, &ratio);
            let n_solid = ratios.len();
            let total = n_solid + points.len();
            let failed = AtomicBool::new(false);
            let solid = run
                .phase(&ratios, 0, total, &failed, |&r| self.solid(r))
                .map_err(|(e, i)| match e {
                    Some(source) => BatchError::Solid {
                        ratio: ratios[i],
                        source,
                    },
                    None => BatchError::Cancelled { done: i, total },
                })?;
            run.phase(points, n_solid, total, &failed, |p| {
                let r = ratio(p);
                let i = ratios
                    .binary_search_by(|x| x.total_cmp(&r))
                    .expect("every ratio has its solid run");
                damped(p, &solid[i])
            })
            .map_err(|(e, done)| match e {
                Some(e) => BatchError::Point(e),
                None => BatchError::Cancelled {
                    done: n_solid + done,
                    total,
                },
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::Rk4;

    fn short() -> RunSettings {
        RunSettings {
            duration_s: 0.01,
            dt_s: 1e-5,
            rms_fraction: 0.5,
        }
    }

    #[test]
    fn solid_runs_are_shared_per_ratio_and_rows_keep_the_point_order() {
        let base = SweepBase::paper();
        let st = short();
        let solver = Rk4 { dt_s: 1e-5 };
        let points = [1.0, 0.95, 1.0, 0.95, 1.05];
        let solid_calls = AtomicUsize::new(0);
        let batch = Batch::new(&base, &st, &solver);
        let rows = batch
            .run(
                &points,
                |&r| r,
                |&r, s| -> Result<_, SimError> {
                    solid_calls.fetch_add(1, Ordering::Relaxed);
                    Ok((r, s.rms_m))
                },
            )
            .unwrap();
        assert_eq!(solid_calls.into_inner(), 5);
        for (&(r, rms), &p) in rows.iter().zip(&points) {
            assert_eq!(r.to_bits(), p.to_bits());
            assert_eq!(rms.to_bits(), batch.solid(p).unwrap().rms_m.to_bits());
        }
    }

    #[test]
    fn a_raised_cancel_flag_stops_before_any_run() {
        let base = SweepBase::paper();
        let st = short();
        let solver = Rk4 { dt_s: 1e-5 };
        let cancel = AtomicBool::new(true);
        let batch = Batch::new(&base, &st, &solver).on(Runner::default().with_cancel(&cancel));
        let e = batch
            .run(
                &[1.0, 0.9],
                |&r| r,
                |_, _| -> Result<(), SimError> { Ok(()) },
            )
            .unwrap_err();
        assert_eq!(e, BatchError::Cancelled { done: 0, total: 4 });
    }

    #[test]
    fn the_first_failing_point_is_reported_and_zero_threads_is_refused() {
        let base = SweepBase::paper();
        let st = short();
        let solver = Rk4 { dt_s: 1e-5 };
        let batch = Batch::new(&base, &st, &solver).on(Runner::default().with_threads(Some(1)));
        let e = batch
            .run(
                &[1.0, 2.0, 3.0],
                |&r| r,
                |&r, _| if r >= 2.0 { Err(r) } else { Ok(r) },
            )
            .unwrap_err();
        assert_eq!(e, BatchError::Point(2.0));
        let zero = batch.on(Runner::default().with_threads(Some(0)));
        let e = zero
            .run(&[1.0], |&r| r, |&r, _| -> Result<f64, SimError> { Ok(r) })
            .unwrap_err();
        assert!(e.to_string().contains("threads"), "{e}");
    }

    #[test]
    fn each_keeps_the_order_and_reports_every_item() {
        let calls = AtomicUsize::new(0);
        let progress = |_: usize, total: usize| {
            assert_eq!(total, 100);
            calls.fetch_add(1, Ordering::Relaxed);
        };
        let runner = Runner::default()
            .with_progress(&progress)
            .with_threads(Some(2));
        let items: Vec<u32> = (0..100).collect();
        let out = runner
            .each(&items, |&i| -> Result<u32, SimError> { Ok(2 * i) })
            .unwrap();
        assert_eq!(out, items.iter().map(|i| 2 * i).collect::<Vec<_>>());
        assert_eq!(calls.into_inner(), 100);
    }
}
