//! `vibrobar contact-laws`: the generated document (`docs/contact-laws.md`) that asks whether
//! the paper's instantaneous impact law is an adequate model (issue #9 §5), by running the
//! lumped paper cases with `restitution` and with `hertz`: the Figs. 3 and 5 sweep set, the best
//! gap at resonance, and initial-condition ensembles at the chaotic points (statistics, not
//! single runs). It also tabulates the single-impact laboratory (closed forms, the drift of the
//! published approximate damping laws). Every number is computed here; `--quick` is for tests.

use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::PathBuf;
use vibrobar_core::analysis::contact_test::single_impact;
use vibrobar_core::analysis::ensemble::{run_ensemble, EnsembleParams, EnsembleStats};
use vibrobar_core::analysis::map::{Axis, Grid, GridAxis, MapSpec};
use vibrobar_core::analysis::regime::Tolerances;
use vibrobar_core::analysis::{SweepBase, SweepRow};
use vibrobar_core::damper::contact::{d_flores, d_lankarani_nikravesh, damping_factor, Hertz};
use vibrobar_core::{ContactLaw, FrictionModel, RunSettings};

use super::paper::{ensemble_ranges, paper_points, ENSEMBLE_SEED};
use super::{solver, sweep_rows};
use crate::cli::REPRODUCING_FRICTION_N;
use crate::scenario::sweep_ratios;
use vibrobar_core::analysis::sweep::SweepRange;
use vibrobar_report::report::{variants, ContactComparison};

/// `vibrobar contact-laws`.
#[derive(Debug, Clone, clap::Args)]
pub struct ContactLawsArgs {
    /// The Markdown document to write (e.g. docs/contact-laws.md).
    #[arg(long)]
    pub out: PathBuf,
    /// Simulated time of each run, s.
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
    pub duration: f64,
    /// Members of each initial-condition ensemble.
    #[arg(long, default_value_t = 24)]
    pub members: usize,
    /// Short runs for tests: 0.1 s, 4 members, three ratios.
    #[arg(long)]
    pub quick: bool,
}

/// Gaps of the best-gap scan at r = 1, frictionless, mm.
const GAPS_MM: [f64; 8] = [0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0];
/// Ratios of the ensembles (gap 0.1 mm, frictionless: the chaotic band of the paper case).
const ENSEMBLE_RATIOS: [f64; 3] = [0.98, 1.0, 1.02];

fn base(law: ContactLaw) -> SweepBase {
    let mut b = SweepBase::paper();
    b.ball.contact.law = law;
    b
}

/// Run the command.
pub fn run(args: &ContactLawsArgs) -> Result<()> {
    let mut st = RunSettings {
        duration_s: args.duration,
        ..RunSettings::default()
    };
    let mut ratios = sweep_ratios(&SweepRange::paper())?;
    let mut members = args.members;
    if args.quick {
        st.duration_s = 0.1;
        ratios = vec![0.95, 1.0, 1.05];
        members = 4;
    }
    st.validate()?;
    let exact = solver("exact", &st)?;
    let vs = variants(REPRODUCING_FRICTION_N);
    let t0 = std::time::Instant::now();
    let runs = law_runs(&st, &ratios, members, &vs)?;
    // Best gap at resonance, frictionless.
    let gap_points: Vec<_> = GAPS_MM
        .iter()
        .map(|&g| vibrobar_core::analysis::SweepPoint {
            ratio: 1.0,
            gap_m: g * 1e-3,
            friction: FrictionModel::None,
            friction_force_n: None,
        })
        .collect();
    let mut gaps = Vec::new();
    for law in ContactLaw::ALL {
        gaps.push(sweep_rows(
            &gap_points,
            &base(law),
            &st,
            exact.as_ref(),
            &format!("contact-laws gaps [{law}]"),
            false,
        )?);
    }
    let doc = render(
        args,
        &st,
        members,
        &vs,
        &runs,
        &gaps,
        t0.elapsed().as_secs_f64(),
    )?;
    vibrobar_io::csv::write_text(&args.out, &doc)
        .with_context(|| format!("writing {}", args.out.display()))?;
    println!("wrote {}", args.out.display());
    Ok(())
}

/// The paper's sweep set and the chaotic-point ensembles under both laws (exact solver).
pub(crate) struct LawRuns {
    /// Sweep rows per law (`ContactLaw::ALL` order).
    pub sweeps: Vec<Vec<SweepRow>>,
    /// Wall time of each law's sweep, s.
    pub walls: Vec<f64>,
    /// Ensembles per law at [`ENSEMBLE_RATIOS`], gap 0.1 mm, frictionless.
    pub ens: Vec<Vec<EnsembleStats>>,
    /// Members per ensemble point.
    pub members: usize,
}

