//! Regression tests of the exact solver, each named after the bug it pins (issue #7).
//!
//! A3: `exact` failed on ordinary long runs with "event search did not converge". Root causes
//! (written out in `solver/exact/lumped/roots.rs`): (a) a segment without events was one root search
//! over the whole rest of the run, whose number of proven steps grows with the interval, so it
//! hit the iteration cap after ~1e5 half periods; (b) a (nearly) undamped bar near resonance:
//! the steady and transient parts of the closed form are each metres and cancel, and the bound
//! on `|g''|` used for the proven steps was the sum of their amplitudes, ~1e5 too loose.
mod common;

use common::linear_bar_from_rest;

use vibrobar_core::solver::{Event, Exact, Observer, Rk4, Segment, Solver};
use vibrobar_core::EventLimitCause;
use vibrobar_core::*;

/// Counts segments, those that end without an event (work-bound restarts of a search, and the
/// last one), and keeps the first event times.
#[derive(Default)]
struct Count {
    segments: u64,
    without_event: u64,
    open: bool,
    first_events: Vec<f64>,
}

impl Observer for Count {
    fn segment(&mut self, _seg: &dyn Segment) {
        if self.open {
            self.without_event += 1;
        }
        self.segments += 1;
        self.open = true;
    }
    fn event(&mut self, ev: &Event) {
        self.open = false;
        if self.first_events.len() < 8 {
            self.first_events.push(ev.t_s);
        }
    }
}

impl Count {
    /// Segments that ended without an event before the run's end.
    fn restarts(&self) -> u64 {
        self.without_event
    }
}

fn checked() -> Exact {
    Exact {
        check_invariants: true,
        ..Default::default()
    }
}

/// Bug A3 (a): frictionless runs whose ball never meets a wall are one segment without events;
/// its root search hit the iteration cap at t = 27.7, 49.8, 83.0 and 114.7 s (gaps 0.25, 0.5,
/// 1 and 2 mm, the paper bar at r = 1). Now a search stops after a bounded number of proven
/// steps and the same flight goes on from the closed-form state, which stays exact.
#[test]
fn regression_frictionless_run_without_events_hit_the_search_iteration_cap() {
    for (gap_m, t_end) in [(0.25e-3, 40.0), (0.5e-3, 60.0), (1e-3, 84.0), (2e-3, 130.0)] {
        let sys = System::paper_damped(gap_m, FrictionModel::None, 1.0);
        let mut obs = Count::default();
        let r = checked()
            .run(&sys, &State::REST, t_end, &mut obs)
            .unwrap_or_else(|e| panic!("gap {gap_m} m, {t_end} s: {e}"));
        assert_eq!(r.events, 0);
        // The work bound was reached, and a bounded number of times.
        assert!(
            obs.restarts() >= 1 && obs.segments < 200,
            "gap {gap_m}: {} segments",
            obs.segments
        );
        let (u, du) = linear_bar_from_rest(&sys, t_end);
        let s = r.final_state;
        let scale = u.hypot(du / sys.omega_rad_s());
        assert!(
            (s.u_m - u).abs() <= 1e-9 * scale
                && (s.du_m_s - du).abs() <= 1e-9 * scale * sys.omega_rad_s(),
            "gap {gap_m}: u = {} m, u̇ = {} m/s; closed form {u} m, {du} m/s",
            s.u_m,
            s.du_m_s
        );
    }
}

/// Bug A3 (a), as reported: `run --preset paper --gap-mm 1 --duration 84` stopped with "event
/// search did not converge near t = 83.04 s"; the same through the paper's RMS runner, and a
/// 1000 s run.
#[test]
fn regression_paper_preset_at_1_mm_stopped_near_83_s() {
    let sys = System::paper_damped(1e-3, FrictionModel::None, 1.0);
    for t_end in [84.0, 1000.0] {
        let r = checked().run(&sys, &State::REST, t_end, &mut ());
        assert!(r.is_ok(), "{t_end} s: {r:?}");
    }
}

fn undamped(gap_m: f64, ratio: f64) -> System {
    let mut sys = System::paper_damped(gap_m, FrictionModel::None, ratio);
    sys.bar.as_lumped_mut().unwrap().damping_ratio = 0.0;
    sys
}

