//! The modal RK4 (`solver::modal_rk4`) and the modal laws, each against a closed form or an
//! independent computation. Every future N-mode solver must pass these cases.
use vibrobar_core::damper::impact::{modal_impact, modal_inverse_effective_mass_per_kg};
use vibrobar_core::limits::MAX_BEAM_MODES;
use vibrobar_core::solver::modal_rk4::{ModalObserver, ModalRk4};
use vibrobar_core::solver::{Event, EventKind, Observer, Rk4, Segment, SegmentIntegrals, Solver};
use vibrobar_core::structure::{Beam, ModalState, ModalSystem, Point, Structure};
use vibrobar_core::*;

#[path = "common/modal_beam.rs"]
mod modal_beam;
use modal_beam::{beam_system, impact_errors, mode_closed_form};

#[path = "common/fit.rs"]
mod fit;
use fit::log_log_slope;

/// Records the public stream (step-end states, events, summed integrals) and the modal one.
#[derive(Default)]
struct Rec {
    ends: Vec<State>,
    events: Vec<Event>,
    totals: SegmentIntegrals,
    /// (before, after, loss) of every impact.
    impacts: Vec<(ModalState, ModalState, f64)>,
    first: Option<ModalState>,
    last: Option<ModalState>,
    /// Public state at every step end and the modal state there (before any impact).
    pairs: Vec<(State, ModalState)>,
}

impl Observer for Rec {
    fn segment(&mut self, seg: &dyn Segment) {
        self.totals += seg.integrals(seg.t_start_s(), seg.t_end_s());
        self.ends.push(seg.state_at(seg.t_end_s()));
    }
    fn event(&mut self, ev: &Event) {
        self.events.push(*ev);
    }
}

impl ModalObserver for Rec {
    fn modal_step(&mut self, a: &ModalState, b: &ModalState) {
        self.first.get_or_insert(*a);
        self.last = Some(*b);
        self.pairs.push((*self.ends.last().unwrap(), *b));
    }
    fn modal_impact(&mut self, before: &ModalState, after: &ModalState, loss: f64) {
        self.impacts.push((*before, *after, loss));
        self.last = Some(*after);
    }
}