impl LawRuns {
    /// The claim's numbers ([`ContactComparison`], one criterion for this document and REPORT.md).
    pub fn comparison(&self, vs: &[vibrobar_report::report::Variant]) -> ContactComparison {
        ContactComparison::new(
            vs,
            &self.sweeps[0],
            &self.sweeps[1],
            &self.ens[0],
            &self.ens[1],
            self.members,
        )
    }
}

/// Run [`LawRuns`]: the sweep set at `ratios`, the ensembles with `members` each.
pub(crate) fn law_runs(
    st: &RunSettings,
    ratios: &[f64],
    members: usize,
    vs: &[vibrobar_report::report::Variant],
) -> Result<LawRuns> {
    let st = *st;
    let exact = solver("exact", &st)?;
    let points = paper_points(vs, ratios);
    let mut sweeps: Vec<Vec<SweepRow>> = Vec::new();
    let mut walls = Vec::new();
    for law in ContactLaw::ALL {
        let t = std::time::Instant::now();
        sweeps.push(sweep_rows(
            &points,
            &base(law),
            &st,
            exact.as_ref(),
            &format!("contact-laws sweep [{law}]"),
            true,
        )?);
        walls.push(t.elapsed().as_secs_f64());
    }
    let grid = Grid::new(vec![
        GridAxis {
            axis: Axis::FreqRatio,
            values: ENSEMBLE_RATIOS.to_vec(),
        },
        GridAxis {
            axis: Axis::GapM,
            values: vec![0.1e-3],
        },
    ])?;
    let gpts = grid.points();
    let mut ens: Vec<Vec<EnsembleStats>> = Vec::new();
    for law in ContactLaw::ALL {
        let b = base(law);
        let spec = MapSpec {
            base: b,
            friction: FrictionModel::None,
            settings: st,
            tolerances: Tolerances::default(),
        };
        let params = EnsembleParams {
            seed: ENSEMBLE_SEED,
            members,
            ranges: ensemble_ranges(&b),
        };
        ens.push(
            run_ensemble(&spec, exact.as_ref(), &gpts, &params, &|_, _| {})
                .map_err(|e| anyhow::anyhow!("contact-laws ensemble [{law}]: {e}"))?,
        );
    }
    Ok(LawRuns {
        sweeps,
        walls,
        ens,
        members,
    })
}

