//! `vibrobar contact-convergence`: the generated study (`docs/contact-convergence.md`, its CSV
//! and figure) of how the beam's answers move with the number of modes N under the two contact
//! laws (issue #9 §4): tip RMS reduction and dissipated power for N = 1…12, `restitution` and
//! `hertz`, at the three design points of the N study of `lumped-vs-beam` (issue #8 §4), the
//! paper's beam with the cavity where that study puts it. Every number comes from
//! `analysis::placement::mode_convergence` (the function `lumped-vs-beam` uses) run by the exact
//! solver; the verdicts are computed from the table by the criterion stated in the document.
//! `--quick` (short runs, N ≤ 4, one point) is for the tests.

use super::lumped_vs_beam::{DesignPoint, POINTS};
use super::placement::case_for;
use super::{check_value, with_threads};
use anyhow::Context;
use plotters::style::RGBColor;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use vibrobar_core::analysis::placement::{mode_convergence, ConvergenceRow, PlacementSpec};
use vibrobar_core::analysis::regime::{Regime, Tolerances};
use vibrobar_core::analysis::Runner;
use vibrobar_core::damper::contact::Hertz;
use vibrobar_core::params::STANDARD_GRAVITY_M_S2;
use vibrobar_core::structure::{Beam, Point};
use vibrobar_core::{Contact, ContactLaw, Damper, Forcing, FrictionModel, RunSettings};
use vibrobar_report::plot::{panels, Curve, Panel};

/// `vibrobar contact-convergence`.
#[derive(Debug, Clone, clap::Args)]
pub struct ContactConvergenceArgs {
    /// The Markdown document to write (e.g. docs/contact-convergence.md); the table goes beside
    /// it as `.csv`, the figure as `.png` and `.svg`.
    #[arg(long)]
    pub out: PathBuf,
    /// Simulated time of each run, s.
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
    pub duration: f64,
    /// RMS and dissipation over this last fraction of each run.
    #[arg(long, default_value_t = 0.8, allow_negative_numbers = true)]
    pub rms_fraction: f64,
    /// Largest number of modes.
    #[arg(long, default_value_t = 12)]
    pub max_modes: usize,
    /// Short runs for tests: 0.05 s, N ≤ 4, point A only.
    #[arg(long)]
    pub quick: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// The header of the CSV (one row per point, law and N).
pub const CSV_HEADER: &str = "point,gap_mm,ratio,law,modes,inverse_effective_mass_per_kg,residual_compliance_m_per_n,rms_solid_m,rms_damped_m,reduction_pct,dissipation_w,impacts_per_cycle,regime";

/// Band of the reduction over the upper half of the N range within which a law is said to
/// converge at a point, percentage points.
const BAND_PP: f64 = 1.0;
/// Band of the dissipated power over the same range, relative to its mean.
const BAND_REL: f64 = 0.03;
/// Residual compliance, relative to the contact's, from which a static correction would matter.
const RESIDUAL_MATTERS: f64 = 0.05;

/// One law at one point: its rows by N.
struct Series {
    law: ContactLaw,
    rows: Vec<ConvergenceRow>,
}

/// The verdict on one series: the bands over N = ⌈N_max/2⌉…N_max and whether both are within
/// [`BAND_PP`] and [`BAND_REL`].
struct Verdict {
    from_n: usize,
    band_pp: f64,
    band_rel: f64,
    converges: bool,
    /// Every run of the upper half is chaotic: the band mixes the law's trend with the scatter
    /// of single chaotic runs.
    chaotic: bool,
}

fn verdict(rows: &[ConvergenceRow]) -> Verdict {
    let n_max = rows.last().map_or(1, |r| r.modes);
    let from_n = n_max.div_ceil(2);
    let upper: Vec<&ConvergenceRow> = rows.iter().filter(|r| r.modes >= from_n).collect();
    let band = |f: &dyn Fn(&ConvergenceRow) -> f64| {
        let (lo, hi) = upper
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |a, r| {
                (a.0.min(f(r)), a.1.max(f(r)))
            });
        (lo, hi)
    };
    let (lo, hi) = band(&|r| r.reduction_pct);
    let band_pp = hi - lo;
    let (dlo, dhi) = band(&|r| r.impact_loss_w);
    let mean = upper.iter().map(|r| r.impact_loss_w).sum::<f64>() / upper.len().max(1) as f64;
    let band_rel = if mean > 0.0 { (dhi - dlo) / mean } else { 0.0 };
    Verdict {
        from_n,
        band_pp,
        band_rel,
        converges: upper.len() >= 3 && band_pp <= BAND_PP && band_rel <= BAND_REL,
        chaotic: upper.iter().all(|r| r.regime == Regime::Chaotic),
    }
}

