//! Newton's method on the stroboscopic map (`analysis::orbit`) against independent computations:
//! the analytic symmetric two-impact orbit (RMS, impact phase and velocity), finite differences
//! of the exact solver for the monodromy matrix, and the growth of simulated perturbations for
//! the Floquet multipliers. Bad input: the period's range and a Newton that does not converge.
mod common;

use vibrobar_core::analysis::orbit::*;
use vibrobar_core::solver::{EventKind, Wall};
use vibrobar_core::*;

fn paper(gap_m: f64, ratio: f64) -> System {
    System::paper_damped(gap_m, FrictionModel::None, ratio)
}

/// The paper's bar with e = 0.8, 0.1 mm gap, r = 0.9: two symmetric orbits, one stable (as in
/// `exact_periodic_orbit.rs`).
fn two_branch_case() -> System {
    let mut sys = paper(0.1e-3, 0.9);
    sys.damper.as_mut().unwrap().restitution = 0.8;
    sys
}

fn cases() -> Vec<(System, usize)> {
    let mut v: Vec<(System, usize)> = [0.06e-3, 0.08e-3, 0.09e-3, 0.1e-3]
        .iter()
        .map(|&g| (paper(g, 1.0), 0))
        .collect();
    v.push((two_branch_case(), 0));
    v.push((two_branch_case(), 1));
    v
}

#[test]
fn newton_converges_to_the_analytic_symmetric_orbit_from_a_perturbed_start() {
    for (sys, i) in cases() {
        let o = symmetric_orbits(&sys).unwrap()[i];
        let (sec, x0) = starting_guess(&sys, 1, &Start::Symmetric(i)).unwrap();
        let sc = scales(&sys);
        // 2 % of each scale off the orbit (w inward).
        let guess = [
            x0[0] + 0.02 * sc[0],
            x0[1] - 0.02 * sc[1],
            x0[2] - 0.02 * sc[2] * x0[2].signum(),
            x0[3] + 0.02 * sc[3],
        ];
        for jac in [
            &ExactJacobian as &dyn MapJacobian,
            &FiniteDifference::default(),
        ] {
            let orb = find_orbit(&sec, &guess, jac, &NewtonSettings::default()).unwrap();
            assert!(orb.iterations >= 1 && orb.residual <= 1e-9, "{orb:?}");
            assert!(((orb.rms_m - o.rms_m(&sys)) / o.rms_m(&sys)).abs() < 1e-9);
            assert_eq!(orb.impacts_per_period, 2);
            assert!(orb.symmetry_defect().unwrap().unwrap() < 1e-9);
            assert!(orb.physicality.confined);
            let t = sys.forcing_period_s();
            let plus = orb
                .events
                .iter()
                .find(|e| {
                    matches!(
                        e.kind,
                        EventKind::Impact {
                            wall: Wall::Plus,
                            ..
                        }
                    )
                })
                .unwrap();
            let EventKind::Impact { dw_m_s, .. } = plus.kind else {
                unreachable!()
            };
            let ph = ((sec.t0_s + plus.dt_s - o.t0) / t).rem_euclid(1.0);
            assert!(
                ph.min(1.0 - ph) < 1e-9,
                "impact phase off by {ph:e} periods"
            );
            let dw = o.impact_speed_m_s();
            assert!(((dw_m_s - dw) / dw).abs() < 1e-8, "{dw_m_s} vs {dw}");
        }
    }
}

#[test]
fn newton_from_a_settled_run_finds_the_stable_symmetric_orbit() {
    let sys = paper(0.08e-3, 1.0);
    let o = symmetric_orbits(&sys).unwrap()[0];
    let (sec, x0) = starting_guess(
        &sys,
        1,
        &Start::Settled {
            init: State::REST,
            settle_s: 0.4,
        },
    )
    .unwrap();
    let orb = find_orbit(&sec, &x0, &ExactJacobian, &NewtonSettings::default()).unwrap();
    assert!(orb.stable());
    assert!(((orb.rms_m - o.rms_m(&sys)) / o.rms_m(&sys)).abs() < 1e-9);
    assert_eq!(orb.sequence.len(), 2);
}

