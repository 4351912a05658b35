//! The bar that bends in two planes, on its reference solver (RK4 with located events and a
//! resting mode), against closed forms and against the one-plane exact solver.

use vibrobar_core::params::two_plane::{
    Gravity, Hole, PlanarBall, PlanarBar, PlanarForcing, TwoPlaneBar, TwoPlaneSystem,
};
use vibrobar_core::solver::exact::modal::ModalExact;
use vibrobar_core::solver::two_plane_exact::{self, TwoPlaneExact};
use vibrobar_core::solver::two_plane_rk4::{
    HoleWall, Sampling, TwoPlaneEvent, TwoPlaneEventKind, TwoPlaneRk4, TwoPlaneSample,
    TwoPlaneStart, WallMotion,
};
use vibrobar_core::solver::{Event, EventKind, Exact, Observer, Solver, Wall};
use vibrobar_core::*;

const R_BALL: f64 = 0.0075;

/// The paper's bar in both planes with its 15 mm ball on frictionless walls.
fn paper(
    gap_m: f64,
    c_r_m: f64,
    hole_deg: f64,
    force_deg: f64,
    ratio: f64,
    g: f64,
) -> TwoPlaneSystem {
    TwoPlaneSystem {
        bar: PlanarBar::isotropic(&Bar::PAPER_CAVITY).into(),
        ball: PlanarBall::paper_frictionless(),
        hole: Hole {
            angle_deg: hole_deg,
            axial_gap_m: gap_m,
            diameter_m: Hole::diameter_for_clearance_m(R_BALL, c_r_m),
        },
        forcing: PlanarForcing {
            amplitude_n: 15.0,
            frequency: Frequency::Ratio(ratio),
            angle_deg: force_deg,
        },
        gravity: Gravity {
            m_s2: g,
            angle_deg: 90.0,
        },
        bar_diameter_m: None,
    }
}

fn settings(duration_s: f64) -> RunSettings {
    RunSettings {
        duration_s,
        dt_s: 1e-6,
        rms_fraction: 0.8,
    }
}

fn run2(
    sys: &TwoPlaneSystem,
    start: &TwoPlaneStart,
    dur: f64,
) -> (
    Vec<TwoPlaneEvent>,
    vibrobar_core::solver::two_plane_rk4::TwoPlaneSummary,
) {
    let mut evs = Vec::new();
    let s = TwoPlaneRk4::default()
        .run(sys, start, &settings(dur), &mut |e| evs.push(*e))
        .unwrap();
    (evs, s)
}

#[derive(Default)]
struct Impacts(Vec<Event>);
impl Observer for Impacts {
    fn event(&mut self, ev: &Event) {
        if matches!(ev.kind, EventKind::Impact { .. }) {
            self.0.push(*ev);
        }
    }
}

/// The one-plane exact run of the paper's bar with force amplitude `f0`, gap `gap_m`, at `Ω`.
fn one_plane(f0: f64, gap_m: f64, omega: f64, dur: f64) -> Vec<Event> {
    let sys = System {
        bar: Bar::PAPER_CAVITY.into(),
        damper: Some(Damper::paper(gap_m, FrictionModel::None)),
        forcing: Forcing {
            amplitude_n: f0,
            frequency: Frequency::RadPerS(omega),
            static_force_n: 0.0,
        },
        gravity_m_s2: STANDARD_GRAVITY_M_S2,
    };
    let mut rec = Impacts::default();
    Exact::default()
        .run(&sys, &State::REST, dur, &mut rec)
        .unwrap();
    rec.0
}

/// Impact times at the walls of one axis, with their sign.
fn impacts_on(evs: &[TwoPlaneEvent], axis: usize) -> Vec<(f64, f64)> {
    evs.iter()
        .filter_map(|e| match e.kind {
            TwoPlaneEventKind::Impact { wall, .. } if wall.axis() == axis => {
                Some((e.t_s, wall.sign()))
            }
            _ => None,
        })
        .collect()
}

fn assert_same_impacts(two: &[(f64, f64)], one: &[Event], tol_s: f64, what: &str) {
    assert!(!one.is_empty(), "{what}: the one-plane run has no impact");
    assert_eq!(two.len(), one.len(), "{what}: impact counts differ");
    for ((t2, s2), e) in two.iter().zip(one) {
        let EventKind::Impact { wall, .. } = e.kind else {
            unreachable!()
        };
        let s1 = if wall == Wall::Plus { 1.0 } else { -1.0 };
        assert!(
            (t2 - e.t_s).abs() < tol_s,
            "{what}: impact at {t2} s against {} s",
            e.t_s
        );
        assert!(s1 * s2 > 0.0, "{what}: different walls at {t2} s");
    }
}

use vibrobar_core::params::STANDARD_GRAVITY_M_S2;

#[test]
fn force_along_the_hole_is_the_one_plane_model() {
    // No gravity, the ball centred: nothing moves across the hole.
    let sys = paper(0.1e-3, 0.05e-3, 0.0, 0.0, 1.0, 0.0);
    let dur = 0.06;
    let (evs, s) = run2(&sys, &TwoPlaneStart::at_rest([0.0; 2]), dur);
    assert_eq!(s.impacts[2] + s.impacts[3], 0);
    let one = one_plane(15.0, 0.1e-3, sys.omega_rad_s(), dur);
    assert_same_impacts(&impacts_on(&evs, 0), &one, 1e-10, "along the hole");
}

#[test]
fn frictionless_planes_decouple_on_a_round_bar() {
    // Force at 30° to the hole, no gravity: along the hole the one-plane run with F0 cos 30° and
    // the axial gap, across it the one with F0 sin 30° and the radial clearance.
    let (gap, c_r) = (0.1e-3, 0.02e-3);
    for hole_deg in [0.0, 40.0] {
        let sys = paper(gap, c_r, hole_deg, hole_deg + 30.0, 1.0, 0.0);
        let dur = 0.06;
        let (evs, _) = run2(&sys, &TwoPlaneStart::at_rest([0.0; 2]), dur);
        let om = sys.omega_rad_s();
        let along = one_plane(15.0 * 30f64.to_radians().cos(), gap, om, dur);
        let across = one_plane(15.0 * 30f64.to_radians().sin(), 2.0 * c_r, om, dur);
        assert_same_impacts(&impacts_on(&evs, 0), &along, 1e-10, "along");
        assert_same_impacts(&impacts_on(&evs, 1), &across, 1e-10, "across");
    }
}

#[test]
fn frictionless_answers_depend_on_the_force_angle_minus_the_hole_angle() {
    let base = paper(1.0e-3, 0.05e-3, 0.0, 63.4, 1.0, 9.80665);
    let mut turned = paper(1.0e-3, 0.05e-3, 25.0, 88.4, 1.0, 9.80665);
    turned.gravity.angle_deg += 25.0;
    let start = TwoPlaneStart::resting(&base, 0.0);
    let start_t = TwoPlaneStart::resting(&turned, 0.0);
    assert_eq!(start.w_hole_m, start_t.w_hole_m);
    // Over the first 60 ms: the same events at the same times, and the same RMS. The turned
    // run differs by rounding (1e-16 in every projection), which this impacting motion
    // amplifies to about 1e-10 s by the 60th ms; by 0.3 s the two runs have parted.
    let (ea, a) = run2(&base, &start, 0.06);
    let (eb, b) = run2(&turned, &start_t, 0.06);
    assert!(ea.len() > 20, "{}", ea.len());
    assert_eq!(a.impacts, b.impacts);
    same_events(&ea, &eb, |w| w, 1e-8);
    let rel = (a.rms_along_force_m - b.rms_along_force_m).abs() / a.rms_along_force_m;
    assert!(rel < 1e-7, "rms along the force differs by {rel:e}");
    assert!((a.rms_total_m - b.rms_total_m).abs() / a.rms_total_m < 1e-7);
}

/// The same events (walls mapped by `map`) at the same times.
fn same_events(
    a: &[TwoPlaneEvent],
    b: &[TwoPlaneEvent],
    map: impl Fn(HoleWall) -> HoleWall,
    tol_s: f64,
) {
    assert_eq!(a.len(), b.len());
    let wall = |k: &TwoPlaneEventKind| match *k {
        TwoPlaneEventKind::Impact { wall, .. }
        | TwoPlaneEventKind::Rest { wall, .. }
        | TwoPlaneEventKind::LiftOff { wall }
        | TwoPlaneEventKind::Motion { wall, .. } => wall,
    };
    for (x, y) in a.iter().zip(b) {
        assert!((x.t_s - y.t_s).abs() < tol_s, "{x:?} against {y:?}");
        assert_eq!(map(wall(&x.kind)), wall(&y.kind), "{x:?} against {y:?}");
        assert_eq!(
            std::mem::discriminant(&x.kind),
            std::mem::discriminant(&y.kind)
        );
    }
}

