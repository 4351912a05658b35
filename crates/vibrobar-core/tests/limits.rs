//! Issue #7 A2/A4/A5: every size a user can inflate and every input that gave NaN, inf or
//! nonsense is refused before any work, naming the field and the allowed range.

use vibrobar_core::analysis::lyapunov::{max_lyapunov, LyapunovParams};
use vibrobar_core::analysis::run_case;
use vibrobar_core::limits;
use vibrobar_core::solver::{Exact, Rk4};
use vibrobar_core::{FrictionModel, ParamError, RunSettings, SimError, Solver, State, System};

fn param_err<T: std::fmt::Debug>(r: Result<T, SimError>) -> ParamError {
    match r {
        Err(SimError::Param(p)) => p,
        other => panic!("expected a parameter error, got {other:?}"),
    }
}

fn paper() -> System {
    System::paper_damped(0.1e-3, FrictionModel::None, 1.0)
}

fn settings(duration_s: f64, dt_s: f64) -> RunSettings {
    RunSettings {
        duration_s,
        dt_s,
        rms_fraction: 0.8,
    }
}

#[test]
fn regression_ratio_1e151_is_refused_instead_of_nan_rows() {
    let sys = System::paper_damped(0.1e-3, FrictionModel::None, 1e151);
    let e = sys.validate().unwrap_err();
    assert_eq!(e.field(), "forcing.frequency_ratio");
    assert_eq!(
        e.to_string(),
        "forcing.frequency_ratio = 1e151 is outside the allowed range [0.001, 1000] (Ω/√(K/M) of a one-mode bar)"
    );
    for solver in [&Exact::default() as &dyn Solver, &Rk4::default()] {
        let e = param_err(run_case(
            &sys,
            &State::REST,
            &settings(0.01, 1e-6),
            solver,
            &mut (),
        ));
        assert_eq!(e.field(), "forcing.frequency_ratio");
    }
    // The bounds themselves are fine.
    for r in [limits::FREQ_RATIO_MIN, limits::FREQ_RATIO_MAX] {
        let sys = System::paper_damped(0.1e-3, FrictionModel::None, r);
        let res = run_case(
            &sys,
            &State::REST,
            &settings(0.01, 1e-6),
            &Exact::default(),
            &mut (),
        )
        .unwrap();
        assert!(
            res.rms_m.is_finite() && res.impacts_per_cycle.is_finite(),
            "{res:?}"
        );
    }
}

#[test]
fn regression_rk4_dt_beyond_its_stability_limit_is_refused() {
    // `run --solver rk4 --dt 0.1` gave an RMS of 5.8e79 m with exit 0.
    let sys = paper();
    let wn = sys.lumped_bar().unwrap().natural_freq_rad_s();
    for dt in [0.1, 1e-3, 2.6 / wn] {
        let e = param_err(Rk4 { dt_s: dt }.run(&sys, &State::REST, 0.2, &mut ()));
        assert_eq!(e.field(), "dt_s (--dt)");
        let msg = e.to_string();
        assert!(
            msg.contains("stability") && msg.contains("allowed range [0, 6.6"),
            "{msg}"
        );
    }
    // Just inside the limit the run is stable (inaccurate, but bounded and finite).
    let r = Rk4 { dt_s: 2.4 / wn }
        .run(&sys, &State::REST, 0.2, &mut ())
        .unwrap();
    assert!(r.final_state.u_m.abs() < 1e-3, "{r:?}");
}

#[test]
fn regression_rk4_steps_are_bounded_before_the_run() {
    // `run --solver rk4 --dt 1e-320` ran until killed; 1e-12 and --duration 1e308 allocated.
    let sys = paper();
    for (dt, t_end) in [(1e-320, 2.0), (1e-12, 2.0), (1e-6, 1001.0)] {
        let t = std::time::Instant::now();
        let e = param_err(Rk4 { dt_s: dt }.run(&sys, &State::REST, t_end, &mut ()));
        assert_eq!(e.field(), "steps duration/dt (--duration, --dt)", "{e}");
        assert!(e.to_string().contains("[0, 1e9]"), "{e}");
        assert!(t.elapsed().as_secs_f64() < 1.0);
    }
}

#[test]
fn regression_huge_duration_is_refused_by_every_solver() {
    // `run --duration 1e308`, `map --duration 1e308`: refused before any step (phase limit).
    let sys = paper();
    for solver in [&Exact::default() as &dyn Solver, &Rk4::default()] {
        let e = param_err(solver.run(&sys, &State::REST, 1e308, &mut ()));
        assert!(e.field().starts_with("phase max(Ω, ω_n)·t_end"), "{e}");
        assert!(e.to_string().contains("[0, 1e10]"), "{e}");
    }
}

