//! `map`: reduction of the RMS vibration over a grid of frequency ratio × gap (optionally also
//! friction level, restitution and mass ratio), with the optimum and figures.
//!
//! Output `FILE.csv`, header `ratio,gap_mm[,friction_force_n][,restitution][,mass_ratio],
//! rms_solid_m,rms_damped_m,reduction_pct,impacts_per_cycle,regime` (the optional columns appear
//! only when `--friction-forces-n`, `--restitutions`, `--mass-ratios` are given). Rows are in grid
//! order: row-major over ratio, gap, then the optional axes in that order, the last varying fastest.
//!
//! Rows go through a journal (`FILE.csv.journal`) as they finish, so a killed run loses at most
//! the runs in flight and `--resume` completes it with a byte-identical result. Beside the data:
//! `FILE.csv.meta.json`; for a whole (unsharded) map also `FILE.optimum.csv` (with the energy books of
//! each ratio's optimum point, rerun with the energy audit) and the figures
//! `FILE.reduction.{png,svg}` and `FILE.impacts.{png,svg}` (see [`postprocess`]).
use super::{
    batch_error, check_value, fmt_coord, make_solver, parse_range, with_threads, SystemArgs,
    DEFAULT_SOLVER,
};
use crate::progress::Progress;
use crate::scenario::{Scenario, ScenarioArgs, Source};
use anyhow::Context;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vibrobar_core::analysis::energy::{EnergyAudit, EnergyBalance};
use vibrobar_core::analysis::map::{
    compute_point_from, optimum, Axis, BandBest, Grid, GridAxis, GridPoint, MapRow, MapSpec,
    Optimum,
};
use vibrobar_core::analysis::regime::Tolerances;
use vibrobar_core::analysis::{run_case, Runner, SolidRatios, SweepBase};
use vibrobar_core::params::FrictionModel;
use vibrobar_core::solver::{Solver, SOLVER_NAMES};
use vibrobar_io::csv::{map_key, map_schema, map_values, optimum_schema};
pub use vibrobar_io::csv::{read_map_csv, MapTable};
use vibrobar_io::params::MapParams;
use vibrobar_io::{shard, GridInfo, Journal, Metadata};

/// `vibrobar map`: design map over frequency ratio × gap.
#[derive(Debug, Clone, clap::Args)]
#[command(group(clap::ArgGroup::new("frequencies").required(true).args(["ratios", "freqs_hz"])))]
pub struct MapArgs {
    #[command(flatten)]
    /// System and solver.
    pub system: SystemArgs,
    /// Frequency ratios Ω/ω₁ (each bar's own first frequency), START:STOP:STEP (inclusive), each > 0.
    #[arg(long, allow_hyphen_values = true)]
    pub ratios: Option<String>,
    /// Absolute forcing frequencies in Hz as START:STOP:STEP, STOP included, instead of
    /// --ratios: the damped and the solid bar both run at the same Ω (the `ratio` column is then
    /// Ω/ω₁ of the damped bar; the frequencies go to the metadata; the figures stay in ratio).
    #[arg(long, value_name = "START:STOP:STEP", allow_hyphen_values = true)]
    pub freqs_hz: Option<String>,
    /// Total gaps (clearance) in mm, START:STOP:STEP (inclusive), each > 0.
    #[arg(long, allow_hyphen_values = true)]
    pub gaps_mm: String,
    /// Optional axis: friction force levels in N (START:STOP:STEP, ≥ 0); adds a column
    /// `friction_force_n` after `gap_mm`.
    #[arg(long, allow_hyphen_values = true)]
    pub friction_forces_n: Option<String>,
    /// Optional axis: coefficients of restitution (START:STOP:STEP, in [0, 1]); adds `restitution`.
    #[arg(long, allow_hyphen_values = true)]
    pub restitutions: Option<String>,
    /// Optional axis: mass ratios m_d/M (START:STOP:STEP, > 0); adds `mass_ratio`. On a beam, M is
    /// mode 1's effective mass at the cavity, m₁/φ₁(x_d)².
    #[arg(long, allow_hyphen_values = true)]
    pub mass_ratios: Option<String>,
    /// Compute only slice K of N of the grid (round-robin); merge the slices with `merge`.
    #[arg(long)]
    pub shard: Option<String>,
    /// Worker threads (default: all cores, or RAYON_NUM_THREADS).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Continue an interrupted run from FILE.journal.
    #[arg(long)]
    pub resume: bool,
    /// Draw the stability boundary of the symmetric two-impact orbit (two-parameter curves:
    /// torus, fold, branch point) over the reduction figure (lumped bar, restitution law).
    #[arg(long)]
    pub stability_overlay: bool,
    /// A `[two_plane]` scenario: hole directions in degrees, START:STOP:STEP (inclusive); an
    /// axis of the design map beside the gaps.
    #[arg(long, value_name = "START:STOP:STEP", allow_hyphen_values = true)]
    pub hole_angles_deg: Option<String>,
    /// A `[two_plane]` scenario: hole diameters in mm, START:STOP:STEP (inclusive), each larger
    /// than the ball; an axis of the design map beside the gaps.
    #[arg(long, value_name = "START:STOP:STEP", allow_hyphen_values = true)]
    pub hole_diameters_mm: Option<String>,
    /// Output CSV.
    #[arg(long)]
    pub out: PathBuf,
}

