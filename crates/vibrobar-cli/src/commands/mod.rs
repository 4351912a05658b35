//! One module per command, plus what they share: one case ([`run_one`]), sweep rows through the
//! core's batch runner ([`sweep_rows`]), journals. The subcommand table is [`crate::app`].

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
pub use vibrobar_core::analysis::case::{run_one, Case, CaseOutcome};
use vibrobar_core::analysis::sweep::sweep_audited;
pub use vibrobar_core::analysis::SweepRow;
use vibrobar_core::analysis::{BatchError, Runner, SweepBase, SweepPoint};
use vibrobar_core::{RunSettings, Solver};

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

/// Sweep rows through the core's batch runner ([`sweep_audited`]: one solid run per distinct
/// ratio, shared), with a progress bar on stderr. The damped runs carry the energy audit when
/// `energy_audit` is set (their friction work goes into the rows).
pub fn sweep_rows(
    points: &[SweepPoint],
    base: &SweepBase,
    settings: &RunSettings,
    solver: &dyn Solver,
    label: &str,
    energy_audit: bool,
) -> Result<Vec<SweepRow>> {
    let bar = crate::progress::Progress::new(label, points.len(), 0);
    let progress = bar.callback();
    let rows = sweep_audited(
        points,
        base,
        settings,
        solver,
        Runner::default().with_progress(&progress),
        energy_audit,
    );
    bar.finish();
    rows.map_err(|e| anyhow!("{label}: {e}"))
}

/// Wall time formatted for humans.
pub fn fmt_secs(s: f64) -> String {
    if s < 1.0 {
        format!("{:.0} ms", s * 1e3)
    } else {
        format!("{s:.2} s")
    }
}
