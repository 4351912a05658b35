//! The golden points of the exact solver (`tests/golden_exact.rs`): systems, and a run reduced to
//! an event-sequence digest and the RMS.
//!
//! Systems are built from `params` directly (not through the sweep helpers), so a refactor of the
//! analyses cannot move the pinned inputs.

use vibrobar_core::solver::{Event, EventKind, Exact, Observer, Segment, Solver, Wall};
use vibrobar_core::*;

/// Run length and RMS window of the paper: 2 s, RMS over the last 80 %.
pub const DURATION_S: f64 = 2.0;
pub const RMS_FRACTION: f64 = 0.8;

/// One golden point.
#[derive(Debug, Clone, Copy)]
pub struct Point {
    pub name: &'static str,
    pub sys: System,
    /// Initial state at t = 0 (rest, ball centred, unless said otherwise).
    pub init: State,
}

/// What a run is reduced to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outcome {
    /// FNV-1a 64 over every event's kind, wall and `t_s.to_bits()`.
    pub digest: u64,
    pub events: u64,
    pub impacts: u64,
    pub rms_m: f64,
    /// Impacts per forcing cycle inside the RMS window.
    pub impacts_per_cycle: f64,
}

/// The paper's friction cases: (label, model, override of the level).
pub const FRICTIONS: [(&str, FrictionModel, Option<f64>); 4] = [
    ("none", FrictionModel::None, None),
    ("aspub", FrictionModel::AsPublished, None),
    ("aspub20", FrictionModel::AsPublished, Some(20.0)),
    ("coulomb", FrictionModel::Coulomb, None),
];
pub const GAPS_M: [f64; 2] = [0.1e-3, 1e-3];
pub const RATIOS: [f64; 5] = [0.95, 0.98, 1.0, 1.02, 1.05];

fn damped(gap_m: f64, friction: FrictionModel, level: Option<f64>, ratio: f64) -> System {
    let mut sys = System::paper_damped(gap_m, friction, ratio);
    sys.damper.as_mut().unwrap().friction_force_n = level;
    sys
}

/// Every golden point, in a fixed order: the paper sweep's gaps × frictions × ratios, the solid
/// bars, and two non-paper cases.
pub fn points() -> Vec<Point> {
    let mut v = Vec::new();
    let names = golden_names();
    let mut k = 0;
    for gap in GAPS_M {
        for (_, model, level) in FRICTIONS {
            for r in RATIOS {
                v.push(Point {
                    name: names[k],
                    sys: damped(gap, model, level, r),
                    init: State::REST,
                });
                k += 1;
            }
        }
    }
    for r in RATIOS {
        v.push(Point {
            name: names[k],
            sys: System::paper_solid(r),
            init: State::REST,
        });
        k += 1;
    }
    // Symmetric two-impact orbit (e = 0.8, r = 0.9, 0.1 mm; see exact_periodic_orbit.rs). From
    // rest the ball never moves; a 0.02 m/s throw sets it bouncing onto the stable orbit.
    let mut e08 = damped(0.1e-3, FrictionModel::None, None, 0.9);
    e08.damper.as_mut().unwrap().restitution = 0.8;
    v.push(Point {
        name: names[k],
        sys: e08,
        init: State {
            dv_m_s: 0.02,
            ..State::REST
        },
    });
    k += 1;
    // Coulomb friction strong enough that the ball sticks most of the time.
    v.push(Point {
        name: names[k],
        sys: damped(1e-3, FrictionModel::Coulomb, Some(5.0), 1.0),
        init: State::REST,
    });
    v
}