/// Everything a map job needs, checked.
pub struct MapJob {
    /// Fixed parameters.
    pub spec: MapSpec,
    /// The grid (SI values).
    pub grid: Grid,
    /// Optional axes, in column order.
    pub extra: Vec<Axis>,
    /// CSV header.
    pub header: String,
    /// Every parameter, for metadata and the fingerprint.
    pub params: MapParams,
    /// Solver name.
    pub solver: String,
    /// The solid bar's ratio of each ratio of the grid (its own with `--freqs-hz`).
    pub solid: SolidRatios,
}

/// The map's ratio axis (`Ω/ω₁` of the damped bar), the solid bar's ratios, and the frequencies
/// in Hz when given by `--freqs-hz`.
fn ratio_axis(
    args: &MapArgs,
    base: &SweepBase,
) -> anyhow::Result<(Vec<f64>, SolidRatios, Option<Vec<f64>>)> {
    match (&args.ratios, &args.freqs_hz) {
        (_, Some(spec)) => {
            let (r, solid, f) = super::ratios_at_hz(spec, base)?;
            Ok((r, solid, Some(f)))
        }
        (Some(spec), None) => Ok((
            parse_range("--ratios", spec, |x| x > 0.0, "(0, ∞)")?,
            SolidRatios::default(),
            None,
        )),
        (None, None) => anyhow::bail!("map needs --ratios or --freqs-hz (one of them)"),
    }
}

/// Build and check the job from the flags (no shard, no output).
pub fn job(args: &MapArgs) -> anyhow::Result<MapJob> {
    let sc = args.system.scenario()?;
    let settings = sc.settings();
    let base = sc.base()?;
    let (ratios, solid, frequencies_hz) = ratio_axis(args, &base)?;
    if args.stability_overlay {
        overlay_system(args, &ratios)?;
    }
    make_solver(&sc.run.solver, &settings)?;
    let gaps_mm = parse_range("--gaps-mm", &args.gaps_mm, |x| x > 0.0, "(0, ∞) mm")?;
    let mut axes = vec![
        GridAxis {
            axis: Axis::FreqRatio,
            values: ratios,
        },
        GridAxis {
            axis: Axis::GapM,
            values: gaps_mm.iter().map(|g| g * 1e-3).collect(),
        },
    ];
    let mut extra = Vec::new();
    let mut axes_flags = std::collections::BTreeMap::new();
    if let Some(t) = &args.ratios {
        axes_flags.insert("ratios".to_string(), t.clone());
    }
    if let Some(t) = &args.freqs_hz {
        axes_flags.insert("freqs_hz".to_string(), t.clone());
    }
    axes_flags.insert("gaps_mm".to_string(), args.gaps_mm.clone());
    type Check = fn(f64) -> bool;
    let optional: [(&str, &Option<String>, Axis, Check, &str); 3] = [
        (
            "--friction-forces-n",
            &args.friction_forces_n,
            Axis::FrictionForceN,
            |x| x >= 0.0,
            "[0, ∞) N",
        ),
        (
            "--restitutions",
            &args.restitutions,
            Axis::Restitution,
            |x| (0.0..=1.0).contains(&x),
            "[0, 1]",
        ),
        (
            "--mass-ratios",
            &args.mass_ratios,
            Axis::MassRatio,
            |x| x > 0.0,
            "(0, ∞)",
        ),
    ];
    for (flag, text, axis, ok, allowed) in optional {
        if let Some(t) = text {
            axes.push(GridAxis {
                axis,
                values: parse_range(flag, t, ok, allowed)?,
            });
            extra.push(axis);
            axes_flags.insert(flag.trim_start_matches("--").replace('-', "_"), t.clone());
        }
    }
    let values_si: std::collections::BTreeMap<String, Vec<f64>> = axes
        .iter()
        .map(|a| (a.axis.as_str().to_string(), a.values.clone()))
        .collect();
    let grid = Grid::new(axes).map_err(|e| anyhow::anyhow!("grid: {e}"))?;
    let spec = MapSpec {
        base,
        friction: sc.damper.friction,
        settings,
        tolerances: Tolerances::default(),
    };
    // Every point must be a valid system with the initial state inside its cavity: fail before
    // any run, naming the field.
    for p in grid.points() {
        spec.damped_system(&p)
            .and_then(|s| {
                s.validate()?;
                s.validate_horizon(0.0, settings.duration_s)?;
                spec.base.init.validate(&s)
            })
            .map_err(|e| anyhow::anyhow!("{e} (at {})", describe(&p)))?;
    }
    let header = map_schema(&extra).header();
    let params = MapParams {
        system: args.system.to_params()?,
        grid: axes_flags,
        grid_values_si: values_si,
        regime_tolerances: spec.tolerances,
        frequencies_hz,
    };
    Ok(MapJob {
        spec,
        grid,
        extra,
        header,
        params,
        solver: sc.run.solver,
        solid,
    })
}

