//! `vibrobar orbit` (a periodic orbit by Newton's method on the stroboscopic map, its Floquet
//! multipliers and checks, as JSON) and `vibrobar continue` (pseudo-arclength continuation in one
//! parameter with bifurcation and grazing detection, as CSV and a figure). Lumped bar, exact
//! solver; the core is `vibrobar_core::analysis::orbit`.
use super::explore::PointArgs;
use super::{check_value, fmt_coord, SystemArgs};
use anyhow::{bail, Context};
use std::path::PathBuf;
use vibrobar_core::analysis::grid::Axis;
use vibrobar_core::analysis::orbit::continuation::{
    continue_orbit, param_of, ContinuationSettings, CONTINUATION_PARAMS, MAX_CONTINUATION_POINTS,
};
use vibrobar_core::analysis::orbit::{
    find_orbit, orbit_auto, starting_guess, ExactJacobian, FiniteDifference, MapJacobian,
    NewtonSettings, PeriodicOrbit, Start, MAX_ORBIT_PERIOD,
};
use vibrobar_core::params::FrictionModel;
use vibrobar_core::solver::{EventKind, Wall};
use vibrobar_core::System;
use vibrobar_io::csv::{continuation_schema, continuation_values, write_csv, write_json};
use vibrobar_io::params::{ContinuationParams, OrbitParams, PointParams};
use vibrobar_io::Metadata;
use vibrobar_report::figures::branch::BranchDot;

/// Where Newton starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum StartArg {
    /// The analytic symmetric orbit when one exists (the stable one if any), else a settled run.
    Auto,
    /// The analytic symmetric two-impact orbit number --branch (of the frictionless system).
    Symmetric,
    /// A run from the scenario's initial state over --settle seconds.
    Settled,
}

/// Which Jacobian of the map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum JacobianArg {
    /// The variational flow with saltation matrices (exact).
    Exact,
    /// Central differences of the exact solver.
    FiniteDifference,
}

impl JacobianArg {
    fn get(self) -> &'static dyn MapJacobian {
        match self {
            JacobianArg::Exact => &ExactJacobian,
            JacobianArg::FiniteDifference => &FD,
        }
    }
}

static FD: FiniteDifference = FiniteDifference { rel_step: 1e-6 };

/// How to find the starting orbit (shared by `orbit` and `continue`).
#[derive(Debug, Clone, clap::Args)]
pub struct OrbitStartArgs {
    /// Period of the orbit in forcing cycles, in [1, 64].
    #[arg(long, default_value_t = 1)]
    pub period: u64,
    /// Starting guess of Newton's method.
    #[arg(long, value_enum, default_value = "auto")]
    pub start: StartArg,
    /// Which analytic symmetric orbit (0, 1, … in the order of their impact phase) with
    /// --start symmetric.
    #[arg(long)]
    pub branch: Option<usize>,
    /// Settling time of --start settled (or auto without a symmetric orbit), s
    /// [default: the part of the run before the RMS window].
    #[arg(long, allow_negative_numbers = true)]
    pub settle: Option<f64>,
    /// Jacobian of the stroboscopic map.
    #[arg(long, value_enum, default_value = "exact")]
    pub jacobian: JacobianArg,
}

pub(crate) fn period_of(a: &OrbitStartArgs) -> anyhow::Result<u32> {
    check_value(
        "--period",
        a.period as f64,
        |k| (1.0..=MAX_ORBIT_PERIOD as f64).contains(&k),
        "[1, 64] forcing cycles (a whole number; longer orbits are better seen in a Poincaré section)",
    )?;
    Ok(a.period as u32)
}

pub(crate) fn exact_only(s: &SystemArgs) -> anyhow::Result<()> {
    let name = s.solver_name()?;
    if name != "exact" {
        bail!("--solver {name}: periodic orbits use the exact solver (the stroboscopic map and its Jacobian are exact); leave --solver out or give --solver exact");
    }
    Ok(())
}

