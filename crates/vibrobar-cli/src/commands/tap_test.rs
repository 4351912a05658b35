//! `vibrobar tap-test`: the worked example `docs/tap-test.md`, from a tap test to a design.
//!
//! The "measurement" is made here: the driving-point receptance at the tool tip of a known
//! 3-mode bar and its cross receptance to the cavity, on 2 Hz lines from 2 to 12 000 Hz, with
//! 1 % complex noise from a fixed seed, written as universal files (dataset 58, ASCII). From
//! them the command runs what a user runs:
//! 1. `vibrobar fit-modes` (the same function): `[[modes]]`, the stabilisation chart and the
//!    fit; the recovered parameters against the true ones, with and without the noise;
//! 2. the lobes straight from the measured lines (the spline of `vibrobar lobes --frf`), from the
//!    fitted modes and from the true system;
//! 3. the damped design on the fitted bar: where the cavity goes (the fitted modes with the
//!    clamped–free beam's shape at each position, forced-response sweeps with the ball beside
//!    the bar without it) and how wide it cuts (time-domain lobe design of gap × ball mass at
//!    the chosen position, the functions of `vibrobar lobe-design`).
//!
//! Every number in the document is computed by this run; every file is written atomically, the
//! document last.
use super::{check_value, fmt_coord, parse_range};
use crate::progress::Progress;
use anyhow::{bail, Context, Result};
use num_complex::Complex64;
use plotters::style::RGBColor;
use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vibrobar_core::analysis::batch::Runner;
use vibrobar_core::analysis::ensemble::SplitMix64;
use vibrobar_core::analysis::lobe_design::{
    optimum, DesignAxis, DesignRow, SPREAD_REL, SPREAD_SEEDS,
};
use vibrobar_core::analysis::lobes_frf::FrfLobeTable;
use vibrobar_core::structure::fit::{self, FitSettings, FrfLines, ModalFit};
use vibrobar_core::structure::frf_data::{FrfKind, MeasuredFrf};
use vibrobar_core::structure::MeasuredMode;
use vibrobar_io::csv::{lobe_design_schema, lobe_design_values, write_text};
use vibrobar_io::frf::{read_frf, write_frf_uff, FrfReadOptions, Uff58Header};
use vibrobar_report::plot::Curve;
use vibrobar_scenario::Scenario;

/// `vibrobar tap-test`.
#[derive(Debug, Clone, clap::Args)]
pub struct TapTestArgs {
    /// The Markdown document to write (e.g. docs/tap-test.md); the measured files, the fitted
    /// modes, the scenarios, tables and figures go to the directory of the same name without
    /// `.md`.
    #[arg(long, value_name = "FILE.md")]
    pub out: PathBuf,
    /// Spindle speeds of the linear lobes, rpm, START:STOP:STEP (inclusive), in [1, 200000].
    #[arg(long, default_value = "2000:20000:10", value_name = "START:STOP:STEP")]
    pub lobes_rpm: String,
    /// Cavity centres tried, mm from the clamp, START:STOP:STEP (inclusive), inside the
    /// 175 mm bar.
    #[arg(long, default_value = "80:160:10", value_name = "START:STOP:STEP")]
    pub positions_mm: String,
    /// Gaps of the forced-response placement and of the lobe design, mm, START:STOP:STEP.
    #[arg(long, default_value = "0.05:0.2:0.05", value_name = "START:STOP:STEP")]
    pub gaps_mm: String,
    /// Forcing frequency ratios Ω/ω₁ of the placement's band, START:STOP:STEP.
    #[arg(
        long,
        default_value = "0.95:1.05:0.005",
        value_name = "START:STOP:STEP"
    )]
    pub ratios: String,
    /// Simulated time of each forced-response run, s (RMS over its last 80 %).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub forced_duration: f64,
    /// Ball masses of the lobe design, g, START:STOP:STEP (inclusive).
    #[arg(long, default_value = "13:39:13", value_name = "START:STOP:STEP")]
    pub ball_masses_g: String,
    /// Spindle speeds of the lobe design's band, rpm, START:STOP:STEP (inclusive).
    #[arg(long, default_value = "4000:6000:1000", value_name = "START:STOP:STEP")]
    pub design_rpm: String,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// The known bar: the first three bending modes of the paper's bar as a beam with its cavity,
/// in the tip normalisation: (frequency Hz, damping ratio, modal mass kg, shape at the cavity).
pub const TRUE_MODES: [(f64, f64, f64, f64); 3] = [
    (597.51, 0.01, 0.15637, 0.70066),
    (3588.7, 0.012, 0.16333, -0.015423),
    (10057.0, 0.02, 0.17623, -0.55646),
];
/// The bar's length, m, and the cavity centre of the cross FRF, m from the clamp.
const LENGTH_M: f64 = 0.175;
const CAVITY_M: f64 = 0.137;
/// Noise: each line times (1 + ε), ε complex with parts uniform in ±NOISE.
const NOISE: f64 = 0.01;
/// The seeds of the tip and the cross record's noise.
const SEEDS: (u64, u64) = (11, 12);
/// The cut: K_f of steel (N/m²), direction factors 1.
const K_F: f64 = 2e9;
/// The ball template: the paper's 15 mm carbide ball.
const BALL_RADIUS_M: f64 = 0.0075;
const BALL_MASS_KG: f64 = 0.026;

