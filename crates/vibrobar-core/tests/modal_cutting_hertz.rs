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
    BarModel, Contact, Damper, Forcing, Frequency, FrictionModel, State, System,
};
use vibrobar_core::solver::exact::cutting::ExactCutting;
use vibrobar_core::solver::exact::modal::cutting::ModalCutting;
use vibrobar_core::solver::{Event, EventKind, Fanout, Mode, Observer, Segment, Solver};
use vibrobar_core::structure::{Beam, ModalState, ModalSystem, Point, Structure};

#[path = "common/lumped_cut.rs"]
mod lumped_cut;
use lumped_cut::{bar, wn, H0, K, KF, ZETA};

const GAP: f64 = 2e-5;
const MD: f64 = 0.01;

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
    let init = State {
        du_m_s: 1.5 * H0 * wn(),
        dv_m_s: 1.5 * H0 * wn(),
        ..State::default()
    };
    for (law, friction, f) in [
        (CuttingForceLaw::Linear, FrictionModel::None, None),
        (
            CuttingForceLaw::Linear,
            FrictionModel::AsPublished,
            Some(0.5),
        ),
        (CuttingForceLaw::Linear, FrictionModel::Coulomb, Some(0.5)),
        // The three-quarter law: the contact phase takes the law's force, the pieces between
        // contacts the remainder fit; both paths are the lumped bar's.
        (
            CuttingForceLaw::ThreeQuarter,
            FrictionModel::Coulomb,
            Some(0.5),
        ),
    ] {
        let c = Cutting {
            force_law: law,
            ..cut(1.5 * bl, rpm)
        };
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
            "{law:?} {friction}: lumped {} contacts ({} cut events in contact, {} contact steps), modal \
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

/// The paper's beam on `n` modes, the paper's ball (`gap`, `friction`) under the `hertz` law, no
/// harmonic force.
fn beam(n: usize, gap: f64, friction: FrictionModel, f: Option<f64>) -> System {
    System {
        bar: BarModel::Modal(
            Structure::Beam(Beam {
                modes: Some(n),
                ..Beam::default()
            })
            .modal_model()
            .unwrap(),
        ),
        damper: Some(Damper {
            contact: Contact::hertz(),
            friction_force_n: f,
            ..Damper::paper(gap, friction)
        }),
        forcing: no_force(),
        gravity_m_s2: 9.81,
    }
}

/// `b_lim` of a modal bar without the ball at `rpm` (the exact lobes).
fn b_lim(s: &System, rpm: f64) -> f64 {
    let BarModel::Modal(m) = &s.bar else {
        unreachable!()
    };
    let rec = TipReceptance::new(m, Linearisation::BallFree).unwrap();
    LobeTable::new(rec)
        .unwrap()
        .boundary_at(rpm, KF)
        .unwrap()
        .b_lim_m
}

fn modal_sys(s: &System) -> ModalSystem {
    ModalSystem::from_system(s).unwrap()
}

fn kappa(s: &System) -> f64 {
    let BarModel::Modal(m) = &s.bar else {
        unreachable!()
    };
    let modes: &[vibrobar_core::structure::Mode] = m.modes();
    let phi: Vec<f64> = modes.iter().map(|x| x.shape(Point::Cavity)).collect();
    let mass: Vec<f64> = modes.iter().map(|x| x.modal_mass_kg).collect();
    modal_inverse_effective_mass_per_kg(s.damper.unwrap().ball_mass_kg, &phi, &mass)
}

/// The energy books of `hertz` cutting runs of the 4-mode beam close with the cutting work
/// (`ΔE = −viscous − contact dissipation + friction + cutting work`, Hertz's elastic energy in
/// `E`) to the contact phase's tolerance, for every friction law, with the invariant checks on
/// (5000 rpm, 1.5 b_lim, 0.1 s from 1.5 h0 out of the cut; the run ends outside a contact, a
/// phase's dissipation being booked at its release). Measured: residual 2.9e-9, 1.3e-8 and
/// 3.6e-9 of the books' scale (frictionless, as published, coulomb), 56 to 86 contacts, 5 cut
/// events inside them. Momentum: the contacts of fast approach (≥ a quarter of the fastest)
/// leave at 0.63 to 1.09 times the target restitution `e` of the approach speed (the law is
/// calibrated to `e` on a free pair; the bar's motion and the cut act during the contact).
/// Penetration: the deepest is the closed-form Hertz value at the fastest approach on the beam's
/// effective mass at the cavity `1/κ`, up to a quarter above it (measured 1.053; the bar and the
/// cut push on during the contact), as on the lumped bar.
#[test]
fn energy_books_close_on_a_four_mode_beam() {
    let rpm = 5000.0;
    for (friction, f) in [
        (FrictionModel::None, None),
        (FrictionModel::AsPublished, None),
        (FrictionModel::Coulomb, Some(0.5)),
    ] {
        let s = beam(4, 0.1e-3, friction, f);
        let c = cut(1.5 * b_lim(&s, rpm), rpm);
        let mut solver = ExactCutting::new(c);
        solver.exact.check_invariants = true;
        let init = State {
            u_m: 1.5 * H0,
            v_m: 1.5 * H0,
            ..State::default()
        };
        let mut t_end = 0.1;
        let (r, e, w) = loop {
            let mut audit = EnergyAudit::new(&s);
            let mut w = Watch::new(1.0);
            let r = solver
                .run(&s, &init, t_end, &mut Fanout(&mut [&mut audit, &mut w]))
                .unwrap();
            if r.final_state.w_m().abs() <= 0.05e-3 * 0.999 {
                break (r, audit.balance().unwrap(), w);
            }
            t_end += 1e-4;
        };
        let scale = e.work_input_j.abs()
            + e.viscous_loss_j
            + e.impact_loss_j
            + e.friction_work_j.abs()
            + e.cutting_work_j.abs();
        let law = Hertz::of_damper(&s.damper.unwrap());
        let vmax = w.speeds.iter().map(|x| x.0).fold(0.0, f64::max);
        let closed = law.max_penetration_m(1.0 / kappa(&s), vmax);
        let ratio = r.max_penetration_m / closed;
        // Restitution of the contacts of fast approach (a quarter of the fastest or more).
        let fast: Vec<f64> = w
            .speeds
            .iter()
            .filter(|x| x.0 >= 0.25 * vmax)
            .map(|x| x.1 / x.0)
            .collect();
        let (emin, emax) = fast
            .iter()
            .fold((f64::INFINITY, 0.0_f64), |(a, b), &x| (a.min(x), b.max(x)));
        println!(
            "{friction}: {t_end:.4} s, {} contacts ({} fast: leaving/approach {emin:.3}..{emax:.3}), \
             {} cut events in contact, left the cut {}; books {e:?}, residual/scale {:.2e}; \
             max penetration {:.3e} m, closed form at {vmax:.3} m/s {closed:.3e} m ({ratio:.3})",
            w.releases,
            fast.len(),
            w.cut_events_in_contact,
            w.left_cut,
            e.residual_j / scale,
            r.max_penetration_m
        );
        assert!(w.releases > 50 && w.left_cut && w.cut_events_in_contact >= 1);
        assert!(e.cutting_work_j != 0.0 && e.impact_loss_j > 0.0);
        assert!(e.residual_j.abs() < 1e-7 * scale, "{e:?}");
        assert!((1.0..1.25).contains(&ratio), "{ratio}");
        let e_target = s.damper.unwrap().restitution;
        assert!(
            fast.len() >= 20 && emin >= 0.6 * e_target && emax <= 1.15 * e_target,
            "{emin} {emax}"
        );
    }
}

/// The run converges with the contact phase's DP5 tolerance: on the 4-mode beam (frictionless
/// ball, 5000 rpm, 1.5 b_lim, 20 ms from 1.5 h0 out of the cut, 24 contacts, 5 cut events inside
/// them, 32 pieces per period) the largest difference in `u` on a grid of τ/200 against rtol
/// 1e-13 never grows as rtol falls, and falls 65-fold from 1e-7 to 1e-11, the contacts and cut
/// events the same in number. Measured (of the amplitude 1.6e-4 m): 1.8e-4 at rtol 1e-5 to 1e-7
/// (there the DP5 steps are the delay stepping's pieces, 1/32 of the fastest mode's period, not
/// the tolerance's), 3.0e-5 at 1e-8, 1.5e-5 at the default 1e-9, 3.1e-6 at 1e-10, 2.8e-6 at
/// 1e-11: a floor, because each DP5 step is a knot of the surface history and the knots move
/// with rtol (the Hermite surface between them differs by the pieces' own error). With 512
/// pieces per period the floor falls to 1.4e-7 at 1e-11.
#[test]
fn converges_with_the_contact_tolerance_on_a_four_mode_beam() {
    let rpm = 5000.0;
    let s = beam(4, 0.1e-3, FrictionModel::None, None);
    let c = cut(1.5 * b_lim(&s, rpm), rpm);
    let ms = modal_sys(&s);
    let BarModel::Modal(model) = &s.bar else {
        unreachable!()
    };
    let init = ModalState::from_public(
        model,
        &State {
            u_m: 1.5 * H0,
            v_m: 1.5 * H0,
            ..State::default()
        },
    )
    .unwrap();
    let solver = ModalCutting::new(c);
    let dt = c.delay_s() / 200.0;
    let run = |rtol: f64| {
        let mut w = Watch::new(dt);
        solver
            .run_with_contact_rtol(&ms, &init, 0.02, rtol, &mut w)
            .unwrap();
        w
    };
    let reference = run(1e-13);
    let amp = reference.u.iter().map(|u| u.abs()).fold(0.0, f64::max);
    let mut errs = vec![];
    for rtol in [1e-5, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11] {
        let w = run(rtol);
        let e = max_diff(&w.u, &reference.u);
        println!(
            "rtol {rtol:e}: max |Δu| {e:.3e} m of {amp:.3e} m ({:.2e}); {} contacts, {} cut \
             events in contact (reference {}, {})",
            e / amp,
            w.releases,
            w.cut_events_in_contact,
            reference.releases,
            reference.cut_events_in_contact
        );
        assert_eq!(
            (w.releases, w.cut_events_in_contact),
            (reference.releases, reference.cut_events_in_contact)
        );
        errs.push(e);
    }
    assert!(reference.releases >= 10 && reference.cut_events_in_contact >= 1);
    for p in errs.windows(2) {
        assert!(p[1] <= 1.01 * p[0], "{errs:?}");
    }
    assert!(errs[5] < errs[1] / 30.0, "{errs:?}");
    assert!(errs[3] < 3e-5 * amp, "{errs:?}");
    // Out of range: the error names the tolerance.
    let e = solver
        .run_with_contact_rtol(&ms, &init, 0.02, 0.1, &mut ())
        .unwrap_err()
        .to_string();
    assert!(e.contains("rtol") && e.contains("0.001"), "{e}");
}

/// A beam's cutting run stopped inside a `hertz` contact phase and continued
/// ([`ExactCutting::continue_run`]) goes on with the phase where it stopped (the penetration, the
/// friction state and the contact's dissipation kept), and follows the uninterrupted run: the
/// same contacts, `u` on a grid within the contact phase's tolerance of its amplitude. Three
/// friction laws on the 4-mode paper beam at 1.5 b_lim.
#[test]
fn a_beam_run_continued_from_inside_a_contact_is_the_uninterrupted_run() {
    let rpm = 5000.0;
    for (friction, f) in [
        (FrictionModel::None, None),
        (FrictionModel::AsPublished, None),
        (FrictionModel::Coulomb, Some(0.5)),
    ] {
        let s = beam(4, 0.1e-3, friction, f);
        let c = cut(1.5 * b_lim(&s, rpm), rpm);
        let mut solver = ExactCutting::new(c);
        solver.exact.check_invariants = true;
        let init = State {
            u_m: 1.5 * H0,
            v_m: 1.5 * H0,
            ..State::default()
        };
        let t_end = 0.05;
        // A time inside a contact: the middle of a contact segment after 20 ms.
        struct Mid(Option<f64>);
        impl Observer for Mid {
            fn segment(&mut self, seg: &dyn Segment) {
                if self.0.is_none()
                    && seg.t_start_s() > 0.02
                    && matches!(seg.mode(), Mode::Contact(_))
                    && seg.t_end_s() > seg.t_start_s()
                {
                    self.0 = Some(0.5 * (seg.t_start_s() + seg.t_end_s()));
                }
            }
        }
        let dt = c.delay_s() / 200.0;
        let (mut mid, mut whole) = (Mid(None), Watch::new(dt));
        solver
            .run(&s, &init, t_end, &mut Fanout(&mut [&mut mid, &mut whole]))
            .unwrap();
        let t1 = mid.0.expect("a contact after 20 ms");
        let mut parts = Watch::new(dt);
        let (r1, end) = solver.run_keeping(&s, &init, t1, &mut parts).unwrap();
        let pen = r1.final_state.w_m().abs() - 0.05e-3;
        assert!(pen > 0.0, "{friction}: not inside a contact at {t1}: {pen}");
        solver
            .continue_run(&s, &end, t_end, &mut parts)
            .unwrap_or_else(|e| panic!("{friction}: {e}"));
        let amp = whole.u.iter().map(|u| u.abs()).fold(0.0, f64::max);
        let d = max_diff(&whole.u, &parts.u);
        println!(
            "{friction}: stopped at {t1:.5e} s with {pen:.3e} m penetration: max |Δu| {d:.3e} m \
             of {amp:.3e} m; contacts {} vs {}",
            parts.releases, whole.releases
        );
        assert!(whole.releases >= 5, "{}", whole.releases);
        assert_eq!(parts.releases, whole.releases, "{friction}");
        assert!(d < 1e-6 * amp, "{friction}: {d} of {amp}");
    }
}
