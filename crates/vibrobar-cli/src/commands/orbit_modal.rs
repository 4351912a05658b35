//! `vibrobar orbit` and `vibrobar continue` on an N-mode bar (`[beam]`, `[[modes]]`): the core
//! is `vibrobar_core::analysis::orbit::modal` and `::modal_continuation`. The output files have
//! the lumped commands' keys and columns; the state is modal.
use super::orbit::{
    continuation_params, continued_point, continued_point_params, event_json, period_of,
    write_branch, BranchMark, ContinueArgs, JacobianArg, OrbitArgs, StartArg,
};
use super::{check_value, fmt_coord, SystemArgs};
use anyhow::{bail, Context};
use vibrobar_core::analysis::grid::Axis;
use vibrobar_core::analysis::orbit::continuation::{ContinuationSettings, CONTINUATION_PARAMS};
use vibrobar_core::analysis::orbit::modal::{
    continue_modal_orbit, modal_orbit_settled_at, ModalFamily, ModalParam, ModalPeriodicOrbit,
};
use vibrobar_core::structure::{ModalState, ModalSystem, Point};
use vibrobar_core::System;
use vibrobar_io::csv::{continuation_values, write_json};
use vibrobar_io::params::OrbitParams;
use vibrobar_io::Metadata;
use vibrobar_report::figures::branch::BranchDot;

/// The scenario describes an N-mode bar.
pub fn is_modal(s: &SystemArgs) -> anyhow::Result<bool> {
    let sc = s.scenario()?;
    Ok(sc.beam.is_some() || sc.modes.is_some())
}

/// The start of a modal orbit: a settled run (`auto` is `settled` here: the analytic symmetric
/// orbit is the lumped bar's). Returns the orbit and the settling time used.
fn start_modal(
    sys: &ModalSystem,
    s: &SystemArgs,
    a: &super::orbit::OrbitStartArgs,
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

/// The JSON of a modal orbit: the lumped orbit's keys, the state in modal coordinates.
pub fn modal_orbit_json(o: &ModalPeriodicOrbit) -> serde_json::Value {
    let s = &o.state;
    let sys = &o.section.system;
    let n = sys.n_modes();
    let ph = &o.physicality;
    let inf_null = |x: f64| x.is_finite().then_some(x);
    let d = o.section.dim();
    serde_json::json!({
        "rms_m": o.rms_m,
        "impacts_per_period": o.impacts_per_period,
        "impacts_per_cycle": o.impacts_per_cycle(),
        "period": o.section.periods,
        "multipliers": o.multipliers.iter().map(|l| [l.re, l.im]).collect::<Vec<_>>(),
        "max_abs_multiplier": o.max_abs_multiplier(),
        "stable": o.stable(),
        "modes": n,
        "state": {
            "t_s": s.t_s,
            "q_m": &s.q_m[..n],
            "dq_m_s": &s.dq_m_s[..n],
            "u_m": s.u_at(&sys.model, Point::Response),
            "du_m_s": s.du_at(&sys.model, Point::Response),
            "w_m": s.w_m(&sys.model),
            "dw_m_s": s.dw_m_s(&sys.model),
        },
        "section_phase_rad": (sys.omega_rad_s() * o.section.t0_s).rem_euclid(std::f64::consts::TAU),
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
        "jacobian": "variational",
        "monodromy_coordinates": "(q_1..q_N, dq_1..dq_N, w, dw)",
        "monodromy": (0..d).map(|i| (0..d).map(|j| o.jacobian[(i, j)]).collect::<Vec<_>>()).collect::<Vec<_>>(),
    })
}

/// `vibrobar orbit` on an N-mode bar.
pub fn run_orbit_modal(a: &OrbitArgs, sys: &System) -> anyhow::Result<()> {
    let msys = ModalSystem::from_system(sys)?;
    let (o, settle) = start_modal(&msys, &a.point.system, &a.start)?;
    let params = OrbitParams {
        point: a.point.to_params()?,
        period: o.section.periods,
        start: "settled".into(),
        branch: None,
        settle_s: Some(settle),
        jacobian: "variational".into(),
    };
    let mut j = modal_orbit_json(&o);
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
        "period-{} orbit of the {}-mode bar (settled): RMS {:.4e} m, {} impacts per period, events {:?}, largest multipliers [{}] (max |λ| = {:.6}): {}; |w| ≤ l_g {}",
        o.section.periods,
        o.section.n_modes(),
        o.rms_m,
        o.impacts_per_period,
        o.sequence,
        mults.join(", "),
        o.max_abs_multiplier(),
        if o.stable() { "stable" } else { "unstable" },
        if o.physicality.confined { "holds" } else { "VIOLATED" },
    );
    println!("wrote {}", a.out.display());
    Ok(())
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
pub fn run_continue_modal(a: &ContinueArgs) -> anyhow::Result<()> {
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
    let ends: Vec<String> = b
        .stop_reasons
        .iter()
        .enumerate()
        .map(|(i, r)| format!("branch {i} ended: {r}"))
        .collect();
    write_branch(a, &params, &rows, &marks, &title, &summary, &ends)
}

/// `vibrobar bench`: the median wall time of one Newton solve of the 4-mode paper beam's
/// two-impact orbit (0.1 mm, r = 1, frictionless, exact modal Jacobian, from the same settled
/// start) and of a 50-point branch of it in the cavity position, over 5 repetitions.
pub fn bench_row() -> anyhow::Result<()> {
    use vibrobar_core::analysis::orbit::modal::{find_modal_orbit, modal_starting_guess};
    use vibrobar_core::analysis::orbit::NewtonSettings;
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
    let (mut tn, mut tc) = (Vec::new(), Vec::new());
    let (mut iters, mut n) = (0, 0);
    for _ in 0..5 {
        let t = std::time::Instant::now();
        let o = find_modal_orbit(&sec, &x0, &NewtonSettings::default())?;
        tn.push(t.elapsed().as_secs_f64());
        iters = o.iterations;
        let p0 = beam.cavity_position_m;
        let t = std::time::Instant::now();
        let b = continue_modal_orbit(&o, &fam, p0, p0 - 20e-3, &settings)?;
        tc.push(t.elapsed().as_secs_f64());
        n = b.points.len();
    }
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    println!(
        "  exact  periodic orbit of the 4-mode beam (r = 1, 0.1 mm, frictionless): Newton ({iters} iterations from a settled run) median {:.2} ms; a {n}-point branch in the cavity position median {:.1} ms over 5",
        med(&mut tn) * 1e3,
        med(&mut tc) * 1e3
    );
    Ok(())
}
