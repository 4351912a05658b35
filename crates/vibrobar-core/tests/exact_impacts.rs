//! Impacts against closed forms: a geometric bounce sequence, a chatter sequence summed to its
//! accumulation point, and constructed grazing cases (touch, near miss, near hit).
mod common;

use common::{constant_push, Recorder};
use vibrobar_core::analysis::Sampler;
use vibrobar_core::solver::{EventKind, Exact, Observer, Rk4, Segment, Solver, Wall};
use vibrobar_core::*;

fn checked() -> Exact {
    Exact {
        check_invariants: true,
        ..Default::default()
    }
}

/// A bar so heavy and stiff that it does not move; frictionless ball launched at 1 m/s.
fn fixed_bar(restitution: f64) -> System {
    System {
        bar: Bar {
            mass_kg: 1e12,
            stiffness_n_per_m: 1e18,
            damping_ratio: 0.01,
        }
        .into(),
        damper: Some(Damper {
            restitution,
            ..Damper::paper(2e-3, FrictionModel::None)
        }),
        forcing: Forcing {
            amplitude_n: 0.0,
            frequency: Frequency::RadPerS(1.0),
            static_force_n: 0.0,
        },
        gravity_m_s2: 9.81,
    }
}

fn launched(dw: f64) -> State {
    State {
        dv_m_s: dw,
        ..State::REST
    }
}

#[test]
fn bounces_form_a_geometric_sequence() {
    let e = 0.9;
    let sys = fixed_bar(e);
    let lg = 1e-3;
    let mut rec = Recorder::default();
    checked().run(&sys, &launched(1.0), 0.25, &mut rec).unwrap();
    let imp = rec.impacts();
    assert!(imp.len() >= 15, "{}", imp.len());
    let mut t = lg / 1.0;
    let mut dw: f64 = 1.0;
    for (n, ev) in imp.iter().enumerate() {
        let EventKind::Impact { wall, dw_m_s, .. } = ev.kind else {
            unreachable!()
        };
        assert!(
            (ev.t_s - t).abs() < 1e-9 * t,
            "impact {n}: t {} vs {t}",
            ev.t_s
        );
        assert!(
            (dw_m_s - dw).abs() < 1e-9 * dw.abs(),
            "impact {n}: {dw_m_s} vs {dw}"
        );
        assert_eq!(wall, if n % 2 == 0 { Wall::Plus } else { Wall::Minus });
        dw *= -e;
        t += 2.0 * lg / dw.abs();
    }
}

#[test]
fn rk4_bounces_agree_loosely() {
    let sys = fixed_bar(0.9);
    let mut a = Recorder::default();
    let mut b = Recorder::default();
    checked().run(&sys, &launched(1.0), 0.05, &mut a).unwrap();
    let dt = 1e-6;
    Rk4 { dt_s: dt }
        .run(&sys, &launched(1.0), 0.05, &mut b)
        .unwrap();
    let (ia, ib) = (a.impacts(), b.impacts());
    assert_eq!(ia.len(), ib.len());
    for (n, (x, y)) in ia.iter().zip(&ib).enumerate() {
        // After-step detection: each impact is late by < dt, and the lateness accumulates.
        assert!((x.t_s - y.t_s).abs() < (n as f64 + 1.0) * 2.0 * dt, "{n}");
    }
}

