//! `System` with a modal bar (issue #8 part 2): the `Rk4` dispatch is `ModalRk4` bit for bit,
//! the public state carries the cavity's motion, the energy audit reads the segments' modal
//! energies, a lumped-style initial state maps onto mode 1, and every modal input error names
//! its field. The lumped path is pinned by `golden_exact.rs` and `sweep_snapshot.rs`.
use vibrobar_core::analysis::energy::EnergyAudit;
use vibrobar_core::analysis::lyapunov::{max_lyapunov, max_lyapunov_modal, LyapunovParams};
use vibrobar_core::analysis::map::Axis;
use vibrobar_core::params::{BarModel, CavityMotion};
use vibrobar_core::solver::modal_rk4::{ModalObserver, ModalRk4};
use vibrobar_core::solver::{Event, Exact, Observer, Rk4, Segment, SegmentIntegrals, Solver};
use vibrobar_core::structure::{Beam, ModalModel, ModalState, ModalSystem, Mode, Point};
use vibrobar_core::*;

/// The paper's bar (L = 175 mm, D = 25 mm, steel, ζ = 0.01) with `n` modes, cavity 38 mm from
/// the free end, force and response at the tip (or the response at `response_m`).
fn paper_beam(n: usize, response_m: Option<f64>) -> ModalModel {
    Beam {
        modes: Some(n),
        response_position_m: response_m,
        ..Beam::default()
    }
    .modal_model()
    .unwrap()
}

fn beam_system(model: ModalModel, friction: Option<FrictionModel>, ratio: f64) -> System {
    System {
        bar: BarModel::Modal(model),
        damper: friction.map(|f| Damper::paper(0.1e-3, f)),
        forcing: Forcing::paper(ratio),
        gravity_m_s2: params::STANDARD_GRAVITY_M_S2,
    }
}

/// Everything a solver reports: every segment's end state, energy and integrals, every event.
#[derive(Default, PartialEq, Debug)]
struct Stream {
    ends: Vec<(f64, State, f64)>,
    totals: Vec<SegmentIntegrals>,
    events: Vec<Event>,
}

impl Observer for Stream {
    fn segment(&mut self, seg: &dyn Segment) {
        let t = seg.t_end_s();
        self.ends
            .push((t, seg.state_at(t), seg.mechanical_energy_j(t)));
        self.totals.push(seg.integrals(seg.t_start_s(), t));
    }
    fn event(&mut self, ev: &Event) {
        self.events.push(*ev);
    }
}

/// Bitwise equality of two streams (`PartialEq` would let 0.0 == −0.0 pass).
fn assert_bits_equal(a: &Stream, b: &Stream) {
    assert_eq!(format!("{a:?}"), format!("{b:?}"));
    let bits = |s: &State| {
        [
            s.t_s,
            s.u_m,
            s.du_m_s,
            s.v_m,
            s.dv_m_s,
            s.u_cavity_m(),
            s.du_cavity_m_s(),
        ]
        .map(f64::to_bits)
    };
    for (x, y) in a.ends.iter().zip(&b.ends) {
        assert_eq!(bits(&x.1), bits(&y.1));
        assert_eq!(x.2.to_bits(), y.2.to_bits());
    }
}

/// `Rk4::run` on a `BarModel::Modal` system is `ModalRk4::run` on its `ModalSystem`: the same
/// stream (states, energies, integrals, events) and summary, bit for bit; from rest and from a
/// displaced start (mapped onto mode 1 by `ModalState::from_public`), with impacts and friction.
#[test]
fn rk4_dispatch_on_a_modal_bar_is_modal_rk4_bit_for_bit() {
    let dt = 1e-6;
    let t_end = 0.03;
    let displaced = State {
        u_m: 2e-6,
        du_m_s: -1e-3,
        v_m: 2e-6 + 2e-5,
        dv_m_s: -1e-3,
        ..State::REST
    };
    let mut impacts = 0;
    for friction in [
        None,
        Some(FrictionModel::None),
        Some(FrictionModel::AsPublished),
    ] {
        for init in [State::REST, displaced] {
            let model = paper_beam(4, None);
            let sys = beam_system(model, friction, 1.0);
            let mut a = Stream::default();
            let ra = Rk4 { dt_s: dt }.run(&sys, &init, t_end, &mut a).unwrap();
            let msys = ModalSystem::from_system(&sys).unwrap();
            let minit = ModalState::from_public(&model, &init).unwrap();
            let mut b = Stream::default();
            let rb = ModalRk4 { dt_s: dt }
                .run(&msys, &minit, t_end, &mut b)
                .unwrap();
            assert_eq!(format!("{ra:?}"), format!("{:?}", rb.summary));
            assert_bits_equal(&a, &b);
            assert_eq!(a.ends.len(), 30_000);
            impacts += ra.impacts;
        }
    }
    eprintln!("{impacts} impacts over the six runs");
    assert!(
        impacts >= 100,
        "{impacts} impacts: the case must exercise the impact law"
    );
}

