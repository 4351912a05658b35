//! The bar that bends in two planes from Python: one design point from keywords
//! (`vibrobar.two_plane`), one run of a `[two_plane]` scenario (`vibrobar.two_plane_run`), and
//! the tables, sections and exponents that `sweep`, `ensemble`, `map`, `poincare` and
//! `lyapunov` give for such a scenario, computed as the command line computes them.

use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use vibrobar_core::analysis::lyapunov::LyapunovParams;
use vibrobar_core::analysis::two_plane::{
    design_points, max_lyapunov_two_plane, poincare_two_plane, TwoPlaneMethod,
};
use vibrobar_core::params::two_plane::{direction, TwoPlaneSystem};
use vibrobar_core::solver::two_plane_rk4::TwoPlaneStart;
use vibrobar_core::{limits, Frequency};
use vibrobar_io::csv::{self as iocsv, Value};
use vibrobar_io::two_plane_csv::{self, MapCell};
use vibrobar_scenario::{Scenario, TwoPlaneAxes};

use super::{
    anyhow_input, check_threads, columns, detached, input_error, run_error, runner, transient,
    values, PyScenario,
};

/// Core field names (`hole.diameter_m`) as the keywords of `vibrobar.two_plane`
/// (`hole_diameter_m`).
fn two_plane_keywords(msg: String) -> String {
    ["bar.", "ball.", "hole.", "forcing.", "gravity."]
        .iter()
        .fold(msg, |m, p| m.replace(p, &p.replace('.', "_")))
}