/// The starting orbit of `sys`: Newton from the guess `a` asks for. Returns the orbit and the
/// start it used (for the metadata).
fn start_orbit(
    sys: &System,
    s: &SystemArgs,
    a: &OrbitStartArgs,
) -> anyhow::Result<(PeriodicOrbit, String, Option<usize>, Option<f64>)> {
    let periods = period_of(a)?;
    let sc = s.scenario()?;
    let settings = sc.settings();
    let settle = match a.settle {
        Some(t) => check_value("--settle", t, |x| x > 0.0, "(0, ∞) s")?,
        None => settings.duration_s * (1.0 - settings.rms_fraction),
    };
    let init = sc.base()?.init;
    let jac = a.jacobian.get();
    let newton = NewtonSettings::default();
    let settled = |settle: f64| -> anyhow::Result<PeriodicOrbit> {
        let (sec, x0) = starting_guess(
            sys,
            periods,
            &Start::Settled {
                init,
                settle_s: settle,
            },
        )?;
        Ok(find_orbit(&sec, &x0, jac, &newton)?)
    };
    let symmetric = |i: usize| -> anyhow::Result<PeriodicOrbit> {
        let (sec, x0) = starting_guess(sys, periods, &Start::Symmetric(i))?;
        Ok(find_orbit(&sec, &x0, jac, &newton)?)
    };
    match a.start {
        StartArg::Settled => Ok((settled(settle)?, "settled".into(), None, Some(settle))),
        StartArg::Symmetric => {
            let i = a.branch.unwrap_or(0);
            Ok((symmetric(i)?, "symmetric".into(), Some(i), None))
        }
        StartArg::Auto => {
            let (o, st) = orbit_auto(sys, periods, &init, settle, jac)?;
            Ok(match st {
                Start::Symmetric(i) => (o, "symmetric".into(), Some(i), None),
                Start::Settled { .. } => (o, "settled".into(), None, Some(settle)),
            })
        }
    }
}

/// `vibrobar orbit`: one periodic orbit.
#[derive(Debug, Clone, clap::Args)]
pub struct OrbitArgs {
    #[command(flatten)]
    /// The point.
    pub point: PointArgs,
    #[command(flatten)]
    /// The start.
    pub start: OrbitStartArgs,
    /// Output JSON: rms_m, impacts_per_period, multipliers ([re, im], largest first), stable,
    /// the state at the section, the event sequence, the physicality checks and the parameters;
    /// FILE.meta.json beside it.
    #[arg(long)]
    pub out: PathBuf,
}

pub(crate) fn event_json(e: &vibrobar_core::analysis::orbit::OrbitEvent) -> serde_json::Value {
    let wall = |w: Wall| if w == Wall::Plus { "plus" } else { "minus" };
    let (kind, wall, dw) = match e.kind {
        EventKind::Impact {
            wall: w, dw_m_s, ..
        } => ("impact", Some(wall(w)), Some(dw_m_s)),
        EventKind::FrictionSwitch => ("friction-switch", None, None),
        EventKind::Stick => ("stick", None, None),
        EventKind::Unstick => ("unstick", None, None),
        EventKind::ChatterLimit { wall: w, .. } => ("chatter-limit", Some(wall(w)), None),
        EventKind::ContactRelease { wall: w } => ("release", Some(wall(w)), None),
    };
    serde_json::json!({ "dt_s": e.dt_s, "kind": kind, "wall": wall, "dw_m_s": dw })
}

/// The JSON of an orbit (without parameters).
pub fn orbit_json(o: &PeriodicOrbit) -> anyhow::Result<serde_json::Value> {
    let s = &o.state;
    let ph = &o.physicality;
    let inf_null = |x: f64| x.is_finite().then_some(x);
    Ok(serde_json::json!({
        "rms_m": o.rms_m,
        "impacts_per_period": o.impacts_per_period,
        "impacts_per_cycle": o.impacts_per_cycle(),
        "period": o.section.periods,
        "multipliers": o.multipliers.iter().map(|l| [l.re, l.im]).collect::<Vec<_>>(),
        "max_abs_multiplier": o.max_abs_multiplier(),
        "stable": o.stable(),
        "state": {
            "t_s": s.t_s, "u_m": s.u_m, "du_m_s": s.du_m_s, "w_m": s.w_m(), "dw_m_s": s.dw_m_s(),
        },
        "section_phase_rad": (o.section.system.omega_rad_s() * o.section.t0_s)
            .rem_euclid(std::f64::consts::TAU),
        "event_sequence": o.sequence,
        "events": o.events.iter().map(event_json).collect::<Vec<_>>(),
        "physical": {
            "confined": ph.confined,
            "max_penetration_m": ph.max_penetration_m,
            "grazing_margin_m": inf_null(ph.grazing_margin_m),
            "min_impact_speed_m_s": inf_null(ph.min_impact_speed_m_s),
        },
        "symmetry_defect": o.symmetry_defect()?,
        "residual": o.residual,
        "newton_iterations": o.iterations,
        "jacobian": o.jacobian_source,
        "monodromy": (0..4).map(|i| (0..4).map(|j| o.jacobian[(i, j)]).collect::<Vec<_>>()).collect::<Vec<_>>(),
    }))
}