/// The lumped bar's public states keep `cavity = None` (the cavity is where `u` is measured), so
/// `w = v − u` exactly as before; a modal run fills the cavity's motion, `Σφₙ(x_d)qₙ`, which
/// differs from the response point's.
#[test]
fn public_states_carry_the_cavity_motion() {
    let sys = System::paper_damped(0.1e-3, FrictionModel::None, 1.0);
    let mut s = Stream::default();
    Rk4 { dt_s: 1e-6 }
        .run(&sys, &State::REST, 0.01, &mut s)
        .unwrap();
    assert!(
        s.ends
            .iter()
            .all(|(_, st, _)| st.cavity.is_none()
                && st.w_m().to_bits() == (st.v_m - st.u_m).to_bits())
    );

    /// Checks every step end against the modal state the solver reports beside it.
    struct Check<'a> {
        model: &'a ModalModel,
        last: Option<State>,
        checked: usize,
        worst: f64,
    }
    impl Observer for Check<'_> {
        fn segment(&mut self, seg: &dyn Segment) {
            self.last = Some(seg.state_at(seg.t_end_s()));
        }
    }
    impl ModalObserver for Check<'_> {
        fn modal_step(&mut self, _a: &ModalState, b: &ModalState) {
            let p = self.last.unwrap();
            let c = p.cavity.expect("a modal state carries the cavity's motion");
            assert_eq!(c.u_cavity_m, b.u_at(self.model, Point::Cavity));
            assert_eq!(c.du_cavity_m_s, b.du_at(self.model, Point::Cavity));
            assert_eq!(p.u_m, b.u_at(self.model, Point::Response));
            assert_eq!(p.w_m(), b.w_m(self.model));
            assert_eq!(p.dw_m_s(), b.dw_m_s(self.model));
            assert_eq!(p, b.public(self.model));
            self.worst = self.worst.max((p.u_m - c.u_cavity_m).abs());
            self.checked += 1;
        }
    }
    let model = paper_beam(4, Some(0.1));
    let msys =
        ModalSystem::from_system(&beam_system(model, Some(FrictionModel::None), 1.0)).unwrap();
    let mut c = Check {
        model: &model,
        last: None,
        checked: 0,
        worst: 0.0,
    };
    ModalRk4 { dt_s: 1e-6 }
        .run_modal(&msys, &ModalState::REST, 0.01, &mut c)
        .unwrap();
    assert_eq!(c.checked, 10_000);
    eprintln!("largest |u(x_r) − u(x_d)| = {:.3e} m", c.worst);
    // Response at 100 mm, cavity at 137 mm: different points, different motions.
    assert!(c.worst > 1e-6, "{}", c.worst);
}

