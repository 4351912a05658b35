//! Regression tests, each named after the bug it pins.

use vibrobar_core::solver::Rk4;
use vibrobar_core::{ParamError, SimError, Solver, State, System};

/// Bug: `Rk4::run` accepted a NaN, infinite or backward `t_end_s`, ran zero steps and returned
/// `Ok` with the initial state, so a bad duration looked like a finished run.
#[test]
fn rk4_accepted_nan_or_backward_end_time() {
    let sys = System::paper_solid(1.0);
    let init = State {
        t_s: 0.5,
        ..State::REST
    };
    // The same check guards every solver (it lives in `solver::validate_run`).
    let exact = vibrobar_core::solver::Exact::default();
    let solvers: [&dyn vibrobar_core::Solver; 2] = [&Rk4 { dt_s: 1e-6 }, &exact];
    for solver in solvers {
        for t_end in [f64::NAN, f64::INFINITY, 0.25] {
            let r = solver.run(&sys, &init, t_end, &mut ());
            match r {
                Err(SimError::Param(ParamError::NotFinite { field, .. }))
                | Err(SimError::Param(ParamError::OutOfRange { field, .. })) => {
                    assert_eq!(field, "t_end_s", "{}: t_end = {t_end}", solver.name())
                }
                other => panic!(
                    "{}: t_end = {t_end} (start 0.5 s): want a t_end_s error, got {other:?}",
                    solver.name()
                ),
            }
        }
    }
    // Zero-length runs stay allowed.
    let s = Rk4 { dt_s: 1e-6 }.run(&sys, &init, 0.5, &mut ()).unwrap();
    assert_eq!(s.final_state, init);
}

/// Bug: rk4's `Segment::integrals` took the friction work of a step as the start-of-step
/// friction force times `Δw`. On a step where `ẇ` reverses, `Δw` can have the other sign, so a
/// step of `as-published` friction (power `F|ẇ| ≥ 0`) reported negative work (−8.8e-12 J seen
/// at gap 1 mm, 0.0204 N), and `coulomb` positive work. Now `±F·∫|ẇ|dt`.
#[test]
fn rk4_step_friction_work_had_wrong_sign_when_dw_reversed_in_step() {
    use vibrobar_core::solver::{Observer, Segment};
    use vibrobar_core::FrictionModel;
    struct Probe {
        reversals: u64,
        min_work: f64,
        max_work: f64,
    }
    impl Observer for Probe {
        fn segment(&mut self, seg: &dyn Segment) {
            let (a, b) = (seg.t_start_s(), seg.t_end_s());
            if seg.state_at(a).dw_m_s() * seg.state_at(b).dw_m_s() < 0.0 {
                self.reversals += 1;
                let w = seg.integrals(a, b).friction_work_j;
                self.min_work = self.min_work.min(w);
                self.max_work = self.max_work.max(w);
            }
        }
    }
    for model in [FrictionModel::AsPublished, FrictionModel::Coulomb] {
        let sys = System::paper_damped(1e-3, model, 1.0);
        let mut p = Probe {
            reversals: 0,
            min_work: f64::INFINITY,
            max_work: f64::NEG_INFINITY,
        };
        Rk4 { dt_s: 1e-6 }
            .run(&sys, &State::REST, 0.05, &mut p)
            .unwrap();
        assert!(
            p.reversals > 10,
            "{model}: only {} reversal steps",
            p.reversals
        );
        match model {
            FrictionModel::AsPublished => assert!(
                p.min_work >= 0.0,
                "{model}: friction work {} J < 0 on a reversal step",
                p.min_work
            ),
            _ => assert!(
                p.max_work <= 0.0,
                "{model}: friction work {} J > 0 on a reversal step",
                p.max_work
            ),
        }
    }
}