/// N = 1 from `from_lumped` is the lumped `Rk4`: same steps, same impacts, states within 1e-12
/// of their scale over 0.05 s of the paper's cases (impacts, every friction law, the solid bar).
/// Not bit for bit after the first impact: the modal impulse `P = (1+e)ẇ m_eff`, `Δq̇ = P/m`
/// rounds differently from the lumped `μ(1+e)/(1+μ) ẇ` (measured: at most 2.0e-14 of the scale).
#[test]
fn one_unit_mode_reproduces_the_lumped_rk4() {
    let dt = 1e-6;
    let t_end = 0.05;
    let mut cases: Vec<System> = Vec::new();
    for gap in [0.05e-3, 0.1e-3] {
        for f in FrictionModel::ALL {
            cases.push(System::paper_damped(gap, f, 1.0));
        }
    }
    cases.push(System::paper_solid(1.0));
    let mut worst = 0.0f64;
    let mut bit_identical_checked = 0;
    for sys in &cases {
        let mut lumped = Rec::default();
        let rl = Rk4 { dt_s: dt }
            .run(sys, &State::REST, t_end, &mut lumped)
            .unwrap();
        let msys = ModalSystem::from_lumped(sys).unwrap();
        let mut modal = Rec::default();
        let rm = ModalRk4 { dt_s: dt }
            .run_modal(&msys, &ModalState::REST, t_end, &mut modal)
            .unwrap();
        assert_eq!(rl.impacts, rm.summary.impacts, "{sys:?}");
        assert_eq!(lumped.ends.len(), modal.ends.len());
        assert_eq!(lumped.events.len(), modal.events.len());
        if sys.damper.is_some() {
            assert!(rl.impacts >= 10, "{} impacts", rl.impacts);
        }
        let scale = |f: &dyn Fn(&State) -> f64| {
            lumped
                .ends
                .iter()
                .map(|s| f(s).abs())
                .fold(0.0, f64::max)
                .max(1e-300)
        };
        let fields: [&dyn Fn(&State) -> f64; 4] =
            [&|s| s.u_m, &|s| s.du_m_s, &|s| s.v_m, &|s| s.dv_m_s];
        // Before the first impact the arithmetic is the lumped one, operation for operation:
        // bit-identical where `M·(√(K/M))² = K` holds in floating point (the paper's cavity bar;
        // not its solid bar, 0.668 kg and 9.26 MN/m, where they differ by 2e-16 relative).
        let msys1 = &msys.model.modes()[0];
        if msys1.modal_stiffness_n_per_m().to_bits()
            == sys.lumped_bar().unwrap().stiffness_n_per_m.to_bits()
        {
            bit_identical_checked += 1;
            let t_first = lumped.events.first().map_or(f64::INFINITY, |e| e.t_s);
            for (a, b) in lumped.ends.iter().zip(&modal.ends) {
                if a.t_s >= t_first {
                    break;
                }
                assert_eq!(
                    [a.u_m, a.du_m_s, a.v_m, a.dv_m_s].map(f64::to_bits),
                    [b.u_m, b.du_m_s, b.v_m, b.dv_m_s].map(f64::to_bits),
                    "{sys:?} at {}",
                    a.t_s
                );
            }
        }
        let mut case_worst = 0.0f64;
        for f in fields {
            let sc = scale(f);
            for (a, b) in lumped.ends.iter().zip(&modal.ends) {
                assert_eq!(a.t_s.to_bits(), b.t_s.to_bits());
                let d = (f(a) - f(b)).abs() / sc;
                case_worst = case_worst.max(d);
                assert!(d <= 1e-12, "{sys:?} at {}: {d:e}", a.t_s);
            }
        }
        worst = worst.max(case_worst);
        eprintln!(
            "N = 1 vs lumped: {} {:?} {} impacts: {case_worst:e}",
            sys.damper.map_or(0.0, |d| d.gap_m),
            sys.damper.map(|d| d.friction),
            rl.impacts
        );
        for (a, b) in lumped.events.iter().zip(&modal.events) {
            assert_eq!(a.t_s.to_bits(), b.t_s.to_bits());
            if let (
                EventKind::Impact {
                    dw_m_s: d1,
                    energy_loss_j: l1,
                    ..
                },
                EventKind::Impact {
                    dw_m_s: d2,
                    energy_loss_j: l2,
                    ..
                },
            ) = (a.kind, b.kind)
            {
                assert!((d1 - d2).abs() <= 1e-12 * d1.abs(), "{d1} {d2}");
                assert!((l1 - l2).abs() <= 1e-12 * l1, "{l1} {l2}");
            }
        }
        let (ta, tb) = (lumped.totals, modal.totals);
        for (x, y) in [
            (ta.u2_m2_s, tb.u2_m2_s),
            (ta.forcing_work_j, tb.forcing_work_j),
            (ta.viscous_loss_j, tb.viscous_loss_j),
            (ta.friction_work_j, tb.friction_work_j),
        ] {
            assert!((x - y).abs() <= 1e-12 * x.abs().max(1e-300), "{x} {y}");
        }
    }
    assert_eq!(bit_identical_checked, 6, "every cavity-bar case");
    eprintln!("N = 1 vs lumped rk4: largest difference {worst:e} of the scale");
}

