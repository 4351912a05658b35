//! FRFs of every model (`analysis::frf`) against closed forms and independent computations:
//! the one-mode receptance at resonance, the stuck lumped bar as one mode of mass M + m_d, the
//! Sherman–Morrison stuck receptance against a direct solve of the modal equations with the
//! ball's mass added, the stepped sine at a force too small for impacts against the linear FRF
//! (ball free when frictionless, ball stuck under Coulomb sticking) to 1e-9, the tap test's H1
//! against the linear receptance, and bad input.

use num_complex::Complex64;
use std::f64::consts::PI;
use vibrobar_core::analysis::frf::{
    frequency_lines_hz, half_sine_spectrum, linear_frf, linear_receptance, stepped_sine, tap_test,
    ResponsePoint, SteppedSine, TapTest, MAX_FRF_LINES,
};
use vibrobar_core::analysis::Runner;
use vibrobar_core::params::BarModel;
use vibrobar_core::solver::Exact;
use vibrobar_core::structure::{ModalModel, Mode, Point, Structure};
use vibrobar_core::{Bar, FrictionModel, State, System};

fn rel(a: Complex64, b: Complex64) -> f64 {
    (a - b).norm() / b.norm()
}

/// Three modes whose force, response and cavity shapes all differ.
fn three_modes() -> ModalModel {
    let m = |f_hz: f64, zeta: f64, mass: f64, c: f64, fo: f64, r: f64| Mode {
        omega_rad_s: 2.0 * PI * f_hz,
        damping_ratio: zeta,
        modal_mass_kg: mass,
        shape_cavity: c,
        shape_force: fo,
        shape_response: r,
    };
    Structure::Measured(vec![
        m(597.5, 0.01, 0.156, 0.70, 1.0, 0.9),
        m(3588.7, 0.02, 0.163, -0.015, 1.0, 0.6),
        m(10057.0, 0.015, 0.176, -0.55, 1.0, -0.3),
    ])
    .modal_model()
    .unwrap()
}

fn paper_damped(friction: FrictionModel, gap_m: f64) -> System {
    System::paper_damped(gap_m, friction, 1.0)
}

fn modal_damped(friction: FrictionModel, gap_m: f64) -> System {
    System {
        bar: BarModel::Modal(three_modes()),
        ..paper_damped(friction, gap_m)
    }
}

/// Solve `A x = b` for a small dense complex system (Gaussian elimination, partial pivoting).
#[allow(clippy::needless_range_loop)] // textbook index form
fn solve(mut a: Vec<Vec<Complex64>>, mut b: Vec<Complex64>) -> Vec<Complex64> {
    let n = b.len();
    for k in 0..n {
        let p = (k..n)
            .max_by(|&i, &j| a[i][k].norm().total_cmp(&a[j][k].norm()))
            .unwrap();
        a.swap(k, p);
        b.swap(k, p);
        for i in k + 1..n {
            let f = a[i][k] / a[k][k];
            for j in k..n {
                let akj = a[k][j];
                a[i][j] -= f * akj;
            }
            let bk = b[k];
            b[i] -= f * bk;
        }
    }
    let mut x = vec![Complex64::new(0.0, 0.0); n];
    for k in (0..n).rev() {
        let mut s = b[k];
        for j in k + 1..n {
            s -= a[k][j] * x[j];
        }
        x[k] = s / a[k][k];
    }
    x
}

#[test]
fn one_mode_receptance_at_resonance_is_minus_i_over_2_zeta_k() {
    let bar = Bar::PAPER_CAVITY;
    let model = Structure::Lumped(bar).modal_model().unwrap();
    let wn = bar.natural_freq_rad_s();
    let g = linear_receptance(&model, None, Point::Force, Point::Response, wn);
    let expect = Complex64::new(
        0.0,
        -1.0 / (2.0 * bar.damping_ratio * bar.stiffness_n_per_m),
    );
    assert!(rel(g, expect) < 1e-13, "{g} vs {expect}");
}

