//! One module per command, plus the case runner they share.

pub mod beam;
pub mod bench;
pub mod design;
pub mod explore;
pub mod map;
pub mod merge;
pub mod paper;
pub mod run;
pub mod sweep;

pub use design::{
    check_value, fmt_coord, make_solver, parse_range, with_threads, SystemArgs, DEFAULT_SOLVER,
};

use anyhow::{anyhow, Result};
use vibrobar_core::analysis::energy::{EnergyAudit, EnergyBalance};
use vibrobar_core::analysis::{par_map_with_progress, run_case, RunResult, Sampler, SweepPoint};
use vibrobar_core::solver::{solver_by_name, Fanout, SOLVER_NAMES};
use vibrobar_core::{Observer, RunSettings, SimError, Solver, State, System};

use crate::cli::{Cli, Command};

/// Run the parsed command line.
pub fn dispatch(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Sweep(a) => sweep::sweep(&a),
        Command::Run(a) => run::run(&a),
        Command::Paper(a) => paper::paper(&a),
        Command::Beam(a) => beam::beam(&a),
        Command::Map(a) => map::run(&a),
        Command::Merge(a) => merge::run(&a),
        Command::Poincare(a) => explore::run_poincare(&a),
        Command::Bifurcation(a) => explore::run_bifurcation(&a),
        Command::Lyapunov(a) => explore::run_lyapunov(&a),
        Command::Ensemble(a) => explore::run_ensemble_cmd(&a),
        Command::BenchMap(a) => map::run_bench(&a),
        Command::Bench(a) => bench::bench(&a),
    }
}

/// Look a solver up by name; the error lists the names the library provides.
pub fn solver(name: &str, settings: &RunSettings) -> Result<Box<dyn Solver>> {
    solver_by_name(name, settings).ok_or_else(|| {
        anyhow!(
            "unknown solver {name:?}; available: {}",
            SOLVER_NAMES.join(", ")
        )
    })
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

/// Run many cases in parallel (rayon), in order, with a progress bar on stderr.
pub fn run_cases(
    cases: &[Case],
    settings: &RunSettings,
    solver: &dyn Solver,
    label: &str,
) -> Result<Vec<CaseOutcome>> {
    let bar = crate::progress::Progress::new(label, cases.len(), 0);
    let out = par_map_with_progress(cases, |c| run_one(c, settings, solver), &bar.callback());
    bar.finish();
    out.into_iter()
        .zip(cases)
        .map(|(r, c)| {
            r.map_err(|e| {
                anyhow!(
                    "{label}: run at ratio {} failed: {e}",
                    match c.system.forcing.frequency {
                        vibrobar_core::Frequency::Ratio(r) => format!("{r:.4}"),
                        vibrobar_core::Frequency::RadPerS(w) => format!("{w} rad/s"),
                    }
                )
            })
        })
        .collect()
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

/// Cases of a sweep: the solid bar once per distinct ratio, then every damped point.
/// Returns the cases and, per point, the index of its solid case.
pub fn sweep_cases(
    points: &[SweepPoint],
    base: &vibrobar_core::analysis::SweepBase,
    gravity_m_s2: f64,
    init: &State,
    energy_audit: bool,
) -> (Vec<Case>, Vec<usize>) {
    let mut ratios: Vec<f64> = points.iter().map(|p| p.ratio).collect();
    ratios.sort_by(f64::total_cmp);
    ratios.dedup();
    let mut cases: Vec<Case> = ratios
        .iter()
        .map(|&r| Case {
            system: System {
                gravity_m_s2,
                ..base.solid_system(r)
            },
            init: *init,
            sample_interval_s: None,
            energy_audit: false,
        })
        .collect();
    let mut solid_index = Vec::with_capacity(points.len());
    for p in points {
        cases.push(Case {
            system: System {
                gravity_m_s2,
                ..base.damped_system(p)
            },
            init: *init,
            sample_interval_s: None,
            energy_audit,
        });
        solid_index.push(
            ratios
                .iter()
                .position(|r| r.total_cmp(&p.ratio).is_eq())
                .expect("ratio listed"),
        );
    }
    (cases, solid_index)
}

/// Assemble sweep rows from the outcomes of [`sweep_cases`] (outcomes may be a longer list:
/// only the first `n_solid + points.len()` are read, starting at `offset`).
pub fn assemble_sweep(
    points: &[SweepPoint],
    solid_index: &[usize],
    outcomes: &[CaseOutcome],
    offset: usize,
    solver: &str,
) -> Vec<SweepResult> {
    let n_solid = solid_index.iter().copied().max().map_or(0, |m| m + 1);
    points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let d = &outcomes[offset + n_solid + i];
            SweepResult {
                point: *p,
                solver: solver.to_string(),
                solid: outcomes[offset + solid_index[i]].result,
                damped: d.result,
                friction_work_j: d.friction_work_j,
            }
        })
        .collect()
}

/// Wall time formatted for humans.
pub fn fmt_secs(s: f64) -> String {
    if s < 1.0 {
        format!("{:.0} ms", s * 1e3)
    } else {
        format!("{s:.2} s")
    }
}
