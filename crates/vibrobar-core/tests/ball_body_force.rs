//! A constant body force on the ball along the gap (`damper.gravity_along_gap_m_s2 = g_s`,
//! gravity along the hole) against closed forms: the drop to the wall, the ball resting on it
//! under a small harmonic load (the pair's linear response), the lift-off where the pair's
//! acceleration reaches `g_s`, the energy books with the work `m_d g_s Δv`, rk4 against exact,
//! the refusals where it is not supported, and the parameter's validation and serialisation.
mod common;

use common::Recorder;
use vibrobar_core::analysis::energy::EnergyAudit;
use vibrobar_core::error::SimError;
use vibrobar_core::params::{BarModel, ContactLaw};
use vibrobar_core::solver::{EventKind, Exact, Mode, Observer, Rk4, Segment, Solver, Wall};
use vibrobar_core::structure::{Beam, ModalModel, Structure};
use vibrobar_core::*;

const G: f64 = 9.80665;
const M: f64 = 1.0;
const K: f64 = 1e4;
const ZETA: f64 = 0.05;
const MD: f64 = 0.026;
const LG: f64 = 1e-3;
const E: f64 = 0.5;

fn checked() -> Exact {
    Exact {
        check_invariants: true,
        ..Default::default()
    }
}

fn bar() -> Bar {
    Bar {
        mass_kg: M,
        stiffness_n_per_m: K,
        damping_ratio: ZETA,
    }
}

fn ball(gs: f64, friction: FrictionModel) -> Damper {
    Damper {
        ball_mass_kg: MD,
        restitution: E,
        gravity_along_gap_m_s2: gs,
        ..Damper::paper(2.0 * LG, friction)
    }
}

/// The lumped bar, the one-mode modal bar of the same constants, or the paper's 4-mode beam,
/// with the frictionless ball under `g_s`, forced by `F0 sin Ωt`.
fn system(model: &str, gs: f64, f0: f64, omega: f64) -> System {
    let bar_model = match model {
        "lumped" => BarModel::Lumped(bar()),
        "one-mode" => BarModel::Modal(ModalModel::lumped(&bar())),
        "beam" => BarModel::Modal(
            Structure::Beam(Beam {
                modes: Some(4),
                ..Beam::default()
            })
            .modal_model()
            .unwrap(),
        ),
        _ => unreachable!(),
    };
    System {
        bar: bar_model,
        damper: Some(ball(gs, FrictionModel::None)),
        forcing: Forcing {
            amplitude_n: f0,
            frequency: Frequency::RadPerS(omega),
            static_force_n: 0.0,
        },
        gravity_m_s2: G,
    }
}

/// `1/M_eff = Σ φₙ(x_d)²/mₙ` of a bar at its cavity.
fn inv_eff_mass(sys: &System) -> f64 {
    match &sys.bar {
        BarModel::Lumped(b) => 1.0 / b.mass_kg,
        BarModel::Modal(m) => m
            .modes()
            .iter()
            .map(|x| x.shape_cavity * x.shape_cavity / x.modal_mass_kg)
            .sum(),
    }
}

/// The bar's velocity at the cavity.
fn du_cavity(s: &State) -> f64 {
    s.cavity.map_or(s.du_m_s, |c| c.du_cavity_m_s)
}

