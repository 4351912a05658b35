//! The `hertz` contact law on the N-mode beam (`ModalExact`): the one-mode beam against the
//! lumped `Exact`, momentum and restitution of a contact of free modes, the energy books with the
//! contact dissipation, and an independent fixed-step RK4 of the N-mode contact phase.

use vibrobar_core::damper::contact::Hertz;
use vibrobar_core::solver::exact::modal::ModalExact;
use vibrobar_core::solver::modal_rk4::{ModalObserver, ModalRk4};
use vibrobar_core::solver::{Event, EventKind, Exact, Mode, Observer, Segment, Solver};
use vibrobar_core::structure::{Beam, ModalModel, ModalState, ModalSystem, Structure};
use vibrobar_core::*;

#[path = "common/modal_beam.rs"]
mod modal_beam;
use modal_beam::{lumped_and_modal, one_mode_tip_model, run_differences};

fn hertz(d: Damper) -> Damper {
    Damper {
        contact: Contact::hertz(),
        ..d
    }
}

/// Records events, segments (start, end, mode), the public state on a grid, the books and the
/// modal states at the ends of the steps.
#[derive(Default)]
struct Rec {
    grid_dt: f64,
    grid: Vec<State>,
    events: Vec<Event>,
    segs: Vec<(f64, f64, Mode)>,
    input: f64,
    viscous: f64,
    friction: f64,
    losses: f64,
    e_first: Option<f64>,
    e_last: f64,
    modal: Vec<ModalState>,
}

impl Observer for Rec {
    fn segment(&mut self, seg: &dyn Segment) {
        let (a, b) = (seg.t_start_s(), seg.t_end_s());
        self.segs.push((a, b, seg.mode()));
        let i = seg.integrals(a, b);
        self.input += i.forcing_work_j;
        self.viscous += i.viscous_loss_j;
        self.friction += i.friction_work_j;
        self.e_first.get_or_insert(seg.mechanical_energy_j(a));
        self.e_last = seg.mechanical_energy_j(b);
        if self.grid_dt > 0.0 {
            let mut k = (a / self.grid_dt).ceil() as u64;
            while (k as f64) * self.grid_dt < b {
                self.grid.push(seg.state_at(k as f64 * self.grid_dt));
                k += 1;
            }
        }
    }
    fn event(&mut self, ev: &Event) {
        self.events.push(*ev);
        if let EventKind::Impact { energy_loss_j, .. }
        | EventKind::ChatterLimit { energy_loss_j, .. } = ev.kind
        {
            self.losses += energy_loss_j;
        }
    }
}

impl ModalObserver for Rec {
    fn modal_step(&mut self, _a: &ModalState, b: &ModalState) {
        self.modal.push(*b);
    }
}

impl Rec {
    fn residual(&self) -> f64 {
        let books = self.input - self.viscous - self.losses + self.friction;
        ((self.e_last - self.e_first.unwrap()) - books).abs() / self.input.abs()
    }
}

fn beam_system(n: usize, gap: f64, friction: FrictionModel) -> ModalSystem {
    modal_beam::beam_system(n, Some(hertz(Damper::paper(gap, friction))), 1.0)
}

/// Issue #9 on the beam: a one-mode beam with the ball at the tip (tip-normalised modal mass and
/// stiffness as the lumped `M`, `K`) under the `hertz` law is the lumped hertz run over 0.05 s:
/// the same events, states on a 10 µs grid within 1e-9 of their scale and event times within
/// 1e-9/Ω (both integrate the same equations with the same Dopri5, tolerance and first step;
/// they differ by rounding: `k = mω²`, the effective mass `1/κ`, the shapes `1 ± 1e-15`).
#[test]
fn one_mode_beam_with_the_ball_at_the_tip_is_the_lumped_hertz_bar() {
    let model = one_mode_tip_model();
    for friction in FrictionModel::ALL {
        let damper = hertz(Damper::paper(0.1e-3, friction));
        let (lumped_sys, msys) = lumped_and_modal(model, damper);
        let mut lumped = Rec {
            grid_dt: 1e-5,
            ..Default::default()
        };
        let rl = Exact::default()
            .run(&lumped_sys, &State::REST, 0.05, &mut lumped)
            .unwrap();
        let mut modal = Rec {
            grid_dt: 1e-5,
            ..Default::default()
        };
        let rm = ModalExact::default()
            .run_modal(&msys, &ModalState::REST, 0.05, &mut modal)
            .unwrap();
        assert_eq!(rl.impacts, rm.summary.impacts, "{friction}");
        assert!(rl.impacts >= 10, "{}", rl.impacts);
        assert_eq!(lumped.events.len(), modal.events.len());
        assert_eq!(lumped.grid.len(), modal.grid.len());
        let om = lumped_sys.omega_rad_s();
        let (worst, worst_t) =
            run_differences(&lumped.grid, &modal.grid, &lumped.events, &modal.events, om);
        let contacts = modal
            .segs
            .iter()
            .filter(|s| matches!(s.2, Mode::Contact(_)))
            .count();
        eprintln!(
            "hertz, one-mode beam, ball at the tip, {friction}: {} impacts, {contacts} contact steps; states {worst:e}, times·Ω {worst_t:e}",
            rl.impacts
        );
        assert!(contacts > 10 * rl.impacts as usize);
        assert!(worst < 1e-9 && worst_t < 1e-9, "{worst:e} {worst_t:e}");
        assert!((rl.max_penetration_m / rm.summary.max_penetration_m - 1.0).abs() < 1e-6);
    }
}

