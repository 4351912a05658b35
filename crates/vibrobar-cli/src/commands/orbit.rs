//! `vibrobar orbit` (a periodic orbit by Newton's method on the stroboscopic map, its Floquet
//! multipliers and checks, as JSON) and `vibrobar continue` (pseudo-arclength continuation in one
//! parameter with bifurcation and grazing detection, as CSV and a figure), on the lumped bar and
//! on an N-mode bar (`[beam]`, `[[modes]]`), exact solver; the core is
//! `vibrobar_core::analysis::orbit`. One code path writes and reports an orbit or a branch of
//! either bar ([`Bar`] holds what differs: the state's keys, the bar's name); the output files
//! have the same keys and columns, the state of an N-mode bar is modal.
use super::explore::PointArgs;
use super::{check_value, fmt_coord, SystemArgs};
use anyhow::{bail, Context};
use std::path::PathBuf;
use vibrobar_core::analysis::grid::Axis;
use vibrobar_core::analysis::orbit::continuation::Branch;
use vibrobar_core::analysis::orbit::continuation::{
    continue_orbit, ContinuationSettings, CONTINUATION_PARAMS, MAX_CONTINUATION_POINTS,
};
use vibrobar_core::analysis::orbit::modal::{
    continue_modal_orbit, modal_orbit_settled_at, ModalFamily, ModalParam, ModalPeriodicOrbit,
    ModalSection,
};
use vibrobar_core::analysis::orbit::{
    find_orbit, orbit_auto, starting_guess, ExactJacobian, FiniteDifference, Flow, MapJacobian,
    NewtonSettings, Orbit, PeriodicOrbit, Section, Start, MAX_ORBIT_PERIOD,
};
use vibrobar_core::params::FrictionModel;
use vibrobar_core::solver::{EventKind, Wall};
use vibrobar_core::structure::{ModalState, ModalSystem, Point};
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
    pub(crate) fn get(self) -> &'static dyn MapJacobian {
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
    /// FILE.meta.json beside it. A `[two_plane]` scenario: the orbit's multipliers and RMS along
    /// the force, per direction and in total, and each plane's orbit under `planes`.
    #[arg(long)]
    pub out: PathBuf,
    /// A `[two_plane]` scenario: settle from member K of its ensemble of starts [default: 0].
    #[arg(long, value_name = "K")]
    pub member: Option<usize>,
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

/// What the orbit commands write and print differently for the lumped and the N-mode bar.
pub trait Bar: Flow {
    /// The label of the multipliers in the report line.
    const MULTIPLIERS: &'static str;
    /// The `state` object of the JSON.
    fn state_json(o: &Orbit<Self>) -> serde_json::Value;
    /// The keys only this bar's orbits have.
    fn bar_json(o: &Orbit<Self>) -> anyhow::Result<serde_json::Value>;
    /// What the report line says of the bar after `period-k orbit` (empty on the lumped bar).
    fn bar_name(o: &Orbit<Self>) -> String;
}

impl Bar for Section {
    const MULTIPLIERS: &'static str = "multipliers";

    fn state_json(o: &PeriodicOrbit) -> serde_json::Value {
        let s = &o.state;
        serde_json::json!({
            "t_s": s.t_s, "u_m": s.u_m, "du_m_s": s.du_m_s, "w_m": s.w_m(), "dw_m_s": s.dw_m_s(),
        })
    }

    fn bar_json(o: &PeriodicOrbit) -> anyhow::Result<serde_json::Value> {
        Ok(serde_json::json!({ "symmetry_defect": o.symmetry_defect()? }))
    }

    fn bar_name(_: &PeriodicOrbit) -> String {
        String::new()
    }
}

impl Bar for ModalSection {
    const MULTIPLIERS: &'static str = "largest multipliers";

    fn state_json(o: &ModalPeriodicOrbit) -> serde_json::Value {
        let s = &o.state;
        let sys = &o.section.system;
        let n = sys.n_modes();
        serde_json::json!({
            "t_s": s.t_s,
            "q_m": &s.q_m[..n],
            "dq_m_s": &s.dq_m_s[..n],
            "u_m": s.u_at(&sys.model, Point::Response),
            "du_m_s": s.du_at(&sys.model, Point::Response),
            "w_m": s.w_m(&sys.model),
            "dw_m_s": s.dw_m_s(&sys.model),
        })
    }

