//! `vibrobar continue2`: two-parameter continuation in (ratio, gap) of a fold, period-doubling,
//! torus, branch-point or grazing point of a periodic orbit
//! ([`vibrobar_core::analysis::orbit::two_param`]), from a point the one-parameter `continue`
//! located, on the lumped bar or an N-mode bar (`[beam]`, `[[modes]]`). Output: the curve as CSV ([`vibrobar_io::csv::curve2_schema`]) and a figure of it in
//! the (ratio, gap) plane (`FILE.png/.svg`: the edge of stability bold, codimension-two points
//! marked).
use super::{check_value, fmt_coord, SystemArgs};
use anyhow::{bail, Context};
use std::path::PathBuf;
use vibrobar_core::analysis::orbit::modal::modal_orbit_settled_at;
use vibrobar_core::analysis::orbit::two_param::{
    continue_curve, on_boundary, stability_boundary, Curve, Curve2Settings, CurveKind,
};
use vibrobar_core::analysis::orbit::{orbit_auto, region::symmetric_orbit_at, ExactJacobian, Flow};
use vibrobar_core::structure::{ModalState, ModalSystem};
use vibrobar_io::csv::{curve2_schema, curve2_values, write_csv};

/// `vibrobar continue2`.
#[derive(Debug, Clone, clap::Args)]
pub struct Continue2Args {
    #[command(flatten)]
    /// System and solver.
    pub system: SystemArgs,
    /// The starting point `ratio=R,gap-mm=G`: a point of the kind, e.g. one the one-parameter
    /// `continue` located (its `event` row); Newton corrects it onto the curve at ratio R. The
    /// orbit there is the symmetric one on the lumped bar when it exists, else (and always on an
    /// N-mode bar) Newton from a settled run.
    #[arg(long)]
    pub from_point: String,
    /// What to continue: fold, period-doubling, torus, branch-point or grazing.
    #[arg(long)]
    pub kind: String,
    /// Ratio interval A:B the curve may cover (0 < A < B).
    #[arg(long, default_value = "0.95:1.05")]
    pub ratios: String,
    /// Gap interval A:B in mm the curve may cover (0 < A < B).
    #[arg(long, default_value = "0.005:1")]
    pub gaps_mm: String,
    /// Period in forcing cycles of the orbit.
    #[arg(long, default_value_t = 1)]
    pub period: u32,
    /// Most points on each side of the start, in [2, 100000].
    #[arg(long, default_value_t = 400)]
    pub max_points: usize,
    /// Output CSV `ratio,gap_mm,kind,rms_m,max_abs_multiplier,on_boundary,test_function,residual,impacts_per_period,event`; FILE.png/.svg beside it.
    #[arg(long)]
    pub out: PathBuf,
}

/// `A:B` with `0 < A < B`, the error naming `flag`.
fn interval(flag: &str, s: &str) -> anyhow::Result<(f64, f64)> {
    let parts: Vec<&str> = s.split(':').collect();
    let parsed: Vec<f64> = parts.iter().filter_map(|p| p.trim().parse().ok()).collect();
    if parts.len() != 2 || parsed.len() != 2 {
        bail!("{flag} must be A:B (two numbers), got {s:?}");
    }
    let (a, b) = (parsed[0], parsed[1]);
    if !(a.is_finite() && b.is_finite() && a > 0.0 && b > a) {
        bail!(
            "{flag} = {s}: the interval is empty, reversed or not finite; give A:B with 0 < A < B"
        );
    }
    Ok((a, b))
}

/// `ratio=R,gap-mm=G`.
fn point(s: &str) -> anyhow::Result<(f64, f64)> {
    let (mut r, mut g) = (None, None);
    for kv in s.split(',') {
        let (k, v) = kv
            .split_once('=')
            .with_context(|| format!("--from-point must be ratio=R,gap-mm=G, got {s:?}"))?;
        let v: f64 = v
            .trim()
            .parse()
            .with_context(|| format!("--from-point: {k} = {v:?} is not a number"))?;
        match k.trim() {
            "ratio" => r = Some(check_value("--from-point ratio", v, |x| x > 0.0, "(0, ∞)")?),
            "gap-mm" => {
                g = Some(check_value(
                    "--from-point gap-mm",
                    v,
                    |x| x > 0.0,
                    "(0, ∞) mm",
                )?)
            }
            other => bail!("--from-point: unknown key {other:?} (ratio, gap-mm)"),
        }
    }
    match (r, g) {
        (Some(r), Some(g)) => Ok((r, g)),
        _ => bail!("--from-point must give both ratio=R and gap-mm=G, got {s:?}"),
    }
}

