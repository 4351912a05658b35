//! The variational layer (issue #11, item 1) against central finite differences of the exact
//! solver's end state, one run per event kind, at points where no event is near grazing.

use vibrobar_core::analysis::variational::{det4, flow_with_jacobian, FlowJacobian, Mat4};
use vibrobar_core::params::{FrictionModel, State, System};
use vibrobar_core::solver::{Exact, Solver};

/// Scales of `(u, u̇, v, v̇)`: the FD steps and the norm of the comparison.
fn scales(sys: &System) -> [f64; 4] {
    let bar = sys.lumped_bar().unwrap();
    let su = sys.forcing.amplitude_n / bar.stiffness_n_per_m;
    let wn = bar.natural_freq_rad_s();
    [su, wn * su, su, wn * su]
}

fn settled(sys: &System, t_s: f64) -> State {
    Exact::default()
        .run(sys, &State::REST, t_s, &mut ())
        .unwrap()
        .final_state
}

fn end(sys: &System, x: &State, t_end: f64) -> [f64; 4] {
    let s = Exact::default()
        .run(sys, x, t_end, &mut ())
        .unwrap()
        .final_state;
    [s.u_m, s.du_m_s, s.v_m, s.dv_m_s]
}

fn set(x: &State, j: usize, d: f64) -> State {
    let mut y = *x;
    match j {
        0 => y.u_m += d,
        1 => y.du_m_s += d,
        2 => y.v_m += d,
        _ => y.dv_m_s += d,
    }
    y
}

/// Central differences with relative step `h` (in units of the scales); returns the FD
/// Jacobian in scaled coordinates.
fn fd_jacobian(sys: &System, x: &State, t_end: f64, h: f64, dirs: &[usize]) -> Mat4 {
    let sc = scales(sys);
    let mut j = [[0.0; 4]; 4];
    for &c in dirs {
        let d = h * sc[c];
        let (p, m) = (
            end(sys, &set(x, c, d), t_end),
            end(sys, &set(x, c, -d), t_end),
        );
        for r in 0..4 {
            j[r][c] = (p[r] - m[r]) / (2.0 * d) * sc[c] / sc[r];
        }
    }
    j
}

fn scaled(sys: &System, j: &Mat4) -> Mat4 {
    let sc = scales(sys);
    let mut o = *j;
    for r in 0..4 {
        for c in 0..4 {
            o[r][c] = j[r][c] * sc[c] / sc[r];
        }
    }
    o
}

/// Largest entry error over the largest entry, over the columns `dirs`.
fn rel_err(a: &Mat4, b: &Mat4, dirs: &[usize]) -> f64 {
    let (mut e, mut n) = (0.0f64, 0.0f64);
    for r in 0..4 {
        for &c in dirs {
            e = e.max((a[r][c] - b[r][c]).abs());
            n = n.max(a[r][c].abs());
        }
    }
    e / n
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