/// Constant relative acceleration `a` toward the + wall: `t∞ = t1 + 2 e s1 / (a (1 − e))`, then
/// the pair moves as one body under `F_s`: momentum `F_s t`, centre of mass `F_s t²/(2(M+m))`.
fn chatter_case(e: f64) {
    let fs = -1.0;
    let gap = 2e-3;
    let sys = constant_push(fs, gap, e);
    let (m, md, lg) = (1.0, 0.05, 1e-3);
    let a = -fs / m;
    let t1 = (2.0 * lg / a).sqrt();
    let s1 = a * t1;
    let t_inf = t1 + 2.0 * e * s1 / (a * (1.0 - e));
    let t_end = 2.0 * t_inf;
    let mut rec = Recorder::default();
    let sum = checked().run(&sys, &State::REST, t_end, &mut rec).unwrap();
    // Accumulation point.
    let t_contact = rec
        .events
        .iter()
        .find(|ev| {
            matches!(ev.kind, EventKind::ChatterLimit { .. })
                || (e == 0.0 && matches!(ev.kind, EventKind::Impact { .. }))
        })
        .map(|ev| ev.t_s)
        .expect("contact reached");
    assert!(
        (t_contact - t_inf).abs() < 1e-9 * t_inf,
        "accumulation at {t_contact} vs {t_inf}"
    );
    // Nothing after it: the ball rides the + wall.
    assert!(rec.events.last().unwrap().t_s <= t_contact);
    let mt = m + md;
    let state_at = |t: f64| {
        let x = fs * t * t / (2.0 * mt);
        let v = fs * t / mt;
        (x - md * lg / mt, v)
    };
    for t in [t_inf, t_end] {
        let (u, du) = state_at(t);
        let s = if t == t_end {
            sum.final_state
        } else {
            rec.events.last().unwrap().after
        };
        assert!((s.u_m - u).abs() < 1e-9 * u.abs(), "u {} vs {u}", s.u_m);
        assert!(
            (s.du_m_s - du).abs() < 1e-9 * du.abs(),
            "u̇ {} vs {du}",
            s.du_m_s
        );
        assert!((s.w_m() - lg).abs() < 1e-15);
        assert!((s.dv_m_s - du).abs() < 1e-9 * du.abs());
    }
    // Energy audit: forcing work = ΔE + losses (frictionless, undamped).
    let e0 = 0.0;
    let e1 = model::mechanical_energy_j(&sys, &sum.final_state).unwrap();
    let audit = rec.totals.forcing_work_j - rec.totals.viscous_loss_j - rec.losses_j() - (e1 - e0);
    assert!(
        audit.abs() < 1e-9 * rec.totals.forcing_work_j.abs(),
        "audit {audit:e}"
    );
}

#[test]
fn chatter_sums_to_its_accumulation_point() {
    chatter_case(0.5);
    chatter_case(0.8);
}

#[test]
fn plastic_impact_goes_straight_to_contact() {
    chatter_case(0.0);
}

/// Observer that evaluates the state at given times from whichever segment holds them.
struct Probe {
    times: Vec<f64>,
    found: Vec<Option<State>>,
}

impl Observer for Probe {
    fn segment(&mut self, seg: &dyn Segment) {
        for (i, &t) in self.times.iter().enumerate() {
            if t >= seg.t_start_s() && t <= seg.t_end_s() && self.found[i].is_none() {
                self.found[i] = Some(seg.state_at(t));
            }
        }
    }
}

/// Ball launched toward the + wall against a constant relative deceleration `a = 1`: its apex
/// is at `l_g + δ`.
fn graze(delta: f64) -> (Recorder, Probe, Sampler, f64, f64) {
    let sys = constant_push(1.0, 2e-3, 0.5);
    let lg = 1e-3;
    let a = 1.0;
    let dw0 = (2.0 * a * (lg + delta)).sqrt();
    let t_apex = dw0 / a;
    let mut rec = Recorder::default();
    let mut probe = Probe {
        times: vec![t_apex],
        found: vec![None],
    };
    let mut sampler = Sampler::new(0.0, t_apex / 1000.0);
    {
        let mut obs: [&mut dyn Observer; 3] = [&mut rec, &mut probe, &mut sampler];
        checked()
            .run(
                &sys,
                &launched(dw0),
                1.9 * t_apex,
                &mut vibrobar_core::solver::Fanout(&mut obs),
            )
            .unwrap();
    }
    for s in &sampler.samples {
        assert!(s.w_m().abs() <= lg + 1e-12, "sample outside: {}", s.w_m());
    }
    (rec, probe, sampler, dw0, t_apex)
}

