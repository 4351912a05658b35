//! `vibrobar frf`: frequency response functions of a scenario's bar
//! ([`vibrobar_core::analysis::frf`]) over a band in Hz: the linear receptances of the solid
//! reference, of the damped bar with the ball free and with the ball stuck, between any two of
//! the force, cavity and response points; the stepped sine of the nonlinear damped bar at a
//! force level; a simulated tap test (H1 and coherence). CSV schema
//! `vibrobar_io::frf_csv::frf_schema`, metadata beside it, and a figure (`STEM.png`,
//! `STEM.svg`) of the magnitudes and phases overlaid.

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use serde::Serialize;
use std::path::PathBuf;
use vibrobar_core::analysis::frf::{
    frequency_lines_hz, linear_frf, stepped_sine, tap_test, FrfCurve, ResponsePoint, SteppedSine,
    TapTest,
};
use vibrobar_core::analysis::Runner;
use vibrobar_core::params::BarModel;
use vibrobar_core::structure::{ModalModel, Point, Structure};

use crate::cli::{ContactArg, FrictionArg};
use crate::progress::Progress;
use crate::scenario::{check_positive, Overrides, Scenario};

/// A point of the bar.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PointArg {
    /// Where the force acts (the tip of a lumped bar or of measured modes).
    Force,
    /// The cavity centre (the ball).
    Cavity,
    /// Where the response is measured (the tip of a lumped bar or of measured modes).
    Response,
}

impl From<PointArg> for Point {
    fn from(p: PointArg) -> Point {
        match p {
            PointArg::Force => Point::Force,
            PointArg::Cavity => Point::Cavity,
            PointArg::Response => Point::Response,
        }
    }
}

/// One curve of the FRF.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CurveArg {
    /// The solid reference bar (linear).
    Solid,
    /// The damped bar with the ball free: it never touches a wall (linear: the bar alone).
    BallFree,
    /// The damped bar with the ball stuck at the cavity, its mass added there (linear).
    BallStuck,
    /// The nonlinear damped bar forced at --force-n: first harmonic of the settled response.
    SteppedSine,
    /// A simulated tap test of the damped bar: H1 and coherence (depends on the tap force).
    Tap,
}

