//! Periodic orbits of the N-mode bar (`analysis::orbit::modal`): the one-mode bar with the
//! lumped bar's `M`, `K` against the lumped orbit, a multi-mode beam orbit's largest multiplier
//! against the growth of simulated perturbations, bad input.
use vibrobar_core::analysis::orbit::modal::*;
use vibrobar_core::analysis::orbit::*;
use vibrobar_core::params::{self, Damper, Forcing};
use vibrobar_core::structure::{Beam, MeasuredMode, ModalState, ModalSystem, Structure};
use vibrobar_core::*;

fn beam(n: usize, gap_m: f64, ratio: f64) -> ModalSystem {
    ModalSystem {
        model: Structure::Beam(Beam {
            modes: Some(n),
            ..Beam::default()
        })
        .modal_model()
        .unwrap(),
        damper: Some(Damper::paper(gap_m, FrictionModel::None)),
        forcing: Forcing::paper(ratio),
        gravity_m_s2: params::STANDARD_GRAVITY_M_S2,
    }
}

/// The lumped bar's one unit mode as a `[[modes]]` table (`frequency_hz = √(K/M)/2π`, `ζ`,
/// `modal_mass_kg = M`, `shape_cavity = 1`).
fn measured_one_mode(lumped: &System) -> ModalSystem {
    let bar = lumped.lumped_bar().unwrap();
    let mm = MeasuredMode {
        frequency_hz: bar.natural_freq_rad_s() / (2.0 * std::f64::consts::PI),
        damping_ratio: bar.damping_ratio,
        modal_mass_kg: bar.mass_kg,
        shape_cavity: 1.0,
    };
    ModalSystem {
        model: Structure::Measured(vec![mm.mode()]).modal_model().unwrap(),
        ..ModalSystem::from_lumped(lumped).unwrap()
    }
}

#[test]
fn one_unit_mode_reproduces_the_lumped_orbit_and_multipliers() {
    for gap in [0.06e-3, 0.08e-3, 0.09e-3] {
        let lumped = System::paper_damped(gap, FrictionModel::None, 1.0);
        let (sec, x0) = starting_guess(&lumped, 1, &Start::Symmetric(0)).unwrap();
        let lo = find_orbit(&sec, &x0, &ExactJacobian, &NewtonSettings::default()).unwrap();
        for (name, modal) in [
            ("unit mode", ModalSystem::from_lumped(&lumped).unwrap()),
            ("[[modes]] table", measured_one_mode(&lumped)),
        ] {
            let ms = ModalSection::new(modal, sec.t0_s, 1).unwrap();
            let mo = find_modal_orbit(&ms, &x0, &NewtonSettings::default()).unwrap();
            let xl = to_vector(&lo.state);
            let xm = mo.vector();
            let sc = scales(&lumped);
            let dx = (0..4)
                .map(|i| ((xl[i] - xm[i]) / sc[i]).abs())
                .fold(0.0, f64::max);
            let drms = ((mo.rms_m - lo.rms_m) / lo.rms_m).abs();
            let dl = lo
                .multipliers
                .iter()
                .zip(&mo.multipliers)
                .map(|(a, b)| (a - b).norm())
                .fold(0.0, f64::max);
            eprintln!(
                "{gap} {name}: state {dx:.2e}, rms {drms:.2e}, multipliers {dl:.2e} ({:?}), {} / {}",
                mo.multipliers, mo.sequence, lo.sequence
            );
            // The monodromy matrices agree to rounding; their eigenvalues amplify that by the
            // conditioning of the complex pairs (measured: 8e-11, 6e-11, 3e-9 at 0.06, 0.08,
            // 0.09 mm).
            let big = lo.jacobian.abs().max();
            let dj = (0..4)
                .flat_map(|r| (0..4).map(move |c| (r, c)))
                .map(|(r, c)| (lo.jacobian[(r, c)] - mo.jacobian[(r, c)]).abs())
                .fold(0.0, f64::max);
            eprintln!("  monodromy {:.2e} of {big:.2e}", dj / big);
            assert!(dx < 1e-9 && drms < 1e-9 && dl < 1e-8, "{name} at {gap}");
            assert!(dj < 1e-12 * big, "{name} at {gap}: {dj:e} of {big:e}");
            assert_eq!(mo.sequence, lo.sequence);
            assert_eq!(mo.impacts_per_period, 2);
            assert_eq!(mo.stable(), lo.stable());
            assert!(mo.physicality.confined);
        }
    }
}