/// Bug: `linspace_inclusive(0.0, 1.0, 0.0)` computed `inf as i64 = i64::MAX` points and tried to
/// allocate them (abort), and a NaN step silently gave one point. Bad grids now give an empty
/// vector, and `checked_linspace_inclusive` an error naming the argument.
#[test]
fn linspace_with_zero_step_tried_to_allocate_i64_max_points() {
    use vibrobar_core::analysis::{checked_linspace_inclusive, linspace_inclusive};
    for (start, stop, step, field) in [
        (0.0, 1.0, 0.0, "grid.step"),
        (0.0, 1.0, -0.1, "grid.step"),
        (0.0, 1.0, f64::NAN, "grid.step"),
        (0.0, 1.0, 1e-300, "grid.step"),
        (f64::NAN, 1.0, 0.1, "grid.start"),
        (0.0, f64::INFINITY, 0.1, "grid.stop"),
        (1.0, 0.0, 0.1, "grid.stop"),
    ] {
        assert!(
            linspace_inclusive(start, stop, step).is_empty(),
            "({start}, {stop}, {step})"
        );
        match checked_linspace_inclusive(start, stop, step) {
            Err(e) => assert_eq!(e.field(), field, "({start}, {stop}, {step})"),
            Ok(v) => panic!("({start}, {stop}, {step}) accepted: {} points", v.len()),
        }
    }
    // A single point and the paper grid still work.
    assert_eq!(linspace_inclusive(1.0, 1.0, 0.01), vec![1.0]);
    assert_eq!(linspace_inclusive(0.95, 1.05, 0.01).len(), 11);
}

/// Bug: the exact solver took a segment's friction work as `F_ball·(w(b) − w(a))`. A coulomb slide
/// much shorter than the rounding of `w` (here 2.6e-16 m at `w ≈ −4.3e-7 m`) lost its length to
/// that rounding: friction work 1e-7 relative off, so the energy audit of an unforced run that
/// only brakes a slow ball missed by 2.3e-23 J of 2.3e-16 J (found by `exact_properties`, case
/// 377). Now the increment of the closed form, `w(b) − w(0)` evaluated without `w(0)`.
#[test]
fn regression_friction_work_of_a_slide_shorter_than_the_rounding_of_w() {
    use vibrobar_core::analysis::energy::EnergyAudit;
    use vibrobar_core::solver::Exact;
    use vibrobar_core::{Bar, Damper, Forcing, Frequency, FrictionModel};
    let sys = System {
        bar: Bar {
            mass_kg: 0.104,
            stiffness_n_per_m: 1.7e5,
            damping_ratio: 0.28,
        }
        .into(),
        damper: Some(Damper {
            ball_mass_kg: 7.26e-5,
            ball_radius_m: 0.0075,
            restitution: 0.22,
            gap_m: 6.46e-6,
            rolling_friction_m: 0.6e-3,
            friction: FrictionModel::Coulomb,
            friction_force_n: Some(0.884),
            contact: vibrobar_core::Contact::default(),
            gravity_along_gap_m_s2: 0.0,
        }),
        forcing: Forcing {
            amplitude_n: 0.0,
            frequency: Frequency::Ratio(0.84),
            static_force_n: 0.0,
        },
        gravity_m_s2: vibrobar_core::params::STANDARD_GRAVITY_M_S2,
    };
    let init = State {
        v_m: -4.35e-7,
        dv_m_s: -2.534e-6,
        ..State::REST
    };
    let mut audit = EnergyAudit::new(&sys);
    let solver = Exact {
        check_invariants: true,
        ..Default::default()
    };
    solver.run(&sys, &init, 0.01, &mut audit).unwrap();
    let b = audit.balance().unwrap();
    // The ball's kinetic energy goes (almost all) into friction.
    let e0 = 0.5 * 7.26e-5 * 2.534e-6_f64.powi(2);
    assert!(
        (-b.friction_work_j - e0).abs() < 1e-2 * e0,
        "friction work {:e} J, start energy {e0:e} J",
        b.friction_work_j
    );
    assert!(
        b.residual_j.abs() <= 1e-9 * e0,
        "residual {:e} J of {e0:e} J: {b:?}",
        b.residual_j
    );
}

