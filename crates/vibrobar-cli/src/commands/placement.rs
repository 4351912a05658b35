//! `placement`: where along the beam, and with which gap, the ball damps the response best over a
//! band of forcing frequencies (issue #8 §5–6; core `analysis::placement`).
//!
//! Output `FILE.csv`, header `position_mm,gap_mm,mean_reduction_pct,worst_rms_m,worst_ratio,
//! min_reduction_pct,mean_impacts_per_cycle,regime` (defined once: `vibrobar_io::csv::
//! placement_schema`), one row per cavity position × gap, position outer. Positions are the
//! cavity centre measured from the clamp. Reductions are of the RMS at the response point against
//! the solid bar (the same beam without cavity section and ball, forced at the same ratios of its
//! own `ω₁`), over the ratios given: the mean over the band, its smallest value, the largest damped
//! RMS in the band and its ratio, the mean impacts per cycle, and the regime at that worst ratio.
//!
//! The bar is the scenario's `[beam]`; without `--scenario`, the paper's bar as a beam
//! (`Beam::default()`: L = 175 mm, D = 25 mm, steel) with the paper's ball and 15 N forcing. A
//! scenario without `[beam]` is refused (the lumped bar has no positions). Every run starts at
//! rest with the ball centred.
//!
//! The same machinery as `map`: rows go through a journal (`FILE.csv.journal`, `--resume`
//! completes a killed run byte-identically), `--shard K/N` writes a slice that `vibrobar merge`
//! joins into the file an unsharded run writes, metadata `FILE.csv.meta.json` (typed:
//! `vibrobar_io::params::PlacementParams`). A whole study also draws `FILE.reduction.{png,svg}`
//! (mean reduction, the nodes of modes 2 and 3 of the damped bar, the optimum) and prints the
//! optimum (largest mean reduction; ties: smaller worst RMS, then the position nearer the clamp
//! and the smaller gap).
use super::{batch_error, fmt_coord, make_solver, parse_range, SystemArgs};
use crate::progress::Progress;
use crate::scenario::{Overrides, Scenario};
use anyhow::{bail, Context};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vibrobar_core::analysis::placement::{
    self, optimum, solver_case, CaseStats, PlacementGrid, PlacementPoint, PlacementRow,
    PlacementSpec,
};
use vibrobar_core::analysis::regime::Tolerances;
use vibrobar_core::analysis::Runner;
use vibrobar_core::error::Compact;
use vibrobar_core::structure::nodes::mode_nodes_m;
use vibrobar_core::structure::Beam;
use vibrobar_core::{RunSettings, SimError, Solver, State, System};
use vibrobar_io::csv::{placement_key, placement_schema, placement_values, read_placement_csv};
use vibrobar_io::params::PlacementParams;
use vibrobar_io::{shard, GridInfo, Journal, Metadata};

/// `vibrobar placement`: cavity position × gap over a band of ratios on a beam.
#[derive(Debug, Clone, clap::Args)]
pub struct PlacementArgs {
    #[command(flatten)]
    /// System and solver (the scenario must have a `[beam]`; without --scenario: the paper's
    /// bar as a beam).
    pub system: SystemArgs,
    /// Cavity centres from the clamp in mm, START:STOP:STEP (inclusive), inside the bar:
    /// [0, L], or [d_h/2, L − d_h/2] with a cavity section.
    #[arg(long, allow_hyphen_values = true)]
    pub positions_mm: String,
    /// Total gaps (clearance) in mm, START:STOP:STEP (inclusive), each > 0.
    #[arg(long, allow_hyphen_values = true)]
    pub gaps_mm: String,
    /// The band: frequency ratios Ω/ω₁ of each bar, START:STOP:STEP (inclusive), each > 0.
    #[arg(long, allow_hyphen_values = true)]
    pub ratios: String,
    /// Compute only slice K of N of the grid (round-robin); merge the slices with `merge`.
    #[arg(long)]
    pub shard: Option<String>,
    /// Worker threads (default: all cores, or RAYON_NUM_THREADS).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Continue an interrupted run from FILE.journal.
    #[arg(long)]
    pub resume: bool,
    /// Output CSV.
    #[arg(long)]
    pub out: PathBuf,
}

/// Everything a placement job needs, checked.
pub struct PlacementJob {
    /// Fixed parameters.
    pub spec: PlacementSpec,
    /// The grid.
    pub grid: PlacementGrid,
    /// Every parameter, for metadata and the fingerprint.
    pub params: PlacementParams,
}

