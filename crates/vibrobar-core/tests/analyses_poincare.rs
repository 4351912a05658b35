//! Poincaré sections against the closed-form steady state of a linear bar, impact sections and
//! bifurcation rows.

use std::f64::consts::TAU;
use vibrobar_core::analysis::map::Axis;
use vibrobar_core::analysis::poincare::{bifurcation, BifurcationSpec, ImpactSection, Stroboscope};
use vibrobar_core::solver::{Rk4, Solver, Wall};
use vibrobar_core::{FrictionModel, State, System};

/// Steady state of `M ü + C u̇ + K u = F_s + F0 sin(Ωt)` at forcing phase `φ` (`Ωt ≡ φ`):
/// `u = F_s/K + X sin(φ − θ)`, `u̇ = XΩ cos(φ − θ)`.
fn closed_form(sys: &System, phase: f64) -> (f64, f64) {
    let k = sys.lumped_bar().unwrap().stiffness_n_per_m;
    let r = sys.omega_rad_s() / sys.lumped_bar().unwrap().natural_freq_rad_s();
    let z = sys.lumped_bar().unwrap().damping_ratio;
    let x = sys.forcing.amplitude_n / k / ((1.0 - r * r).powi(2) + (2.0 * z * r).powi(2)).sqrt();
    let theta = (2.0 * z * r).atan2(1.0 - r * r);
    (
        sys.forcing.static_force_n / k + x * (phase - theta).sin(),
        x * sys.omega_rad_s() * (phase - theta).cos(),
    )
}

#[test]
fn stroboscopic_points_converge_to_the_linear_steady_state() {
    let mut sys = System::paper_solid(0.9);
    sys.forcing.static_force_n = 3.0;
    let phase = 1.0;
    let (u_ss, du_ss) = closed_form(&sys, phase);
    let x =
        (u_ss - 3.0 / sys.lumped_bar().unwrap().stiffness_n_per_m).hypot(du_ss / sys.omega_rad_s());
    let mut strobe = Stroboscope::for_system(&sys, phase, 0.05);
    Rk4 { dt_s: 1e-6 }
        .run(&sys, &State::REST, 0.4, &mut strobe)
        .unwrap();
    let pts = &strobe.points;
    let period = sys.forcing_period_s();
    // One point per period, at (φ + 2πk)/Ω exactly, from 0.05 s on.
    assert!(pts[0].t_s >= 0.05 && pts[0].t_s - period < 0.05);
    for s in pts {
        let k = ((s.t_s * sys.omega_rad_s() - phase) / TAU).round();
        assert!((s.t_s - (phase + TAU * k) / sys.omega_rad_s()).abs() < 1e-12);
    }
    assert_eq!(
        pts.len(),
        ((0.4 - pts[0].t_s) / period).floor() as usize + 1
    );
    let err = |s: &State| (s.u_m - u_ss).hypot((s.du_m_s - du_ss) / sys.omega_rad_s()) / x;
    // The transient decays like exp(−ζω_n t): at 0.05 s it is still there (e^−1.9 ≈ 15 %) …
    assert!(err(&pts[0]) > 1e-2, "first error {}", err(&pts[0]));
    // … at 0.4 s it is e^−15 ≈ 3e-7 of the start: the points sit on the closed form.
    let last = pts.last().unwrap();
    assert!(err(last) < 2e-5, "last error {}", err(last));
    assert!((last.u_m - u_ss).abs() < 2e-5 * x);
}

