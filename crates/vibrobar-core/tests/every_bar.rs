//! The exact solver's one event loop on every bar it has a kernel for, as one suite: the lumped
//! paper bar, the same bar as a one-mode `[[modes]]` table, and the paper's bar as a 4-mode
//! beam, each under the three friction laws and both contact laws. Whatever the kernel, the
//! loop's transitions must keep the ball in the cavity, close the energy books, and follow the
//! laws' rules for stick, wall contact and release; and the two kernels of the same one-mode bar
//! must give the same run. A new kernel joins by one more entry in [`bars`].

use vibrobar_core::analysis::energy::EnergyAudit;
use vibrobar_core::params::{
    BarModel, Contact, ContactLaw, Damper, Forcing, FrictionModel, State, System,
};
use vibrobar_core::solver::exact::Exact;
use vibrobar_core::solver::{Event, EventKind, Fanout, Observer, Solver, Wall};
use vibrobar_core::structure::{Beam, Structure};

/// The bars, by name, with the paper's forcing at ratio 1 of each bar's first frequency.
fn bars(damper: Damper) -> Vec<(&'static str, System)> {
    let lumped = System::paper_damped(damper.gap_m, damper.friction, 1.0);
    let lumped = System {
        damper: Some(damper),
        ..lumped
    };
    let bar = *lumped.lumped_bar().unwrap();
    let one_mode = vibrobar_core::structure::Mode {
        omega_rad_s: bar.natural_freq_rad_s(),
        damping_ratio: bar.damping_ratio,
        modal_mass_kg: bar.mass_kg,
        shape_cavity: 1.0,
        shape_force: 1.0,
        shape_response: 1.0,
    };
    let table = System {
        bar: BarModel::Modal(Structure::Measured(vec![one_mode]).modal_model().unwrap()),
        ..lumped
    };
    let beam = System {
        bar: BarModel::Modal(
            Structure::Beam(Beam {
                modes: Some(4),
                ..Beam::default()
            })
            .modal_model()
            .unwrap(),
        ),
        forcing: Forcing::paper(1.0),
        ..lumped
    };
    vec![
        ("lumped", lumped),
        ("one-mode table", table),
        ("4-mode beam", beam),
    ]
}

/// The laws: friction (with a level that makes the coulomb ball stick and the as-published one
/// switch often) and the contact law.
fn laws() -> Vec<(FrictionModel, Option<f64>, ContactLaw)> {
    let mut v = vec![];
    for law in [ContactLaw::Restitution, ContactLaw::Hertz] {
        v.push((FrictionModel::None, None, law));
        v.push((FrictionModel::AsPublished, Some(0.5), law));
        v.push((FrictionModel::Coulomb, Some(0.5), law));
    }
    v
}

fn damper(friction: FrictionModel, f: Option<f64>, law: ContactLaw) -> Damper {
    Damper {
        friction_force_n: f,
        contact: match law {
            ContactLaw::Restitution => Contact::default(),
            ContactLaw::Hertz => Contact::hertz(),
        },
        ..Damper::paper(0.1e-3, friction)
    }
}

/// The events of a run, and the rules they must follow whatever the bar.
#[derive(Default)]
struct Rules {
    events: Vec<Event>,
}

impl Observer for Rules {
    fn event(&mut self, ev: &Event) {
        self.events.push(*ev);
    }
}

impl Rules {
    /// Stick is left only by an unstick; a ball summed onto a wall (chatter limit) or released
    /// from it has that wall's contact; no event kind the law cannot produce.
    fn check(&self, name: &str, friction: FrictionModel, law: ContactLaw) {
        // Unknown before the first event: a start at rest may be stuck without an event.
        let mut stuck: Option<bool> = None;
        for (i, ev) in self.events.iter().enumerate() {
            let what = format!("{name}, {friction}, {law:?}: event {i} at {} s", ev.t_s);
            match ev.kind {
                EventKind::Stick => {
                    assert_eq!(friction, FrictionModel::Coulomb, "{what}: stick");
                    assert_ne!(stuck, Some(true), "{what}: stick while stuck");
                    stuck = Some(true);
                }
                EventKind::Unstick => {
                    assert_eq!(friction, FrictionModel::Coulomb, "{what}: unstick");
                    assert_ne!(stuck, Some(false), "{what}: unstick while not stuck");
                    stuck = Some(false);
                }
                _ => {
                    assert_ne!(stuck, Some(true), "{what}: {:?} while stuck", ev.kind);
                    stuck = Some(false);
                }
            }
            if let EventKind::FrictionSwitch = ev.kind {
                assert_ne!(
                    friction,
                    FrictionModel::None,
                    "{what}: a switch without friction"
                );
            }
            if let EventKind::ChatterLimit { .. } = ev.kind {
                assert_eq!(
                    law,
                    ContactLaw::Restitution,
                    "{what}: a chatter limit under hertz"
                );
            }
            if let EventKind::Impact { wall, dw_m_s, .. } = ev.kind {
                // Into the wall it hit (or a graze at ẇ = 0).
                let s = match wall {
                    Wall::Plus => 1.0,
                    Wall::Minus => -1.0,
                };
                assert!(s * dw_m_s >= 0.0, "{what}: impact leaving the wall");
            }
        }
    }
}

