//! Exploration of single design points: stroboscopic Poincaré section, bifurcation diagram over
//! the ratio or the gap, largest Lyapunov exponent, and initial-condition ensembles.
//! Every command takes the same system flags as `map` (`--preset` or `--scenario`, `--friction`,
//! `--friction-force-n`, `--solver`, `--duration`, `--dt`, `--rms-fraction`), starts from the
//! scenario's initial state (at rest for the preset) and writes `FILE.meta.json` beside its data.
use super::{check_value, fmt_coord, parse_range, with_threads, SystemArgs};
use crate::progress::Progress;
use anyhow::{bail, Context};
use std::io::Write;
use std::path::{Path, PathBuf};
use vibrobar_core::analysis::ensemble::{run_ensemble, EnsembleParams, IcRanges};
use vibrobar_core::analysis::lyapunov::{max_lyapunov, max_lyapunov_modal, LyapunovParams};
use vibrobar_core::analysis::lyapunov_spectrum::{lyapunov_spectrum, SpectrumParams};
use vibrobar_core::analysis::map::{Axis, Grid, GridAxis, GridPoint, MapSpec};
use vibrobar_core::analysis::poincare::{bifurcation, BifurcationSpec, Stroboscope};
use vibrobar_core::analysis::regime::Tolerances;
use vibrobar_core::params::BarModel;
use vibrobar_core::params::System;
use vibrobar_core::solver::modal_run_by_name;
use vibrobar_core::structure::{ModalState, ModalSystem};
use vibrobar_io::csv::{
    bifurcation_impacts_schema, bifurcation_schema, ensemble_schema, poincare_schema,
    poincare_values, regime_counts, write_csv, EnsembleCsvRow, Schema, Value,
};
use vibrobar_io::params::{
    BifurcationParams, EnsembleFileParams, IcHalfRanges, PoincareParams, PointParams,
};
use vibrobar_io::{npy, shard, GridInfo, Metadata};

/// One design point: system flags plus ratio and gap.
#[derive(Debug, Clone, clap::Args)]
pub struct PointArgs {
    #[command(flatten)]
    /// System and solver.
    pub system: SystemArgs,
    /// Frequency ratio Ω/ω_n (> 0).
    #[arg(long, allow_negative_numbers = true)]
    pub ratio: f64,
    /// Total gap in mm (> 0).
    #[arg(long, allow_negative_numbers = true)]
    pub gap_mm: f64,
}

fn spec(s: &SystemArgs) -> anyhow::Result<MapSpec> {
    let sc = s.scenario()?;
    Ok(MapSpec {
        base: sc.base()?,
        friction: sc.damper.friction,
        settings: sc.settings(),
        tolerances: Tolerances::default(),
    })
}

fn point(ratio: f64, gap_mm: f64) -> anyhow::Result<GridPoint> {
    check_value("--ratio", ratio, |x| x > 0.0, "(0, ∞)")?;
    check_value("--gap-mm", gap_mm, |x| x > 0.0, "(0, ∞) mm")?;
    Ok(GridPoint {
        index: 0,
        coords: vec![(Axis::FreqRatio, ratio), (Axis::GapM, gap_mm * 1e-3)],
    })
}

impl PointArgs {
    /// The damped system at the point, validated.
    pub fn system(&self) -> anyhow::Result<System> {
        let spec = spec(&self.system)?;
        let sys = spec.damped_system(&point(self.ratio, self.gap_mm)?)?;
        sys.validate()?;
        spec.base.init.validate(&sys)?;
        Ok(sys)
    }

    /// Parameters for metadata.
    pub fn to_params(&self) -> anyhow::Result<PointParams> {
        Ok(PointParams {
            system: self.system.to_params()?,
            ratio: self.ratio,
            gap_m: self.gap_mm * 1e-3,
        })
    }
}

