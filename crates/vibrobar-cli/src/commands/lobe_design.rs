//! `vibrobar lobe-design` (issue #14 §3): score each design (gap × ball mass on the lumped bar,
//! gap × cavity position on a `[beam]`) by its time-domain lobes from the large disturbance over
//! a band of spindle speeds (core [`vibrobar_core::analysis::lobe_design`]): the worst-case
//! acceptable width (the score; the optimum maximises it) and the mean, beside the solid bar's
//! over the same band (searched once per speed) and the gains.
//!
//! Output `FILE.csv` (schema `vibrobar_io::csv::lobe_design_schema`), one row per design in
//! index order (gap outer). Rows go through a journal, so `--resume` completes an interrupted
//! run to the same bytes; `--shard K/N` computes designs K, K+N, … and `vibrobar merge` joins
//! the shards. Beside the data: `FILE.csv.meta.json`; for a whole study also
//! `FILE.optimum.csv` (the header and the optimum's row) and the heat map `FILE.{png,svg}`
//! ([`postprocess`]).

use anyhow::{bail, Context, Result};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vibrobar_core::analysis::batch::Runner;
use vibrobar_core::analysis::lobe_design::{
    check_speeds, optimum, score_design, solid_reference, DesignAxis, DesignGrid, LobeDesignSpec,
};
use vibrobar_io::csv::{
    lobe_design_key, lobe_design_schema, lobe_design_values, read_lobe_design_csv, LOBE_DESIGN_KIND,
};
use vibrobar_io::{shard, GridInfo, Metadata};
use vibrobar_scenario::Scenario;

use super::{batch_error, fmt_coord, parse_range};
use crate::progress::Progress;

/// `vibrobar lobe-design`.
#[derive(Debug, Clone, clap::Args)]
#[command(group(clap::ArgGroup::new("design_axis").required(true).args(["ball_masses_g", "positions_mm"])))]
pub struct LobeDesignArgs {
    /// Scenario file (TOML) with a `[cutting]` section (and optionally `[time_domain]`); its
    /// `[damper]` is the ball template.
    #[arg(long, value_name = "FILE.toml")]
    pub scenario: PathBuf,
    /// The band of spindle speeds in rpm as START:STOP:STEP, STOP included, each in
    /// [1, 200000].
    #[arg(long, value_name = "START:STOP:STEP")]
    pub rpm: String,
    /// Total gaps (clearance) in mm, START:STOP:STEP (inclusive), each > 0.
    #[arg(long, value_name = "START:STOP:STEP")]
    pub gaps_mm: String,
    /// Ball masses in g, START:STOP:STEP (inclusive), each > 0 (the ball's other fields kept).
    #[arg(long, value_name = "START:STOP:STEP")]
    pub ball_masses_g: Option<String>,
    /// Cavity centres in mm from the clamp, START:STOP:STEP (inclusive), inside the bar (a
    /// `[beam]` scenario).
    #[arg(long, value_name = "START:STOP:STEP")]
    pub positions_mm: Option<String>,
    /// Number of modes N of a `[beam]` scenario, overriding `[beam] modes`, in [1, 32].
    #[arg(long, value_name = "N")]
    pub beam_modes: Option<usize>,
    /// Worker threads (default: all cores, or RAYON_NUM_THREADS).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Complete an interrupted run from its journal.
    #[arg(long)]
    pub resume: bool,
    /// Compute only shard K of N (designs K, K+N, …); join with `vibrobar merge`.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// No figure.
    #[arg(long)]
    pub no_figure: bool,
    /// Output CSV: gap_m,ball_mass_kg (or position_m),worst_width_m,worst_rpm,mean_width_m,
    /// solid_worst_width_m,solid_worst_rpm,solid_mean_width_m,worst_gain,mean_gain,
    /// event_limit_runs,non_monotonic,capped,runs,worst_regime,spread_min_width_m,
    /// spread_mean_width_m,spread_max_width_m.
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
}

/// What the metadata records (and the fingerprint a resume must match).
#[derive(Serialize)]
struct LobeDesignParams<'a> {
    scenario: &'a Scenario,
    spindle_rpm: &'a [f64],
    gaps_m: &'a [f64],
    axis: &'static str,
    values: &'a [f64],
    order: &'static str,
}

/// The study's spec, grid and speeds from the flags, every design checked (errors name the
/// flag or field and the design).
pub fn job(args: &LobeDesignArgs) -> Result<(Scenario, LobeDesignSpec, DesignGrid, Vec<f64>)> {
    let (_, _, _, rpms) = super::lobes::parse_rpm(&args.rpm)?;
    check_speeds(&rpms)?;
    let gaps: Vec<f64> = parse_range("--gaps-mm", &args.gaps_mm, |x| x > 0.0, "(0, ∞) mm")?
        .iter()
        .map(|g| g / 1e3)
        .collect();
    let (axis, values) = match (&args.ball_masses_g, &args.positions_mm) {
        (Some(m), None) => (
            DesignAxis::BallMass,
            parse_range("--ball-masses-g", m, |x| x > 0.0, "(0, ∞) g")?,
        ),
        (None, Some(x)) => (
            DesignAxis::Position,
            parse_range("--positions-mm", x, |x| x >= 0.0, "[0, L] mm")?,
        ),
        _ => bail!("give exactly one of --ball-masses-g (lumped bar) and --positions-mm (beam)"),
    };
    // Divisions, not products: 175 mm is the same double as 0.175 m (see apply_beam_flags).
    let values: Vec<f64> = values.iter().map(|v| v / 1e3).collect();
    let mut sc = Scenario::load(&args.scenario)?;
    sc.apply_beam_flags(args.beam_modes, None)?;
    if axis == DesignAxis::Position && sc.beam.is_none() {
        bail!(
            "--positions-mm moves the cavity along a [beam]; this scenario is {} (use \
             --ball-masses-g)",
            if sc.modes.is_some() {
                "measured modes, [[modes]]"
            } else {
                "the lumped bar"
            }
        );
    }
    let spec = LobeDesignSpec {
        base: sc.cut_problem()?,
        beam: sc.beam.clone(),
        axis,
    };
    let grid = DesignGrid::new(axis, gaps, values)?;
    for d in grid.points() {
        spec.problem(&d)
            .with_context(|| format!("design {}", describe(axis, d.gap_m, d.value)))?;
    }
    Ok((sc, spec, grid, rpms))
}