/// The scenario of a beam study: the file's (it must have `[beam]`), or the paper's bar as a
/// beam; the flags applied on top, checked. The beam's number of modes is resolved once (the
/// scenario's, `--beam-modes`, or the default rule on the bar with its cavity as given), so that
/// every position and the solid reference keep the same N.
pub fn beam_scenario(a: &SystemArgs) -> anyhow::Result<(Scenario, Beam)> {
    if a.cavity_position_mm.is_some() {
        bail!(
            "--cavity-position-mm does not apply here: the cavity positions are the grid's \
             (--positions-mm)"
        );
    }
    let sc = match &a.scenario {
        Some(p) => {
            let sc = a.scenario()?;
            if sc.beam.is_none() {
                bail!(
                    "--scenario {}: no [beam] section; this command needs a beam (the lumped \
                     [bar] has one mode and no positions along it): add a [beam] section, or \
                     omit --scenario for the paper's bar as a beam",
                    p.display()
                );
            }
            sc
        }
        None => {
            let mut sc = Scenario::paper();
            sc.beam = Some(Beam::default());
            sc.apply(&Overrides {
                friction: a.friction.map(Into::into),
                friction_force_n: a.friction_force_n,
                contact: a.contact.map(Into::into),
                solver: a.solver.clone(),
                dt: a.dt,
                duration: a.duration,
                rms_fraction: a.rms_fraction,
                ..Overrides::default()
            })?;
            sc.apply_beam_flags(a.beam_modes, None)?;
            let st = sc.settings();
            if a.dt.is_some() && st.dt_s > st.duration_s {
                bail!(
                    "--dt must be in (0, --duration = {}] s, got {}",
                    Compact(st.duration_s),
                    Compact(st.dt_s)
                );
            }
            sc.validate()?;
            sc
        }
    };
    if sc.initial != State::REST {
        bail!(
            "[initial] does not apply to a beam study: every run starts at rest with the ball \
             centred; remove [initial]"
        );
    }
    let n = sc.bars()?.0.as_modal().map_or(1, |m| m.len());
    let beam = sc.beam.clone().expect("checked above").with_modes(n);
    Ok((sc, beam))
}

/// A solver with the settings of a study: runs one case of it ([`solver_case`]).
pub struct OwnedCase {
    solver: Box<dyn Solver>,
    settings: RunSettings,
    tolerances: Tolerances,
    audit: bool,
}

impl OwnedCase {
    /// One case (see [`solver_case`]).
    pub fn run(&self, sys: &System) -> Result<CaseStats, SimError> {
        solver_case(
            self.solver.as_ref(),
            self.settings,
            self.tolerances,
            self.audit,
        )(sys)
    }
}

/// How one case runs for `solver` (by name) with `settings`; `audit` adds the energy audit
/// (impact loss). A solver that does not run a modal bar yet is refused here, before any
/// journal, with its own reason (probed on a short run of the solid beam).
pub fn case_for(
    solver: &str,
    spec: &PlacementSpec,
    settings: RunSettings,
    audit: bool,
) -> anyhow::Result<OwnedCase> {
    let s = make_solver(solver, &settings)?;
    let probe = RunSettings {
        duration_s: 10.0 * settings.dt_s,
        rms_fraction: 1.0,
        ..settings
    };
    let sys = spec.system(&spec.solid_model()?, None, 1.0);
    if let Err(SimError::Unsupported(why)) =
        vibrobar_core::analysis::run_case(&sys, &State::REST, &probe, s.as_ref(), &mut ())
    {
        bail!("--solver {solver}: {why}");
    }
    Ok(OwnedCase {
        solver: s,
        settings,
        tolerances: spec.tolerances,
        audit,
    })
}