pub(crate) fn transient_or_default(flag: Option<f64>, s: &SystemArgs) -> anyhow::Result<f64> {
    let st = s.settings()?;
    let t = flag.unwrap_or(st.duration_s * (1.0 - st.rms_fraction));
    check_value(
        "--transient",
        t,
        |x| x >= 0.0 && x < st.duration_s,
        "[0, --duration) s",
    )
}

/// Write the rows of `schema` to `path` and the typed `params` beside it.
fn write_csv_with_meta<P: serde::Serialize>(
    path: &Path,
    kind: &str,
    schema: &Schema,
    rows: impl IntoIterator<Item = Vec<Value>>,
    params: P,
) -> anyhow::Result<()> {
    write_csv(path, schema, rows).with_context(|| format!("writing {}", path.display()))?;
    Metadata::new(kind, &schema.header(), params, None)
        .write_beside(path)
        .with_context(|| format!("metadata beside {}", path.display()))?;
    Ok(())
}

/// `vibrobar poincare`: stroboscopic section (once per forcing period) of one run.
#[derive(Debug, Clone, clap::Args)]
pub struct PoincareArgs {
    #[command(flatten)]
    /// The point.
    pub point: PointArgs,
    /// Forcing phase Ωt of the section, in degrees.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    pub phase_deg: f64,
    /// Discarded time at the start, s (default: the part before the RMS window).
    #[arg(long, allow_negative_numbers = true)]
    pub transient: Option<f64>,
    /// A `[two_plane]` scenario: start from member K of its ensemble of starts [default: 0].
    #[arg(long, value_name = "K")]
    pub member: Option<usize>,
    /// Output CSV (`t_s,u_m,du_m_s,w_m,dw_m_s`; a `[two_plane]` scenario: the columns of its
    /// `run` history); FILE.npy and FILE.png/.svg beside it.
    #[arg(long)]
    pub out: PathBuf,
}

/// `vibrobar poincare`.
pub fn run_poincare(a: &PoincareArgs) -> anyhow::Result<()> {
    let sc = a.point.system.scenario()?;
    if sc.two_plane.is_some() {
        return super::poincare_two_plane::run(a, &sc);
    }
    super::sweep_two_plane::refuse_member(a.member)?;
    let sys = a.point.system()?;
    let solver = a.point.system.solver()?;
    let phase = check_value("--phase-deg", a.phase_deg, |_| true, "finite")?.to_radians();
    let transient = transient_or_default(a.transient, &a.point.system)?;
    let spec = spec(&a.point.system)?;
    vibrobar_core::limits::check_samples(
        "Poincaré points = (--duration − --transient) / forcing period",
        spec.settings.duration_s - transient,
        sys.forcing_period_s(),
    )?;
    let mut strobe = Stroboscope::for_system(&sys, phase, transient);
    let init = spec.base.init;
    solver.run(
        &sys,
        &init,
        init.t_s + spec.settings.duration_s,
        &mut strobe,
    )?;
    let pts = &strobe.points;
    let data: Vec<f64> = pts.iter().flat_map(poincare_values).collect();
    let params = PoincareParams {
        point: a.point.to_params()?,
        phase_rad: phase,
        transient_s: transient,
    };
    write_csv_with_meta(
        &a.out,
        "poincare",
        &poincare_schema(),
        pts.iter()
            .map(|s| poincare_values(s).map(Value::F).to_vec()),
        &params,
    )?;
    let npy_path = a.out.with_extension("npy");
    npy::write_f64(&npy_path, &[pts.len(), 5], &data)?;
    Metadata::new("poincare", "", &params, None).write_beside(&npy_path)?;
    let xy: Vec<(f64, f64)> = pts.iter().map(|s| (s.u_m * 1e6, s.du_m_s * 1e3)).collect();
    let title = format!(
        "Poincaré section at Ωt = {}°, r = {}, gap = {} mm",
        fmt_coord(a.phase_deg),
        fmt_coord(a.point.ratio),
        fmt_coord(a.point.gap_mm)
    );
    let files = vibrobar_report::figures::scatter_files(
        &a.out.with_extension(""),
        &vibrobar_report::figures::Scatter {
            title: &title,
            x_label: "bar displacement u (µm)",
            y_label: "bar velocity du/dt (mm/s)",
            points: &xy,
            radius: 3,
        },
    )?;
    println!(
        "{} points; wrote {}, {}",
        pts.len(),
        a.out.display(),
        npy_path.display()
    );
    for f in files {
        println!("wrote {}", f.display());
    }
    Ok(())
}