#[test]
fn regression_rms_window_shorter_than_a_step_is_refused() {
    // `map --rms-fraction=1e-320` gave NaN with exit 0.
    let s = RunSettings {
        rms_fraction: 1e-320,
        ..RunSettings::default()
    };
    let e = s.validate().unwrap_err();
    assert_eq!(e.field(), "rms_fraction (--rms-fraction)");
    assert!(e.to_string().contains("[5e-7, 1]"), "{e}");
    let e = param_err(run_case(
        &paper(),
        &State::REST,
        &s,
        &Exact::default(),
        &mut (),
    ));
    assert_eq!(e.field(), "rms_fraction (--rms-fraction)");
    // One step is enough.
    let s = RunSettings {
        rms_fraction: 5e-7,
        ..RunSettings::default()
    };
    assert!(s.validate().is_ok());
}

#[test]
fn regression_lyapunov_d0_below_rounding_is_refused() {
    // `lyapunov --d0=1e-320` reported λ = 8515 1/s.
    let sys = paper();
    let mut p = LyapunovParams::periods(&sys, 0.0, 5.0, 4);
    p.blocks = 2;
    for d0 in [1e-320, 1e-13, 0.5] {
        p.d0 = d0;
        let e = param_err(max_lyapunov(&sys, &State::REST, &Exact::default(), &p));
        assert_eq!(e.field(), "d0 (--d0)");
        assert!(e.to_string().contains("[1e-12, 0.01]"), "{e}");
    }
    p.d0 = 1e-9;
    p.intervals = limits::MAX_LYAPUNOV_INTERVALS + 1;
    let t = std::time::Instant::now();
    let e = param_err(max_lyapunov(&sys, &State::REST, &Exact::default(), &p));
    assert!(e.field().starts_with("intervals"), "{e}");
    assert!(t.elapsed().as_secs_f64() < 1.0);
}

#[test]
fn regression_non_finite_rms_is_an_error_not_a_result() {
    // The last line of defence: a force that passes validation (finite) but squares past the
    // largest float gives an error naming the quantity and the likely cause, never an inf row.
    let mut sys = System::paper_solid(1.0);
    sys.forcing.amplitude_n = 1e200;
    for solver in [&Exact::default() as &dyn Solver, &Rk4::default()] {
        let r = run_case(&sys, &State::REST, &settings(0.01, 1e-6), solver, &mut ());
        match r {
            Err(SimError::Param(ParamError::NonFiniteResult {
                quantity, cause, ..
            })) => {
                assert_eq!(quantity, "RMS of u");
                assert!(cause.contains("forces"), "{cause}");
            }
            Err(other) => panic!("{}: expected NonFiniteResult, got {other}", solver.name()),
            Ok(res) => panic!("{}: accepted {res:?}", solver.name()),
        }
    }
}

#[test]
fn regression_grid_and_ensemble_sizes_are_bounded() {
    use vibrobar_core::analysis::ensemble::{EnsembleParams, IcRanges};
    use vibrobar_core::analysis::map::{Axis, Grid, GridAxis};
    // A 9.4e9-point map allocated until killed: the product is checked before any point exists.
    let axis = |axis, n: usize| GridAxis {
        axis,
        values: (0..n).map(|i| 1.0 + i as f64).collect(),
    };
    let e = Grid::new(vec![
        axis(Axis::FreqRatio, 100_000),
        axis(Axis::GapM, 94_000),
    ])
    .unwrap_err();
    assert!(e.field().starts_with("grid points"), "{e}");
    assert!(
        e.to_string().contains("9.4e9") && e.to_string().contains("[1, 1e7]"),
        "{e}"
    );
    assert!(Grid::new(vec![axis(Axis::FreqRatio, 1000), axis(Axis::GapM, 10_000)]).is_ok());
    // `ensemble --members 1000000000`.
    let p = EnsembleParams {
        seed: 1,
        members: 1_000_000_000,
        ranges: IcRanges {
            u_m: (0.0, 0.0),
            du_m_s: (0.0, 0.0),
            w_over_half_gap: (-1.0, 1.0),
            dw_m_s: (0.0, 0.0),
        },
    };
    let e = p.validate().unwrap_err();
    assert!(
        e.to_string().contains("1e9") && e.to_string().contains("[1, 100000]"),
        "{e}"
    );
}
