//! The variational layer through compliant (`hertz`) contact phases (issue #11): the Jacobian
//! against central differences of the exact solver, the Lyapunov sum against the trace of the
//! vector field, and the approach to the restitution law as the contact stiffens.

use vibrobar_core::analysis::lyapunov_spectrum::{lyapunov_spectrum, SpectrumParams};
use vibrobar_core::analysis::variational::{det4, flow_with_jacobian, FlowJacobian};
use vibrobar_core::damper::contact::Hertz;
use vibrobar_core::params::{ContactLaw, FrictionModel, State, System};
use vibrobar_core::solver::{Exact, Mode, Observer, Segment, Solver};

#[path = "common/variational_fd.rs"]
mod variational_fd;
use variational_fd::{fd_jacobian, rel_err, scaled};

fn hertz(gap_m: f64, friction: FrictionModel, ratio: f64, f_n: Option<f64>) -> System {
    let mut sys = System::paper_damped(gap_m, friction, ratio);
    let d = sys.damper.as_mut().unwrap();
    d.friction_force_n = f_n.or(d.friction_force_n);
    d.contact.law = ContactLaw::Hertz;
    sys
}

/// A settled state in free flight (not inside a contact) near `t_s`.
fn settled_free(sys: &System, t_s: f64) -> State {
    let lg = sys.damper.unwrap().half_gap_m();
    let mut t = t_s;
    loop {
        let s = Exact::default()
            .run(sys, &State::REST, t, &mut ())
            .unwrap()
            .final_state;
        if s.w_m().abs() < 0.99 * lg {
            return s;
        }
        t += 1e-4;
    }
}

fn check(name: &str, sys: &System, x: &State, t_end: f64, h: f64, tol: f64) -> FlowJacobian {
    let fj = flow_with_jacobian(&Exact::default(), sys, x, t_end, &mut ()).unwrap();
    let js = scaled(sys, &fj.jacobian);
    let all = [0, 1, 2, 3];
    let fd = fd_jacobian(sys, x, t_end, h, &all);
    let e = rel_err(&fd, &js, &all);
    eprintln!(
        "{name}: FD rel err {e:.3e} (h {h:e}), {:?}, det {:.6e}",
        fj.events,
        det4(&fj.jacobian)
    );
    eprintln!("  J  {:?}\n  FD {:?}", js, fd);
    assert!(e < tol, "{name}: Jacobian vs FD relative error {e:e}");
    fj
}

/// FD step (units of the scales) and tolerance on the largest entry error over the largest
/// entry. The solver's contact phase runs at `CONTACT_RTOL = 1e-9`: its end state is not
/// differentiable to better than ~1e-5 relative (the step sequence moves with the start state),
/// so central differences agree with the Jacobian to ~1e-5 at every step from 1e-3 to 1e-6
/// (measured, frictionless 0.08 mm: 1.1e-5 at each; with the phase at 1e-12 the agreement is
/// 2e-8). Leaving out the approach-speed memory (`c = 0`) gives 0.16–0.46.
const H: f64 = 1e-4;
const TOL_FRICTIONLESS: f64 = 1e-4;
/// Three periods, 5–6 contacts with friction reversing inside each: measured 8e-6 … 1.6e-4.
const TOL_FRICTION: f64 = 1e-3;

#[test]
fn frictionless_contact_phases_match_finite_differences() {
    for (gap, ratio) in [(0.08e-3, 1.0), (0.1e-3, 0.99)] {
        let sys = hertz(gap, FrictionModel::None, ratio, None);
        let x = settled_free(&sys, 0.3);
        let t = x.t_s + 1.0 * sys.forcing_period_s();
        for h in [H, 0.1 * H] {
            let fj = check("hertz frictionless", &sys, &x, t, h, TOL_FRICTIONLESS);
            assert!(fj.events.compliant_contacts >= 1, "{:?}", fj.events);
            assert_eq!(fj.events.compliant_contacts, fj.events.impacts);
            assert_eq!(fj.events.grazing, 0);
        }
    }
}