/// Without a ball, 4 modes under harmonic forcing converge with order 4 in dt to the sum of the
/// modes' closed-form responses (transient from rest included).
#[test]
fn four_modes_without_ball_converge_with_order_four_to_the_modal_closed_form() {
    let sys = beam_system(4, None, 1.0);
    let omega = sys.omega_rad_s();
    let t_end = 0.01;
    let (mut u, mut du) = (0.0, 0.0);
    for m in sys.model.modes() {
        let (q, dq) = mode_closed_form(m, sys.forcing.amplitude_n, omega, t_end);
        u += m.shape_response * q;
        du += m.shape_response * dq;
    }
    let mut pts = Vec::new();
    for dt in [4e-6, 2e-6, 1e-6, 5e-7] {
        let r = ModalRk4 { dt_s: dt }
            .run(&sys, &ModalState::REST, t_end, &mut ())
            .unwrap();
        let s = r.summary.final_state;
        let err = (s.u_m - u).hypot((s.du_m_s - du) / omega);
        pts.push((dt, err));
    }
    let p = log_log_slope(&pts);
    eprintln!("modal rk4 order without ball (4 modes): {p:.3} ({pts:?}); tip u = {u:e} m");
    assert!((p - 4.0).abs() < 0.15, "order {p}");
    assert!(pts[3].1 < 1e-9 * u.abs().max(du.abs() / omega), "{pts:?}");
}

/// The steady tip response (transient decayed by e⁻²⁷) is `Im(F0 G(iΩ) e^{iΩt})` with the
/// model's receptance between the force and the response points.
#[test]
fn steady_tip_response_is_the_receptance_times_the_force() {
    let mut sys = beam_system(4, None, 1.0);
    for m in sys.model.modes_mut() {
        m.damping_ratio = 0.05;
    }
    let t_end = 0.15;
    assert!((-0.05 * sys.omega1_rad_s() * t_end).exp() < 3e-12);
    for ratio in [0.7, 1.0, 1.3] {
        sys.forcing.frequency = Frequency::Ratio(ratio);
        let omega = sys.omega_rad_s();
        let r = ModalRk4 { dt_s: 1e-6 }
            .run(&sys, &ModalState::REST, t_end, &mut ())
            .unwrap();
        let s = r.summary.final_state;
        let g = sys.model.receptance(Point::Force, Point::Response, omega);
        let f0 = sys.forcing.amplitude_n;
        let amp = s.u_m.hypot(s.du_m_s / omega);
        let want = g.norm() * f0;
        let (sn, cs) = (omega * t_end).sin_cos();
        let u_want = f0 * (g.re * sn + g.im * cs);
        eprintln!(
            "Ω/ω₁ = {ratio}: amplitude {amp:e} m vs |G|F0 {want:e} m ({:e}); u {:e}",
            amp / want - 1.0,
            (s.u_m - u_want) / want
        );
        assert!((amp / want - 1.0).abs() < 1e-8, "{amp} {want}");
        assert!((s.u_m - u_want).abs() < 1e-8 * want);
    }
}

/// The paper's ball in the paper's beam (4 modes, cavity 38 mm from the free end), at resonance.
fn impacting_beam(friction: FrictionModel) -> ModalSystem {
    beam_system(4, Some(Damper::paper(0.1e-3, friction)), 1.0)
}

/// A point impulse changes each mode's generalised momentum by `φₙ(x_d) P` and the ball's by
/// `−P`: `mₙ q̇ₙ + φₙ(x_d) m_d v̇` is conserved for every mode; the kinetic energy lost is
/// `½ m_eff (1 − e²) ẇ−²` and `ẇ+ = −e ẇ−`. Checked to 1e-13 over every impact of 0.2 s.
#[test]
fn modal_impacts_conserve_momentum_per_mode_and_lose_the_law_s_energy() {
    for friction in [FrictionModel::None, FrictionModel::AsPublished] {
        let sys = impacting_beam(friction);
        let mut rec = Rec::default();
        ModalRk4 { dt_s: 1e-6 }
            .run_modal(&sys, &ModalState::REST, 0.2, &mut rec)
            .unwrap();
        assert!(rec.impacts.len() >= 200, "{} impacts", rec.impacts.len());
        let (mut worst_p, mut worst_e, mut worst_w) = (0.0f64, 0.0f64, 0.0f64);
        for (b, a, loss) in &rec.impacts {
            let (p, e, w) = impact_errors(&sys, b, a, *loss);
            worst_p = worst_p.max(p);
            worst_e = worst_e.max(e);
            worst_w = worst_w.max(w);
        }
        eprintln!(
            "{friction}: {} impacts; momentum {worst_p:e}, energy {worst_e:e}, ẇ+ {worst_w:e}",
            rec.impacts.len()
        );
        assert!(worst_p <= 1e-13 && worst_e <= 1e-13 && worst_w <= 1e-13);
    }
}