/// The bar that bends in two planes at one design point: a seeded ensemble of starts on the
/// two-plane reference solver, the one-plane model from the same starts, and the bar without
/// its ball. Keywords and meaning: `vibrobar.two_plane`.
#[pyfunction]
#[pyo3(signature = (
    bar_mass_kg, bar_stiffness_n_per_m, bar_damping_ratio, bar_principal_axis_deg,
    ball_mass_kg, ball_radius_m, ball_restitution, ball_friction_static, ball_friction_kinetic,
    ball_rolling_friction_m, hole_angle_deg, hole_axial_gap_m, hole_diameter_m,
    forcing_amplitude_n, forcing_frequency_ratio, forcing_angle_deg, gravity_m_s2,
    gravity_angle_deg, members, seed, start_speed_m_s, duration_s, dt_s, rms_fraction, solver,
    threads, progress
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn two_plane<'py>(
    py: Python<'py>,
    bar_mass_kg: f64,
    bar_stiffness_n_per_m: (f64, f64),
    bar_damping_ratio: (f64, f64),
    bar_principal_axis_deg: f64,
    ball_mass_kg: f64,
    ball_radius_m: f64,
    ball_restitution: f64,
    ball_friction_static: f64,
    ball_friction_kinetic: f64,
    ball_rolling_friction_m: f64,
    hole_angle_deg: f64,
    hole_axial_gap_m: f64,
    hole_diameter_m: f64,
    forcing_amplitude_n: f64,
    forcing_frequency_ratio: f64,
    forcing_angle_deg: f64,
    gravity_m_s2: f64,
    gravity_angle_deg: f64,
    members: usize,
    seed: u64,
    start_speed_m_s: f64,
    duration_s: f64,
    dt_s: f64,
    rms_fraction: f64,
    solver: &str,
    threads: Option<usize>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    use vibrobar_core::analysis::two_plane::{
        design_points, starts, TwoPlaneEnsemble, TwoPlaneMethod,
    };
    use vibrobar_core::params::two_plane::{
        Gravity, Hole, PlanarBall, PlanarBar, PlanarForcing, TwoPlaneSystem,
    };
    use vibrobar_core::solver::two_plane_rk4::TwoPlaneStart;
    use vibrobar_core::RunSettings;
    check_threads(threads)?;
    let sys = TwoPlaneSystem {
        bar: PlanarBar {
            mass_kg: bar_mass_kg,
            stiffness_n_per_m: [bar_stiffness_n_per_m.0, bar_stiffness_n_per_m.1],
            damping_ratio: [bar_damping_ratio.0, bar_damping_ratio.1],
            principal_axis_deg: bar_principal_axis_deg,
        }
        .into(),
        ball: PlanarBall {
            mass_kg: ball_mass_kg,
            radius_m: ball_radius_m,
            restitution: ball_restitution,
            friction_static: ball_friction_static,
            friction_kinetic: ball_friction_kinetic,
            rolling_friction_m: ball_rolling_friction_m,
        },
        hole: Hole {
            angle_deg: hole_angle_deg,
            axial_gap_m: hole_axial_gap_m,
            diameter_m: hole_diameter_m,
        },
        forcing: PlanarForcing {
            amplitude_n: forcing_amplitude_n,
            frequency: Frequency::Ratio(forcing_frequency_ratio),
            angle_deg: forcing_angle_deg,
        },
        gravity: Gravity {
            m_s2: gravity_m_s2,
            angle_deg: gravity_angle_deg,
        },
        bar_diameter_m: None,
    };
    sys.validate()
        .map_err(|e| input_error(two_plane_keywords(e.to_string())))?;
    let settings = RunSettings {
        duration_s,
        dt_s,
        rms_fraction,
    };
    settings.validate().map_err(input_error)?;
    let ens = TwoPlaneEnsemble {
        members,
        seed,
        start_speed_m_s,
    };
    // The ensemble's fields, checked before anything runs.
    starts(&sys, &ens).map_err(|e| input_error(e.to_string().replace(" (--members)", "")))?;
    let method = match solver {
        "auto" => TwoPlaneMethod::Auto { dt_s },
        "exact" => TwoPlaneMethod::Exact,
        "reference" => TwoPlaneMethod::Reference { dt_s },
        _ => {
            return Err(input_error(format!(
                "solver = {solver:?} is not one of the allowed values: auto, exact, reference"
            )))
        }
    };
    let point = detached(py, progress, |ctl| {
        let cb = |d: usize, t: usize| ctl.progress(d, t);
        design_points(
            std::slice::from_ref(&sys),
            &ens,
            method,
            &settings,
            &runner(ctl, &cb, threads),
        )
        .map_err(|e| run_error(two_plane_keywords(e.to_string())))
    })?
    .pop()
    .expect("one design point");
    let (starts, two) = (&point.starts, &point.members);
    let d = PyDict::new(py);
    let col = |f: &dyn Fn(&vibrobar_core::solver::two_plane_rk4::TwoPlaneSummary) -> f64| {
        two.iter().map(f).collect::<Vec<f64>>()
    };
    let start_col = |f: &dyn Fn(&TwoPlaneStart) -> f64| starts.iter().map(f).collect::<Vec<f64>>();
    d.set_item(
        "w_along_start_m",
        start_col(&|s| s.w_hole_m[0]).into_pyarray(py),
    )?;
    d.set_item(
        "dw_along_start_m_s",
        start_col(&|s| s.dw_hole_m_s[0]).into_pyarray(py),
    )?;
    d.set_item(
        "dw_across_start_m_s",
        start_col(&|s| s.dw_hole_m_s[1]).into_pyarray(py),
    )?;
    d.set_item(
        "rms_along_force_m",
        col(&|s| s.rms_along_force_m).into_pyarray(py),
    )?;
    d.set_item("rms_radial_m", col(&|s| s.rms_m[0]).into_pyarray(py))?;
    d.set_item("rms_tangential_m", col(&|s| s.rms_m[1]).into_pyarray(py))?;
    d.set_item("rms_total_m", col(&|s| s.rms_total_m).into_pyarray(py))?;
    for (k, name) in ["axial_plus", "axial_minus", "across_plus", "across_minus"]
        .iter()
        .enumerate()
    {
        d.set_item(
            format!("impacts_{name}"),
            two.iter()
                .map(|s| s.impacts[k] as i64)
                .collect::<Vec<_>>()
                .into_pyarray(py),
        )?;
    }
    d.set_item(
        "flight_fraction",
        col(&|s| s.flight_fraction).into_pyarray(py),
    )?;
    d.set_item(
        "one_plane_rms_m",
        point.one_plane_rms_m.clone().into_pyarray(py),
    )?;
    d.set_item(
        "solid_rms_m",
        vec![point.solid_rms_m; two.len()].into_pyarray(py),
    )?;
    d.set_item("solver", vec![point.solver; two.len()])?;
    Ok(d)
}