/// Bug: the exact solver summed a chatter sequence only for `e < 1`. With `e = 1` and coulomb
/// friction the bounces still shrink (friction brakes the ball both ways, so it flies out
/// against `a_away` and back with only `a_back < a_away`: `q = √(a_back/a_away) < 1`), a Zeno
/// sequence the solver followed impact by impact down to rounding (54 impacts here, ~20 to
/// the resolution limit) or into `TooManyEvents` (found by `exact_properties`: M = 1.66 kg,
/// K = 1.36e5 N/m, ζ = 0, m_d = 0.45 kg, gap 69 µm, f = 88 N, F0 = 80 N, ratio 0.914 stopped at
/// 41 % of the run with 2e5 events; now 27856 events for the whole run).
#[test]
fn regression_elastic_chatter_under_coulomb_friction_was_not_summed() {
    use vibrobar_core::analysis::energy::EnergyAudit;
    use vibrobar_core::solver::{Event, EventKind, Exact, Observer, Wall};
    use vibrobar_core::{Bar, Damper, Forcing, Frequency, FrictionModel};
    struct Count(u64, u64);
    impl Observer for Count {
        fn event(&mut self, ev: &Event) {
            match ev.kind {
                EventKind::Impact { .. } => self.0 += 1,
                EventKind::ChatterLimit {
                    wall: Wall::Minus, ..
                } => self.1 += 1,
                _ => {}
            }
        }
    }
    // Static load on a heavily damped bar: a_b ≈ 10 m/s² pushes the ball onto the −wall,
    // friction 0.2 N gives fκ = 2.2 m/s², so q = √(7.8/12.2) ≈ 0.8; the ball starts leaving the
    // wall at 0.1 mm/s.
    let sys = System {
        bar: Bar {
            mass_kg: 1.0,
            stiffness_n_per_m: 1e4,
            damping_ratio: 0.5,
        }
        .into(),
        damper: Some(Damper {
            ball_mass_kg: 0.1,
            ball_radius_m: 0.0075,
            restitution: 1.0,
            gap_m: 1e-3,
            rolling_friction_m: 0.6e-3,
            friction: FrictionModel::Coulomb,
            friction_force_n: Some(0.2),
            contact: vibrobar_core::Contact::default(),
            gravity_along_gap_m_s2: 0.0,
        }),
        forcing: Forcing {
            amplitude_n: 0.0,
            frequency: Frequency::Ratio(1.0),
            static_force_n: 10.0,
        },
        gravity_m_s2: vibrobar_core::params::STANDARD_GRAVITY_M_S2,
    };
    let init = State {
        v_m: -0.5e-3,
        dv_m_s: 1e-4,
        ..State::REST
    };
    let solver = Exact {
        check_invariants: true,
        max_events: 10_000,
    };
    let mut obs = (Count(0, 0), EnergyAudit::new(&sys));
    let r = solver.run(&sys, &init, 0.01, &mut obs);
    assert!(r.is_ok(), "{r:?}");
    let (count, audit) = obs;
    assert_eq!(
        count.1, 1,
        "chatter limits at the −wall ({} impacts)",
        count.0
    );
    assert!(count.0 <= 30, "{} impacts", count.0);
    let b = audit.balance().unwrap();
    assert!(b.residual_j.abs() <= 1e-9 * b.work_input_j.abs(), "{b:?}");
}

/// Bug: a system entirely at rest and unforced, ball resting on a wall (or, coulomb with a zero
/// friction level, sticking), has a contact (stick) margin that is exactly 0 for all time. The
/// search reported it as a root at once, the release departed with `ẅ ≡ 0` (unconfirmed), the
/// graze impact with `ẇ− = 0` went back to contact, and so on at `t = 0` until `TooManyEvents`
/// (found by `exact_properties`). A constant margin ≥ 0 now holds the mode.
#[test]
fn regression_unforced_ball_at_rest_on_a_wall_looped_at_one_instant() {
    use vibrobar_core::solver::Exact;
    use vibrobar_core::{Bar, Damper, Forcing, Frequency, FrictionModel};
    for (friction, level, w0) in [
        (FrictionModel::None, None, 0.5e-3),
        (FrictionModel::None, None, -0.5e-3),
        (FrictionModel::Coulomb, Some(0.0), 0.0),
        (FrictionModel::Coulomb, Some(0.0), 0.5e-3),
    ] {
        let sys = System {
            bar: Bar::PAPER_CAVITY.into(),
            damper: Some(Damper {
                friction,
                friction_force_n: level,
                ..Damper::paper(1e-3, friction)
            }),
            forcing: Forcing {
                amplitude_n: 0.0,
                frequency: Frequency::Ratio(1.0),
                static_force_n: 0.0,
            },
            gravity_m_s2: vibrobar_core::params::STANDARD_GRAVITY_M_S2,
        };
        let init = State {
            v_m: w0,
            ..State::REST
        };
        let solver = Exact {
            check_invariants: true,
            max_events: 1000,
        };
        let r = solver.run(&sys, &init, 0.01, &mut ());
        let sum = r.unwrap_or_else(|e| panic!("{friction} {level:?} w0 = {w0}: {e}"));
        assert_eq!(sum.final_state, State { t_s: 0.01, ..init });
        assert!(
            sum.events <= 1,
            "{friction} w0 = {w0}: {} events",
            sum.events
        );
    }
}
