//! One module per command, plus what they share: one case ([`run_one`]), sweep rows through the
//! core's batch runner ([`sweep_rows`]), journals. The subcommand table is [`crate::app`].

pub mod beam;
pub mod bench;
pub mod design;
pub mod explore;
pub mod map;
pub mod merge;
pub mod modes;
pub mod paper;
pub mod run;
pub mod sweep;

pub use design::{
    check_value, fmt_coord, make_solver, parse_range, with_threads, SystemArgs, DEFAULT_SOLVER,
};

use anyhow::{anyhow, Result};
use vibrobar_core::analysis::energy::{EnergyAudit, EnergyBalance};
use vibrobar_core::analysis::{
    run_case, Batch, BatchError, RunResult, Runner, Sampler, SweepBase, SweepPoint,
};
use vibrobar_core::solver::Fanout;
use vibrobar_core::{Observer, RunSettings, SimError, Solver, State, System};

/// Look a solver up by name; the error lists the names the library provides.
pub fn solver(name: &str, settings: &RunSettings) -> Result<Box<dyn Solver>> {
    make_solver(name, settings)
}

/// A batch runner error as one message: the job's own error as it is, the runner's (a solid
/// run, cancellation, the pool) with its numbers.
pub fn batch_error(e: BatchError<anyhow::Error>) -> anyhow::Error {
    match e {
        BatchError::Point(e) => e,
        other => anyhow!("{other}"),
    }
}

/// One simulation to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Case {
    /// The system.
    pub system: System,
    /// Initial state.
    pub init: State,
    /// Sample the history every this many seconds.
    pub sample_interval_s: Option<f64>,
    /// Audit the energy (core `EnergyAudit`: forcing, viscous, impact and friction work); costs
    /// the full segment integrals per step.
    pub energy_audit: bool,
}

/// What a case gave.
#[derive(Debug, Clone, PartialEq)]
pub struct CaseOutcome {
    /// RMS and impact statistics.
    pub result: RunResult,
    /// Friction work in J (0 without friction or without audit).
    pub friction_work_j: f64,
    /// Energy books of the whole run, when audited.
    pub energy: Option<EnergyBalance>,
    /// Sampled history (empty unless asked for).
    pub samples: Vec<State>,
    /// Wall time of this run in s.
    pub wall_s: f64,
}

/// Run one case.
pub fn run_one(
    case: &Case,
    settings: &RunSettings,
    solver: &dyn Solver,
) -> Result<CaseOutcome, SimError> {
    let t0 = std::time::Instant::now();
    let mut audit = case.energy_audit.then(|| EnergyAudit::new(&case.system));
    let mut sampler = case
        .sample_interval_s
        .map(|dt| Sampler::new(case.init.t_s, dt));
    let result = {
        let mut obs: Vec<&mut dyn Observer> = Vec::with_capacity(2);
        if let Some(a) = audit.as_mut() {
            obs.push(a);
        }
        if let Some(s) = sampler.as_mut() {
            obs.push(s);
        }
        run_case(
            &case.system,
            &case.init,
            settings,
            solver,
            &mut Fanout(&mut obs),
        )?
    };
    let energy = audit.and_then(|a| a.balance());
    Ok(CaseOutcome {
        result,
        friction_work_j: energy.map_or(0.0, |e| e.friction_work_j),
        energy,
        samples: sampler.map(|s| s.samples).unwrap_or_default(),
        wall_s: t0.elapsed().as_secs_f64(),
    })
}

/// Run independent cases through the core's runner (parallel, in order), with a progress bar
/// on stderr.
pub fn run_cases(
    cases: &[Case],
    settings: &RunSettings,
    solver: &dyn Solver,
    label: &str,
) -> Result<Vec<CaseOutcome>> {
    let bar = crate::progress::Progress::new(label, cases.len(), 0);
    let progress = bar.callback();
    let out = Runner::default().with_progress(&progress).each(cases, |c| {
        run_one(c, settings, solver).map_err(|e| {
            anyhow!(
                "{label}: run at ratio {} failed: {e}",
                match c.system.forcing.frequency {
                    vibrobar_core::Frequency::Ratio(r) => format!("{r:.4}"),
                    vibrobar_core::Frequency::RadPerS(w) => format!("{w} rad/s"),
                }
            )
        })
    });
    bar.finish();
    out.map_err(batch_error)
}