/// One run of a scenario with `[two_plane]`, as `vibrobar run` on it: member `member` of its
/// ensemble of starts, its history every `sample_every` steps and its summary. Meaning:
/// `vibrobar.two_plane_run`.
#[pyfunction]
#[pyo3(signature = (scenario, member = 0, sample_every = 10))]
pub(crate) fn two_plane_run<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    member: usize,
    sample_every: u64,
) -> PyResult<Bound<'py, PyDict>> {
    use vibrobar_core::analysis::two_plane::solid_rms_m;
    use vibrobar_core::params::two_plane::direction;
    use vibrobar_core::solver::two_plane_rk4::{HoleWall, Sampling, TwoPlaneSample, WallMotion};
    let sc = two_plane_scenario(scenario, "two_plane_run")?;
    if sample_every == 0 {
        return Err(PyValueError::new_err(
            "sample_every = 0 is outside the allowed range [1, ∞) steps",
        ));
    }
    let settings = sc.settings();
    settings.validate().map_err(input_error)?;
    let (sys, method) = sc.two_plane_run().map_err(anyhow_input)?;
    let start = sc
        .two_plane_start(&sys, member, "member")
        .map_err(anyhow_input)?;
    let interval_s = sample_every as f64 * settings.dt_s;
    limits::check_samples(
        "rows = duration_s / (sample_every · dt_s)",
        settings.duration_s,
        interval_s,
    )
    .map_err(input_error)?;
    let e_f = direction(sys.forcing.angle_deg);
    let (summary, rows, solid) = detached(py, None, |_| {
        let mut rows: Vec<[f64; 11]> = Vec::new();
        let mut on_sample = |s: &TwoPlaneSample| rows.push(iocsv::two_plane_history_values(s, e_f));
        let summary = method
            .run_from(
                &sys,
                &start,
                0.0,
                &settings,
                &mut |_| {},
                Some(Sampling {
                    start_s: 0.0,
                    interval_s,
                    on_sample: &mut on_sample,
                }),
            )
            .map_err(|e| run_error(two_plane_keywords(e.to_string())))?;
        let solid = solid_rms_m(&sys, &settings).map_err(run_error)?;
        Ok((summary, rows, solid))
    })?;
    let schema = iocsv::two_plane_history_schema();
    let names: Vec<String> = schema.header().split(',').map(String::from).collect();
    let history = PyDict::new(py);
    for (j, name) in names.iter().enumerate() {
        history.set_item(
            name,
            rows.iter()
                .map(|r| r[j])
                .collect::<Vec<f64>>()
                .into_pyarray(py),
        )?;
    }
    let mut csv = schema.header();
    csv.push('\n');
    for r in &rows {
        schema.format_into(&r.map(iocsv::Value::F), &mut csv);
        csv.push('\n');
    }
    let d = PyDict::new(py);
    d.set_item("history", history)?;
    d.set_item("history_csv", csv)?;
    rms_items(&d, &summary, solid)?;
    let walls = PyDict::new(py);
    for (w, name) in
        HoleWall::ALL
            .iter()
            .zip(["axial_plus", "axial_minus", "across_plus", "across_minus"])
    {
        let f = summary.contact_fraction[*w as usize];
        let e = PyDict::new(py);
        e.set_item("impacts", summary.impacts[*w as usize])?;
        e.set_item("rolling", f[WallMotion::Rolling as usize])?;
        e.set_item("sliding", f[WallMotion::Sliding as usize])?;
        e.set_item("stuck", f[WallMotion::Stuck as usize])?;
        walls.set_item(name, e)?;
    }
    d.set_item("walls", walls)?;
    d.set_item("flight_fraction", summary.flight_fraction)?;
    d.set_item("events", summary.events)?;
    d.set_item("max_penetration_m", summary.max_penetration_m.max(0.0))?;
    let b = summary.book;
    let energy = PyDict::new(py);
    energy.set_item("forcing_work_j", b.forcing_work_j)?;
    energy.set_item("viscous_loss_j", b.viscous_loss_j)?;
    energy.set_item("impact_loss_j", b.impact_loss_j)?;
    energy.set_item("sliding_loss_j", b.sliding_loss_j)?;
    energy.set_item("rolling_loss_j", b.rolling_loss_j)?;
    energy.set_item("delta_mechanical_j", b.energy_change_j)?;
    energy.set_item("residual_j", b.residual_j())?;
    d.set_item("energy", energy)?;
    d.set_item("solver", method.solver_for(&sys))?;
    d.set_item("member", member)?;
    Ok(d)
}

