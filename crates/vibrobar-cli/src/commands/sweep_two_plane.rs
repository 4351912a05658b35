//! `vibrobar sweep` on a `[two_plane]` scenario: the bar that bends in two planes over gaps and
//! frequency ratios, each point an ensemble of starts, beside the one-plane model and the bar
//! without its ball.
//!
//! One row per (gap, ratio), gap-major: the ensemble's RMS along the force (mean, standard
//! error, range), its reduction against the bar without the ball, the one-plane model's from the
//! same starts, the RMS per direction, impacts and flight, and the solver that ran. The file is
//! written whole at the end (atomically), after every point has run.

use anyhow::{Context, Result};
use vibrobar_core::analysis::two_plane::{
    design_points, DesignPoint, TwoPlaneEnsemble, TwoPlaneMethod,
};
use vibrobar_core::analysis::Runner;
use vibrobar_core::params::two_plane::TwoPlaneSystem;
use vibrobar_core::RunSettings;

use crate::cli::SweepArgs;
use crate::progress::Progress;
use crate::scenario::{parse_ratios, sweep_ratios, Scenario};
use vibrobar_io::two_plane_csv;
use vibrobar_scenario::TwoPlaneAxes;

/// The one-plane model's flags given to a `[two_plane]` scenario, `(solver, friction,
/// friction force, contact law)`: refused by name rather than silently not used.
pub fn refuse_one_plane_flags(given: [bool; 4]) -> Result<()> {
    let why = [
        (
            "--solver",
            "a [two_plane] scenario runs on its [two_plane] solver (exact, reference or auto)",
        ),
        (
            "--friction",
            "friction on the hole's walls is [two_plane] friction_static and friction_kinetic",
        ),
        (
            "--friction-force-n",
            "friction on the hole's walls is [two_plane] friction_static and friction_kinetic",
        ),
        (
            "--contact",
            "the walls of the two-plane hole take the restitution law",
        ),
    ];
    for ((flag, why), g) in why.iter().zip(given) {
        if g {
            anyhow::bail!("{flag}: {why}; leave it out");
        }
    }
    Ok(())
}

/// `--member` given for a one-plane scenario: refused (only a `[two_plane]` scenario has an
/// ensemble of starts).
pub fn refuse_member(member: Option<usize>) -> Result<()> {
    if member.is_some() {
        anyhow::bail!(
            "--member: only a scenario with [two_plane] has an ensemble of starts to choose \
             from; the one-plane start is the scenario's [initial]"
        );
    }
    Ok(())
}

/// [`refuse_one_plane_flags`] of a command's system flags.
pub fn refuse_system_flags(s: &super::SystemArgs) -> Result<()> {
    refuse_one_plane_flags([
        s.solver.is_some(),
        s.friction.is_some(),
        s.friction_force_n.is_some(),
        s.contact.is_some(),
    ])
}

/// [`refuse_one_plane_flags`] of `run`'s and `sweep`'s model flags.
pub fn refuse_model_flags(m: &crate::cli::ModelArgs) -> Result<()> {
    refuse_one_plane_flags([
        m.solver.is_some(),
        m.friction.is_some(),
        m.friction_force_n.is_some(),
        m.contact.is_some(),
    ])
}

/// Run the design points of `systems` (an ensemble each) with a progress bar, saying first what
/// `command` runs: what `sweep`, `ensemble` and `map` of a `[two_plane]` scenario share.
pub fn run_points(
    command: &str,
    systems: &[TwoPlaneSystem],
    ens: &TwoPlaneEnsemble,
    method: TwoPlaneMethod,
    settings: &RunSettings,
    threads: Option<usize>,
    solver: &str,
) -> Result<Vec<DesignPoint>> {
    if let Some(n) = threads {
        vibrobar_core::limits::check_count(
            "--threads",
            n,
            1,
            vibrobar_core::limits::MAX_THREADS,
            "",
        )?;
    }
    let total = systems.len() * ens.members;
    eprintln!(
        "{command}: two planes, {} points × {} members (seed {}; {total} runs of {} s; solver \
         {solver})",
        systems.len(),
        ens.members,
        ens.seed,
        settings.duration_s,
    );
    let bar = Progress::new(&format!("two-plane {command}"), total, 0);
    let cb = bar.callback();
    let points = design_points(
        systems,
        ens,
        method,
        settings,
        &Runner::default().with_threads(threads).with_progress(&cb),
    )
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    bar.finish();
    Ok(points)
}

/// Run the command on a scenario with `[two_plane]`.
pub fn sweep(args: &SweepArgs, sc: &Scenario) -> Result<()> {
    let t0 = std::time::Instant::now();
    let Some(section) = &sc.two_plane else {
        anyhow::bail!("no [two_plane] section");
    };
    refuse_model_flags(&args.model)?;
    if args.resume {
        anyhow::bail!(
            "--resume: a sweep of a [two_plane] scenario writes its file whole at the end; run \
             it again without --resume"
        );
    }
    if args.freqs_hz.is_some() {
        anyhow::bail!(
            "--freqs-hz: a sweep of a [two_plane] scenario takes frequency ratios (--ratios); \
             the ratio refers to the bar's lower principal frequency or first mode"
        );
    }
    for g in &args.gap_mm {
        crate::scenario::check_positive("--gap-mm", *g, "mm")?;
    }
    let gaps_m: Vec<f64> = if args.gap_mm.is_empty() {
        sc.sweep.gaps_m.clone()
    } else {
        args.gap_mm.iter().map(|g| g * 1e-3).collect()
    };
    if gaps_m.is_empty() {
        anyhow::bail!("sweep.gaps_m = [] in the scenario file: no gap to sweep (or give --gap-mm)");
    }
    let ratios = match &args.ratios {
        Some(spec) => parse_ratios(spec)?,
        None => sweep_ratios(&sc.sweep)?,
    };
    let settings = sc.settings();
    let method = section.method(settings.dt_s)?;
    let ens = section.ensemble()?;
    let cells = sc.two_plane_cells(
        &TwoPlaneAxes::gaps_and_ratios(&gaps_m, &ratios),
        ens.members,
        "sweep runs (points × members)",
    )?;
    let systems: Vec<TwoPlaneSystem> = cells.iter().map(|c| c.system).collect();
    settings.validate()?;
    let points = run_points(
        "sweep",
        &systems,
        &ens,
        method,
        &settings,
        None,
        &section.solver,
    )?;
    let rows = cells
        .iter()
        .zip(&points)
        .map(|(c, p)| two_plane_csv::sweep_values(c.axial_gap_m, c.ratio, p));
    vibrobar_io::csv::write_csv(&args.out, &two_plane_csv::sweep_schema(), rows)
        .with_context(|| format!("writing {}", args.out.display()))?;
    println!(
        "wrote {} ({} points, {:.1} s)",
        args.out.display(),
        points.len(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
