//! The modal variational layer (issue #11 on the N-mode bar) against central finite
//! differences of [`ModalExact`]'s end state, one run per event kind, at points where no event
//! is near grazing; the impact determinant `e²`; the one-mode bar against the lumped layer.

use vibrobar_core::analysis::variational::flow_with_jacobian;
use vibrobar_core::analysis::variational_modal::{modal_flow_with_jacobian, ModalFlowJacobian};
use vibrobar_core::params::{Damper, FrictionModel, State, System};
use vibrobar_core::solver::exact::modal::ModalExact;
use vibrobar_core::solver::{Exact, Solver};
use vibrobar_core::structure::{ModalState, ModalSystem};

#[path = "common/modal_beam.rs"]
mod modal_beam;

/// The paper's bar with `n` modes, the paper's damper at `gap_m` with `friction`, ratio 1.
fn beam(
    n: usize,
    gap_m: f64,
    friction: FrictionModel,
    f_n: Option<f64>,
    e: Option<f64>,
) -> ModalSystem {
    let mut d = Damper::paper(gap_m, friction);
    d.friction_force_n = f_n.or(d.friction_force_n);
    d.restitution = e.unwrap_or(d.restitution);
    modal_beam::beam_system(n, Some(d), 1.0)
}

/// Scales of `(q, q̇, v, v̇)`: each mode's static response to the force amplitude (`φ_fn F₀/kₙ`)
/// and `ωₙ` times it; the tip's for the ball.
fn scales(sys: &ModalSystem) -> Vec<f64> {
    let f0 = sys.forcing.amplitude_n;
    let modes = sys.model.modes();
    let n = modes.len();
    let mut s = vec![0.0; 2 * n + 2];
    let mut tip = 0.0;
    for (i, m) in modes.iter().enumerate() {
        let q = (m.shape_force * f0 / m.modal_stiffness_n_per_m()).abs();
        s[i] = q;
        s[n + i] = m.omega_rad_s * q;
        tip += q;
    }
    s[2 * n] = tip;
    s[2 * n + 1] = modes[0].omega_rad_s * tip;
    s
}

fn settled(sys: &ModalSystem, t_s: f64) -> ModalState {
    ModalExact::default()
        .run(sys, &ModalState::REST, t_s, &mut ())
        .unwrap()
        .final_state
}

fn vec_of(sys: &ModalSystem, s: &ModalState) -> Vec<f64> {
    let n = sys.n_modes();
    let mut x = s.q_m[..n].to_vec();
    x.extend_from_slice(&s.dq_m_s[..n]);
    x.push(s.v_m);
    x.push(s.dv_m_s);
    x
}

fn set(sys: &ModalSystem, x: &ModalState, j: usize, d: f64) -> ModalState {
    let n = sys.n_modes();
    let mut y = *x;
    if j < n {
        y.q_m[j] += d;
    } else if j < 2 * n {
        y.dq_m_s[j - n] += d;
    } else if j == 2 * n {
        y.v_m += d;
    } else {
        y.dv_m_s += d;
    }
    y
}

fn end(sys: &ModalSystem, x: &ModalState, t_end: f64) -> Vec<f64> {
    let s = ModalExact::default()
        .run(sys, x, t_end, &mut ())
        .unwrap()
        .final_state;
    vec_of(sys, &s)
}

/// Central differences (step `h` in units of the scales), scaled coordinates, columns `dirs`.
fn fd_jacobian(
    sys: &ModalSystem,
    x: &ModalState,
    t_end: f64,
    h: f64,
    dirs: &[usize],
) -> Vec<Vec<f64>> {
    let sc = scales(sys);
    let d = sc.len();
    let mut j = vec![vec![0.0; d]; d];
    for &c in dirs {
        let st = h * sc[c];
        let (p, m) = (
            end(sys, &set(sys, x, c, st), t_end),
            end(sys, &set(sys, x, c, -st), t_end),
        );
        for r in 0..d {
            j[r][c] = (p[r] - m[r]) / (2.0 * st) * sc[c] / sc[r];
        }
    }
    j
}