/// 2 Hz lines from 2 Hz to 12 000 Hz.
fn lines() -> Vec<f64> {
    (1..=6000).map(|k| 2.0 * k as f64).collect()
}

/// The true receptance between the tip and the tip (`cross` false) or the cavity, m/N.
fn true_receptance(f_hz: f64, cross: bool) -> Complex64 {
    let w = 2.0 * PI * f_hz;
    TRUE_MODES
        .iter()
        .map(|&(f, z, m, s)| {
            let wn = 2.0 * PI * f;
            let phi = if cross { s } else { 1.0 };
            phi / (m * Complex64::new(wn * wn - w * w, 2.0 * z * wn * w))
        })
        .sum()
}

/// The record: the true receptance times (1 + ε), ε of `noise` from `seed`.
fn record(cross: bool, noise: f64, seed: u64) -> Result<MeasuredFrf> {
    let mut rng = SplitMix64::new(seed);
    let f = lines();
    let h = f
        .iter()
        .map(|&f| {
            let e = Complex64::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)) * noise;
            true_receptance(f, cross) * (1.0 + e)
        })
        .collect();
    Ok(MeasuredFrf::new(
        f,
        h,
        FrfKind::Receptance,
        None,
        !cross,
        "SI (m/N)".into(),
    )?)
}

/// The fit of `vibrobar fit-modes` with its defaults.
fn fit_of(tip: &MeasuredFrf, cross: &MeasuredFrf) -> Result<ModalFit> {
    let d = FrfLines::from(tip);
    let c = FrfLines::from(cross);
    Ok(fit::fit_modes(&d, Some(&c), &FitSettings::default())?)
}

/// Modes `(f, ζ, m)` with the shape at the cavity.
fn measured(
    modes: &[(f64, f64, f64)],
    shape: impl Fn(usize) -> Result<f64>,
) -> Result<Vec<MeasuredMode>> {
    modes
        .iter()
        .enumerate()
        .map(|(k, &(f, z, m))| {
            let mode = MeasuredMode {
                frequency_hz: f,
                damping_ratio: z,
                modal_mass_kg: m,
                shape_cavity: shape(k)?,
                direction_deg: None,
            };
            mode.validate()?;
            Ok(mode)
        })
        .collect()
}

/// The `[[modes]]` tables of a scenario.
fn modes_toml(modes: &[MeasuredMode]) -> String {
    let mut s = String::new();
    for m in modes {
        let _ = writeln!(
            s,
            "[[modes]]\nfrequency_hz = {:e}\ndamping_ratio = {:e}\nmodal_mass_kg = {:e}\nshape_cavity = {:e}\n",
            m.frequency_hz, m.damping_ratio, m.modal_mass_kg, m.shape_cavity
        );
    }
    s
}

/// The damper table of the scenarios: the paper's ball, Coulomb friction at η/r·m_d·g.
fn damper_toml(gap_m: f64) -> String {
    format!(
        "[damper]\nball_mass_kg = {BALL_MASS_KG}\nball_radius_m = {BALL_RADIUS_M}\nrestitution = 0.5\ngap_m = {gap_m:e}\nrolling_friction_m = 6.0e-4\nfriction = \"coulomb\"\n"
    )
}

fn cutting_toml() -> String {
    format!(
        "[cutting]\ncoefficient_n_m2 = {K_F:e}\nwidth_m = 2.0e-5\nfeed_m = 1.0e-4\nspindle_rpm = 5000.0\nforce_law = \"linear\"\n"
    )
}

fn rel(path: &Path, doc: &Path) -> String {
    let base = doc.parent().unwrap_or(Path::new(""));
    path.strip_prefix(base)
        .unwrap_or(path)
        .display()
        .to_string()
}

/// Seven significant digits, in exponent form where a fixed one would be long.
fn sig(x: f64) -> String {
    if x != 0.0 && !(1e-3..1e5).contains(&x.abs()) {
        format!("{x:.6e}")
    } else if x == 0.0 {
        "0".into()
    } else {
        let decimals = (6 - x.abs().log10().floor() as i32).max(0) as usize;
        format!("{x:.decimals$}")
    }
}

fn pct(x: f64, truth: f64) -> String {
    format!("{:+.2e}", x / truth - 1.0)
}

fn curve(label: &str, points: Vec<(f64, f64)>, color: RGBColor, dashed: bool) -> Curve {
    Curve {
        label: label.into(),
        points,
        color,
        markers: false,
        dashed,
        width: 1,
    }
}

