//! One module per command, plus what they share: one case ([`run_one`]), sweep rows through the
//! core's batch runner ([`sweep_rows`]), journals. The subcommand table is [`crate::app`].

pub mod beam;
pub mod bench;
pub mod contact_convergence;
pub mod contact_laws;
pub mod contact_test;
pub mod continue2;
pub mod cutting_deeper;
pub mod design;
pub mod ensemble_two_plane;
pub mod explore;
pub mod fit_modes;
pub mod frf;
pub mod lobe_design;
pub mod lobes;
pub mod lumped_vs_beam;
pub mod lyapunov_two_plane;
pub mod map;
pub mod map_two_plane;
pub mod merge;
pub mod modes;
pub mod orbit;
pub mod orbit_docs;
pub mod orbit_two_plane;
pub mod paper;
pub mod placement;
pub mod placement_two_plane;
pub mod poincare_two_plane;
pub mod run;
pub mod run_two_plane;
pub mod sweep;
pub mod sweep_two_plane;
pub mod tap_test;
pub mod time_domain;
pub mod two_plane;

pub use design::{
    check_value, fmt_coord, make_solver, parse_range, with_threads, SystemArgs, DEFAULT_SOLVER,
};

use anyhow::{anyhow, Result};
pub use vibrobar_core::analysis::case::{run_one, Case, CaseOutcome};
use vibrobar_core::analysis::sweep::sweep_audited;
pub use vibrobar_core::analysis::SweepRow;
use vibrobar_core::analysis::{BatchError, Runner, SolidRatios, SweepBase, SweepPoint};
use vibrobar_core::ContactLaw;
use vibrobar_core::{Observer, RunSettings, SimError, Solver, State, System};

/// Look a solver up by name; the error lists the names the library provides.
pub fn solver(name: &str, settings: &RunSettings) -> Result<Box<dyn Solver>> {
    make_solver(name, settings)
}

/// `--freqs-hz START:STOP:STEP` of `sweep` and `map`: both bars at the same absolute
/// frequencies. Returns the damped bar's ratios `Ω/ω₁` (the grid's ratio axis and the `ratio`
/// column), the solid bar's ratio of each, and the frequencies in Hz (for the metadata).
pub fn ratios_at_hz(spec: &str, base: &SweepBase) -> Result<(Vec<f64>, SolidRatios, Vec<f64>)> {
    let (_, f) = frf::parse_lines("--freqs-hz", spec)?;
    let (r, solid) = SolidRatios::at_hz(base, &f, "--freqs-hz")?;
    Ok((r, solid, f))
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

/// The warning printed when `rk4` left the ball `pen_m` beyond the wall, a fraction `f` of
/// the gap ([`vibrobar_core::limits::excessive_penetration`]); `at` names the worst point of a
/// batch.
pub fn penetration_warning(pen_m: f64, f: f64, solver: &str, at: Option<&str>) -> String {
    format!(
        "warning: the ball went {pen_m:.2e} m beyond the wall, {:.1} % of the gap (warning above {} %){}: {solver} detects impacts only after a step; lower --dt or use --solver exact",
        100.0 * f,
        100.0 * vibrobar_core::limits::RK4_PENETRATION_WARN_FRACTION,
        at.map_or(String::new(), |a| format!(" {a}"))
    )
}

/// A solver that remembers the deepest wall penetration (as a fraction of the gap) of the runs
/// it made, so that a batch (`sweep`, `map`) warns once, naming its worst point, instead of
/// leaving it unsaid; results are the inner solver's, untouched.
pub struct PenetrationWatch<'a> {
    inner: &'a dyn Solver,
    /// The worst run and how many runs exceeded the limit.
    worst: std::sync::Mutex<(Option<Penetration>, usize)>,
}

/// `(fraction of the gap, penetration m, ratio, gap m)` of one run.
type Penetration = (f64, f64, f64, f64);

impl<'a> PenetrationWatch<'a> {
    /// Watch `inner`.
    pub fn new(inner: &'a dyn Solver) -> Self {
        PenetrationWatch {
            inner,
            worst: std::sync::Mutex::new((None, 0)),
        }
    }

    /// The warning for the worst run, if any run went beyond the limit.
    pub fn warning(&self) -> Option<String> {
        let g = self.worst.lock().unwrap_or_else(|p| p.into_inner());
        let (f, pen, ratio, gap_m) = g.0?;
        let at = format!(
            "at ratio {}, gap {} mm (the worst of {} such runs)",
            fmt_coord(ratio),
            fmt_coord(gap_m * 1e3),
            g.1
        );
        Some(penetration_warning(pen, f, self.inner.name(), Some(&at)))
    }
}

impl Solver for PenetrationWatch<'_> {
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    fn run(
        &self,
        sys: &System,
        init: &State,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<vibrobar_core::solver::RunSummary, SimError> {
        let r = self.inner.run(sys, init, t_end_s, obs)?;
        // Under the hertz law the penetration is the contact's own compression, not an error.
        if let Some(d) = sys
            .damper
            .filter(|d| d.contact.law == ContactLaw::Restitution)
        {
            let pen = r.max_penetration_m;
            if let Some(f) = vibrobar_core::limits::excessive_penetration(pen, d.gap_m) {
                let ratio = sys.omega_rad_s() / sys.omega1_rad_s();
                let mut g = self.worst.lock().unwrap_or_else(|p| p.into_inner());
                g.1 += 1;
                if g.0.is_none_or(|w| f > w.0) {
                    g.0 = Some((f, pen, ratio, d.gap_m));
                }
            }
        }
        Ok(r)
    }
}

/// Wall time formatted for humans.
pub fn fmt_secs(s: f64) -> String {
    if s < 1.0 {
        format!("{:.0} ms", s * 1e3)
    } else {
        format!("{s:.2} s")
    }
}

/// `", a.png, a.svg"`: the figures written beside an output, for its summary line (empty when
/// none).
pub fn after_outputs(figures: &[std::path::PathBuf]) -> String {
    figures
        .iter()
        .map(|p| format!(", {}", p.display()))
        .collect()
}