fn describe(p: &GridPoint) -> String {
    p.coords
        .iter()
        .map(|(a, v)| match a {
            Axis::GapM => format!("gap_mm = {}", fmt_coord(v * 1e3)),
            _ => format!("{} = {}", a.as_str(), fmt_coord(*v)),
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// One CSV row (without the index), by the map's schema.
pub fn format_row(row: &MapRow, extra: &[Axis]) -> String {
    map_schema(extra).format(&map_values(row, extra))
}

/// Compute the journal's pending points through the batch runner (solid runs first, one per
/// ratio, then the damped runs), each row appended to the journal as soon as it is done.
fn compute(
    job: &MapJob,
    solver: &dyn Solver,
    journal: &Journal,
    total_in_job: usize,
    threads: Option<usize>,
) -> anyhow::Result<()> {
    let pending: Vec<GridPoint> = journal
        .pending()
        .into_iter()
        .map(|i| job.grid.point(i).expect("index inside the grid"))
        .collect();
    if pending.is_empty() {
        return Ok(());
    }
    let bar = Progress::new("map", total_in_job, journal.done_count());
    let spec = &job.spec;
    let progress = bar.callback();
    let res = spec
        .batch(solver)
        .on(Runner::default()
            .with_threads(threads)
            .with_progress(&progress))
        .run(
            &pending,
            |p| job.solid.of(spec.ratio(p)),
            |p, solid| -> anyhow::Result<()> {
                let row = compute_point_from(spec, solver, p, &spec.base.init, solid.rms_m)
                    .with_context(|| format!("damped bar at {}", describe(p)))?;
                journal.append(p.index, &format_row(&row, &job.extra))?;
                Ok(())
            },
        );
    bar.finish();
    res.map(|_| ()).map_err(batch_error)
}

/// `vibrobar map`.
pub fn run(args: &MapArgs) -> anyhow::Result<()> {
    let sc = args.system.scenario()?;
    if sc.two_plane.is_some() {
        return super::map_two_plane::run(args, &sc);
    }
    for (flag, given) in [
        ("--hole-angles-deg", args.hole_angles_deg.is_some()),
        ("--hole-diameters-mm", args.hole_diameters_mm.is_some()),
    ] {
        if given {
            anyhow::bail!(
                "{flag}: only a scenario with [two_plane] has a hole across the bar; the \
                 one-plane model's cavity is its gap"
            );
        }
    }
    let job = job(args)?;
    let shard = args
        .shard
        .as_deref()
        .map(shard::parse_shard)
        .transpose()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let settings = job.spec.settings;
    let solver = make_solver(&job.solver, &settings)?;
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
    let meta = Metadata::new(
        "map",
        &job.header,
        job.params.clone(),
        Some(GridInfo {
            total,
            shard,
            indices: shard.map(|_| indices.clone()),
        }),
    );
    let schema = map_schema(&job.extra);
    let key = |i: usize| match job.grid.point(i) {
        Some(p) => schema.format(&map_key(&p, &job.extra)),
        None => String::new(),
    };
    let journal = super::open_journal(&args.out, &meta, &schema, &indices, &key, args.resume)?;
    let t0 = Instant::now();
    let watch = super::PenetrationWatch::new(solver.as_ref());
    compute(&job, &watch, &journal, indices.len(), args.threads)?;
    journal.finish()?;
    if let Some(w) = watch.warning() {
        eprintln!("{w}");
    }
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
        if args.stability_overlay {
            stability_overlay(args, &job)?;
        }
    }
    Ok(())
}

/// The map's base system at its first grid point, checked for periodic orbits (the error names
/// `--stability-overlay`).
fn overlay_system(
    args: &MapArgs,
    ratios: &[f64],
) -> anyhow::Result<(vibrobar_core::System, Vec<f64>, Vec<f64>)> {
    let ratios = ratios.to_vec();
    let gaps_mm = parse_range("--gaps-mm", &args.gaps_mm, |x| x > 0.0, "(0, ∞) mm")?;
    let sys = super::explore::PointArgs {
        system: args.system.clone(),
        ratio: ratios[0],
        gap_mm: gaps_mm[0],
    }
    .system()?;
    vibrobar_core::analysis::orbit::Section::new(sys, 0.0, 1)
        .map_err(|e| anyhow::anyhow!("--stability-overlay: {e}"))?;
    Ok((sys, ratios, gaps_mm))
}

/// Redraw the map's figures with the stability boundary over the reduction map.
fn stability_overlay(args: &MapArgs, job: &MapJob) -> anyhow::Result<()> {
    let ratios = job
        .grid
        .axes()
        .iter()
        .find(|a| a.axis == Axis::FreqRatio)
        .map(|a| a.values.clone())
        .unwrap_or_default();
    let (sys, ratios, gaps_mm) = overlay_system(args, &ratios)?;
    if ratios.len() < 2 || gaps_mm.len() < 2 {
        anyhow::bail!("--stability-overlay needs at least two ratios and two gaps");
    }
    let gaps_m: Vec<f64> = gaps_mm.iter().map(|g| g * 1e-3).collect();
    let (overlay, curves) =
        super::continue2::boundary_overlay(&sys, (ratios[0], ratios[ratios.len() - 1]), &gaps_m)?;
    let t = read_map_csv(&args.out)?;
    let o = optimum(&t.rows);
    vibrobar_report::figures::map::draw_map_figures_with(&args.out, &t, &o, &overlay)?;
    if curves.is_empty() {
        println!("stability overlay: no stable symmetric orbit in the map's range");
    }
    for c in &curves {
        println!(
            "stability overlay: {} curve, {} points",
            c.kind.as_str(),
            c.points.len()
        );
    }
    Ok(())
}

/// Header of the optimum file (`FILE.optimum.csv`, see [`optimum_path`]); the columns are
/// defined by [`vibrobar_io::csv::optimum_schema`].
pub fn optimum_header(extra: &[Axis]) -> String {
    optimum_schema(extra).header()
}

/// The text of the optimum file for a map; `energy[k]` are the books of `o.per_ratio[k]`.
pub fn optimum_csv(t: &MapTable, o: &Optimum, energy: &[Option<EnergyBalance>]) -> String {
    let books: Vec<Option<(f64, f64)>> = energy
        .iter()
        .map(|e| e.map(|e| (e.friction_work_j, e.work_input_j)))
        .collect();
    vibrobar_io::csv::optimum_csv(&t.extra, o, &books)
}

/// The map's system, friction, solver and regime tolerances rebuilt from its typed metadata
/// parameters: everything [`job`] wrote is what is reloaded.
pub fn spec_from_params(p: &MapParams) -> anyhow::Result<(MapSpec, String)> {
    let s = &p.system;
    let friction = FrictionModel::parse(&s.friction)
        .with_context(|| format!("metadata: unknown friction model {:?}", s.friction))?;
    let spec = MapSpec {
        base: SweepBase {
            damped_bar: s.damped_bar,
            solid_bar: s.solid_bar,
            ball: s.ball,
            forcing: s.forcing,
            gravity_m_s2: s.gravity_m_s2,
            init: s.initial,
        },
        friction,
        settings: s.settings,
        tolerances: p.regime_tolerances,
    };
    Ok((spec, s.solver.clone()))
}

/// Rerun each per-ratio optimum point (from the map's initial state, as it ran) with the energy
/// audit.
/// One short run per ratio, in parallel; the order of `o.per_ratio` is kept.
pub fn optimum_energy(
    params: &MapParams,
    o: &Optimum,
) -> anyhow::Result<Vec<Option<EnergyBalance>>> {
    let (spec, solver_name) = spec_from_params(params)?;
    let solver = make_solver(&solver_name, &spec.settings)?;
    let grid = grid_from_params(params);
    o.per_ratio
        .par_iter()
        .map(|r| -> anyhow::Result<Option<EnergyBalance>> {
            // The exact grid values (the CSV's are rounded to 12 digits, and a chaotic run would
            // amplify that), when the metadata's grid agrees with the row.
            let point = grid
                .as_ref()
                .and_then(|g| g.point(r.point.index))
                .filter(|g| same_point(g, &r.point))
                .unwrap_or_else(|| r.point.clone());
            let sys = spec
                .damped_system(&point)
                .map_err(|e| anyhow::anyhow!("{e} (at {})", describe(&point)))?;
            let mut audit = EnergyAudit::new(&sys);
            run_case(
                &sys,
                &spec.base.init,
                &spec.settings,
                solver.as_ref(),
                &mut audit,
            )
            .with_context(|| format!("energy audit at {}", describe(&r.point)))?;
            Ok(audit.balance())
        })
        .collect()
}

/// The map's grid from its metadata ([`MapParams::grid`]).
fn grid_from_params(p: &MapParams) -> Option<Grid> {
    p.grid()
}

/// Same axes and values up to the CSV's 12-digit rounding.
fn same_point(a: &GridPoint, b: &GridPoint) -> bool {
    a.coords.len() == b.coords.len()
        && a.coords
            .iter()
            .zip(&b.coords)
            .all(|((xa, va), (xb, vb))| xa == xb && (va - vb).abs() <= 1e-10 * va.abs().max(1e-30))
}

/// One line: friction work over the optimum points, its range and sign, against the cutting
/// force's work. `None` when nothing was audited.
pub fn friction_work_summary(energy: &[Option<EnergyBalance>]) -> Option<String> {
    let e: Vec<&EnergyBalance> = energy.iter().flatten().collect();
    if e.is_empty() {
        return None;
    }
    let range = |f: fn(&EnergyBalance) -> f64| {
        e.iter()
            .map(|b| f(b))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            })
    };
    let (f_lo, f_hi) = range(|b| b.friction_work_j);
    let (w_lo, w_hi) = range(|b| b.work_input_j);
    let sign = if f_lo > 0.0 {
        "friction put energy in"
    } else if f_hi < 0.0 {
        "friction took energy out"
    } else if f_lo == 0.0 && f_hi == 0.0 {
        "none"
    } else {
        "friction work of both signs"
    };
    let share = e
        .iter()
        .filter(|b| b.work_input_j.abs() > 0.0)
        .map(|b| (b.friction_work_j / b.work_input_j).abs())
        .fold(0.0, f64::max);
    Some(format!(
        "friction work at the {} optimum points: {:.3e}..{:.3e} J ({sign}); cutting-force work \
         {:.3e}..{:.3e} J; |friction/cutting| up to {:.2} %",
        e.len(),
        f_lo,
        f_hi,
        w_lo,
        w_hi,
        100.0 * share
    ))
}

