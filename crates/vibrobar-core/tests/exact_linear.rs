//! Linear bar, no ball (and a ball too far from the walls to matter): the exact solver against
//! the textbook closed form including the transient, its RMS integral against an independent
//! quadrature; RK4 against the same model with a loose tolerance.
mod common;

use vibrobar_core::analysis::{RmsObserver, Sampler};
use vibrobar_core::solver::{Exact, Rk4, Solver};
use vibrobar_core::*;

/// Independent closed form of `M ü + C u̇ + K u = F_s + F0 sin Ωt` from `(u0, u̇0)` at `t0`,
/// written with the amplitude/phase of the steady state and absolute time.
fn closed_form(sys: &System, t0: f64, u0: f64, du0: f64, t: f64) -> f64 {
    let (m, k, c) = (
        sys.lumped_bar().unwrap().mass_kg,
        sys.lumped_bar().unwrap().stiffness_n_per_m,
        sys.lumped_bar().unwrap().damping_n_s_per_m(),
    );
    let om = sys.omega_rad_s();
    let f0 = sys.forcing.amplitude_n;
    let us = sys.forcing.static_force_n / k;
    // Steady state X sin(Ωt − φ).
    let x = f0 / ((k - m * om * om).powi(2) + (c * om).powi(2)).sqrt();
    let phi = (c * om).atan2(k - m * om * om);
    let up = |t: f64| us + x * (om * t - phi).sin();
    let dup = |t: f64| x * om * (om * t - phi).cos();
    let zeta = sys.lumped_bar().unwrap().damping_ratio;
    let wn = (k / m).sqrt();
    let wd = wn * (1.0 - zeta * zeta).sqrt();
    let (a0, b0) = (u0 - up(t0), du0 - dup(t0));
    let s = t - t0;
    let hom = (-zeta * wn * s).exp()
        * (a0 * (wd * s).cos() + (b0 + zeta * wn * a0) / wd * (wd * s).sin());
    up(t) + hom
}

fn bar_system(with_far_ball: bool) -> System {
    let mut sys = System::paper_solid(0.97);
    sys.forcing.static_force_n = 3.0;
    if with_far_ball {
        // 1 m of clearance: the ball, at rest, never reaches a wall.
        sys.damper = Some(Damper::paper(1.0, FrictionModel::None));
    }
    sys
}

fn check_against_closed_form(sys: &System, solver: &dyn Solver, rel_tol: f64) {
    let init = State {
        t_s: 0.3,
        u_m: 2e-5,
        du_m_s: -0.01,
        v_m: 2e-5,
        dv_m_s: -0.01,
        cavity: None,
    };
    let t_end = 0.35;
    let mut sampler = Sampler::new(init.t_s, 1.37e-5);
    let summary = solver.run(sys, &init, t_end, &mut sampler).unwrap();
    assert_eq!(summary.impacts, 0);
    let scale = sampler
        .samples
        .iter()
        .map(|s| s.u_m.abs())
        .fold(0.0, f64::max);
    assert!(sampler.samples.len() > 3000);
    let mut worst = 0.0f64;
    for s in &sampler.samples {
        let want = closed_form(sys, init.t_s, init.u_m, init.du_m_s, s.t_s);
        worst = worst.max((s.u_m - want).abs() / scale);
    }
    assert!(
        worst < rel_tol,
        "{}: worst relative error {worst:e}",
        solver.name()
    );
    let f = &summary.final_state;
    let want = closed_form(sys, init.t_s, init.u_m, init.du_m_s, t_end);
    assert!((f.u_m - want).abs() < rel_tol * scale);
}

#[test]
fn exact_matches_closed_form_without_ball() {
    check_against_closed_form(&bar_system(false), &Exact::default(), 1e-10);
}

#[test]
fn exact_matches_closed_form_with_unreachable_ball() {
    check_against_closed_form(&bar_system(true), &Exact::default(), 1e-10);
}

#[test]
fn rk4_matches_closed_form_loosely() {
    check_against_closed_form(&bar_system(false), &Rk4 { dt_s: 1e-6 }, 1e-6);
}

#[test]
fn rms_integral_matches_independent_quadrature() {
    let sys = bar_system(false);
    let init = State {
        t_s: 0.0,
        u_m: 1e-5,
        du_m_s: 0.02,
        ..State::REST
    };
    let (a, b) = (0.013, 0.2);
    let mut rms = RmsObserver::new(a, b);
    Exact::default().run(&sys, &init, 0.25, &mut rms).unwrap();
    // Composite Simpson on the independent closed form.
    let n = 400_000;
    let h = (b - a) / n as f64;
    let mut s = 0.0;
    for i in 0..=n {
        let t = a + i as f64 * h;
        let wgt = if i == 0 || i == n {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        s += wgt * closed_form(&sys, 0.0, init.u_m, init.du_m_s, t).powi(2);
    }
    let want = (s * h / 3.0 / (b - a)).sqrt();
    let got = rms.rms_m();
    assert!(
        ((got - want) / want).abs() < 1e-10,
        "rms {got:e} vs quadrature {want:e}"
    );
}

#[test]
fn undamped_exact_resonance_is_an_error_not_a_panic() {
    let mut sys = System::paper_solid(1.0);
    sys.bar.as_lumped_mut().unwrap().damping_ratio = 0.0;
    sys.forcing.frequency = Frequency::RadPerS(sys.lumped_bar().unwrap().natural_freq_rad_s());
    let r = Exact::default().run(&sys, &State::REST, 0.01, &mut ());
    assert!(
        matches!(r, Err(SimError::UndampedResonance { .. })),
        "{r:?}"
    );
}