/// The scenario of a `[two_plane]` function, refused without the section.
fn two_plane_scenario<'a>(scenario: &'a PyScenario, function: &str) -> PyResult<&'a Scenario> {
    let sc = &scenario.inner;
    if sc.two_plane.is_none() {
        return Err(PyValueError::new_err(format!(
            "vibrobar.{function} of the bar that bends in two planes needs a scenario with \
             [two_plane]"
        )));
    }
    Ok(sc)
}

/// `sweep`, `ensemble` and `map` of a `[two_plane]` scenario (`kind`): every design point of
/// the grid an ensemble of starts, the rows and the text of the command line's CSV.
#[pyfunction]
#[pyo3(signature = (scenario, kind, ratios, gaps_m, hole_angles_deg, hole_diameters_m, members, seed, progress, threads))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn two_plane_table<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    kind: &str,
    ratios: Option<PyReadonlyArray1<'py, f64>>,
    gaps_m: Option<PyReadonlyArray1<'py, f64>>,
    hole_angles_deg: Option<PyReadonlyArray1<'py, f64>>,
    hole_diameters_m: Option<PyReadonlyArray1<'py, f64>>,
    members: Option<usize>,
    seed: Option<u64>,
    progress: Option<&Bound<'py, PyAny>>,
    threads: Option<usize>,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    if !matches!(kind, "sweep" | "ensemble" | "map") {
        return Err(PyValueError::new_err(format!(
            "kind = {kind:?} is not one of the allowed values: sweep, ensemble, map"
        )));
    }
    let sc = two_plane_scenario(scenario, kind)?;
    let section = sc.two_plane.as_ref().expect("checked");
    check_threads(threads)?;
    if kind != "map" && (hole_angles_deg.is_some() || hole_diameters_m.is_some()) {
        return Err(PyValueError::new_err(format!(
            "hole_angles_deg and hole_diameters_m are axes of vibrobar.map; vibrobar.{kind} runs \
             the scenario's hole"
        )));
    }
    let max = limits::MAX_SWEEP_RATIOS + 1;
    let ratios = match &ratios {
        Some(r) => values("ratios", r, |x| x > 0.0, "(0, ∞)", max)?,
        None if kind == "sweep" => {
            vibrobar_scenario::sweep_ratios(&sc.sweep).map_err(anyhow_input)?
        }
        None => return Err(PyValueError::new_err("ratios is required")),
    };
    let gaps_m =
        match &gaps_m {
            Some(g) => values("gaps_m", g, |x| x > 0.0, "(0, ∞) m", max)?,
            None if kind == "sweep" && !sc.sweep.gaps_m.is_empty() => sc.sweep.gaps_m.clone(),
            None if kind == "sweep" => return Err(PyValueError::new_err(
                "sweep.gaps_m = [] in the scenario: no gap to sweep (allowed: one or more gaps \
                 > 0 m; or give gaps_m)",
            )),
            None => return Err(PyValueError::new_err("gaps_m is required")),
        };
    let angles = match &hole_angles_deg {
        Some(a) => Some(values(
            "hole_angles_deg",
            a,
            |x| x.abs() <= 360.0,
            "[−360, 360] °",
            max,
        )?),
        None => None,
    };
    let diameters = match &hole_diameters_m {
        Some(d) => Some(values("hole_diameters_m", d, |x| x > 0.0, "(0, ∞) m", max)?),
        None => None,
    };
    let mut ens = section.ensemble().map_err(anyhow_input)?;
    if let Some(m) = members {
        ens.members = m;
    }
    if let Some(s) = seed {
        ens.seed = s;
    }
    ens.validate()
        .map_err(|e| input_error(e.to_string().replace("members (--members)", "members")))?;
    let settings = sc.settings();
    settings.validate().map_err(input_error)?;
    let method = section.method(settings.dt_s).map_err(anyhow_input)?;
    let cells = sc
        .two_plane_cells(
            &TwoPlaneAxes {
                ratios: &ratios,
                gaps_m: &gaps_m,
                hole_angles_deg: angles.as_deref(),
                hole_diameters_m: diameters.as_deref(),
                names: ["hole_angles_deg", "hole_diameters_m"],
            },
            ens.members,
            "runs (points × members)",
        )
        .map_err(anyhow_input)?;
    let systems: Vec<TwoPlaneSystem> = cells.iter().map(|c| c.system).collect();
    let points = detached(py, progress, |ctl| {
        let cb = |d: usize, t: usize| ctl.progress(d, t);
        design_points(
            &systems,
            &ens,
            method,
            &settings,
            &runner(ctl, &cb, threads),
        )
        .map_err(|e| run_error(two_plane_keywords(e.to_string())))
    })?;
    let (schema, rows) = match kind {
        "sweep" => (
            two_plane_csv::sweep_schema(),
            cells
                .iter()
                .zip(&points)
                .map(|(c, p)| two_plane_csv::sweep_values(c.axial_gap_m, c.ratio, p))
                .collect::<Vec<_>>(),
        ),
        "ensemble" => (
            two_plane_csv::ensemble_schema(),
            cells
                .iter()
                .zip(&points)
                .flat_map(|(c, p)| two_plane_csv::ensemble_rows(c.axial_gap_m, c.ratio, p))
                .collect(),
        ),
        _ => (
            two_plane_csv::map_schema(),
            cells
                .iter()
                .zip(&points)
                .map(|(c, p)| {
                    let cell = MapCell {
                        ratio: c.ratio,
                        axial_gap_m: c.axial_gap_m,
                        hole_angle_deg: c.hole_angle_deg,
                        hole_diameter_m: c.hole_diameter_m,
                        radial_clearance_m: c.system.radial_clearance_m(),
                    };
                    two_plane_csv::map_values(&cell, p)
                })
                .collect(),
        ),
    };
    for r in &rows {
        schema.check(r).map_err(run_error)?;
    }
    columns(py, &schema, &rows)
}

