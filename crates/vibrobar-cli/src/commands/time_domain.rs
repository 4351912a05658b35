//! What the ball damper buys against regenerative chatter (issue #14): `vibrobar width-diagram`
//! (settled vibration over widths at one speed, both bars, both disturbances) and the
//! time-domain lobes (largest acceptable width per speed). Both run through the core's batch
//! runner, write through a journal (`--resume` completes an interrupted run to the same bytes),
//! shard with `--shard K/N` (`vibrobar merge` joins the shards) and draw a figure.
//!
//! The judge's settings are the scenario's `[time_domain]` section (core
//! `TimeDomainSettings`: `small_disturbance_m`, `large_disturbance_m`, `settle_revs`,
//! `judge_revs`, `vibration_limit_m`, `growth_tolerance_per_rev`, `bisection_tolerance`,
//! `monotonic_checks`); the cut is its `[cutting]` (its width and speed are set per run).

use anyhow::{bail, Context, Result};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vibrobar_core::analysis::batch::{BatchError, Runner};
use vibrobar_core::analysis::time_domain::{
    linear_at, td_lobe_row, BarKind, CutProblem, DiagramRow, Disturbance, TdLobeRow,
};
use vibrobar_core::SimError;
use vibrobar_io::csv::{
    td_lobes_key, td_lobes_schema, td_lobes_values, width_diagram_key, width_diagram_schema,
    width_diagram_values, Schema, Value, TD_LOBES_KIND, WIDTH_DIAGRAM_KIND,
};
use vibrobar_io::{shard, GridInfo, Metadata};
use vibrobar_report::plot::{lines, Curve};
use vibrobar_scenario::Scenario;

use crate::progress::Progress;

/// Most points of a width or speed range.
const MAX_RANGE_POINTS: usize = 100_000;

/// `START:STOP:STEP` (STOP included) times `scale`; errors name `flag`: an empty, non-finite or
/// non-positive range.
pub fn parse_range(flag: &str, text: &str, scale: f64) -> Result<Vec<f64>> {
    let parts: Vec<&str> = text.split(':').collect();
    if parts.len() != 3 {
        bail!("{flag} {text:?}: expected START:STOP:STEP");
    }
    let mut v = [0.0; 3];
    for (k, (name, p)) in ["START", "STOP", "STEP"].iter().zip(&parts).enumerate() {
        let x: f64 = p
            .trim()
            .parse()
            .with_context(|| format!("{flag} {name} = {p:?} is not a number"))?;
        if !x.is_finite() || x <= 0.0 {
            bail!("{flag} {name} = {x} is outside the allowed range (0, ∞) (finite)");
        }
        v[k] = x;
    }
    let [a, b, s] = v;
    if b < a {
        bail!("{flag} range is empty: STOP = {b} < START = {a} (allowed: STOP ≥ START)");
    }
    let n = ((b - a) / s + 1e-9).floor() + 1.0;
    if n > MAX_RANGE_POINTS as f64 {
        bail!("{flag} has {n} points; at most {MAX_RANGE_POINTS}");
    }
    Ok((0..n as usize)
        .map(|i| (a + s * i as f64) * scale)
        .collect())
}

fn problem(scenario: &Path) -> Result<(Scenario, CutProblem)> {
    let sc = Scenario::load(scenario)?;
    let p = sc.cut_problem()?;
    Ok((sc, p))
}

fn shard_of(s: &Option<String>) -> Result<Option<vibrobar_io::meta::ShardInfo>> {
    s.as_deref()
        .map(shard::parse_shard)
        .transpose()
        .map_err(|e| anyhow::anyhow!("{e}"))
}

fn batch_err(e: BatchError<anyhow::Error>) -> anyhow::Error {
    super::batch_error(e)
}

fn sim(e: SimError, what: String) -> anyhow::Error {
    anyhow::anyhow!("{what}: {e}")
}

/// `vibrobar width-diagram`.
#[derive(Debug, Clone, clap::Args)]
pub struct WidthDiagramArgs {
    /// Scenario file (TOML) with a `[cutting]` section (and optionally `[time_domain]`).
    #[arg(long, value_name = "FILE.toml")]
    pub scenario: PathBuf,
    /// Spindle speed, rpm, in [1, 200000].
    #[arg(long, value_name = "N")]
    pub rpm: f64,
    /// Widths of cut in mm as START:STOP:STEP, STOP included, all > 0.
    #[arg(long, value_name = "START:STOP:STEP")]
    pub widths_mm: String,
    /// Complete an interrupted run from its journal.
    #[arg(long)]
    pub resume: bool,
    /// Compute only shard K of N (rows K, K+N, …); join with `vibrobar merge`.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// No figure.
    #[arg(long)]
    pub no_figure: bool,
    /// Output CSV (width_m,disturbance,bar,peak_to_peak_m,out_of_cut_fraction,impacts_per_rev,
    /// regime,static_deflection_m,growth_per_rev,acceptable,spindle_rpm); the figure is
    /// STEM.png and STEM.svg, the parameters FILE.meta.json.
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
}