fn scaled(sys: &ModalSystem, j: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let sc = scales(sys);
    j.iter()
        .enumerate()
        .map(|(r, row)| {
            row.iter()
                .enumerate()
                .map(|(c, v)| v * sc[c] / sc[r])
                .collect()
        })
        .collect()
}

/// Largest entry error over the largest entry, over the columns `dirs`.
fn rel_err(a: &[Vec<f64>], b: &[Vec<f64>], dirs: &[usize]) -> f64 {
    let (mut e, mut n) = (0.0f64, 0.0f64);
    for r in 0..a.len() {
        for &c in dirs {
            e = e.max((a[r][c] - b[r][c]).abs());
            n = n.max(a[r][c].abs());
        }
    }
    e / n
}

/// Steps in units of the scales (the lumped tests use 1e-5 alone): the impacts excite the
/// higher modes far beyond their static response, the scaled Jacobian reaches 3e4 there, and the
/// O(h²) truncation and the O(ε/h) rounding of the end state balance at a step that depends on
/// the run (measured on the frictionless 4-mode beam: 2.3e-3, 2.3e-5, 1.9e-7, 3.3e-7 at
/// h = 1e-4 … 1e-7). The best of the three must meet the tolerance of `tests/variational.rs`.
const STEPS: [f64; 3] = [1e-5, 1e-6, 1e-7];
const TOL: f64 = 1e-6;

fn check(name: &str, sys: &ModalSystem, x: &ModalState, t_end: f64) -> ModalFlowJacobian {
    let d = 2 * sys.n_modes() + 2;
    let all: Vec<usize> = (0..d).collect();
    let fj = modal_flow_with_jacobian(sys, x, t_end).unwrap();
    let js = scaled(sys, &fj.jacobian);
    let errs: Vec<f64> = STEPS
        .iter()
        .map(|&h| rel_err(&fd_jacobian(sys, x, t_end, h, &all), &js, &all))
        .collect();
    let e = errs.iter().copied().fold(f64::INFINITY, f64::min);
    eprintln!(
        "{name}: FD rel err {errs:?} at h = {STEPS:?}, {:?}",
        fj.events
    );
    assert!(e < TOL, "{name}: Jacobian vs FD relative error {errs:?}");
    assert_eq!(fj.events.grazing, 0, "{name}");
    fj
}

fn window(sys: &ModalSystem, t_settle: f64, periods: f64) -> (ModalState, f64) {
    let x = settled(sys, t_settle);
    let t = x.t_s + periods * 2.0 * std::f64::consts::PI / sys.omega_rad_s();
    (x, t)
}

/// Determinant by LU with partial pivoting.
#[allow(clippy::needless_range_loop)]
fn det(a: &[Vec<f64>]) -> f64 {
    let mut m = a.to_vec();
    let n = m.len();
    let mut d = 1.0;
    for k in 0..n {
        let p = (k..n)
            .max_by(|&i, &j| m[i][k].abs().total_cmp(&m[j][k].abs()))
            .unwrap();
        if p != k {
            m.swap(p, k);
            d = -d;
        }
        let piv = m[k][k];
        d *= piv;
        if piv == 0.0 {
            return 0.0;
        }
        for i in k + 1..n {
            let f = m[i][k] / piv;
            for j in k..n {
                m[i][j] -= f * m[k][j];
            }
        }
    }
    d
}

#[test]
fn impacts_of_the_frictionless_beam_match_finite_differences() {
    for e in [0.5, 0.8] {
        let sys = beam(4, 0.08e-3, FrictionModel::None, None, Some(e));
        let (x, t) = window(&sys, 0.3, 2.0);
        let fj = check(&format!("4-mode frictionless e {e}"), &sys, &x, t);
        assert!(fj.events.impacts >= 4, "{:?}", fj.events);
    }
}