/// `vibrobar orbit`.
pub fn run_orbit(a: &OrbitArgs) -> anyhow::Result<()> {
    exact_only(&a.point.system)?;
    let sys = a.point.system()?;
    if sys.lumped_bar().is_none() {
        return super::orbit_modal::run_orbit_modal(a, &sys);
    }
    let (o, start, branch, settle) = start_orbit(&sys, &a.point.system, &a.start)?;
    let params = OrbitParams {
        point: a.point.to_params()?,
        period: o.section.periods,
        start,
        branch,
        settle_s: settle,
        jacobian: o.jacobian_source.into(),
    };
    let hertz = sys
        .damper
        .is_some_and(|d| d.contact.law == vibrobar_core::ContactLaw::Hertz);
    let mut j = orbit_json(&o)?;
    j["parameters"] = serde_json::to_value(&params)?;
    write_json(&a.out, &j).with_context(|| format!("writing {}", a.out.display()))?;
    Metadata::new("orbit", "", &params, None)
        .write_beside(&a.out)
        .with_context(|| format!("metadata beside {}", a.out.display()))?;
    let mults: Vec<String> = o
        .multipliers
        .iter()
        .map(|l| format!("{:.4}{:+.4}i", l.re, l.im))
        .collect();
    println!(
        "period-{} orbit ({}): RMS {:.4e} m, {} impacts per period, events {:?}, multipliers [{}] (max |λ| = {:.6}): {}; {}",
        o.section.periods,
        params.start,
        o.rms_m,
        o.impacts_per_period,
        o.sequence,
        mults.join(", "),
        o.max_abs_multiplier(),
        if o.stable() { "stable" } else { "unstable" },
        match (o.physicality.confined, hertz) {
            (true, false) => "|w| ≤ l_g holds".to_string(),
            (true, true) => format!(
                "hertz contacts: largest compression {:.3e} m",
                o.physicality.max_penetration_m
            ),
            (false, _) => "|w| ≤ l_g VIOLATED".to_string(),
        },
    );
    println!("wrote {}", a.out.display());
    Ok(())
}

/// `vibrobar continue`: follow an orbit in one parameter.
#[derive(Debug, Clone, clap::Args)]
pub struct ContinueArgs {
    #[command(flatten)]
    /// System and solver.
    pub system: SystemArgs,
    /// Frequency ratio Ω/ω_n (> 0), unless it is the followed parameter.
    #[arg(long, allow_negative_numbers = true)]
    pub ratio: Option<f64>,
    /// Total gap in mm (> 0), unless it is the followed parameter.
    #[arg(long, allow_negative_numbers = true)]
    pub gap_mm: Option<f64>,
    /// Followed parameter: ratio, gap-mm, friction-force-n or restitution.
    #[arg(long)]
    pub param: String,
    /// Start of the interval (the starting orbit is computed there), in the parameter's unit.
    #[arg(long, allow_negative_numbers = true)]
    pub from: f64,
    /// End of the interval.
    #[arg(long, allow_negative_numbers = true)]
    pub to: f64,
    #[command(flatten)]
    /// The starting orbit.
    pub start: OrbitStartArgs,
    /// Largest number of points on the main branch, in [2, 100000].
    #[arg(long, default_value_t = 2000)]
    pub max_points: usize,
    /// Do not follow the period-doubled branches from the period doublings found.
    #[arg(long)]
    pub no_switch: bool,
    /// Output CSV `param,rms_m,max_abs_multiplier,stable,impacts_per_period,period,event`;
    /// FILE.png/.svg (the branch: stable solid, unstable dashed, events marked) and
    /// FILE.meta.json beside it.
    #[arg(long)]
    pub out: PathBuf,
}

fn axis_of(name: &str) -> anyhow::Result<(Axis, f64)> {
    if let Some((_, a)) = CONTINUATION_PARAMS.iter().find(|(n, _)| *n == name) {
        let scale = if *a == Axis::GapM { 1e-3 } else { 1.0 };
        return Ok((*a, scale));
    }
    let names: Vec<&str> = CONTINUATION_PARAMS.iter().map(|(n, _)| *n).collect();
    let why = if name == "cavity-position-mm" {
        " (the cavity position is a parameter of the N-mode bar: give a scenario with a [beam])"
    } else {
        ""
    };
    bail!(
        "--param must be one of {}, got {name:?}{why}",
        names.join(", ")
    )
}