/// The 4-mode paper beam at 0.1 mm, r = 1 (frictionless): Newton from a settled run finds the
/// two-impact orbit, unstable with a real multiplier ≈ 28. Two trajectories from the orbit and
/// from a perturbation of 1e-9 scaled units separate by that factor per period (the other
/// multipliers are below 1: after a few periods the largest alone sets the growth; measured
/// 28.109 against 28.116).
#[test]
fn four_mode_beam_multiplier_predicts_perturbation_growth() {
    let sys = beam(4, 0.1e-3, 1.0);
    let o = modal_orbit_settled(&sys, 1, &ModalState::REST, 0.5).unwrap();
    assert!(o.residual <= 1e-9 && o.physicality.confined);
    assert_eq!(o.impacts_per_period, 2);
    let l1 = o.multipliers[0];
    assert!(
        l1.im == 0.0 && l1.re > 1.0 && !o.stable(),
        "{:?}",
        o.multipliers
    );
    let sec = &o.section;
    let sc = sec.scales();
    let d = sec.dim();
    let mut a = o.vector();
    let mut b: Vec<f64> = (0..d)
        .map(|i| a[i] + 1e-9 * sc[i] * (1.0 + 0.1 * i as f64) * if i % 2 == 0 { 1.0 } else { -1.0 })
        .collect();
    b = sec.clamp(&b);
    let norm = |a: &[f64], b: &[f64]| -> f64 {
        (0..d)
            .map(|i| ((a[i] - b[i]) / sc[i]).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let mut prev = norm(&a, &b);
    let mut growth = 0.0;
    for m in 1..=4 {
        a = sec.flow(&a).unwrap();
        b = sec.flow(&b).unwrap();
        let now = norm(&a, &b);
        growth = now / prev;
        eprintln!(
            "period {m}: separation {now:.3e}, growth {growth:.4} (λ₁ = {:.4})",
            l1.re
        );
        prev = now;
    }
    assert!(
        (growth - l1.re).abs() < 0.01 * l1.re,
        "growth {growth} vs multiplier {}",
        l1.re
    );
}

#[test]
fn bad_input_is_refused_with_the_field_named() {
    let sys = beam(4, 0.1e-3, 1.0);
    for k in [0, MAX_ORBIT_PERIOD + 1] {
        let e = ModalSection::new(sys.clone(), 0.0, k)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--period"), "{e}");
    }
    let e = modal_starting_guess(&sys, 1, &ModalState::REST, 1e-4)
        .unwrap_err()
        .to_string();
    assert!(e.contains("--settle"), "{e}");
    let sec = ModalSection::new(sys.clone(), 0.0, 1).unwrap();
    // A start far from any orbit: Newton says so with the residual, never returns a non-orbit.
    let mut x = vec![0.0; sec.dim()];
    x[0] = 1e-3;
    let s = NewtonSettings {
        max_iterations: 2,
        tolerance: 1e-9,
    };
    let e = find_modal_orbit(&sec, &x, &s).unwrap_err().to_string();
    assert!(
        e.contains("did not converge") && e.contains("residual"),
        "{e}"
    );
    let e = find_modal_orbit(&sec, &x[..3], &s).unwrap_err().to_string();
    assert!(e.contains("2N + 2"), "{e}");
}