/// One contact of the ball on a beam whose modes are free (ω → 0, no damping, no force): the
/// contact row's impulse goes to every mode by its shape (`mₙΔq̇ₙ = −φₙ(x_d) m_d Δv`, momentum at
/// the cavity), and the bar at the cavity is then one body of mass `1/Σφₙ²/mₙ`, so the exact
/// `D(e)` gives `ẇ+ = −e ẇ−` and the loss `½ m_eff (1 − e²) ẇ−²`.
#[test]
fn a_contact_of_free_modes_conserves_momentum_with_the_target_restitution() {
    let beam = Structure::Beam(Beam {
        modes: Some(6),
        ..Beam::default()
    })
    .modal_model()
    .unwrap();
    let mut modes = beam.modes().to_vec();
    for m in &mut modes {
        m.omega_rad_s = 1e-3;
        m.damping_ratio = 0.0;
    }
    let model = ModalModel::new(&modes, beam.static_tip_compliance_m_per_n).unwrap();
    for e in [1.0, 0.6, 0.3] {
        let d = hertz(Damper {
            restitution: e,
            ..Damper::paper(1e-3, FrictionModel::None)
        });
        let sys = ModalSystem {
            model,
            damper: Some(d),
            forcing: Forcing {
                amplitude_n: 0.0,
                frequency: params::Frequency::Ratio(1.0),
                static_force_n: 0.0,
            },
            gravity_m_s2: params::STANDARD_GRAVITY_M_S2,
        };
        let v0 = 0.1;
        let lg = d.half_gap_m();
        let init = ModalState {
            v_m: lg * 0.99,
            dv_m_s: v0,
            ..ModalState::REST
        };
        let mut rec = Rec::default();
        ModalExact::default()
            .run_modal(&sys, &init, 2e-3, &mut rec)
            .unwrap();
        let ev = rec
            .events
            .iter()
            .find(|e| matches!(e.kind, EventKind::Impact { .. }))
            .unwrap();
        let after = rec
            .modal
            .iter()
            .rev()
            .find(|s| s.t_s <= ev.t_s)
            .copied()
            .unwrap();
        assert_eq!(after.t_s, ev.t_s);
        let dv = after.dv_m_s - v0;
        let mut kinv = 0.0;
        for (i, m) in modes.iter().enumerate() {
            let p = m.modal_mass_kg * after.dq_m_s[i];
            let want = -m.shape_cavity * d.ball_mass_kg * dv;
            assert!(
                (p - want).abs() < 1e-9 * d.ball_mass_kg * v0,
                "{e} mode {i}: {p} {want}"
            );
            kinv += m.shape_cavity * m.shape_cavity / m.modal_mass_kg;
        }
        let dw_out = ev.after.dv_m_s - ev.after.cavity.unwrap().du_cavity_m_s;
        assert!((dw_out + e * v0).abs() < 1e-6 * v0, "{e}: ẇ+ {dw_out}");
        let meff = 1.0 / (kinv + 1.0 / d.ball_mass_kg);
        if let EventKind::Impact { energy_loss_j, .. } = ev.kind {
            let want = 0.5 * meff * (1.0 - e * e) * v0 * v0;
            assert!(
                (energy_loss_j - want).abs() <= 1e-6 * want.max(1e-9 * meff * v0 * v0),
                "{e}: {energy_loss_j} {want}"
            );
        }
        if e == 1.0 {
            let tc = ev.t_s
                - rec
                    .segs
                    .iter()
                    .find(|s| matches!(s.2, Mode::Contact(_)))
                    .unwrap()
                    .0;
            let want = Hertz::of_damper(&d).undamped_contact_time_s(meff, v0);
            assert!((tc / want - 1.0).abs() < 1e-4, "{tc} {want}");
        }
    }
}