/// (1) Unforced bar, ball at rest in the middle, `g_s = −g`: it falls freely and hits the `−`
/// wall at `t = √(2 l_g/g)` with `ẇ− = −√(2 g l_g)`; the bar's velocity at the cavity jumps by
/// the impact law's `(1 + e) ẇ− (1/M_eff)/κ`, `κ = 1/m_d + 1/M_eff`.
#[test]
fn a_dropped_ball_hits_the_lower_wall_at_the_free_fall_time() {
    let t_hit = (2.0 * LG / G).sqrt();
    let dw_hit = -(2.0 * G * LG).sqrt();
    for model in ["lumped", "one-mode", "beam"] {
        let sys = system(model, -G, 0.0, 1.0);
        let mut rec = Recorder::default();
        checked()
            .run(&sys, &State::REST, 1.5 * t_hit, &mut rec)
            .unwrap();
        let imp = rec.impacts();
        let ev = imp.first().unwrap_or_else(|| panic!("{model}: no impact"));
        let EventKind::Impact { wall, dw_m_s, .. } = ev.kind else {
            unreachable!()
        };
        assert_eq!(wall, Wall::Minus, "{model}");
        let rel_t = (ev.t_s / t_hit - 1.0).abs();
        assert!(
            rel_t < 1e-12,
            "{model}: impact at {} s, free fall {t_hit} s (rel {rel_t:.1e})",
            ev.t_s
        );
        assert!(
            (dw_m_s / dw_hit - 1.0).abs() < 1e-12,
            "{model}: ẇ− {dw_m_s} vs {dw_hit}"
        );
        // Nothing else before it: the bar is unloaded and at rest until the impact.
        assert!(
            du_cavity(&ev.before).abs() == 0.0,
            "{model}: {:?}",
            ev.before
        );
        let inv_m = inv_eff_mass(&sys);
        let kappa = 1.0 / MD + inv_m;
        let jump = du_cavity(&ev.after) - du_cavity(&ev.before);
        let want = (1.0 + E) * dw_m_s * inv_m / kappa;
        assert!(
            (jump / want - 1.0).abs() < 1e-12,
            "{model}: bar velocity jump {jump} vs impact law {want}"
        );
        let dw_after = ev.after.dv_m_s - du_cavity(&ev.after);
        assert!(
            (dw_after / (-E * dw_m_s) - 1.0).abs() < 1e-12,
            "{model}: ẇ+ {dw_after} vs {}",
            -E * dw_m_s
        );
    }
}

/// The same drop with `g_s = 0` never hits: the ball floats (the test above can fail).
#[test]
fn without_the_body_force_the_ball_floats() {
    let sys = system("lumped", 0.0, 0.0, 1.0);
    let mut rec = Recorder::default();
    checked().run(&sys, &State::REST, 1.0, &mut rec).unwrap();
    assert!(rec.events.is_empty(), "{:?}", rec.events.first());
}

/// Samples `u` (response point) on a grid of every segment.
#[derive(Default)]
struct Grid {
    dt: f64,
    pts: Vec<(f64, f64, f64)>,
    modes: Vec<Mode>,
}

impl Observer for Grid {
    fn segment(&mut self, seg: &dyn Segment) {
        self.modes.push(seg.mode());
        let (a, b) = (seg.t_start_s(), seg.t_end_s());
        let mut t = (a / self.dt).ceil() * self.dt;
        while t <= b {
            let s = seg.state_at(t);
            self.pts.push((t, s.u_m, s.du_m_s));
            t += self.dt;
        }
    }
}

/// (2a) With `e < 1` the bounces accumulate (a chatter summed to its limit) and the ball ends
/// resting on the `−` wall; the unforced bar settles at the static offset `m_d g_s/K`.
#[test]
fn the_bounces_accumulate_and_the_ball_rests_on_the_lower_wall() {
    for model in ["lumped", "one-mode"] {
        let sys = system(model, -G, 0.0, 1.0);
        let mut rec = Recorder::default();
        checked().run(&sys, &State::REST, 10.0, &mut rec).unwrap();
        let chatter = rec.count(|k| {
            matches!(
                k,
                EventKind::ChatterLimit {
                    wall: Wall::Minus,
                    ..
                }
            )
        });
        assert!(chatter >= 1, "{model}: no chatter limit");
        assert_eq!(
            rec.count(|k| matches!(k, EventKind::ContactRelease { .. })),
            0,
            "{model}: the ball left the wall"
        );
        let (_, _, mode, _, _, end) = rec.segs.last().unwrap();
        assert_eq!(*mode, Mode::Contact(Wall::Minus), "{model}");
        let u_s = MD * -G / K;
        assert!(
            (end.u_m / u_s - 1.0).abs() < 1e-9,
            "{model}: rest at {} m, static offset {u_s} m",
            end.u_m
        );
        assert!((end.v_m - end.u_m + LG).abs() < 1e-15, "{model}: {end:?}");
    }
}