fn law_name(l: ContactLaw) -> &'static str {
    match l {
        ContactLaw::Restitution => "restitution",
        ContactLaw::Hertz => "hertz",
    }
}

/// `vibrobar contact-convergence`.
pub fn run(args: &ContactConvergenceArgs) -> anyhow::Result<()> {
    let (duration, max_modes, points): (f64, usize, &[DesignPoint]) = if args.quick {
        (0.05, args.max_modes.min(4), &POINTS[..1])
    } else {
        (
            check_value("--duration", args.duration, |x| x > 0.0, "(0, ∞) s")?,
            args.max_modes,
            &POINTS[..],
        )
    };
    vibrobar_core::limits::check_count(
        "--max-modes",
        max_modes,
        1,
        vibrobar_core::limits::MAX_BEAM_MODES,
        "",
    )?;
    let settings = RunSettings {
        duration_s: duration,
        rms_fraction: check_value(
            "--rms-fraction",
            args.rms_fraction,
            |x| x > 0.0 && x <= 1.0,
            "(0, 1]",
        )?,
        ..RunSettings::default()
    };
    settings.validate()?;
    let t0 = std::time::Instant::now();
    let spec_of = |law: ContactLaw| {
        let ball = Damper {
            contact: Contact {
                law,
                ..Contact::hertz()
            },
            ..Damper::paper(1e-3, FrictionModel::None)
        };
        PlacementSpec {
            beam: Beam::default(),
            ball,
            forcing: Forcing::paper(1.0),
            gravity_m_s2: STANDARD_GRAVITY_M_S2,
            settings,
            tolerances: Tolerances::default(),
        }
    };
    let base = spec_of(ContactLaw::Restitution);
    let x_d = base.beam.cavity_position_m;
    let modes: Vec<usize> = (1..=max_modes).collect();
    let mut study: Vec<Vec<Series>> = Vec::new();
    for p in points {
        let mut per_law = Vec::new();
        for law in [ContactLaw::Restitution, ContactLaw::Hertz] {
            let spec = spec_of(law);
            let owned = case_for("exact", &spec, settings, true)?;
            let case = |s: &vibrobar_core::System| owned.run(s);
            let rows = with_threads(args.threads, || {
                mode_convergence(
                    &spec,
                    x_d,
                    p.gap_mm / 1e3,
                    p.ratio,
                    &modes,
                    Runner::default(),
                    &case,
                )
            })?
            .map_err(|e| anyhow::anyhow!("point {}, {}: {e}", p.name, law_name(law)))?;
            eprintln!(
                "point {}, {}: N = 1…{max_modes} done ({:.1} s)",
                p.name,
                law_name(law),
                t0.elapsed().as_secs_f64()
            );
            per_law.push(Series { law, rows });
        }
        study.push(per_law);
    }
    // The static compliance at the cavity that N modes leave out, against the 32-mode sum.
    let compliance = |n: usize| -> anyhow::Result<f64> {
        let m = PlacementSpec {
            beam: base.beam.clone().with_modes(n),
            ..base.clone()
        }
        .damped_model(x_d)?;
        Ok(m.static_compliance_m_per_n(Point::Cavity, Point::Cavity))
    };
    let full = compliance(vibrobar_core::limits::MAX_BEAM_MODES)?;
    let residual: Vec<f64> = modes
        .iter()
        .map(|&n| compliance(n).map(|c| full - c))
        .collect::<anyhow::Result<_>>()?;

    let csv_path = args.out.with_extension("csv");
    let mut csv = String::from(CSV_HEADER);
    csv.push('\n');
    for (p, per_law) in points.iter().zip(&study) {
        for s in per_law {
            for (r, res) in s.rows.iter().zip(&residual) {
                writeln!(
                    csv,
                    "{},{},{},{},{},{},{:e},{:e},{:e},{},{:e},{},{}",
                    p.name,
                    p.gap_mm,
                    p.ratio,
                    law_name(s.law),
                    r.modes,
                    r.inverse_effective_mass_per_kg,
                    res,
                    r.rms_solid_m,
                    r.rms_damped_m,
                    r.reduction_pct,
                    r.impact_loss_w,
                    r.impacts_per_cycle,
                    r.regime
                )?;
            }
        }
    }
    let fig_stem = args.out.with_extension("");
    draw(&fig_stem, points, &study)?;
    let doc = render(
        args,
        &settings,
        points,
        &study,
        &residual,
        full,
        &csv_path,
        &fig_stem,
        t0.elapsed().as_secs_f64(),
    )?;
    vibrobar_io::csv::write_text(&csv_path, &csv)
        .with_context(|| format!("writing {}", csv_path.display()))?;
    vibrobar_io::csv::write_text(&args.out, &doc)
        .with_context(|| format!("writing {}", args.out.display()))?;
    println!(
        "wrote {}, {} and {}.png/.svg",
        args.out.display(),
        csv_path.display(),
        fig_stem.display()
    );
    Ok(())
}

