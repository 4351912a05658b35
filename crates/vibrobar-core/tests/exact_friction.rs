//! Friction in the exact solver: Den Hartog's closed form for Coulomb friction to ground, the
//! sign of the friction power per model, and the force conditions at stick/unstick and
//! contact/release transitions.
mod common;

use common::Recorder;
use vibrobar_core::solver::{Event, EventKind, Exact, Mode, Observer, Segment, Solver};
use vibrobar_core::*;

fn checked() -> Exact {
    Exact {
        check_invariants: true,
        ..Default::default()
    }
}

/// Den Hartog (1931): `X/(F0/K) = √(V0² − f² U²)`.
fn den_hartog(r: f64, f: f64) -> f64 {
    let v0 = 1.0 / (1.0 - r * r);
    let pr = std::f64::consts::PI / r;
    let u = pr.sin() / (r * (1.0 + pr.cos()));
    (v0 * v0 - f * f * u * u).sqrt()
}

/// Max |u| and the number of sticks inside a time window.
struct Window {
    from: f64,
    max_u: f64,
    sticks: usize,
}

impl Observer for Window {
    fn segment(&mut self, seg: &dyn Segment) {
        if seg.t_end_s() <= self.from {
            return;
        }
        let a = seg.t_start_s().max(self.from);
        let n = 200;
        for i in 0..=n {
            let t = a + (seg.t_end_s() - a) * i as f64 / n as f64;
            self.max_u = self.max_u.max(seg.state_at(t).u_m.abs());
        }
    }
    fn event(&mut self, ev: &Event) {
        if ev.t_s > self.from && ev.kind == EventKind::Stick {
            self.sticks += 1;
        }
    }
}

#[test]
fn coulomb_to_ground_matches_den_hartog() {
    for (r, f) in [(0.6, 0.3), (0.8, 0.5), (1.5, 0.3)] {
        let (sys, static_defl) = common::friction_to_ground(r, f);
        let period = sys.forcing_period_s();
        let t_end = 400.0 * period;
        let mut win = Window {
            from: t_end - 20.0 * period,
            max_u: 0.0,
            sticks: 0,
        };
        let sum = checked().run(&sys, &State::REST, t_end, &mut win).unwrap();
        assert_eq!(sum.impacts, 0);
        assert_eq!(win.sticks, 0, "r={r} f={f}: motion with stops");
        let x = win.max_u / static_defl;
        let want = den_hartog(r, f);
        assert!(
            ((x - want) / want).abs() < 1e-7,
            "r={r} f={f}: X/(F0/K) = {x} vs Den Hartog {want}"
        );
    }
}

fn paper(fr: FrictionModel, gap: f64, f: Option<f64>, r: f64) -> System {
    let mut sys = System::paper_damped(gap, fr, r);
    sys.damper.as_mut().unwrap().friction_force_n = f;
    sys
}

/// `m_d ü_pair` from a state in which the ball moves with the bar.
fn md_acc_pair(sys: &System, s: &State) -> f64 {
    let d = sys.damper.unwrap();
    let f = sys.force_n(s.t_s)
        - sys.lumped_bar().unwrap().damping_n_s_per_m() * s.du_m_s
        - sys.lumped_bar().unwrap().stiffness_n_per_m * s.u_m;
    d.ball_mass_kg * f / (sys.lumped_bar().unwrap().mass_kg + d.ball_mass_kg)
}

fn run(sys: &System, t_end: f64) -> (Recorder, State) {
    let mut rec = Recorder::default();
    let sum = checked().run(sys, &State::REST, t_end, &mut rec).unwrap();
    (rec, sum.final_state)
}

/// `ΔE = W_forcing − W_viscous + W_friction − impact/chatter losses` to `rel` of the input work.
fn audit(sys: &System, rec: &Recorder, end: &State, rel: f64) {
    let t = rec.totals;
    let de = model::mechanical_energy_j(sys, end).unwrap()
        - model::mechanical_energy_j(sys, &State::REST).unwrap();
    let gap = t.forcing_work_j - t.viscous_loss_j + t.friction_work_j - rec.losses_j() - de;
    assert!(
        gap.abs() < rel * t.forcing_work_j.abs(),
        "energy audit off by {gap:e} J of {:e} J",
        t.forcing_work_j
    );
}

#[test]
fn friction_power_has_the_sign_of_the_model() {
    for (sys, sign) in [
        (
            paper(FrictionModel::AsPublished, 1e-3, Some(20.0), 1.0),
            1.0,
        ),
        (paper(FrictionModel::AsPublished, 1e-4, None, 1.05), 1.0),
        (paper(FrictionModel::Coulomb, 1e-4, Some(1.0), 1.0), -1.0),
        (paper(FrictionModel::Coulomb, 1e-3, Some(5.0), 1.05), -1.0),
    ] {
        let (rec, end) = run(&sys, 0.2);
        let mut free = 0;
        for (_, _, mode, i, _, _) in &rec.segs {
            assert!(
                sign * i.friction_work_j >= 0.0,
                "{mode:?}: {}",
                i.friction_work_j
            );
            if *mode == Mode::Free {
                free += 1;
            }
        }
        assert!(free > 0);
        assert!(sign * rec.totals.friction_work_j > 0.0);
        audit(&sys, &rec, &end, 1e-9);
    }
}