#[test]
fn plastic_impacts_match_finite_differences() {
    let sys = beam(4, 0.1e-3, FrictionModel::None, None, Some(0.0));
    let (x, t) = window(&sys, 0.3, 3.0);
    let fj = check("4-mode e = 0", &sys, &x, t);
    // Every impact puts the ball on the wall (the held phase, constrained modes) until it is
    // released.
    assert!(
        fj.events.impacts >= 4 && fj.events.releases >= 4,
        "{:?}",
        fj.events
    );
}

#[test]
fn friction_switches_match_finite_differences() {
    // As published, 1 N: the ball reverses in flight many times a period.
    // The run is chaotic, so which windows hold switches depends on its last bits: windows
    // from 0.3 s on, 10 ms apart, each checked, until one holds at least four.
    let sys = beam(4, 0.1e-3, FrictionModel::AsPublished, Some(1.0), None);
    let mut seen = Vec::new();
    for j in 0..20 {
        let (x, t) = window(&sys, 0.3 + 0.01 * j as f64, 2.0);
        let fj = check("4-mode as-published 1 N", &sys, &x, t);
        if fj.events.friction_switches >= 4 {
            return;
        }
        seen.push(fj.events.friction_switches);
    }
    panic!("no window with four switches: {seen:?}");
}

#[test]
fn stick_and_unstick_match_finite_differences() {
    // Coulomb 8 N, e = 0.3: impacts, switches, the ball sticks (constrained modes) and breaks
    // free; 20 N: stick and unstick only.
    let sys = beam(4, 0.1e-3, FrictionModel::Coulomb, Some(8.0), Some(0.3));
    let (x, t) = window(&sys, 0.3, 3.0);
    let fj = check("4-mode coulomb 8 N", &sys, &x, t);
    assert!(
        fj.events.impacts >= 4 && fj.events.friction_switches >= 4,
        "{:?}",
        fj.events
    );
    let sys = beam(4, 0.1e-3, FrictionModel::Coulomb, Some(20.0), None);
    let (x, t) = window(&sys, 0.3, 3.0);
    let fj = check("4-mode coulomb 20 N", &sys, &x, t);
    assert!(
        fj.events.sticks >= 2 && fj.events.unsticks >= 2,
        "{:?}",
        fj.events
    );
}

#[test]
fn impact_accumulation_and_release_match_finite_differences() {
    // As published, 2 N, 0.05 mm, e = 0.3: accumulating impact sequences summed to their
    // plastic limit, the ball riding the wall and released.
    // Half a period holding two summed sequences (over longer windows their sensitivity makes
    // the FD truncation dominate: 2.7e-6 at best over one period, measured).
    let sys = beam(4, 0.05e-3, FrictionModel::AsPublished, Some(2.0), Some(0.3));
    let half = 0.5 * 2.0 * std::f64::consts::PI / sys.omega_rad_s();
    let (x, t) = window(&sys, 0.3 + half, 0.5);
    let fj = check("4-mode as-published", &sys, &x, t);
    let ev = fj.events;
    assert!(ev.impacts >= 4 && ev.friction_switches >= 4, "{ev:?}");
    assert!(
        ev.plastic_impacts >= 1 && ev.chatter_limits >= 1 && ev.releases >= 1,
        "{ev:?}"
    );
}

/// Over a window of the frictionless beam, `det J = Πₙ e^{−(cₙ/mₙ)T} · e^{2·impacts}` (each
/// impact's saltation has `det S = e²`, module docs of `variational_modal`).
#[test]
fn impact_saltation_determinant_is_e_squared() {
    for e in [0.5, 0.8] {
        let sys = beam(3, 0.08e-3, FrictionModel::None, None, Some(e));
        let (x, t) = window(&sys, 0.3, 2.0);
        let fj = modal_flow_with_jacobian(&sys, &x, t).unwrap();
        assert!(
            fj.events.impacts >= 2 && fj.events.plastic_impacts == 0,
            "{:?}",
            fj.events
        );
        let decay: f64 = sys
            .model
            .modes()
            .iter()
            .map(|m| 2.0 * m.damping_ratio * m.omega_rad_s)
            .sum();
        let want = -decay * (t - x.t_s) + 2.0 * e.ln() * fj.events.impacts as f64;
        let got = det(&fj.jacobian).abs().ln();
        eprintln!("e {e}: ln det {got:.12} vs {want:.12}");
        assert!((got - want).abs() < 1e-9 * want.abs(), "{got} vs {want}");
    }
}