/// The optimum file of a map, named after it (`maps/c.csv` → `maps/c.optimum.csv`), so that
/// two maps in one folder keep their own.
pub fn optimum_path(map_csv: &Path) -> PathBuf {
    let stem = map_csv
        .file_stem()
        .map(|s| s.to_os_string())
        .unwrap_or_default();
    let mut name = stem;
    name.push(".optimum.csv");
    map_csv.with_file_name(name)
}

/// After a whole map is written (by `map` or `merge`): the optimum file and the figures, all
/// computed from the CSV itself so both paths give the same result.
pub fn postprocess(map_csv: &Path) -> anyhow::Result<()> {
    let t = read_map_csv(map_csv)?;
    let o = optimum(&t.rows);
    let energy = match Metadata::read_beside(map_csv) {
        Ok(meta) => optimum_energy(&meta.parameters_as(map_csv)?, &o)
            .with_context(|| format!("energy audit of the optimum of {}", map_csv.display()))?,
        Err(e) => {
            eprintln!("energy audit skipped: no metadata beside the map ({e})");
            vec![None; o.per_ratio.len()]
        }
    };
    let opt = optimum_path(map_csv);
    vibrobar_io::write_atomic(&opt, optimum_csv(&t, &o, &energy).as_bytes())
        .with_context(|| format!("writing {}", opt.display()))?;
    if let Some(line) = friction_work_summary(&energy) {
        println!("{line}");
    }
    let figs = vibrobar_report::figures::map::draw_map_figures(map_csv, &t, &o)?;
    // Gap coordinate of a band design (NaN if the design has none).
    let gap_of = |b: &BandBest| {
        b.design
            .iter()
            .find(|(a, _)| *a == Axis::GapM)
            .map_or(f64::NAN, |d| d.1)
    };
    if let Some(b) = &o.best_mean_reduction {
        let gap = gap_of(b);
        println!(
            "best gap over the band (mean reduction): {} mm, {:.1} % mean reduction",
            fmt_coord(gap * 1e3),
            b.mean_reduction_pct
        );
    }
    if let Some(b) = &o.best_minimax_rms {
        let gap = gap_of(b);
        println!(
            "best gap over the band (minimax RMS): {} mm, worst RMS {:.3e} m",
            fmt_coord(gap * 1e3),
            b.max_rms_damped_m
        );
    }
    println!("wrote {}", opt.display());
    for f in figs {
        println!("wrote {}", f.display());
    }
    Ok(())
}