/// Parameter of a bifurcation diagram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BifParam {
    /// Frequency ratio.
    Ratio,
    /// Gap in mm.
    GapMm,
}

/// `vibrobar bifurcation`: stroboscopic points after the transient for each parameter value.
#[derive(Debug, Clone, clap::Args)]
pub struct BifurcationArgs {
    #[command(flatten)]
    /// System and solver.
    pub system: SystemArgs,
    /// Swept parameter.
    #[arg(long, value_enum)]
    pub param: BifParam,
    /// Values, START:STOP:STEP (inclusive).
    #[arg(long, allow_hyphen_values = true)]
    pub values: String,
    /// Fixed ratio (when sweeping the gap).
    #[arg(long, allow_negative_numbers = true)]
    pub ratio: Option<f64>,
    /// Fixed gap in mm (when sweeping the ratio).
    #[arg(long, allow_negative_numbers = true)]
    pub gap_mm: Option<f64>,
    /// Forcing phase of the section, degrees.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    pub phase_deg: f64,
    /// Discarded time at the start of each run, s (default: before the RMS window).
    #[arg(long, allow_negative_numbers = true)]
    pub transient: Option<f64>,
    /// Threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Output CSV (`PARAM,t_s,u_m,du_m_s`); FILE.npy (n × 4), FILE.impacts.csv and
    /// FILE.png/.svg beside it.
    #[arg(long)]
    pub out: PathBuf,
}