#[test]
fn mirrored_clearances_and_force_give_the_same_answer() {
    // Zero gravity, no friction, a round bar: the force at θ with (l_g, c_r) equals the force at
    // 90° − θ with (c_r, l_g).
    let (l_g, c_r, theta) = (0.06e-3, 0.02e-3, 25.0);
    let a = paper(2.0 * l_g, c_r, 0.0, theta, 1.0, 0.0);
    let b = paper(2.0 * c_r, l_g, 0.0, 90.0 - theta, 1.0, 0.0);
    let (ea, ra) = run2(&a, &TwoPlaneStart::at_rest([0.0; 2]), 0.06);
    let (eb, rb) = run2(&b, &TwoPlaneStart::at_rest([0.0; 2]), 0.06);
    assert!(ea.len() > 20, "{}", ea.len());
    // Reflecting about the 45° line swaps the hole's axes: the plugs become the hole's wall.
    let swap = |w: HoleWall| match w {
        HoleWall::AxialPlus => HoleWall::AcrossPlus,
        HoleWall::AxialMinus => HoleWall::AcrossMinus,
        HoleWall::AcrossPlus => HoleWall::AxialPlus,
        HoleWall::AcrossMinus => HoleWall::AxialMinus,
    };
    same_events(&ea, &eb, swap, 1e-10);
    let rel = (ra.rms_along_force_m - rb.rms_along_force_m).abs() / ra.rms_along_force_m;
    assert!(rel < 1e-9, "{rel:e}");
    assert!((ra.rms_m[0] - rb.rms_m[1]).abs() / ra.rms_m[0] < 1e-9);
}

#[test]
fn a_dropped_ball_falls_as_a_parabola() {
    // Gravity along the hole, no force: the bar stays at rest until the ball lands.
    let mut sys = paper(1.0e-3, 0.05e-3, 0.0, 0.0, 1.0, 9.80665);
    sys.gravity.angle_deg = 0.0;
    sys.forcing.amplitude_n = 0.0;
    let (evs, s) = run2(&sys, &TwoPlaneStart::at_rest([0.0, 0.0]), 0.05);
    let TwoPlaneEventKind::Impact {
        wall, approach_m_s, ..
    } = evs[0].kind
    else {
        panic!("{:?}", evs[0])
    };
    let (g, l_g): (f64, f64) = (9.80665, 0.5e-3);
    assert_eq!(wall, HoleWall::AxialPlus);
    assert!(
        (evs[0].t_s - (2.0 * l_g / g).sqrt()).abs() < 1e-14,
        "{}",
        evs[0].t_s
    );
    assert!((approach_m_s - (2.0 * g * l_g).sqrt()).abs() < 1e-12);
    // e = 0.5: the bounces end with the ball resting on the plug.
    assert!(evs.iter().any(|e| matches!(
        e.kind,
        TwoPlaneEventKind::Rest {
            wall: HoleWall::AxialPlus,
            ..
        }
    )));
    // The landing's impulse shakes the bar harder than g, so the ball lifts off again.
    assert!(
        s.rest_fraction(HoleWall::AxialPlus) > 0.0,
        "{:?}",
        s.contact_fraction
    );
}

/// The steady state of the bar carrying the resting ball across the hole (gravity at 90°, the
/// hole at 0°, the force across it): `(u_y, u̇_y)` at `t = 0` and the acceleration amplitude.
fn carried_steady_state(sys: &TwoPlaneSystem) -> ([f64; 2], f64) {
    let b = *sys.bar.lumped().unwrap();
    let (m, k) = (b.mass_kg + sys.ball.mass_kg, b.stiffness_n_per_m[0]);
    let c = 2.0 * b.damping_ratio[0] * (k * b.mass_kg).sqrt();
    let om = sys.omega_rad_s();
    let (re, im) = (k - m * om * om, c * om);
    let mag = sys.forcing.amplitude_n / (re * re + im * im).sqrt();
    let phi = im.atan2(re);
    let stat = sys.ball.mass_kg * sys.gravity.m_s2 / k;
    // u = stat + X sin(Ωt − φ).
    (
        [stat - mag * phi.sin(), mag * om * phi.cos()],
        mag * om * om,
    )
}

#[test]
fn the_ball_lifts_off_where_the_cavity_accelerates_away_faster_than_g() {
    let mut sys = paper(1.0e-3, 0.05e-3, 0.0, 90.0, 1.0, 9.80665);
    let (_, acc1) = carried_steady_state(&sys);
    let threshold_n = sys.forcing.amplitude_n * 9.80665 / acc1;
    for (scale, lifts) in [(0.95, false), (1.05, true)] {
        sys.forcing.amplitude_n = scale * threshold_n;
        let ([u, du], _) = carried_steady_state(&sys);
        let start = TwoPlaneStart {
            u_m: [0.0, u],
            du_m_s: [0.0, du],
            ..TwoPlaneStart::resting(&sys, 0.0)
        };
        assert!(start.w_hole_m[0] == 0.0 && (start.w_hole_m[1] - 0.05e-3).abs() < 1e-18);
        let (evs, s) = run2(&sys, &start, 0.1);
        let first_lift = evs
            .iter()
            .find(|e| matches!(e.kind, TwoPlaneEventKind::LiftOff { .. }));
        assert_eq!(
            first_lift.is_some(),
            lifts,
            "scale {scale}: {:?}",
            evs.first()
        );
        if !lifts {
            // Carried all along: the response is the linear one of M + m_d.
            assert!(evs.is_empty());
            assert!(s.rest_fraction(HoleWall::AcrossPlus) > 0.999_999);
        } else {
            // At lift-off the cavity's acceleration across the hole equals g: run to the event
            // and read the bar's force there (a resting ball leaves when f_y/M reaches g).
            let t_ev = first_lift.unwrap().t_s;
            let (_, s) = run2(&sys, &start, t_ev);
            let (kk, cc) = sys.bar.lumped_mut().unwrap().matrices();
            let fy = sys.forcing.amplitude_n * (sys.omega_rad_s() * t_ev).sin()
                - cc[1][1] * s.end.du_m_s[1]
                - kk[1][1] * s.end.u_m[1];
            let acc = fy / sys.bar.lumped_mut().unwrap().mass_kg;
            assert!((acc - 9.80665).abs() < 1e-6 * 9.80665, "{acc}");
        }
    }
}

#[test]
fn a_carried_ball_adds_its_mass_to_the_bar() {
    // Force across the hole below the lift-off threshold: the bar carries the ball, and its RMS
    // is that of the linear bar of mass M + m_d about its static offset.
    let mut sys = paper(1.0e-3, 0.05e-3, 0.0, 90.0, 1.0, 9.80665);
    sys.forcing.amplitude_n = 0.2;
    let ([u, du], acc) = carried_steady_state(&sys);
    assert!(acc < 9.80665);
    let start = TwoPlaneStart {
        u_m: [0.0, u],
        du_m_s: [0.0, du],
        ..TwoPlaneStart::resting(&sys, 0.0)
    };
    let (evs, s) = run2(&sys, &start, 0.2);
    assert!(evs.is_empty());
    let om = sys.omega_rad_s();
    let stat = sys.ball.mass_kg * 9.80665 / sys.bar.lumped_mut().unwrap().stiffness_n_per_m[0];
    let amp = acc / (om * om);
    // Over whole periods RMS² = stat² + amp²/2; the window is 0.16 s, 0.16·Ω/2π periods.
    let periods = 0.16 * om / (2.0 * std::f64::consts::PI);
    let want = (stat * stat + 0.5 * amp * amp).sqrt();
    let tol = amp * amp / periods; // the partial period's share, an upper bound
    assert!(
        (s.rms_m[1] * s.rms_m[1] - want * want).abs() < tol,
        "{} against {want}",
        s.rms_m[1]
    );
    assert!(s.rms_m[0] < 1e-15);
}

#[test]
fn books_close_and_the_ball_stays_inside_over_a_long_run() {
    // Force at 63.4° to a radial hole, gravity at 90°, the 15.1 mm hole and the 1 mm gap.
    let sys = paper(1.0e-3, 0.05e-3, 0.0, 63.4, 1.0, 9.80665);
    let (evs, s) = run2(&sys, &TwoPlaneStart::resting(&sys, 0.0), 0.5);
    assert!(evs.len() > 100, "{} events", evs.len());
    let b = s.book;
    assert!(
        b.residual_j().abs() < 1e-8 * b.forcing_work_j.abs(),
        "{b:?}, residual {:e}",
        b.residual_j()
    );
    assert!(s.max_penetration_m <= 1e-12, "{}", s.max_penetration_m);
    assert!(s.end.w_hole_m[0].abs() <= 0.5e-3 + 1e-12);
    assert!(s.end.w_hole_m[1].abs() <= 0.05e-3 + 1e-12);
    let total: f64 = s.flight_fraction
        + HoleWall::ALL
            .iter()
            .map(|&w| s.rest_fraction(w))
            .sum::<f64>();
    assert!(total >= 1.0 - 1e-9, "{total}");
}