#[test]
fn near_miss_by_a_picometre_has_no_impact() {
    let (rec, probe, _, _, _) = graze(-1e-12);
    assert_eq!(rec.impacts().len(), 0);
    let w = probe.found[0].unwrap().w_m();
    assert!((w - (1e-3 - 1e-12)).abs() < 1e-15, "apex {w}");
}

#[test]
fn near_hit_by_a_picometre_is_one_gentle_impact() {
    let (rec, _, _, dw0, _) = graze(1e-12);
    let imp = rec.impacts();
    assert_eq!(imp.len(), 1);
    let EventKind::Impact { wall, dw_m_s, .. } = imp[0].kind else {
        unreachable!()
    };
    assert_eq!(wall, Wall::Plus);
    let want = (2.0f64 * 1e-12).sqrt();
    assert!((dw_m_s - want).abs() < 1e-3 * want, "{dw_m_s} vs {want}");
    let t_hit = dw0 - (dw0 * dw0 - 2e-3).sqrt();
    assert!(
        (imp[0].t_s - t_hit).abs() < 1e-9,
        "{} vs {t_hit}",
        imp[0].t_s
    );
}

#[test]
fn exact_touch_is_at_most_a_tangential_impact() {
    let (rec, _, _, _, t_apex) = graze(0.0);
    let imp = rec.impacts();
    assert!(imp.len() <= 1);
    for ev in imp {
        let EventKind::Impact { dw_m_s, .. } = ev.kind else {
            unreachable!()
        };
        assert!(dw_m_s.abs() < 1e-7, "{dw_m_s}");
        assert!((ev.t_s - t_apex).abs() < 1e-6);
    }
    // Bounded work: the touch does not start an event loop.
    assert!(rec.events.len() <= 3, "{}", rec.events.len());
}