/// A one-mode table with every shape 1 is the lumped bar: the modal Jacobian equals the lumped
/// layer's on `(u, u̇, v, v̇)`.
#[test]
fn one_unit_mode_is_the_lumped_jacobian() {
    for (fm, f) in [
        (FrictionModel::None, None),
        (FrictionModel::Coulomb, Some(8.0)),
        (FrictionModel::AsPublished, None),
    ] {
        let mut lumped = System::paper_damped(0.1e-3, fm, 1.0);
        lumped.damper.as_mut().unwrap().friction_force_n =
            f.or(lumped.damper.unwrap().friction_force_n);
        let modal = ModalSystem::from_lumped(&lumped).unwrap();
        let x = Exact::default()
            .run(&lumped, &State::REST, 0.3, &mut ())
            .unwrap()
            .final_state;
        let t = x.t_s + 3.0 * lumped.forcing_period_s();
        let lj = flow_with_jacobian(&Exact::default(), &lumped, &x, t, &mut ()).unwrap();
        let mj = modal_flow_with_jacobian(&modal, &ModalState::from_lumped(&x), t).unwrap();
        let big = lj
            .jacobian
            .iter()
            .flatten()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        let err = (0..4)
            .flat_map(|r| (0..4).map(move |c| (r, c)))
            .map(|(r, c)| (lj.jacobian[r][c] - mj.jacobian[r][c]).abs())
            .fold(0.0, f64::max);
        eprintln!(
            "{fm:?}: lumped vs one-mode Jacobian {:.2e} of {big:.2e}, {:?}",
            err / big,
            mj.events
        );
        assert_eq!(lj.events, mj.events, "{fm:?}");
        assert!(err < 1e-8 * big, "{fm:?}: {err:e} of {big:e}");
    }
}

use vibrobar_core::analysis::lyapunov_spectrum::{
    lyapunov_spectrum, lyapunov_spectrum_modal, modal_volume_contraction_per_s, SpectrumParams,
};

/// The sum identity of the frictionless modal bar: `Σλ = −Σₙ cₙ/mₙ + 2 ln(e) × impacts/s`
/// (module docs of `lyapunov_spectrum`), on the 3- and 4-mode beams.
#[test]
fn spectrum_sum_of_the_frictionless_beam_is_the_volume_identity() {
    for (n, gap, e) in [(3, 0.1e-3, 0.6), (4, 0.08e-3, 0.5)] {
        let sys = beam(n, gap, FrictionModel::None, None, Some(e));
        let p = SpectrumParams {
            transient_s: 0.2,
            duration_s: 0.1,
            blocks: 5,
            scales: None,
        };
        let r = lyapunov_spectrum_modal(&sys, &ModalState::REST, &p).unwrap();
        let want = -modal_volume_contraction_per_s(&sys) + 2.0 * e.ln() * r.impacts_per_s;
        eprintln!(
            "{n} modes, {gap}: λ = {:?}, Σλ {:.10} vs identity {:.10} ({:.2e} rel), {:?}",
            r.exponents_per_s,
            r.sum_per_s,
            want,
            ((r.sum_per_s - want) / want).abs(),
            r.events
        );
        assert_eq!(r.collapsed, 0);
        assert_eq!(r.exponents_per_s.len(), 2 * n + 2);
        assert!(r.impacts_per_s > 100.0 && r.events.plastic_impacts == 0);
        assert!(
            ((r.sum_per_s - want) / want).abs() < 1e-9,
            "{} vs {want}",
            r.sum_per_s
        );
    }
}