#[derive(Serialize)]
struct DiagramParams<'a> {
    scenario: &'a Scenario,
    spindle_rpm: f64,
    widths_m: &'a [f64],
    order: &'static str,
}

/// `vibrobar width-diagram`.
pub fn width_diagram(args: &WidthDiagramArgs) -> Result<()> {
    let t0 = Instant::now();
    let (sc, p) = problem(&args.scenario)?;
    vibrobar_core::limits::check(
        "--rpm",
        args.rpm,
        vibrobar_core::limits::SPINDLE_RPM_MIN,
        vibrobar_core::limits::SPINDLE_RPM_MAX,
        "revolutions per minute",
    )?;
    let widths = parse_range("--widths-mm", &args.widths_mm, 1e-3)?;
    let jobs: Vec<(f64, Disturbance, BarKind)> = widths
        .iter()
        .flat_map(|&w| {
            Disturbance::ALL
                .into_iter()
                .flat_map(move |d| BarKind::ALL.into_iter().map(move |b| (w, d, b)))
        })
        .collect();
    let shard = shard_of(&args.shard)?;
    let indices = shard::shard_indices(jobs.len(), shard);
    let schema = width_diagram_schema();
    let meta = Metadata::new(
        WIDTH_DIAGRAM_KIND,
        &schema.header(),
        DiagramParams {
            scenario: &sc,
            spindle_rpm: args.rpm,
            widths_m: &widths,
            order: "width-major, then disturbance (small, large), then bar (solid, damped)",
        },
        Some(GridInfo {
            total: jobs.len(),
            shard,
            indices: shard.map(|_| indices.clone()),
        }),
    );
    let key = |i: usize| {
        let (w, d, b) = jobs[i];
        width_diagram_key(w, d.as_str(), b.as_str())
    };
    let journal = super::open_journal(&args.out, &meta, &schema, &indices, &key, args.resume)?;
    let pending = journal.pending();
    let lin = linear_at(&p, &[args.rpm])?[0];
    let bar = Progress::new("width-diagram", indices.len(), journal.done_count());
    let progress = bar.callback();
    let res = Runner::default()
        .with_progress(&progress)
        .each(&pending, |&i| -> Result<()> {
            let (w, d, b) = jobs[i];
            let om = match b {
                BarKind::Solid => lin.omega_solid_rad_s,
                BarKind::Damped => lin.omega_damped_rad_s,
            };
            let judged = p.judge(b, d, w, args.rpm, om).map_err(|e| {
                sim(
                    e,
                    format!(
                        "width {w} m, {} bar, {} disturbance",
                        b.as_str(),
                        d.as_str()
                    ),
                )
            })?;
            let row = DiagramRow {
                width_m: w,
                disturbance: d,
                bar: b,
                judged,
            };
            journal.append(i, &schema.format(&width_diagram_values(&row, args.rpm)))?;
            Ok(())
        });
    bar.finish();
    res.map_err(batch_err)?;
    journal.finish()?;
    meta.write_beside(&args.out)
        .with_context(|| format!("writing metadata beside {}", args.out.display()))?;
    eprintln!(
        "width-diagram: {} rows at {} rpm written to {} in {}",
        indices.len(),
        args.rpm,
        args.out.display(),
        super::fmt_secs(t0.elapsed().as_secs_f64())
    );
    if shard.is_none() && !args.no_figure {
        width_diagram_figure(&args.out)?;
    }
    Ok(())
}

fn read_rows(path: &Path, schema: &Schema) -> Result<Vec<Vec<Value>>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut lines = text.lines();
    let header = lines.next().unwrap_or_default();
    if header != schema.header() {
        bail!("{}: not the expected header", path.display());
    }
    lines
        .enumerate()
        .map(|(i, l)| Ok(schema.parse_at(l, path, i + 2)?))
        .collect()
}

fn stem(out: &Path) -> PathBuf {
    out.with_extension("")
}

const COLORS: [(u8, u8, u8); 4] = [(200, 60, 40), (240, 150, 40), (31, 90, 160), (60, 170, 200)];

/// The width–amplitude figure from a finished diagram CSV: peak-to-peak (µm) over width (mm),
/// one curve per bar and disturbance; where small and large differ is the bistable band.
pub fn width_diagram_figure(out: &Path) -> Result<()> {
    let schema = width_diagram_schema();
    let rows = read_rows(out, &schema)?;
    let mut curves = Vec::new();
    for (k, (b, d)) in [
        ("solid", "small"),
        ("solid", "large"),
        ("damped", "small"),
        ("damped", "large"),
    ]
    .into_iter()
    .enumerate()
    {
        let points: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r[1].s() == d && r[2].s() == b)
            .filter(|r| r[3].f().is_finite())
            .map(|r| (r[0].f() * 1e3, r[3].f() * 1e6))
            .collect();
        let (r, g, bl) = COLORS[k];
        curves.push(Curve {
            label: format!("{b} bar, {d} disturbance"),
            points,
            color: plotters::style::RGBColor(r, g, bl),
            markers: true,
            dashed: d == "large",
            width: 2,
        });
    }
    lines(
        &stem(out),
        "Settled vibration over the width of cut (bistable band: small and large curves apart)",
        "width of cut b (mm)",
        "peak-to-peak tip vibration (µm)",
        &curves,
        &[],
    )
}