#[test]
fn bad_input_names_the_field() {
    let good = paper(1.0e-3, 0.05e-3, 0.0, 63.4, 1.0, 9.80665);
    assert!(good.validate().is_ok());
    let err = |f: &dyn Fn(&mut TwoPlaneSystem)| {
        let mut s = good;
        f(&mut s);
        s.validate().unwrap_err().to_string()
    };
    assert!(err(&|s| s.hole.diameter_m = 0.012).contains("hole.diameter_m"));
    assert!(err(&|s| {
        s.bar_diameter_m = Some(0.016);
    })
    .contains("bar_diameter_m"));
    assert!(err(&|s| {
        s.bar_diameter_m = Some(0.0155);
        s.hole.diameter_m = 0.0151;
    })
    .contains("must fit across bar_diameter_m"));
    assert!(err(&|s| s.hole.angle_deg = f64::NAN).contains("hole.angle_deg"));
    assert!(err(&|s| s.forcing.angle_deg = f64::INFINITY).contains("forcing.angle_deg"));
    assert!(err(&|s| s.gravity.angle_deg = f64::NAN).contains("gravity.angle_deg"));
    assert!(err(&|s| s.gravity.m_s2 = f64::NAN).contains("gravity.m_s2"));
    assert!(err(&|s| s.hole.axial_gap_m = -1e-4).contains("hole.axial_gap_m"));
    assert!(err(&|s| s.ball.friction_static = -0.1).contains("ball.friction_static"));
    assert!(err(&|s| s.ball.friction_static = 1.0).contains("[0, 1)"));
    assert!(err(&|s| {
        s.ball.friction_static = 0.2;
        s.ball.friction_kinetic = 0.3;
    })
    .contains("ball.friction_kinetic"));
    // A start outside the box.
    let e = TwoPlaneRk4::default()
        .run(
            &good,
            &TwoPlaneStart::at_rest([0.6e-3, 0.0]),
            &settings(0.01),
            &mut |_| {},
        )
        .unwrap_err();
    assert!(e.to_string().contains("start.w_hole_m[0]"), "{e}");
}

/// The paper's ball with friction on the walls.
fn frictional(mut sys: TwoPlaneSystem, mu_s: f64, mu_k: f64, eta: f64) -> TwoPlaneSystem {
    sys.ball.friction_static = mu_s;
    sys.ball.friction_kinetic = mu_k;
    sys.ball.rolling_friction_m = eta;
    sys
}

/// A bar so heavy it does not move: 1e9 kg at 100 rad/s, no force.
fn fixed_wall(gap_m: f64, mu_s: f64, mu_k: f64, eta: f64) -> TwoPlaneSystem {
    let mut sys = paper(gap_m, 0.05e-3, 0.0, 0.0, 1.0, 9.80665);
    sys.bar = TwoPlaneBar::from(PlanarBar::isotropic(&Bar {
        mass_kg: 1e9,
        stiffness_n_per_m: 1e13,
        damping_ratio: 0.01,
    }));
    sys.forcing.amplitude_n = 0.0;
    frictional(sys, mu_s, mu_k, eta)
}

fn first_motion(evs: &[TwoPlaneEvent], motion: WallMotion) -> Option<f64> {
    evs.iter().find_map(|e| match e.kind {
        TwoPlaneEventKind::Motion { motion: m, .. } if m == motion => Some(e.t_s),
        _ => None,
    })
}

#[test]
fn a_ball_launched_sliding_rolls_after_2v0_over_7_mu_g_at_five_sevenths() {
    let (mu_k, v0, g) = (0.2, 0.05, 9.80665);
    let sys = fixed_wall(20e-3, 0.3, mu_k, 0.0);
    let start = TwoPlaneStart {
        dw_hole_m_s: [v0, 0.0],
        ..TwoPlaneStart::resting(&sys, 0.0)
    };
    let (evs, _) = run2(&sys, &start, 0.02);
    let t_roll = first_motion(&evs, WallMotion::Rolling).expect("the ball starts to roll");
    let want = 2.0 * v0 / (7.0 * mu_k * g);
    assert!(
        (t_roll - want).abs() < 1e-9 * want,
        "{t_roll} against {want}"
    );
    let (_, s) = run2(&sys, &start, t_roll);
    let v = s.end.dw_hole_m_s[0];
    assert!((v - 5.0 / 7.0 * v0).abs() < 1e-9 * v0, "{v}");
    // Rolling without resistance keeps that speed.
    let (_, s) = run2(&sys, &start, 0.02);
    assert!((s.end.dw_hole_m_s[0] - 5.0 / 7.0 * v0).abs() < 1e-9 * v0);
    assert!((s.end.spin_rad_s * R_BALL - 5.0 / 7.0 * v0).abs() < 1e-9 * v0);
}

#[test]
fn rolling_resistance_stops_a_rolling_ball_after_7rv0_over_5_eta_g() {
    let (eta, v0, g) = (0.6e-3, 0.01, 9.80665);
    let sys = fixed_wall(20e-3, 0.3, 0.2, eta);
    // Rolling without slip: σ = (ḃ − u̇)·t + rω = −v0 + rω = 0 on the wall at +n.
    let start = TwoPlaneStart {
        dw_hole_m_s: [v0, 0.0],
        spin_rad_s: v0 / R_BALL,
        ..TwoPlaneStart::resting(&sys, 0.0)
    };
    let (evs, s) = run2(&sys, &start, 0.03);
    let t_stop = first_motion(&evs, WallMotion::Stuck).expect("the ball stops");
    let want = 7.0 * R_BALL * v0 / (5.0 * eta * g);
    assert!(
        (t_stop - want).abs() < 1e-9 * want,
        "{t_stop} against {want}"
    );
    // Distance rolled: v0²/(2a) with a = (5/7)(η/r) g.
    let a = 5.0 / 7.0 * eta / R_BALL * g;
    let x = s.end.w_hole_m[0];
    assert!((x - v0 * v0 / (2.0 * a)).abs() < 1e-9 * x, "{x}");
    assert!(s.end.dw_hole_m_s[0].abs() < 1e-15 && s.end.spin_rad_s.abs() < 1e-12);
    // The rolling loss is the kinetic energy the ball had, translation and spin.
    let ke = 0.5 * 0.026 * v0 * v0 * (1.0 + 0.4);
    assert!(
        (s.book.rolling_loss_j - ke).abs() < 1e-9 * ke,
        "{:?}",
        s.book
    );
}

/// A bar driven along the hole with the ball resting (rolling) on the hole's wall, gravity
/// across: its steady state along x as a bar of mass `M + extra` and the static offset across.
fn rolling_start(sys: &TwoPlaneSystem, extra_kg: f64) -> (TwoPlaneStart, f64) {
    let b = *sys.bar.lumped().unwrap();
    let (m, k) = (b.mass_kg + extra_kg, b.stiffness_n_per_m[0]);
    let c = 2.0 * b.damping_ratio[0] * (k * b.mass_kg).sqrt();
    let om = sys.omega_rad_s();
    let (re, im) = (k - m * om * om, c * om);
    let mag = sys.forcing.amplitude_n / (re * re + im * im).sqrt();
    let phi = im.atan2(re);
    let stat = sys.ball.mass_kg * sys.gravity.m_s2 / k;
    let start = TwoPlaneStart {
        u_m: [-mag * phi.sin(), stat],
        du_m_s: [mag * om * phi.cos(), 0.0],
        ..TwoPlaneStart::resting(sys, 0.0)
    };
    (start, mag * om * om)
}

#[test]
fn a_rolling_ball_lags_the_wall_by_five_sevenths_and_loads_the_bar_with_two_sevenths() {
    let (mu_s, g, md) = (0.3, 9.80665, 0.026);
    let mut sys = frictional(paper(1.0e-3, 0.05e-3, 0.0, 0.0, 0.98, g), mu_s, 0.2, 0.0);
    let extra = 2.0 / 7.0 * md;
    sys.forcing.amplitude_n = 0.1;
    let (start, acc) = rolling_start(&sys, extra);
    assert!(acc < 3.5 * mu_s * g);
    let dur = 0.01;
    let (evs, s) = run2(&sys, &start, dur);
    assert!(evs.is_empty(), "{:?}", evs.first());
    assert!(
        s.contact_fraction[HoleWall::AcrossPlus as usize][WallMotion::Rolling as usize] > 0.999_999
    );
    // The ball moves along the wall by −5/7 of the bar's motion beyond its start's drift.
    let du0 = start.du_m_s[0];
    let u_rel = s.end.u_m[0] - start.u_m[0] - du0 * dur;
    let w = s.end.w_hole_m[0];
    assert!(
        (w + 5.0 / 7.0 * u_rel).abs() < 1e-9 * u_rel.abs(),
        "{w} against {u_rel}"
    );
    // The bar stays on the steady state of mass M + 2/7 m_d: the end matches it (the steady
    // state's start shifted by `dur` is its state at the end).
    let mag = acc / sys.omega_rad_s().powi(2);
    let shift = sys.omega_rad_s() * dur;
    let (u0, v0) = (start.u_m[0], start.du_m_s[0] / sys.omega_rad_s());
    let u_end = u0 * shift.cos() + v0 * shift.sin();
    assert!(
        (s.end.u_m[0] - u_end).abs() < 1e-8 * mag,
        "{} against {u_end}",
        s.end.u_m[0]
    );
    // Across, the bar carries the resting ball's weight, still at its static offset.
    let stat = md * g / sys.bar.lumped_mut().unwrap().stiffness_n_per_m[1];
    assert!(
        (s.end.u_m[1] - stat).abs() < 1e-9 * stat,
        "{}",
        s.end.u_m[1]
    );
}