/// One unit mode: the modal spectrum is the lumped layer's, on the stable two-impact orbit at
/// 0.08 mm (a chaotic point would not do: the two solvers' trajectories, equal to 1e-12, part
/// at the rate of the largest exponent).
#[test]
fn one_unit_mode_spectrum_is_the_lumped_spectrum() {
    let lumped = System::paper_damped(0.08e-3, FrictionModel::None, 1.0);
    let modal = ModalSystem::from_lumped(&lumped).unwrap();
    let p = SpectrumParams {
        transient_s: 0.2,
        duration_s: 0.2,
        blocks: 5,
        scales: None,
    };
    let l = lyapunov_spectrum(&lumped, &State::REST, &Exact::default(), &p).unwrap();
    let m = lyapunov_spectrum_modal(&modal, &ModalState::REST, &p).unwrap();
    eprintln!(
        "lumped {:?} {:?}\nmodal  {:?} {:?}",
        l.exponents_per_s, l.events, m.exponents_per_s, m.events
    );
    assert_eq!(l.events, m.events);
    // Each complex Floquet pair's two exponents split differently over a finite window in
    // another inner product; their sum (the pair's 2-plane volume) does not (measured: the
    // pairs agree to 4e-3 and 5e-4, the whole sums to 1e-9 as asserted).
    let ex = |r: &vibrobar_core::analysis::lyapunov_spectrum::SpectrumResult| -> Vec<f64> {
        r.exponents_per_s.iter().map(|x| x.unwrap()).collect()
    };
    let (a, b) = (ex(&l), ex(&m));
    for k in [0, 2] {
        let (pa, pb) = (a[k] + a[k + 1], b[k] + b[k + 1]);
        eprintln!("pair {k}: {pa} vs {pb}");
        assert!(((pa - pb) / pa).abs() < 1e-2, "{pa} vs {pb}");
    }
    assert!(((l.sum_per_s - m.sum_per_s) / l.sum_per_s).abs() < 1e-9);
}

// ---- The hertz law (compliant contact phases) ----

use vibrobar_core::params::ContactLaw;

/// `sys` under the hertz law.
fn with_hertz(mut sys: ModalSystem) -> ModalSystem {
    sys.damper.as_mut().unwrap().contact.law = ContactLaw::Hertz;
    sys
}

/// A settled state in free flight (not inside a contact) near `t_s`.
fn settled_free(sys: &ModalSystem, t_s: f64) -> ModalState {
    let lg = sys.damper.unwrap().half_gap_m();
    let mut t = t_s;
    loop {
        let s = settled(sys, t);
        if s.w_m(&sys.model).abs() < 0.99 * lg {
            return s;
        }
        t += 1e-4;
    }
}

/// FD steps and tolerance through compliant phases. The solver's contact phase runs at
/// `CONTACT_RTOL = 1e-9`: its end state is not differentiable to better than that lets the step
/// sequence move with the start state, and the beam's scaled Jacobian amplifies it (measured at
/// the best step: 2.9e-4, 1.7e-3, 6.0e-6, 2.3e-4, 2.3e-6 for the cases below). With the phase
/// and the tangent at 1e-12 (the constant edited) the same comparison gives 1.2e-6, 8.3e-6,
/// 2.0e-7, 1.4e-7, that is the FD's own truncation and rounding; leaving out the approach-speed
/// memory (`c = 0`) gives 0.77–1.08.
const HERTZ_STEPS: [f64; 3] = [1e-3, 1e-4, 1e-5];
const HERTZ_TOL: f64 = 5e-3;