#[test]
fn stuck_lumped_bar_is_one_mode_of_mass_m_plus_md() {
    let bar = Bar::PAPER_CAVITY;
    let md = 0.026;
    let model = Structure::Lumped(bar).modal_model().unwrap();
    let c = bar.damping_n_s_per_m();
    for f in [100.0, 550.0, 580.0, 590.0, 600.0, 1200.0, 5000.0] {
        let w = 2.0 * PI * f;
        let g = linear_receptance(&model, Some(md), Point::Force, Point::Response, w);
        let expect =
            1.0 / Complex64::new(bar.stiffness_n_per_m - w * w * (bar.mass_kg + md), w * c);
        assert!(rel(g, expect) < 1e-12, "{f} Hz: {g} vs {expect}");
    }
}

#[test]
fn sherman_morrison_equals_a_direct_solve_with_the_ball_mass_added() {
    let model = three_modes();
    let md = 0.05;
    let pts = [Point::Force, Point::Cavity, Point::Response];
    for f in [50.0, 500.0, 597.5, 650.0, 2000.0, 3588.7, 9000.0, 20000.0] {
        let w = 2.0 * PI * f;
        let n = model.len();
        let phi = |p: Point| -> Vec<f64> { model.modes().iter().map(|m| m.shape(p)).collect() };
        let pd = phi(Point::Cavity);
        let mut a = vec![vec![Complex64::new(0.0, 0.0); n]; n];
        for (i, m) in model.modes().iter().enumerate() {
            let k = m.modal_stiffness_n_per_m();
            let c = 2.0 * m.damping_ratio * m.omega_rad_s * m.modal_mass_kg;
            a[i][i] = Complex64::new(k - w * w * m.modal_mass_kg, w * c);
            for j in 0..n {
                a[i][j] -= w * w * md * pd[i] * pd[j];
            }
        }
        for from in pts {
            let q = solve(a.clone(), phi(from).iter().map(|&x| x.into()).collect());
            for to in pts {
                let direct: Complex64 = phi(to).iter().zip(&q).map(|(p, x)| p * x).sum();
                let g = linear_receptance(&model, Some(md), from, to, w);
                assert!(
                    rel(g, direct) < 1e-11,
                    "{f} Hz {from:?}→{to:?}: {g} vs {direct}"
                );
            }
        }
    }
}

fn spec(force_n: f64, response: ResponsePoint) -> SteppedSine {
    SteppedSine {
        force_amplitude_n: force_n,
        settle_s: None,
        measure_periods: 40,
        response,
    }
}

/// The stepped sine of `sys` at `lines` against the linear FRF (`stuck`: the ball's mass) to
/// `tol`, without an impact; also RMS = |G| F0/√2.
fn check_stepped_sine(
    sys: &System,
    stuck: Option<f64>,
    force_n: f64,
    response: ResponsePoint,
    lines: &[f64],
    tol: f64,
) -> f64 {
    let rows = stepped_sine(
        sys,
        &State::REST,
        &spec(force_n, response),
        lines,
        &Exact::default(),
        Runner::default(),
    )
    .unwrap();
    let model = sys.modal_model();
    let linear = linear_frf(&model, stuck, Point::Force, response.point(), lines).unwrap();
    let mut worst: f64 = 0.0;
    for (r, g) in rows.iter().zip(&linear) {
        let e = rel(r.first_harmonic_m_per_n, *g);
        worst = worst.max(e);
        assert!(
            e < tol,
            "{} Hz: {} vs {g} (rel {e:e})",
            r.frequency_hz,
            r.first_harmonic_m_per_n
        );
        assert_eq!(r.impacts, 0, "{} Hz", r.frequency_hz);
        let rms = g.norm() * force_n / 2f64.sqrt();
        assert!((r.rms_m - rms).abs() < tol * rms, "{} vs {rms}", r.rms_m);
    }
    worst
}

#[test]
fn stepped_sine_without_impacts_is_the_ball_free_frf_when_frictionless() {
    let sys = paper_damped(FrictionModel::None, 0.1e-3);
    let f1 = sys.omega1_rad_s() / (2.0 * PI);
    let lines: Vec<f64> = [0.5, 0.9, 0.98, 1.0, 1.01, 1.05, 2.0, 3.3]
        .iter()
        .map(|r| r * f1)
        .collect();
    let worst = check_stepped_sine(&sys, None, 1.0, ResponsePoint::Response, &lines, 1e-9);
    eprintln!("lumped frictionless: worst relative error {worst:e}");
    let sys = modal_damped(FrictionModel::None, 0.1e-3);
    let lines = [200.0, 590.0, 597.5, 605.0, 2000.0, 3588.7, 7000.0, 10057.0];
    for p in [ResponsePoint::Response, ResponsePoint::Cavity] {
        let worst = check_stepped_sine(&sys, None, 1.0, p, &lines, 1e-9);
        eprintln!("3 modes frictionless {p:?}: worst relative error {worst:e}");
    }
}