fn draw(stem: &Path, points: &[DesignPoint], study: &[Vec<Series>]) -> anyhow::Result<()> {
    let colour = |l: ContactLaw| match l {
        ContactLaw::Restitution => RGBColor(200, 60, 40),
        ContactLaw::Hertz => RGBColor(30, 90, 200),
    };
    let mut ps: Vec<Panel> = Vec::new();
    for (p, per_law) in points.iter().zip(study) {
        let curves = |f: &dyn Fn(&ConvergenceRow) -> f64| -> Vec<Curve> {
            per_law
                .iter()
                .map(|s| Curve {
                    label: law_name(s.law).to_string(),
                    points: s.rows.iter().map(|r| (r.modes as f64, f(r))).collect(),
                    color: colour(s.law),
                    markers: true,
                    dashed: s.law == ContactLaw::Restitution,
                    width: 2,
                })
                .collect()
        };
        let head = format!("{}: gap {} mm, Ω/ω₁ = {}", p.name, p.gap_mm, p.ratio);
        ps.push((
            format!("{head}: tip RMS reduction"),
            "modes N".into(),
            "reduction (%)".into(),
            curves(&|r| r.reduction_pct),
        ));
        ps.push((
            format!("{head}: dissipated power"),
            "modes N".into(),
            "impact/contact loss (W)".into(),
            curves(&|r| r.impact_loss_w),
        ));
    }
    panels(
        stem,
        "Beam answers against the number of modes: restitution vs hertz",
        points.len(),
        2,
        &ps,
    )
}