/// The energy audit works on a modal bar: its energies come from the segments (every mode's
/// `½mq̇² + ½kq²` and the ball's), its ΔE is the modal states' own, and the books close to the
/// rk4 error (`modal_rk4.rs` measured 5e-8 J at dt = 1 µs, 1.4e-9 J at 0.5 µs of 3e-2 J input).
#[test]
fn energy_audit_closes_on_a_modal_bar_through_the_segments() {
    #[derive(Default)]
    struct Ends {
        first: Option<ModalState>,
        last: Option<ModalState>,
    }
    impl Observer for Ends {}
    impl ModalObserver for Ends {
        fn modal_step(&mut self, a: &ModalState, b: &ModalState) {
            self.first.get_or_insert(*a);
            self.last = Some(*b);
        }
        fn modal_impact(&mut self, _b: &ModalState, after: &ModalState, _loss: f64) {
            self.last = Some(*after);
        }
    }
    let model = paper_beam(4, None);
    let sys = beam_system(model, Some(FrictionModel::AsPublished), 1.0);
    for (dt, bound) in [(1e-6, 4e-7), (0.5e-6, 1e-8)] {
        let mut audit = EnergyAudit::new(&sys);
        let r = Rk4 { dt_s: dt }
            .run(&sys, &State::REST, 0.2, &mut audit)
            .unwrap();
        assert!(r.impacts > 100, "{} impacts", r.impacts);
        let b = audit.balance().unwrap();
        let msys = ModalSystem::from_system(&sys).unwrap();
        let mut ends = Ends::default();
        ModalRk4 { dt_s: dt }
            .run_modal(&msys, &ModalState::REST, 0.2, &mut ends)
            .unwrap();
        let direct = msys.mechanical_energy_j(&ends.last.unwrap())
            - msys.mechanical_energy_j(&ends.first.unwrap());
        assert!(
            (b.delta_mechanical_j - direct).abs() <= 1e-12 * b.work_input_j,
            "ΔE audit {} vs modal {direct}",
            b.delta_mechanical_j
        );
        assert!(b.impact_loss_j > 0.1 * b.work_input_j, "{b:?}");
        eprintln!(
            "dt {dt:e}: {} impacts, input {:.4e} J, impacts {:.4e} J, residual {:.2e} J, ΔE audit − modal {:.1e} J",
            r.impacts,
            b.work_input_j,
            b.impact_loss_j,
            b.residual_j,
            b.delta_mechanical_j - direct
        );
        assert!(b.residual_j.abs() < bound, "dt {dt}: {b:?}");
    }
}

/// A lumped-style initial state on a modal bar: `u`, `u̇` at the response point go into mode 1
/// (`q₁ = u/φ₁(x_r)`), the ball keeps its place relative to the cavity; the public state of the
/// result gives them back. What cannot be mapped is refused with the field named.
#[test]
fn initial_state_maps_onto_mode_one_or_is_refused() {
    let model = paper_beam(3, Some(0.1));
    let m1 = model.modes()[0];
    let init = State {
        t_s: 0.25,
        u_m: 3e-6,
        du_m_s: 2e-3,
        v_m: 3e-6 - 4e-5,
        dv_m_s: 2e-3 + 0.01,
        cavity: None,
    };
    let ms = ModalState::from_public(&model, &init).unwrap();
    assert_eq!(ms.t_s, 0.25);
    assert_eq!(ms.q_m[0], 3e-6 / m1.shape_response);
    assert!(ms.q_m[1..].iter().chain(&ms.dq_m_s[1..]).all(|x| *x == 0.0));
    let p = ms.public(&model);
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
    assert!(rel(p.u_m, 3e-6) < 1e-15 && rel(p.du_m_s, 2e-3) < 1e-15);
    assert!(rel(p.w_m(), -4e-5) < 1e-12 && rel(p.dw_m_s(), 0.01) < 1e-12);
    assert!(rel(p.u_cavity_m(), m1.shape_cavity / m1.shape_response * 3e-6) < 1e-15);
    // At rest with the ball displaced: the modes at rest, v = w.
    let rest = State {
        v_m: 1e-5,
        dv_m_s: 0.1,
        ..State::REST
    };
    let ms = ModalState::from_public(&model, &rest).unwrap();
    assert_eq!((ms.v_m, ms.dv_m_s), (1e-5, 0.1));
    assert!(ms.q_m.iter().chain(&ms.dq_m_s).all(|x| *x == 0.0));
    // Another run's public (modal) state cannot be mapped back onto N modes.
    let moved = State {
        cavity: Some(CavityMotion {
            u_cavity_m: 1e-6,
            du_cavity_m_s: 0.0,
        }),
        ..State::REST
    };
    let e = ModalState::from_public(&model, &moved).unwrap_err();
    assert!(e.to_string().contains("initial.cavity"), "{e}");
    // The same checks guard every run (State::validate through validate_run).
    let sys = beam_system(model, Some(FrictionModel::None), 1.0);
    let e = Rk4::default().run(&sys, &moved, 0.01, &mut ()).unwrap_err();
    assert!(e.to_string().contains("initial.cavity"), "{e}");
    // A response point on mode 1's node (the clamp) cannot carry a displacement.
    let at_clamp = paper_beam(3, Some(0.0));
    let e = ModalState::from_public(&at_clamp, &init).unwrap_err();
    assert!(e.to_string().contains("initial.u_m"), "{e}");
    // The ball outside the gap is still refused, relative to the cavity.
    let out = State {
        v_m: 0.06e-3,
        ..State::REST
    };
    let e = out.validate(&sys).unwrap_err();
    assert!(e.to_string().contains("initial.w_m"), "{e}");
}

