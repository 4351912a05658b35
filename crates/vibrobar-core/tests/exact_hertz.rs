//! The `hertz` contact law in the lumped exact solver: single contacts against closed forms and
//! momentum conservation, an independent RK4 of the contact phase, the energy books of a paper
//! run, and bad input.

mod common;

use common::{constant_push, Recorder};
use vibrobar_core::analysis::energy::EnergyAudit;
use vibrobar_core::damper::contact::Hertz;
use vibrobar_core::solver::exact::Exact;
use vibrobar_core::solver::{EventKind, Mode, Rk4, Solver};
use vibrobar_core::*;

fn hertz(mut sys: System) -> System {
    if let Some(d) = sys.damper.as_mut() {
        d.contact = Contact::hertz();
    }
    sys
}

/// A free pair (vanishing spring, no force): the ball arrives at 0.1 m/s. During the contact
/// momentum is conserved; the pair separates with `ẇ+ = −e ẇ−` (the exact `D(e)` holds for two
/// free bodies with `m_eff`); undamped (`e = 1`) the contact time is Hertz's with `m_eff`.
#[test]
fn free_pair_contact_conserves_momentum_with_target_restitution_and_hertz_time() {
    for e in [1.0, 0.5, 0.2] {
        let sys = hertz(constant_push(0.0, 1e-3, e));
        let d = sys.damper.unwrap();
        let (m, md) = (sys.lumped_bar().unwrap().mass_kg, d.ball_mass_kg);
        let v0 = 0.1;
        let init = State {
            t_s: 0.0,
            u_m: 0.0,
            du_m_s: 0.0,
            v_m: 0.0,
            dv_m_s: v0,
            cavity: None,
        };
        let mut rec = Recorder::default();
        Exact::default().run(&sys, &init, 0.1, &mut rec).unwrap();
        let first = rec.impacts()[0];
        let (a, b) = (first.after.du_m_s, first.after.dv_m_s);
        let p0 = md * v0;
        let p1 = m * a + md * b;
        assert!((p1 - p0).abs() < 1e-9 * p0, "{e}: momentum {p0} → {p1}");
        let dw_out = b - a;
        assert!((dw_out + e * v0).abs() < 1e-6 * v0, "{e}: ẇ+ = {dw_out}");
        let meff = m * md / (m + md);
        let law = Hertz::of_damper(&d);
        if let EventKind::Impact { energy_loss_j, .. } = first.kind {
            let want = 0.5 * meff * (1.0 - e * e) * v0 * v0;
            assert!(
                (energy_loss_j - want).abs() <= 1e-6 * want.max(1e-12),
                "{e}: {energy_loss_j} {want}"
            );
        }
        // Contact time: the span of the contact segments before the first release.
        let t_touch = rec
            .segs
            .iter()
            .find(|s| matches!(s.2, Mode::Contact(_)))
            .unwrap()
            .0;
        let tc = first.t_s - t_touch;
        if e == 1.0 {
            let want = law.undamped_contact_time_s(meff, v0);
            assert!((tc / want - 1.0).abs() < 1e-4, "{tc} {want}");
        }
        assert!(
            rec.impacts().len() >= 2,
            "{e}: the ball goes on to the other wall"
        );
    }
}

