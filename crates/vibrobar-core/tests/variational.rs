//! The variational layer (issue #11, item 1) against central finite differences of the exact
//! solver's end state, one run per event kind, at points where no event is near grazing.

use vibrobar_core::analysis::variational::{det4, flow_with_jacobian, FlowJacobian, Mat4};
use vibrobar_core::params::{FrictionModel, State, System};
use vibrobar_core::solver::{Exact, Solver};

#[path = "common/variational_fd.rs"]
mod variational_fd;
use variational_fd::{fd_jacobian, rel_err, scaled};

fn settled(sys: &System, t_s: f64) -> State {
    Exact::default()
        .run(sys, &State::REST, t_s, &mut ())
        .unwrap()
        .final_state
}

/// FD step in units of the scales: the end state carries ~1e-12 relative noise (event times
/// resolved to ~1e-15 s, then amplified by the flow), so the FD error is that over `h` plus the
/// `O(h²)` truncation; `h = 1e-5` balances them (measured: 1e-7…1e-9, against 1e-6…1e-5 at
/// `h = 1e-7`).
const H: f64 = 1e-5;
/// Tolerance on the largest entry error relative to the largest entry (scaled coordinates).
const TOL: f64 = 1e-6;

/// The Jacobian of the run from `x` to `t_end` against central differences; returns the error
/// and the events the run went through.
fn check(name: &str, sys: &System, x: &State, t_end: f64) -> (f64, FlowJacobian) {
    let all = [0, 1, 2, 3];
    let fj = flow_with_jacobian(&Exact::default(), sys, x, t_end, &mut ()).unwrap();
    let js = scaled(sys, &fj.jacobian);
    let fd = fd_jacobian(sys, x, t_end, H, &all);
    let e = rel_err(&fd, &js, &all);
    eprintln!(
        "{name}: FD rel err {e:.3e}, {:?}, det {:.6e}",
        fj.events,
        det4(&fj.jacobian)
    );
    assert!(e < TOL, "{name}: Jacobian vs FD relative error {e:e}");
    assert_eq!(fj.events.grazing, 0, "{name}");
    (e, fj)
}

fn paper(
    gap_m: f64,
    friction: FrictionModel,
    ratio: f64,
    f_n: Option<f64>,
    e: Option<f64>,
) -> System {
    let mut sys = System::paper_damped(gap_m, friction, ratio);
    let d = sys.damper.as_mut().unwrap();
    d.friction_force_n = f_n.or(d.friction_force_n);
    d.restitution = e.unwrap_or(d.restitution);
    sys
}

/// Three forcing periods from a state settled for `t_settle`.
fn window(sys: &System, t_settle: f64, periods: f64) -> (State, f64) {
    let x = settled(sys, t_settle);
    (x, x.t_s + periods * sys.forcing_period_s())
}

#[test]
fn impacts_of_the_frictionless_bar_match_finite_differences() {
    for e in [0.5, 0.2, 0.8] {
        let sys = paper(0.08e-3, FrictionModel::None, 1.0, None, Some(e));
        let (x, t) = window(&sys, 0.3, 3.0);
        let (_, fj) = check(&format!("frictionless e {e}"), &sys, &x, t);
        assert!(fj.events.impacts >= 4, "{:?}", fj.events);
    }
}

#[test]
fn plastic_impacts_match_finite_differences() {
    // e = 0: every impact is plastic; the ball leaves the wall at once or rides it.
    let sys = paper(0.1e-3, FrictionModel::None, 1.0, None, Some(0.0));
    let (x, t) = window(&sys, 0.3, 3.0);
    let (_, fj) = check("e = 0", &sys, &x, t);
    assert!(fj.events.impacts >= 4, "{:?}", fj.events);
}

#[test]
fn friction_switches_match_finite_differences() {
    // Coulomb friction of 5 N: the ball slides to and fro without reaching a wall.
    let sys = paper(0.1e-3, FrictionModel::Coulomb, 1.0, Some(5.0), None);
    let (x, t) = window(&sys, 0.3, 3.0);
    let (_, fj) = check("coulomb 5 N", &sys, &x, t);
    assert!(fj.events.friction_switches >= 4, "{:?}", fj.events);
}

