//! The Lyapunov spectrum by QR of the variational flow (issue #11, item 5): the phase-volume
//! identity of the frictionless lumped bar, the determinant of each impact's saltation matrix,
//! and the largest exponent against the two-trajectory estimate.

use vibrobar_core::analysis::lyapunov::{max_lyapunov, LyapunovParams};
use vibrobar_core::analysis::lyapunov_spectrum::{lyapunov_spectrum, SpectrumParams};
use vibrobar_core::analysis::variational::{det4, Mat4, Step, TangentSink, Variational};
use vibrobar_core::params::{ContactLaw, FrictionModel, State, System};
use vibrobar_core::solver::{EventKind, Exact, Mode, Solver};

fn paper(gap_m: f64, friction: FrictionModel, e: f64) -> System {
    let mut sys = System::paper_damped(gap_m, friction, 1.0);
    sys.damper.as_mut().unwrap().restitution = e;
    sys
}

/// `−C/M + 2 ln(e) × impacts per second`.
fn predicted_sum(sys: &System, impacts_per_s: f64) -> f64 {
    let bar = sys.lumped_bar().unwrap();
    let e = sys.damper.unwrap().restitution;
    -bar.damping_n_s_per_m() / bar.mass_kg + 2.0 * e.ln() * impacts_per_s
}

/// Records the determinant of every tangent map with its step.
#[derive(Default)]
struct Dets(Vec<(Step, f64)>);

impl TangentSink for Dets {
    fn apply(&mut self, m: &Mat4, step: Step) {
        self.0.push((step, det4(m)));
    }
}

#[test]
fn every_impact_saltation_has_determinant_e_squared() {
    for (gap, e) in [(0.1e-3, 0.9), (0.08e-3, 0.5), (0.1e-3, 0.2)] {
        let sys = paper(gap, FrictionModel::None, e);
        let bar = *sys.lumped_bar().unwrap();
        let x = Exact::default()
            .run(&sys, &State::REST, 0.3, &mut ())
            .unwrap()
            .final_state;
        let mut var = Variational::new(&sys, Dets::default()).unwrap();
        Exact::default()
            .run(&sys, &x, x.t_s + 20.0 * sys.forcing_period_s(), &mut var)
            .unwrap();
        var.finish();
        let (mut impacts, mut free) = (0, 0);
        for (step, d) in &var.sink.0 {
            match *step {
                Step::Event {
                    kind: EventKind::Impact { .. },
                    plastic: false,
                    ..
                } => {
                    impacts += 1;
                    assert!((d - e * e).abs() < 1e-12, "gap {gap} e {e}: det S = {d}");
                }
                Step::Segment {
                    t0_s,
                    t1_s,
                    mode: Mode::Free,
                } => {
                    free += 1;
                    let want = (-bar.damping_n_s_per_m() / bar.mass_kg * (t1_s - t0_s)).exp();
                    assert!(
                        (d - want).abs() < 1e-12 * want,
                        "det Φ = {d}, e^(−Cτ/M) = {want}"
                    );
                }
                _ => {}
            }
        }
        assert!(
            impacts >= 20 && free >= 20,
            "gap {gap} e {e}: {impacts} impacts"
        );
    }
}

#[test]
fn spectrum_sum_is_the_phase_volume_identity() {
    // Frictionless, no impact accumulation (which would collapse directions): a chaotic point
    // (0.1 mm, e = 0.9) and the periodic two-impact orbit (0.08 mm, e = 0.5).
    for (gap, e) in [(0.1e-3, 0.9), (0.08e-3, 0.5)] {
        let sys = paper(gap, FrictionModel::None, e);
        let p = SpectrumParams::periods(&sys, 0.5, 3000.0);
        let sp = lyapunov_spectrum(&sys, &State::REST, &Exact::default(), &p).unwrap();
        assert_eq!(sp.collapsed, 0, "{sp:?}");
        assert_eq!(sp.events.grazing, 0);
        assert!(sp.impacts_per_s > 500.0, "{sp:?}");
        let want = predicted_sum(&sys, sp.impacts_per_s);
        eprintln!(
            "gap {gap} e {e}: λ = {:?}, Σ = {} 1/s, −C/M + 2 ln(e)·{} /s = {} 1/s",
            sp.exponents_per_s, sp.sum_per_s, sp.impacts_per_s, want
        );
        assert!(
            (sp.sum_per_s - want).abs() < 1e-9 * want.abs(),
            "Σλ = {} vs {want}",
            sp.sum_per_s
        );
        let l: Vec<f64> = sp.exponents_per_s.iter().map(|x| x.unwrap()).collect();
        // Ordered, up to the pairs of a periodic orbit's complex multipliers (equal exponents
        // that the finite window splits slightly).
        assert!(
            l.windows(2).all(|w| w[0] >= w[1] - 1e-3 * w[1].abs()),
            "{l:?}"
        );
    }
}