/// The time-domain lobes (`vibrobar lobes --time-domain`; the flags are `lobes`' own).
#[derive(Debug, Clone)]
pub struct TdLobesArgs {
    /// Scenario file (TOML) with a `[cutting]` section (and optionally `[time_domain]`).
    pub scenario: PathBuf,
    /// Spindle speeds, rpm (checked by `lobes`' `--rpm` parser).
    pub rpms: Vec<f64>,
    /// Complete an interrupted run from its journal.
    pub resume: bool,
    /// `K/N`: compute only shard K of N.
    pub shard: Option<String>,
    /// No figure.
    pub no_figure: bool,
    /// Output CSV (spindle_rpm,b_lim_m,b_lim_solid_m,b_solid_small_m,b_solid_large_m,
    /// b_damped_small_m,b_damped_large_m,event_limit_runs,non_monotonic,capped,runs).
    pub out: PathBuf,
}

#[derive(Serialize)]
struct TdLobesParams<'a> {
    scenario: &'a Scenario,
    spindle_rpm: &'a [f64],
}

/// `vibrobar lobes --time-domain`.
pub fn td_lobes(args: &TdLobesArgs) -> Result<()> {
    let t0 = Instant::now();
    let (sc, p) = problem(&args.scenario)?;
    let rpms = args.rpms.clone();
    let shard = shard_of(&args.shard)?;
    let indices = shard::shard_indices(rpms.len(), shard);
    let schema = td_lobes_schema();
    let meta = Metadata::new(
        TD_LOBES_KIND,
        &schema.header(),
        TdLobesParams {
            scenario: &sc,
            spindle_rpm: &rpms,
        },
        Some(GridInfo {
            total: rpms.len(),
            shard,
            indices: shard.map(|_| indices.clone()),
        }),
    );
    let key = |i: usize| td_lobes_key(rpms[i]);
    let journal = super::open_journal(&args.out, &meta, &schema, &indices, &key, args.resume)?;
    let pending = journal.pending();
    let lin = linear_at(&p, &rpms)?;
    let bar = Progress::new("time-domain lobes", indices.len(), journal.done_count());
    let progress = bar.callback();
    let res = Runner::default()
        .with_progress(&progress)
        .each(&pending, |&i| -> Result<()> {
            let row: TdLobeRow = td_lobe_row(&p, rpms[i], &lin[i])
                .map_err(|e| sim(e, format!("time-domain lobes at {} rpm", rpms[i])))?;
            journal.append(i, &schema.format(&td_lobes_values(&row)))?;
            Ok(())
        });
    bar.finish();
    res.map_err(batch_err)?;
    journal.finish()?;
    meta.write_beside(&args.out)
        .with_context(|| format!("writing metadata beside {}", args.out.display()))?;
    eprintln!(
        "lobes --time-domain: {} speeds written to {} in {}",
        indices.len(),
        args.out.display(),
        super::fmt_secs(t0.elapsed().as_secs_f64())
    );
    if shard.is_none() && !args.no_figure {
        td_lobes_figure(&args.out)?;
    }
    Ok(())
}

/// The time-domain lobes figure from a finished CSV: the exact linear boundaries and the four
/// time-domain curves (mm over rpm).
pub fn td_lobes_figure(out: &Path) -> Result<()> {
    let schema = td_lobes_schema();
    let rows = read_rows(out, &schema)?;
    let curve = |col: usize, label: &str, c: (u8, u8, u8), dashed: bool, markers: bool| Curve {
        label: label.into(),
        points: rows.iter().map(|r| (r[0].f(), r[col].f() * 1e3)).collect(),
        color: plotters::style::RGBColor(c.0, c.1, c.2),
        markers,
        dashed,
        width: if markers { 2 } else { 1 },
    };
    let curves = [
        curve(2, "linear, solid bar (exact)", (0, 0, 0), true, false),
        curve(
            1,
            "linear, damped bar, ball free (exact)",
            (120, 120, 120),
            true,
            false,
        ),
        curve(3, "solid, small disturbance", COLORS[0], false, true),
        curve(4, "solid, large disturbance", COLORS[1], false, true),
        curve(5, "damped, small disturbance", COLORS[2], false, true),
        curve(6, "damped, large disturbance", COLORS[3], false, true),
    ];
    lines(
        &stem(out),
        "Time-domain stability lobes: largest acceptable width of cut",
        "spindle speed (rpm)",
        "width of cut b (mm)",
        &curves,
        &[],
    )
}