fn describe(axis: DesignAxis, gap_m: f64, value: f64) -> String {
    let second = match axis {
        DesignAxis::BallMass => format!("ball {} g", fmt_coord(value * 1e3)),
        DesignAxis::Position => format!("cavity at {} mm", fmt_coord(value * 1e3)),
    };
    format!("gap {} mm, {second}", fmt_coord(gap_m * 1e3))
}

/// `vibrobar lobe-design`.
pub fn run(args: &LobeDesignArgs) -> Result<()> {
    let t0 = Instant::now();
    let (sc, spec, grid, rpms) = job(args)?;
    let shard = args
        .shard
        .as_deref()
        .map(shard::parse_shard)
        .transpose()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let indices = shard::shard_indices(grid.len(), shard);
    let axis = grid.axis();
    let schema = lobe_design_schema(axis);
    let meta = Metadata::new(
        LOBE_DESIGN_KIND,
        &schema.header(),
        LobeDesignParams {
            scenario: &sc,
            spindle_rpm: &rpms,
            gaps_m: grid.gaps_m(),
            axis: axis.column(),
            values: grid.values(),
            order: "gap-major (every value of the second axis for the first gap, then the next)",
        },
        Some(GridInfo {
            total: grid.len(),
            shard,
            indices: shard.map(|_| indices.clone()),
        }),
    );
    // The solid reference first (once per speed, shared by every design): a structure the
    // judge cannot run yet fails here, before a journal is opened.
    let bar = Progress::new("lobe-design: solid reference", rpms.len(), 0);
    let progress = bar.callback();
    let runner = Runner::default().with_threads(args.threads);
    let solid = solid_reference(&spec.base, &rpms, &runner.with_progress(&progress));
    bar.finish();
    let solid = solid.map_err(|e| anyhow::anyhow!("solid reference: {e}"))?;
    let key = |i: usize| match grid.point(i) {
        Some(d) => lobe_design_key(axis, d.gap_m, d.value),
        None => String::new(),
    };
    let journal = super::open_journal(&args.out, &meta, &schema, &indices, &key, args.resume)?;
    let pending = journal.pending();
    let bar = Progress::new("lobe-design", indices.len(), journal.done_count());
    let progress = bar.callback();
    let res = runner
        .with_progress(&progress)
        .each(&pending, |&i| -> Result<()> {
            let d = grid.point(i).expect("index inside the grid");
            let row = score_design(&spec, &d, &solid)
                .with_context(|| format!("design {}", describe(axis, d.gap_m, d.value)))?;
            journal.append(i, &schema.format(&lobe_design_values(&row)))?;
            Ok(())
        });
    bar.finish();
    res.map_err(batch_error)?;
    journal.finish()?;
    meta.write_beside(&args.out)
        .with_context(|| format!("writing metadata beside {}", args.out.display()))?;
    eprintln!(
        "lobe-design: {} designs × {} speeds written to {} in {}",
        indices.len(),
        rpms.len(),
        args.out.display(),
        super::fmt_secs(t0.elapsed().as_secs_f64())
    );
    if shard.is_none() {
        postprocess(&args.out, !args.no_figure)?;
    }
    Ok(())
}

/// After a whole study is written (by `lobe-design` or `merge`): the optimum file and the
/// figure, both from the CSV itself so both paths give the same result; the optimum printed.
pub fn postprocess(csv: &Path, figure: bool) -> Result<()> {
    let (axis, rows) = read_lobe_design_csv(csv)?;
    let schema = lobe_design_schema(axis);
    let Some(best) = optimum(&rows) else {
        bail!("{}: no designs", csv.display());
    };
    let opt = super::map::optimum_path(csv);
    let text = format!(
        "{}\n{}\n",
        schema.header(),
        schema.format(&lobe_design_values(best))
    );
    vibrobar_io::write_atomic(&opt, text.as_bytes())
        .with_context(|| format!("writing {}", opt.display()))?;
    let um = |m: f64| format!("{:.3} µm", m * 1e6);
    println!(
        "solid bar over the band: worst {} at {} rpm, mean {}",
        um(best.solid.worst_width_m),
        fmt_coord(best.solid.worst_rpm),
        um(best.solid.mean_width_m)
    );
    let gain = |g: Option<f64>| g.map_or("—".to_string(), |g| format!("{g:.3}×"));
    println!(
        "optimum ({} designs): {}: worst {} at {} rpm ({} the solid bar's), mean {} ({})",
        rows.len(),
        describe(axis, best.point.gap_m, best.point.value),
        um(best.damped.worst_width_m),
        fmt_coord(best.damped.worst_rpm),
        gain(best.worst_gain()),
        um(best.damped.mean_width_m),
        gain(best.mean_gain())
    );
    println!("wrote {}", opt.display());
    if figure {
        for f in vibrobar_report::figures::lobe_design::draw_lobe_design_figure(csv, axis, &rows)? {
            println!("wrote {}", f.display());
        }
    }
    Ok(())
}