/// The fixed (ratio, gap in mm) of a continuation in `followed` (`None`: neither), after the
/// interval and point-count checks every `continue` makes.
pub(crate) fn continued_point(
    a: &ContinueArgs,
    followed: Option<Axis>,
) -> anyhow::Result<(f64, f64)> {
    check_value("--from", a.from, |_| true, "finite")?;
    check_value("--to", a.to, |_| true, "finite")?;
    if a.from == a.to {
        bail!(
            "--to = --from = {}: the interval is empty; give two different ends",
            fmt_coord(a.from)
        );
    }
    vibrobar_core::limits::check_count(
        "--max-points",
        a.max_points,
        2,
        MAX_CONTINUATION_POINTS,
        "",
    )?;
    let ratio = || a.ratio.context("--ratio is required unless --param ratio");
    let gap = || {
        a.gap_mm
            .context("--gap-mm is required unless --param gap-mm")
    };
    Ok(match followed {
        Some(Axis::FreqRatio) => {
            if a.ratio.is_some() {
                bail!("--ratio is the followed parameter: give its interval as --from, --to");
            }
            (a.from, gap()?)
        }
        Some(Axis::GapM) => {
            if a.gap_mm.is_some() {
                bail!("--gap-mm is the followed parameter: give its interval as --from, --to");
            }
            (ratio()?, a.from)
        }
        _ => (ratio()?, gap()?),
    })
}

/// `vibrobar continue`.
pub fn run_continue(a: &ContinueArgs) -> anyhow::Result<()> {
    exact_only(&a.system)?;
    if super::orbit_modal::is_modal(&a.system)? {
        return super::orbit_modal::run_continue_modal(a);
    }
    let (axis, scale) = axis_of(&a.param)?;
    let (ratio, gap_mm) = continued_point(a, Some(axis))?;
    let point = PointArgs {
        system: a.system.clone(),
        ratio,
        gap_mm,
    };
    let mut sys = point.system()?;
    let (from, to) = (a.from * scale, a.to * scale);
    for (flag, v) in [("--from", from), ("--to", to)] {
        let mut s = sys;
        axis.apply(&mut s, v)?;
        s.validate()
            .map_err(|e| anyhow::anyhow!("{flag} = {}: {e}", fmt_coord(v / scale)))?;
    }
    axis.apply(&mut sys, from)?;
    let (o, start, branch, settle) = start_orbit(&sys, &a.system, &a.start)?;
    let settings = ContinuationSettings {
        max_points: a.max_points,
        switch_branches: !a.no_switch,
        ..Default::default()
    };
    let t = std::time::Instant::now();
    let b = continue_orbit(&o, axis, from, to, a.start.jacobian.get(), &settings)?;
    let wall = t.elapsed().as_secs_f64();
    let _ = param_of;
    let params = continuation_params(
        a,
        OrbitParams {
            point: continued_point_params(a, ratio, gap_mm)?,
            period: o.section.periods,
            start,
            branch,
            settle_s: settle,
            jacobian: o.jacobian_source.into(),
        },
    );
    let inv = 1.0 / scale;
    let rows: Vec<_> = b
        .points
        .iter()
        .map(|p| continuation_values(p, inv))
        .collect();
    let marks: Vec<_> = b
        .points
        .iter()
        .map(|p| BranchMark {
            dot: BranchDot {
                x: p.param * inv,
                y: p.orbit.rms_m * 1e6,
                stable: p.orbit.stable(),
                branch: p.branch,
                event: p.event.map(|e| e.as_str()),
            },
            period: p.orbit.section.periods,
            max_abs_multiplier: p.orbit.max_abs_multiplier(),
        })
        .collect();
    let title = format!(
        "Periodic orbits in {}{}",
        a.param,
        match axis {
            Axis::FreqRatio => format!(", gap = {} mm", fmt_coord(gap_mm)),
            Axis::GapM => format!(", r = {}", fmt_coord(ratio)),
            _ => format!(", r = {}, gap = {} mm", fmt_coord(ratio), fmt_coord(gap_mm)),
        }
    );
    let summary = format!(
        "{} points in {:.3} s; starting orbit: {} ({} impacts per period, {})",
        b.points.len(),
        wall,
        params.orbit.start,
        o.impacts_per_period,
        if o.stable() { "stable" } else { "unstable" }
    );
    let ends: Vec<String> = b
        .stop_reasons
        .iter()
        .enumerate()
        .map(|(i, r)| format!("branch {i} ended: {r}"))
        .collect();
    write_branch(a, &params, &rows, &marks, &title, &summary, &ends)
}