/// Inputs of a modal system: the errors name the field (and the flag) with the range.
#[test]
fn modal_inputs_are_refused_with_the_field_named() {
    let model = paper_beam(4, None);
    let sys = beam_system(model, Some(FrictionModel::None), 1.0);
    let w4 = model.modes()[3].omega_rad_s;
    assert_eq!(sys.omega1_rad_s(), model.modes()[0].omega_rad_s);
    assert_eq!(sys.omega_max_rad_s(), w4);
    assert_eq!(sys.omega_rad_s(), model.modes()[0].omega_rad_s);
    // rk4's step limit is the highest mode's, ω_N·dt ≤ 2.5.
    let limit = 2.5 / w4;
    assert!(sys.validate_fixed_step(0.99 * limit, 0.01).is_ok());
    let e = Rk4 { dt_s: 1.01 * limit }
        .run(&sys, &State::REST, 0.01, &mut ())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("dt_s (--dt)") && e.contains("ω_N·dt ≤ 2.5"),
        "{e}"
    );
    // The phase limit sees ω_N too.
    let e = sys.validate_horizon(0.0, 1e10).unwrap_err().to_string();
    assert!(e.contains("phase"), "{e}");
    // Ratio range, modal damping, restitution: System::validate on the modal bar.
    let mut bad = sys;
    bad.forcing.frequency = Frequency::Ratio(1e9);
    let e = bad.validate().unwrap_err().to_string();
    assert!(
        e.contains("forcing.frequency_ratio") && e.contains("Ω/ω₁"),
        "{e}"
    );
    let mut m = model;
    m.modes_mut()[2].damping_ratio = 1.0;
    let e = beam_system(m, None, 1.0)
        .validate()
        .unwrap_err()
        .to_string();
    assert!(e.contains("modes.damping_ratio"), "{e}");
    let mut bad = sys;
    bad.damper.as_mut().unwrap().restitution = 2.0;
    assert!(bad
        .validate()
        .unwrap_err()
        .to_string()
        .contains("damper.restitution"));
    // A model's mode count: 1 … MAX_BEAM_MODES.
    let e = ModalModel::new(&[], 1.0).unwrap_err().to_string();
    assert!(e.contains("modes"), "{e}");
    let many = vec![model.modes()[0]; limits::MAX_BEAM_MODES + 1];
    assert!(ModalModel::new(&many, 1.0).is_err());
    assert_eq!(
        ModalModel::new(&many[..limits::MAX_BEAM_MODES], 1.0)
            .unwrap()
            .len(),
        limits::MAX_BEAM_MODES
    );
}

/// `exact` refuses a modal bar with a message that says why and what to use, until the N-mode
/// exact solver is wired in; `max_lyapunov` refuses it (its tangent space is 2N + 2: that is
/// `max_lyapunov_modal`'s).
#[test]
fn exact_and_lyapunov_refuse_a_modal_bar_clearly() {
    let sys = beam_system(paper_beam(3, None), Some(FrictionModel::None), 1.0);
    let e = Exact::default()
        .run(&sys, &State::REST, 0.01, &mut ())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("--solver rk4") && e.contains("N-mode exact"),
        "{e}"
    );
    let p = LyapunovParams::periods(&sys, 0.0, 2.0, 4);
    let e = max_lyapunov(&sys, &State::REST, &Rk4::default(), &p)
        .unwrap_err()
        .to_string();
    assert!(e.contains("lumped bar only") && e.contains("2N + 2"), "{e}");
}