#[test]
fn stepped_sine_without_slip_is_the_ball_stuck_frf_under_coulomb() {
    let sys = paper_damped(FrictionModel::Coulomb, 0.1e-3);
    let md = sys.damper.unwrap().ball_mass_kg;
    let f1 = sys.omega1_rad_s() / (2.0 * PI);
    let fs = f1 * (0.644f64 / (0.644 + md)).sqrt();
    let lines: Vec<f64> = [0.5, 0.95, 0.99, 1.0, 1.02, 2.0]
        .iter()
        .map(|r| r * fs)
        .collect();
    let worst = check_stepped_sine(&sys, Some(md), 1e-3, ResponsePoint::Response, &lines, 1e-9);
    eprintln!("lumped coulomb: worst relative error {worst:e}");
    let sys = modal_damped(FrictionModel::Coulomb, 0.1e-3);
    let lines = [200.0, 580.0, 590.0, 2000.0, 3588.7, 7000.0];
    for p in [ResponsePoint::Response, ResponsePoint::Cavity] {
        let worst = check_stepped_sine(&sys, Some(md), 1e-3, p, &lines, 1e-9);
        eprintln!("3 modes coulomb {p:?}: worst relative error {worst:e}");
    }
}

#[test]
fn stepped_sine_with_impacts_lowers_the_resonant_response() {
    // The paper's case (15 N, 0.1 mm, frictionless, r = 1): the ball impacts and the first
    // harmonic at resonance falls well below the linear bar's.
    let sys = paper_damped(FrictionModel::None, 0.1e-3);
    let f1 = sys.omega1_rad_s() / (2.0 * PI);
    let rows = stepped_sine(
        &sys,
        &State::REST,
        &spec(15.0, ResponsePoint::Response),
        &[f1],
        &Exact::default(),
        Runner::default(),
    )
    .unwrap();
    let g = linear_receptance(
        &sys.modal_model(),
        None,
        Point::Force,
        Point::Response,
        2.0 * PI * f1,
    );
    assert!(rows[0].impacts > 0);
    assert!(rows[0].impacts_per_cycle > 0.5);
    assert!(
        rows[0].first_harmonic_m_per_n.norm() < 0.5 * g.norm(),
        "{} vs {}",
        rows[0].first_harmonic_m_per_n.norm(),
        g.norm()
    );
}

#[test]
fn half_sine_spectrum_matches_quadrature() {
    let (p, tau) = (100.0, 2e-4);
    for omega in [0.0, 1000.0, PI / tau, 0.7 * PI / tau, 3.0 * PI / tau, 2e5] {
        let n = 20000;
        let h = tau / n as f64;
        let mut s = Complex64::new(0.0, 0.0);
        for k in 0..n {
            let t = (k as f64 + 0.5) * h;
            s += Complex64::from_polar(1.0, -omega * t) * (p * (PI * t / tau).sin() * h);
        }
        let f = half_sine_spectrum(p, tau, omega);
        assert!((f - s).norm() < 1e-8 * p * tau, "ω = {omega}: {f} vs {s}");
    }
}

fn tap(force_n: f64, taps: usize) -> TapTest {
    TapTest {
        peak_force_n: force_n,
        pulse_duration_s: 1e-4,
        taps,
        sample_rate_hz: None,
        record_s: None,
        response: ResponsePoint::Response,
    }
}

/// H1 of a tap test of `sys` against the linear receptance; returns the worst relative error.
fn check_tap(sys: &System, stuck: Option<f64>, t: &TapTest, lines: &[f64], tol: f64) -> f64 {
    let (rows, summary) = tap_test(sys, t, lines, Runner::default()).unwrap();
    assert!(summary.impacts_per_tap.iter().all(|&n| n == 0));
    let linear = linear_frf(
        &sys.modal_model(),
        stuck,
        Point::Force,
        t.response.point(),
        lines,
    )
    .unwrap();
    let mut worst: f64 = 0.0;
    for (r, g) in rows.iter().zip(&linear) {
        let e = rel(r.h1_m_per_n, *g);
        worst = worst.max(e);
        assert!(
            e < tol,
            "{} Hz: {} vs {g} ({e:e})",
            r.frequency_hz,
            r.h1_m_per_n
        );
        assert!((r.coherence - 1.0).abs() < 1e-9, "{}", r.coherence);
    }
    worst
}