/// `bench-map`: time a subsample of the 200 × 100 ratio × gap map (2 s runs) with each solver
/// and project the whole map.
#[derive(Debug, Clone, clap::Args)]
pub struct BenchMapArgs {
    /// Ratios in the map (0.9..1.1).
    #[arg(long, default_value_t = 200)]
    pub ratios: usize,
    /// Gaps in the map (0.05..1.0 mm).
    #[arg(long, default_value_t = 100)]
    pub gaps: usize,
    /// Damped runs actually timed per solver (spread over the grid); 0 = the whole map.
    #[arg(long, default_value_t = 40)]
    pub subsample: usize,
    /// Simulated time per run, s [default: the scenario's, else 2].
    #[arg(long, allow_negative_numbers = true)]
    pub duration: Option<f64>,
    /// Solvers to time (default: all).
    #[arg(long)]
    pub solver: Vec<String>,
    /// Scenario file (TOML, as for `run`): bars, ball, forcing, friction and run settings of the
    /// map [default: the paper's, frictionless].
    #[arg(long, value_name = "FILE.toml")]
    pub scenario: Option<PathBuf>,
    /// Number of modes N of a `[beam]` scenario, overriding `[beam] modes`, in [1, 32].
    #[arg(long, value_name = "N")]
    pub beam_modes: Option<usize>,
    /// Cavity centre (the ball) of a `[beam]` scenario in mm from the clamp, in [0, L].
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub cavity_position_mm: Option<f64>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// One line of the bench.
#[derive(Debug, Clone, serde::Serialize)]
pub struct BenchMapResult {
    /// Solver.
    pub solver: String,
    /// Runs timed (damped + solid).
    pub runs: usize,
    /// Wall time of the timed runs, s.
    pub seconds: f64,
    /// Runs per second.
    pub runs_per_s: f64,
    /// Runs of the whole map (damped + one solid per ratio).
    pub map_runs: usize,
    /// Projected (or measured, when the whole map ran) wall time of the map, s.
    pub map_seconds: f64,
    /// True when the whole map ran.
    pub measured: bool,
}

/// The bench's scenario (the file's, or the paper's) and run settings with `--duration` applied.
fn bench_settings(args: &BenchMapArgs) -> anyhow::Result<(Scenario, vibrobar_core::RunSettings)> {
    let mut sc = match &args.scenario {
        Some(p) => Scenario::from_source(Source::File(p))?,
        None => Scenario::paper(),
    };
    sc.apply_beam_flags(args.beam_modes, args.cavity_position_mm)?;
    let mut settings = sc.settings();
    if let Some(d) = args.duration {
        settings.duration_s = check_value("--duration", d, |x| x > 0.0, "(0, ∞) s")?;
    }
    settings.validate()?;
    Ok((sc, settings))
}

/// Run the bench (library entry point for `vibrobar bench`).
pub fn bench_map(args: &BenchMapArgs) -> anyhow::Result<Vec<BenchMapResult>> {
    let n_r = check_value("--ratios", args.ratios as f64, |x| x >= 2.0, "[2, ∞)")? as usize;
    let n_g = check_value("--gaps", args.gaps as f64, |x| x >= 2.0, "[2, ∞)")? as usize;
    // Before the axes are built: 2³² ratios alone would be 34 GB.
    vibrobar_core::limits::check(
        "map points --ratios × --gaps",
        n_r as f64 * n_g as f64,
        4.0,
        vibrobar_core::limits::MAX_GRID_POINTS as f64,
        "",
    )?;
    let (sc, settings) = bench_settings(args)?;
    let ratios: Vec<f64> = (0..n_r)
        .map(|i| 0.9 + 0.2 * i as f64 / (n_r - 1) as f64)
        .collect();
    let gaps: Vec<f64> = (0..n_g)
        .map(|i| (0.05 + 0.95 * i as f64 / (n_g - 1) as f64) * 1e-3)
        .collect();
    let grid = Grid::new(vec![
        GridAxis {
            axis: Axis::FreqRatio,
            values: ratios,
        },
        GridAxis {
            axis: Axis::GapM,
            values: gaps,
        },
    ])?;
    let total = grid.len();
    let idx: Vec<usize> = if args.subsample == 0 || args.subsample >= total {
        (0..total).collect()
    } else {
        // Low-discrepancy picks (golden-ratio sequence): spread over ratios and gaps alike.
        let phi = 0.618_033_988_749_894_9_f64;
        let mut v: Vec<usize> = (0..args.subsample)
            .map(|k| (((k as f64 + 0.5) * phi).fract() * total as f64) as usize)
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let points: Vec<GridPoint> = idx.iter().filter_map(|&i| grid.point(i)).collect();
    // The preset bench keeps its historical template (the paper's ball at 1 mm, frictionless).
    let (base, friction) = match &args.scenario {
        Some(_) => (sc.base()?, sc.damper.friction),
        None => (SweepBase::paper(), FrictionModel::None),
    };
    let names: Vec<String> = if args.solver.is_empty() {
        SOLVER_NAMES.iter().map(|s| s.to_string()).collect()
    } else {
        args.solver.clone()
    };
    let mut out = Vec::new();
    for name in names {
        let solver = make_solver(&name, &settings)?;
        let spec = MapSpec {
            base,
            friction,
            settings,
            tolerances: Tolerances::default(),
        };
        let t0 = Instant::now();
        let rows = with_threads(args.threads, || {
            let bar = Progress::new(&format!("bench {name}"), 2 * points.len(), 0);
            let r = vibrobar_core::analysis::map::run_map(
                &spec,
                solver.as_ref(),
                &points,
                &bar.callback(),
            );
            bar.finish();
            r
        })??;
        let secs = t0.elapsed().as_secs_f64();
        let mut rs: Vec<u64> = rows.iter().map(|r| r.ratio.to_bits()).collect();
        rs.sort_unstable();
        rs.dedup();
        let runs = rows.len() + rs.len();
        let rate = runs as f64 / secs;
        let map_runs = total + n_r;
        let measured = points.len() == total;
        out.push(BenchMapResult {
            solver: name,
            runs,
            seconds: secs,
            runs_per_s: rate,
            map_runs,
            map_seconds: if measured {
                secs
            } else {
                map_runs as f64 / rate
            },
            measured,
        });
    }
    Ok(out)
}

/// `vibrobar bench-map`: print the bench.
pub fn run_bench(args: &BenchMapArgs) -> anyhow::Result<()> {
    let threads = args.threads.unwrap_or_else(rayon::current_num_threads);
    println!(
        "map {} ratios × {} gaps, {} s per run, {} threads (default solver {DEFAULT_SOLVER})",
        args.ratios,
        args.gaps,
        bench_settings(args)?.1.duration_s,
        threads
    );
    for r in bench_map(args)? {
        println!(
            "{:>6}: {} runs in {:.2} s = {:.1} runs/s; whole map ({} runs) {} {:.1} s ({:.2} h)",
            r.solver,
            r.runs,
            r.seconds,
            r.runs_per_s,
            r.map_runs,
            if r.measured { "took" } else { "projected" },
            r.map_seconds,
            r.map_seconds / 3600.0
        );
    }
    Ok(())
}
