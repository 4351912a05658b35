//! The exact solver converges to the symmetric two-impacts-per-cycle orbit derived in
//! `common/orbit.rs`, from a nearby start: impact phase and relative velocity to 1e-8.
mod common;

use common::orbit::orbits;
use common::Recorder;
use vibrobar_core::solver::{EventKind, Exact, Solver, Wall};
use vibrobar_core::*;

fn case(ratio: f64, ball_kg: f64, gap_m: f64, e: f64) -> System {
    let mut sys = System::paper_damped(gap_m, FrictionModel::None, ratio);
    let d = sys.damper.as_mut().unwrap();
    d.ball_mass_kg = ball_kg;
    d.restitution = e;
    sys
}

/// Start just after the `+` impact of the orbit, ball velocity scaled by `1 + eps`.
fn start(sys: &System, o: &common::orbit::Orbit, eps: f64) -> State {
    let lg = sys.damper.unwrap().half_gap_m();
    let mut s = State {
        t_s: o.t0,
        u_m: o.u0,
        du_m_s: o.du_plus,
        v_m: o.u0 + lg,
        dv_m_s: -o.v_ball * (1.0 + eps),
        cavity: None,
    };
    // Keep w = v − u within [−l_g, l_g] despite rounding.
    while s.w_m() > lg {
        s.v_m = f64::from_bits(s.v_m.to_bits() - 1);
    }
    s
}

/// Largest deviation of the last `n` impacts from the orbit: (phase in periods, relative
/// velocity relative to the orbit's).
fn deviation(sys: &System, o: &common::orbit::Orbit, rec: &Recorder, n: usize) -> (f64, f64) {
    let t = sys.forcing_period_s();
    let imp: Vec<_> = rec.impacts().into_iter().rev().take(n).collect();
    assert_eq!(imp.len(), n);
    let dw = o.v_ball - o.du_minus;
    imp.iter().fold((0.0f64, 0.0f64), |(p, v), ev| {
        let EventKind::Impact { wall, dw_m_s, .. } = ev.kind else {
            unreachable!()
        };
        let want_t = if wall == Wall::Plus {
            o.t0
        } else {
            o.t0 + 0.5 * t
        };
        let ph = ((ev.t_s - want_t) / t).rem_euclid(1.0);
        (
            p.max(ph.min(1.0 - ph)),
            v.max((dw_m_s.abs() - dw).abs() / dw),
        )
    })
}

/// The paper's bar with e = 0.8, 0.1 mm gap, r = 0.9: two orbits, one stable.
fn sys() -> System {
    case(0.9, 0.026, 0.1e-3, 0.8)
}

#[test]
fn both_branches_are_solutions_of_the_solver() {
    let sys = sys();
    let os = orbits(&sys);
    assert_eq!(os.len(), 2, "{os:?}");
    for o in &os {
        // Exactly on the orbit, one period: the solver reproduces both impacts.
        let mut rec = Recorder::default();
        let t = sys.forcing_period_s();
        Exact::default()
            .run(&sys, &start(&sys, o, 0.0), o.t0 + 1.01 * t, &mut rec)
            .unwrap();
        assert_eq!(rec.impacts().len(), 2);
        let (ph, dv) = deviation(&sys, o, &rec, 2);
        assert!(ph < 1e-9 && dv < 1e-9, "{o:?}: {ph:e} {dv:e}");
    }
}

#[test]
fn solver_converges_to_the_stable_orbit() {
    let sys = sys();
    let os = orbits(&sys);
    let t = sys.forcing_period_s();
    let mut stable = 0;
    for o in &os {
        let mut rec = Recorder::default();
        let r = Exact {
            check_invariants: true,
            ..Default::default()
        }
        .run(&sys, &start(&sys, o, 1e-2), o.t0 + 300.0 * t, &mut rec)
        .unwrap();
        assert!(r.impacts > 500);
        let (ph, dv) = deviation(&sys, o, &rec, 6);
        if ph < 1e-8 && dv < 1e-8 {
            stable += 1;
        }
    }
    assert_eq!(stable, 1, "exactly one branch attracts a perturbed start");
}