#[test]
fn the_ball_slides_where_the_wall_accelerates_at_seven_halves_mu_g() {
    let (mu_s, g, md) = (0.3, 9.80665, 0.026);
    let mut sys = frictional(paper(1.0e-3, 0.05e-3, 0.0, 0.0, 0.98, g), mu_s, 0.2, 0.0);
    let extra = 2.0 / 7.0 * md;
    sys.forcing.amplitude_n = 1.0;
    let (_, acc1) = rolling_start(&sys, extra);
    let threshold_n = 3.5 * mu_s * g / acc1;
    for (scale, slides) in [(0.97, false), (1.03, true)] {
        sys.forcing.amplitude_n = scale * threshold_n;
        let (start, _) = rolling_start(&sys, extra);
        let (evs, _) = run2(&sys, &start, 0.01);
        let t = first_motion(&evs, WallMotion::Sliding);
        assert_eq!(t.is_some(), slides, "scale {scale}: {:?}", evs.first());
        if let Some(t) = t {
            let (_, s) = run2(&sys, &start, t);
            let (kk, cc) = sys.bar.lumped_mut().unwrap().matrices();
            let fx = sys.forcing.amplitude_n * (sys.omega_rad_s() * t).sin()
                - cc[0][0] * s.end.du_m_s[0]
                - kk[0][0] * s.end.u_m[0];
            let acc = fx / (sys.bar.lumped_mut().unwrap().mass_kg + extra);
            assert!((acc.abs() - 3.5 * mu_s * g).abs() < 1e-6 * g, "{acc}");
        }
    }
}

#[test]
fn books_close_with_friction_and_spin() {
    let sys = frictional(
        paper(1.0e-3, 0.05e-3, 0.0, 63.4, 1.0, 9.80665),
        0.3,
        0.2,
        0.6e-3,
    );
    let (evs, s) = run2(&sys, &TwoPlaneStart::resting(&sys, 0.0), 0.3);
    assert!(evs.len() > 100, "{} events", evs.len());
    let b = s.book;
    assert!(b.sliding_loss_j > 0.0 && b.rolling_loss_j >= 0.0, "{b:?}");
    assert!(
        b.residual_j().abs() < 1e-8 * b.forcing_work_j.abs(),
        "{b:?}, residual {:e}",
        b.residual_j()
    );
    assert!(s.max_penetration_m <= 1e-12, "{}", s.max_penetration_m);
}

/// Every event of a one-plane exact run.
#[derive(Default)]
struct AllEvents(Vec<Event>);
impl Observer for AllEvents {
    fn event(&mut self, ev: &Event) {
        self.0.push(*ev);
    }
}

#[test]
fn the_plane_across_the_hole_is_the_one_plane_model_with_gravity_on_the_ball() {
    // Frictionless walls, a round bar, gravity across the hole: the plane across it is the
    // one-plane run with the force's component across, the radial clearance, and gravity as a
    // body force on the ball along its slot; the ball starts resting on the wall gravity presses
    // it onto.
    let (gap, c_r, g) = (0.04e-3, 0.02e-3, 9.80665);
    let sys = paper(gap, c_r, 0.0, 60.0, 1.0, g);
    let dur = 0.06;
    let start = TwoPlaneStart::resting(&sys, 0.0);
    let (evs, _) = run2(&sys, &start, dur);
    let one = System {
        bar: Bar::PAPER_CAVITY.into(),
        damper: Some(Damper {
            gravity_along_gap_m_s2: g,
            ..Damper::paper(2.0 * c_r, FrictionModel::None)
        }),
        forcing: Forcing {
            amplitude_n: 15.0 * 60f64.to_radians().sin(),
            frequency: Frequency::RadPerS(sys.omega_rad_s()),
            static_force_n: 0.0,
        },
        gravity_m_s2: g,
    };
    let init = State {
        v_m: c_r,
        ..State::REST
    };
    let mut rec = AllEvents::default();
    Exact::default().run(&one, &init, dur, &mut rec).unwrap();
    // The releases from the wall: the two-plane lift-offs.
    let lifts: Vec<f64> = evs
        .iter()
        .filter(|e| matches!(e.kind, TwoPlaneEventKind::LiftOff { wall } if wall.axis() == 1))
        .map(|e| e.t_s)
        .collect();
    let releases: Vec<f64> = rec
        .0
        .iter()
        .filter(|e| matches!(e.kind, EventKind::ContactRelease { .. }))
        .map(|e| e.t_s)
        .collect();
    assert!(lifts.len() >= 2, "{} lift-offs", lifts.len());
    assert_eq!(lifts.len(), releases.len());
    for (a, b) in lifts.iter().zip(&releases) {
        assert!(
            (a - b).abs() < 1e-9,
            "lift-off at {a} s against release at {b} s"
        );
    }
    // The impacts that matter (the two solvers sum a bounce sequence to its end at different
    // depths: below one step here, below 1e-10 of the gap there).
    let big2: Vec<f64> = evs
        .iter()
        .filter_map(|e| match e.kind {
            TwoPlaneEventKind::Impact {
                wall, approach_m_s, ..
            } if wall.axis() == 1 && approach_m_s > 0.01 => Some(e.t_s),
            _ => None,
        })
        .collect();
    let big1: Vec<f64> = rec
        .0
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::Impact { dw_m_s, .. } if dw_m_s.abs() > 0.01 => Some(e.t_s),
            _ => None,
        })
        .collect();
    assert!(big2.len() >= 3, "{} impacts", big2.len());
    assert_eq!(big2.len(), big1.len());
    for (a, b) in big2.iter().zip(&big1) {
        assert!((a - b).abs() < 1e-9, "impact at {a} s against {b} s");
    }
    // And along the hole, the one-plane run without gravity.
    let along = one_plane(15.0 * 60f64.to_radians().cos(), gap, sys.omega_rad_s(), dur);
    assert_same_impacts(&impacts_on(&evs, 0), &along, 1e-10, "along");
}

#[test]
fn an_anisotropic_bar_responds_along_its_principal_axes() {
    // A ball that never touches a wall (no gravity, 20 mm of clearance each way, centred): the
    // bar alone, with 600 and 618 Hz-like principal stiffnesses at 20°. Its steady response along
    // x is the sum over the principal axes of the force's projection times each axis' receptance.
    let mut sys = paper(20e-3, 10e-3, 0.0, 65.0, 1.0, 0.0);
    sys.bar.lumped_mut().unwrap().stiffness_n_per_m = [9.22e6, 9.22e6 * (618.0f64 / 600.0).powi(2)];
    sys.bar.lumped_mut().unwrap().damping_ratio = [0.01, 0.02];
    sys.bar.lumped_mut().unwrap().principal_axis_deg = 20.0;
    let (_, s) = run2(&sys, &TwoPlaneStart::at_rest([0.0; 2]), 2.0);
    assert_eq!(s.impacts, [0; 4]);
    let om = sys.omega_rad_s();
    let m = sys.bar.lumped_mut().unwrap().mass_kg;
    let f = 15.0;
    let (mut ux, mut uy) = ((0.0, 0.0), (0.0, 0.0));
    for i in 0..2 {
        let ang = (20.0 + 90.0 * i as f64).to_radians();
        let p = [ang.cos(), ang.sin()];
        let k = sys.bar.lumped_mut().unwrap().stiffness_n_per_m[i];
        let c = 2.0 * sys.bar.lumped_mut().unwrap().damping_ratio[i] * (k * m).sqrt();
        // Receptance 1/(k − mΩ² + icΩ).
        let (re, im) = (k - m * om * om, c * om);
        let h = (re / (re * re + im * im), -im / (re * re + im * im));
        let fp = f * (p[0] * 65f64.to_radians().cos() + p[1] * 65f64.to_radians().sin());
        ux = (ux.0 + p[0] * fp * h.0, ux.1 + p[0] * fp * h.1);
        uy = (uy.0 + p[1] * fp * h.0, uy.1 + p[1] * fp * h.1);
    }
    // RMS of a harmonic of complex amplitude z: |z|/√2 (over the 1.6 s window, about 1000
    // periods; the partial period's share is below 1e-4 here).
    let rms = |z: (f64, f64)| ((z.0 * z.0 + z.1 * z.1) / 2.0).sqrt();
    for (got, want) in [(s.rms_m[0], rms(ux)), (s.rms_m[1], rms(uy))] {
        assert!((got - want).abs() < 1e-4 * want, "{got} against {want}");
    }
    // An isotropic bar would answer differently: the axes matter.
    let mut iso = sys;
    iso.bar.lumped_mut().unwrap().stiffness_n_per_m = [9.22e6; 2];
    iso.bar.lumped_mut().unwrap().damping_ratio = [0.01; 2];
    let (_, si) = run2(&iso, &TwoPlaneStart::at_rest([0.0; 2]), 2.0);
    assert!((si.rms_m[0] - s.rms_m[0]).abs() > 0.05 * s.rms_m[0]);
}