/// `vibrobar continue2`.
pub fn run(a: &Continue2Args) -> anyhow::Result<()> {
    let kind = CurveKind::parse(&a.kind).map_err(anyhow::Error::msg)?;
    let (r0, g0_mm) = point(&a.from_point)?;
    let ratios = interval("--ratios", &a.ratios)?;
    let gaps_mm = interval("--gaps-mm", &a.gaps_mm)?;
    if !(ratios.0..=ratios.1).contains(&r0) {
        bail!(
            "--from-point ratio = {} lies outside --ratios {}",
            fmt_coord(r0),
            a.ratios
        );
    }
    let name = a.system.solver_name()?;
    if name != "exact" {
        bail!("--solver {name}: two-parameter curves use the exact solver; leave --solver out");
    }
    let sc = a.system.scenario()?;
    let sys = super::explore::PointArgs {
        system: a.system.clone(),
        ratio: r0,
        gap_mm: g0_mm,
    }
    .system()?;
    let settings = Curve2Settings {
        ratios,
        gaps_m: (gaps_mm.0 * 1e-3, gaps_mm.1 * 1e-3),
        max_points: a.max_points,
        ..Default::default()
    };
    if sys.lumped_bar().is_none() {
        // An N-mode bar: Newton from a settled run (the analytic symmetric orbit is the lumped
        // bar's), as `orbit` and `continue` start there.
        let msys = ModalSystem::from_system(&sys)?;
        let init = ModalState::from_public(&msys.model, &sc.base()?.init)?;
        let s = sc.settings();
        let (start, _) = modal_orbit_settled_at(
            &msys,
            a.period,
            &init,
            s.duration_s * (1.0 - s.rms_fraction),
        )?;
        let t = std::time::Instant::now();
        let c = continue_curve(&start, kind, &settings)?;
        return write_curve(a, kind, ratios, &c, t.elapsed().as_secs_f64());
    }
    // The symmetric orbit when it exists there (period 1), else Newton from the best start.
    let start = match (a.period, symmetric_orbit_at(&sys, &ExactJacobian)) {
        (1, Some(o)) => o,
        _ => {
            let settings = sc.settings();
            let init = sc.base()?.init;
            orbit_auto(
                &sys,
                a.period,
                &init,
                settings.duration_s * (1.0 - settings.rms_fraction),
                &ExactJacobian,
            )?
            .0
        }
    };
    let t = std::time::Instant::now();
    let c = continue_curve(&start, kind, &settings)?;
    write_curve(a, kind, ratios, &c, t.elapsed().as_secs_f64())
}