/// An independent computation of one contact on the paper's forced bar: a plain fixed-step RK4
/// of the same equations at 2e5 steps per contact time gives the same release time and
/// velocities.
#[test]
fn contact_phase_matches_an_independent_fixed_step_rk4() {
    let sys = hertz(System::paper_damped(0.1e-3, FrictionModel::None, 1.0));
    let d = sys.damper.unwrap();
    let bar = *sys.lumped_bar().unwrap();
    let lg = d.half_gap_m();
    let (u0, du0, v0) = (2e-6, 0.01, 0.05);
    let t0 = 1e-4;
    let init = State {
        t_s: t0,
        u_m: u0,
        du_m_s: du0,
        v_m: u0 + lg,
        dv_m_s: du0 + v0,
        cavity: None,
    };
    let mut rec = Recorder::default();
    Exact::default()
        .run(&sys, &init, t0 + 2e-4, &mut rec)
        .unwrap();
    let ev = rec.impacts()[0];
    // Reference: y = [u, u̇, δ, δ̇], the wall +.
    let law = Hertz::of_damper(&d);
    let (m, md, k, c) = (
        bar.mass_kg,
        d.ball_mass_kg,
        bar.stiffness_n_per_m,
        bar.damping_n_s_per_m(),
    );
    let om = sys.omega_rad_s();
    let f = |t: f64, y: [f64; 4]| {
        let p = law.force_n(y[2], y[3], v0);
        let ddu = (sys.forcing.amplitude_n * (om * t).sin() - c * y[1] - k * y[0] + p) / m;
        [y[1], ddu, y[3], -p / md - ddu]
    };
    let tc = law.undamped_contact_time_s(m * md / (m + md), v0);
    let h = tc / 2e5;
    let (mut t, mut y) = (t0, [u0, du0, 0.0, v0]);
    loop {
        let k1 = f(t, y);
        let ad = |a: [f64; 4], s: f64, k: [f64; 4]| std::array::from_fn(|i| a[i] + s * k[i]);
        let k2 = f(t + h / 2.0, ad(y, h / 2.0, k1));
        let k3 = f(t + h / 2.0, ad(y, h / 2.0, k2));
        let k4 = f(t + h, ad(y, h, k3));
        let yn: [f64; 4] =
            std::array::from_fn(|i| y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
        if yn[2] < 0.0 && t > t0 {
            // Linear interpolation of the release inside the last step.
            let th = y[2] / (y[2] - yn[2]);
            let t_rel = t + th * h;
            let dw = y[3] + th * (yn[3] - y[3]);
            assert!((ev.t_s - t_rel).abs() < 1e-6 * tc, "{} {t_rel}", ev.t_s);
            let dw_ex = ev.after.dv_m_s - ev.after.du_m_s;
            assert!((dw_ex - dw).abs() < 1e-6 * v0, "{dw_ex} {dw}");
            let du = y[1] + th * (yn[1] - y[1]);
            assert!(
                (ev.after.du_m_s - du).abs() < 1e-6 * v0,
                "{} {du}",
                ev.after.du_m_s
            );
            break;
        }
        y = yn;
        t += h;
    }
}

/// The energy books of a paper run with the hertz law close: ΔE = input − viscous − contact
/// dissipation, to a residual far below the input (the integrator's tolerance, rtol 1e-9).
#[test]
fn paper_run_energy_books_close_with_contact_dissipation() {
    for friction in FrictionModel::ALL {
        let sys = hertz(System::paper_damped(0.1e-3, friction, 1.0));
        let mut audit = EnergyAudit::new(&sys);
        let s = Exact::default()
            .run(&sys, &State::default(), 0.1, &mut audit)
            .unwrap();
        let b = audit.balance().unwrap();
        assert!(s.impacts > 50, "{s:?}");
        assert!(b.impact_loss_j > 0.0);
        let rel = b.residual_j.abs() / b.work_input_j.abs();
        eprintln!("{friction}: {b:?} rel {rel:e}");
        assert!(rel < 1e-7, "{friction}: {b:?}");
        assert!(
            s.max_penetration_m > 0.0 && s.max_penetration_m < 1e-5,
            "{s:?}"
        );
    }
}

/// The restitution law's results are untouched by the new section: the default contact is the
/// restitution law and a run is bit-identical with it given explicitly.
#[test]
fn restitution_law_is_the_default_and_unchanged() {
    let sys = System::paper_damped(0.1e-3, FrictionModel::None, 1.0);
    assert_eq!(sys.damper.unwrap().contact.law, ContactLaw::Restitution);
    let a = Exact::default()
        .run(&sys, &State::default(), 0.05, &mut ())
        .unwrap();
    let mut sys2 = sys;
    sys2.damper.as_mut().unwrap().contact = Contact {
        law: ContactLaw::Restitution,
        ..Contact::hertz()
    };
    let b = Exact::default()
        .run(&sys2, &State::default(), 0.05, &mut ())
        .unwrap();
    assert_eq!(format!("{a:?}"), format!("{b:?}"));
}

/// Bad input names the field; the solvers without the law refuse it.
#[test]
fn bad_contact_input_names_the_field() {
    let base = hertz(System::paper_damped(0.1e-3, FrictionModel::None, 1.0));
    let with = |f: &dyn Fn(&mut Damper)| {
        let mut s = base;
        f(s.damper.as_mut().unwrap());
        s.validate().unwrap_err().to_string()
    };
    type Edit<'a> = &'a dyn Fn(&mut Damper);
    let cases: [(Edit, &str); 7] = [
        (
            &|d| d.contact.ball_modulus_pa = 0.0,
            "contact.ball_modulus_pa",
        ),
        (
            &|d| d.contact.wall_modulus_pa = -1.0,
            "contact.wall_modulus_pa",
        ),
        (&|d| d.contact.ball_poisson = 0.5, "contact.ball_poisson"),
        (&|d| d.contact.wall_poisson = -1.0, "contact.wall_poisson"),
        (
            &|d| d.contact.wall_radius_m = Some(0.007),
            "contact.wall_radius_m",
        ),
        (
            &|d| d.contact.wall_radius_m = Some(-1.0),
            "contact.wall_radius_m",
        ),
        (&|d| d.restitution = 0.0, "damper.restitution"),
    ];
    for (f, field) in cases {
        let msg = with(f);
        assert!(msg.contains(field), "{msg}");
    }
    let err = Rk4 { dt_s: 1e-6 }
        .run(&base, &State::default(), 0.01, &mut ())
        .unwrap_err();
    assert!(err.to_string().contains("hertz"), "{err}");
}

/// A ball pressed on a wall by a constant push (the resting contact a grazing touch leads to,
/// the case that must not stall). The floor of the damping's reference speed `δ̇₀` makes the rest
/// an overdamped creep towards Hertz's static penetration `δ_s = (m_d a/K_h)^{2/3}`
/// (`a = F_s/(M + m_d)`, time constant `D δ_s/(1.5 δ̇₀)` ≈ 55 ms here): after 50 ms the ball is
/// between 0.7 δ_s and δ_s and still sinking. A long rest exceeds the bound on the work per
/// contact (the explicit integrator is stability-limited by the contact's own 1e4 rad/s mode):
/// a clear error within bounded time, never a hang.
#[test]
fn resting_contact_creeps_to_the_static_penetration_and_its_work_is_bounded() {
    let fs = -2.0; // pushes the bar to −u: the ball (w = v − u) is pressed on the + wall
    let sys = hertz(constant_push(fs, 1e-3, 0.5));
    let d = sys.damper.unwrap();
    let m = sys.lumped_bar().unwrap().mass_kg;
    let lg = d.half_gap_m();
    let init = State {
        t_s: 0.0,
        u_m: 0.0,
        du_m_s: 0.0,
        v_m: lg,
        dv_m_s: 0.0,
        cavity: None,
    };
    let s = Exact::default().run(&sys, &init, 0.05, &mut ()).unwrap();
    let law = Hertz::of_damper(&d);
    let a = fs.abs() / (m + d.ball_mass_kg);
    let ds = (d.ball_mass_kg * a / law.stiffness_n_m32).powf(2.0 / 3.0);
    let pen = s.final_state.w_m() - lg;
    assert!(pen > 0.7 * ds && pen < ds, "{pen} {ds} {s:?}");
    assert!(s.final_state.dw_m_s() > 0.0, "still sinking: {s:?}");
    let t = std::time::Instant::now();
    let e = Exact::default()
        .run(&sys, &init, 100.0, &mut ())
        .unwrap_err();
    assert!(e.to_string().contains("integrator steps"), "{e}");
    assert!(t.elapsed().as_secs_f64() < 10.0);
}
