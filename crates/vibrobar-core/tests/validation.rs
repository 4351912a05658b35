//! Every parameter error: bad input gives a `ParamError` that names the field and the allowed
//! range, and `Solver::run` / `run_case` return `Err` instead of panicking.

use vibrobar_core::analysis::run_case;
use vibrobar_core::solver::Rk4;
use vibrobar_core::{FrictionModel, ParamError, RunSettings, SimError, Solver, State, System};

fn field_of(e: &ParamError) -> &'static str {
    e.field()
}

/// `sys` must be rejected by `validate`, by `Rk4::run` and by `run_case`, naming `field`; the
/// message names the field and, for finite values, the allowed range `allowed`.
fn rejects(sys: &System, field: &str, allowed: Option<&str>) {
    let e = sys
        .validate()
        .expect_err(&format!("{field}: accepted {sys:?}"));
    assert_eq!(field_of(&e), field, "wrong field in {e}");
    let msg = e.to_string();
    assert!(msg.contains(field), "message '{msg}' does not name {field}");
    match (&e, allowed) {
        (ParamError::OutOfRange { allowed: a, .. }, Some(want)) => {
            assert_eq!(*a, want, "allowed range of {field}");
            assert!(msg.contains(want), "message '{msg}' lacks the range {want}");
        }
        (ParamError::NotFinite { .. }, None) => {
            assert!(
                msg.contains("finite"),
                "message '{msg}' should ask for a finite number"
            )
        }
        _ => panic!("{field}: unexpected error kind {e:?} (want range {allowed:?})"),
    }
    let run = Rk4 { dt_s: 1e-6 }.run(sys, &State::REST, 1e-3, &mut ());
    assert!(
        matches!(run, Err(SimError::Param(ref p)) if field_of(p) == field),
        "Rk4::run with bad {field}: {run:?}"
    );
    let settings = RunSettings {
        duration_s: 1e-3,
        ..RunSettings::default()
    };
    let rc = run_case(sys, &State::REST, &settings, &Rk4::default(), &mut ());
    assert!(rc.is_err(), "run_case with bad {field} returned Ok");
}

fn damped() -> System {
    System::paper_damped(1e-3, FrictionModel::AsPublished, 1.0)
}

#[test]
fn non_positive_masses_stiffness_gap_and_ranges() {
    for bad in [0.0, -1.0] {
        let mut s = damped();
        s.bar.as_lumped_mut().unwrap().mass_kg = bad;
        rejects(&s, "bar.mass_kg", Some("(0, ∞)"));
        let mut s = damped();
        s.bar.as_lumped_mut().unwrap().stiffness_n_per_m = bad;
        rejects(&s, "bar.stiffness_n_per_m", Some("(0, ∞)"));
        let mut s = damped();
        s.damper.as_mut().unwrap().ball_mass_kg = bad;
        rejects(&s, "damper.ball_mass_kg", Some("(0, ∞)"));
        let mut s = damped();
        s.damper.as_mut().unwrap().gap_m = bad;
        rejects(&s, "damper.gap_m", Some("(0, ∞)"));
        let mut s = damped();
        s.damper.as_mut().unwrap().ball_radius_m = bad;
        rejects(&s, "damper.ball_radius_m", Some("(0, ∞)"));
    }
    for e in [-0.1, 1.0 + 1e-12, 2.0] {
        let mut s = damped();
        s.damper.as_mut().unwrap().restitution = e;
        rejects(&s, "damper.restitution", Some("[0, 1]"));
    }
    for z in [1.0, 1.5, -0.01] {
        let mut s = damped();
        s.bar.as_lumped_mut().unwrap().damping_ratio = z;
        rejects(&s, "bar.damping_ratio", Some("[0, 1)"));
    }
    let mut s = damped();
    s.damper.as_mut().unwrap().friction_force_n = Some(-1.0);
    rejects(&s, "damper.friction_force_n", Some("[0, ∞)"));
    // Limits that are allowed.
    for e in [0.0, 1.0] {
        let mut s = damped();
        s.damper.as_mut().unwrap().restitution = e;
        assert!(s.validate().is_ok(), "e = {e} must be allowed");
    }
    let mut s = damped();
    s.bar.as_lumped_mut().unwrap().damping_ratio = 0.0;
    assert!(s.validate().is_ok(), "ζ = 0 must be allowed");
}