/// `vibrobar bifurcation`.
pub fn run_bifurcation(a: &BifurcationArgs) -> anyhow::Result<()> {
    let (axis, col, values, fixed) = match a.param {
        BifParam::Ratio => {
            let v = parse_range(
                "--values",
                &a.values,
                |x| x > 0.0,
                "(0, ∞) for --param ratio",
            )?;
            let g = a
                .gap_mm
                .context("--gap-mm is required with --param ratio")?;
            (Axis::FreqRatio, "ratio", v, point(1.0, g)?)
        }
        BifParam::GapMm => {
            let v = parse_range(
                "--values",
                &a.values,
                |x| x > 0.0,
                "(0, ∞) mm for --param gap-mm",
            )?;
            let r = a.ratio.context("--ratio is required with --param gap-mm")?;
            (Axis::GapM, "gap_mm", v, point(r, 1.0)?)
        }
    };
    let scale = if axis == Axis::GapM { 1e-3 } else { 1.0 };
    let si: Vec<f64> = values.iter().map(|v| v * scale).collect();
    let spec = spec(&a.system)?;
    let sys = spec.damped_system(&fixed)?;
    for &v in &si {
        let mut s = sys;
        axis.apply(&mut s, v)?;
        s.validate()?;
        spec.base.init.validate(&s)?;
    }
    let transient = transient_or_default(a.transient, &a.system)?;
    let phase = check_value("--phase-deg", a.phase_deg, |_| true, "finite")?.to_radians();
    let solver = a.system.solver()?;
    let bs = BifurcationSpec {
        system: sys,
        axis,
        init: spec.base.init,
        duration_s: spec.settings.duration_s,
        transient_s: transient,
        phase_rad: phase,
        impact_wall: None,
    };
    let bar = Progress::new("bifurcation", si.len(), 0);
    let b = with_threads(a.threads, || {
        bifurcation(&bs, &si, solver.as_ref(), &bar.callback())
    })??;
    bar.finish();
    // The value as the user wrote it (mm for gaps), identical in the CSV and the NPY.
    let user_value =
        |param: f64| -> f64 { fmt_coord(param / scale).parse().expect("formatted float") };
    let data: Vec<f64> = b
        .points
        .iter()
        .flat_map(|p| [user_value(p.param), p.t_s, p.u_m, p.du_m_s])
        .collect();
    let params = BifurcationParams {
        system: a.system.to_params()?,
        param: col.into(),
        values: values.clone(),
        fixed_ratio: a.ratio,
        fixed_gap_m: a.gap_mm.map(|g| g * 1e-3),
        phase_rad: phase,
        transient_s: transient,
    };
    write_csv_with_meta(
        &a.out,
        "bifurcation",
        &bifurcation_schema(col),
        data.chunks_exact(4)
            .map(|r| r.iter().map(|x| Value::F(*x)).collect()),
        &params,
    )?;
    let npy_path = a.out.with_extension("npy");
    npy::write_f64(&npy_path, &[b.points.len(), 4], &data)?;
    Metadata::new("bifurcation", "", &params, None).write_beside(&npy_path)?;
    let imp_path = vibrobar_report::figures::with_ext(&a.out.with_extension(""), "impacts.csv");
    write_csv_with_meta(
        &imp_path,
        "bifurcation-impacts",
        &bifurcation_impacts_schema(col),
        b.impacts.iter().map(|i| {
            vec![
                Value::F(i.param / scale),
                Value::F(i.t_s),
                Value::S(if i.wall.sign() > 0.0 { "plus" } else { "minus" }.into()),
                Value::F(i.dw_m_s),
            ]
        }),
        &params,
    )?;
    let xy: Vec<(f64, f64)> = b
        .points
        .iter()
        .map(|p| (p.param / scale, p.u_m * 1e6))
        .collect();
    let (x_label, title) = match a.param {
        BifParam::Ratio => (
            "frequency ratio Ω/ωn",
            format!(
                "Bifurcation diagram, gap = {} mm",
                fmt_coord(a.gap_mm.unwrap_or(f64::NAN))
            ),
        ),
        BifParam::GapMm => (
            "gap (mm)",
            format!(
                "Bifurcation diagram, r = {}",
                fmt_coord(a.ratio.unwrap_or(f64::NAN))
            ),
        ),
    };
    let files = vibrobar_report::figures::scatter_files(
        &a.out.with_extension(""),
        &vibrobar_report::figures::Scatter {
            title: &title,
            x_label,
            y_label: "stroboscopic u (µm)",
            points: &xy,
            radius: 1,
        },
    )?;
    println!(
        "{} points, {} impacts; wrote {}, {}, {}",
        b.points.len(),
        b.impacts.len(),
        a.out.display(),
        npy_path.display(),
        imp_path.display()
    );
    for f in files {
        println!("wrote {}", f.display());
    }
    Ok(())
}

/// `vibrobar lyapunov`: largest Lyapunov exponent (two-trajectory divergence).
#[derive(Debug, Clone, clap::Args)]
pub struct LyapunovArgs {
    #[command(flatten)]
    /// The point.
    pub point: PointArgs,
    /// Discarded time before the first interval, s (default: before the RMS window).
    #[arg(long, allow_negative_numbers = true)]
    pub transient: Option<f64>,
    /// Forcing periods per renormalisation interval.
    #[arg(long, allow_negative_numbers = true, default_value_t = 5.0)]
    pub periods: f64,
    /// Initial separation in scaled units (see the core docs: with rk4 use ≳ |ẇ|·dt / l_g).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1e-9)]
    pub d0: f64,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// All exponents (4 on the lumped bar, 2N + 2 on an N-mode bar) by QR of the variational
    /// flow with saltation matrices (exact solver, restitution law) over the window after the
    /// transient, instead of the largest by two trajectories (--periods and --d0 do not apply).
    #[arg(long)]
    pub spectrum: bool,
    /// A `[two_plane]` scenario: start from member K of its ensemble of starts [default: 0].
    #[arg(long, value_name = "K")]
    pub member: Option<usize>,
}