/// Tolerances: H1 differs from G by the record's truncation (the default record ends when the
/// slowest mode has decayed by 1e-8, so the missing tail is ~1e-8 of the peak response) and by
/// the aliases of the response's samples, `Σ_{k≠0} X(f + k·fs) / X(f)`, which grow with the
/// line's frequency against `fs` (20 × the highest line by default) and with modes above the
/// band. Measured: 3e-8 to 4e-8 on the lumped bar (lines 300–900 Hz; 1e-6 asked), 2.2e-6 on the
/// three modes up to 12 kHz at the cavity (2e-5 asked).
#[test]
fn tap_test_h1_is_the_linear_receptance_without_impacts() {
    let lines: Vec<f64> = (0..=30).map(|k| 300.0 + 20.0 * k as f64).collect();
    // The solid bar, and the damped bar tapped too softly for the ball to reach a wall.
    let solid = System::paper_solid(1.0);
    let sys = System {
        damper: None,
        ..solid
    };
    let w = check_tap(&sys, None, &tap(100.0, 1), &lines, 1e-6);
    eprintln!("tap, solid bar: worst relative error {w:e}");
    let free = paper_damped(FrictionModel::None, 0.1e-3);
    let w = check_tap(&free, None, &tap(1.0, 3), &lines, 1e-6);
    eprintln!("tap, ball free: worst relative error {w:e}");
    let stuck = paper_damped(FrictionModel::Coulomb, 0.1e-3);
    let w = check_tap(&stuck, Some(0.026), &tap(1e-3, 3), &lines, 1e-6);
    eprintln!("tap, ball stuck: worst relative error {w:e}");
    let modal = modal_damped(FrictionModel::None, 0.1e-3);
    let lines: Vec<f64> = (1..=60).map(|k| 200.0 * k as f64).collect();
    let t = TapTest {
        response: ResponsePoint::Cavity,
        ..tap(1.0, 2)
    };
    let w = check_tap(&modal, None, &t, &lines, 2e-5);
    eprintln!("tap, 3 modes at the cavity: worst relative error {w:e}");
}

#[test]
fn tap_test_of_a_bar_with_a_ball_depends_on_the_tap_force() {
    let sys = paper_damped(FrictionModel::None, 0.1e-3);
    let f1 = sys.omega1_rad_s() / (2.0 * PI);
    let lines = [0.9 * f1, f1, 1.1 * f1];
    let g = linear_receptance(
        &sys.modal_model(),
        None,
        Point::Force,
        Point::Response,
        2.0 * PI * f1,
    );
    let (soft, s) = tap_test(&sys, &tap(1.0, 4), &lines, Runner::default()).unwrap();
    let (hard, h) = tap_test(&sys, &tap(2000.0, 4), &lines, Runner::default()).unwrap();
    assert!(s.impacts_per_tap.iter().all(|&n| n == 0));
    assert!(
        h.impacts_per_tap.iter().all(|&n| n > 0),
        "{:?}",
        h.impacts_per_tap
    );
    assert!(rel(soft[1].h1_m_per_n, g) < 1e-5);
    // The impacts take energy out: the hard tap's resonance is lower and the taps differ.
    assert!(hard[1].h1_m_per_n.norm() < 0.9 * g.norm());
    assert!(hard.iter().any(|r| r.coherence < 0.999), "{hard:?}");
}