/// One member's run of a `[two_plane]` scenario at a point: the scenario there, its system, the
/// solver and the member's start.
fn member_at(
    sc: &Scenario,
    ratio: Option<f64>,
    gap_m: Option<f64>,
    member: usize,
) -> PyResult<(Scenario, TwoPlaneSystem, TwoPlaneMethod, TwoPlaneStart)> {
    let mut s = sc.clone();
    if let Some(r) = ratio {
        if !(r.is_finite() && r > 0.0) {
            return Err(PyValueError::new_err(format!(
                "ratio = {r} is outside the allowed range (0, ∞)"
            )));
        }
        s.forcing.frequency = Frequency::Ratio(r);
    }
    if let Some(g) = gap_m {
        if !(g.is_finite() && g > 0.0) {
            return Err(PyValueError::new_err(format!(
                "gap_m = {g} is outside the allowed range (0, ∞) m"
            )));
        }
        s.damper.gap_m = g;
    }
    let (sys, method) = s.two_plane_run().map_err(anyhow_input)?;
    let start = s
        .two_plane_start(&sys, member, "member")
        .map_err(anyhow_input)?;
    s.settings().validate().map_err(input_error)?;
    Ok((s, sys, method, start))
}

/// `poincare` of a `[two_plane]` scenario: member `member`'s state once per forcing period at
/// `phase_deg`, after the transient; the columns of a two-plane history.
#[pyfunction]
#[pyo3(signature = (scenario, ratio, gap_m, member, phase_deg, transient_s))]
pub(crate) fn two_plane_poincare<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    ratio: Option<f64>,
    gap_m: Option<f64>,
    member: usize,
    phase_deg: f64,
    transient_s: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let sc = two_plane_scenario(scenario, "poincare")?;
    let (s, sys, method, start) = member_at(sc, ratio, gap_m, member)?;
    if !phase_deg.is_finite() {
        return Err(PyValueError::new_err(format!(
            "phase_deg = {phase_deg} must be finite"
        )));
    }
    let t = transient(&s, transient_s)?;
    let settings = s.settings();
    let points = detached(py, None, |_| {
        poincare_two_plane(&sys, &start, method, &settings, phase_deg.to_radians(), t).map_err(
            |e| match e {
                vibrobar_core::SimError::Param(p) => input_error(p),
                other => run_error(two_plane_keywords(other.to_string())),
            },
        )
    })?;
    let e_f = direction(sys.forcing.angle_deg);
    let rows: Vec<Vec<Value>> = points
        .iter()
        .map(|p| {
            iocsv::two_plane_history_values(p, e_f)
                .map(Value::F)
                .to_vec()
        })
        .collect();
    Ok(columns(py, &iocsv::two_plane_history_schema(), &rows)?.0)
}