/// `vibrobar lyapunov`.
pub fn run_lyapunov(a: &LyapunovArgs) -> anyhow::Result<()> {
    let sc = a.point.system.scenario()?;
    if sc.two_plane.is_some() {
        return super::lyapunov_two_plane::run(a, &sc);
    }
    super::sweep_two_plane::refuse_member(a.member)?;
    if a.spectrum {
        return run_spectrum(a);
    }
    let sys = a.point.system()?;
    let solver = a.point.system.solver()?;
    let transient = transient_or_default(a.transient, &a.point.system)?;
    let periods = check_value("--periods", a.periods, |x| x > 0.0, "(0, ∞)")?;
    let d0 = check_value("--d0", a.d0, |x| x > 0.0, "(0, ∞)")?;
    let interval = periods * sys.forcing_period_s();
    let spec = spec(&a.point.system)?;
    let duration = spec.settings.duration_s;
    let intervals = ((duration - transient) / interval).floor() as usize;
    if intervals < 2 {
        bail!(
            "--duration {} s leaves {} intervals of {:.3e} s after the transient; at least 2 are needed (raise --duration or lower --periods)",
            vibrobar_core::error::Compact(duration),
            intervals,
            interval
        );
    }
    let mut p = LyapunovParams::periods(&sys, transient, periods, intervals);
    p.d0 = d0;
    p.blocks = p.blocks.min(intervals);
    let r = match &sys.bar {
        BarModel::Lumped(_) => max_lyapunov(&sys, &spec.base.init, solver.as_ref(), &p)?,
        // A beam: on its modal states (the whole 2N + 2-dimensional state).
        BarModel::Modal(model) => {
            let run = modal_run_by_name(solver.name(), &spec.settings)
                .with_context(|| format!("no modal run for solver {}", solver.name()))?;
            let init = ModalState::from_public(model, &spec.base.init)?;
            max_lyapunov_modal(&ModalSystem::from_system(&sys)?, &init, &*run, &p)?
        }
    };
    if a.json {
        let j = serde_json::json!({
            "exponent_per_s": r.exponent_per_s,
            "std_error_per_s": r.std_error_per_s,
            "intervals": intervals,
            "interval_s": interval,
            "blocks": r.block_means_per_s.len(),
            "clamped": r.clamped,
            "d0": d0,
            "parameters": a.point.to_params()?,
        });
        // A closed pipe (`| head`) is not an error worth a panic.
        let _ = writeln!(std::io::stdout(), "{}", serde_json::to_string_pretty(&j)?);
    } else {
        println!(
            "λ = {:.4} ± {:.4} 1/s ({} intervals of {:.3e} s, {} projections into the cavity)",
            r.exponent_per_s, r.std_error_per_s, intervals, interval, r.clamped
        );
    }
    Ok(())
}