#[test]
fn frictional_contact_phases_match_finite_differences() {
    // Sliding friction acts through each contact and reverses where δ̇ crosses 0 (peak
    // compression): a saltation inside every contact phase; Coulomb 5 N at 0.02 mm also sticks
    // and unsticks in free flight after its contacts.
    for (name, fm, f, gap) in [
        ("as-published", FrictionModel::AsPublished, None, 0.1e-3),
        ("coulomb 5 N", FrictionModel::Coulomb, Some(5.0), 0.08e-3),
        ("coulomb 2 N", FrictionModel::Coulomb, Some(2.0), 0.08e-3),
        (
            "coulomb 5 N, 0.02 mm",
            FrictionModel::Coulomb,
            Some(5.0),
            0.02e-3,
        ),
    ] {
        let sys = hertz(gap, fm, 1.0, f);
        let x = settled_free(&sys, 0.3);
        let t = x.t_s + 3.0 * sys.forcing_period_s();
        let fj = check(name, &sys, &x, t, H, TOL_FRICTION);
        let ev = fj.events;
        assert!(ev.compliant_contacts >= 1, "{name}: {ev:?}");
        // At least one reversal per contact (inside it) besides those in flight.
        assert!(
            ev.friction_switches >= ev.compliant_contacts,
            "{name}: {ev:?}"
        );
        assert_eq!(ev.grazing, 0, "{name}");
    }
}

/// `∫ tr(∂f/∂x) dt` along a run, from the segments' states: `−C/M` in flight and
/// `−C/M − K_h δ^{3/2} (D/δ̇₀)(1/M + 1/m_d)` in a compliant contact (composite 5-point
/// Gauss–Legendre on each step). Frictionless runs only (no stick).
struct Trace {
    c_over_m: f64,
    inv_mass: f64,
    lg: f64,
    law: Hertz,
    integral: f64,
    contacts: u64,
    last_contact_end: f64,
}

impl Observer for Trace {
    fn segment(&mut self, seg: &dyn Segment) {
        let (a, b) = (seg.t_start_s(), seg.t_end_s());
        assert!(
            seg.mode() == Mode::Free || seg.compliant_contact().is_some(),
            "{:?}",
            seg.mode()
        );
        self.integral -= self.c_over_m * (b - a);
        let Some(c) = seg.compliant_contact() else {
            return;
        };
        assert_eq!(c.law, self.law);
        if a != self.last_contact_end {
            self.contacts += 1;
        }
        self.last_contact_end = b;
        const X: [f64; 5] = [
            -0.906_179_845_938_664,
            -0.538_469_310_105_683,
            0.0,
            0.538_469_310_105_683,
            0.906_179_845_938_664,
        ];
        const W: [f64; 5] = [
            0.236_926_885_056_189,
            0.478_628_670_499_366,
            0.568_888_888_888_889,
            0.478_628_670_499_366,
            0.236_926_885_056_189,
        ];
        let pieces = 16;
        let hp = (b - a) / pieces as f64;
        let d_over_v0 = self.law.damping / c.reference_speed_m_s;
        for k in 0..pieces {
            let mid = a + (k as f64 + 0.5) * hp;
            for (x, w) in X.iter().zip(W) {
                let s = seg.state_at(mid + 0.5 * hp * x);
                let delta = (c.wall_sign * s.w_m() - self.lg).max(0.0);
                let p_dd = self.law.stiffness_n_m32 * delta * delta.sqrt() * d_over_v0;
                self.integral -= w * 0.5 * hp * p_dd * self.inv_mass;
            }
        }
    }
}

/// The Lyapunov sum against the trace of the vector field, replaying the spectrum's runs
/// (transient, then the blocks, each started from the last one's end put back on the wall).
fn trace_of_spectrum_window(sys: &System, p: &SpectrumParams) -> (f64, u64) {
    let bar = sys.lumped_bar().unwrap();
    let d = sys.damper.unwrap();
    let lg = d.half_gap_m();
    let mut tr = Trace {
        c_over_m: bar.damping_n_s_per_m() / bar.mass_kg,
        inv_mass: 1.0 / bar.mass_kg + 1.0 / d.ball_mass_kg,
        lg,
        law: Hertz::of_damper(&d),
        integral: 0.0,
        contacts: 0,
        last_contact_end: f64::NAN,
    };
    let onto = |mut s: State| {
        // The library's onto_cavity: on the wall, stepped inwards by ulps.
        let w = s.w_m();
        if w.abs() > lg {
            s.v_m = s.u_m + lg.copysign(w);
            for _ in 0..64 {
                if s.w_m().abs() <= lg {
                    break;
                }
                s.v_m -= w.signum() * f64::EPSILON * s.v_m.abs();
            }
        }
        s
    };
    let ex = Exact::default();
    let mut x = onto(
        ex.run(sys, &State::REST, p.transient_s, &mut ())
            .unwrap()
            .final_state,
    );
    let t0 = x.t_s;
    let block = p.duration_s / p.blocks as f64;
    for b in 1..=p.blocks {
        x = onto(
            ex.run(sys, &x, t0 + b as f64 * block, &mut tr)
                .unwrap()
                .final_state,
        );
    }
    (tr.integral / p.duration_s, tr.contacts)
}