    fn bar_json(o: &ModalPeriodicOrbit) -> anyhow::Result<serde_json::Value> {
        Ok(serde_json::json!({
            "modes": o.section.n_modes(),
            "monodromy_coordinates": "(q_1..q_N, dq_1..dq_N, w, dw)",
        }))
    }

    fn bar_name(o: &ModalPeriodicOrbit) -> String {
        format!(" of the {}-mode bar", o.section.n_modes())
    }
}

/// The JSON of an orbit of either bar (without parameters).
pub fn orbit_json<F: Bar>(o: &Orbit<F>) -> anyhow::Result<serde_json::Value> {
    let ph = &o.physicality;
    let inf_null = |x: f64| x.is_finite().then_some(x);
    let d = o.section.dim();
    let mut j = serde_json::json!({
        "rms_m": o.rms_m,
        "impacts_per_period": o.impacts_per_period,
        "impacts_per_cycle": o.impacts_per_cycle(),
        "period": o.section.periods(),
        "multipliers": o.multipliers.iter().map(|l| [l.re, l.im]).collect::<Vec<_>>(),
        "max_abs_multiplier": o.max_abs_multiplier(),
        "stable": o.stable(),
        "state": F::state_json(o),
        "section_phase_rad": (o.section.omega_rad_s() * o.section.t0_s())
            .rem_euclid(std::f64::consts::TAU),
        "event_sequence": o.sequence,
        "events": o.events.iter().map(event_json).collect::<Vec<_>>(),
        "physical": {
            "confined": ph.confined,
            "max_penetration_m": ph.max_penetration_m,
            "grazing_margin_m": inf_null(ph.grazing_margin_m),
            "min_impact_speed_m_s": inf_null(ph.min_impact_speed_m_s),
        },
        "residual": o.residual,
        "newton_iterations": o.iterations,
        "jacobian": o.jacobian_source,
        "monodromy": (0..d).map(|i| (0..d).map(|j| o.jacobian[(i, j)]).collect::<Vec<_>>()).collect::<Vec<_>>(),
    });
    if let (Some(m), serde_json::Value::Object(extra)) = (j.as_object_mut(), F::bar_json(o)?) {
        m.extend(extra);
    }
    Ok(j)
}

/// `vibrobar orbit`.
pub fn run_orbit(a: &OrbitArgs) -> anyhow::Result<()> {
    let sc = a.point.system.scenario()?;
    if sc.two_plane.is_some() {
        return super::orbit_two_plane::run(a, &sc);
    }
    super::sweep_two_plane::refuse_member(a.member)?;
    exact_only(&a.point.system)?;
    let sys = a.point.system()?;
    if sys.lumped_bar().is_none() {
        let msys = ModalSystem::from_system(&sys)?;
        let (o, settle) = start_modal(&msys, &a.point.system, &a.start)?;
        return report_orbit(a, &o, "settled".into(), None, Some(settle));
    }
    let (o, start, branch, settle) = start_orbit(&sys, &a.point.system, &a.start)?;
    report_orbit(a, &o, start, branch, settle)
}