#[test]
fn exact_jacobian_matches_finite_differences() {
    for (sys, i) in cases() {
        let (sec, x0) = starting_guess(&sys, 1, &Start::Symmetric(i)).unwrap();
        let orb = find_orbit(&sec, &x0, &ExactJacobian, &NewtonSettings::default()).unwrap();
        let x = to_vector(&orb.state);
        let (_, fd) = FiniteDifference::default()
            .map_and_jacobian(&sec, &x)
            .unwrap();
        let (_, ex) = ExactJacobian.map_and_jacobian(&sec, &x).unwrap();
        // Entries relative to their row and column scales.
        let sc = scales(&sys);
        for r in 0..4 {
            for c in 0..4 {
                let d = (fd[(r, c)] - ex[(r, c)]) * sc[c] / sc[r];
                assert!(
                    d.abs() < 1e-6,
                    "entry ({r}, {c}): {} vs {}",
                    fd[(r, c)],
                    ex[(r, c)]
                );
            }
        }
        let (a, b) = (multipliers_of(&fd), multipliers_of(&ex));
        for (l, m) in a.iter().zip(&b) {
            assert!((l - m).norm() < 1e-6, "{a:?} vs {b:?}");
        }
    }
}

/// Slope of `ln |P^n(x + δ) − x|` over `n`, fitted by least squares: the growth rate of a
/// simulated perturbation, to compare with `ln max |λ|`.
fn growth_rate(sec: &Section, x: &[f64; 4], eps: f64, n: usize) -> f64 {
    let sc = scales(&sec.system);
    let mut y = sec.clamp([0, 1, 2, 3].map(|i| x[i] + eps * sc[i] * [0.5, -0.3, -0.6, 0.55][i]));
    let mut pts = Vec::new();
    for k in 1..=n {
        y = sec.flow(&y).unwrap();
        let d = (0..4)
            .map(|i| ((y[i] - x[i]) / sc[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        if k > 5 {
            pts.push((k as f64, d.ln()));
        }
    }
    let m = pts.len() as f64;
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (mx, my) = (sx / m, sy / m);
    let num: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let den: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    num / den
}

#[test]
fn largest_multiplier_predicts_simulated_perturbation_growth() {
    // Unstable (a complex pair outside, 0.1 mm) and stable (0.08 mm) orbits at r = 1.
    for (gap, eps, n) in [(0.1e-3, 1e-10, 40), (0.08e-3, 1e-6, 60)] {
        let sys = paper(gap, 1.0);
        let (sec, x0) = starting_guess(&sys, 1, &Start::Symmetric(0)).unwrap();
        let orb = find_orbit(&sec, &x0, &ExactJacobian, &NewtonSettings::default()).unwrap();
        let want = orb.max_abs_multiplier().ln();
        let got = growth_rate(&sec, &to_vector(&orb.state), eps, n);
        assert!(
            (got - want).abs() < 0.03 * want.abs().max(0.1),
            "gap {gap}: growth {got} per period, ln max|λ| = {want}"
        );
    }
}

#[test]
fn bad_periods_are_refused_naming_the_flag() {
    let sys = paper(0.08e-3, 1.0);
    for k in [0, MAX_ORBIT_PERIOD + 1, u32::MAX] {
        let e = Section::new(sys, 0.0, k).unwrap_err().to_string();
        assert!(e.contains("--period") && e.contains("[1, 64]"), "{e}");
        let e = starting_guess(&sys, k, &Start::Symmetric(0))
            .unwrap_err()
            .to_string();
        assert!(e.contains("--period"), "{e}");
    }
}

#[test]
fn newton_that_does_not_converge_says_so_with_its_residual() {
    let sys = paper(0.08e-3, 1.0);
    let (sec, x0) = starting_guess(&sys, 1, &Start::Symmetric(0)).unwrap();
    let sc = scales(&sys);
    let far = [x0[0] + 3.0 * sc[0], x0[1], x0[2], x0[3] - 0.5 * sc[3]];
    let settings = NewtonSettings {
        max_iterations: 1,
        tolerance: 1e-9,
    };
    match find_orbit(&sec, &far, &ExactJacobian, &settings) {
        Err(e @ SimError::NoConvergence { residual, .. }) => {
            assert!(residual > 1e-9);
            let m = e.to_string();
            assert!(
                m.contains("did not converge") && m.contains("residual"),
                "{m}"
            );
        }
        other => panic!("expected NoConvergence, got {other:?}"),
    }
    // A period-2 "orbit" of the symmetric orbit is the same orbit: Newton on P² from it is at
    // rest at once, and a non-orbit is never returned (residual within tolerance).
    let (sec2, x2) = starting_guess(&sys, 2, &Start::Symmetric(0)).unwrap();
    let orb = find_orbit(&sec2, &x2, &ExactJacobian, &NewtonSettings::default()).unwrap();
    assert!(orb.residual <= 1e-9 && orb.impacts_per_period == 4);
}

#[test]
fn symmetric_orbit_rms_is_the_solver_rms_over_a_period() {
    // The closed-form RMS of the analytic orbit against the exact solver's ∫u² over the orbit
    // (an independent integral: segments' closed forms vs Simpson on the bar flow).
    let sys = two_branch_case();
    for (i, o) in symmetric_orbits(&sys).unwrap().iter().enumerate() {
        let (sec, x0) = starting_guess(&sys, 1, &Start::Symmetric(i)).unwrap();
        let orb = describe(&sec, &x0, nalgebra::DMatrix::identity(4, 4), "none", 0.0, 0).unwrap();
        assert!(((orb.rms_m - o.rms_m(&sys)) / o.rms_m(&sys)).abs() < 1e-9);
    }
}

#[test]
fn friction_only_orbit_has_den_hartogs_amplitude() {
    // Den Hartog (1931): an undamped bar with Coulomb friction to ground (a ball 1e9 times
    // heavier than the bar, gap far beyond the motion) moving without stops has the peak
    // X/(F0/K) = √(V0² − f²U²), V0 = 1/(1 − r²), U = sin(π/r)/(r(1 + cos(π/r))).
    use vibrobar_core::solver::{Event, Observer, Solver};
    struct Peaks(f64);
    impl Observer for Peaks {
        fn event(&mut self, ev: &Event) {
            if ev.kind == EventKind::FrictionSwitch {
                self.0 = self.0.max(ev.before.u_m.abs());
            }
        }
    }
    for (r, f) in [(0.6, 0.3), (0.8, 0.5), (1.5, 0.3)] {
        let (sys, _) = common::friction_to_ground(r, f);
        let k = sys.lumped_bar().unwrap().stiffness_n_per_m;
        // A short settling run only: Newton does the rest.
        let start = Start::Settled {
            init: State::REST,
            settle_s: 5.0 * sys.forcing_period_s(),
        };
        let (sec, x0) = starting_guess(&sys, 1, &start).unwrap();
        let orb = find_orbit(&sec, &x0, &ExactJacobian, &NewtonSettings::default()).unwrap();
        assert_eq!(orb.impacts_per_period, 0);
        assert_eq!(orb.sequence, "ff", "r={r} f={f}: motion with stops");
        let mut p = Peaks(0.0);
        vibrobar_core::solver::Exact::default()
            .run(&sys, &orb.state, sec.t0_s + sec.period_s(), &mut p)
            .unwrap();
        let v0 = 1.0 / (1.0 - r * r);
        let pr = std::f64::consts::PI / r;
        let u = pr.sin() / (r * (1.0 + pr.cos()));
        let want = (v0 * v0 - f * f * u * u).sqrt();
        let x = p.0 * k;
        assert!(
            ((x - want) / want).abs() < 1e-7,
            "r={r} f={f}: {x} vs {want}"
        );
    }
}