/// The map's mass-ratio axis: `μ = m_d/M` with the lumped `M`; on a modal bar `M` is mode 1's
/// effective mass at the cavity, `m₁/φ₁(x_d)²` (for the lumped bar's unit mode, `M` itself).
#[test]
fn mass_ratio_axis_on_a_modal_bar_uses_mode_one_s_effective_mass() {
    let model = paper_beam(3, None);
    let m1 = model.modes()[0];
    let mut sys = beam_system(model, Some(FrictionModel::None), 1.0);
    Axis::MassRatio.apply(&mut sys, 0.1).unwrap();
    let want = 0.1 * (m1.modal_mass_kg / (m1.shape_cavity * m1.shape_cavity));
    assert_eq!(sys.damper.unwrap().ball_mass_kg, want);
    // ρAL/4 = 0.1686 kg at φ₁ = 0.70: about 0.342 kg, twice the tip's modal mass.
    assert!((want / 0.1 - 0.342).abs() < 1e-3, "{want}");
    // The lumped bar and its unit mode agree.
    let mut lumped = System::paper_damped(0.1e-3, FrictionModel::None, 1.0);
    let mut unit = lumped;
    unit.bar = BarModel::Modal(lumped.modal_model());
    Axis::MassRatio.apply(&mut lumped, 0.04).unwrap();
    Axis::MassRatio.apply(&mut unit, 0.04).unwrap();
    assert_eq!(lumped.damper.unwrap().ball_mass_kg, 0.04 * 0.644);
    assert_eq!(unit.damper, lumped.damper);
    // A cavity on mode 1's node (the clamp) has no such mass.
    let mut at_node = beam_system(
        Beam {
            modes: Some(3),
            cavity_position_m: 0.0,
            ..Beam::default()
        }
        .modal_model()
        .unwrap(),
        Some(FrictionModel::None),
        1.0,
    );
    let e = Axis::MassRatio.apply(&mut at_node, 0.1).unwrap_err();
    assert!(e.to_string().contains("mass_ratio"), "{e}");
    // The other axes do not need it.
    Axis::GapM.apply(&mut at_node, 0.2e-3).unwrap();
}

/// A lumped bar serialises as the `Bar` it is (the metadata of every lumped run is unchanged);
/// a modal one as its modes, and it reads back.
#[test]
fn bar_model_serialises_lumped_as_the_bar_and_modal_as_its_modes() {
    let j = serde_json::to_value(System::paper_damped(1e-3, FrictionModel::None, 1.0)).unwrap();
    assert_eq!(
        j["bar"],
        serde_json::to_value(Bar::PAPER_CAVITY).unwrap(),
        "{j}"
    );
    let back: System = serde_json::from_value(j).unwrap();
    assert_eq!(back.bar, BarModel::Lumped(Bar::PAPER_CAVITY));
    let sys = beam_system(paper_beam(3, None), None, 1.0);
    let j = serde_json::to_value(sys).unwrap();
    assert_eq!(j["bar"]["modes"].as_array().unwrap().len(), 3);
    let back: System = serde_json::from_value(j).unwrap();
    assert_eq!(back, sys);
    // The lumped bar's one-mode model: ω = √(K/M), m = M, shapes 1.
    let m = System::paper_solid(1.0).modal_model();
    assert_eq!(
        m.modes(),
        &[Mode {
            omega_rad_s: Bar::PAPER_SOLID.natural_freq_rad_s(),
            damping_ratio: 0.01,
            modal_mass_kg: 0.668,
            shape_cavity: 1.0,
            shape_force: 1.0,
            shape_response: 1.0,
        }]
    );
}

fn modal_rk4_run(dt: f64) -> Box<vibrobar_core::solver::ModalRun<'static>> {
    let settings = RunSettings {
        dt_s: dt,
        ..RunSettings::default()
    };
    vibrobar_core::solver::modal_run_by_name("rk4", &settings).unwrap()
}