/// The pair `M + m_d` forced at `Ω`: its steady `u = u_s + X sin(Ωt − φ)` with the static
/// offset `u_s = m_d g_s/K`, and the state on it at `t = 0` with the ball on the `−` wall.
fn pair_orbit(gs: f64, accel_over_g: f64, omega: f64) -> (f64, f64, f64, f64, State) {
    let mp = M + MD;
    let c = 2.0 * ZETA * (K * M).sqrt();
    let (re, im) = (K - mp * omega * omega, c * omega);
    let x = accel_over_g * G / (omega * omega);
    let f0 = x * re.hypot(im);
    let phi = im.atan2(re);
    let u_s = MD * gs / K;
    let u0 = u_s - x * phi.sin();
    let du0 = x * omega * phi.cos();
    let init = State {
        u_m: u0,
        du_m_s: du0,
        v_m: u0 - LG,
        dv_m_s: du0,
        ..State::REST
    };
    (f0, x, phi, u_s, init)
}

/// (2b) Resting on the `−` wall under a harmonic force whose pair acceleration amplitude is half
/// of `g`: the ball never leaves, and the bar moves as the pair's linear response (plus the
/// static offset `m_d g_s/K`) to 1e-9 of its amplitude.
#[test]
fn under_a_small_force_the_resting_ball_rides_the_bar_as_one_body() {
    let omega = 60.0;
    let (f0, x, phi, u_s, init) = pair_orbit(-G, 0.5, omega);
    for model in ["lumped", "one-mode"] {
        let sys = system(model, -G, f0, omega);
        let mut grid = Grid {
            dt: 1e-3,
            ..Default::default()
        };
        let r = checked().run(&sys, &init, 1.0, &mut grid).unwrap();
        assert_eq!(r.events, 0, "{model}: the ball left the wall");
        assert!(
            grid.modes.iter().all(|m| *m == Mode::Contact(Wall::Minus)),
            "{model}: {:?}",
            grid.modes
        );
        let mut worst: f64 = 0.0;
        for &(t, u, du) in &grid.pts {
            let want = u_s + x * (omega * t - phi).sin();
            let dwant = x * omega * (omega * t - phi).cos();
            worst = worst
                .max((u - want).abs() / x)
                .max((du - dwant).abs() / (x * omega));
        }
        assert!(grid.pts.len() > 900, "{model}: {}", grid.pts.len());
        assert!(worst < 1e-9, "{model}: largest deviation {worst:.2e} of X");
    }
}