/// Names of [`points`], in order (static, so they can key the literal tables).
pub fn golden_names() -> Vec<&'static str> {
    const N: [&str; 47] = [
        "g0.1_none_r0.95",
        "g0.1_none_r0.98",
        "g0.1_none_r1.00",
        "g0.1_none_r1.02",
        "g0.1_none_r1.05",
        "g0.1_aspub_r0.95",
        "g0.1_aspub_r0.98",
        "g0.1_aspub_r1.00",
        "g0.1_aspub_r1.02",
        "g0.1_aspub_r1.05",
        "g0.1_aspub20_r0.95",
        "g0.1_aspub20_r0.98",
        "g0.1_aspub20_r1.00",
        "g0.1_aspub20_r1.02",
        "g0.1_aspub20_r1.05",
        "g0.1_coulomb_r0.95",
        "g0.1_coulomb_r0.98",
        "g0.1_coulomb_r1.00",
        "g0.1_coulomb_r1.02",
        "g0.1_coulomb_r1.05",
        "g1.0_none_r0.95",
        "g1.0_none_r0.98",
        "g1.0_none_r1.00",
        "g1.0_none_r1.02",
        "g1.0_none_r1.05",
        "g1.0_aspub_r0.95",
        "g1.0_aspub_r0.98",
        "g1.0_aspub_r1.00",
        "g1.0_aspub_r1.02",
        "g1.0_aspub_r1.05",
        "g1.0_aspub20_r0.95",
        "g1.0_aspub20_r0.98",
        "g1.0_aspub20_r1.00",
        "g1.0_aspub20_r1.02",
        "g1.0_aspub20_r1.05",
        "g1.0_coulomb_r0.95",
        "g1.0_coulomb_r0.98",
        "g1.0_coulomb_r1.00",
        "g1.0_coulomb_r1.02",
        "g1.0_coulomb_r1.05",
        "solid_r0.95",
        "solid_r0.98",
        "solid_r1.00",
        "solid_r1.02",
        "solid_r1.05",
        "e0.8_orbit_g0.1_r0.90_throw",
        "coulomb5N_stick_g1.0_r1.00",
    ];
    N.to_vec()
}

/// Digest, counts and RMS of one run, computed from the events and segments alone.
struct Reducer {
    hash: u64,
    events: u64,
    impacts: u64,
    impacts_in_window: u64,
    window_start_s: f64,
    window_end_s: f64,
    u2: f64,
    covered_s: f64,
}

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;

impl Reducer {
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.hash ^= x as u64;
            self.hash = self.hash.wrapping_mul(FNV_PRIME);
        }
    }
}

fn wall_code(w: Wall) -> u8 {
    match w {
        Wall::Plus => 1,
        Wall::Minus => 2,
    }
}

impl Observer for Reducer {
    fn segment(&mut self, seg: &dyn Segment) {
        // As the RMS observer of the analyses does it.
        let a = seg.t_start_s().max(self.window_start_s);
        let b = seg.t_end_s().min(self.window_end_s);
        if b > a {
            self.u2 += seg.integral_u2(a, b);
            self.covered_s += b - a;
        }
    }
    fn event(&mut self, ev: &Event) {
        let (kind, wall) = match ev.kind {
            EventKind::Impact { wall, .. } => (1u8, wall_code(wall)),
            EventKind::FrictionSwitch => (2, 0),
            EventKind::Stick => (3, 0),
            EventKind::Unstick => (4, 0),
            EventKind::ChatterLimit { wall, .. } => (5, wall_code(wall)),
            EventKind::ContactRelease { wall } => (6, wall_code(wall)),
        };
        self.bytes(&[kind, wall]);
        self.bytes(&ev.t_s.to_bits().to_le_bytes());
        self.events += 1;
        if kind == 1 {
            self.impacts += 1;
            if ev.t_s >= self.window_start_s {
                self.impacts_in_window += 1;
            }
        }
    }
}

/// Run `sys` from `init` (at t = 0) for the paper's 2 s with the default exact solver.
pub fn run_from(sys: &System, init: &State) -> Outcome {
    let w0 = DURATION_S * (1.0 - RMS_FRACTION);
    let mut r = Reducer {
        hash: FNV_OFFSET,
        events: 0,
        impacts: 0,
        impacts_in_window: 0,
        window_start_s: w0,
        window_end_s: DURATION_S,
        u2: 0.0,
        covered_s: 0.0,
    };
    let sum = Exact::default()
        .run(sys, init, DURATION_S, &mut r)
        .expect("golden run");
    assert_eq!((sum.events, sum.impacts), (r.events, r.impacts));
    Outcome {
        digest: r.hash,
        events: r.events,
        impacts: r.impacts,
        rms_m: (r.u2 / r.covered_s).sqrt(),
        impacts_per_cycle: r.impacts_in_window as f64
            / ((DURATION_S - w0) / sys.forcing_period_s()),
    }
}

/// A point's own run.
pub fn run(p: &Point) -> Outcome {
    run_from(&p.sys, &p.init)
}

/// The `k`-th member of a perturbed ensemble of a point: the bar displaced by `k·1e-12` of the
/// static deflection `F0/K` (the ball moves along, so `w` is unchanged).
pub fn perturbed(p: &Point, k: u32) -> Outcome {
    let du = k as f64 * 1e-12 * p.sys.forcing.amplitude_n
        / p.sys.lumped_bar().unwrap().stiffness_n_per_m;
    let init = State {
        u_m: p.init.u_m + du,
        v_m: p.init.v_m + du,
        ..p.init
    };
    run_from(&p.sys, &init)
}
