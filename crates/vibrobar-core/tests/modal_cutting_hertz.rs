//! The compliant (`hertz`) contact law on a cutting run of a modal bar (issue #13): a one-mode
//! `[[modes]]` table against the lumped cutting-Hertz run (an independent code path: its own
//! right-hand side, history recorder and driver), and on a 4-mode beam the energy books with the
//! cutting work, the contacts' momentum and penetration, and the convergence with the contact
//! phase's DP5 tolerance.

use vibrobar_core::analysis::energy::EnergyAudit;
use vibrobar_core::analysis::lobes::{Linearisation, LobeTable, TipReceptance};
use vibrobar_core::damper::contact::Hertz;
use vibrobar_core::damper::impact::modal_inverse_effective_mass_per_kg;
use vibrobar_core::excitation::{one_mode_limit_width_m, Cutting, CuttingForceLaw};
use vibrobar_core::params::{
    Bar, BarModel, Contact, Damper, Forcing, Frequency, FrictionModel, State, System,
};
use vibrobar_core::solver::exact::cutting::ExactCutting;
use vibrobar_core::solver::exact::modal::cutting::ModalCutting;
use vibrobar_core::solver::{Event, EventKind, Fanout, Mode, Observer, Segment, Solver};
use vibrobar_core::structure::{Beam, ModalModel, ModalState, ModalSystem, Point, Structure};

const F_HZ: f64 = 600.0;
const K: f64 = 2.2e6;
const ZETA: f64 = 0.01;
const KF: f64 = 2e9;
const H0: f64 = 1e-4;
const GAP: f64 = 2e-5;
const MD: f64 = 0.01;

fn wn() -> f64 {
    2.0 * std::f64::consts::PI * F_HZ
}

fn bar() -> Bar {
    Bar {
        mass_kg: K / (wn() * wn()),
        stiffness_n_per_m: K,
        damping_ratio: ZETA,
    }
}

fn ball(friction: FrictionModel, friction_force_n: Option<f64>) -> Damper {
    Damper {
        ball_mass_kg: MD,
        gap_m: GAP,
        friction,
        friction_force_n,
        contact: Contact::hertz(),
        ..Damper::default()
    }
}

fn no_force() -> Forcing {
    Forcing {
        amplitude_n: 0.0,
        frequency: Frequency::Ratio(1.0),
        static_force_n: 0.0,
    }
}

fn cut(width_m: f64, rpm: f64) -> Cutting {
    Cutting {
        coefficient_n_m2: KF,
        width_m,
        feed_m: H0,
        spindle_rpm: rpm,
        force_direction_factor: 1.0,
        chip_direction_factor: 1.0,
        force_law: CuttingForceLaw::Linear,
    }
}

/// Samples `u` on a grid; counts the contact phases (their releases), the cut events inside
/// contact phases (a contact segment following a contact segment on the other side of the cut),
/// and watches the cut.
struct Watch {
    dt: f64,
    next: f64,
    u: Vec<f64>,
    prev: Option<(f64, Mode, bool)>,
    cut_events_in_contact: u64,
    releases: u64,
    left_cut: bool,
    contact_segments: u64,
    /// Per release: (approach speed, leaving speed).
    speeds: Vec<(f64, f64)>,
}

impl Watch {
    fn new(dt: f64) -> Self {
        Watch {
            dt,
            next: 0.0,
            u: vec![],
            prev: None,
            cut_events_in_contact: 0,
            releases: 0,
            left_cut: false,
            contact_segments: 0,
            speeds: vec![],
        }
    }
}