/// The curve's CSV, its figure and the report line, either bar.
fn write_curve<F: Flow>(
    a: &Continue2Args,
    kind: CurveKind,
    ratios: (f64, f64),
    c: &Curve<F>,
    wall: f64,
) -> anyhow::Result<()> {
    let schema = curve2_schema();
    write_csv(
        &a.out,
        &schema,
        c.points.iter().map(|p| curve2_values(kind, p)),
    )
    .with_context(|| format!("writing {}", a.out.display()))?;
    // Figure: the curve in the (ratio, gap) plane over an empty grid.
    let pts: Vec<(f64, f64)> = c.points.iter().map(|p| (p.ratio, p.gap_m * 1e3)).collect();
    let edge: Vec<(f64, f64)> = c
        .points
        .iter()
        .map(|p| {
            if on_boundary(p) {
                (p.ratio, p.gap_m * 1e3)
            } else {
                (f64::NAN, f64::NAN)
            }
        })
        .collect();
    let marks: Vec<(f64, f64)> = c
        .points
        .iter()
        .filter(|p| p.event.is_some())
        .map(|p| (p.ratio, p.gap_m * 1e3))
        .collect();
    let (glo, ghi) = pts
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
    let pad = 0.1 * (ghi - glo).max(1e-3);
    let xs: Vec<f64> = (0..=40)
        .map(|i| ratios.0 + (ratios.1 - ratios.0) * i as f64 / 40.0)
        .collect();
    let ys: Vec<f64> = (0..=40)
        .map(|i| (glo - pad) + (ghi - glo + 2.0 * pad) * i as f64 / 40.0)
        .collect();
    let z = vec![vec![f64::NAN; ys.len()]; xs.len()];
    let title = format!("{} curve of the orbit in (ratio, gap)", kind.as_str());
    let stem = a.out.with_extension("");
    vibrobar_report::figures::heat_files_with_curves(
        &stem,
        &vibrobar_report::figures::Heat {
            title: &title,
            x_label: "frequency ratio Ω/ωn",
            y_label: "gap (mm)",
            z_label: "",
            xs: &xs,
            ys: &ys,
            z: &z,
            levels: vec![],
            strong_level: None,
            markers: None,
            hlines: vec![],
            vlines: vec![],
        },
        &[
            vibrobar_report::figures::HeatCurve {
                label: format!("{} curve", kind.as_str()),
                colour: plotters::style::RGBColor(20, 40, 160),
                points: pts,
                marks: marks.clone(),
            },
            vibrobar_report::figures::HeatCurve {
                label: "edge of stability".into(),
                colour: plotters::style::RGBColor(220, 30, 30),
                points: edge,
                marks: vec![],
            },
        ],
    )?;
    println!(
        "{} curve: {} points in {:.2} s ({}); ends: {}",
        kind.as_str(),
        c.points.len(),
        wall,
        if c.symmetric {
            "symmetric orbit, half map"
        } else {
            "full map"
        },
        c.stop_reasons.join("; ")
    );
    for p in c.points.iter().filter(|p| p.event.is_some()) {
        println!(
            "  {} at ratio {:.6}, gap {:.6} mm",
            p.event.map_or("", |e| e.as_str()),
            p.ratio,
            p.gap_m * 1e3
        );
    }
    println!("wrote {}", a.out.display());
    Ok(())
}

/// Colour of a boundary curve by kind.
fn kind_colour(k: CurveKind) -> plotters::style::RGBColor {
    use plotters::style::RGBColor;
    match k {
        CurveKind::Torus => RGBColor(230, 40, 40),
        CurveKind::Fold => RGBColor(255, 150, 20),
        CurveKind::BranchPoint => RGBColor(240, 80, 240),
        CurveKind::PeriodDoubling => RGBColor(40, 200, 240),
        CurveKind::Grazing => RGBColor(255, 255, 255),
    }
}

/// The stability boundary of the symmetric orbit of `base` over `ratios` × `gaps_m` (the
/// two-parameter curves, [`stability_boundary`] seeded at the ends, the middle and r = 1 when
/// inside), and the overlay curves (gap in mm): only the parts on the edge of stability, the
/// codimension-two points on it marked.
pub fn boundary_overlay(
    base: &vibrobar_core::System,
    ratios: (f64, f64),
    gaps_m: &[f64],
) -> anyhow::Result<(
    Vec<vibrobar_report::figures::HeatCurve>,
    Vec<vibrobar_core::analysis::orbit::two_param::Curve>,
)> {
    let mut seeds = vec![ratios.0, 0.5 * (ratios.0 + ratios.1), ratios.1];
    if ratios.0 < 1.0 && 1.0 < ratios.1 {
        seeds.insert(1, 1.0);
    }
    let (glo, ghi) = (gaps_m[0], gaps_m[gaps_m.len() - 1]);
    let settings = Curve2Settings {
        ratios,
        gaps_m: (glo, ghi),
        ..Default::default()
    };
    let curves = stability_boundary(base, &seeds, gaps_m, &settings)?;
    let overlay = curves
        .iter()
        .map(|c| vibrobar_report::figures::HeatCurve {
            label: format!("edge of stability: {}", c.kind.as_str()),
            colour: kind_colour(c.kind),
            points: c
                .points
                .iter()
                .map(|p| {
                    if on_boundary(p) {
                        (p.ratio, p.gap_m * 1e3)
                    } else {
                        (f64::NAN, f64::NAN)
                    }
                })
                .collect(),
            marks: c
                .points
                .iter()
                .filter(|p| p.event.is_some() && p.orbit.max_abs_multiplier() < 1.0 + 1e-3)
                .map(|p| (p.ratio, p.gap_m * 1e3))
                .collect(),
        })
        .collect();
    Ok((overlay, curves))
}