/// A run of the exact two-plane solver, its events checked to come in the order of time.
fn exact2(
    sys: &TwoPlaneSystem,
    start: &TwoPlaneStart,
    dur: f64,
) -> (
    Vec<TwoPlaneEvent>,
    vibrobar_core::solver::two_plane_rk4::TwoPlaneSummary,
) {
    let mut evs: Vec<TwoPlaneEvent> = Vec::new();
    let s = TwoPlaneExact::default()
        .run(sys, start, &settings(dur), &mut |e| evs.push(*e))
        .unwrap();
    assert!(
        evs.windows(2).all(|p| p[0].t_s <= p[1].t_s),
        "events out of order"
    );
    assert_eq!(s.events, evs.len() as u64);
    (evs, s)
}

fn close(a: f64, b: f64, rel: f64, what: &str) {
    assert!(
        (a - b).abs() <= rel * b.abs(),
        "{what}: {a:e} against {b:e} ({:.2e} relative)",
        (a / b - 1.0).abs()
    );
}

#[test]
fn the_exact_solver_is_the_reference_where_the_planes_decouple() {
    // Impacts in both planes (force at 30° to a hole at 40°, no gravity), and the ball pressed on
    // the hole's wall by gravity, lifting off and landing (force at 60°): the same impacts, RMS
    // values and rest fractions as the reference, books that close and no penetration.
    for (sys, start, rms_tol, rest_tol) in [
        {
            let s = paper(0.1e-3, 0.02e-3, 40.0, 70.0, 1.0, 0.0);
            (s, TwoPlaneStart::at_rest([0.0; 2]), 1e-7, 0.0)
        },
        {
            let s = paper(0.04e-3, 0.02e-3, 0.0, 60.0, 1.0, 9.80665);
            (s, TwoPlaneStart::resting(&s, 0.0), 1e-5, 5e-4)
        },
    ] {
        let dur = 0.06;
        let (evs, e) = exact2(&sys, &start, dur);
        let (ref_evs, r) = run2(&sys, &start, dur);
        for axis in 0..2 {
            let (a, b) = (impacts_on(&evs, axis), impacts_on(&ref_evs, axis));
            let big = |v: &[TwoPlaneEvent]| {
                v.iter()
                    .filter(|e| {
                        matches!(e.kind, TwoPlaneEventKind::Impact { wall, approach_m_s, .. }
                            if wall.axis() == axis && approach_m_s > 0.01)
                    })
                    .map(|e| e.t_s)
                    .collect::<Vec<_>>()
            };
            let (ba, bb) = (big(&evs), big(&ref_evs));
            assert!(!ba.is_empty() && !a.is_empty() && !b.is_empty());
            assert_eq!(
                ba.len(),
                bb.len(),
                "axis {axis}: impacts faster than 0.01 m/s"
            );
            for (x, y) in ba.iter().zip(&bb) {
                assert!(
                    (x - y).abs() < 1e-9,
                    "axis {axis}: impact at {x} s against {y} s"
                );
            }
        }
        close(
            e.rms_along_force_m,
            r.rms_along_force_m,
            rms_tol,
            "RMS along the force",
        );
        close(e.rms_m[0], r.rms_m[0], rms_tol, "RMS of u_x");
        close(e.rms_m[1], r.rms_m[1], rms_tol, "RMS of u_y");
        close(e.rms_total_m, r.rms_total_m, rms_tol, "RMS of |u|");
        for w in HoleWall::ALL {
            assert!(
                (e.rest_fraction(w) - r.rest_fraction(w)).abs() <= rest_tol,
                "{w:?}: rests {} against {}",
                e.rest_fraction(w),
                r.rest_fraction(w)
            );
        }
        assert!((e.flight_fraction - r.flight_fraction).abs() <= rest_tol);
        let b = e.book;
        assert!(b.residual_j().abs() < 1e-12 * b.forcing_work_j, "{b:?}");
        assert!(e.max_penetration_m <= 1e-12);
        close(
            b.forcing_work_j,
            r.book.forcing_work_j,
            1e-5,
            "forcing work",
        );
        close(b.impact_loss_j, r.book.impact_loss_j, 1e-4, "impact loss");
        for i in 0..2 {
            close(e.end.u_m[i], r.end.u_m[i], 1e-4, "u at the end");
        }
    }
}

#[test]
fn the_rms_along_the_force_carries_the_cross_term_of_the_planes() {
    // No wall touched (no gravity, a centred ball, wide clearances): the bar alone, whose steady
    // response along a force at 50° to the hole is the force's full amplitude through the
    // receptance, while the hole's planes see its cosine and sine. Without the cross term the
    // RMS along the force would be that of |u| projected wrongly; with it, the closed form.
    // 550 Hz: the window of 1.6 s holds 880 periods.
    let mut sys = paper(20e-3, 10e-3, 10.0, 60.0, 0.9, 0.0);
    sys.forcing.frequency = Frequency::RadPerS(2.0 * std::f64::consts::PI * 550.0);
    let dur = 2.0;
    let (evs, e) = exact2(&sys, &TwoPlaneStart::at_rest([0.0; 2]), dur);
    assert!(evs.is_empty());
    let bar = Bar::PAPER_CAVITY;
    let om = sys.omega_rad_s();
    let (m, k) = (bar.mass_kg, bar.stiffness_n_per_m);
    let c = 2.0 * bar.damping_ratio * (k * m).sqrt();
    let amp = 15.0 / ((k - m * om * om).powi(2) + (c * om).powi(2)).sqrt();
    // The transient has decayed by e^(−ζω·0.4 s) ≈ 3e-7 when the window opens.
    close(
        e.rms_along_force_m,
        amp / 2f64.sqrt(),
        1e-6,
        "RMS along the force",
    );
    close(e.rms_total_m, amp / 2f64.sqrt(), 1e-6, "RMS of |u|");
    let (_, r) = run2(&sys, &TwoPlaneStart::at_rest([0.0; 2]), dur);
    close(
        e.rms_along_force_m,
        r.rms_along_force_m,
        1e-9,
        "against the reference",
    );
    close(e.rms_m[0], r.rms_m[0], 1e-9, "u_x against the reference");
    close(e.rms_m[1], r.rms_m[1], 1e-9, "u_y against the reference");
}

#[test]
fn the_exact_solver_says_where_the_planes_do_not_decouple() {
    let base = paper(1.0e-3, 0.05e-3, 0.0, 63.4, 1.0, 9.80665);
    let start = TwoPlaneStart::resting(&base, 0.0);
    let refuse = |sys: TwoPlaneSystem, words: &str| {
        let err = TwoPlaneExact::default()
            .run(&sys, &start, &settings(0.01), &mut |_| {})
            .unwrap_err()
            .to_string();
        assert!(err.contains(words), "{err}");
        assert!(two_plane_exact::decoupled(&sys).is_err());
    };
    refuse(frictional(base, 0.3, 0.2, 0.0), "friction");
    let mut slanted = base;
    slanted.bar.lumped_mut().unwrap().stiffness_n_per_m[1] *= 1.1;
    slanted.bar.lumped_mut().unwrap().principal_axis_deg = 20.0;
    refuse(slanted, "principal axes");
    // Along and across the hole, an anisotropic bar decouples.
    let mut aligned = slanted;
    aligned.bar.lumped_mut().unwrap().principal_axis_deg = 90.0;
    assert!(two_plane_exact::decoupled(&aligned).is_ok());
    // Rolling resistance alone does not couple frictionless walls.
    assert!(two_plane_exact::decoupled(&frictional(base, 0.0, 0.0, 0.6e-3)).is_ok());
}

/// The paper's bar as a round beam of its modes (the default rule), with its ball.
fn round_beam(gap_m: f64, c_r_m: f64, force_deg: f64, ratio: f64, g: f64) -> TwoPlaneSystem {
    let mut sys = paper(gap_m, c_r_m, 0.0, force_deg, ratio, g);
    sys.bar = TwoPlaneBar::Round(
        vibrobar_core::structure::Beam::default()
            .modal_model()
            .unwrap(),
    );
    sys
}

#[test]
fn a_round_beam_far_from_the_walls_responds_through_its_receptance() {
    // No wall touched: the tip's steady RMS along the force is |F0·G_tip,force(Ω)|/√2 in any
    // direction of the force, and the planes' cross term puts it together.
    use vibrobar_core::structure::Point;
    let mut sys = round_beam(20e-3, 10e-3, 50.0, 1.0, 0.0);
    sys.forcing.frequency = Frequency::RadPerS(2.0 * std::f64::consts::PI * 550.0);
    let (evs, e) = exact2(&sys, &TwoPlaneStart::at_rest([0.0; 2]), 2.0);
    assert!(evs.is_empty());
    let TwoPlaneBar::Round(m) = sys.bar else {
        unreachable!()
    };
    let g = m.receptance(Point::Force, Point::Response, sys.omega_rad_s());
    let amp = 15.0 * g.norm();
    close(
        e.rms_along_force_m,
        amp / 2f64.sqrt(),
        1e-6,
        "RMS along the force",
    );
    close(e.rms_total_m, amp / 2f64.sqrt(), 1e-6, "RMS of |u|");
    assert!(m.len() >= 2, "{} modes", m.len());
}