/// Energy books of a 4-mode beam run: forcing work − viscous loss − impact losses + friction
/// work = Δ(mechanical energy), the residual falling as dt² (trapezoid integrals).
#[test]
fn energy_books_close_to_order_dt_squared_on_a_four_mode_beam() {
    for friction in [FrictionModel::None, FrictionModel::AsPublished] {
        let sys = impacting_beam(friction);
        let mut res = Vec::new();
        for dt in [1e-6, 5e-7] {
            let mut rec = Rec::default();
            ModalRk4 { dt_s: dt }
                .run_modal(&sys, &ModalState::REST, 0.02, &mut rec)
                .unwrap();
            let losses: f64 = rec.impacts.iter().map(|x| x.2).sum();
            let t = rec.totals;
            let books = t.forcing_work_j - t.viscous_loss_j - losses + t.friction_work_j;
            let delta = sys.mechanical_energy_j(rec.last.as_ref().unwrap())
                - sys.mechanical_energy_j(rec.first.as_ref().unwrap());
            let residual = delta - books;
            eprintln!(
                "{friction} dt = {dt:e}: input {:e} J, viscous {:e}, impacts {losses:e} ({}), \
                 friction {:e}, Δ {delta:e}, residual {residual:e}",
                t.forcing_work_j,
                t.viscous_loss_j,
                rec.impacts.len(),
                t.friction_work_j
            );
            res.push((residual.abs(), t.forcing_work_j));
        }
        assert!(res[0].0 < 1e-5 * res[0].1, "{res:?}");
        let ratio = res[0].0 / res[1].0;
        assert!(ratio > 3.0, "residual ratio for dt/2: {ratio} ({res:?})");
    }
}

/// At the tip of a uniform bar every tip-normalised mode has `φ = 1` and `m = ρAL/4`, so the
/// impact law's `1/m_eff − 1/m_d = Σ φₙ²/mₙ = 4N/(ρAL)` (VALIDATION.md): the bar's effective mass
/// at a point goes to 0 as N grows. The impulse is the one of that mass.
#[test]
fn effective_mass_at_the_tip_of_a_uniform_bar_is_rho_a_l_over_4n() {
    let beam = Beam {
        cavity_position_m: Beam::default().length_m,
        ..Beam::default()
    };
    let rho_a_l = beam.mass_kg();
    let md = 0.026;
    for n in 1..=12 {
        let model = Structure::Beam(Beam {
            modes: Some(n),
            ..beam.clone()
        })
        .modal_model()
        .unwrap();
        let phi: Vec<f64> = model.modes().iter().map(|m| m.shape_cavity).collect();
        let mass: Vec<f64> = model.modes().iter().map(|m| m.modal_mass_kg).collect();
        let inv = modal_inverse_effective_mass_per_kg(md, &phi, &mass);
        let want = 4.0 * n as f64 / rho_a_l;
        assert!(
            ((inv - 1.0 / md) / want - 1.0).abs() < 1e-9,
            "N = {n}: {} vs {want}",
            inv - 1.0 / md
        );
        let mut dq = vec![0.0; n];
        let (mut dv, e, dw) = (1.0, 0.5, 1.0);
        let law = modal_impact(md, e, &phi, &mass, dw, &mut dq, &mut dv);
        let m_eff = 1.0 / (1.0 / md + want);
        assert!((law.impulse_n_s / ((1.0 + e) * dw * m_eff) - 1.0).abs() < 1e-9);
        let tip: f64 = dq.iter().zip(&phi).map(|(q, p)| q * p).sum();
        assert!((dv - tip + e * dw).abs() < 1e-13, "ẇ+ = −e ẇ−");
        let sys = ModalSystem {
            model,
            ..beam_system(1, None, 1.0)
        };
        let me = sys.bar_effective_mass_at_cavity_kg();
        assert!((me * 4.0 * n as f64 / rho_a_l - 1.0).abs() < 1e-9, "{me}");
    }
}