#[test]
fn impact_section_keeps_the_chosen_wall_only() {
    let sys = System::paper_damped(1e-4, FrictionModel::None, 1.0);
    let solver = Rk4 { dt_s: 2e-6 };
    let lg = 0.5e-4;
    let mut plus = ImpactSection::new(&sys, Some(Wall::Plus), 0.05);
    let mut minus = ImpactSection::new(&sys, Some(Wall::Minus), 0.05);
    let mut both = ImpactSection::new(&sys, None, 0.05);
    let mut all = ImpactSection::new(&sys, None, 0.0);
    {
        let mut obs: [&mut dyn vibrobar_core::Observer; 4] =
            [&mut plus, &mut minus, &mut both, &mut all];
        solver
            .run(
                &sys,
                &State::REST,
                0.2,
                &mut vibrobar_core::solver::Fanout(&mut obs),
            )
            .unwrap();
    }
    assert!(!plus.points.is_empty() && !minus.points.is_empty());
    assert_eq!(plus.points.len() + minus.points.len(), both.points.len());
    assert!(all.points.len() > both.points.len());
    for p in &plus.points {
        assert_eq!(p.wall, Wall::Plus);
        assert!(p.t_s >= 0.05);
        assert!(p.before.w_m() >= lg && p.dw_m_s > 0.0);
        // Eq. 5: ẇ+ = −e ẇ−.
        assert!((p.after.dw_m_s() + 0.5 * p.dw_m_s).abs() < 1e-12 * p.dw_m_s.abs().max(1.0));
        assert!((0.0..TAU).contains(&p.phase_rad));
        let ph = (sys.omega_rad_s() * p.t_s).rem_euclid(TAU);
        assert!((ph - p.phase_rad).abs() < 1e-12);
    }
    for p in &minus.points {
        assert_eq!(p.wall, Wall::Minus);
        assert!(p.before.w_m() <= -lg && p.dw_m_s < 0.0);
    }
}

#[test]
fn bifurcation_rows_of_a_linear_bar_lie_on_the_closed_form() {
    let spec = BifurcationSpec {
        system: System::paper_solid(1.0),
        axis: Axis::FreqRatio,
        init: State::REST,
        duration_s: 0.5,
        transient_s: 0.4,
        phase_rad: 0.0,
        impact_wall: None,
    };
    let ratios = [0.8, 0.95, 1.1];
    let b = bifurcation(&spec, &ratios, &Rk4 { dt_s: 2e-6 }, &|_, _| {}).unwrap();
    assert!(b.impacts.is_empty());
    for &r in &ratios {
        let mut sys = spec.system;
        Axis::FreqRatio.apply(&mut sys, r).unwrap();
        let (u, _) = closed_form(&sys, 0.0);
        let rows: Vec<_> = b
            .points
            .iter()
            .filter(|p| p.param.total_cmp(&r).is_eq())
            .collect();
        // ≈ 0.1 s of points, one per period, all after the transient.
        let n = (0.1 / sys.forcing_period_s()).floor() as usize;
        assert!(
            rows.len() == n || rows.len() == n + 1,
            "{} vs {n}",
            rows.len()
        );
        let amp = closed_form(&sys, std::f64::consts::FRAC_PI_2).0.hypot(u);
        for p in rows {
            assert!(p.t_s >= 0.4);
            // e^(−ζω_n·0.4) ≈ 3e-7 of the transient left: within 1e-4 of the amplitude.
            assert!((p.u_m - u).abs() < 1e-4 * amp, "r = {r}: {} vs {u}", p.u_m);
        }
    }
    // Rows come in parameter order.
    assert!(b.points.windows(2).all(|w| w[0].param <= w[1].param));
    // A gap axis needs a ball.
    let err = bifurcation(
        &BifurcationSpec {
            axis: Axis::GapM,
            ..spec
        },
        &[1e-4],
        &Rk4 { dt_s: 2e-6 },
        &|_, _| {},
    );
    assert!(err.is_err());
}

#[test]
fn bifurcation_collects_impact_velocities() {
    let spec = BifurcationSpec {
        system: System::paper_damped(1e-4, FrictionModel::None, 1.0),
        axis: Axis::GapM,
        init: State::REST,
        duration_s: 0.1,
        transient_s: 0.05,
        phase_rad: 0.0,
        impact_wall: Some(Wall::Minus),
    };
    let b = bifurcation(&spec, &[1e-4, 2e-3], &Rk4 { dt_s: 2e-6 }, &|_, _| {}).unwrap();
    // 0.1 mm impacts at resonance, a 2 mm gap does not (the bar amplitude is ≈ 0.08 mm).
    assert!(b
        .impacts
        .iter()
        .any(|i| i.param.to_bits() == 1e-4f64.to_bits()));
    assert!(b
        .impacts
        .iter()
        .all(|i| i.param.to_bits() == 1e-4f64.to_bits() && i.wall == Wall::Minus));
    assert!(b.impacts.iter().all(|i| i.dw_m_s < 0.0 && i.t_s >= 0.05));
}