#[test]
fn impact_accumulation_and_release_match_finite_differences() {
    // The paper's as-published friction at 0.1 mm: impacts, friction switches, an accumulating
    // impact sequence summed to its plastic limit, the ball riding the wall and released.
    let sys = paper(0.1e-3, FrictionModel::AsPublished, 1.0, None, None);
    let (x, t) = window(&sys, 0.3, 3.0);
    let (_, fj) = check("as-published", &sys, &x, t);
    let ev = fj.events;
    assert!(ev.impacts >= 4 && ev.friction_switches >= 4, "{ev:?}");
    assert!(
        ev.plastic_impacts >= 1 && ev.chatter_limits >= 1 && ev.releases >= 1,
        "{ev:?}"
    );
}

#[test]
fn stick_and_unstick_match_finite_differences() {
    // Coulomb friction of 8 N: the ball slides, sticks to the bar and breaks free twice a period.
    let sys = paper(0.1e-3, FrictionModel::Coulomb, 1.0, Some(8.0), None);
    let (x, t) = window(&sys, 0.3, 3.0);
    let (_, fj) = check("coulomb 8 N", &sys, &x, t);
    assert!(
        fj.events.sticks >= 4 && fj.events.unsticks >= 4,
        "{:?}",
        fj.events
    );
    // Stick removes one dimension (ẇ = 0) for good: the Jacobian is singular, its determinant
    // is rounding next to the product of its column norms (Hadamard's bound).
    let js = scaled(&sys, &fj.jacobian);
    let cols: f64 = (0..4)
        .map(|c| (0..4).map(|r| js[r][c] * js[r][c]).sum::<f64>().sqrt())
        .product();
    assert!(det4(&js).abs() < 1e-12 * cols, "{} vs {cols}", det4(&js));
}

/// A body force on the ball along the gap (gravity along the hole): it enters the vector fields
/// at every event and the pair's load while the ball rests on a wall, never a transition
/// matrix. At the paper's force the ball flies and impacts; at a small force the bar's
/// acceleration barely exceeds g, so the ball rests on the wall gravity presses it onto, is
/// lifted off, lands and accumulates back to rest every period.
#[test]
fn a_body_force_on_the_ball_matches_finite_differences() {
    let g = 9.80665;
    for (name, gap_m, f0, gs, settle) in [
        ("paper force, 1 mm, g towards +", 1.0e-3, 15.0, g, 0.3),
        ("paper force, 0.1 mm, g towards -", 0.1e-3, 15.0, -g, 0.3),
        ("0.5 N, 1 mm: rests, lifts off, lands", 1.0e-3, 0.5, -g, 0.3),
    ] {
        let mut sys = paper(gap_m, FrictionModel::None, 1.0, None, None);
        sys.forcing.amplitude_n = f0;
        sys.damper.as_mut().unwrap().gravity_along_gap_m_s2 = gs;
        // Start in a flight: a resting start is differentiated along the wall, which central
        // differences off the wall cannot see.
        let mut flight = FirstFlight {
            t_from: settle,
            mid: None,
        };
        Exact::default()
            .run(&sys, &State::REST, settle + 0.05, &mut flight)
            .unwrap();
        let t0 = flight.mid.expect("a flight after the settling time");
        let x = settled(&sys, t0);
        let t = t0 + 3.0 * sys.forcing_period_s();
        let (_, fj) = check(name, &sys, &x, t);
        assert!(fj.events.impacts >= 2, "{name}: {:?}", fj.events);
        if f0 < 1.0 {
            let ev = fj.events;
            assert!(ev.releases >= 2 && ev.chatter_limits >= 2, "{name}: {ev:?}");
        }
    }
}

/// Finds the middle of the first free flight of the ball after `t_from`.
struct FirstFlight {
    t_from: f64,
    mid: Option<f64>,
}

impl vibrobar_core::solver::Observer for FirstFlight {
    fn segment(&mut self, seg: &dyn vibrobar_core::solver::Segment) {
        if self.mid.is_none()
            && seg.t_start_s() > self.t_from
            && seg.mode() == vibrobar_core::solver::Mode::Free
        {
            self.mid = Some(0.5 * (seg.t_start_s() + seg.t_end_s()));
        }
    }
}

/// Finds the middle of the first stick segment after `t_from`.
struct FirstStick {
    t_from: f64,
    mid: Option<f64>,
}

