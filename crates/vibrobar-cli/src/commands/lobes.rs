//! `vibrobar lobes`: exact linear stability lobes of regenerative chatter
//! ([`vibrobar_core::analysis::lobes`]) of a `[cutting]` scenario, on any structure (lumped
//! bar, `[beam]`, `[[modes]]`): the damped bar with the ball free and with the ball stuck, and
//! the solid reference. CSV schema `vibrobar_io::csv::lobes_schema`, metadata beside it, and a
//! figure (`STEM.png`, `STEM.svg`) of the boundaries with their stable sides shaded.

use anyhow::{Context, Result};
use clap::Args;
use serde::Serialize;
use std::path::PathBuf;
use vibrobar_core::analysis::lobes::{LobeRow, Lobes};

use crate::scenario::{spindle_speeds, Scenario};

/// `vibrobar lobes`.
#[derive(Debug, Args)]
pub struct LobesArgs {
    /// Scenario file (TOML) with a `[cutting]` section (K_f and the direction factors set the
    /// boundary; width, feed and spindle speed do not enter it); its bar is `[bar]`, `[beam]`
    /// or `[[modes]]`.
    #[arg(long, value_name = "FILE.toml")]
    pub scenario: PathBuf,
    /// Spindle speeds in rpm as START:STOP:STEP, STOP included, each in [1, 200000]
    /// (1000:50000:49 is 1001 speeds).
    #[arg(long, value_name = "START:STOP:STEP")]
    pub rpm: String,
    /// Number of modes N of a `[beam]` scenario, overriding `[beam] modes`, in [1, 32].
    #[arg(long, value_name = "N")]
    pub beam_modes: Option<usize>,
    /// Cavity centre (the ball) of a `[beam]` scenario in mm from the clamp, overriding
    /// `[beam] cavity_position_m`.
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub cavity_position_mm: Option<f64>,
    /// No figure (CSV and metadata only).
    #[arg(long)]
    pub no_figure: bool,
    /// Time-domain lobes (issue #14): per speed the largest acceptable width of the solid and
    /// the damped bar from the small and the large disturbance of `[time_domain]` (lumped bar;
    /// see `vibrobar width-diagram`), instead of the exact linear lobes.
    #[arg(long)]
    pub time_domain: bool,
    /// With --time-domain: complete an interrupted run from its journal.
    #[arg(long, requires = "time_domain")]
    pub resume: bool,
    /// With --time-domain: compute only shard K of N (speeds K, K+N, …); join with `vibrobar
    /// merge`.
    #[arg(long, value_name = "K/N", requires = "time_domain")]
    pub shard: Option<String>,
    /// Output CSV: spindle_rpm,b_lim_m,chatter_frequency_hz,b_lim_ball_stuck_m,
    /// chatter_frequency_ball_stuck_hz,b_lim_solid_m,chatter_frequency_solid_hz,lobe,
    /// lobe_ball_stuck,lobe_solid; parameters go to FILE.meta.json, the figure to STEM.png and
    /// STEM.svg.
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
}

/// What the metadata records: the scenario (with its `[cutting]` and, for `[[modes]]` alone,
/// `reference = "no_ball"`) and the speeds asked for.
#[derive(Serialize)]
struct LobesParams<'a> {
    scenario: &'a Scenario,
    rpm_start: f64,
    rpm_stop: f64,
    rpm_step: f64,
}

/// Parse `--rpm START:STOP:STEP` into the speeds.
pub fn parse_rpm(text: &str) -> Result<(f64, f64, f64, Vec<f64>)> {
    let parts: Vec<&str> = text.split(':').collect();
    if parts.len() != 3 {
        anyhow::bail!("--rpm must be START:STOP:STEP (e.g. 1000:50000:49), got {text:?}");
    }
    let mut v = [0.0; 3];
    for (i, (p, name)) in parts.iter().zip(["START", "STOP", "STEP"]).enumerate() {
        v[i] = p.trim().parse::<f64>().map_err(|_| {
            anyhow::anyhow!("--rpm {name} must be a number, got {p:?} (in {text:?})")
        })?;
    }
    Ok((v[0], v[1], v[2], spindle_speeds("--rpm", v[0], v[1], v[2])?))
}