/// `vibrobar frf`.
#[derive(Debug, Args)]
pub struct FrfArgs {
    /// Scenario file (TOML): its bar (`[bar]`/`[solid_bar]`, `[beam]` or `[[modes]]`), ball and
    /// contact law; a `[cutting]` section is not applied (the FRF is the bar's, out of the cut)
    /// [default: the paper's lumped bars].
    #[arg(long, value_name = "FILE.toml")]
    pub scenario: Option<PathBuf>,
    /// Frequency lines in Hz as START:STOP:STEP, STOP included (e.g. 400:800:0.5), each in
    /// (0, 1e7], at most 100000 lines.
    #[arg(long, value_name = "START:STOP:STEP")]
    pub band_hz: String,
    /// Curves, comma-separated.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "solid,ball-free,ball-stuck"
    )]
    pub curves: Vec<CurveArg>,
    /// Point where the force acts (the stepped sine and the tap test force the force point).
    #[arg(long, value_enum, default_value = "force")]
    pub from: PointArg,
    /// Point whose displacement is the response (the stepped sine and the tap test read the
    /// response point or the cavity).
    #[arg(long, value_enum, default_value = "response")]
    pub to: PointArg,
    /// Total clearance in mm (the ball moves ±gap/2) [default: from the scenario].
    #[arg(long, value_name = "G", allow_negative_numbers = true)]
    pub gap_mm: Option<f64>,
    /// Friction law [default: from the scenario].
    #[arg(long, value_enum)]
    pub friction: Option<FrictionArg>,
    /// Friction force level in N, overriding η/r·m_d·g.
    #[arg(long, value_name = "F_N", allow_negative_numbers = true)]
    pub friction_force_n: Option<f64>,
    /// Ball–wall contact law [default: the scenario's].
    #[arg(long, value_enum)]
    pub contact: Option<ContactArg>,
    /// Solver of the stepped sine (the tap test always runs the exact solver) [default: the
    /// scenario's].
    #[arg(long)]
    pub solver: Option<String>,
    /// Number of modes N of a `[beam]` scenario, in [1, 32].
    #[arg(long, value_name = "N")]
    pub beam_modes: Option<usize>,
    /// Cavity centre of a `[beam]` scenario in mm from the clamp.
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub cavity_position_mm: Option<f64>,
    /// Stepped sine: force amplitude F0 in N [default: the scenario's forcing amplitude].
    #[arg(long, value_name = "F0", allow_negative_numbers = true)]
    pub force_n: Option<f64>,
    /// Stepped sine: run time in s before the measuring window at each line [default: the
    /// time in which the slowest mode's free decay falls by 1e12].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub settle_s: Option<f64>,
    /// Stepped sine: measuring window in forcing periods, in [1, 100000].
    #[arg(long, value_name = "N", default_value_t = 50)]
    pub measure_periods: u32,
    /// Tap test: peak force of the half-sine hammer pulse in N.
    #[arg(
        long,
        value_name = "P",
        allow_negative_numbers = true,
        default_value_t = 100.0
    )]
    pub tap_force_n: f64,
    /// Tap test: duration of the pulse in s.
    #[arg(
        long,
        value_name = "S",
        allow_negative_numbers = true,
        default_value_t = 1e-4
    )]
    pub tap_duration_s: f64,
    /// Tap test: number of taps averaged, in [1, 1000].
    #[arg(long, value_name = "N", default_value_t = 5)]
    pub taps: usize,
    /// Tap test: sample rate in Hz, above twice the highest line [default: 20 × the larger of
    /// the highest line and 1/duration].
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    pub sample_rate_hz: Option<f64>,
    /// Tap test: record length in s from the start of the pulse [default: the time in which the
    /// slowest mode's free decay falls by 1e8].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub record_s: Option<f64>,
    /// No figure (CSV and metadata only).
    #[arg(long)]
    pub no_figure: bool,
    /// Output CSV: frequency_hz, then per curve CURVE_re_m_per_n, CURVE_im_m_per_n,
    /// CURVE_mag_m_per_n, CURVE_phase_deg (CURVE = solid, ball_free, ball_stuck, stepped_sine,
    /// tap), and stepped_sine_rms_m, stepped_sine_impacts_per_cycle, tap_coherence; parameters
    /// go to FILE.meta.json, the figure to STEM.png and STEM.svg.
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
}

/// What the metadata records.
#[derive(Serialize)]
struct FrfParams<'a> {
    scenario: &'a Scenario,
    band_hz: [f64; 3],
    curves: &'a [CurveArg],
    from: PointArg,
    to: PointArg,
    stepped_sine: Option<SteppedSineParams>,
    tap: Option<TapParams>,
}

#[derive(Serialize)]
struct SteppedSineParams {
    solver: String,
    force_amplitude_n: f64,
    settle_s: f64,
    measure_periods: u32,
}

#[derive(Serialize)]
struct TapParams {
    solver: &'static str,
    peak_force_n: f64,
    pulse_duration_s: f64,
    taps: usize,
    sample_rate_hz: f64,
    record_s: f64,
    ball_start_w_m: String,
    impacts_per_tap: Vec<u64>,
}

/// Parse `--band-hz START:STOP:STEP` into the lines.
pub fn parse_band(text: &str) -> Result<([f64; 3], Vec<f64>)> {
    parse_lines("--band-hz", text)
}

/// Parse a `flag` of frequencies in Hz, `START:STOP:STEP` (STOP included), into the lines:
/// each in (0, 1e7] Hz, at most 100000 of them.
pub fn parse_lines(flag: &'static str, text: &str) -> Result<([f64; 3], Vec<f64>)> {
    let v = super::lobes::start_stop_step(flag, text, "START:STOP:STEP in Hz (e.g. 400:800:0.5)")?;
    Ok((v, frequency_lines_hz(flag, v[0], v[1], v[2])?))
}

fn modal(b: BarModel) -> Result<ModalModel> {
    Ok(match b {
        BarModel::Lumped(bar) => Structure::Lumped(bar).modal_model()?,
        BarModel::Modal(m) => m,
    })
}

fn response_point(p: PointArg, what: &str) -> Result<ResponsePoint> {
    match p {
        PointArg::Response => Ok(ResponsePoint::Response),
        PointArg::Cavity => Ok(ResponsePoint::Cavity),
        PointArg::Force => anyhow::bail!(
            "--to force: the {what} reads the response point or the cavity (allowed: response, \
             cavity); the linear curves take any point"
        ),
    }
}