#[test]
fn largest_exponent_agrees_with_the_two_trajectory_estimate() {
    // Chaotic points: the paper's 0.1 mm gap at resonance, frictionless (e = 0.5 and 0.9) and
    // with Coulomb friction. Agreement within three combined standard errors.
    for (fm, e) in [
        (FrictionModel::None, 0.5),
        (FrictionModel::None, 0.9),
        (FrictionModel::Coulomb, 0.5),
    ] {
        let sys = paper(0.1e-3, fm, e);
        let sp = lyapunov_spectrum(
            &sys,
            &State::REST,
            &Exact::default(),
            &SpectrumParams::periods(&sys, 0.5, 5000.0),
        )
        .unwrap();
        let two = max_lyapunov(
            &sys,
            &State::REST,
            &Exact::default(),
            &LyapunovParams::periods(&sys, 0.5, 5.0, 1000),
        )
        .unwrap();
        let (l1, s1) = (
            sp.exponents_per_s[0].unwrap(),
            sp.std_error_per_s[0].unwrap(),
        );
        let tol = 3.0 * s1.hypot(two.std_error_per_s);
        eprintln!(
            "{fm:?} e {e}: QR λ₁ = {l1:.1} ± {s1:.1}, two-trajectory {:.1} ± {:.1} 1/s",
            two.exponent_per_s, two.std_error_per_s
        );
        assert!(l1 > 50.0, "chaotic point expected: {l1}");
        assert!(
            (l1 - two.exponent_per_s).abs() < tol,
            "{l1} vs {}",
            two.exponent_per_s
        );
    }
}

#[test]
fn stick_and_wall_contact_collapse_directions() {
    // Coulomb 8 N: the ball sticks twice a period; ẇ = 0 removes one dimension for good.
    let mut sys = paper(0.1e-3, FrictionModel::Coulomb, 0.5);
    sys.damper.as_mut().unwrap().friction_force_n = Some(8.0);
    let sp = lyapunov_spectrum(
        &sys,
        &State::REST,
        &Exact::default(),
        &SpectrumParams::periods(&sys, 0.3, 200.0),
    )
    .unwrap();
    assert!(sp.events.sticks > 100, "{sp:?}");
    assert_eq!(sp.collapsed, 1, "{sp:?}");
    assert!(sp.exponents_per_s[3].is_none() && sp.exponents_per_s[2].is_some());
    // The paper's point rides the walls after accumulating impacts: two dimensions go.
    let sys = paper(0.1e-3, FrictionModel::None, 0.5);
    let sp = lyapunov_spectrum(
        &sys,
        &State::REST,
        &Exact::default(),
        &SpectrumParams::periods(&sys, 0.3, 500.0),
    )
    .unwrap();
    assert!(sp.events.chatter_limits > 0);
    assert_eq!(sp.collapsed, 2, "{sp:?}");
}

#[test]
fn bad_input_is_a_clear_error() {
    let sys = paper(0.1e-3, FrictionModel::None, 0.5);
    let ok = SpectrumParams::periods(&sys, 0.1, 10.0);
    let run = |s: &System, p: &SpectrumParams| {
        lyapunov_spectrum(s, &State::REST, &Exact::default(), p)
            .unwrap_err()
            .to_string()
    };
    assert!(run(&sys, &SpectrumParams { blocks: 1, ..ok }).contains("blocks"));
    assert!(run(
        &sys,
        &SpectrumParams {
            duration_s: 0.0,
            ..ok
        }
    )
    .contains("duration_s"));
    assert!(run(
        &sys,
        &SpectrumParams {
            transient_s: f64::NAN,
            ..ok
        }
    )
    .contains("transient_s"));
    // The hertz law is no longer refused (its compliant phases have variational equations:
    // tests/variational_hertz.rs); the same settings give a finite spectrum.
    let mut hz = sys;
    hz.damper.as_mut().unwrap().contact.law = ContactLaw::Hertz;
    let sp = lyapunov_spectrum(&hz, &State::REST, &Exact::default(), &ok).unwrap();
    assert!(sp.sum_per_s.is_finite() && sp.collapsed == 0, "{sp:?}");
    let solid = System::paper_solid(1.0);
    assert!(run(&solid, &ok).contains("damper"));
    let rk4 = vibrobar_core::solver::Rk4 { dt_s: 1e-6 };
    let e = lyapunov_spectrum(&sys, &State::REST, &rk4, &ok).unwrap_err();
    assert!(e.to_string().contains("needs the exact solver"), "{e}");
}