/// Every bar, every law: the ball stays in the cavity (restitution: to 1e-12 m; hertz: within
/// the contact's own penetration, below 10 µm), the energy books close (to 1e-12 of the energy
/// turned over with restitution, to 1e-7 through contact phases), the events follow the rules.
#[test]
fn every_bar_keeps_the_ball_in_the_cavity_closes_its_books_and_follows_the_rules() {
    let ex = Exact {
        check_invariants: true,
        ..Exact::default()
    };
    for (friction, f, law) in laws() {
        for (name, sys) in bars(damper(friction, f, law)) {
            let mut audit = EnergyAudit::new(&sys);
            let mut rules = Rules::default();
            let r = ex
                .run(
                    &sys,
                    &State::REST,
                    0.2,
                    &mut Fanout(&mut [&mut audit, &mut rules]),
                )
                .unwrap_or_else(|e| panic!("{name}, {friction}, {law:?}: {e}"));
            let b = audit.balance().unwrap();
            let scale = b.work_input_j.abs()
                + b.viscous_loss_j
                + b.impact_loss_j
                + b.friction_work_j.abs()
                + b.delta_mechanical_j.abs();
            println!(
                "{name:>15}, {friction:>12}, {law:?}: {} events, {} impacts, penetration {:.2e} m, \
                 books residual {:.1e} of {scale:.2e} J",
                r.events,
                r.impacts,
                r.max_penetration_m,
                b.residual_j.abs() / scale
            );
            assert!(r.impacts > 0, "{name}, {friction}, {law:?}: no impact");
            // Closed forms close the books to rounding; a contact phase to its DP5 tolerance
            // (relative 1e-9 per step, the quadrature of its books).
            let (tol, pen_max) = match law {
                ContactLaw::Restitution => (1e-12, 1e-12),
                ContactLaw::Hertz => (1e-7, 1e-5),
            };
            assert!(
                b.residual_j.abs() <= tol * scale,
                "{name}, {friction}, {law:?}: residual {:e} of {scale:e}",
                b.residual_j
            );
            assert!(
                r.max_penetration_m <= pen_max,
                "{name}, {friction}, {law:?}: penetration {}",
                r.max_penetration_m
            );
            rules.check(name, friction, law);
        }
    }
}

/// The lumped kernel and the N-mode kernel of the same one-mode bar give the same run over
/// 0.05 s: the same sequence of events, at the same times to 1e-9 of a period, for every law.
#[test]
fn the_lumped_and_the_one_mode_kernels_give_the_same_run() {
    for (friction, f, law) in laws() {
        let b = bars(damper(friction, f, law));
        let period = 2.0 * std::f64::consts::PI / b[0].1.omega_rad_s();
        let runs: Vec<Vec<Event>> = b[..2]
            .iter()
            .map(|(name, sys)| {
                let mut rules = Rules::default();
                Exact::default()
                    .run(sys, &State::REST, 0.05, &mut rules)
                    .unwrap_or_else(|e| panic!("{name}, {friction}, {law:?}: {e}"));
                rules.events
            })
            .collect();
        let (a, c) = (&runs[0], &runs[1]);
        println!("{friction}, {law:?}: {} events vs {}", a.len(), c.len());
        assert!(!a.is_empty());
        assert_eq!(a.len(), c.len(), "{friction}, {law:?}");
        for (x, y) in a.iter().zip(c) {
            let same_kind = std::mem::discriminant(&x.kind) == std::mem::discriminant(&y.kind);
            assert!(
                same_kind,
                "{friction}, {law:?}: {:?} vs {:?}",
                x.kind, y.kind
            );
            assert!(
                (x.t_s - y.t_s).abs() <= 1e-9 * period,
                "{friction}, {law:?}: {} vs {} s",
                x.t_s,
                y.t_s
            );
        }
    }
}