/// Bug A3 (b): an undamped bar at ratio 1.0000001 failed at t = 0.059 s (0.1 mm gap; 0.19 s at
/// 1 mm). The steady part (~8 m) and the transient part cancel to ~1e-4 m; the amplitude bound
/// on `|g''|` was ~1e5 too loose and the proven steps ~300× too short. The events agree with
/// rk4 (dt = 20 ns) to 5 of its steps (the first three; later ones drift apart, the motion is chaotic), and the search needs no work-bound restarts.
#[test]
fn regression_undamped_bar_near_resonance_failed_at_0_059_s() {
    for gap_m in [0.1e-3, 1e-3] {
        let sys = undamped(gap_m, 1.0000001);
        let mut obs = Count::default();
        let r = checked()
            .run(&sys, &State::REST, 2.0, &mut obs)
            .unwrap_or_else(|e| panic!("gap {gap_m}: {e}"));
        assert!(r.impacts > 100, "gap {gap_m}: {} impacts", r.impacts);
        // Proven steps of the usual length: no search needs its work-bound restart (with the
        // loose bound, one every ~0.19 s).
        assert_eq!(obs.restarts(), 0, "gap {gap_m}: {} events", r.events);
        // Cross-check the first events against rk4.
        let t_cmp = obs.first_events[2] + 1e-4;
        let mut exact_ev = Count::default();
        checked()
            .run(&sys, &State::REST, t_cmp, &mut exact_ev)
            .unwrap();
        let mut rk = Count::default();
        Rk4 { dt_s: 2e-8 }
            .run(&sys, &State::REST, t_cmp, &mut rk)
            .unwrap();
        for (a, b) in exact_ev.first_events.iter().zip(&rk.first_events).take(3) {
            assert!((a - b).abs() < 1e-7, "gap {gap_m}: exact {a} s, rk4 {b} s");
        }
    }
}

/// Bug A10: "more than N events before t" named no cause. e = 1 without friction, the ball
/// dropped onto the wall a constant load presses it on: elastic bounces of 1e-12 m that never
/// end.
#[test]
fn regression_event_limit_named_no_cause_elastic_micro_bouncing() {
    let sys = common::constant_push(1.0, 1e-3, 1.0);
    let lg = 0.5e-3;
    let init = State {
        v_m: -lg + 1e-12,
        ..State::REST
    };
    let r = Exact {
        max_events: 2000,
        ..Default::default()
    }
    .run(&sys, &init, 1.0, &mut ());
    match r {
        Err(
            e @ SimError::TooManyEvents {
                cause: EventLimitCause::ElasticMicroBouncing { largest_dw_m_s },
                ..
            },
        ) => {
            assert!(largest_dw_m_s > 1e-7 && largest_dw_m_s < 1e-5, "{e}");
            let msg = e.to_string();
            assert!(msg.contains("restitution = 1"), "{msg}");
        }
        other => panic!("want an elastic micro-bouncing cause, got {other:?}"),
    }
}

/// Bug A10: the same for the energy-injecting as-published law at 100 N (0.1 mm gap, e = 1,
/// r = 1): the relative speed runs away to ~1e2 m/s.
#[test]
fn regression_event_limit_named_no_cause_as_published_runaway() {
    let mut sys = System::paper_damped(0.1e-3, FrictionModel::AsPublished, 1.0);
    let d = sys.damper.as_mut().unwrap();
    d.friction_force_n = Some(100.0);
    d.restitution = 1.0;
    let r = Exact {
        max_events: 20_000,
        ..Default::default()
    }
    .run(&sys, &State::REST, 2.0, &mut ());
    match r {
        Err(
            e @ SimError::TooManyEvents {
                cause: EventLimitCause::FrictionRunaway { largest_dw_m_s },
                events_per_period,
                ..
            },
        ) => {
            assert!(largest_dw_m_s > 10.0, "{e}");
            assert!(events_per_period > 100.0, "{e}");
            assert!(e.to_string().contains("as-published"), "{e}");
        }
        other => panic!("want an as-published runaway cause, got {other:?}"),
    }
}