/// Build and check the job from the flags (no shard, no output).
pub fn job(args: &PlacementArgs) -> anyhow::Result<PlacementJob> {
    let (sc, beam) = beam_scenario(&args.system)?;
    let spec = PlacementSpec {
        beam,
        ball: sc.damper,
        forcing: sc.forcing,
        gravity_m_s2: sc.gravity_m_s2,
        settings: sc.settings(),
        tolerances: Tolerances::default(),
    };
    let _ = case_for(&sc.run.solver, &spec, spec.settings, false)?;
    let (lo, hi) = spec.position_range_m();
    let allowed = if spec.beam.cavity_section.is_some() {
        format!(
            "[{}, {}] mm (the cavity centre from the clamp, its hole inside the bar)",
            fmt_coord(lo * 1e3),
            fmt_coord(hi * 1e3)
        )
    } else {
        format!("[0, {}] mm (from the clamp)", fmt_coord(hi * 1e3))
    };
    // mm → m by a division (correctly rounded: 175 mm is the same double as L = 0.175 m).
    let positions_m: Vec<f64> = parse_range(
        "--positions-mm",
        &args.positions_mm,
        |x| x / 1e3 >= lo && x / 1e3 <= hi,
        &allowed,
    )?
    .iter()
    .map(|x| x / 1e3)
    .collect();
    let gaps_m: Vec<f64> = parse_range("--gaps-mm", &args.gaps_mm, |x| x > 0.0, "(0, ∞) mm")?
        .iter()
        .map(|g| g / 1e3)
        .collect();
    let ratios = parse_range("--ratios", &args.ratios, |x| x > 0.0, "(0, ∞)")?;
    let grid = PlacementGrid::new(positions_m.clone(), gaps_m.clone(), ratios.clone())?;
    // Every position's model, every gap and ratio must make a valid system before any run
    // (and rk4's step must be stable for the highest mode kept).
    let st = spec.settings;
    let check = |sys: &System| -> Result<(), vibrobar_core::ParamError> {
        sys.validate()?;
        sys.validate_horizon(0.0, st.duration_s)?;
        if sc.run.solver == "rk4" {
            sys.validate_fixed_step(st.dt_s, st.duration_s)?;
        }
        Ok(())
    };
    let solid = spec.solid_model()?;
    for &x in &positions_m {
        let at = || format!("cavity at {} mm from the clamp", Compact(x * 1e3));
        let model = spec.damped_model(x).with_context(at)?;
        for (g, r) in gaps_m
            .iter()
            .map(|&g| (g, ratios[0]))
            .chain(ratios.iter().map(|&r| (gaps_m[0], r)))
        {
            let sys = spec.system(&model, Some(spec.damper(g)), r);
            check(&sys)
                .with_context(|| format!("{}, gap {} mm, ratio {r}", at(), Compact(g * 1e3)))?;
        }
    }
    for &r in &ratios {
        check(&spec.system(&solid, None, r)).with_context(|| format!("solid bar at ratio {r}"))?;
    }
    let mut flags = BTreeMap::new();
    flags.insert("positions_mm".to_string(), args.positions_mm.clone());
    flags.insert("gaps_mm".to_string(), args.gaps_mm.clone());
    flags.insert("ratios".to_string(), args.ratios.clone());
    let a = &args.system;
    let params = PlacementParams {
        preset: a.scenario.is_none().then(|| {
            a.preset
                .unwrap_or(super::design::Preset::Paper)
                .as_str()
                .into()
        }),
        scenario_file: a.scenario.as_ref().map(|p| p.display().to_string()),
        solver: sc.run.solver.clone(),
        spec: spec.clone(),
        grid: flags,
        positions_m,
        gaps_m,
        ratios,
    };
    Ok(PlacementJob { spec, grid, params })
}

/// One CSV row (without the index).
pub fn format_row(r: &PlacementRow) -> String {
    placement_schema().format(&placement_values(r))
}

/// Compute the journal's pending points, each row appended as soon as it is done.
fn compute(
    job: &PlacementJob,
    journal: &Journal,
    total_in_job: usize,
    threads: Option<usize>,
) -> anyhow::Result<()> {
    let pending: Vec<PlacementPoint> = journal
        .pending()
        .into_iter()
        .map(|i| job.grid.point(i).expect("index inside the grid"))
        .collect();
    if pending.is_empty() {
        return Ok(());
    }
    let owned = case_for(&job.params.solver, &job.spec, job.spec.settings, false)?;
    let case = |s: &System| owned.run(s);
    let bar = Progress::new("placement", total_in_job, journal.done_count());
    let progress = bar.callback();
    let res = placement::run(
        &job.spec,
        &job.grid,
        &pending,
        Runner::default()
            .with_threads(threads)
            .with_progress(&progress),
        &case,
        |row| -> anyhow::Result<()> {
            journal.append(row.point.index, &format_row(&row))?;
            Ok(())
        },
    );
    bar.finish();
    res.map(|_| ()).map_err(batch_error)
}