/// The continued point of `continue` (its system at `ratio`, `gap_mm`) for the metadata.
pub(crate) fn continued_point_params(
    a: &ContinueArgs,
    ratio: f64,
    gap_mm: f64,
) -> anyhow::Result<PointParams> {
    Ok(PointParams {
        system: a.system.to_params()?,
        ratio,
        gap_m: gap_mm * 1e-3,
    })
}

/// The metadata of `continue` from the starting `orbit`, shared by the lumped and the N-mode
/// bar so both record the same fields.
pub(crate) fn continuation_params(a: &ContinueArgs, orbit: OrbitParams) -> ContinuationParams {
    ContinuationParams {
        orbit,
        param: a.param.clone(),
        from: a.from,
        to: a.to,
        max_points: a.max_points,
        switch_branches: !a.no_switch,
    }
}

/// One point of a followed branch as `continue` draws and reports it.
pub(crate) struct BranchMark {
    pub dot: BranchDot,
    pub period: u32,
    pub max_abs_multiplier: f64,
}

/// The files of `continue` (CSV, metadata, figure) and its report, shared by the lumped and the
/// N-mode bar: `rows` are the CSV rows of `continuation_schema`.
pub(crate) fn write_branch(
    a: &ContinueArgs,
    params: &ContinuationParams,
    rows: &[Vec<vibrobar_io::csv::Value>],
    marks: &[BranchMark],
    title: &str,
    summary: &str,
    ends: &[String],
) -> anyhow::Result<()> {
    let schema = continuation_schema();
    write_csv(&a.out, &schema, rows).with_context(|| format!("writing {}", a.out.display()))?;
    Metadata::new("continuation", &schema.header(), params, None)
        .write_beside(&a.out)
        .with_context(|| format!("metadata beside {}", a.out.display()))?;
    let dots: Vec<BranchDot> = marks.iter().map(|m| m.dot).collect();
    let files = vibrobar_report::figures::branch::branch_files(
        &a.out.with_extension(""),
        &vibrobar_report::figures::branch::BranchFigure {
            title,
            x_label: &a.param,
            points: &dots,
        },
    )?;
    println!("{summary}");
    for m in marks.iter().filter(|m| m.dot.event.is_some()) {
        println!(
            "  {} at {} = {} (period {}, max |λ| = {:.6})",
            m.dot.event.unwrap_or(""),
            a.param,
            fmt_coord(m.dot.x),
            m.period,
            m.max_abs_multiplier
        );
    }
    for e in ends {
        println!("  {e}");
    }
    println!("wrote {}", a.out.display());
    for f in files {
        println!("wrote {}", f.display());
    }
    Ok(())
}

/// Issue #11 §6 in `vibrobar bench`: the median wall time of a 200-point branch (the symmetric
/// orbit of the paper's bar at r = 1 followed in the gap from 0.06 mm, exact Jacobian, one
/// thread) and of one Newton solve, over 5 repetitions.
pub fn bench_row() -> anyhow::Result<()> {
    let sys = System::paper_damped(0.06e-3, FrictionModel::None, 1.0);
    let (sec, x0) = starting_guess(&sys, 1, &Start::Symmetric(0))?;
    let newton = NewtonSettings::default();
    let settings = ContinuationSettings {
        max_points: 200,
        switch_branches: false,
        ..Default::default()
    };
    let (mut tn, mut tc) = (Vec::new(), Vec::new());
    let mut n = 0;
    for _ in 0..5 {
        let t = std::time::Instant::now();
        let o = find_orbit(&sec, &x0, &ExactJacobian, &newton)?;
        tn.push(t.elapsed().as_secs_f64());
        let t = std::time::Instant::now();
        let b = continue_orbit(&o, Axis::GapM, 0.06e-3, 0.2e-3, &ExactJacobian, &settings)?;
        tc.push(t.elapsed().as_secs_f64());
        n = b.points.len();
    }
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    println!(
        "  exact  periodic orbits (r = 1, frictionless): Newton from the analytic orbit median {:.2} ms; a {n}-point branch in the gap from 0.06 mm median {:.1} ms over 5 (issue #11 target: 200 points < 2 s on one core)",
        med(&mut tn) * 1e3,
        med(&mut tc) * 1e3
    );
    Ok(())
}