/// Goal: the modal Jacobian through compliant contact phases (onset and release `S = I`, the
/// approach-speed memory, friction reversing and sticking inside and between contacts) against
/// central differences of `ModalExact`, over two periods holding four to eight contacts.
#[test]
fn hertz_contact_phases_of_the_beam_match_finite_differences() {
    for (name, n, gap, fm, f) in [
        ("3-mode frictionless", 3, 0.1e-3, FrictionModel::None, None),
        ("4-mode frictionless", 4, 0.08e-3, FrictionModel::None, None),
        (
            "3-mode as-published",
            3,
            0.1e-3,
            FrictionModel::AsPublished,
            None,
        ),
        (
            "3-mode coulomb 5 N",
            3,
            0.08e-3,
            FrictionModel::Coulomb,
            Some(5.0),
        ),
        (
            "3-mode coulomb 5 N, 0.02 mm",
            3,
            0.02e-3,
            FrictionModel::Coulomb,
            Some(5.0),
        ),
    ] {
        let sys = with_hertz(beam(n, gap, fm, f, None));
        let x = settled_free(&sys, 0.3);
        let t = x.t_s + 2.0 * 2.0 * std::f64::consts::PI / sys.omega_rad_s();
        let d = 2 * n + 2;
        let all: Vec<usize> = (0..d).collect();
        let fj = modal_flow_with_jacobian(&sys, &x, t).unwrap();
        let js = scaled(&sys, &fj.jacobian);
        let errs: Vec<f64> = HERTZ_STEPS
            .iter()
            .map(|&h| rel_err(&fd_jacobian(&sys, &x, t, h, &all), &js, &all))
            .collect();
        let e = errs.iter().copied().fold(f64::INFINITY, f64::min);
        let ev = fj.events;
        eprintln!("{name}: FD rel err {errs:?} at h = {HERTZ_STEPS:?}, {ev:?}");
        assert!(
            e < HERTZ_TOL,
            "{name}: Jacobian vs FD relative error {errs:?}"
        );
        assert_eq!(ev.grazing, 0, "{name}");
        assert!(ev.compliant_contacts >= 4, "{name}: {ev:?}");
        assert_eq!(ev.compliant_contacts, ev.impacts, "{name}: {ev:?}");
        if fm != FrictionModel::None {
            // At least one reversal per contact (inside it), besides those in flight.
            assert!(
                ev.friction_switches >= ev.compliant_contacts,
                "{name}: {ev:?}"
            );
        }
        if gap == 0.02e-3 {
            assert!(ev.sticks >= 2 && ev.unsticks >= 2, "{name}: {ev:?}");
        }
    }
}

/// One unit mode is the lumped bar under the hertz law too: the modal Jacobian through its
/// compliant phases equals the lumped layer's. The two solvers' trajectories agree to 5e-14 m;
/// the two layers integrate the same tangent equations at `HERTZ_TANGENT_RTOL = 1e-9`, the
/// lumped one as one 4×5 block, the modal one column by column, so their step sequences
/// differ: measured 5.7e-9, 9.1e-10, 4.0e-8 of the largest entry over three periods with six
/// contacts (friction reversing inside each); the bound 1e-6 is 25× the worst of them and 100×
/// below what a wrong term gives (the approach memory alone is O(1)).
#[test]
fn one_unit_mode_is_the_lumped_jacobian_under_hertz() {
    for (fm, f) in [
        (FrictionModel::None, None),
        (FrictionModel::Coulomb, Some(5.0)),
        (FrictionModel::AsPublished, None),
    ] {
        let mut lumped = System::paper_damped(0.08e-3, fm, 1.0);
        let d = lumped.damper.as_mut().unwrap();
        d.friction_force_n = f.or(d.friction_force_n);
        d.contact.law = ContactLaw::Hertz;
        let lg = d.half_gap_m();
        let modal = ModalSystem::from_lumped(&lumped).unwrap();
        let mut t0 = 0.3;
        let x = loop {
            let x = Exact::default()
                .run(&lumped, &State::REST, t0, &mut ())
                .unwrap()
                .final_state;
            if x.w_m().abs() < 0.99 * lg {
                break x;
            }
            t0 += 1e-4;
        };
        let t = x.t_s + 3.0 * lumped.forcing_period_s();
        let lj = flow_with_jacobian(&Exact::default(), &lumped, &x, t, &mut ()).unwrap();
        let mj = modal_flow_with_jacobian(&modal, &ModalState::from_lumped(&x), t).unwrap();
        let big = lj
            .jacobian
            .iter()
            .flatten()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        let err = (0..4)
            .flat_map(|r| (0..4).map(move |c| (r, c)))
            .map(|(r, c)| (lj.jacobian[r][c] - mj.jacobian[r][c]).abs())
            .fold(0.0, f64::max);
        eprintln!(
            "{fm:?}: lumped vs one-mode Jacobian under hertz {:.2e} of {big:.2e}, {:?}",
            err / big,
            mj.events
        );
        assert_eq!(lj.events, mj.events, "{fm:?}");
        assert!(mj.events.compliant_contacts >= 1, "{fm:?}");
        assert!(err < 1e-6 * big, "{fm:?}: {err:e} of {big:e}");
    }
}