/// `vibrobar placement`.
pub fn run(args: &PlacementArgs) -> anyhow::Result<()> {
    if args.system.scenario.is_some() && args.system.scenario()?.two_plane.is_some() {
        return super::placement_two_plane::run(args);
    }
    let job = job(args)?;
    let shard = args
        .shard
        .as_deref()
        .map(shard::parse_shard)
        .transpose()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    // Before the journal is opened: a refused pool must not leave a header-only journal.
    if let Some(n) = args.threads {
        vibrobar_core::limits::check_count(
            "--threads",
            n,
            1,
            vibrobar_core::limits::MAX_THREADS,
            "",
        )?;
    }
    let total = job.grid.len();
    let indices = shard::shard_indices(total, shard);
    let schema = placement_schema();
    let meta = Metadata::new(
        "placement",
        &schema.header(),
        job.params.clone(),
        Some(GridInfo {
            total,
            shard,
            indices: shard.map(|_| indices.clone()),
        }),
    );
    let key = |i: usize| match job.grid.point(i) {
        Some(p) => schema.format(&placement_key(p.position_m, p.gap_m)),
        None => String::new(),
    };
    let journal = super::open_journal(&args.out, &meta, &schema, &indices, &key, args.resume)?;
    let t0 = Instant::now();
    compute(&job, &journal, indices.len(), args.threads)?;
    journal.finish()?;
    meta.write_beside(&args.out)
        .with_context(|| format!("writing metadata beside {}", args.out.display()))?;
    eprintln!(
        "{}: {} rows in {:.1} s",
        args.out.display(),
        indices.len(),
        t0.elapsed().as_secs_f64()
    );
    if shard.is_none() {
        postprocess(&args.out)?;
    }
    Ok(())
}

/// After a whole study is written (by `placement` or `merge`): the optimum (printed) and the
/// figure, from the CSV and its metadata, so both paths give the same result.
pub fn postprocess(csv: &Path) -> anyhow::Result<()> {
    let rows = read_placement_csv(csv)?;
    let best = optimum(&rows);
    let params: Option<PlacementParams> = match Metadata::read_beside(csv) {
        Ok(m) => Some(m.parameters_as(csv)?),
        Err(e) => {
            eprintln!("nodes not marked: no metadata beside the study ({e})");
            None
        }
    };
    // The nodes of the damped bar with its cavity at the optimum (with a cavity section they
    // move a little with the cavity; without one they are the bar's own).
    let mut nodes = Vec::new();
    let mut title = "Mean RMS reduction over the band".to_string();
    if let Some(p) = &params {
        let x = best.map_or(p.spec.beam.cavity_position_m, |b| b.point.position_m);
        let beam = p.spec.damped_beam(x);
        for n in [2, 3] {
            nodes.push((n, mode_nodes_m(&beam, n)?));
        }
        let n_modes = p.spec.damped_model(x)?.len();
        let band = match (p.ratios.first(), p.ratios.last()) {
            (Some(a), Some(b)) if a != b => format!(", Ω/ω₁ {a}–{b}"),
            (Some(a), _) => format!(", Ω/ω₁ = {a}"),
            _ => String::new(),
        };
        title = format!(
            "{title}{band} — {n_modes} modes, friction {}, {}",
            p.spec.ball.friction.as_str(),
            p.solver
        );
    }
    let figs = vibrobar_report::figures::placement::draw_placement_figure(
        csv,
        &rows,
        best.as_ref(),
        &nodes,
        &title,
    )?;
    if let Some(b) = best {
        println!(
            "optimum: cavity at {} mm from the clamp, gap {} mm: {:.2} % mean reduction over the \
             band (worst RMS {:.3e} m at ratio {})",
            vibrobar_io::csv::fmt_coord(b.point.position_m * 1e3),
            vibrobar_io::csv::fmt_coord(b.point.gap_m * 1e3),
            b.mean_reduction_pct,
            b.worst_rms_m,
            vibrobar_io::csv::fmt_coord(b.worst_ratio)
        );
    }
    for (n, xs) in &nodes {
        let mm: Vec<String> = xs.iter().map(|x| format!("{:.2}", x * 1e3)).collect();
        println!(
            "nodes of mode {n} of the damped bar: {} mm from the clamp",
            mm.join(", ")
        );
    }
    for f in figs {
        println!("wrote {}", f.display());
    }
    Ok(())
}