/// (3) Raise the force so the pair's acceleration amplitude is twice `g`: the ball resting on the
/// `−` wall first leaves it where the pair's acceleration reaches `g_s = −g`, at
/// `sin(Ωt − φ) = g/(Ω²X)`. The acceleration is read at the release from the segment's closed
/// form (lumped) and from the event's state through the pair's equation of motion.
#[test]
fn the_ball_lifts_off_where_the_pair_accelerates_down_at_g() {
    let omega = 60.0;
    let (f0, x, phi, _, init) = pair_orbit(-G, 2.0, omega);
    let t_release = (phi + (G / (omega * omega * x)).asin()) / omega;
    for model in ["lumped", "one-mode"] {
        let sys = system(model, -G, f0, omega);
        let mut rec = Recorder::default();
        struct Acc(Vec<(f64, Option<f64>)>);
        impl Observer for Acc {
            fn segment(&mut self, seg: &dyn Segment) {
                self.0
                    .push((seg.t_end_s(), seg.acceleration_at(seg.t_end_s())));
            }
        }
        let mut acc = Acc(Vec::new());
        checked()
            .run(
                &sys,
                &init,
                t_release + 0.01,
                &mut vibrobar_core::solver::Fanout(&mut [&mut rec, &mut acc]),
            )
            .unwrap();
        let ev = rec
            .events
            .iter()
            .find(|e| matches!(e.kind, EventKind::ContactRelease { .. }))
            .unwrap_or_else(|| panic!("{model}: no release"));
        assert_eq!(ev.kind, EventKind::ContactRelease { wall: Wall::Minus });
        assert!(
            rec.events.iter().all(|e| e.t_s >= ev.t_s),
            "{model}: an event before the release"
        );
        assert!(
            (ev.t_s / t_release - 1.0).abs() < 1e-9,
            "{model}: release at {} s, closed form {t_release} s",
            ev.t_s
        );
        // The pair's acceleration from the event's state: (F − C u̇ − K u + m_d g_s)/(M + m_d).
        let s = &ev.before;
        let c = 2.0 * ZETA * (K * M).sqrt();
        let a_state = (sys.force_n(s.t_s) - c * s.du_m_s - K * s.u_m + MD * -G) / (M + MD);
        assert!(
            (a_state / -G - 1.0).abs() < 1e-9,
            "{model}: pair acceleration at release {a_state} m/s², want {}",
            -G
        );
        if let Some(&(_, Some(a_seg))) = acc.0.iter().find(|(t, _)| *t == ev.t_s) {
            assert!(
                (a_seg / -G - 1.0).abs() < 1e-9,
                "{model}: segment acceleration at release {a_seg} m/s², want {}",
                -G
            );
        } else {
            assert_eq!(
                model, "one-mode",
                "the lumped segment holds its acceleration"
            );
        }
        // The ball leaves the wall upwards relative to the bar.
        assert!(ev.after.w_m() == -LG, "{model}: {:?}", ev.after);
    }
}

/// Coulomb friction under the body force: a ball sticks at `ẇ = 0` only where the friction it
/// needs to follow the bar, `|m_d(ü_pair − g_s)|`, is within the level `F`, and unsticks where
/// it reaches `F` (read from the event's state through the pair's equation of motion, 1e-9).
#[test]
fn a_stuck_ball_unsticks_where_the_friction_it_needs_reaches_the_level() {
    let (gs, f) = (3.0 * G, 0.5);
    for model in ["lumped", "one-mode"] {
        let mut sys = system(model, gs, 20.0, 90.0);
        let d = sys.damper.as_mut().unwrap();
        d.friction = FrictionModel::Coulomb;
        d.friction_force_n = Some(f);
        let mut rec = Recorder::default();
        checked().run(&sys, &State::REST, 0.3, &mut rec).unwrap();
        let c = 2.0 * ZETA * (K * M).sqrt();
        let needed = |s: &State| {
            let pair = (sys.force_n(s.t_s) - c * s.du_m_s - K * s.u_m + MD * gs) / (M + MD);
            MD * (pair - gs)
        };
        let (mut sticks, mut unsticks) = (0, 0);
        for ev in &rec.events {
            match ev.kind {
                EventKind::Stick => {
                    sticks += 1;
                    let n = needed(&ev.after).abs();
                    assert!(
                        n <= f * (1.0 + 1e-9),
                        "{model}: stick at {} s needs {n} N > {f} N",
                        ev.t_s
                    );
                }
                EventKind::Unstick => {
                    unsticks += 1;
                    let n = needed(&ev.before).abs();
                    assert!(
                        (n / f - 1.0).abs() < 1e-9,
                        "{model}: unstick at {} s needs {n} N, level {f} N",
                        ev.t_s
                    );
                }
                _ => {}
            }
        }
        assert!(
            sticks >= 3 && unsticks >= 3,
            "{model}: {sticks} sticks, {unsticks} unsticks"
        );
    }
}