/// `vibrobar lyapunov --spectrum`: every exponent by QR of the variational flow.
fn run_spectrum(a: &LyapunovArgs) -> anyhow::Result<()> {
    let sys = a.point.system()?;
    let solver = a.point.system.solver()?;
    if solver.name() != "exact" {
        bail!(
            "--spectrum needs --solver exact (the saltation matrices need the event times the exact solver resolves; got --solver {})",
            solver.name()
        );
    }
    let transient = transient_or_default(a.transient, &a.point.system)?;
    let spec = spec(&a.point.system)?;
    let window = spec.settings.duration_s - transient;
    let p = SpectrumParams {
        transient_s: transient,
        duration_s: window,
        blocks: 10,
        scales: None,
    };
    let r = match &sys.bar {
        BarModel::Lumped(_) => lyapunov_spectrum(&sys, &spec.base.init, solver.as_ref(), &p)?,
        // 2N + 2 exponents of the modal state (the modal variational flow).
        BarModel::Modal(model) => {
            let init = ModalState::from_public(model, &spec.base.init)?;
            vibrobar_core::analysis::lyapunov_spectrum::lyapunov_spectrum_modal(
                &ModalSystem::from_system(&sys)?,
                &init,
                &p,
            )?
        }
    };
    // The frictionless bar's phase-volume identity: Σλ = −C/M + 2 ln(e) × impacts per second
    // (−Σₙ cₙ/mₙ on a modal bar; under the hertz law only in the stiff limit: Σλ is the trace
    // plus the approach memory).
    let hertz = sys
        .damper
        .is_some_and(|d| d.contact.law == vibrobar_core::ContactLaw::Hertz);
    let identity =
        vibrobar_core::analysis::lyapunov_spectrum::volume_identity_per_s(&sys, r.impacts_per_s)?;
    if a.json {
        let ev = r.events;
        let j = serde_json::json!({
            "exponents_per_s": r.exponents_per_s,
            "std_error_per_s": r.std_error_per_s,
            "collapsed": r.collapsed,
            "sum_per_s": r.sum_per_s,
            "volume_identity_per_s": identity,
            "approach_memory_per_s": hertz.then_some(r.approach_memory_per_s),
            "impacts_per_s": r.impacts_per_s,
            "duration_s": r.duration_s,
            "blocks": p.blocks,
            "events": {
                "impacts": ev.impacts,
                "plastic_impacts": ev.plastic_impacts,
                "friction_switches": ev.friction_switches,
                "sticks": ev.sticks,
                "unsticks": ev.unsticks,
                "chatter_limits": ev.chatter_limits,
                "releases": ev.releases,
                "grazing": ev.grazing,
                "compliant_contacts": ev.compliant_contacts,
            },
            "parameters": a.point.to_params()?,
        });
        let _ = writeln!(std::io::stdout(), "{}", serde_json::to_string_pretty(&j)?);
    } else {
        let show = |v: &[Option<f64>], none: &str| -> String {
            v.iter()
                .map(|x| x.map_or(none.to_string(), |x| format!("{x:.4}")))
                .collect::<Vec<_>>()
                .join(", ")
        };
        println!(
            "λ = [{}] 1/s, ± [{}] ({} s window in {} blocks, {} impacts/s, {} directions collapsed by stick or wall contact)",
            show(&r.exponents_per_s, "−∞"),
            show(&r.std_error_per_s, "–"),
            vibrobar_core::error::Compact(r.duration_s),
            p.blocks,
            vibrobar_core::error::Compact(r.impacts_per_s),
            r.collapsed
        );
        match identity {
            Some(id) if hertz && r.collapsed == 0 => println!(
                "Σλ = {:.6} 1/s = trace average {:.6} + approach memory {:.6} (hertz law); the restitution identity −C/M + 2 ln(e) × contacts/s = {:.6} 1/s holds in the stiff limit",
                r.sum_per_s,
                r.sum_per_s - r.approach_memory_per_s,
                r.approach_memory_per_s,
                id
            ),
            Some(id) if r.collapsed == 0 => println!(
                "Σλ = {:.6} 1/s; frictionless identity −C/M (−Σcₙ/mₙ) + 2 ln(e) × impacts/s = {:.6} 1/s",
                r.sum_per_s, id
            ),
            _ => println!("Σλ (finite exponents) = {:.6} 1/s", r.sum_per_s),
        }
    }
    Ok(())
}