#[allow(clippy::too_many_arguments)]
fn render(
    args: &ContactLawsArgs,
    st: &RunSettings,
    members: usize,
    vs: &[vibrobar_report::report::Variant],
    runs: &LawRuns,
    gaps: &[Vec<SweepRow>],
    wall_s: f64,
) -> Result<String> {
    let (sweeps, walls, ens) = (&runs.sweeps, &runs.walls, &runs.ens);
    let cmp = runs.comparison(vs);
    let mut d = String::new();
    let b = SweepBase::paper().ball;
    let law = Hertz::new(
        &vibrobar_core::Contact::hertz(),
        b.ball_radius_m,
        b.restitution,
    );
    writeln!(
        d,
        "# Is the instantaneous impact law good enough? (restitution vs hertz)\n"
    )?;
    writeln!(
        d,
        "Generated by `vibrobar contact-laws --out {}`{} (issue #9 §5). Lumped paper bar, exact \
         solver, {} s per run, RMS over the last {:.0} %. Do not edit by hand.\n",
        args.out.display(),
        if args.quick {
            " --quick (SHORT RUNS: not the real numbers)"
        } else {
            ""
        },
        st.duration_s,
        100.0 * st.rms_fraction
    )?;
    writeln!(d, "## The two laws\n")?;
    writeln!(
        d,
        "* `restitution` (the paper's Eqs. 4–5): an instantaneous impact, `ẇ+ = −e ẇ−`.\n\
         * `hertz`: a compliant contact, `P = K_h δ^{{3/2}} (1 + D δ̇/δ̇₀)`, carbide ball \
         (E = 630 GPa, ν = 0.22) on a flat steel wall (E = 205 GPa, ν = 0.29): \
         E* = {:.2} GPa, R* = {} mm, K_h = {:.4e} N/m^1.5; `D(e)` from the exact phase-plane \
         relation `h(D) = h(−eD)`, `h(x) = x − ln(1+x)`, so the rigid-wall restitution is `e` at \
         every speed. For e = {}: D = {:.6}.\n",
        law.effective_modulus_pa * 1e-9,
        law.effective_radius_m * 1e3,
        law.stiffness_n_m32,
        b.restitution,
        law.damping
    )?;
    writeln!(
        d,
        "### Single impacts on a rigid wall (`vibrobar contact-test`)\n"
    )?;
    writeln!(
        d,
        "| v₀ (m/s) | contact time (s) | Hertz closed form D = 0 (s) | e_eff | peak force (N) | max penetration (m) |"
    )?;
    writeln!(d, "|---|---|---|---|---|---|")?;
    for v in [0.01, 0.1, 1.0] {
        let o = single_impact(&law, b.ball_mass_kg, v)?;
        writeln!(
            d,
            "| {v} | {:.4e} | {:.4e} | {:.7} | {:.4} | {:.4e} |",
            o.contact_time_s,
            law.undamped_contact_time_s(b.ball_mass_kg, v),
            o.restitution,
            o.max_force_n,
            o.max_penetration_m
        )?;
    }
    writeln!(
        d,
        "\nDrift of the published approximate damping factors (effective e on a rigid wall; the \
         law is self-similar, so it is the same at every speed from 0.01 to 1 m/s):\n"
    )?;
    writeln!(
        d,
        "| target e | exact D(e) | Flores et al. 2011 | Lankarani–Nikravesh 1990 |"
    )?;
    writeln!(d, "|---|---|---|---|")?;
    for e in [0.2, 0.5, 0.8, 0.95] {
        let eff = |dd: f64| -> Result<f64> {
            Ok(single_impact(&law.with_damping(dd), b.ball_mass_kg, 0.1)?.restitution)
        };
        writeln!(
            d,
            "| {e} | {:.6} | {:.4} | {:.4} |",
            eff(damping_factor(e))?,
            eff(d_flores(e))?,
            eff(d_lankarani_nikravesh(e))?
        )?;
    }
    writeln!(d, "\n## Figs. 3 and 5 sweep set, side by side\n")?;
    writeln!(
        d,
        "RMS reduction (%) of the damped bar against the solid bar, per variant, gap and ratio. \
         Wall time of the set: restitution {:.1} s, hertz {:.1} s.\n",
        walls[0], walls[1]
    )?;
    writeln!(
        d,
        "| variant | gap (mm) | ratio | restitution | hertz | Δ (points) |"
    )?;
    writeln!(d, "|---|---|---|---|---|---|")?;
    for (r, h) in sweeps[0].iter().zip(&sweeps[1]) {
        let key = vs
            .iter()
            .find(|v| v.friction == r.point.friction && v.force_n == r.point.friction_force_n)
            .map_or("?".to_string(), |v| v.key.clone());
        let (a, c) = (r.reduction_pct(), h.reduction_pct());
        let delta = c - a;
        writeln!(
            d,
            "| {key} | {} | {} | {a:.2} | {c:.2} | {delta:+.2} |",
            vibrobar_io::csv::grid_num(r.point.gap_m * 1e3),
            vibrobar_io::csv::grid_num(r.point.ratio)
        )?;
    }
    writeln!(
        d,
        "\nMean |Δ| = {:.2} percentage points over {} points; largest {:+.2} at {}.\n",
        cmp.mean_abs_pp, cmp.points, cmp.worst_pp, cmp.worst_at
    )?;
    writeln!(d, "## Best gap at resonance (r = 1, frictionless)\n")?;
    writeln!(
        d,
        "| gap (mm) | restitution RMS (m) | hertz RMS (m) | Δ (%) |"
    )?;
    writeln!(d, "|---|---|---|---|")?;
    let mut best = [(f64::INFINITY, 0.0); 2];
    for (r, h) in gaps[0].iter().zip(&gaps[1]) {
        let g = r.point.gap_m * 1e3;
        for (k, row) in [r, h].into_iter().enumerate() {
            if row.damped.rms_m < best[k].0 {
                best[k] = (row.damped.rms_m, g);
            }
        }
        writeln!(
            d,
            "| {} | {:.4e} | {:.4e} | {:+.2} |",
            vibrobar_io::csv::grid_num(g),
            r.damped.rms_m,
            h.damped.rms_m,
            100.0 * (h.damped.rms_m / r.damped.rms_m - 1.0)
        )?;
    }
    writeln!(
        d,
        "\nBest gap: restitution {} mm, hertz {} mm.\n",
        vibrobar_io::csv::grid_num(best[0].1),
        vibrobar_io::csv::grid_num(best[1].1)
    )?;
    writeln!(
        d,
        "## Chaotic points: initial-condition ensembles (gap 0.1 mm, frictionless)\n"
    )?;
    writeln!(
        d,
        "{members} members per point, the paper command's seed and ranges. A single run at a \
         chaotic point is one sample; the laws are compared by the ensemble means, with the \
         standard error of their difference.\n"
    )?;
    writeln!(
        d,
        "| ratio | restitution mean ± std (m) | hertz mean ± std (m) | Δ mean (%) | Δ / std. error |"
    )?;
    writeln!(d, "|---|---|---|---|---|")?;
    for (r, h) in ens[0].iter().zip(&ens[1]) {
        let ratio = r.point.coords[0].1;
        let z = ContactComparison::z(r, h, members);
        writeln!(
            d,
            "| {} | {:.4e} ± {:.2e} | {:.4e} ± {:.2e} | {:+.2} | {:+.2} |",
            vibrobar_io::csv::grid_num(ratio),
            r.mean_rms_m,
            r.std_rms_m,
            h.mean_rms_m,
            h.std_rms_m,
            100.0 * (h.mean_rms_m / r.mean_rms_m - 1.0),
            z
        )?;
    }
    writeln!(d, "\n## Verdict\n")?;
    let adequate = cmp.adequate();
    // What the compliance does: how deep the ball sinks into the wall, against the half gap.
    let pen = |rows: &[SweepRow], gap_m: f64| {
        rows.iter()
            .filter(|r| (r.point.gap_m - gap_m).abs() < 1e-12)
            .map(|r| r.damped.summary.max_penetration_m)
            .fold(0.0f64, f64::max)
    };
    let (p05, p1) = (pen(&gaps[1], 0.05e-3), pen(&gaps[1], 0.1e-3));
    writeln!(
        d,
        "Instantaneous impacts are {}an adequate model of the lumped paper cases (criterion: mean \
         |Δ| < {} points over the sweep set and every ensemble |Δ|/s.e. < {}): the RMS reductions \
         of the sweep set differ by {:.2} percentage points on average (largest {:+.2} at {}), \
         and at the chaotic points the ensemble means differ by up to {:.1} standard errors. \
         The same numbers make claim C1 of `vibrobar paper`'s REPORT.md.\n",
        if adequate { "" } else { "NOT " },
        vibrobar_report::report::CONTACT_MEAN_PP_TOL,
        vibrobar_report::report::CONTACT_Z_TOL,
        cmp.mean_abs_pp,
        cmp.worst_pp,
        cmp.worst_at,
        cmp.max_z
    )?;
    writeln!(
        d,
        "Why: a contact lasts {:.0}–{:.0} µs (1 to 0.01 m/s) against a bar period of {:.2} ms, \
         so the bar hardly moves during one; but the ball sinks up to {:.2} µm into the wall at gap 0.1 mm ({:.0} % of the \
         half gap) and {:.2} µm at 0.05 mm ({:.0} %). The compliance is not small against the \
         clearance, so the compliant law acts like a narrower, softer gap; where the ball never \
         reaches a wall (gaps ≥ 0.2 mm at r = 1 from rest) the laws agree exactly.\n",
        single_impact(&law, b.ball_mass_kg, 1.0)?.contact_time_s * 1e6,
        single_impact(&law, b.ball_mass_kg, 0.01)?.contact_time_s * 1e6,
        2e3 * std::f64::consts::PI / SweepBase::paper().damped_bar.omega1_rad_s(),
        p1 * 1e6,
        100.0 * p1 / 0.05e-3,
        p05 * 1e6,
        100.0 * p05 / 0.025e-3
    )?;
    writeln!(
        d,
        "The N-mode beam under both laws, and whether each converges with the number of modes: \
         `docs/contact-convergence.md` (`vibrobar contact-convergence`).\n\nOn a cutting run \
         (`[cutting]`, issue #13) the `hertz` law works on every bar (lumped, `[beam]`, \
         `[[modes]]`) as on a harmonic run: the contact phase carries the cutting force (the delayed surface of the current piece), \
         stops at every piece end and breakpoint of the delay stepping, and locates the tool \
         leaving or re-entering the cut on its dense output. A stiffer contact with the same \
         restitution approaches the restitution law's cutting run, the difference falling as \
         K_h^(-2/5), like the penetration and the contact time (test \
         `a_stiff_contact_approaches_the_restitution_run`); a one-mode `[[modes]]` table is \
         the lumped run, contact for contact (test \
         `one_mode_table_is_the_lumped_cutting_hertz_run`).\n\nTotal wall time \
         {wall_s:.1} s."
    )?;
    Ok(d)
}