/// `lyapunov` of a `[two_plane]` scenario: the largest exponent of member `member`'s run by
/// two-trajectory divergence with renormalisation every `periods` forcing periods.
#[pyfunction]
#[pyo3(signature = (scenario, ratio, gap_m, member, transient_s, periods, d0))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn two_plane_lyapunov<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    ratio: Option<f64>,
    gap_m: Option<f64>,
    member: usize,
    transient_s: Option<f64>,
    periods: f64,
    d0: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let sc = two_plane_scenario(scenario, "lyapunov")?;
    let (s, sys, method, start) = member_at(sc, ratio, gap_m, member)?;
    for (name, x) in [("periods", periods), ("d0", d0)] {
        if !(x.is_finite() && x > 0.0) {
            return Err(PyValueError::new_err(format!(
                "{name} = {x} is outside the allowed range (0, ∞)"
            )));
        }
    }
    let t = transient(&s, transient_s)?;
    let settings = s.settings();
    let interval = periods * 2.0 * std::f64::consts::PI / sys.omega_rad_s();
    let intervals = ((settings.duration_s - t) / interval).floor() as usize;
    if intervals < 2 {
        return Err(PyValueError::new_err(format!(
            "duration_s = {} s leaves {intervals} intervals of {interval:.3e} s after the \
             transient; at least 2 are needed (raise duration_s or lower periods)",
            settings.duration_s
        )));
    }
    let p = LyapunovParams {
        transient_s: t,
        interval_s: interval,
        intervals,
        d0,
        scales: None,
        blocks: 10.min(intervals),
    };
    let r = detached(py, None, |_| {
        max_lyapunov_two_plane(&sys, &start, method, &settings, &p)
            .map_err(|e| run_error(two_plane_keywords(e.to_string())))
    })?;
    let d = super::lyapunov_dict(py, &r, intervals, interval, d0)?;
    d.set_item("member", member)?;
    d.set_item("solver", method.solver_for(&sys))?;
    Ok(d)
}

/// `orbit` of a `[two_plane]` scenario where its planes decouple: the period-`period` orbit
/// member `member`'s run settles on over `settle_s`, as `vibrobar orbit` on it.
#[pyfunction]
#[pyo3(signature = (scenario, ratio, gap_m, member, period, settle_s))]
pub(crate) fn two_plane_orbit<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    ratio: Option<f64>,
    gap_m: Option<f64>,
    member: usize,
    period: u32,
    settle_s: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    use vibrobar_core::analysis::orbit::{check_period, ExactJacobian};
    use vibrobar_core::analysis::two_plane::solid_rms_m;
    use vibrobar_core::analysis::two_plane_orbit::{two_plane_orbit, TwoPlaneOrbitOf};
    let sc = two_plane_scenario(scenario, "orbit")?;
    let (s, sys, _, start) = member_at(sc, ratio, gap_m, member)?;
    check_period(period).map_err(input_error)?;
    refuse_coupled(&sys)?;
    let settings = s.settings();
    let settle = settle_of(&settings, settle_s)?;
    let (orbit, solid) = detached(py, None, |_| {
        let o = two_plane_orbit(&sys, period, &start, settle, &ExactJacobian)
            .map_err(|e| run_error(two_plane_keywords(e.to_string())))?;
        let solid = solid_rms_m(&sys, &settings).map_err(run_error)?;
        Ok((o, solid))
    })?;
    let d = match &orbit {
        TwoPlaneOrbitOf::Lumped(o) => {
            let planes = [
                super::orbit_dict(py, &o.planes[0])?,
                super::orbit_dict(py, &o.planes[1])?,
            ];
            orbit_of_two_planes(py, o, planes, solid)?
        }
        TwoPlaneOrbitOf::Round(o) => {
            let planes = [
                super::modal_orbit_dict(py, &o.planes[0])?,
                super::modal_orbit_dict(py, &o.planes[1])?,
            ];
            orbit_of_two_planes(py, o, planes, solid)?
        }
    };
    d.set_item("member", member)?;
    Ok(d)
}