/// Run the command.
pub fn run(args: &FrfArgs) -> Result<()> {
    let t0 = std::time::Instant::now();
    let (band, lines) = parse_band(&args.band_hz)?;
    let mut sc = match &args.scenario {
        Some(p) => Scenario::load_any(p)?,
        None => Scenario::paper(),
    };
    sc.apply(&Overrides {
        friction: args.friction.map(Into::into),
        friction_force_n: args.friction_force_n,
        contact: args.contact.map(Into::into),
        solver: args.solver.clone(),
        ..Default::default()
    })?;
    sc.apply_beam_flags(args.beam_modes, args.cavity_position_mm)?;
    if let Some(g) = args.gap_mm {
        check_positive("--gap-mm", g, "mm")?;
        sc.damper.gap_m = g / 1e3;
    }
    let mut curves_asked: Vec<CurveArg> = Vec::new();
    for c in &args.curves {
        if !curves_asked.contains(c) {
            curves_asked.push(*c);
        }
    }
    if curves_asked.is_empty() {
        anyhow::bail!("--curves is empty (allowed: one or more of solid, ball-free, ball-stuck, stepped-sine, tap)");
    }
    let simulated = curves_asked
        .iter()
        .any(|c| matches!(c, CurveArg::SteppedSine | CurveArg::Tap));
    if simulated && args.from != PointArg::Force {
        anyhow::bail!(
            "--from {}: the stepped sine and the tap test force the force point (allowed: force)",
            match args.from {
                PointArg::Cavity => "cavity",
                _ => "response",
            }
        );
    }
    // Every file this command writes, refused up front if it is an input (the scenario).
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
    let (damped_bar, solid_bar) = sc.bars()?;
    let damped_model = modal(damped_bar).context("bar with the cavity")?;
    let solid_model = modal(solid_bar).context("solid reference bar")?;
    let (from, to) = (Point::from(args.from), Point::from(args.to));
    let md = sc.damper.ball_mass_kg;
    let mut curves = Vec::new();
    let mut ss_params = None;
    let mut tap_params = None;
    let mut notes = Vec::new();
    for c in &curves_asked {
        match c {
            CurveArg::Solid => curves.push(FrfCurve::linear(
                "solid",
                linear_frf(&solid_model, None, from, to, &lines).context("solid reference bar")?,
            )),
            CurveArg::BallFree => curves.push(FrfCurve::linear(
                "ball_free",
                linear_frf(&damped_model, None, from, to, &lines).context("bar with the cavity")?,
            )),
            CurveArg::BallStuck => curves.push(FrfCurve::linear(
                "ball_stuck",
                linear_frf(&damped_model, Some(md), from, to, &lines)
                    .context("bar with the cavity, ball stuck")?,
            )),
            CurveArg::SteppedSine => {
                sc.validate()?;
                let sys = sc.damped_system()?;
                let spec = SteppedSine {
                    force_amplitude_n: args.force_n.unwrap_or(sc.forcing.amplitude_n),
                    settle_s: args.settle_s,
                    measure_periods: args.measure_periods,
                    response: response_point(args.to, "stepped sine")?,
                };
                let settle_s = spec.validate(&sys)?;
                let solver = super::solver(&sc.run.solver, &sc.settings())?;
                let bar = Progress::new("frf stepped sine", lines.len(), 0);
                let progress = bar.callback();
                let rows = stepped_sine(
                    &sys,
                    &sc.initial,
                    &spec,
                    &lines,
                    solver.as_ref(),
                    Runner::default().with_progress(&progress),
                );
                bar.finish();
                let rows = rows.map_err(|e| anyhow::anyhow!("frf: {e}"))?;
                let impacting = rows.iter().filter(|r| r.impacts > 0).count();
                notes.push(format!(
                    "stepped sine: F0 = {} N, settle {:.3} s + {} periods per line, {} solver; impacts at {impacting} of {} lines",
                    spec.force_amplitude_n,
                    settle_s,
                    spec.measure_periods,
                    solver.name(),
                    lines.len()
                ));
                ss_params = Some(SteppedSineParams {
                    solver: solver.name().to_string(),
                    force_amplitude_n: spec.force_amplitude_n,
                    settle_s,
                    measure_periods: spec.measure_periods,
                });
                curves.push(FrfCurve::stepped_sine(&rows));
            }
            CurveArg::Tap => {
                sc.validate()?;
                let sys = sc.damped_system()?;
                let spec = TapTest {
                    peak_force_n: args.tap_force_n,
                    pulse_duration_s: args.tap_duration_s,
                    taps: args.taps,
                    sample_rate_hz: args.sample_rate_hz,
                    record_s: args.record_s,
                    response: response_point(args.to, "tap test")?,
                };
                let (rows, summary) = tap_test(&sys, &spec, &lines, Runner::default())
                    .map_err(|e| anyhow::anyhow!("frf: tap test: {e}"))?;
                let min_coh = rows.iter().map(|r| r.coherence).fold(1.0, f64::min);
                notes.push(format!(
                    "tap test: {} taps of {} N over {} s, fs = {} Hz, record {:.3} s; impacts per tap {:?}; lowest coherence {min_coh:.6}{}",
                    spec.taps,
                    spec.peak_force_n,
                    spec.pulse_duration_s,
                    summary.sample_rate_hz,
                    summary.record_s,
                    summary.impacts_per_tap,
                    if summary.impacts_per_tap.iter().any(|&n| n > 0) {
                        " (the ball impacts: this H1 holds for this tap force only)"
                    } else {
                        ""
                    }
                ));
                tap_params = Some(TapParams {
                    solver: "exact",
                    peak_force_n: spec.peak_force_n,
                    pulse_duration_s: spec.pulse_duration_s,
                    taps: spec.taps,
                    sample_rate_hz: summary.sample_rate_hz,
                    record_s: summary.record_s,
                    ball_start_w_m: "tap k of n: (2(k + 1/2)/n − 1) · gap/2, at rest".into(),
                    impacts_per_tap: summary.impacts_per_tap.clone(),
                });
                curves.push(FrfCurve::tap(&rows));
            }
        }
    }
    let secs = t0.elapsed().as_secs_f64();
    vibrobar_io::frf_csv::write_frf_csv(&args.out, &lines, &curves)
        .with_context(|| format!("writing {}", args.out.display()))?;
    vibrobar_io::Metadata::new(
        "frf",
        &vibrobar_io::frf_csv::frf_schema(&curves).header(),
        FrfParams {
            scenario: &sc,
            band_hz: band,
            curves: &curves_asked,
            from: args.from,
            to: args.to,
            stepped_sine: ss_params,
            tap: tap_params,
        },
        None,
    )
    .write_beside(&args.out)
    .with_context(|| format!("metadata beside {}", args.out.display()))?;
    let structure = match (&sc.beam, &sc.modes) {
        (_, Some(m)) => format!("{} measured mode(s)", m.len()),
        (Some(_), None) => format!("beam, {} mode(s)", damped_model.len()),
        (None, None) => "lumped bar".to_string(),
    };
    let name = |p: PointArg| match p {
        PointArg::Force => "force point",
        PointArg::Cavity => "cavity",
        PointArg::Response => "response point",
    };
    let figures = if draw {
        vibrobar_report::figures::frf::draw_frf_figure(
            &args.out,
            &lines,
            &curves,
            &format!(
                "Receptance, {} → {} ({structure})",
                name(args.from),
                name(args.to)
            ),
        )?
    } else {
        Vec::new()
    };

    println!("vibrobar frf ({})", crate::VERSION);
    println!(
        "  model      : {structure}; ball {} g, gap {} mm, friction {}; force at the {}, response at the {}",
        md * 1e3,
        vibrobar_io::csv::fmt_coord(sc.damper.gap_m * 1e3),
        sc.damper.friction,
        name(args.from),
        name(args.to)
    );
    for c in &curves {
        let (i, g) = c
            .values_m_per_n
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.norm().total_cmp(&b.1.norm()))
            .expect("at least one line");
        println!(
            "  {:<12} : peak |G| = {:.4e} m/N at {} Hz",
            c.name,
            g.norm(),
            vibrobar_io::csv::fmt_coord(lines[i])
        );
    }
    for n in &notes {
        println!("  {n}");
    }
    println!(
        "  output     : {} lines {}–{} Hz to {} (+ .meta.json{}) in {}",
        lines.len(),
        vibrobar_io::csv::fmt_coord(lines[0]),
        vibrobar_io::csv::fmt_coord(*lines.last().expect("one line")),
        args.out.display(),
        super::after_outputs(&figures),
        super::fmt_secs(secs)
    );
    Ok(())
}