/// The files and the report line of `vibrobar orbit`, either bar.
fn report_orbit<F: Bar>(
    a: &OrbitArgs,
    o: &Orbit<F>,
    start: String,
    branch: Option<usize>,
    settle: Option<f64>,
) -> anyhow::Result<()> {
    let params = OrbitParams {
        point: a.point.to_params()?,
        period: o.section.periods(),
        start,
        branch,
        settle_s: settle,
        jacobian: o.jacobian_source.into(),
    };
    let mut j = orbit_json(o)?;
    j["parameters"] = serde_json::to_value(&params)?;
    write_json(&a.out, &j).with_context(|| format!("writing {}", a.out.display()))?;
    Metadata::new("orbit", "", &params, None)
        .write_beside(&a.out)
        .with_context(|| format!("metadata beside {}", a.out.display()))?;
    let mults: Vec<String> = o
        .multipliers
        .iter()
        .take(4)
        .map(|l| format!("{:.4}{:+.4}i", l.re, l.im))
        .collect();
    println!(
        "period-{} orbit{} ({}): RMS {:.4e} m, {} impacts per period, events {:?}, {} [{}] (max |λ| = {:.6}): {}; {}",
        o.section.periods(),
        F::bar_name(o),
        params.start,
        o.rms_m,
        o.impacts_per_period,
        o.sequence,
        F::MULTIPLIERS,
        mults.join(", "),
        o.max_abs_multiplier(),
        if o.stable() { "stable" } else { "unstable" },
        match (o.physicality.confined, o.section.compliant()) {
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
    /// FILE.meta.json beside it. A `[two_plane]` scenario: a `plane` column first
    /// (`along_hole`, `across_hole`) and one figure per plane, FILE.along_hole.png and
    /// FILE.across_hole.png.
    #[arg(long)]
    pub out: PathBuf,
    /// A `[two_plane]` scenario: settle from member K of its ensemble of starts [default: 0].
    #[arg(long, value_name = "K")]
    pub member: Option<usize>,
}

pub(crate) fn axis_of(name: &str) -> anyhow::Result<(Axis, f64)> {
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
    let sc = a.system.scenario()?;
    if sc.two_plane.is_some() {
        return super::orbit_two_plane::run_continue(a, &sc);
    }
    super::sweep_two_plane::refuse_member(a.member)?;
    exact_only(&a.system)?;
    if is_modal(&a.system)? {
        return run_continue_modal(a);
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
    write_branch(a, &params, &b, scale, &title, &summary)
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

/// The files of `continue` (CSV, metadata, figure) and its report for a branch of either bar;
/// `scale` is the parameter's SI value per file unit (1e-3 for `gap-mm`).
fn write_branch<F: Flow>(
    a: &ContinueArgs,
    params: &ContinuationParams,
    b: &Branch<F>,
    scale: f64,
    title: &str,
    summary: &str,
) -> anyhow::Result<()> {
    let inv = 1.0 / scale;
    let rows: Vec<_> = b
        .points
        .iter()
        .map(|p| continuation_values(p, inv))
        .collect();
    let dots: Vec<BranchDot> = b
        .points
        .iter()
        .map(|p| BranchDot {
            x: p.param * inv,
            y: p.orbit.rms_m * 1e6,
            stable: p.orbit.stable(),
            branch: p.branch,
            event: p.event.map(|e| e.as_str()),
        })
        .collect();
    let schema = continuation_schema();
    write_csv(&a.out, &schema, &rows).with_context(|| format!("writing {}", a.out.display()))?;
    Metadata::new("continuation", &schema.header(), params, None)
        .write_beside(&a.out)
        .with_context(|| format!("metadata beside {}", a.out.display()))?;
    let files = vibrobar_report::figures::branch::branch_files(
        &a.out.with_extension(""),
        &vibrobar_report::figures::branch::BranchFigure {
            title,
            x_label: &a.param,
            points: &dots,
        },
    )?;
    println!("{summary}");
    for (p, dot) in b.points.iter().zip(&dots) {
        if let Some(e) = dot.event {
            println!(
                "  {e} at {} = {} (period {}, max |λ| = {:.6})",
                a.param,
                fmt_coord(dot.x),
                p.orbit.section.periods(),
                p.orbit.max_abs_multiplier()
            );
        }
    }
    for (i, r) in b.stop_reasons.iter().enumerate() {
        println!("  branch {i} ended: {r}");
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
    let (tn, tc, _, n) = time_orbit_and_branch(
        || find_orbit(&sec, &x0, &ExactJacobian, &newton),
        |o| continue_orbit(o, Axis::GapM, 0.06e-3, 0.2e-3, &ExactJacobian, &settings),
    )?;
    println!(
        "  exact  periodic orbits (r = 1, frictionless): Newton from the analytic orbit median {:.2} ms; a {n}-point branch in the gap from 0.06 mm median {:.1} ms over 5 (target: 200 points < 2 s on one core)",
        tn * 1e3,
        tc * 1e3
    );
    Ok(())
}

/// The median wall times of `newton` (one orbit) and of `branch` (a branch from it) over 5
/// repetitions, the orbit's Newton iterations and the branch's points: the bench rows of both
/// bars.
fn time_orbit_and_branch<F: Flow>(
    newton: impl Fn() -> Result<Orbit<F>, vibrobar_core::SimError>,
    branch: impl Fn(&Orbit<F>) -> Result<Branch<F>, vibrobar_core::SimError>,
) -> anyhow::Result<(f64, f64, usize, usize)> {
    let (mut tn, mut tc) = (Vec::new(), Vec::new());
    let (mut iters, mut n) = (0, 0);
    for _ in 0..5 {
        let t = std::time::Instant::now();
        let o = newton()?;
        tn.push(t.elapsed().as_secs_f64());
        iters = o.iterations;
        let t = std::time::Instant::now();
        n = branch(&o)?.points.len();
        tc.push(t.elapsed().as_secs_f64());
    }
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    Ok((med(&mut tn), med(&mut tc), iters, n))
}

/// The scenario describes an N-mode bar.
fn is_modal(s: &SystemArgs) -> anyhow::Result<bool> {
    let sc = s.scenario()?;
    Ok(sc.beam.is_some() || sc.modes.is_some())
}

/// The start of a modal orbit: a settled run (`auto` is `settled` here: the analytic symmetric
/// orbit is the lumped bar's). Returns the orbit and the settling time used.
fn start_modal(
    sys: &ModalSystem,
    s: &SystemArgs,
    a: &OrbitStartArgs,
) -> anyhow::Result<(ModalPeriodicOrbit, f64)> {
    let periods = period_of(a)?;
    if a.start == StartArg::Symmetric {
        bail!("--start symmetric: the analytic symmetric orbit is the lumped bar's; on an N-mode bar use --start settled (or auto)");
    }
    if a.branch.is_some() {
        bail!("--branch selects an analytic symmetric orbit, which only the lumped bar has; leave it out on an N-mode bar");
    }
    if a.jacobian != JacobianArg::Exact {
        bail!("--jacobian finite-difference: orbits of an N-mode bar use the exact Jacobian (the modal variational flow); leave --jacobian out");
    }
    let sc = s.scenario()?;
    let settings = sc.settings();
    let settle = match a.settle {
        Some(t) => check_value("--settle", t, |x| x > 0.0, "(0, ∞) s")?,
        None => settings.duration_s * (1.0 - settings.rms_fraction),
    };
    let init = ModalState::from_public(&sys.model, &sc.base()?.init)?;
    Ok(modal_orbit_settled_at(sys, periods, &init, settle)?)
}

/// The followed parameter of a modal branch and its file unit (1e-3: mm).
fn modal_param_of(name: &str) -> anyhow::Result<(ModalParam, f64)> {
    if name == "cavity-position-mm" {
        return Ok((ModalParam::CavityPositionM, 1e-3));
    }
    if let Some((_, a)) = CONTINUATION_PARAMS.iter().find(|(n, _)| *n == name) {
        let scale = if *a == Axis::GapM { 1e-3 } else { 1.0 };
        return Ok((ModalParam::Axis(*a), scale));
    }
    let names: Vec<&str> = CONTINUATION_PARAMS.iter().map(|(n, _)| *n).collect();
    bail!(
        "--param must be one of {}, cavity-position-mm (a [beam]), got {name:?}",
        names.join(", ")
    )
}

/// `vibrobar continue` on an N-mode bar.
fn run_continue_modal(a: &ContinueArgs) -> anyhow::Result<()> {
    let (param, scale) = modal_param_of(&a.param)?;
    let followed = match param {
        ModalParam::Axis(ax) => Some(ax),
        ModalParam::CavityPositionM => None,
    };
    let (ratio, gap_mm) = continued_point(a, followed)?;
    let point = super::explore::PointArgs {
        system: a.system.clone(),
        ratio,
        gap_mm,
    };
    let sys = point.system()?;
    let sc = a.system.scenario()?;
    let beam = sc.beam.clone().filter(|_| sc.modes.is_none());
    if param == ModalParam::CavityPositionM && beam.is_none() {
        bail!("--param cavity-position-mm needs a scenario with a [beam] (measured [[modes]] give the shapes at one cavity only)");
    }
    let base = ModalSystem::from_system(&sys)?;
    let mut fam = ModalFamily { base, beam, param };
    let (from, to) = (a.from * scale, a.to * scale);
    for (flag, v) in [("--from", from), ("--to", to)] {
        fam.system_at(v)
            .map_err(|e| anyhow::anyhow!("{flag} = {}: {e}", fmt_coord(v / scale)))?;
    }
    fam.base = fam.system_at(from)?;
    if let (ModalParam::CavityPositionM, Some(b)) = (param, fam.beam.as_mut()) {
        b.cavity_position_m = from;
    }
    let (o, settle) = start_modal(&fam.base, &a.system, &a.start)?;
    let settings = ContinuationSettings {
        max_points: a.max_points,
        switch_branches: !a.no_switch,
        ..Default::default()
    };
    let t = std::time::Instant::now();
    let b = continue_modal_orbit(&o, &fam, from, to, &settings)?;
    let wall = t.elapsed().as_secs_f64();
    let params = continuation_params(
        a,
        OrbitParams {
            point: continued_point_params(a, ratio, gap_mm)?,
            period: o.section.periods,
            start: "settled".into(),
            branch: None,
            settle_s: Some(settle),
            jacobian: "variational".into(),
        },
    );
    let title = format!(
        "Periodic orbits of the {}-mode bar in {}, r = {}, gap = {} mm",
        o.section.n_modes(),
        a.param,
        fmt_coord(ratio),
        fmt_coord(gap_mm)
    );
    let summary = format!(
        "{} points in {:.3} s ({}-mode bar); starting orbit: settled ({} impacts per period, {})",
        b.points.len(),
        wall,
        o.section.n_modes(),
        o.impacts_per_period,
        if o.stable() { "stable" } else { "unstable" }
    );
    write_branch(a, &params, &b, scale, &title, &summary)
}

/// `vibrobar bench`, the N-mode bar: the median wall time of one Newton solve of the 4-mode paper beam's
/// two-impact orbit (0.1 mm, r = 1, frictionless, exact modal Jacobian, from the same settled
/// start) and of a 50-point branch of it in the cavity position, over 5 repetitions.
pub fn bench_row_modal() -> anyhow::Result<()> {
    use vibrobar_core::analysis::orbit::modal::{find_modal_orbit, modal_starting_guess};
    use vibrobar_core::params::{Damper, Forcing, FrictionModel, STANDARD_GRAVITY_M_S2};
    use vibrobar_core::structure::{Beam, Structure};
    let beam = Beam {
        modes: Some(4),
        ..Beam::default()
    };
    let sys = ModalSystem {
        model: Structure::Beam(beam.clone()).modal_model()?,
        damper: Some(Damper::paper(0.1e-3, FrictionModel::None)),
        forcing: Forcing::paper(1.0),
        gravity_m_s2: STANDARD_GRAVITY_M_S2,
    };
    // (The settling time Newton converges from, 0.5 s or a few periods more: the run is
    // chaotic.)
    let (_, settle) = modal_orbit_settled_at(&sys, 1, &ModalState::REST, 0.5)?;
    let (sec, x0) = modal_starting_guess(&sys, 1, &ModalState::REST, settle)?;
    let fam = ModalFamily {
        base: sys.clone(),
        beam: Some(beam.clone()),
        param: ModalParam::CavityPositionM,
    };
    let settings = ContinuationSettings {
        max_points: 50,
        switch_branches: false,
        ..Default::default()
    };
    let p0 = beam.cavity_position_m;
    let (tn, tc, iters, n) = time_orbit_and_branch(
        || find_modal_orbit(&sec, &x0, &NewtonSettings::default()),
        |o| continue_modal_orbit(o, &fam, p0, p0 - 20e-3, &settings),
    )?;
    println!(
        "  exact  periodic orbit of the 4-mode beam (r = 1, 0.1 mm, frictionless): Newton ({iters} iterations from a settled run) median {:.2} ms; a {n}-point branch in the cavity position median {:.1} ms over 5",
        tn * 1e3,
        tc * 1e3
    );
    Ok(())
}