/// `vibrobar tap-test`.
pub fn run(args: &TapTestArgs) -> Result<()> {
    let t0 = Instant::now();
    let (lr0, lr1, lr_step, lobe_rpms) = super::lobes::parse_rpm(&args.lobes_rpm)
        .map_err(|e| anyhow::anyhow!("--lobes-rpm: {e}"))?;
    let (_, _, _, design_rpms) = super::lobes::parse_rpm(&args.design_rpm)
        .map_err(|e| anyhow::anyhow!("--design-rpm: {e}"))?;
    let mm = |v: Vec<f64>| v.iter().map(|x| x / 1e3).collect::<Vec<f64>>();
    let positions = mm(parse_range(
        "--positions-mm",
        &args.positions_mm,
        |x| x > 0.0 && x <= LENGTH_M * 1e3,
        "(0, 175] mm",
    )?);
    let gaps = mm(parse_range(
        "--gaps-mm",
        &args.gaps_mm,
        |x| x > 0.0,
        "(0, ∞) mm",
    )?);
    let masses = mm(parse_range(
        "--ball-masses-g",
        &args.ball_masses_g,
        |x| x > 0.0,
        "(0, ∞) g",
    )?);
    let ratios = parse_range("--ratios", &args.ratios, |x| x > 0.0, "(0, ∞)")?;
    let duration = check_value(
        "--forced-duration",
        args.forced_duration,
        |x| x > 0.0 && x <= 100.0,
        "(0, 100] s",
    )?;
    if args.out.extension().and_then(|e| e.to_str()) != Some("md") {
        bail!(
            "--out {}: the document must be a .md file",
            args.out.display()
        );
    }
    let dir = args.out.with_extension("");
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let runner = Runner::default().with_threads(args.threads);

    // 1. The measurement, written as a user's data-acquisition system would.
    let tip_path = dir.join("tip.uff");
    let cross_path = dir.join("cross.uff");
    let header = |desc: &str, ref_node: i64| Uff58Header {
        description: desc.into(),
        rsp_node: 1,
        rsp_dir: 3,
        ref_node,
        ref_dir: 3,
    };
    write_frf_uff(
        &tip_path,
        &record(false, NOISE, SEEDS.0)?,
        &header("tap at the tool tip, response at the tool tip", 1),
        false,
    )?;
    write_frf_uff(
        &cross_path,
        &record(true, NOISE, SEEDS.1)?,
        &header("tap at the cavity, response at the tool tip", 2),
        false,
    )?;

    // 2. The fit, as `vibrobar fit-modes` runs it (it writes modes.toml and its figures).
    let modes_path = dir.join("modes.toml");
    super::fit_modes::run(&super::fit_modes::FitModesArgs {
        frf: tip_path.clone(),
        cross: Some(cross_path.clone()),
        units: None,
        frf_type: None,
        frf_columns: "re-im".into(),
        frf_record: None,
        band_hz: None,
        max_order: 40,
        min_stable_orders: 4,
        poles_hz: None,
        lower_residual: false,
        no_upper_residual: false,
        pseudo_mode_hz: None,
        no_refine: false,
        length_mm: None,
        cavity_from_clamp_mm: None,
        out: modes_path.clone(),
    })?;
    // The same fit in memory, from the files as read back, and the noise-free one beside it.
    let opts = FrfReadOptions::default();
    let tip = read_frf(&tip_path, &opts)?.frf;
    let cross = read_frf(
        &cross_path,
        &FrfReadOptions {
            cross: true,
            ..FrfReadOptions::default()
        },
    )?
    .frf;
    let noisy = fit_of(&tip, &cross)?;
    let clean = fit_of(&record(false, 0.0, SEEDS.0)?, &record(true, 0.0, SEEDS.1)?)?;
    for (name, f) in [("noisy", &noisy), ("noise-free", &clean)] {
        if f.modes.len() != TRUE_MODES.len() {
            bail!(
                "the {name} fit found {} modes, not {}: the example's data are broken",
                f.modes.len(),
                TRUE_MODES.len()
            );
        }
    }
    let fmodes = |f: &ModalFit| -> Result<Vec<MeasuredMode>> {
        let v: Vec<_> = f
            .modes
            .iter()
            .map(|m| (m.frequency_hz, m.damping_ratio, m.modal_mass_kg))
            .collect();
        measured(&v, |k| Ok(f.modes[k].shape_cavity.unwrap_or(1.0)))
    };
    let truth = measured(&TRUE_MODES.map(|(f, z, m, _)| (f, z, m)), |k| {
        Ok(TRUE_MODES[k].3)
    })?;
    let fitted = fmodes(&noisy)?;
    let fitted_clean = fmodes(&clean)?;

    // 3. Lobes: the measured lines, the fitted modes, the true system.
    let measured_table = FrfLobeTable::new(&tip)?;
    let mut fitted_table = super::lobes::modes_lobe_table(&fitted)?;
    let mut true_table = super::lobes::modes_lobe_table(&truth)?;
    let mut first_table = super::lobes::modes_lobe_table(&fitted[..1])?;
    let mut csv = String::from(
        "spindle_rpm,measured_b_lim_m,fitted_b_lim_m,true_b_lim_m,fitted_first_mode_b_lim_m\n",
    );
    let mut pts: [Vec<(f64, f64)>; 3] = Default::default();
    for &n in &lobe_rpms {
        let m = measured_table.boundary_at(n, K_F)?.b_lim_m;
        let f = fitted_table.boundary_at(n, K_F)?.b_lim_m;
        let t = true_table.boundary_at(n, K_F)?.b_lim_m;
        let o = first_table.boundary_at(n, K_F)?.b_lim_m;
        let _ = writeln!(csv, "{n},{m:e},{f:e},{t:e},{o:e}");
        pts[0].push((n, m * 1e3));
        pts[1].push((n, f * 1e3));
        pts[2].push((n, t * 1e3));
    }
    let lobes_csv = dir.join("lobes.csv");
    write_text(&lobes_csv, &csv)?;
    let [pm, pf, pt] = pts;
    let lobes_stem = dir.join("lobes");
    vibrobar_report::plot::lines(
        &lobes_stem,
        "linear lobes: measured lines, fitted modes, true bar",
        "spindle speed (rpm)",
        "b_lim (mm)",
        &[
            curve(
                "from the measured lines (spline)",
                pm,
                RGBColor(120, 120, 120),
                false,
            ),
            curve("from the fitted modes", pf, RGBColor(200, 40, 40), true),
            curve("true bar", pt, RGBColor(30, 90, 200), true),
        ],
        &[],
    )?;
    let minimum = |(s, w): (f64, f64)| (s / K_F, w / (2.0 * PI));
    let min_measured = minimum(measured_table.minimum());
    let min_fitted = minimum(fitted_table.minimum());
    let min_true = minimum(true_table.minimum());
    let min_clean = minimum(super::lobes::modes_lobe_table(&fitted_clean)?.minimum());
    let min_first = minimum(first_table.minimum());

    // 4a. Where the cavity goes: the fitted modes with the clamped–free shape at each position.
    let settings = vibrobar_core::RunSettings {
        duration_s: duration,
        dt_s: 1e-6,
        rms_fraction: 0.8,
    };
    settings.validate()?;
    let mut placement: Vec<(f64, Vec<f64>, Vec<f64>)> = Vec::new();
    let bar = Progress::new("tap-test: placement", positions.len(), 0);
    for &x in &positions {
        let shaped = measured(
            &fitted
                .iter()
                .map(|m| (m.frequency_hz, m.damping_ratio, m.modal_mass_kg))
                .collect::<Vec<_>>(),
            |k| Ok(fit::uniform_beam_shape(k + 1, x, LENGTH_M)?),
        )?;
        let toml = format!(
            "gravity_m_s2 = 9.80665\n\n{}{}",
            modes_toml(&shaped),
            damper_toml(gaps[0])
        );
        let sc = Scenario::from_toml(&toml).context("the placement scenario")?;
        let solver = super::solver(&sc.run.solver, &settings)?;
        let points = sc.sweep_points(&gaps, &ratios);
        let rows = super::sweep_rows(
            &points,
            &sc.base()?,
            &settings,
            solver.as_ref(),
            &format!("tap-test: cavity at {} mm", fmt_coord(x * 1e3)),
            false,
        )?;
        // Per gap: the mean RMS reduction over the band and the worst damped RMS against the
        // worst solid RMS.
        let mut mean = Vec::new();
        let mut worst = Vec::new();
        for g in rows.chunks(ratios.len()) {
            let red: f64 = g
                .iter()
                .map(|r| 1.0 - r.damped.rms_m / r.solid.rms_m)
                .sum::<f64>()
                / g.len() as f64;
            let wd = g.iter().map(|r| r.damped.rms_m).fold(0.0, f64::max);
            let ws = g.iter().map(|r| r.solid.rms_m).fold(0.0, f64::max);
            mean.push(100.0 * red);
            worst.push(wd / ws);
        }
        placement.push((x, mean, worst));
        bar.inc();
    }
    bar.finish();
    let mut csv =
        String::from("position_m,shape_mode1,gap_m,mean_rms_reduction_pct,worst_rms_over_solid\n");
    for (x, mean, worst) in &placement {
        let s = fit::uniform_beam_shape(1, *x, LENGTH_M)?;
        for (k, g) in gaps.iter().enumerate() {
            let _ = writeln!(csv, "{x:e},{s:e},{g:e},{:e},{:e}", mean[k], worst[k]);
        }
    }
    let placement_csv = dir.join("placement.csv");
    write_text(&placement_csv, &csv)?;
    let palette = [
        RGBColor(30, 90, 200),
        RGBColor(200, 40, 40),
        RGBColor(40, 150, 60),
        RGBColor(150, 60, 170),
        RGBColor(220, 140, 20),
    ];
    let placement_curves: Vec<Curve> = gaps
        .iter()
        .enumerate()
        .map(|(k, g)| Curve {
            markers: true,
            ..curve(
                &format!("gap {} mm", fmt_coord(g * 1e3)),
                placement.iter().map(|(x, m, _)| (x * 1e3, m[k])).collect(),
                palette[k % palette.len()],
                false,
            )
        })
        .collect();
    let placement_stem = dir.join("placement");
    vibrobar_report::plot::lines(
        &placement_stem,
        "fitted bar: mean RMS reduction over the band by cavity position",
        "cavity centre from the clamp (mm)",
        "mean RMS reduction (%)",
        &placement_curves,
        &[],
    )?;
    let (best_k, best_x, best_gap_k) = placement
        .iter()
        .enumerate()
        .flat_map(|(i, (x, m, _))| m.iter().enumerate().map(move |(k, &r)| (i, *x, k, r)))
        .max_by(|a, b| a.3.total_cmp(&b.3))
        .map(|(i, x, k, _)| (i, x, k))
        .context("no placement")?;

    // 4b. How wide it cuts: time-domain lobe design of gap × ball mass, the cavity at the best
    // position, on the fitted bar's first mode (module docs of the document say why).
    let first = measured(
        &[(
            fitted[0].frequency_hz,
            fitted[0].damping_ratio,
            fitted[0].modal_mass_kg,
        )],
        |_| Ok(fit::uniform_beam_shape(1, best_x, LENGTH_M)?),
    )?;
    let design_toml = format!(
        "# The fitted bar's first mode, the cavity {} mm from the clamp (the clamped–free shape),\n# the paper's ball, a continuous cut of steel. Generated by `vibrobar tap-test`.\ngravity_m_s2 = 9.80665\n\n{}{}\n{}",
        fmt_coord(best_x * 1e3),
        modes_toml(&first),
        damper_toml(gaps[0]),
        cutting_toml()
    );
    let td = Instant::now();
    let (_, _, grid, solid, computed) = super::cutting_deeper::design_study(
        "design",
        design_toml,
        DesignAxis::BallMass,
        gaps.clone(),
        masses.clone(),
        &design_rpms,
        runner,
        &dir,
    )?;
    let td_secs = td.elapsed().as_secs_f64();
    let rows: Vec<DesignRow> = computed.into_iter().map(|(_, r)| r).collect();
    let design_csv = dir.join("design.csv");
    vibrobar_io::csv::write_csv(
        &design_csv,
        &lobe_design_schema(grid.axis()),
        rows.iter().map(lobe_design_values),
    )?;
    vibrobar_report::figures::lobe_design::draw_lobe_design_figure(
        &design_csv,
        grid.axis(),
        &rows,
    )?;
    let best = optimum(&rows).context("no designs")?;

    // The document.
    let doc = &args.out;
    let r = |p: &Path| rel(p, doc);
    let mut d = String::new();
    let _ = writeln!(d, "# From a tap test to a design: a worked example\n");
    let _ = writeln!(
        d,
        "Generated by `vibrobar tap-test --out {}` ({}); every number below comes from that run. \
The example starts where a tool designer starts: a hammer tap at the tool tip on the machine, \
recorded as a universal file. It fits the bar's modes, takes the stability lobes from the \
measurement and from the fit, and then designs the ball damper on the fitted bar.\n",
        doc.display(),
        crate::VERSION
    );
    let _ = writeln!(
        d,
        "**The modes describe the bar without the ball.** Tap the bar with the ball removed, or \
locked with its mass subtracted; the simulator adds the ball itself.\n"
    );
    let _ = writeln!(d, "## 1. The measurement\n");
    let _ = writeln!(
        d,
        "A known bar stands in for the machine, so the fit can be checked: the first three \
bending modes of the paper's bar as a beam with its cavity ({} mm long, the cavity {} mm from \
the clamp), in the tip normalisation (shape 1 at the tip).\n",
        fmt_coord(LENGTH_M * 1e3),
        fmt_coord(CAVITY_M * 1e3)
    );
    let _ = writeln!(d, "| mode | frequency (Hz) | damping ratio | modal mass at the tip (kg) | shape at the cavity |");
    let _ = writeln!(d, "|---|---|---|---|---|");
    for (k, (f, z, m, s)) in TRUE_MODES.iter().enumerate() {
        let _ = writeln!(d, "| {} | {f} | {z} | {m} | {s} |", k + 1);
    }
    let _ = writeln!(
        d,
        "\nTwo records, each on 2 Hz lines from 2 to 12 000 Hz (6000 lines), each line multiplied \
by (1 + ε) with ε complex, both parts uniform in ±{} (seeds {} and {}):\n\n\
- [`{}`]({}): the driving-point receptance, tap and response at the tool tip;\n\
- [`{}`]({}): the cross receptance, tap at the cavity and response at the tip, which gives each \
mode's shape at the cavity.\n\n\
Both are universal files, dataset 58 (ASCII) with dataset 164 for the units, as a \
data-acquisition system writes them. `vibrobar` reads 58 and 58b, several records per file, \
and plain columns in m/N, mm/N, µm/N, in/lbf, (m/s)/N, (m/s²)/N or g/N.\n",
        NOISE,
        SEEDS.0,
        SEEDS.1,
        r(&tip_path),
        r(&tip_path),
        r(&cross_path),
        r(&cross_path),
    );
    let _ = writeln!(d, "## 2. The modal fit\n");
    let _ = writeln!(
        d,
        "```\nvibrobar fit-modes --frf {} --cross {} --out {}\n```\n",
        tip_path.display(),
        cross_path.display(),
        modes_path.display()
    );
    let _ = writeln!(
        d,
        "Poles by least-squares complex frequency (LSCF) over model orders 2–40, residues by \
least squares, then both refined together. A pole counts as a mode where it is stable \
(frequency within 1 %, damping within 5 % of the lower order's, damping > 0) over 4 orders, \
and is taken at the highest such order. The stabilisation chart:\n\n\
![stabilisation chart]({})\n\n\
The measured against the fitted receptance:\n\n![fit]({})\n",
        r(&dir.join("modes.stabilisation.png")),
        r(&dir.join("modes.fit.png")),
    );
    let _ = writeln!(
        d,
        "The recovered parameters against the true ones (relative errors; for the shape the \
absolute error). Fit error over the band: {:.2e} without noise, {:.2e} with it (the noise's own \
RMS is {:.2e}).\n",
        clean.fit_error,
        noisy.fit_error,
        NOISE * (2.0f64 / 3.0).sqrt()
    );
    let _ = writeln!(
        d,
        "| mode | quantity | true | fitted, no noise | error | fitted, 1 % noise | error |"
    );
    let _ = writeln!(d, "|---|---|---|---|---|---|---|");
    for k in 0..TRUE_MODES.len() {
        let (t, c, n) = (&truth[k], &fitted_clean[k], &fitted[k]);
        let stiff = |m: &MeasuredMode| m.modal_mass_kg * (2.0 * PI * m.frequency_hz).powi(2);
        let rows: [(&str, f64, f64, f64, bool); 5] = [
            (
                "frequency (Hz)",
                t.frequency_hz,
                c.frequency_hz,
                n.frequency_hz,
                false,
            ),
            (
                "damping ratio",
                t.damping_ratio,
                c.damping_ratio,
                n.damping_ratio,
                false,
            ),
            (
                "modal mass (kg)",
                t.modal_mass_kg,
                c.modal_mass_kg,
                n.modal_mass_kg,
                false,
            ),
            ("modal stiffness (N/m)", stiff(t), stiff(c), stiff(n), false),
            (
                "shape at the cavity",
                t.shape_cavity,
                c.shape_cavity,
                n.shape_cavity,
                true,
            ),
        ];
        for (q, tv, cv, nv, abs) in rows {
            let err = |v: f64| {
                if abs {
                    format!("{:.1e}", (v - tv).abs())
                } else {
                    pct(v, tv)
                }
            };
            let _ = writeln!(
                d,
                "| {} | {q} | {} | {} | {} | {} | {} |",
                k + 1,
                sig(tv),
                sig(cv),
                err(cv),
                sig(nv),
                err(nv)
            );
        }
    }
    let _ = writeln!(
        d,
        "\nPer mode, with the noise: residue phase {} (near −90° for a receptance), MPC {} and \
FRAC {}.\n",
        noisy
            .modes
            .iter()
            .map(|m| format!("{:.1}°", m.residue_phase_deg))
            .collect::<Vec<_>>()
            .join(", "),
        noisy
            .modes
            .iter()
            .map(|m| format!("{:.4}", m.mpc))
            .collect::<Vec<_>>()
            .join(", "),
        noisy
            .modes
            .iter()
            .map(|m| format!("{:.4}", m.frac))
            .collect::<Vec<_>>()
            .join(", "),
    );
    let _ = writeln!(
        d,
        "[`{}`]({}) holds the fitted `[[modes]]`; every scenario that takes `[[modes]]` runs on it.\n",
        r(&modes_path),
        r(&modes_path)
    );
    let _ = writeln!(d, "## 3. Lobes from the measurement and from the fit\n");
    let cut_path = dir.join("cut.toml");
    write_text(
        &cut_path,
        &format!(
            "# Only [cutting] is read by `vibrobar lobes --frf`. Generated by `vibrobar tap-test`.\n{}",
            cutting_toml()
        ),
    )?;
    let _ = writeln!(
        d,
        "```\nvibrobar lobes --frf {} --scenario {} --rpm {}:{}:{} --out lobes-measured.csv\n```\n",
        tip_path.display(),
        cut_path.display(),
        fmt_coord(lr0),
        fmt_coord(lr1),
        fmt_coord(lr_step)
    );
    let _ = writeln!(
        d,
        "The lobes straight from the measured lines need no fit: the receptance is interpolated \
between the lines by a cubic spline and b_lim = −1/(2 K_f Re G) is swept over it. K_f = {:.0} \
N/mm² (steel), direction factors 1: **the FRF must be measured in the direction that the \
`[cutting]` direction factors assume.** Beside them, the exact lobes of the fitted modes and of \
the true bar ([`{}`]({})):\n\n![lobes]({})\n",
        K_F * 1e-6,
        r(&lobes_csv),
        r(&lobes_csv),
        r(&lobes_stem.with_extension("png"))
    );
    let _ = writeln!(
        d,
        "| lobes of | minimum b_lim (µm) | chatter frequency (Hz) | against the true bar |"
    );
    let _ = writeln!(d, "|---|---|---|---|");
    for (name, (b, f)) in [
        ("the true bar", min_true),
        ("the measured lines (spline, no fit)", min_measured),
        ("the modes fitted to the noisy record", min_fitted),
        ("the modes fitted to the noise-free record", min_clean),
        ("the first fitted mode alone", min_first),
    ] {
        let _ = writeln!(
            d,
            "| {name} | {:.4} | {f:.2} | {:+.3} % |",
            b * 1e6,
            100.0 * (b / min_true.0 - 1.0)
        );
    }
    let _ = writeln!(
        d,
        "\nThe lowest point of every lobe is set by the first mode: the first mode alone gives a \
minimum within {:.2} % of the three modes'.\n",
        100.0 * (min_first.0 / min_fitted.0 - 1.0).abs()
    );
    let coarse: Vec<String> = vibrobar_core::analysis::lobes_frf::peak_resolution(&tip)?
        .iter()
        .filter(|p| p.under_resolved)
        .map(|p| {
            format!(
                "{:.0} Hz (ζ·f ≈ {:.1} Hz against {} Hz lines)",
                p.peak_hz,
                p.zeta_f_hz,
                fmt_coord(p.line_spacing_hz)
            )
        })
        .collect();
    if !coarse.is_empty() {
        let _ = writeln!(
            d,
            "`lobes --frf` warns here that the peak at {} is under-resolved: it asks for ζ·f of at \
least 5 line spacings. The spline lobes then carry the noise of the few lines across the peak \
(their minimum is off by the {:+.2} % above), while the fit pools every line of the band. With \
a lightly damped bar, measure with finer lines, or use the fitted modes' lobes.\n",
            coarse.join(", "),
            100.0 * (min_measured.0 / min_true.0 - 1.0)
        );
    }
    let _ = writeln!(d, "## 4. The damped design on the fitted bar\n");
    let _ = writeln!(d, "### Where the cavity goes\n");
    let _ = writeln!(
        d,
        "A tap at the tip gives each mode's shape only where the cross FRF was measured. To move \
the cavity, the fitted frequencies, damping ratios and modal masses are kept and the shape at \
each position is the clamped–free beam's (`vibrobar fit-modes --length-mm {} \
--cavity-from-clamp-mm X` writes the same modes). At the measured cavity, {} mm from the clamp, \
that shape of mode 1 is {:.4}; the cross FRF gave {:.4} (the true bar, with the hole's loss of \
section: {}). For each position: the paper's 26 g ball with Coulomb friction, a 15 N \
harmonic force at the tip, ratios {} of the fitted first mode ({:.1}–{:.1} Hz), {} s runs, RMS \
over the last 80 %, against the same bar without the ball ([`{}`]({})):\n\n![placement]({})\n",
        fmt_coord(LENGTH_M * 1e3),
        fmt_coord(CAVITY_M * 1e3),
        fit::uniform_beam_shape(1, CAVITY_M, LENGTH_M)?,
        fitted[0].shape_cavity,
        TRUE_MODES[0].3,
        args.ratios,
        ratios[0] * fitted[0].frequency_hz,
        ratios[ratios.len() - 1] * fitted[0].frequency_hz,
        fmt_coord(duration),
        r(&placement_csv),
        r(&placement_csv),
        r(&placement_stem.with_extension("png"))
    );
    let _ = write!(d, "| cavity (mm from the clamp) | shape of mode 1 |");
    for g in &gaps {
        let _ = write!(d, " gap {} mm: mean reduction (%) |", fmt_coord(g * 1e3));
    }
    let _ = writeln!(d);
    let _ = writeln!(d, "|---|---|{}", "---|".repeat(gaps.len()));
    for (i, (x, mean, _)) in placement.iter().enumerate() {
        let _ = write!(
            d,
            "| {}{} | {:.4} |",
            fmt_coord(x * 1e3),
            if i == best_k { " (best)" } else { "" },
            fit::uniform_beam_shape(1, *x, LENGTH_M)?
        );
        for m in mean {
            let _ = write!(d, " {m:.2} |");
        }
        let _ = writeln!(d);
    }
    let _ = writeln!(
        d,
        "\nThe best cavity is {} mm from the clamp with the {} mm gap: {:.2} % mean RMS reduction \
over the band, the worst damped RMS {:.3}× the worst without the ball. Nearer the tip the shape, \
and with it the ball's leverage, grows; the hole must stay inside the bar, its centre at most \
L − d_h/2 from the clamp. Two things this step cannot see, since the tap was made with the \
cavity where it is: a cavity elsewhere changes the bar's own modes a little (the hole's loss of \
section), and the clamped–free shape is that of a uniform bar ({:.4} against the cross FRF's \
{:.4} at the measured cavity). Where it matters, tap the bar as built.\n",
        fmt_coord(best_x * 1e3),
        fmt_coord(gaps[best_gap_k] * 1e3),
        placement[best_k].1[best_gap_k],
        placement[best_k].2[best_gap_k],
        fit::uniform_beam_shape(1, CAVITY_M, LENGTH_M)?,
        fitted[0].shape_cavity,
    );
    let _ = writeln!(d, "### How wide it cuts\n");
    let design_path = dir.join("design.toml");
    let _ = writeln!(
        d,
        "```\nvibrobar lobe-design --scenario {} --rpm {} --gaps-mm {} --ball-masses-g {} --out {}\n```\n",
        design_path.display(),
        args.design_rpm,
        args.gaps_mm,
        args.ball_masses_g,
        design_csv.display()
    );
    let _ = writeln!(
        d,
        "Linearised, a free ball changes nothing, so what it buys against chatter is judged in \
the time domain: at each speed, the largest width of cut whose vibration settles, from a large \
disturbance, for each gap × ball mass, beside the bar without the ball ([`{}`]({})). The \
scenario is the fitted bar's first mode with the cavity at {} mm; the first mode alone sets the \
lobes' minimum (above), and a time-domain run of all three modes is held to the 10 kHz mode's \
steps, minutes per speed. Designs scored by their worst width over the band and their mean \
({} designs × {} speeds in {:.0} s):\n\n![design]({})\n",
        r(&design_path),
        r(&design_path),
        fmt_coord(best_x * 1e3),
        rows.len(),
        design_rpms.len(),
        td_secs,
        r(&design_csv.with_extension("png"))
    );
    let _ = writeln!(
        d,
        "| gap (mm) | ball (g) | worst width (µm) | at (rpm) | mean width (µm) | worst gain | mean gain | spread of the worst width over seeds (µm) |"
    );
    let _ = writeln!(d, "|---|---|---|---|---|---|---|---|");
    for row in &rows {
        let g = |x: Option<f64>| x.map_or("—".into(), |g| format!("{g:.3}"));
        let _ = writeln!(
            d,
            "| {} | {} | {:.2} | {} | {:.2} | {} | {} | {} |",
            fmt_coord(row.point.gap_m * 1e3),
            fmt_coord(row.point.value * 1e3),
            row.damped.worst_width_m * 1e6,
            fmt_coord(row.damped.worst_rpm),
            row.damped.mean_width_m * 1e6,
            g(row.worst_gain()),
            g(row.mean_gain()),
            row.spread.as_ref().map_or("—".into(), |s| format!(
                "{:.2}–{:.2}",
                s.min_width_m * 1e6,
                s.max_width_m * 1e6
            ))
        );
    }
    let _ = writeln!(
        d,
        "\nThe bar without the ball: worst {:.2} µm at {} rpm, mean {:.2} µm. The best design, \
gap {} mm and ball {} g: worst {:.2} µm ({}× the bar without the ball), mean {:.2} µm{}. The \
spread column: where the damped run at a design's worst case is chaotic, its width is searched \
again from {} seeded perturbations (±{} %) of the disturbance, and the column gives their range; \
a chaotic answer is a scattered quantity, not one number. \"—\": not chaotic there.\n",
        solid.score.worst_width_m * 1e6,
        fmt_coord(solid.score.worst_rpm),
        solid.score.mean_width_m * 1e6,
        fmt_coord(best.point.gap_m * 1e3),
        fmt_coord(best.point.value * 1e3),
        best.damped.worst_width_m * 1e6,
        best.worst_gain().map_or("—".into(), |g| format!("{g:.3}")),
        best.damped.mean_width_m * 1e6,
        best.spread.as_ref().map_or(String::new(), |s| format!(
            "; over seeded disturbances its worst width ranges {:.2}–{:.2} µm, so the gain that \
holds is {:.3}×",
            s.min_width_m * 1e6,
            s.max_width_m * 1e6,
            s.min_width_m / solid.score.worst_width_m
        )),
        SPREAD_SEEDS,
        fmt_coord(100.0 * SPREAD_REL),
    );
    let _ = writeln!(d, "Generated in {:.0} s.", t0.elapsed().as_secs_f64());
    write_text(doc, &d)?;
    println!("wrote {} and its files in {}", doc.display(), dir.display());
    Ok(())
}