#[test]
fn frequency_lines_refuse_bad_bands_naming_the_field() {
    let f = "--band-hz";
    assert_eq!(
        frequency_lines_hz(f, 100.0, 200.0, 50.0).unwrap(),
        [100.0, 150.0, 200.0]
    );
    for (a, b, c, what) in [
        (0.0, 100.0, 1.0, "START"),
        (-5.0, 100.0, 1.0, "START"),
        (100.0, 50.0, 1.0, "STOP"),
        (100.0, 200.0, 0.0, "STEP"),
        (100.0, 200.0, -1.0, "STEP"),
        (100.0, 2e7, 1e3, "STOP"),
    ] {
        let e = frequency_lines_hz(f, a, b, c).unwrap_err().to_string();
        assert!(e.contains(f) && e.contains(what), "{e}");
    }
    for (a, b, c) in [
        (f64::NAN, 1.0, 1.0),
        (1.0, f64::INFINITY, 1.0),
        (1.0, 2.0, f64::NAN),
    ] {
        let e = frequency_lines_hz(f, a, b, c).unwrap_err().to_string();
        assert!(e.contains("finite"), "{e}");
    }
    let e = frequency_lines_hz(f, 1.0, 1e6, 1e-3)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(&format!("{MAX_FRF_LINES}")) || e.contains("1e5"),
        "{e}"
    );
    let model = three_modes();
    for lines in [vec![], vec![100.0, -1.0], vec![f64::NAN], vec![0.0]] {
        let e = linear_frf(&model, None, Point::Force, Point::Response, &lines).unwrap_err();
        assert!(e.to_string().contains("frequency lines"), "{e}");
    }
    let e = linear_frf(&model, Some(-1.0), Point::Force, Point::Response, &[1.0]).unwrap_err();
    assert!(e.to_string().contains("ball_mass_kg"), "{e}");
}

#[test]
fn stepped_sine_and_tap_settings_are_checked_naming_the_flag() {
    let sys = paper_damped(FrictionModel::None, 0.1e-3);
    let run = |s: SteppedSine| {
        stepped_sine(
            &sys,
            &State::REST,
            &s,
            &[600.0],
            &Exact::default(),
            Runner::default(),
        )
        .unwrap_err()
        .to_string()
    };
    let ok = spec(1.0, ResponsePoint::Response);
    for (s, flag) in [
        (
            SteppedSine {
                force_amplitude_n: f64::NAN,
                ..ok
            },
            "--force-n",
        ),
        (
            SteppedSine {
                force_amplitude_n: 0.0,
                ..ok
            },
            "--force-n",
        ),
        (
            SteppedSine {
                measure_periods: 0,
                ..ok
            },
            "--measure-periods",
        ),
        (
            SteppedSine {
                settle_s: Some(-1.0),
                ..ok
            },
            "--settle-s",
        ),
        (
            SteppedSine {
                settle_s: Some(f64::NAN),
                ..ok
            },
            "--settle-s",
        ),
    ] {
        let e = run(s);
        assert!(e.contains(flag), "{e}");
    }
    // An undamped bar never settles: the settling time must be given.
    let mut undamped = sys;
    if let BarModel::Lumped(b) = &mut undamped.bar {
        b.damping_ratio = 0.0;
    }
    let e = stepped_sine(
        &undamped,
        &State::REST,
        &ok,
        &[500.0],
        &Exact::default(),
        Runner::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("--settle-s"), "{e}");
    let t = |t: TapTest, lines: &[f64]| {
        tap_test(&sys, &t, lines, Runner::default())
            .unwrap_err()
            .to_string()
    };
    let ok = tap(1.0, 2);
    for (s, flag) in [
        (
            TapTest {
                peak_force_n: -1.0,
                ..ok
            },
            "--tap-force-n",
        ),
        (
            TapTest {
                pulse_duration_s: 0.0,
                ..ok
            },
            "--tap-duration-s",
        ),
        (TapTest { taps: 0, ..ok }, "--taps"),
        (
            TapTest {
                taps: 100_000,
                ..ok
            },
            "--taps",
        ),
        (
            TapTest {
                sample_rate_hz: Some(1000.0),
                ..ok
            },
            "--sample-rate-hz",
        ),
        (
            TapTest {
                record_s: Some(1e-5),
                ..ok
            },
            "--record-s",
        ),
        (
            TapTest {
                record_s: Some(1e4),
                sample_rate_hz: Some(1e6),
                ..ok
            },
            "--record-s",
        ),
    ] {
        let e = t(s, &[600.0]);
        assert!(e.contains(flag), "{e}");
    }
    let e = t(ok, &[]);
    assert!(e.contains("frequency lines"), "{e}");
}