#[test]
fn stick_and_unstick_follow_the_force_condition() {
    let sys = paper(FrictionModel::Coulomb, 1e-3, Some(5.0), 1.05);
    let f = 5.0;
    let d = sys.damper.unwrap();
    let kappa = 1.0 / d.ball_mass_kg + 1.0 / sys.lumped_bar().unwrap().mass_kg;
    let (rec, end) = run(&sys, 0.2);
    let (mut sticks, mut unsticks) = (0, 0);
    for ev in &rec.events {
        let s = ev.after;
        match ev.kind {
            EventKind::Stick => {
                sticks += 1;
                assert!(s.dw_m_s().abs() < 1e-15);
                // Needed force |a_b|/κ within the limit.
                let a_b = md_acc_pair(&sys, &s)
                    * (sys.lumped_bar().unwrap().mass_kg + d.ball_mass_kg)
                    / (d.ball_mass_kg * sys.lumped_bar().unwrap().mass_kg);
                assert!(
                    a_b.abs() <= f * kappa * (1.0 + 1e-12),
                    "{a_b} {}",
                    f * kappa
                );
            }
            EventKind::Unstick => {
                unsticks += 1;
                let need = md_acc_pair(&sys, &s).abs();
                assert!((need - f).abs() < 1e-9 * f, "unstick at |m ü| = {need}");
            }
            _ => {}
        }
    }
    assert!(sticks >= 5 && unsticks >= 5, "{sticks} {unsticks}");
    // Inside stick segments the needed force stays within the limit.
    let mut stick_segs = 0;
    for (a, b, mode, _, sa, sb) in &rec.segs {
        if *mode == Mode::Stick && b > a {
            stick_segs += 1;
            for s in [sa, sb] {
                assert!(md_acc_pair(&sys, s).abs() <= f * (1.0 + 1e-9));
                assert!(s.dw_m_s().abs() < 1e-15);
            }
        }
    }
    assert!(stick_segs >= 5);
    audit(&sys, &rec, &end, 1e-9);
}

/// Ball chattering into contact with the + wall under `F = −2 sin 10t` (vanishing spring): the
/// contact holds while `m_d ü_pair = m_d F/(M + m_d) ≤ f_hold` and releases exactly when `F`
/// reaches `f_hold (M + m_d)/m_d`, i.e. at `10t = π + asin(F/2)`.
#[test]
fn contact_releases_when_the_contact_force_vanishes() {
    for (fr, f) in [
        (FrictionModel::None, 0.0),
        (FrictionModel::AsPublished, 0.002),
        (FrictionModel::Coulomb, 0.005),
    ] {
        let mut sys = common::constant_push(0.0, 2e-4, 0.3);
        sys.bar.as_lumped_mut().unwrap().stiffness_n_per_m = 1e-12;
        sys.forcing.amplitude_n = -2.0;
        sys.forcing.frequency = Frequency::RadPerS(10.0);
        let d = sys.damper.as_mut().unwrap();
        d.friction = fr;
        d.friction_force_n = Some(f);
        let (m, md) = (1.0, 0.05);
        let f_hold = if fr == FrictionModel::Coulomb { f } else { 0.0 };
        let (rec, end) = run(&sys, 0.45);
        let release = rec
            .events
            .iter()
            .find(|e| matches!(e.kind, EventKind::ContactRelease { .. }))
            .unwrap_or_else(|| panic!("{fr}: no release"));
        assert!(matches!(
            release.kind,
            EventKind::ContactRelease {
                wall: solver::Wall::Plus
            }
        ));
        let f_release = f_hold * (m + md) / md;
        let t_want = (std::f64::consts::PI + (f_release / 2.0).asin()) / 10.0;
        assert!(
            (release.t_s - t_want).abs() < 1e-12,
            "{fr}: release at {} vs {t_want}",
            release.t_s
        );
        let s_acc = md_acc_pair(&sys, &release.after);
        assert!((s_acc - f_hold).abs() < 1e-12, "{fr}: {s_acc}");
        // Contact reached by chatter before, held in between.
        assert!(rec.count(|k| matches!(k, EventKind::ChatterLimit { .. })) >= 1);
        for (_, _, mode, _, sa, sb) in &rec.segs {
            if let Mode::Contact(wall) = mode {
                for s in [sa, sb] {
                    assert!(wall.sign() * md_acc_pair(&sys, s) <= f_hold + 1e-12);
                    assert!((s.w_m() - wall.sign() * 1e-4).abs() < 1e-15);
                }
            }
        }
        audit(&sys, &rec, &end, 1e-9);
    }
}