#[test]
fn nan_and_inf_in_every_field() {
    type Set = fn(&mut System, f64);
    let fields: [(&str, Set); 12] = [
        ("bar.mass_kg", |s, x| {
            s.bar.as_lumped_mut().unwrap().mass_kg = x
        }),
        ("bar.stiffness_n_per_m", |s, x| {
            s.bar.as_lumped_mut().unwrap().stiffness_n_per_m = x
        }),
        ("bar.damping_ratio", |s, x| {
            s.bar.as_lumped_mut().unwrap().damping_ratio = x
        }),
        ("forcing.amplitude_n", |s, x| s.forcing.amplitude_n = x),
        ("forcing.static_force_n", |s, x| {
            s.forcing.static_force_n = x
        }),
        ("forcing.frequency_ratio", |s, x| {
            s.forcing.frequency = vibrobar_core::Frequency::Ratio(x)
        }),
        ("gravity_m_s2", |s, x| s.gravity_m_s2 = x),
        ("damper.ball_mass_kg", |s, x| {
            s.damper.as_mut().unwrap().ball_mass_kg = x
        }),
        ("damper.ball_radius_m", |s, x| {
            s.damper.as_mut().unwrap().ball_radius_m = x
        }),
        ("damper.restitution", |s, x| {
            s.damper.as_mut().unwrap().restitution = x
        }),
        ("damper.gap_m", |s, x| s.damper.as_mut().unwrap().gap_m = x),
        ("damper.rolling_friction_m", |s, x| {
            s.damper.as_mut().unwrap().rolling_friction_m = x
        }),
    ];
    for (field, set) in fields {
        for x in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut s = damped();
            set(&mut s, x);
            rejects(&s, field, None);
        }
    }
    let mut s = damped();
    s.forcing.frequency = vibrobar_core::Frequency::RadPerS(f64::NAN);
    rejects(&s, "forcing.omega_rad_s", None);
    let mut s = damped();
    s.damper.as_mut().unwrap().friction_force_n = Some(f64::INFINITY);
    rejects(&s, "damper.friction_force_n", None);
}

#[test]
fn initial_state_outside_the_cavity_or_not_finite() {
    let sys = damped(); // gap 1 mm: l_g = 0.5 mm
    for w in [0.5e-3 * (1.0 + 1e-9), -0.6e-3] {
        let init = State {
            v_m: w,
            ..State::REST
        };
        let e = init.validate(&sys).expect_err(&format!("w = {w} accepted"));
        assert_eq!(field_of(&e), "initial.w_m (v − u)", "{e}");
        assert!(
            e.to_string().contains("gap/2"),
            "message lacks the range: {e}"
        );
        let r = Rk4::default().run(&sys, &init, 1e-3, &mut ());
        assert!(
            matches!(r, Err(SimError::Param(_))),
            "Rk4::run from w = {w} m (l_g = 0.5 mm): {r:?}"
        );
    }
    // On the wall is allowed.
    let on_wall = State {
        v_m: 0.5e-3,
        ..State::REST
    };
    assert!(on_wall.validate(&sys).is_ok());
    let init = State {
        du_m_s: f64::NAN,
        ..State::REST
    };
    let e = init.validate(&sys).unwrap_err();
    assert_eq!(field_of(&e), "initial.du_m_s", "{e}");
}

#[test]
fn run_settings_dt_and_duration() {
    for bad in [0.0, -1e-6] {
        let st = RunSettings {
            dt_s: bad,
            ..RunSettings::default()
        };
        let e = st.validate().unwrap_err();
        assert_eq!(field_of(&e), "dt_s", "{e}");
        assert!(e.to_string().contains("(0, ∞)"), "{e}");
        let st = RunSettings {
            duration_s: bad,
            ..RunSettings::default()
        };
        let e = st.validate().unwrap_err();
        assert_eq!(field_of(&e), "duration_s", "{e}");
        assert!(e.to_string().contains("(0, ∞)"), "{e}");
        let r = run_case(&damped(), &State::REST, &st, &Rk4::default(), &mut ());
        assert!(matches!(r, Err(SimError::Param(_))), "{r:?}");
        // The solver itself checks its step.
        let r = Rk4 { dt_s: bad }.run(&damped(), &State::REST, 1e-3, &mut ());
        assert!(
            matches!(r, Err(SimError::Param(ref p)) if field_of(p) == "dt_s"),
            "Rk4 with dt = {bad}: {r:?}"
        );
    }
    for bad in [f64::NAN, f64::INFINITY] {
        let st = RunSettings {
            duration_s: bad,
            ..RunSettings::default()
        };
        assert_eq!(field_of(&st.validate().unwrap_err()), "duration_s");
        let st = RunSettings {
            dt_s: bad,
            ..RunSettings::default()
        };
        assert_eq!(field_of(&st.validate().unwrap_err()), "dt_s");
    }
    let st = RunSettings {
        dt_s: 3.0,
        ..RunSettings::default()
    };
    let e = st.validate().unwrap_err();
    assert_eq!(field_of(&e), "dt_s", "dt > duration: {e}");
    for f in [0.0, 1.5, f64::NAN] {
        let st = RunSettings {
            rms_fraction: f,
            ..RunSettings::default()
        };
        let e = st.validate().unwrap_err();
        assert_eq!(field_of(&e), "rms_fraction", "{e}");
    }
}