/// The energy books of beam runs with the hertz law close: ΔE = input − viscous − contact
/// dissipation + friction work, to a residual far below the input (the integrator's tolerance,
/// rtol 1e-9), for 4 and 12 modes and every friction law; the largest penetration is the
/// contacts' compression (micrometres).
#[test]
fn beam_energy_books_close_with_contact_dissipation() {
    for (n, friction) in [
        (4, FrictionModel::None),
        (4, FrictionModel::AsPublished),
        (4, FrictionModel::Coulomb),
        (12, FrictionModel::None),
    ] {
        let sys = beam_system(n, 0.1e-3, friction);
        let mut rec = Rec::default();
        let r = ModalExact {
            check_invariants: true,
            ..Default::default()
        }
        .run_modal(&sys, &ModalState::REST, 0.1, &mut rec)
        .unwrap();
        let res = rec.residual();
        eprintln!(
            "N = {n}, {friction}: {} impacts, input {:e} J, contact loss {:e} J, friction {:e} J, residual {res:e}, max penetration {:e} m",
            r.summary.impacts, rec.input, rec.losses, rec.friction, r.summary.max_penetration_m
        );
        assert!(r.summary.impacts > 20, "{r:?}");
        assert!(rec.losses > 0.0);
        assert!(res < 1e-7, "{res:e}");
        let pen = r.summary.max_penetration_m;
        assert!(pen > 0.0 && pen < 1e-5, "{pen}");
    }
}