/// The exponents sum to `ln|det J|/T`. Inside a contact phase Liouville gives the trace of the
/// field's Jacobian; the law's reference speed `δ̇₀`, fixed from the touch state, adds
/// `ln|1 + cᵀW⁻¹ζ|` per contact (module docs of `variational`). The trace is integrated here
/// from the solver's own segments (independent of the tangent integration); the memory term
/// is the layer's. At `e = 1` (`D = 0`) the law has no memory and the sum is the trace alone.
/// Measured (100 periods): 3.9e-10 (e = 0.5), 2.0e-8 (e = 1), 4.1e-9 (e = 0.9, chaotic).
#[test]
fn lyapunov_sum_is_the_trace_plus_the_approach_memory() {
    for (e, gap) in [(0.5, 0.08e-3), (1.0, 0.08e-3), (0.9, 0.1e-3)] {
        let mut sys = hertz(gap, FrictionModel::None, 1.0, None);
        sys.damper.as_mut().unwrap().restitution = e;
        let p = SpectrumParams::periods(&sys, 0.3, 100.0);
        let sp = lyapunov_spectrum(&sys, &State::REST, &Exact::default(), &p).unwrap();
        let (trace, contacts) = trace_of_spectrum_window(&sys, &p);
        let want = trace + sp.approach_memory_per_s;
        let rel = (sp.sum_per_s - want).abs() / want.abs();
        eprintln!(
            "e {e}, gap {gap}: sum {:.9e}, trace {trace:.9e} + memory {:.9e} (rel {rel:.2e}), \
             {contacts} contacts, {:?}",
            sp.sum_per_s, sp.approach_memory_per_s, sp.exponents_per_s
        );
        assert_eq!(sp.collapsed, 0, "{sp:?}");
        assert!(contacts >= 150, "{contacts}");
        assert!(rel < 1e-6, "e {e}: {} vs {want}", sp.sum_per_s);
        if e == 1.0 {
            assert_eq!(sp.approach_memory_per_s, 0.0);
        } else {
            // The memory is not a correction: without it the identity is off by a third.
            assert!(
                sp.approach_memory_per_s > 0.25 * sp.sum_per_s.abs(),
                "{sp:?}"
            );
        }
    }
}

/// The paper's point (frictionless, 0.08 mm, r = 1) with both moduli scaled by `s`
/// (`K_h ∝ E*`).
fn stiffened(s: f64) -> System {
    let mut sys = hertz(0.08e-3, FrictionModel::None, 1.0, None);
    let c = &mut sys.damper.as_mut().unwrap().contact;
    c.ball_modulus_pa *= s;
    c.wall_modulus_pa *= s;
    sys
}

/// As the contact stiffens (contact time `∝ K_h^{−2/5}`) the hertz orbit and its multipliers
/// tend to the restitution law's (the same target `e` at every speed). Newton from the
/// analytic symmetric orbit with the exact Jacobian (4 iterations at `K_h × 1`), and the largest
/// multiplier against that of central differences of the map (measured ~4e-7 apart).
#[test]
fn stiffer_contacts_approach_the_restitution_orbit() {
    use vibrobar_core::analysis::orbit::*;
    let mut rest = stiffened(1.0);
    rest.damper.as_mut().unwrap().contact.law = ContactLaw::Restitution;
    let newton = NewtonSettings::default();
    let (sec, x0) = starting_guess(&rest, 1, &Start::Symmetric(0)).unwrap();
    let o_rest = find_orbit(&sec, &x0, &ExactJacobian, &newton).unwrap();
    let sc = scales(&rest);
    let mods = |o: &PeriodicOrbit| {
        let mut m: Vec<f64> = o.multipliers.iter().map(|l| l.norm()).collect();
        m.sort_by(|a, b| b.total_cmp(a));
        m
    };
    let m_rest = mods(&o_rest);
    let mut last = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
    for s in [1.0, 1e2, 1e4] {
        let sys = stiffened(s);
        let (sec, x0) = starting_guess(&sys, 1, &Start::Symmetric(0)).unwrap();
        let o = find_orbit(&sec, &x0, &ExactJacobian, &newton).unwrap();
        assert_eq!(o.impacts_per_period, 2);
        assert!(o.physicality.confined && o.residual <= 1e-9, "{o:?}");
        // The multipliers from the variational Jacobian against central differences.
        let (_, fd) = FiniteDifference::default()
            .map_and_jacobian(&sec, &vibrobar_core::analysis::orbit::to_vector(&o.state))
            .unwrap();
        let fd_max = multipliers_of(&fd)
            .iter()
            .map(|l| l.norm())
            .fold(0.0, f64::max);
        assert!(
            (fd_max - o.max_abs_multiplier()).abs() < 1e-4,
            "s {s}: {fd_max} vs {}",
            o.max_abs_multiplier()
        );
        // The orbit at the same section phase as the restitution one.
        let p = Section::new(sys, o_rest.section.t0_s, 1).unwrap();
        let xr = to_vector(&o_rest.state);
        let x = find_orbit(&p, &xr, &ExactJacobian, &newton).unwrap();
        let dx = (0..4)
            .map(|i| ((to_vector(&x.state)[i] - xr[i]) / sc[i]).abs())
            .fold(0.0, f64::max);
        let m = mods(&x);
        let dm = (0..4).map(|i| (m[i] - m_rest[i]).abs()).fold(0.0, f64::max);
        let drms = (x.rms_m / o_rest.rms_m - 1.0).abs();
        eprintln!(
            "K_h × {s:e}: max compression {:.3e} m, state {dx:.3e}, RMS {drms:.3e}, \
             |multipliers| {dm:.3e} ({m:?} vs {m_rest:?})",
            x.physicality.max_penetration_m
        );
        // Each 100× in K_h divides the contact time by 100^{2/5} = 6.3: measured state
        // 2.39 → 0.370 → 0.058 (scaled), RMS 7.5 % → 2.6 % → 0.43 %, |multipliers| 0.118 →
        // 7.7e-3 → 1.1e-3.
        assert!(
            dx < 0.25 * last.0 && drms < 0.5 * last.1 && dm < 0.25 * last.2,
            "s {s}: {dx} {drms} {dm} after {last:?}"
        );
        last = (dx, drms, dm);
    }
    assert!(last.1 < 0.01 && last.2 < 2e-3, "{last:?}");
}