#[test]
fn a_bar_of_one_mode_is_the_lumped_bar_in_two_planes() {
    // The one-mode model of the paper's lumped bar, with gravity, lift-off and impacts in both
    // planes: the same run as the lumped two-plane bar.
    let lumped = paper(0.1e-3, 0.05e-3, 0.0, 63.4, 1.0, 9.80665);
    let mut one_mode = lumped;
    one_mode.bar = TwoPlaneBar::Round(vibrobar_core::structure::ModalModel::lumped(
        &Bar::PAPER_CAVITY,
    ));
    let start = TwoPlaneStart::resting(&lumped, 0.0);
    // 60 ms: later the motion's sensitivity grows the rounding-level differences of the two
    // kernels beyond 1e-9 s.
    let (ea, a) = exact2(&lumped, &start, 0.06);
    let (eb, b) = exact2(&one_mode, &start, 0.06);
    assert!(a.impacts.iter().sum::<u64>() > 10, "{:?}", a.impacts);
    assert_eq!(ea.len(), eb.len());
    for (x, y) in ea.iter().zip(&eb) {
        assert!((x.t_s - y.t_s).abs() < 1e-9, "{x:?} against {y:?}");
    }
    close(
        b.rms_along_force_m,
        a.rms_along_force_m,
        1e-7,
        "RMS along the force",
    );
    close(b.rms_m[1], a.rms_m[1], 1e-7, "RMS of u_y");
    close(
        b.book.forcing_work_j,
        a.book.forcing_work_j,
        1e-7,
        "forcing work",
    );
    assert!(
        b.book.residual_j().abs() < 1e-10 * b.book.forcing_work_j,
        "{:?}",
        b.book
    );
    // The reference solver runs the lumped bar only, and says so.
    let err = TwoPlaneRk4::default()
        .run(&one_mode, &start, &settings(0.01), &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(err.contains("lumped bar only"), "{err}");
}

#[test]
fn a_round_beam_with_the_force_along_the_hole_is_the_one_plane_beam() {
    // No gravity, the ball centred: the plane across the hole stays still, and along it the
    // run is the one-plane beam's.
    let sys = round_beam(0.1e-3, 0.05e-3, 0.0, 1.0, 0.0);
    let start = TwoPlaneStart::at_rest([0.0; 2]);
    let dur = 0.2;
    let (_, e) = exact2(&sys, &start, dur);
    let one = vibrobar_core::analysis::two_plane::one_plane_system(&sys, FrictionModel::None);
    let rms = vibrobar_core::analysis::two_plane::one_plane_rms_m(
        &one,
        &vibrobar_core::analysis::two_plane::one_plane_start(&start),
        &settings(dur),
    )
    .unwrap();
    assert!(e.impacts[0] + e.impacts[1] > 0 && e.impacts[2] + e.impacts[3] == 0);
    close(e.rms_along_force_m, rms, 1e-9, "RMS along the force");
    assert!(e.rms_m[1] < 1e-15);
    // The end state's ball is relative to the cavity, not to the tip.
    assert!(e.end.w_hole_m[0].abs() <= 0.05e-3 + 1e-12, "{:?}", e.end);
}

/// A run of `solver` sampled every `interval_s`: its samples and summary.
fn sampled(
    sys: &TwoPlaneSystem,
    start: &TwoPlaneStart,
    dur: f64,
    interval_s: f64,
    method: vibrobar_core::analysis::two_plane::TwoPlaneMethod,
) -> (
    Vec<TwoPlaneSample>,
    vibrobar_core::solver::two_plane_rk4::TwoPlaneSummary,
) {
    let mut out = Vec::new();
    let mut on_sample = |s: &TwoPlaneSample| out.push(*s);
    let s = method
        .run_from(
            sys,
            start,
            0.0,
            &settings(dur),
            &mut |_| {},
            Some(Sampling {
                start_s: 0.0,
                interval_s,
                on_sample: &mut on_sample,
            }),
        )
        .unwrap();
    (out, s)
}

#[test]
fn sampled_runs_give_the_grid_and_agree_between_the_solvers() {
    // Impacts in both planes and the ball lifting off and landing on the hole's wall (the
    // cases of the exact-against-reference check), sampled every 20 µs over 60 ms.
    use vibrobar_core::analysis::two_plane::TwoPlaneMethod;
    for (sys, start) in [
        {
            let s = paper(0.1e-3, 0.02e-3, 40.0, 70.0, 1.0, 0.0);
            (s, TwoPlaneStart::at_rest([0.0; 2]))
        },
        {
            let s = paper(0.04e-3, 0.02e-3, 0.0, 60.0, 1.0, 9.80665);
            (s, TwoPlaneStart::resting(&s, 0.0))
        },
    ] {
        let (dur, dt) = (0.06, 20e-6);
        let (ex, e) = sampled(&sys, &start, dur, dt, TwoPlaneMethod::Exact);
        let (rk, r) = sampled(
            &sys,
            &start,
            dur,
            dt,
            TwoPlaneMethod::Reference { dt_s: 1e-6 },
        );
        // The grid from t = 0 to the end, whole, in both.
        assert_eq!(ex.len(), 3001);
        assert_eq!(rk.len(), 3001);
        for (k, (a, b)) in ex.iter().zip(&rk).enumerate() {
            assert!((a.t_s - k as f64 * dt).abs() < 1e-15, "{} at {k}", a.t_s);
            assert!((b.t_s - a.t_s).abs() < 1e-12, "{} against {}", b.t_s, a.t_s);
        }
        // Sampling changes nothing else.
        let (_, plain) = exact2(&sys, &start, dur);
        assert_eq!(
            e.rms_along_force_m.to_bits(),
            plain.rms_along_force_m.to_bits()
        );
        assert_eq!(e.impacts, plain.impacts);
        // The first sample is the start, the last the end.
        assert_eq!(ex[0].state.w_hole_m, start.w_hole_m);
        let last = ex.last().unwrap().state;
        for i in 0..2 {
            assert!(
                (last.u_m[i] - e.end.u_m[i]).abs() <= 1e-15,
                "{last:?} {:?}",
                e.end
            );
            assert!((last.w_hole_m[i] - e.end.w_hole_m[i]).abs() <= 1e-15);
            assert!((rk.last().unwrap().state.u_m[i] - r.end.u_m[i]).abs() <= 1e-15);
        }
        // The bar's motion agrees with the reference's to a small fraction of its amplitude,
        // and the ball stays inside the hole in both.
        let amp = ex
            .iter()
            .map(|s| s.state.u_m[0].hypot(s.state.u_m[1]))
            .fold(0.0, f64::max);
        let clr = [sys.hole.half_axial_gap_m(), sys.radial_clearance_m()];
        for (a, b) in ex.iter().zip(&rk) {
            for (i, c) in clr.iter().enumerate() {
                assert!(
                    (a.state.u_m[i] - b.state.u_m[i]).abs() < 1e-3 * amp,
                    "u at {}: {:?} against {:?}",
                    a.t_s,
                    a.state,
                    b.state
                );
                assert!(a.state.w_hole_m[i].abs() <= c + 1e-12);
                assert!(b.state.w_hole_m[i].abs() <= c + 1e-9);
            }
        }
    }
}

#[test]
fn a_stroboscopic_sampling_lands_on_the_steady_state_in_both_solvers() {
    // No wall touched (no gravity, a centred ball, wide clearances): the bar's steady response
    // along the force is amp·sin(Ωt − φ). Sampled once per forcing period from a phase of 40°
    // after 1.2 s (the transient has decayed by e^(−ζω·1.2 s) ≈ 1e-12), every point is on it.
    use vibrobar_core::analysis::two_plane::TwoPlaneMethod;
    let mut sys = paper(20e-3, 10e-3, 10.0, 60.0, 0.9, 0.0);
    sys.forcing.frequency = Frequency::RadPerS(2.0 * std::f64::consts::PI * 550.0);
    let bar = Bar::PAPER_CAVITY;
    let om = sys.omega_rad_s();
    let (m, k) = (bar.mass_kg, bar.stiffness_n_per_m);
    let c = 2.0 * bar.damping_ratio * (k * m).sqrt();
    let amp = 15.0 / ((k - m * om * om).powi(2) + (c * om).powi(2)).sqrt();
    let phi = (c * om).atan2(k - m * om * om);
    let period = 2.0 * std::f64::consts::PI / om;
    let first = 40f64.to_radians() / om + (1.2 / period).ceil() * period;
    let e_f = [60f64.to_radians().cos(), 60f64.to_radians().sin()];
    for method in [
        TwoPlaneMethod::Exact,
        TwoPlaneMethod::Reference { dt_s: 1e-6 },
    ] {
        let mut pts = Vec::new();
        let mut on_sample = |s: &TwoPlaneSample| pts.push(*s);
        method
            .run_from(
                &sys,
                &TwoPlaneStart::at_rest([0.0; 2]),
                0.0,
                &settings(1.5),
                &mut |_| {},
                Some(Sampling {
                    start_s: first,
                    interval_s: period,
                    on_sample: &mut on_sample,
                }),
            )
            .unwrap();
        let expected = ((1.5 - first) / period).floor() as usize + 1;
        assert_eq!(pts.len(), expected, "{method:?}");
        for (j, p) in pts.iter().enumerate() {
            assert!((p.t_s - (first + j as f64 * period)).abs() < 1e-12);
            let u = p.state.u_m[0] * e_f[0] + p.state.u_m[1] * e_f[1];
            let want = amp * (om * p.t_s - phi).sin();
            assert!(
                (u - want).abs() < 1e-6 * amp,
                "{method:?} at {}: {u} against {want}",
                p.t_s
            );
        }
    }
}

#[test]
fn a_run_from_a_later_time_continues_the_run_that_reached_it() {
    // From the state a run reached at t0 (its sample), a run started at t0 follows it on:
    // the bar alone (nothing touched) to rounding, and with impacts in both planes closely over
    // a short span (the answer does not restart the forcing's phase).
    use vibrobar_core::analysis::two_plane::TwoPlaneMethod;
    let mut linear = paper(20e-3, 10e-3, 10.0, 60.0, 0.9, 0.0);
    linear.forcing.frequency = Frequency::RadPerS(2.0 * std::f64::consts::PI * 550.0);
    let impacting = paper(0.1e-3, 0.02e-3, 40.0, 70.0, 1.0, 0.0);
    for (sys, tol, dur) in [(linear, 1e-12, 0.1), (impacting, 1e-6, 0.02)] {
        for method in [
            TwoPlaneMethod::Exact,
            TwoPlaneMethod::Reference { dt_s: 1e-6 },
        ] {
            let t0 = 0.5 * dur;
            let (at_t0, whole) = {
                let mut mid = None;
                let mut on_sample = |s: &TwoPlaneSample| mid = Some(*s);
                let whole = method
                    .run_from(
                        &sys,
                        &TwoPlaneStart::at_rest([0.0; 2]),
                        0.0,
                        &settings(dur),
                        &mut |_| {},
                        Some(Sampling {
                            start_s: t0,
                            interval_s: 1.0,
                            on_sample: &mut on_sample,
                        }),
                    )
                    .unwrap();
                (mid.expect("the sample at t0"), whole)
            };
            assert!((at_t0.t_s - t0).abs() < 1e-15);
            // Sampled on a grid from t = 0, the run from t0 reports the grid from t0 on only.
            let mut times = Vec::new();
            let mut on_sample = |s: &TwoPlaneSample| times.push(s.t_s);
            let rest = method
                .run_from(
                    &sys,
                    &at_t0.state,
                    t0,
                    &settings(dur - t0),
                    &mut |_| {},
                    Some(Sampling {
                        start_s: 0.0,
                        interval_s: t0 / 4.0,
                        on_sample: &mut on_sample,
                    }),
                )
                .unwrap();
            assert_eq!(times.len(), 5, "{method:?}: {times:?}");
            assert!((times[0] - t0).abs() < 1e-15 && (times[4] - dur).abs() < 1e-15);
            let amp = whole.end.u_m[0].hypot(whole.end.u_m[1]).max(1e-9);
            for i in 0..2 {
                assert!(
                    (rest.end.u_m[i] - whole.end.u_m[i]).abs() <= tol * amp,
                    "{method:?}: {:?} against {:?}",
                    rest.end,
                    whole.end
                );
            }
        }
    }
}

#[test]
fn the_largest_lyapunov_exponent_agrees_between_solvers_and_with_the_plane_across() {
    // The 15.1 mm hole with the 1 mm axial gap, r = 1, the force at 63.4°: the ball's motion
    // across the hole is chaotic (its Poincaré section is a strange attractor), while along
    // the hole it never reaches a plug. On frictionless walls the planes decouple, so the
    // exponent is that of the plane across the hole run as a one-plane model with gravity on
    // the ball: three independent estimates (exact, reference, one-plane exact), each from 192
    // intervals of five periods, agree within three combined standard errors (measured: 219 ±
    // 10, 224 ± 9 and 192 ± 11 1/s).
    use vibrobar_core::analysis::lyapunov::{max_lyapunov, LyapunovParams};
    use vibrobar_core::analysis::two_plane::{max_lyapunov_two_plane, TwoPlaneMethod};
    let sys = paper(1e-3, 0.05e-3, 0.0, 63.4, 1.0, 9.80665);
    let start = TwoPlaneStart::resting(&sys, 0.0);
    let st = settings(2.0);
    let period = 2.0 * std::f64::consts::PI / sys.omega_rad_s();
    let p = LyapunovParams {
        transient_s: 0.4,
        interval_s: 5.0 * period,
        intervals: 192,
        d0: 1e-9,
        scales: None,
        blocks: 10,
    };
    let ex = max_lyapunov_two_plane(&sys, &start, TwoPlaneMethod::Exact, &st, &p).unwrap();
    let rk = max_lyapunov_two_plane(
        &sys,
        &start,
        TwoPlaneMethod::Reference { dt_s: 1e-6 },
        &st,
        &p,
    )
    .unwrap();
    let across = two_plane_exact::plane_system(&sys, 1).unwrap();
    let one_start = State {
        v_m: start.w_hole_m[1],
        ..State::REST
    };
    let one = max_lyapunov(&across, &one_start, &Exact::default(), &p).unwrap();
    assert!(
        ex.exponent_per_s > 10.0 * ex.std_error_per_s,
        "not chaotic: {ex:?}"
    );
    for (other, what) in [(&rk, "reference"), (&one, "one-plane across")] {
        let se = ex.std_error_per_s.hypot(other.std_error_per_s);
        assert!(
            (ex.exponent_per_s - other.exponent_per_s).abs() < 3.0 * se,
            "{what}: {} ± {} against {} ± {}",
            other.exponent_per_s,
            other.std_error_per_s,
            ex.exponent_per_s,
            ex.std_error_per_s
        );
    }
    assert_eq!(ex.clamped, 0);
}

/// A periodic orbit of the two-plane bar where its planes decouple: the orbit of each plane,
/// whose states a two-plane run from the combined state repeats after one period; where the
/// orbit is stable, the RMS of a long run from the same start settles on the orbit's, and the
/// largest Lyapunov exponent of that run is `ln max|λ| / T` of the orbit's multipliers (the
/// planes' saltation at a fixed point against QR along the run).
#[test]
fn a_two_plane_orbit_is_the_pair_of_plane_orbits_and_the_long_run_settles_on_it() {
    use vibrobar_core::analysis::lyapunov_spectrum::SpectrumParams;
    use vibrobar_core::analysis::orbit::ExactJacobian;
    use vibrobar_core::analysis::two_plane_orbit::{
        two_plane_lyapunov_spectrum, two_plane_orbit, TwoPlaneOrbitOf,
    };
    let g = STANDARD_GRAVITY_M_S2;
    // The force at 63.4° to the radial hole, gravity across it, r = 1. A tight hole (0.04 mm
    // axial gap, 0.04 mm radial clearance): a stable two-impact orbit in each plane, the ball
    // pressed on the hole's wall by gravity between impacts across it. With the 1 mm axial
    // gap the resting ball floats along the hole without an impact (multipliers 1: not
    // asymptotically stable) while the orbit across the hole stays.
    for (name, gap_m, c_r_m) in [
        ("tight", 0.04e-3, 0.04e-3),
        ("1 mm axial gap", 1e-3, 0.04e-3),
    ] {
        let sys = paper(gap_m, c_r_m, 0.0, 63.4, 1.0, g);
        let start = TwoPlaneStart::resting(&sys, 0.0);
        let TwoPlaneOrbitOf::Lumped(o) =
            two_plane_orbit(&sys, 1, &start, 0.5, &ExactJacobian).unwrap()
        else {
            panic!("{name}: a lumped bar's orbit");
        };
        let m = o.multipliers();
        eprintln!(
            "{name}: impacts {} per period, return gap {:.1e}, rms along force {:.4e}, stable {}, \
             |λ| max {:.4}",
            o.impacts_per_period(),
            o.return_gap,
            o.summary.rms_along_force_m,
            o.stable(),
            m[0].norm()
        );
        assert_eq!(m.len(), 8, "{name}");
        assert!(o.return_gap < 1e-7, "{name}: return gap {:e}", o.return_gap);
        assert_eq!(
            o.summary.impacts.iter().sum::<u64>(),
            o.impacts_per_period() as u64,
            "{name}: impacts of the two-plane run over the orbit"
        );
        if name != "tight" {
            assert!(!o.stable() && o.planes[0].impacts_per_period == 0, "{name}");
            assert!(
                (o.planes[0].max_abs_multiplier() - 1.0).abs() < 1e-6,
                "{name}"
            );
            assert!(
                o.planes[1].stable() && o.planes[1].impacts_per_period == 2,
                "{name}"
            );
            continue;
        }
        assert!(o.stable() && o.planes.iter().all(|p| p.impacts_per_period == 2));
        // A window of whole periods (300, after 75 of settling).
        let t_period = 2.0 * std::f64::consts::PI / sys.omega_rad_s();
        let (_, long) = exact2(&sys, &start, 375.0 * t_period);
        close(
            long.rms_along_force_m,
            o.summary.rms_along_force_m,
            1e-6,
            &format!("{name}: RMS of the settled run against the orbit's"),
        );
        let p = SpectrumParams {
            transient_s: 0.3,
            duration_s: 0.7,
            blocks: 10,
            scales: None,
        };
        let sp = two_plane_lyapunov_spectrum(&sys, &start, &p).unwrap();
        let top = sp
            .iter()
            .flat_map(|s| s.exponents_per_s.iter().flatten().copied())
            .fold(f64::NEG_INFINITY, f64::max);
        let expected = m[0].norm().ln() / t_period;
        eprintln!("{name}: largest exponent {top:.3} 1/s, orbit {expected:.3} 1/s");
        close(top, expected, 1e-2, &format!("{name}: largest exponent"));
    }
    // With friction the planes couple: refused, naming why.
    let mut rough = paper(1e-3, 0.05e-3, 0.0, 63.4, 1.0, g);
    rough.ball.friction_static = 0.3;
    rough.ball.friction_kinetic = 0.2;
    let e = two_plane_orbit(
        &rough,
        1,
        &TwoPlaneStart::resting(&rough, 0.0),
        0.5,
        &ExactJacobian,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("decouple") && e.contains("friction"), "{e}");
}

/// A periodic orbit of the round beam in two planes (0.1 mm axial gap, 0.04 mm radial
/// clearance, r = 1, gravity across the hole): each plane's orbit is the one-plane modal orbit
/// of its system, the two-plane run started from the planes' modal states comes back to them
/// after one period, and its RMS along the force (the planes' closed forms and cross term) is
/// the quadrature of the sampled displacement along the force.
#[test]
fn a_round_beam_two_plane_orbit_is_the_pair_of_modal_orbits() {
    use vibrobar_core::analysis::orbit::modal::modal_orbit_settled;
    use vibrobar_core::analysis::orbit::ExactJacobian;
    use vibrobar_core::analysis::two_plane_orbit::{two_plane_orbit, TwoPlaneOrbitOf};
    use vibrobar_core::params::two_plane::direction;
    use vibrobar_core::structure::{ModalState, ModalSystem};
    let sys = round_beam(0.1e-3, 0.04e-3, 63.4, 1.0, STANDARD_GRAVITY_M_S2);
    let start = TwoPlaneStart::resting(&sys, 0.0);
    let TwoPlaneOrbitOf::Round(o) = two_plane_orbit(&sys, 1, &start, 0.3, &ExactJacobian).unwrap()
    else {
        panic!("a round bar's orbit");
    };
    eprintln!(
        "beam: impacts {} per period, return gap {:.1e}, rms along force {:.4e}, |λ| max {:.4}",
        o.impacts_per_period(),
        o.return_gap,
        o.summary.rms_along_force_m,
        o.multipliers()[0].norm()
    );
    assert!(o.return_gap < 1e-8, "return gap {:e}", o.return_gap);
    assert_eq!(
        o.multipliers().len(),
        2 * (2 * o.planes[0].section.n_modes() + 2)
    );
    for axis in 0..2 {
        let psys = two_plane_exact::plane_system(&sys, axis).unwrap();
        let ms = ModalSystem::from_system(&psys).unwrap();
        let init = ModalState::from_public(
            &ms.model,
            &two_plane_exact::plane_start(&sys, &start, axis, 0.0),
        )
        .unwrap();
        let one = modal_orbit_settled(&ms, 1, &init, 0.3).unwrap();
        close(
            o.planes[axis].max_abs_multiplier(),
            one.max_abs_multiplier(),
            1e-9,
            "a plane's multipliers are its one-plane orbit's",
        );
        assert_eq!(o.planes[axis].impacts_per_period, one.impacts_per_period);
    }
    // The RMS along the force over the period by the trapezoid rule on 20 000 samples.
    let period_s = 2.0 * std::f64::consts::PI / sys.omega_rad_s();
    let n = 20_000;
    let e_f = direction(sys.forcing.angle_deg);
    let mut u2 = Vec::with_capacity(n + 1);
    let mut on_sample = |s: &TwoPlaneSample| {
        let u = s.state.u_m[0] * e_f[0] + s.state.u_m[1] * e_f[1];
        u2.push(u * u);
    };
    let modal = [0, 1].map(|axis| {
        let o1 = &o.planes[axis];
        ModalExact::default()
            .run(&o1.section.system, &o1.state, o.start_t_s, &mut ())
            .unwrap()
            .final_state
    });
    TwoPlaneExact::default()
        .run_from_modal(
            &sys,
            &o.start,
            &modal,
            o.start_t_s,
            &RunSettings {
                duration_s: period_s,
                dt_s: 1e-6,
                rms_fraction: 1.0,
            },
            &mut |_| {},
            Some(Sampling {
                start_s: o.start_t_s,
                interval_s: period_s / n as f64,
                on_sample: &mut on_sample,
            }),
        )
        .unwrap();
    assert!(u2.len() >= n, "{} samples", u2.len());
    let mean = (u2[..n].iter().sum::<f64>() + 0.5 * (u2[n.min(u2.len() - 1)] - u2[0])) / n as f64;
    close(
        mean.sqrt(),
        o.summary.rms_along_force_m,
        1e-5,
        "the orbit's RMS along the force against the quadrature",
    );
}

/// Measured modes in two perpendicular bending directions (a clamping that splits the pair).
fn measured_pair(split: f64, axis_deg: f64) -> vibrobar_core::params::two_plane::ModalPair {
    use vibrobar_core::structure::{ModalModel, Mode};
    let family = |scale: f64| {
        ModalModel::new(
            &[
                Mode {
                    omega_rad_s: 2.0 * std::f64::consts::PI * 600.0 * scale,
                    damping_ratio: 0.01,
                    modal_mass_kg: 0.16,
                    shape_cavity: 0.7,
                    shape_force: 1.0,
                    shape_response: 1.0,
                },
                Mode {
                    omega_rad_s: 2.0 * std::f64::consts::PI * 3700.0 * scale,
                    damping_ratio: 0.015,
                    modal_mass_kg: 0.16,
                    shape_cavity: -0.4,
                    shape_force: 1.0,
                    shape_response: 1.0,
                },
            ],
            0.0,
        )
        .unwrap()
    };
    vibrobar_core::params::two_plane::ModalPair {
        modes: [family(1.0), family(split)],
        axis_deg,
    }
}

#[test]
fn measured_modes_bend_in_their_directions() {
    use vibrobar_core::structure::Point;
    // Far from the walls (no impact): the tip's response along the force is
    // F0 Σⱼ (e_F·dⱼ)² Gⱼ(Ω), each family through its receptance along its direction.
    let mut sys = paper(20e-3, 10e-3, 30.0, 75.0, 1.0, 0.0);
    let pair = measured_pair(1.04, 30.0);
    sys.bar = TwoPlaneBar::Measured(pair);
    sys.forcing.frequency = Frequency::RadPerS(2.0 * std::f64::consts::PI * 610.0);
    assert!(two_plane_exact::decoupled(&sys).is_ok());
    let (evs, e) = exact2(&sys, &TwoPlaneStart::at_rest([0.0; 2]), 2.0);
    assert!(evs.is_empty());
    let w = sys.omega_rad_s();
    let rel = (75.0f64 - 30.0).to_radians();
    let g = pair.modes[0].receptance(Point::Force, Point::Response, w) * rel.cos().powi(2)
        + pair.modes[1].receptance(Point::Force, Point::Response, w) * rel.sin().powi(2);
    close(
        e.rms_along_force_m,
        15.0 * g.norm() / 2f64.sqrt(),
        1e-6,
        "RMS along the force of the split pair",
    );
    // A ratio refers to the lower first mode; the hole across the first family puts the second
    // along the hole.
    close(
        sys.bar.omega1_rad_s(),
        2.0 * std::f64::consts::PI * 600.0,
        1e-15,
        "ω₁",
    );
    let mut across = sys;
    across.hole.angle_deg = 120.0;
    let p0 = two_plane_exact::plane_system(&across, 0).unwrap();
    assert_eq!(
        p0.bar,
        vibrobar_core::params::BarModel::Modal(pair.modes[1])
    );
    // Equal families are a round bar: the same run as TwoPlaneBar::Round, at any hole angle.
    let mut twins = paper(0.1e-3, 0.05e-3, 10.0, 63.4, 1.0, 9.80665);
    twins.bar = TwoPlaneBar::Measured(measured_pair(1.0, 47.0));
    let mut round = twins;
    round.bar = TwoPlaneBar::Round(pair.modes[0]);
    let start = TwoPlaneStart::resting(&twins, 0.0);
    let (ea, a) = exact2(&twins, &start, 0.05);
    let (eb, b) = exact2(&round, &start, 0.05);
    assert_eq!(ea.len(), eb.len());
    assert!(a.impacts.iter().sum::<u64>() > 5);
    assert_eq!(a.rms_along_force_m, b.rms_along_force_m);
    // At a slant to the hole the families couple the planes: refused, saying so.
    let mut slant = sys;
    slant.hole.angle_deg = 50.0;
    let why = two_plane_exact::decoupled(&slant).unwrap_err();
    assert!(why.contains("bending directions"), "{why}");
    let err = TwoPlaneRk4::default()
        .run(
            &slant,
            &TwoPlaneStart::at_rest([0.0; 2]),
            &settings(0.01),
            &mut |_| {},
        )
        .unwrap_err()
        .to_string();
    assert!(err.contains("lumped bar only"), "{err}");
}