/// An independent computation of one contact on the forced 4-mode beam: a plain fixed-step RK4
/// of the N-mode contact equations at 2e5 steps per contact time gives the release time, the
/// relative velocity and every modal velocity of the exact solver's contact phase.
#[test]
fn beam_contact_matches_an_independent_fixed_step_rk4() {
    const N: usize = 4;
    let sys = beam_system(N, 0.1e-3, FrictionModel::None);
    let d = sys.damper.unwrap();
    let lg = d.half_gap_m();
    let modes = sys.model.modes().to_vec();
    let t0 = 1e-4;
    let approach = 0.05;
    let mut init = ModalState {
        t_s: t0,
        ..ModalState::REST
    };
    for i in 0..N {
        init.q_m[i] = 2e-6 / (1 + i * i) as f64;
        init.dq_m_s[i] = 0.01 / (1 + i) as f64;
    }
    let ud: f64 = (0..N).map(|i| modes[i].shape_cavity * init.q_m[i]).sum();
    let dud: f64 = (0..N).map(|i| modes[i].shape_cavity * init.dq_m_s[i]).sum();
    init.v_m = ud + lg;
    init.dv_m_s = dud + approach;
    let mut rec = Rec::default();
    ModalExact::default()
        .run_modal(&sys, &init, t0 + 2e-4, &mut rec)
        .unwrap();
    let ev = *rec
        .events
        .iter()
        .find(|e| matches!(e.kind, EventKind::Impact { .. }))
        .unwrap();
    let at_release = *rec.modal.iter().find(|s| s.t_s == ev.t_s).unwrap();
    // Reference: y = [q (N), q̇ (N), δ, δ̇], the wall +.
    let law = Hertz::of_damper(&d);
    let om = sys.omega_rad_s();
    let f0 = sys.forcing.amplitude_n;
    let f = |t: f64, y: &[f64; 2 * N + 2]| {
        let p = law.force_n(y[2 * N], y[2 * N + 1], approach);
        let mut out = [0.0; 2 * N + 2];
        let mut ddud = 0.0;
        for (i, m) in modes.iter().enumerate() {
            let k = m.modal_stiffness_n_per_m();
            let c = 2.0 * m.damping_ratio * (k * m.modal_mass_kg).sqrt();
            let a = (m.shape_force * f0 * (om * t).sin() - c * y[N + i] - k * y[i]
                + m.shape_cavity * p)
                / m.modal_mass_kg;
            out[i] = y[N + i];
            out[N + i] = a;
            ddud += m.shape_cavity * a;
        }
        out[2 * N] = y[2 * N + 1];
        out[2 * N + 1] = -p / d.ball_mass_kg - ddud;
        out
    };
    let meff = 1.0
        / (1.0 / d.ball_mass_kg
            + modes[..N]
                .iter()
                .map(|m| m.shape_cavity * m.shape_cavity / m.modal_mass_kg)
                .sum::<f64>());
    let tc = law.undamped_contact_time_s(meff, approach);
    let h = tc / 2e5;
    let mut y = [0.0; 2 * N + 2];
    y[..N].copy_from_slice(&init.q_m[..N]);
    y[N..2 * N].copy_from_slice(&init.dq_m_s[..N]);
    y[2 * N + 1] = approach;
    let mut t = t0;
    let ad = |a: &[f64; 2 * N + 2], s: f64, k: &[f64; 2 * N + 2]| -> [f64; 2 * N + 2] {
        std::array::from_fn(|i| a[i] + s * k[i])
    };
    loop {
        let k1 = f(t, &y);
        let k2 = f(t + h / 2.0, &ad(&y, h / 2.0, &k1));
        let k3 = f(t + h / 2.0, &ad(&y, h / 2.0, &k2));
        let k4 = f(t + h, &ad(&y, h, &k3));
        let yn: [f64; 2 * N + 2] =
            std::array::from_fn(|i| y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
        if yn[2 * N] < 0.0 && t > t0 {
            let th = y[2 * N] / (y[2 * N] - yn[2 * N]);
            let lerp = |i: usize| y[i] + th * (yn[i] - y[i]);
            let t_rel = t + th * h;
            assert!((ev.t_s - t_rel).abs() < 1e-6 * tc, "{} {t_rel}", ev.t_s);
            let dw_ex = ev.after.dv_m_s - ev.after.cavity.unwrap().du_cavity_m_s;
            assert!((dw_ex - lerp(2 * N + 1)).abs() < 1e-6 * approach, "{dw_ex}");
            for i in 0..N {
                let (a, b) = (at_release.dq_m_s[i], lerp(N + i));
                assert!((a - b).abs() < 1e-6 * approach, "mode {i}: {a} {b}");
            }
            break;
        }
        y = yn;
        t += h;
        assert!(t < t0 + 2e-4, "no release");
    }
}

/// The modal rk4 (instantaneous impacts only) refuses the law by name.
#[test]
fn modal_rk4_refuses_hertz() {
    let sys = beam_system(4, 0.1e-3, FrictionModel::None);
    let err = ModalRk4 { dt_s: 1e-6 }
        .run(&sys, &ModalState::REST, 0.01, &mut ())
        .unwrap_err();
    assert!(err.to_string().contains("hertz"), "{err}");
}

/// A ball pressed on a wall of a beam whose modes are free (ω → 0, no damping) by a constant
/// push at the tip (the resting contact a grazing touch leads to): a long rest ends at the bound
/// on the work per contact with an error that names it, in bounded time, never a hang. (The
/// creep towards Hertz's static penetration is tested on the lumped bar, tests/exact_hertz.rs;
/// here the damping's reference-speed floor, 1e-3·l_g·max(Ω, ω₁), is tiny with these free
/// modes, so the rest is stiff and reaches the bound within milliseconds.)
#[test]
fn resting_contact_on_the_beam_is_bounded() {
    let beam = Structure::Beam(Beam {
        modes: Some(3),
        ..Beam::default()
    })
    .modal_model()
    .unwrap();
    let mut modes = beam.modes().to_vec();
    for m in &mut modes {
        m.omega_rad_s = 1e-3;
        m.damping_ratio = 0.0;
    }
    let d = hertz(Damper::paper(1e-3, FrictionModel::None));
    let sys = ModalSystem {
        model: ModalModel::new(&modes, beam.static_tip_compliance_m_per_n).unwrap(),
        damper: Some(d),
        forcing: Forcing {
            amplitude_n: 0.0,
            frequency: params::Frequency::Ratio(1.0),
            // Pushes the bar to −u (φ_f, φ_d > 0): the ball (w = v − u) is pressed on +.
            static_force_n: -2.0,
        },
        gravity_m_s2: params::STANDARD_GRAVITY_M_S2,
    };
    let lg = d.half_gap_m();
    let init = ModalState {
        v_m: lg,
        ..ModalState::REST
    };
    let t = std::time::Instant::now();
    let e = ModalExact::default()
        .run(&sys, &init, 100.0, &mut ())
        .unwrap_err();
    assert!(e.to_string().contains("integrator steps"), "{e}");
    assert!(t.elapsed().as_secs_f64() < 20.0);
}