/// The modal estimate against closed forms: a beam without ball decays like its slowest mode,
/// `λ = −ζ₁ω₁`; with a ball that never hits, the free ball is neutral (`λ → 0⁺` like
/// `ln(n)/(nτ)`, as for the lumped bar); with one unit mode it is `max_lyapunov`'s estimate.
#[test]
fn modal_lyapunov_exponent_against_closed_forms() {
    let run = modal_rk4_run(2e-6);
    // No ball, 3 modes: the slowest decay.
    let model = paper_beam(3, None);
    let zw = model.modes()[0].damping_ratio * model.modes()[0].omega_rad_s;
    let sys = ModalSystem::from_system(&beam_system(model, None, 0.9)).unwrap();
    let p = LyapunovParams::periods(&sys.to_system(), 0.01, 3.0, 60);
    let r = max_lyapunov_modal(&sys, &ModalState::REST, &*run, &p).unwrap();
    // The first interval also loses the faster modes' share of the initial direction
    // (ln √3 over 60 intervals ≈ 1.8/s); after it, the direction is mode 1's.
    let late = &r.interval_exponents_per_s[1..];
    let late_mean = late.iter().sum::<f64>() / late.len() as f64;
    eprintln!(
        "no ball: λ = {}, after the first interval {late_mean}, vs −ζ₁ω₁ = {}",
        r.exponent_per_s, -zw
    );
    assert!((late_mean + zw).abs() < 0.01 * zw, "{late_mean}");
    assert!(
        (r.exponent_per_s + zw).abs() < 0.06 * zw,
        "{}",
        r.exponent_per_s
    );
    assert_eq!(r.clamped, 0);
    // A ball that never hits (ratio 0.9, 1 mm gap): neutral.
    let mut sys_b = beam_system(model, Some(FrictionModel::None), 0.9);
    sys_b.damper.as_mut().unwrap().gap_m = 1e-3;
    let msys = ModalSystem::from_system(&sys_b).unwrap();
    let p = LyapunovParams::periods(&sys_b, 0.0, 3.0, 200);
    let r = max_lyapunov_modal(&msys, &ModalState::REST, &*run, &p).unwrap();
    let bound = (200f64).ln() / (200.0 * p.interval_s);
    eprintln!(
        "ball, no impact: λ = {}, ln(n)/(nτ) = {bound}",
        r.exponent_per_s
    );
    assert!(r.exponent_per_s > 0.0 && r.exponent_per_s < 1.5 * bound);
    // One unit mode is the lumped estimate (same scaled coordinates; the static deflection
    // 1/(mω²) vs 1/K differs by an ulp).
    let lumped = System::paper_damped(1e-3, FrictionModel::None, 0.9);
    let p = LyapunovParams::periods(&lumped, 0.0, 3.0, 50);
    let rl = max_lyapunov(&lumped, &State::REST, &Rk4 { dt_s: 2e-6 }, &p).unwrap();
    let msys = ModalSystem::from_system(&lumped).unwrap();
    let rm = max_lyapunov_modal(&msys, &ModalState::REST, &*run, &p).unwrap();
    eprintln!(
        "unit mode {} vs lumped {}",
        rm.exponent_per_s, rl.exponent_per_s
    );
    assert!((rm.exponent_per_s / rl.exponent_per_s - 1.0).abs() < 1e-6);
    // Its checks: a start outside the gap, bad settings.
    let out = ModalState {
        v_m: 2e-3,
        ..ModalState::REST
    };
    assert!(max_lyapunov_modal(&msys, &out, &*run, &p).is_err());
    let mut bad = p;
    bad.d0 = 0.0;
    assert!(max_lyapunov_modal(&msys, &ModalState::REST, &*run, &bad).is_err());
    // exact's modal run refuses until the N-mode exact solver is wired in.
    let exact = vibrobar_core::solver::modal_run_by_name("exact", &RunSettings::default()).unwrap();
    let e = max_lyapunov_modal(&msys, &ModalState::REST, &*exact, &p).unwrap_err();
    assert!(e.to_string().contains("N-mode exact"), "{e}");
    assert!(vibrobar_core::solver::modal_run_by_name("euler", &RunSettings::default()).is_none());
}