/// (4) The books close to 1e-12 of the energy turned over with the work of the body force
/// `m_d g_s Δv` booked: impacts, chatter, wall contact (the drop and a forced ball), coulomb
/// stick-slip and as-published friction, on the lumped bar, the one-mode bar and the beam, both
/// signs of `g_s`. The body force's work is far above the tolerance (without it the books
/// would not close).
#[test]
fn the_books_close_with_the_work_of_the_body_force() {
    let cases: Vec<(&str, System, State, f64)> = {
        let mut v = Vec::new();
        for model in ["lumped", "one-mode", "beam"] {
            v.push((model, system(model, -G, 0.0, 1.0), State::REST, 0.5));
            for (gs, friction, f) in [
                (-G, FrictionModel::None, None),
                (3.0 * G, FrictionModel::Coulomb, Some(0.5)),
                (-2.0 * G, FrictionModel::AsPublished, Some(0.1)),
            ] {
                let mut sys = system(model, gs, 20.0, 90.0);
                let d = sys.damper.as_mut().unwrap();
                d.friction = friction;
                d.friction_force_n = f;
                v.push((model, sys, State::REST, 0.3));
            }
        }
        v
    };
    for (model, sys, init, t_end) in cases {
        let d = sys.damper.unwrap();
        let what = format!(
            "{model}, g_s = {}, {}",
            d.gravity_along_gap_m_s2, d.friction
        );
        let mut audit = EnergyAudit::new(&sys);
        let mut rec = Recorder::default();
        let r = checked()
            .run(
                &sys,
                &init,
                t_end,
                &mut vibrobar_core::solver::Fanout(&mut [&mut audit, &mut rec]),
            )
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        let b = audit.balance().unwrap();
        let scale = b.work_input_j.abs()
            + b.viscous_loss_j
            + b.impact_loss_j
            + b.friction_work_j.abs()
            + b.gravity_work_j.abs()
            + b.delta_mechanical_j.abs();
        println!(
            "{what}: {} events, {} impacts, gravity work {:.3e} J, residual {:.1e} of {scale:.2e} J",
            r.events,
            r.impacts,
            b.gravity_work_j,
            b.residual_j.abs() / scale
        );
        assert!(r.impacts > 0, "{what}: no impact");
        assert!(
            b.gravity_work_j.abs() > 1e-6 * scale,
            "{what}: gravity work {} J of {scale} J",
            b.gravity_work_j
        );
        assert!(
            b.residual_j.abs() <= 1e-12 * scale,
            "{what}: residual {:e} of {scale:e} J ({b:?})",
            b.residual_j
        );
    }
}

/// (5) rk4 converges to the exact solver with `g_s ≠ 0` (a bar launched at 1 m/s and forced
/// below resonance, the ball bouncing and once chattering to rest before the bar's motion
/// lifts it off again): the final state's error falls with `dt` (at most first order with the
/// after-step impact detection, which resolves a chatter as many small bounces) and is 1e-4
/// of what the body force changes.
#[test]
fn rk4_agrees_with_exact_under_the_body_force() {
    let gs = -3.0 * G;
    let (f0, omega) = (50.0, 70.0);
    let init = State {
        du_m_s: 1.0,
        dv_m_s: 1.0,
        ..State::REST
    };
    for model in ["lumped", "one-mode"] {
        let sys = system(model, gs, f0, omega);
        let t_end = 0.1;
        let ex = Exact::default().run(&sys, &init, t_end, &mut ()).unwrap();
        let ex0 = Exact::default()
            .run(&system(model, 0.0, f0, omega), &init, t_end, &mut ())
            .unwrap();
        let err = |a: &State, b: &State| (a.u_m - b.u_m).hypot((a.du_m_s - b.du_m_s) / omega);
        let effect = err(&ex.final_state, &ex0.final_state);
        assert!(ex.impacts >= 5, "{model}: {} impacts", ex.impacts);
        let mut errs = Vec::new();
        for dt in [2e-6, 1e-6, 5e-7] {
            let r = Rk4 { dt_s: dt }.run(&sys, &init, t_end, &mut ()).unwrap();
            errs.push(err(&r.final_state, &ex.final_state));
        }
        println!("{model}: rk4 errors {errs:?} m, effect of g_s {effect:e} m");
        // Measured (lumped): 5.8e-9, 2.6e-9, 2.6e-9 m; the summed chatter, which rk4 resolves
        // as small bounces on its grid, keeps the last halving from gaining.
        assert!(
            errs[1] < errs[0] && errs[2] < 0.6 * errs[0],
            "{model}: rk4 error does not fall with dt: {errs:?}"
        );
        assert!(
            errs[2] < 1e-4 * effect,
            "{model}: rk4 error {} m vs the body force's effect {effect} m",
            errs[2]
        );
    }
}