/// Bad input names the field: a step beyond the highest mode's stability limit, a ball outside
/// the gap, a ratio out of range, too many modes in the state.
#[test]
fn modal_inputs_are_checked_with_the_field_named() {
    let sys = impacting_beam(FrictionModel::None);
    let wmax = sys.omega_max_rad_s();
    let err = ModalRk4 { dt_s: 3.0 / wmax }
        .run(&sys, &ModalState::REST, 0.01, &mut ())
        .unwrap_err()
        .to_string();
    assert!(err.contains("dt_s (--dt)"), "{err}");
    let mut init = ModalState::REST;
    init.v_m = 1e-3;
    let err = ModalRk4::default()
        .run(&sys, &init, 0.01, &mut ())
        .unwrap_err()
        .to_string();
    assert!(err.contains("initial.w_m"), "{err}");
    let mut init = ModalState::REST;
    init.q_m[MAX_BEAM_MODES - 1] = 1e-6;
    let err = ModalRk4::default()
        .run(&sys, &init, 0.01, &mut ())
        .unwrap_err()
        .to_string();
    assert!(err.contains("initial.q_m"), "{err}");
    let mut bad = sys.clone();
    bad.forcing.frequency = Frequency::Ratio(1e4);
    let err = bad.validate().unwrap_err().to_string();
    assert!(err.contains("forcing.frequency_ratio"), "{err}");
    let mut bad = sys.clone();
    bad.damper.as_mut().unwrap().restitution = 2.0;
    let err = bad.validate().unwrap_err().to_string();
    assert!(err.contains("damper.restitution"), "{err}");
}

/// Force, cavity and response at three different points: the public stream reads `u` at the
/// response point (`state_at` = `Σφₙ(x_r)qₙ` of the modal state), the forcing work is taken at
/// the force point, and the books still close.
#[test]
fn force_cavity_and_response_at_different_points_keep_the_protocol_and_the_books() {
    let model = Structure::Beam(Beam {
        modes: Some(4),
        force_position_m: Some(0.15),
        response_position_m: Some(0.1),
        ..Beam::default()
    })
    .modal_model()
    .unwrap();
    let m1 = &model.modes()[0];
    assert!(m1.shape_force != m1.shape_response && m1.shape_force != m1.shape_cavity);
    let sys = ModalSystem {
        model,
        ..impacting_beam(FrictionModel::AsPublished)
    };
    let mut rec = Rec::default();
    ModalRk4 { dt_s: 5e-7 }
        .run_modal(&sys, &ModalState::REST, 0.02, &mut rec)
        .unwrap();
    assert!(rec.impacts.len() >= 5, "{} impacts", rec.impacts.len());
    for (public, modal) in &rec.pairs {
        let want = modal.public(&sys.model);
        assert_eq!(public.t_s.to_bits(), want.t_s.to_bits());
        assert!((public.u_m - want.u_m).abs() <= 1e-15 * want.u_m.abs().max(1e-9));
        assert!((public.du_m_s - want.du_m_s).abs() <= 1e-15 * want.du_m_s.abs().max(1e-6));
        assert_eq!(public.v_m.to_bits(), want.v_m.to_bits());
    }
    let losses: f64 = rec.impacts.iter().map(|x| x.2).sum();
    let t = rec.totals;
    let books = t.forcing_work_j - t.viscous_loss_j - losses + t.friction_work_j;
    let delta = sys.mechanical_energy_j(rec.last.as_ref().unwrap())
        - sys.mechanical_energy_j(rec.first.as_ref().unwrap());
    eprintln!(
        "three points: input {:e} J, residual {:e} J, {} impacts",
        t.forcing_work_j,
        delta - books,
        rec.impacts.len()
    );
    assert!((delta - books).abs() < 1e-6 * t.forcing_work_j);
}