/// `vibrobar ensemble`: seeded random initial conditions at one point (or a ratio × gap grid).
#[derive(Debug, Clone, clap::Args)]
pub struct EnsembleArgs {
    #[command(flatten)]
    /// System and solver.
    pub system: SystemArgs,
    /// Ratio of a single point (or use --ratios).
    #[arg(long, allow_negative_numbers = true)]
    pub ratio: Option<f64>,
    /// Gap of a single point, mm (or use --gaps-mm).
    #[arg(long, allow_negative_numbers = true)]
    pub gap_mm: Option<f64>,
    /// Ratios START:STOP:STEP instead of --ratio.
    #[arg(long, allow_hyphen_values = true)]
    pub ratios: Option<String>,
    /// Gaps in mm START:STOP:STEP instead of --gap-mm.
    #[arg(long, allow_hyphen_values = true)]
    pub gaps_mm: Option<String>,
    /// Members per point [default: 16; a `[two_plane]` scenario: its `members`].
    #[arg(long)]
    pub members: Option<usize>,
    /// Seed of the ensemble [default: 1; a `[two_plane]` scenario: its `seed`].
    #[arg(long)]
    pub seed: Option<u64>,
    /// Half range of the initial bar displacement u, m (uniform in ±; a beam: at the response
    /// point, put into mode 1) [default: 5e-5].
    #[arg(long, allow_negative_numbers = true)]
    pub u_m: Option<f64>,
    /// Half range of the initial bar velocity, m/s (a beam: at the response point, into mode 1)
    /// [default: 0.2].
    #[arg(long, allow_negative_numbers = true)]
    pub du_m_s: Option<f64>,
    /// Half range of the initial relative velocity ẇ, m/s (the ball position is uniform over
    /// the whole cavity) [default: 0.2].
    #[arg(long, allow_negative_numbers = true)]
    pub dw_m_s: Option<f64>,
    /// Threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Compute only slice K of N of the grid points (round-robin); merge the slices with `merge`.
    #[arg(long)]
    pub shard: Option<String>,
    /// Continue an interrupted run from FILE.journal.
    #[arg(long)]
    pub resume: bool,
    /// Output CSV `ratio,gap_mm,members,mean_rms_m,std_rms_m,min_rms_m,max_rms_m,regimes`
    /// (`regimes` = `regime:count` joined by `;`).
    #[arg(long)]
    pub out: PathBuf,
}

pub(crate) fn axis_values(
    flag1: &str,
    one: Option<f64>,
    flag2: &str,
    many: &Option<String>,
    allowed: &str,
) -> anyhow::Result<Vec<f64>> {
    match (one, many) {
        (Some(x), None) => Ok(vec![check_value(flag1, x, |x| x > 0.0, allowed)?]),
        (None, Some(t)) => parse_range(flag2, t, |x| x > 0.0, allowed),
        _ => bail!("give exactly one of {flag1} and {flag2}"),
    }
}