/// The dict of a two-plane orbit on either bar, with its planes' dicts.
fn orbit_of_two_planes<'py, F: vibrobar_core::analysis::orbit::Flow>(
    py: Python<'py>,
    o: &vibrobar_core::analysis::two_plane_orbit::TwoPlaneOrbit<F>,
    planes: [Bound<'py, PyDict>; 2],
    solid: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let period = o.planes[0].section.periods();
    let sm = &o.summary;
    let d = PyDict::new(py);
    d.set_item("period", period)?;
    d.set_item("stable", o.stable())?;
    let m = o.multipliers();
    d.set_item("max_abs_multiplier", m.first().map_or(0.0, |l| l.norm()))?;
    d.set_item(
        "multipliers",
        m.iter().map(|l| (l.re, l.im)).collect::<Vec<_>>(),
    )?;
    d.set_item("spin_multiplier", 1.0)?;
    d.set_item("impacts_per_period", o.impacts_per_period())?;
    let walls = PyDict::new(py);
    for (k, name) in ["plug_plus", "plug_minus", "wall_plus", "wall_minus"]
        .iter()
        .enumerate()
    {
        walls.set_item(*name, sm.impacts[k])?;
    }
    d.set_item("impacts_per_wall", walls)?;
    rms_items(&d, sm, solid)?;
    d.set_item("flight_fraction", sm.flight_fraction)?;
    d.set_item("return_gap", o.return_gap)?;
    let st = PyDict::new(py);
    st.set_item("t_s", o.start_t_s)?;
    st.set_item("u_m", o.start.u_m.to_vec())?;
    st.set_item("du_m_s", o.start.du_m_s.to_vec())?;
    st.set_item("w_hole_m", o.start.w_hole_m.to_vec())?;
    st.set_item("dw_hole_m_s", o.start.dw_hole_m_s.to_vec())?;
    d.set_item("state", st)?;
    let [along, across] = planes;
    let p = PyDict::new(py);
    p.set_item("along_hole", along)?;
    p.set_item("across_hole", across)?;
    d.set_item("planes", p)?;
    Ok(d)
}

/// `lyapunov_spectrum` of a `[two_plane]` scenario where its planes decouple: each plane's
/// exponents over the window after the transient, as `vibrobar lyapunov --spectrum` on it.
#[pyfunction]
#[pyo3(signature = (scenario, ratio, gap_m, member, transient_s, blocks))]
pub(crate) fn two_plane_lyapunov_spectrum<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    ratio: Option<f64>,
    gap_m: Option<f64>,
    member: usize,
    transient_s: Option<f64>,
    blocks: usize,
) -> PyResult<Bound<'py, PyDict>> {
    use vibrobar_core::analysis::lyapunov_spectrum::SpectrumParams;
    use vibrobar_core::analysis::two_plane_orbit::two_plane_lyapunov_spectrum as spectrum;
    let sc = two_plane_scenario(scenario, "lyapunov_spectrum")?;
    let (s, sys, _, start) = member_at(sc, ratio, gap_m, member)?;
    refuse_coupled(&sys)?;
    let t = transient(&s, transient_s)?;
    let p = SpectrumParams {
        transient_s: t,
        duration_s: s.settings().duration_s - t,
        blocks,
        scales: None,
    };
    let planes = detached(py, None, |_| {
        spectrum(&sys, &start, &p).map_err(|e| match e {
            vibrobar_core::SimError::Param(p) => input_error(p),
            other => run_error(two_plane_keywords(other.to_string())),
        })
    })?;
    let d = PyDict::new(py);
    for (name, r) in ["along_hole", "across_hole"].iter().zip(&planes) {
        let e = PyDict::new(py);
        e.set_item("exponents_per_s", r.exponents_per_s.clone())?;
        e.set_item("std_error_per_s", r.std_error_per_s.clone())?;
        e.set_item("collapsed", r.collapsed)?;
        e.set_item("sum_per_s", r.sum_per_s)?;
        e.set_item("impacts_per_s", r.impacts_per_s)?;
        e.set_item("duration_s", r.duration_s)?;
        d.set_item(*name, e)?;
    }
    d.set_item("spin_exponent_per_s", 0.0)?;
    d.set_item("blocks", blocks)?;
    d.set_item("member", member)?;
    Ok(d)
}