/// (6) Bad values are refused naming the field.
#[test]
fn a_bad_body_force_is_refused_naming_the_field() {
    for gs in [f64::NAN, 1e4, -1e4, f64::INFINITY] {
        let sys = system("lumped", gs, 0.0, 1.0);
        let e = sys.validate().unwrap_err().to_string();
        assert!(e.contains("damper.gravity_along_gap_m_s2"), "{gs}: {e}");
        let e = checked()
            .run(&sys, &State::REST, 0.01, &mut ())
            .unwrap_err()
            .to_string();
        assert!(e.contains("damper.gravity_along_gap_m_s2"), "{gs}: {e}");
    }
    for gs in [1000.0, -1000.0, 0.0] {
        system("lumped", gs, 0.0, 1.0).validate().unwrap();
    }
}

/// Where it is not supported (hertz contact, cutting, the analytic symmetric orbit) it is
/// refused, naming the field; never silently ignored.
#[test]
fn where_unsupported_the_body_force_is_refused() {
    for model in ["lumped", "one-mode"] {
        let mut sys = system(model, -G, 0.0, 1.0);
        sys.damper.as_mut().unwrap().contact.law = ContactLaw::Hertz;
        match checked().run(&sys, &State::REST, 0.01, &mut ()) {
            Err(SimError::Unsupported(m)) => {
                assert!(
                    m.contains("damper.gravity_along_gap_m_s2") && m.contains("hertz"),
                    "{m}"
                )
            }
            other => panic!("{model}: {other:?}"),
        }
        // The same with g_s = 0 runs.
        sys.damper.as_mut().unwrap().gravity_along_gap_m_s2 = 0.0;
        checked().run(&sys, &State::REST, 0.01, &mut ()).unwrap();
    }
    let sys = system("lumped", -G, 1.0, 90.0);
    // Cutting runs, lumped and modal.
    let cut = vibrobar_core::excitation::Cutting {
        coefficient_n_m2: 1e9,
        width_m: 1e-4,
        feed_m: 1e-4,
        spindle_rpm: 3000.0,
        force_direction_factor: 1.0,
        chip_direction_factor: 1.0,
        force_law: vibrobar_core::excitation::CuttingForceLaw::Linear,
    };
    for model in ["lumped", "one-mode"] {
        let sys = system(model, -G, 0.0, 1.0);
        let r = match model {
            "lumped" => vibrobar_core::solver::exact::cutting::ExactCutting::new(cut)
                .run(&sys, &State::REST, 0.01, &mut ())
                .map(|_| ()),
            _ => {
                let msys = vibrobar_core::structure::ModalSystem::from_system(&sys).unwrap();
                let minit =
                    vibrobar_core::structure::ModalState::from_public(&msys.model, &State::REST)
                        .unwrap();
                vibrobar_core::solver::exact::modal::cutting::ModalCutting::new(cut)
                    .run(&msys, &minit, 0.01, &mut ())
                    .map(|_| ())
            }
        };
        match r {
            Err(SimError::Unsupported(m)) => {
                assert!(
                    m.contains("damper.gravity_along_gap_m_s2") && m.contains("cutting"),
                    "{m}"
                )
            }
            other => panic!("{model} cutting: {other:?}"),
        }
    }
    // The analytic symmetric orbit (the starting guesses) is the symmetric bar's.
    match vibrobar_core::analysis::orbit::symmetric_orbits(&system("lumped", -G, 1.0, 90.0)) {
        Err(SimError::Unsupported(m)) => {
            assert!(m.contains("damper.gravity_along_gap_m_s2"), "{m}")
        }
        other => panic!("symmetric orbits: {:?}", other.map(|v| v.len())),
    }
    let _ = sys;
}