impl vibrobar_core::solver::Observer for FirstStick {
    fn segment(&mut self, seg: &dyn vibrobar_core::solver::Segment) {
        if self.mid.is_none()
            && seg.t_start_s() > self.t_from
            && seg.mode() == vibrobar_core::solver::Mode::Stick
        {
            self.mid = Some(0.5 * (seg.t_start_s() + seg.t_end_s()));
        }
    }
}

#[test]
fn a_run_that_starts_stuck_is_differentiated_along_the_stick() {
    // Started inside a stick phase: a perturbation of the velocities (ẇ ≠ 0) slides briefly
    // and sticks again with the momentum shared (the projection P); a perturbation of a
    // position sticks elsewhere. The slide moves the ball by δẇ|δẇ|/(2a): the map is C¹ but
    // not C², so central differences of the velocity columns converge like h, not h².
    let sys = paper(0.1e-3, FrictionModel::Coulomb, 1.0, Some(8.0), None);
    let mut f = FirstStick {
        t_from: 0.3,
        mid: None,
    };
    Exact::default()
        .run(&sys, &State::REST, 0.35, &mut f)
        .unwrap();
    let x = settled(&sys, f.mid.expect("a stick phase after 0.3 s"));
    assert_eq!(x.dw_m_s(), 0.0);
    let t_end = x.t_s + 2.0 * sys.forcing_period_s();
    let fj = flow_with_jacobian(&Exact::default(), &sys, &x, t_end, &mut ()).unwrap();
    assert!(
        fj.events.sticks >= 2 && fj.events.unsticks >= 2,
        "{:?}",
        fj.events
    );
    let js = scaled(&sys, &fj.jacobian);
    let err = |h: f64, c: usize| rel_err(&fd_jacobian(&sys, &x, t_end, h, &[c]), &js, &[c]);
    for c in [0, 2] {
        let e = err(H, c);
        assert!(e < TOL, "position column {c}: {e:e}");
    }
    for c in [1, 3] {
        let (e4, e5) = (err(1e-4, c), err(1e-5, c));
        eprintln!("velocity column {c}: FD error {e4:.2e} at h = 1e-4, {e5:.2e} at 1e-5");
        assert!(
            e5 < 0.2 * e4 && e5 < 3e-4,
            "velocity column {c}: {e4:e}, {e5:e}"
        );
    }
}

/// Records the saltation matrices of unstick and release events.
#[derive(Default)]
struct Continuous(Vec<Mat4>);

impl vibrobar_core::analysis::variational::TangentSink for Continuous {
    fn apply(&mut self, m: &Mat4, step: vibrobar_core::analysis::variational::Step) {
        use vibrobar_core::solver::EventKind;
        if let vibrobar_core::analysis::variational::Step::Event {
            kind: EventKind::Unstick | EventKind::ContactRelease { .. },
            ..
        } = step
        {
            self.0.push(*m);
        }
    }
}

#[test]
fn unstick_and_release_saltations_are_the_identity() {
    // Coulomb unstick and frictionless release: at the threshold the friction (or wall) force
    // equals what the pair needs, the vector field is continuous there, so S = I (to rounding
    // of f⁺ − f⁻). (An as-published release is not: its friction force F switches on as the
    // ball leaves; the FD test with that law covers it.)
    for (fm, f) in [
        (FrictionModel::Coulomb, Some(8.0)),
        (FrictionModel::None, None),
    ] {
        let sys = paper(0.1e-3, fm, 1.0, f, None);
        let x = settled(&sys, 0.3);
        let mut var =
            vibrobar_core::analysis::variational::Variational::new(&sys, Continuous::default())
                .unwrap();
        Exact::default()
            .run(&sys, &x, x.t_s + 1000.0 * sys.forcing_period_s(), &mut var)
            .unwrap();
        var.finish();
        assert!(!var.sink.0.is_empty(), "{fm:?}: {:?}", var.counts);
        for m in &var.sink.0 {
            let s = scaled(&sys, m);
            for (r, row) in s.iter().enumerate() {
                for (c, v) in row.iter().enumerate() {
                    let want = if r == c { 1.0 } else { 0.0 };
                    assert!((v - want).abs() < 1e-6, "{fm:?}: S[{r}][{c}] = {v}");
                }
            }
        }
    }
}