/// `continuation` of a `[two_plane]` scenario where its planes decouple: each plane's orbit,
/// from the one member `member` settles on, followed in `param` ("ratio", "gap_m" (the axial
/// gap: the plane along the hole) or "restitution"; SI) from `from_` to `to`; the rows of
/// `vibrobar continue` on it, the parameter in SI units.
#[pyfunction]
#[pyo3(signature = (scenario, param, from_, to, ratio, gap_m, member, period, settle_s, max_points, switch_branches))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn two_plane_continuation<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    param: &str,
    from_: f64,
    to: f64,
    ratio: Option<f64>,
    gap_m: Option<f64>,
    member: usize,
    period: u32,
    settle_s: Option<f64>,
    max_points: usize,
    switch_branches: bool,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    use vibrobar_core::analysis::grid::Axis;
    use vibrobar_core::analysis::orbit::continuation::{check_interval, ContinuationSettings};
    use vibrobar_core::analysis::orbit::{check_period, ExactJacobian};
    use vibrobar_core::analysis::two_plane_orbit::{two_plane_branches, PlaneBranch};
    let sc = two_plane_scenario(scenario, "continuation")?;
    let axis = match param {
        "ratio" => Axis::FreqRatio,
        "gap_m" => Axis::GapM,
        "restitution" => Axis::Restitution,
        _ => {
            return Err(PyValueError::new_err(format!(
                "param must be one of \"ratio\", \"gap_m\" (the axial gap), \"restitution\" for a \
                 scenario with [two_plane] (friction on the hole's walls couples the planes), got \
                 {param:?}"
            )))
        }
    };
    check_interval(axis, from_, to).map_err(input_error)?;
    check_period(period).map_err(input_error)?;
    limits::check_count("max_points", max_points, 2, 100_000, "").map_err(input_error)?;
    let (ratio, gap_m) = match axis {
        Axis::FreqRatio => (Some(from_), gap_m),
        Axis::GapM => (ratio, Some(from_)),
        _ => (ratio, gap_m),
    };
    let (s, sys, _, start) = member_at(sc, ratio, gap_m, member)?;
    refuse_coupled(&sys)?;
    let settings = s.settings();
    let settle = settle_of(&settings, settle_s)?;
    let cont = ContinuationSettings {
        max_points,
        switch_branches,
        ..Default::default()
    };
    let planes = detached(py, None, |_| {
        two_plane_branches(
            &sys,
            &start,
            axis,
            from_,
            to,
            period,
            settle,
            &ExactJacobian,
            &cont,
        )
        .map_err(|e| match e {
            vibrobar_core::SimError::Param(p) => input_error(p),
            other => run_error(two_plane_keywords(other.to_string())),
        })
    })?;
    let mut rows = Vec::new();
    for (name, p) in ["along_hole", "across_hole"].iter().zip(&planes) {
        if let PlaneBranch::Followed { branch, scale } = p {
            rows.extend(
                branch
                    .points
                    .iter()
                    .map(|q| two_plane_csv::continuation_values(name, q, *scale)),
            );
        }
    }
    let schema = two_plane_csv::continuation_schema();
    for r in &rows {
        schema.check(r).map_err(run_error)?;
    }
    columns(py, &schema, &rows)
}

/// Orbits, continuation and the spectrum need the planes to decouple: refused, saying why.
fn refuse_coupled(sys: &TwoPlaneSystem) -> PyResult<()> {
    use vibrobar_core::analysis::two_plane_orbit::TWO_PLANE_ORBIT_SCOPE;
    match vibrobar_core::solver::two_plane_exact::decoupled(sys) {
        Ok(()) => Ok(()),
        Err(why) => Err(PyValueError::new_err(format!(
            "{TWO_PLANE_ORBIT_SCOPE}; here {why}"
        ))),
    }
}

/// The settling time of an orbit's start: `settle_s`, or the part of the run before the RMS
/// window.
fn settle_of(settings: &vibrobar_core::RunSettings, settle_s: Option<f64>) -> PyResult<f64> {
    match settle_s {
        Some(t) if t.is_finite() && t > 0.0 => Ok(t),
        Some(t) => Err(PyValueError::new_err(format!(
            "settle_s = {t} is outside the allowed range (0, ∞) s"
        ))),
        None => Ok(settings.duration_s * (1.0 - settings.rms_fraction)),
    }
}

/// The RMS of a two-plane summary (along the force, per direction, in total) beside the bar
/// without its ball, and the reduction, into `d`.
fn rms_items(
    d: &Bound<'_, PyDict>,
    s: &vibrobar_core::solver::two_plane_rk4::TwoPlaneSummary,
    solid: f64,
) -> PyResult<()> {
    d.set_item("rms_along_force_m", s.rms_along_force_m)?;
    d.set_item("rms_radial_m", s.rms_m[0])?;
    d.set_item("rms_tangential_m", s.rms_m[1])?;
    d.set_item("rms_total_m", s.rms_total_m)?;
    d.set_item("solid_rms_m", solid)?;
    d.set_item("reduction_pct", 100.0 * (1.0 - s.rms_along_force_m / solid))
}