/// (7) `g_s = 0` written out reads as the default and serialises as if left out.
#[test]
fn an_explicit_zero_is_the_default_and_is_not_written() {
    let d: Damper = serde_json::from_str(r#"{"gravity_along_gap_m_s2": 0.0}"#).unwrap();
    assert_eq!(d, Damper::default());
    let out = serde_json::to_string(&d).unwrap();
    assert!(!out.contains("gravity_along_gap"), "{out}");
    assert_eq!(out, serde_json::to_string(&Damper::default()).unwrap());
    let g: Damper = serde_json::from_str(r#"{"gravity_along_gap_m_s2": -9.5}"#).unwrap();
    assert_eq!(g.gravity_along_gap_m_s2, -9.5);
    let out = serde_json::to_string(&g).unwrap();
    assert!(out.contains(r#""gravity_along_gap_m_s2":-9.5"#), "{out}");
    let back: Damper = serde_json::from_str(&out).unwrap();
    assert_eq!(back, g);
}

/// Periodic orbits under the body force (gravity along the hole): Newton on the variational
/// flow's Jacobian, from a settled run, finds a fixed point of the stroboscopic map that a
/// plain run repeats, and its Jacobian and multipliers are those of central finite differences
/// of the map. The paper's bar at 0.1 mm and r = 1 with gravity towards the − wall, and at
/// 1 mm with a small force, where the ball rests, lifts off and lands once a period.
#[test]
fn periodic_orbits_under_the_body_force_are_fixed_points_with_the_fd_multipliers() {
    use vibrobar_core::analysis::orbit::{
        multipliers_of, orbit_auto, ExactJacobian, FiniteDifference, MapJacobian,
    };
    for (name, gap_m, f0) in [("0.1 mm, 15 N", 0.1e-3, 15.0), ("1 mm, 0.5 N", 1e-3, 0.5)] {
        let mut sys = System::paper_damped(gap_m, FrictionModel::None, 1.0);
        sys.forcing.amplitude_n = f0;
        sys.damper.as_mut().unwrap().gravity_along_gap_m_s2 = -G;
        let (orb, _) = orbit_auto(&sys, 1, &State::REST, 0.5, &ExactJacobian)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let sec = &orb.section;
        let x = vibrobar_core::analysis::orbit::to_vector(&orb.state);
        // A plain run from the orbit's state comes back to it after one period.
        let back = vibrobar_core::analysis::orbit::to_vector(
            &Exact::default()
                .run(&sys, &orb.state, orb.state.t_s + sec.period_s(), &mut ())
                .unwrap()
                .final_state,
        );
        let sc = vibrobar_core::analysis::orbit::scales(&sys);
        let gap = (0..4)
            .map(|i| ((back[i] - x[i]) / sc[i]).abs())
            .fold(0.0, f64::max);
        assert!(gap < 1e-8, "{name}: the run misses the orbit by {gap:e}");
        let (_, fd) = FiniteDifference::default()
            .map_and_jacobian(sec, &x)
            .unwrap();
        let (_, ex) = ExactJacobian.map_and_jacobian(sec, &x).unwrap();
        let (a, b) = (multipliers_of(&fd), multipliers_of(&ex));
        eprintln!(
            "{name}: {} impacts per period, multipliers {b:?} (FD {a:?}), stable {}",
            orb.impacts_per_period,
            orb.stable()
        );
        assert!(orb.impacts_per_period >= 1, "{name}");
        for (l, m) in a.iter().zip(&b) {
            assert!((l - m).norm() < 1e-5, "{name}: {a:?} vs {b:?}");
        }
    }
}