#[test]
fn event_limit_bounds_the_work() {
    let sys = fixed_bar(0.9);
    let solver = Exact {
        max_events: 5,
        ..Default::default()
    };
    let r = solver.run(&sys, &launched(1.0), 1.0, &mut ());
    match r {
        Err(SimError::TooManyEvents { limit, t_s, .. }) => {
            assert_eq!(limit, 5);
            assert!(t_s > 0.0 && t_s < 1.0);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn registered_by_name() {
    assert!(vibrobar_core::solver::SOLVER_NAMES.contains(&"exact"));
    let s = vibrobar_core::solver::solver_by_name("exact", &RunSettings::default()).unwrap();
    assert_eq!(s.name(), "exact");
}

/// Coulomb friction during the chatter: the ball slides to the wall with `a − fκ`, bounces away
/// against `a + fκ`, so the bounces shrink by `q = e√((a − fκ)/(a + fκ))` and the sequence
/// ends at `t∞ = t1 + T1/(1 − q)`, `T1 = (e s1/a_away)(1 + √(a_away/a_back))`. Friction is
/// internal, so the momentum and centre of mass still follow `F_s`.
#[test]
fn chatter_with_coulomb_friction_sums_to_its_accumulation_point() {
    let (fs, e, f) = (-1.0, 0.6, 0.01);
    let mut sys = constant_push(fs, 2e-3, e);
    let d = sys.damper.as_mut().unwrap();
    d.friction = FrictionModel::Coulomb;
    d.friction_force_n = Some(f);
    let (m, md, lg) = (1.0, 0.05, 1e-3);
    let kappa = 1.0 / md + 1.0 / m;
    let a = -fs / m;
    let (a_away, a_back) = (a + f * kappa, a - f * kappa);
    let t1 = (2.0 * lg / a_back).sqrt();
    let s1 = a_back * t1;
    let q = e * (a_back / a_away).sqrt();
    let t_inf = t1 + e * s1 / a_away * (1.0 + (a_away / a_back).sqrt()) / (1.0 - q);
    let mut rec = Recorder::default();
    let sum = checked()
        .run(&sys, &State::REST, 1.5 * t_inf, &mut rec)
        .unwrap();
    let ev = rec
        .events
        .iter()
        .find(|ev| matches!(ev.kind, EventKind::ChatterLimit { .. }))
        .expect("chatter limit");
    assert!(
        (ev.t_s - t_inf).abs() < 1e-9 * t_inf,
        "{} vs {t_inf}",
        ev.t_s
    );
    let mt = m + md;
    let t = 1.5 * t_inf;
    let (u, du) = (fs * t * t / (2.0 * mt) - md * lg / mt, fs * t / mt);
    let s = sum.final_state;
    assert!((s.u_m - u).abs() < 1e-9 * u.abs(), "{} vs {u}", s.u_m);
    assert!((s.du_m_s - du).abs() < 1e-9 * du.abs());
    assert!((s.w_m() - lg).abs() < 1e-15);
}

/// Grazing on the oscillating paper bar (free, undamped): the ball rests at `v0` while the bar
/// swings `u = U cos ωt`, so `w = v0 − U cos ωt` peaks tangentially at `v0 + U` at `ωt = π`.
fn oscillating_graze(delta: f64) -> (Recorder, Sampler, f64) {
    let mut sys = System::paper_damped(0.1e-3, FrictionModel::None, 1.0);
    sys.bar.as_lumped_mut().unwrap().damping_ratio = 0.0;
    sys.forcing.amplitude_n = 0.0;
    let (lg, big_u) = (0.05e-3, 3e-5);
    let init = State {
        u_m: big_u,
        v_m: lg - big_u + delta,
        ..State::REST
    };
    let period = 2.0 * std::f64::consts::PI / sys.lumped_bar().unwrap().natural_freq_rad_s();
    let mut rec = Recorder::default();
    let mut sampler = Sampler::new(0.0, period / 997.0);
    {
        let mut obs: [&mut dyn Observer; 2] = [&mut rec, &mut sampler];
        checked()
            .run(
                &sys,
                &init,
                0.9 * period,
                &mut vibrobar_core::solver::Fanout(&mut obs),
            )
            .unwrap();
    }
    for s in &sampler.samples {
        assert!(s.w_m().abs() <= lg + 1e-12, "sample outside: {}", s.w_m());
    }
    (rec, sampler, period)
}

#[test]
fn oscillating_near_miss_has_no_impact() {
    let (rec, _, _) = oscillating_graze(-1e-12);
    assert_eq!(rec.impacts().len(), 0);
}

#[test]
fn oscillating_near_hit_is_found() {
    let (rec, _, period) = oscillating_graze(1e-12);
    let imp = rec.impacts();
    assert!(!imp.is_empty());
    let EventKind::Impact { wall, dw_m_s, .. } = imp[0].kind else {
        unreachable!()
    };
    assert_eq!(wall, Wall::Plus);
    // ẇ at w = l_g − 1e-12 below the peak: √(2·1e-12·Uω²).
    let wn = 2.0 * std::f64::consts::PI / period;
    let want = (2.0 * 1e-12 * 3e-5 * wn * wn).sqrt();
    assert!((dw_m_s - want).abs() < 1e-3 * want, "{dw_m_s} vs {want}");
    assert!((imp[0].t_s - 0.5 * period).abs() < 1e-3 * period);
}

#[test]
fn oscillating_exact_touch_terminates() {
    let (rec, _, period) = oscillating_graze(0.0);
    assert!(rec.events.len() <= 3, "{}", rec.events.len());
    for ev in rec.impacts() {
        let EventKind::Impact { dw_m_s, .. } = ev.kind else {
            unreachable!()
        };
        assert!(dw_m_s.abs() < 1e-6, "{dw_m_s}");
        assert!((ev.t_s - 0.5 * period).abs() < 1e-4 * period);
    }
}