/// Each contact's tangent map tends to the restitution law's saltation (determinant `e²`) as
/// the contact stiffens: the exponents' sum tends to `−C/M + 2 ln(e) × contacts per second`
/// (shared VALIDATION.md), reached by the trace and the approach memory together. Measured
/// (relative gap, K_h × 1, 10, 1e2, 1e3, 1e4, 1e6): 2.1e-3, 4.3e-3, 2.2e-3, 9.8e-4, 4.0e-4,
/// 6.5e-5: not monotone below ×10, then like the contact time, `K_h^{−2/5}` (6.2× per 100×).
#[test]
fn stiff_contacts_recover_the_restitution_volume_identity() {
    let mut last = f64::INFINITY;
    for s in [1e2, 1e4, 1e6] {
        let sys = stiffened(s);
        let p = SpectrumParams::periods(&sys, 0.3, 100.0);
        let sp = lyapunov_spectrum(&sys, &State::REST, &Exact::default(), &p).unwrap();
        let bar = sys.lumped_bar().unwrap();
        let e = sys.damper.unwrap().restitution;
        let want = -bar.damping_n_s_per_m() / bar.mass_kg + 2.0 * e.ln() * sp.impacts_per_s;
        let rel = (sp.sum_per_s - want).abs() / want.abs();
        eprintln!(
            "K_h × {s:e}: sum {:.6e}, restitution identity {want:.6e}, rel {rel:.2e} \
             (memory {:.4e})",
            sp.sum_per_s, sp.approach_memory_per_s
        );
        assert!(rel < 0.3 * last, "K_h × {s}: {rel} after {last}");
        last = rel;
    }
    assert!(last < 1e-4, "{last}");
}

/// The parameter column is not built through compliant phases: a clear refusal (the
/// continuation takes central differences of the map instead: `map_param_derivative` is
/// `None` there).
#[test]
fn the_parameter_column_is_refused_under_hertz() {
    use vibrobar_core::analysis::orbit::continuation::map_param_derivative;
    use vibrobar_core::analysis::orbit::Section;
    use vibrobar_core::analysis::variational::{flow_with_param_derivative, Param};
    let sys = hertz(0.08e-3, FrictionModel::None, 1.0, None);
    let x = settled_free(&sys, 0.3);
    let e = flow_with_param_derivative(
        &Exact::default(),
        &sys,
        &x,
        x.t_s + 1e-3,
        Param::GapM,
        &mut (),
    )
    .unwrap_err();
    assert!(e.to_string().contains("central differences"), "{e}");
    let sec = Section::new(sys, x.t_s, 1).unwrap();
    let v = vibrobar_core::analysis::orbit::to_vector(&x);
    let axis = vibrobar_core::analysis::grid::Axis::GapM;
    assert!(map_param_derivative(&sec, axis, &v).unwrap().is_none());
}