/// `vibrobar ensemble`.
pub fn run_ensemble_cmd(a: &EnsembleArgs) -> anyhow::Result<()> {
    let sc = a.system.scenario()?;
    if sc.two_plane.is_some() {
        return super::ensemble_two_plane::ensemble(a, &sc);
    }
    let members = a.members.unwrap_or(16);
    let seed = a.seed.unwrap_or(1);
    let (u_m, du_m_s, dw_m_s) = (
        a.u_m.unwrap_or(5e-5),
        a.du_m_s.unwrap_or(0.2),
        a.dw_m_s.unwrap_or(0.2),
    );
    let ratios = axis_values("--ratio", a.ratio, "--ratios", &a.ratios, "(0, ∞)")?;
    let gaps_mm = axis_values("--gap-mm", a.gap_mm, "--gaps-mm", &a.gaps_mm, "(0, ∞) mm")?;
    check_value("--members", members as f64, |x| x >= 1.0, "[1, ∞)")?;
    check_value("--u-m", u_m, |x| x >= 0.0, "[0, ∞) m")?;
    check_value("--du-m-s", du_m_s, |x| x >= 0.0, "[0, ∞) m/s")?;
    check_value("--dw-m-s", dw_m_s, |x| x >= 0.0, "[0, ∞) m/s")?;
    let spec = spec(&a.system)?;
    let grid = Grid::new(vec![
        GridAxis {
            axis: Axis::FreqRatio,
            values: ratios,
        },
        GridAxis {
            axis: Axis::GapM,
            values: gaps_mm.iter().map(|g| g * 1e-3).collect(),
        },
    ])?;
    let points = grid.points();
    for p in &points {
        spec.damped_system(p)?.validate()?;
    }
    let params = EnsembleParams {
        seed,
        members,
        ranges: IcRanges {
            u_m: (-u_m, u_m),
            du_m_s: (-du_m_s, du_m_s),
            w_over_half_gap: (-1.0, 1.0),
            dw_m_s: (-dw_m_s, dw_m_s),
        },
    };
    params.validate()?;
    // The whole job's size (each batch is checked again by the core).
    vibrobar_core::limits::check(
        "ensemble runs (points × members)",
        points.len() as f64 * members as f64,
        0.0,
        vibrobar_core::limits::MAX_RUNS as f64,
        "fewer points or members",
    )?;
    let solver = a.system.solver()?;
    let shard = a
        .shard
        .as_deref()
        .map(shard::parse_shard)
        .transpose()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    // Before the journal is opened: a refused pool must not leave a header-only journal.
    if let Some(n) = a.threads {
        vibrobar_core::limits::check_count(
            "--threads",
            n,
            1,
            vibrobar_core::limits::MAX_THREADS,
            "",
        )?;
    }
    let file_params = EnsembleFileParams {
        system: a.system.to_params()?,
        ratios: grid.axes()[0].values.clone(),
        gaps_m: grid.axes()[1].values.clone(),
        members,
        seed,
        ic_half_ranges: IcHalfRanges {
            u_m,
            du_m_s,
            dw_m_s,
            w_over_half_gap: 1.0,
        },
    };
    let schema = ensemble_schema();
    let total = points.len();
    let indices = shard::shard_indices(total, shard);
    let meta = Metadata::new(
        "ensemble",
        &schema.header(),
        file_params.clone(),
        Some(GridInfo {
            total,
            shard,
            indices: shard.map(|_| indices.clone()),
        }),
    );
    let key = |i: usize| file_params.key(i).unwrap_or_default();
    let journal = super::open_journal(&a.out, &meta, &schema, &indices, &key, a.resume)?;
    let pending = journal.pending();
    let bar = Progress::new(
        "ensemble",
        indices.len() * members,
        journal.done_count() * members,
    );
    let progress = bar.callback();
    // A few points per batch (enough members to keep every thread busy), each batch's rows
    // journaled as soon as it is done, so a killed run loses at most one batch. A point's
    // statistics depend on its own members only (member i's initial state is seeded by i), so
    // the batching changes no digit.
    let threads = a.threads.unwrap_or_else(rayon::current_num_threads);
    let per_batch = (2 * threads).div_ceil(members).max(1);
    let mut done_runs = journal.done_count() * members;
    for batch in pending.chunks(per_batch) {
        let pts: Vec<GridPoint> = batch.iter().map(|&i| points[i].clone()).collect();
        let offset = done_runs;
        let stats = with_threads(a.threads, || {
            run_ensemble(&spec, solver.as_ref(), &pts, &params, &|d, t| {
                progress(offset + d, t)
            })
        })??;
        done_runs += pts.len() * members;
        for (i, s) in batch.iter().zip(&stats) {
            let row = EnsembleCsvRow {
                ratio: s.point.get(Axis::FreqRatio).unwrap_or(f64::NAN),
                gap_mm: s.point.get(Axis::GapM).unwrap_or(f64::NAN) * 1e3,
                members: s.members as u64,
                rms_m: [s.mean_rms_m, s.std_rms_m, s.min_rms_m, s.max_rms_m],
                regimes: regime_counts(&s.regimes),
            }
            .values();
            journal.append(*i, &schema.format(&row))?;
        }
    }
    bar.finish();
    let rows = journal.rows();
    journal.finish()?;
    meta.write_beside(&a.out)
        .with_context(|| format!("metadata beside {}", a.out.display()))?;
    for (_, r) in &rows {
        println!("{r}");
    }
    eprintln!("wrote {}", a.out.display());
    Ok(())
}