/// The modal spectrum under the hertz law: nothing collapses in a contact, the frictionless
/// one-unit-mode bar gives the lumped spectrum's sum (the approach memory included).
#[test]
fn one_unit_mode_spectrum_under_hertz_is_the_lumped_spectrum() {
    let mut lumped = System::paper_damped(0.08e-3, FrictionModel::None, 1.0);
    lumped.damper.as_mut().unwrap().contact.law = ContactLaw::Hertz;
    let modal = ModalSystem::from_lumped(&lumped).unwrap();
    let p = SpectrumParams {
        transient_s: 0.2,
        duration_s: 0.2,
        blocks: 5,
        scales: None,
    };
    let l = lyapunov_spectrum(&lumped, &State::REST, &Exact::default(), &p).unwrap();
    let m = lyapunov_spectrum_modal(&modal, &ModalState::REST, &p).unwrap();
    eprintln!(
        "lumped {:?} Σ {} memory {}\nmodal  {:?} Σ {} memory {}",
        l.exponents_per_s,
        l.sum_per_s,
        l.approach_memory_per_s,
        m.exponents_per_s,
        m.sum_per_s,
        m.approach_memory_per_s
    );
    assert_eq!(l.events, m.events);
    assert_eq!(m.collapsed, 0);
    assert!(m.events.compliant_contacts > 100, "{:?}", m.events);
    assert!(((l.sum_per_s - m.sum_per_s) / l.sum_per_s).abs() < 1e-6);
    assert!(
        ((l.approach_memory_per_s - m.approach_memory_per_s) / l.approach_memory_per_s).abs()
            < 1e-6
    );
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

/// A body force on the ball along the gap on the 4-mode beam: in free flight the ball's
/// acceleration gains `g_s`; held, the wall's force is `(a_b − g_s)/κ`, which moves the release.
/// At the paper's force the ball impacts (with `e = 0` it is held on the wall after each impact
/// and released); at 2 N it makes long flights across the 1 mm gap.
#[test]
fn a_body_force_on_the_ball_matches_finite_differences() {
    let g = 9.80665;
    for (name, gap_m, f0, gs, e, periods) in [
        (
            "4-mode paper force, 0.1 mm, g towards −",
            0.1e-3,
            15.0,
            -g,
            0.5,
            3.0,
        ),
        (
            "4-mode e = 0, 0.1 mm: held and released",
            0.1e-3,
            15.0,
            -g,
            0.0,
            3.0,
        ),
        (
            "4-mode 2 N, 1 mm: lands and flies",
            1.0e-3,
            2.0,
            -g,
            0.5,
            12.0,
        ),
    ] {
        let mut sys = beam(4, gap_m, FrictionModel::None, None, Some(e));
        sys.forcing.amplitude_n = f0;
        sys.damper.as_mut().unwrap().gravity_along_gap_m_s2 = gs;
        let mut flight = FirstFlight {
            t_from: 0.3,
            mid: None,
        };
        ModalExact::default()
            .run(&sys, &ModalState::REST, 0.35, &mut flight)
            .unwrap();
        let t0 = flight.mid.expect("a flight after the settling time");
        let x = settled(&sys, t0);
        let t = t0 + periods * 2.0 * std::f64::consts::PI / sys.omega_rad_s();
        let fj = check(name, &sys, &x, t);
        assert!(fj.events.impacts >= 2, "{name}: {:?}", fj.events);
        if e == 0.0 {
            assert!(fj.events.releases >= 2, "{name}: {:?}", fj.events);
        }
    }
}