/// Open the row journal of `out` for the job described by `meta` (its fingerprint) with rows of
/// `schema`, whose index `i` has the key columns `key(i)`; saying on stderr how much a resumed
/// run already has.
pub fn open_journal(
    out: &std::path::Path,
    meta: &vibrobar_io::Metadata,
    schema: &vibrobar_io::csv::Schema,
    indices: &[usize],
    key: vibrobar_io::journal::KeyFn,
    resume: bool,
) -> Result<vibrobar_io::Journal> {
    let journal = vibrobar_io::Journal::open(out, schema, &meta.fingerprint, indices, key, resume)?;
    if journal.done_count() > 0 {
        eprintln!(
            "resuming {}: {} of {} rows already done",
            out.display(),
            journal.done_count(),
            indices.len()
        );
    }
    Ok(journal)
}

/// A sweep table row assembled from a solid and a damped outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepResult {
    /// The point.
    pub point: SweepPoint,
    /// Solver name.
    pub solver: String,
    /// Solid bar.
    pub solid: RunResult,
    /// Damped bar.
    pub damped: RunResult,
    /// Friction work in the damped run, J.
    pub friction_work_j: f64,
}

impl SweepResult {
    /// `100(1 − damped/solid)`.
    pub fn reduction_pct(&self) -> f64 {
        100.0 * (1.0 - self.damped.rms_m / self.solid.rms_m)
    }

    /// The CSV row.
    pub fn csv_row(&self) -> vibrobar_io::csv::SweepCsvRow {
        vibrobar_io::csv::SweepCsvRow {
            ratio: self.point.ratio,
            gap_mm: self.point.gap_m * 1e3,
            friction: self.point.friction.as_str().to_string(),
            solver: self.solver.clone(),
            rms_solid_m: self.solid.rms_m,
            rms_damped_m: self.damped.rms_m,
            reduction_pct: self.reduction_pct(),
            impacts: self.damped.impacts,
        }
    }
}

/// Sweep rows through the core's batch runner (one solid run per distinct ratio, shared), with
/// a progress bar on stderr. The damped runs carry the energy audit when `energy_audit` is set
/// (their friction work goes into the rows).
pub fn sweep_rows(
    points: &[SweepPoint],
    base: &SweepBase,
    settings: &RunSettings,
    solver: &dyn Solver,
    label: &str,
    energy_audit: bool,
) -> Result<Vec<SweepResult>> {
    let bar = crate::progress::Progress::new(label, points.len(), 0);
    let progress = bar.callback();
    let rows = Batch::new(base, settings, solver)
        .on(Runner::default().with_progress(&progress))
        .run(
            points,
            |p| p.ratio,
            |p, solid| -> Result<SweepResult> {
                let case = Case {
                    system: base.damped_system(p),
                    init: base.init,
                    sample_interval_s: None,
                    energy_audit,
                };
                let d = run_one(&case, settings, solver).map_err(|e| {
                    anyhow!(
                        "{label}: run at ratio {:.4}, gap {} mm failed: {e}",
                        p.ratio,
                        p.gap_m * 1e3
                    )
                })?;
                Ok(SweepResult {
                    point: *p,
                    solver: solver.name().to_string(),
                    solid: *solid,
                    damped: d.result,
                    friction_work_j: d.friction_work_j,
                })
            },
        );
    bar.finish();
    rows.map_err(batch_error)
}

/// Wall time formatted for humans.
pub fn fmt_secs(s: f64) -> String {
    if s < 1.0 {
        format!("{:.0} ms", s * 1e3)
    } else {
        format!("{s:.2} s")
    }
}
