//! Parameter derivatives of the exact flow (issue #11): the column `∂x(t_end)/∂p` carried by
//! the variational layer against central finite differences of the exact solver's end state
//! in the parameter, at points where no event is near grazing.

use vibrobar_core::analysis::variational::{flow_with_param_derivative, Param};
use vibrobar_core::params::{FrictionModel, State, System};
use vibrobar_core::solver::{Exact, Solver};

#[path = "common/variational_fd.rs"]
mod variational_fd;
use variational_fd::{end, scales};

fn value(sys: &System, p: Param) -> f64 {
    let d = sys.damper.unwrap();
    match p {
        Param::Restitution => d.restitution,
        Param::FrictionForceN => sys.friction_level_n(),
        Param::GapM => d.gap_m,
        Param::FreqRatio => sys.omega_rad_s() / sys.omega1_rad_s(),
    }
}

fn with(sys: &System, p: Param, v: f64) -> System {
    let mut s = *sys;
    if p == Param::FreqRatio {
        s.forcing.frequency = vibrobar_core::params::Frequency::Ratio(v);
        return s;
    }
    let d = s.damper.as_mut().unwrap();
    match p {
        Param::Restitution => d.restitution = v,
        Param::FrictionForceN => d.friction_force_n = Some(v),
        Param::GapM => d.gap_m = v,
        Param::FreqRatio => unreachable!(),
    }
    s
}

/// Relative FD step in the parameter (the end state carries ~1e-12 relative noise; see
/// `tests/variational.rs`).
const H: f64 = 1e-5;
/// The step for the frequency ratio.
const H_RATIO: f64 = 1e-7;
/// Tolerance on the largest entry error over the largest entry (scaled coordinates).
const TOL: f64 = 1e-6;

/// `∂x/∂p` of the run from `x` to `t_end` against central differences; returns the error.
fn check(name: &str, sys: &System, p: Param, x: &State, t_end: f64) -> f64 {
    let (fj, d) = flow_with_param_derivative(&Exact::default(), sys, x, t_end, p, &mut ()).unwrap();
    let p0 = value(sys, p);
    // The ratio moves the forcing phase by `Ω t δr/r` (~900 rad × δr/r at t = 0.3 s): the
    // FD truncation `(Ω t h)²/6` needs a smaller step there.
    let dp = if p == Param::FreqRatio { H_RATIO } else { H } * p0;
    let (a, b) = (
        end(&with(sys, p, p0 + dp), x, t_end),
        end(&with(sys, p, p0 - dp), x, t_end),
    );
    let sc = scales(sys);
    let (mut e, mut n) = (0.0f64, 0.0f64);
    for i in 0..4 {
        let fd = (a[i] - b[i]) / (2.0 * dp) / sc[i];
        e = e.max((fd - d[i] / sc[i]).abs());
        n = n.max(fd.abs());
    }
    let r = e / n;
    eprintln!(
        "{name}: ∂x/∂p FD rel err {r:.3e} (|∂x/∂p| {n:.3e} scaled), {:?}",
        fj.events
    );
    assert!(n > 0.0, "{name}: the parameter has no effect on this run");
    assert!(r < TOL, "{name}: ∂x/∂p vs FD relative error {r:e}");
    assert_eq!(fj.events.grazing, 0, "{name}");
    r
}

fn paper(gap_m: f64, friction: FrictionModel, f_n: Option<f64>, e: Option<f64>) -> System {
    let mut sys = System::paper_damped(gap_m, friction, 1.0);
    let d = sys.damper.as_mut().unwrap();
    d.friction_force_n = f_n.or(d.friction_force_n);
    d.restitution = e.unwrap_or(d.restitution);
    sys
}

/// Three forcing periods from a state settled for 0.3 s.
fn window(sys: &System) -> (State, f64) {
    let x = Exact::default()
        .run(sys, &State::REST, 0.3, &mut ())
        .unwrap()
        .final_state;
    (x, x.t_s + 3.0 * sys.forcing_period_s())
}

#[test]
fn restitution_derivative_matches_finite_differences() {
    for e in [0.5, 0.2, 0.8] {
        let sys = paper(0.08e-3, FrictionModel::None, None, Some(e));
        let (x, t) = window(&sys);
        check(
            &format!("d/de frictionless e {e}"),
            &sys,
            Param::Restitution,
            &x,
            t,
        );
    }
    // Impacts with friction switches, an accumulating sequence summed (plastic, its `∂g/∂e`
    // is zero), the ball riding the wall and released.
    let sys = paper(0.1e-3, FrictionModel::AsPublished, None, None);
    let (x, t) = window(&sys);
    check("d/de as-published", &sys, Param::Restitution, &x, t);
}

#[test]
fn friction_force_derivative_matches_finite_differences() {
    for (name, f) in [("switches 5 N", 5.0), ("stick 8 N", 8.0)] {
        let sys = paper(0.1e-3, FrictionModel::Coulomb, Some(f), None);
        let (x, t) = window(&sys);
        check(
            &format!("d/dF coulomb {name}"),
            &sys,
            Param::FrictionForceN,
            &x,
            t,
        );
    }
    let sys = paper(0.1e-3, FrictionModel::AsPublished, None, None);
    let (x, t) = window(&sys);
    check("d/dF as-published", &sys, Param::FrictionForceN, &x, t);
}

#[test]
fn gap_derivative_matches_finite_differences() {
    for e in [0.5, 0.8] {
        let sys = paper(0.08e-3, FrictionModel::None, None, Some(e));
        let (x, t) = window(&sys);
        check(
            &format!("d/dl_g frictionless e {e}"),
            &sys,
            Param::GapM,
            &x,
            t,
        );
    }
    let sys = paper(0.1e-3, FrictionModel::AsPublished, None, None);
    let (x, t) = window(&sys);
    check("d/dl_g as-published", &sys, Param::GapM, &x, t);
}

#[test]
fn frequency_ratio_derivative_matches_finite_differences() {
    // At fixed start and end times: the secular response to `F₀ t cos Ωt` in every segment
    // (free flight, stick, wall contact), and the unstick/release thresholds.
    for e in [0.5, 0.8] {
        let sys = paper(0.08e-3, FrictionModel::None, None, Some(e));
        let (x, t) = window(&sys);
        check(
            &format!("d/dr frictionless e {e}"),
            &sys,
            Param::FreqRatio,
            &x,
            t,
        );
    }
    for f in [5.0, 8.0] {
        let sys = paper(0.1e-3, FrictionModel::Coulomb, Some(f), None);
        let (x, t) = window(&sys);
        check(
            &format!("d/dr coulomb {f} N"),
            &sys,
            Param::FreqRatio,
            &x,
            t,
        );
    }
    let sys = paper(0.1e-3, FrictionModel::AsPublished, None, None);
    let (x, t) = window(&sys);
    check("d/dr as-published", &sys, Param::FreqRatio, &x, t);
}