/// Run the command.
pub fn run(args: &LobesArgs) -> Result<()> {
    let (start, stop, step, rpms) = parse_rpm(&args.rpm)?;
    if args.time_domain {
        if args.beam_modes.is_some() || args.cavity_position_mm.is_some() {
            anyhow::bail!(
                "--time-domain runs the scenario's own structure ([bar], [beam] or [[modes]]); \
                 --beam-modes and --cavity-position-mm do not apply to it"
            );
        }
        let _ = (start, stop, step);
        return super::time_domain::td_lobes(&super::time_domain::TdLobesArgs {
            scenario: args.scenario.clone(),
            rpms,
            resume: args.resume,
            shard: args.shard.clone(),
            no_figure: args.no_figure,
            out: args.out.clone(),
        });
    }
    let mut sc = Scenario::load_any(&args.scenario)?;
    sc.apply_beam_flags(args.beam_modes, args.cavity_position_mm)?;
    let spec = sc.lobe_spec()?;
    // Every file this command writes, refused up front if it is an input (the scenario): the
    // CSV, its metadata and the figure. A device or FIFO gets the CSV only (no sidecars).
    let draw = !args.no_figure && vibrobar_io::resolve_output(&args.out)?.is_regular();
    let stem = args.out.with_extension("");
    for p in [
        args.out.clone(),
        vibrobar_io::meta::meta_path(&args.out),
        vibrobar_report::figures::with_ext(&stem, "png"),
        vibrobar_report::figures::with_ext(&stem, "svg"),
    ] {
        vibrobar_io::refuse_input(&p)?;
    }
    let t0 = std::time::Instant::now();
    let mut lobes = Lobes::new(&spec)?;
    let rows: Vec<LobeRow> = rpms
        .iter()
        .map(|&n| lobes.row(n))
        .collect::<Result<_, _>>()?;
    let secs = t0.elapsed().as_secs_f64();
    vibrobar_io::csv::write_lobes_csv(&args.out, &rows)
        .with_context(|| format!("writing {}", args.out.display()))?;
    vibrobar_io::Metadata::new(
        "lobes",
        &vibrobar_io::csv::lobes_schema().header(),
        LobesParams {
            scenario: &sc,
            rpm_start: start,
            rpm_stop: stop,
            rpm_step: step,
        },
        None,
    )
    .write_beside(&args.out)
    .with_context(|| format!("metadata beside {}", args.out.display()))?;
    let structure = match (&sc.beam, &sc.modes) {
        (_, Some(m)) => format!("{} measured mode(s)", m.len()),
        (Some(_), None) => format!("beam, {} mode(s)", spec.damped.len()),
        (None, None) => "lumped bar".to_string(),
    };
    let figures = if !draw {
        Vec::new()
    } else {
        vibrobar_report::figures::lobes::draw_lobes_figure(
            &args.out,
            &rows,
            &format!("Stability lobes of regenerative chatter ({structure})"),
        )?
    };

    println!("vibrobar lobes ({})", crate::VERSION);
    let cut = sc.cutting.expect("lobe_spec checked it");
    println!(
        "  cut        : K_f = {:e} N/m², c_force = {}, c_chip = {} (K_f·c_force·c_chip = {:e} N/m²); {structure}; ball {} g",
        cut.coefficient_n_m2,
        cut.force_direction_factor,
        cut.chip_direction_factor,
        spec.oriented_coefficient_n_m2,
        spec.ball_mass_kg * 1e3
    );
    let reference = if sc.reference.is_some() {
        "solid reference = the same modes without the ball (no_ball)"
    } else {
        "solid reference bar"
    };
    for (label, t) in [
        ("ball free ", &lobes.tables()[0]),
        ("ball stuck", &lobes.tables()[1]),
        ("solid     ", &lobes.tables()[2]),
    ] {
        let (s, w) = t.minimum();
        println!(
            "  {label} : b_lim,min = {:.6} mm at {:.2} Hz (lowest point of every lobe)",
            s / spec.oriented_coefficient_n_m2 * 1e3,
            w / (2.0 * std::f64::consts::PI)
        );
    }
    println!(
        "  ({reference}; the ball acts only at finite amplitude: linearised, it is free or stuck)"
    );
    println!(
        "  output     : {} speeds {}–{} rpm to {} (+ .meta.json{}) in {}",
        rows.len(),
        vibrobar_io::csv::fmt_coord(start),
        vibrobar_io::csv::fmt_coord(rows.last().map_or(stop, |r| r.spindle_rpm)),
        args.out.display(),
        if figures.is_empty() {
            String::new()
        } else {
            format!(
                ", {}",
                figures
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        },
        super::fmt_secs(secs)
    );
    Ok(())
}