impl Observer for Watch {
    fn segment(&mut self, seg: &dyn Segment) {
        let (t0, t1) = (seg.t_start_s(), seg.t_end_s());
        while self.next <= t1 {
            if self.next >= t0 {
                self.u.push(seg.state_at(self.next).u_m);
            }
            self.next += self.dt;
        }
        let c0 = seg.cutting_at(t0).unwrap();
        self.left_cut |= !c0.in_cut;
        let contact = matches!(seg.mode(), Mode::Contact(_));
        if contact {
            self.contact_segments += 1;
            if let Some((tp, mp, inp)) = self.prev {
                if matches!(mp, Mode::Contact(_))
                    && tp.to_bits() == t0.to_bits()
                    && inp != c0.in_cut
                {
                    self.cut_events_in_contact += 1;
                }
            }
        }
        self.prev = Some((t1, seg.mode(), c0.in_cut));
    }
    fn event(&mut self, ev: &Event) {
        if let EventKind::Impact { dw_m_s, .. } = ev.kind {
            self.releases += 1;
            self.speeds.push((dw_m_s.abs(), ev.after.dw_m_s().abs()));
        }
    }
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Issue #13: a one-mode `[[modes]]` table with the bar's M and K (shape_cavity = 1) under the
/// `hertz` law reproduces the lumped cutting-Hertz run over 0.05 s at 1.5 b_lim, the tool
/// leaving the cut, tens of contact phases and cut events inside them: the same contacts, the
/// same cut events in contact and the same DP5 steps, `u` on a grid of τ/40 within the contact
/// phase's relative tolerance (1e-9) of its amplitude, the deepest penetration too. Measured:
/// 150 contacts, 40 cut events inside them, ~15 400 contact steps, max |Δu| 3e-13 to 4e-13 of
/// the amplitude for the three friction laws (the paths differ in rounding only: the modal
/// phase's modal force sums against the lumped phase's, `1/κ` against `Mm_d/(M+m_d)`).
#[test]
fn one_mode_table_is_the_lumped_cutting_hertz_run() {
    let rpm = 30_000.0;
    let (bl, _) = one_mode_limit_width_m(&cut(1.0, rpm), bar().mass_kg, K, ZETA);
    let m1 = vibrobar_core::structure::Mode {
        omega_rad_s: wn(),
        damping_ratio: ZETA,
        modal_mass_kg: bar().mass_kg,
        shape_cavity: 1.0,
        shape_force: 1.0,
        shape_response: 1.0,
    };
    let c = cut(1.5 * bl, rpm);
    let init = State {
        du_m_s: 1.5 * H0 * wn(),
        dv_m_s: 1.5 * H0 * wn(),
        ..State::default()
    };
    for (friction, f) in [
        (FrictionModel::None, None),
        (FrictionModel::AsPublished, Some(0.5)),
        (FrictionModel::Coulomb, Some(0.5)),
    ] {
        let d = ball(friction, f);
        let lumped = System {
            bar: BarModel::Lumped(bar()),
            damper: Some(d),
            forcing: no_force(),
            gravity_m_s2: 9.81,
        };
        let modal = System {
            bar: BarModel::Modal(Structure::Measured(vec![m1]).modal_model().unwrap()),
            ..lumped
        };
        let mut solver = ExactCutting::new(c);
        solver.exact.check_invariants = true;
        let dt = c.delay_s() / 40.0;
        let (mut a, mut b) = (Watch::new(dt), Watch::new(dt));
        let ra = solver.run(&lumped, &init, 0.05, &mut a).unwrap();
        let rb = solver.run(&modal, &init, 0.05, &mut b).unwrap();
        let scale = a.u.iter().map(|u| u.abs()).fold(0.0, f64::max);
        let diff = max_diff(&a.u, &b.u);
        println!(
            "{friction}: lumped {} contacts ({} cut events in contact, {} contact steps), modal \
             {} ({}, {}); left the cut {}; max |Δu| {diff:.2e} of {scale:.2e} m ({:.1e}); max \
             penetration {:.4e} vs {:.4e} m",
            a.releases,
            a.cut_events_in_contact,
            a.contact_segments,
            b.releases,
            b.cut_events_in_contact,
            b.contact_segments,
            a.left_cut,
            diff / scale,
            ra.max_penetration_m,
            rb.max_penetration_m
        );
        assert!(a.releases >= 20 && a.left_cut && a.cut_events_in_contact >= 1);
        assert_eq!(
            (a.releases, a.cut_events_in_contact, a.contact_segments),
            (b.releases, b.cut_events_in_contact, b.contact_segments)
        );
        assert_eq!(a.left_cut, b.left_cut);
        assert!(diff <= 1e-9 * scale, "{friction}: {diff:e} of {scale:e}");
        assert!((ra.max_penetration_m - rb.max_penetration_m).abs() <= 1e-9 * ra.max_penetration_m);
    }
}