#[allow(clippy::too_many_arguments)]
fn render(
    args: &ContactConvergenceArgs,
    settings: &RunSettings,
    points: &[DesignPoint],
    study: &[Vec<Series>],
    residual: &[f64],
    full: f64,
    csv_path: &Path,
    fig_stem: &Path,
    wall_s: f64,
) -> anyhow::Result<String> {
    let beam = Beam::default();
    let ball = Damper::paper(1e-3, FrictionModel::None);
    let law = Hertz::new(&Contact::hertz(), ball.ball_radius_m, ball.restitution);
    let file = |p: &Path| {
        p.file_name()
            .map_or_else(String::new, |f| f.to_string_lossy().into_owned())
    };
    let mut d = String::new();
    let cmd = format!(
        "vibrobar contact-convergence{}",
        if args.quick { " --quick" } else { "" }
    );
    writeln!(
        d,
        "# Contact laws on the beam: convergence in the number of modes"
    )?;
    writeln!(d)?;
    writeln!(
        d,
        "Generated by `{cmd} --out {}` (vibrobar {}); do not edit by hand. Table: `{}`; figure: \
         `{}.png` / `.svg`. Issue #9 §4.\n",
        args.out.display(),
        env!("CARGO_PKG_VERSION"),
        file(csv_path),
        file(fig_stem)
    )?;
    writeln!(
        d,
        "The paper's beam (L = {:.0} mm, D = {:.0} mm, steel, ζ = {}), the cavity {:.0} mm from the \
         clamp ({:.0} mm from the free end, as in `docs/lumped-vs-beam.md`), force and response at \
         the tip, the paper's frictionless 26 g ball (e = {}) from rest in the cavity's centre. \
         Each run {} s from rest, RMS and dissipation over the last {:.0} %; solver `exact` (every \
         mode in closed form between contacts; the hertz contact phase integrated by Dopri5 at \
         rtol {:e}). The solid reference has the same N. Dissipation: the kinetic energy lost at \
         impacts (`restitution`) or the Hunt–Crossley damping work of the contacts (`hertz`) in \
         the window, per second. The design points are those of issue #8's N study:\n",
        beam.length_m * 1e3,
        beam.diameter_m * 1e3,
        beam.damping_ratio.of_mode(1),
        beam.cavity_position_m * 1e3,
        (beam.length_m - beam.cavity_position_m) * 1e3,
        ball.restitution,
        settings.duration_s,
        100.0 * settings.rms_fraction,
        vibrobar_core::analysis::contact_test::CONTACT_RTOL,
    )?;
    for p in points {
        writeln!(
            d,
            "- **{}**: gap {} mm, Ω/ω₁ = {} — {}.",
            p.name, p.gap_mm, p.ratio, p.why
        )?;
    }
    writeln!(d)?;
    writeln!(
        d,
        "**Criterion.** A law *converges* at a point when, over the upper half of the range \
         (N = ⌈N_max/2⌉…N_max, which doubles N and roughly doubles the bar's inverse effective \
         mass at the cavity Σφₙ(x_d)²/mₙ), the tip RMS reduction stays within a band of {BAND_PP} \
         percentage point and the dissipated power within a band of {:.0} % of its mean. Chaotic \
         runs are compared as single {} s runs; their run-to-run spread is part of the band.\n",
        100.0 * BAND_REL,
        settings.duration_s
    )?;
    writeln!(
        d,
        "![reduction and dissipation against N]({}.png)\n",
        file(fig_stem)
    )?;
    let mut verdicts = Vec::new();
    for (p, per_law) in points.iter().zip(study) {
        writeln!(
            d,
            "## Point {} (gap {} mm, Ω/ω₁ = {})\n",
            p.name, p.gap_mm, p.ratio
        )?;
        writeln!(
            d,
            "| N | Σφₙ(x_d)²/mₙ (1/kg) | solid RMS (µm) | restitution: RMS (µm) | reduction (%) | loss (mW) | impacts/cycle | regime | hertz: RMS (µm) | reduction (%) | loss (mW) | contacts/cycle | regime |"
        )?;
        writeln!(d, "|---|---|---|---|---|---|---|---|---|---|---|---|---|")?;
        let (r, h) = (&per_law[0].rows, &per_law[1].rows);
        for (a, b) in r.iter().zip(h) {
            writeln!(
                d,
                "| {} | {:.3} | {:.2} | {:.2} | {:.1} | {:.1} | {:.2} | `{}` | {:.2} | {:.1} | {:.1} | {:.2} | `{}` |",
                a.modes,
                a.inverse_effective_mass_per_kg,
                a.rms_solid_m * 1e6,
                a.rms_damped_m * 1e6,
                a.reduction_pct,
                a.impact_loss_w * 1e3,
                a.impacts_per_cycle,
                a.regime,
                b.rms_damped_m * 1e6,
                b.reduction_pct,
                b.impact_loss_w * 1e3,
                b.impacts_per_cycle,
                b.regime
            )?;
        }
        writeln!(d)?;
        for s in per_law {
            let v = verdict(&s.rows);
            writeln!(
                d,
                "- `{}`: over N = {}…{} the reduction spans {:.2} points and the dissipation \
                 {:.1} % — **{}**.",
                law_name(s.law),
                v.from_n,
                s.rows.last().map_or(0, |r| r.modes),
                v.band_pp,
                100.0 * v.band_rel,
                match (v.converges, v.chaotic) {
                    (true, _) => "converges",
                    (false, false) => "does not converge",
                    (false, true) =>
                        "does not converge by the criterion (chaotic at every N of the range: the \
                         band holds the scatter of single chaotic runs as well as any trend)",
                }
            )?;
            verdicts.push((p.name, s.law, v));
        }
        writeln!(d)?;
    }
    writeln!(d, "## Verdict\n")?;
    for law in [ContactLaw::Restitution, ContactLaw::Hertz] {
        let of: Vec<&(&str, ContactLaw, Verdict)> =
            verdicts.iter().filter(|v| v.1 == law).collect();
        let yes: Vec<&str> = of.iter().filter(|v| v.2.converges).map(|v| v.0).collect();
        writeln!(
            d,
            "- `{}` converges at {} of {} points{}.",
            law_name(law),
            yes.len(),
            of.len(),
            if yes.is_empty() {
                String::new()
            } else {
                format!(" ({})", yes.join(", "))
            }
        )?;
    }
    writeln!(d)?;
    // Residual flexibility.
    let md = ball.ball_mass_kg;
    let v_ref = 0.1;
    let dmax = law.with_damping(0.0).max_penetration_m(md, v_ref);
    let hertz_compliance = 2.0 / (3.0 * law.stiffness_n_m32 * dmax.sqrt());
    let t_c = law.undamped_contact_time_s(md, v_ref);
    writeln!(d, "## Residual flexibility of the truncated modes\n")?;
    writeln!(
        d,
        "The modes left out still give the cavity a static compliance G_res(N) = G(x_d, x_d) − \
         Σ_{{n ≤ N}} φₙ(x_d)²/kₙ (G from the {}-mode sum: {:.3e} m/N), which a quasi-static \
         correction would put in series with the Hertz spring. The Hertz spring's own tangent \
         compliance at the peak of a {v_ref} m/s impact of the ball (δ_max = {:.2} µm, contact \
         time {:.1} µs, i.e. quasi-static only for modes above ~{:.0} kHz) is {:.3e} m/N.\n",
        vibrobar_core::limits::MAX_BEAM_MODES,
        full,
        dmax * 1e6,
        t_c * 1e6,
        1e-3 / t_c,
        hertz_compliance
    )?;
    writeln!(d, "| N | G_res (m/N) | G_res / Hertz compliance |")?;
    writeln!(d, "|---|---|---|")?;
    let n_rows = study
        .first()
        .and_then(|s| s.first())
        .map_or(0, |s| s.rows.len());
    for (n, g) in residual.iter().enumerate().take(n_rows) {
        writeln!(d, "| {} | {:.3e} | {:.4} |", n + 1, g, g / hertz_compliance)?;
    }
    writeln!(d)?;
    let hertz_ok = verdicts
        .iter()
        .filter(|v| v.1 == ContactLaw::Hertz)
        .all(|v| v.2.converges);
    let ratios: Vec<f64> = residual[..n_rows]
        .iter()
        .map(|g| g / hertz_compliance)
        .collect();
    let worst = ratios.iter().copied().fold(0.0, f64::max);
    let last = ratios.last().copied().unwrap_or(0.0);
    let sentence = if worst < RESIDUAL_MATTERS {
        format!(
            "The compliance the truncation leaves out is at most {:.1} % of the contact's own \
             (N = 1) and {:.2} % at N = {n_rows}: in series with the Hertz spring it changes the \
             contact stiffness by less than that, below the {:.0} % that would call for a \
             correction. {} The correction is therefore not built.",
            100.0 * worst,
            100.0 * last,
            100.0 * RESIDUAL_MATTERS,
            if hertz_ok {
                "The hertz answers converge without it (criterion above)."
            } else {
                "Where the hertz answers still move with N (criterion above) the cause is not \
                 the missing static flexibility."
            }
        )
    } else {
        format!(
            "The compliance the truncation leaves out reaches {:.1} % of the contact's own; a \
             static correction is a candidate but is not built here.",
            100.0 * worst
        )
    };
    writeln!(d, "{sentence}")?;
    writeln!(d, "\nTotal wall time {wall_s:.1} s.")?;
    Ok(d)
}
