//! Regime classification: constructed impact sequences with a known answer, and real runs.

use vibrobar_core::analysis::ensemble::SplitMix64;
use vibrobar_core::analysis::regime::{
    classify, Collected, ImpactRecord, ModeTime, Regime, RegimeObserver, Tolerances,
};
use vibrobar_core::analysis::run_case;
use vibrobar_core::solver::{Rk4, Wall};
use vibrobar_core::{FrictionModel, RunSettings, State, System};

const T: f64 = 1e-3;

fn collected(impacts: Vec<ImpactRecord>, cycles: f64) -> Collected {
    Collected {
        period_s: T,
        window_start_s: 0.2,
        window_end_s: 0.2 + cycles * T,
        impacts,
        strobe: Vec::new(),
        mode_time: ModeTime {
            free_s: cycles * T,
            ..Default::default()
        },
    }
}

/// Impacts at `0.2 + (c + phase)·T` for each cycle `c` repeating `pattern` every `k` cycles;
/// `jitter(j)` (in periods) is added to impact `j`.
fn sequence(
    pattern: &[(f64, Wall)],
    k: usize,
    cycles: usize,
    jitter: &dyn Fn(usize) -> f64,
) -> Vec<ImpactRecord> {
    let mut out = Vec::new();
    for rep in 0..cycles / k {
        for &(ph, wall) in pattern {
            let j = out.len();
            out.push(ImpactRecord {
                t_s: 0.2 + ((rep * k) as f64 + ph + jitter(j)) * T,
                wall,
            });
        }
    }
    out
}

fn sym2_pattern() -> Vec<(f64, Wall)> {
    vec![(0.2, Wall::Plus), (0.7, Wall::Minus)]
}

#[test]
fn symmetric_two_impacts_per_cycle_is_sym2() {
    let c = collected(sequence(&sym2_pattern(), 1, 60, &|_| 0.0), 60.0);
    let r = classify(&c, &Tolerances::default());
    assert_eq!(r, Regime::Sym2);
    assert_eq!(r.as_str(), "sym2");
}

#[test]
fn sym2_within_phase_tolerance_but_not_beyond() {
    // ±0.4 % of a period of alternating jitter: inside the 1 % tolerance.
    let small = |j: usize| if j % 4 == 1 { 0.004 } else { 0.0 };
    let c = collected(sequence(&sym2_pattern(), 1, 60, &small), 60.0);
    assert_eq!(classify(&c, &Tolerances::default()), Regime::Sym2);
    // 3 % of a period on every other cycle: period 2, and no longer half a period apart.
    let big = |j: usize| if j % 4 == 1 { 0.03 } else { 0.0 };
    let c = collected(sequence(&sym2_pattern(), 1, 60, &big), 60.0);
    assert_eq!(
        classify(&c, &Tolerances::default()),
        Regime::Periodic {
            impacts: 4,
            cycles: 2
        }
    );
}

#[test]
fn two_impacts_per_cycle_not_half_a_period_apart_is_p2_1() {
    let pat = [(0.2, Wall::Plus), (0.5, Wall::Minus)];
    let c = collected(sequence(&pat, 1, 60, &|_| 0.0), 60.0);
    let r = classify(&c, &Tolerances::default());
    assert_eq!(r.as_str(), "p2/1");
    // Same wall twice per cycle: not symmetric either.
    let pat = [(0.2, Wall::Plus), (0.7, Wall::Plus)];
    let c = collected(sequence(&pat, 1, 60, &|_| 0.0), 60.0);
    assert_eq!(classify(&c, &Tolerances::default()).as_str(), "p2/1");
}

#[test]
fn three_impacts_per_two_cycles_is_p3_2() {
    let pat = [(0.1, Wall::Plus), (0.7, Wall::Minus), (1.4, Wall::Plus)];
    let c = collected(sequence(&pat, 2, 60, &|_| 0.0), 60.0);
    let r = classify(&c, &Tolerances::default());
    assert_eq!(
        r,
        Regime::Periodic {
            impacts: 3,
            cycles: 2
        }
    );
    assert_eq!(r.as_str(), "p3/2");
    assert_eq!(Regime::parse("p3/2"), Some(r));
    // Impacts per cycle alternate 2, 1: 30 cycles of each.
    let per = c.impacts_per_cycle();
    assert_eq!(per.len(), 60);
    assert_eq!(&per[..4], &[2, 1, 2, 1]);
    assert_eq!(c.impacts_per_cycle_histogram(), vec![0, 30, 30]);
}

#[test]
fn period_above_k_max_is_chaotic() {
    let pat = [(0.1, Wall::Plus), (2.6, Wall::Minus)];
    let c = collected(sequence(&pat, 5, 60, &|_| 0.0), 60.0);
    assert_eq!(classify(&c, &Tolerances::default()).as_str(), "p2/5");
    let tol = Tolerances {
        k_max: 4,
        ..Default::default()
    };
    assert_eq!(classify(&c, &tol), Regime::Chaotic);
}

#[test]
fn random_impacts_are_chaotic() {
    let mut g = SplitMix64::new(7);
    let mut t = 0.2;
    let mut imp = Vec::new();
    while t < 0.26 {
        t += (0.2 + 0.8 * g.next_f64()) * T;
        let wall = if g.next_u64() & 1 == 0 {
            Wall::Plus
        } else {
            Wall::Minus
        };
        imp.push(ImpactRecord { t_s: t, wall });
    }
    imp.pop();
    let c = collected(imp, 60.0);
    assert_eq!(classify(&c, &Tolerances::default()), Regime::Chaotic);
}

#[test]
fn impacts_that_stop_mid_window_are_not_periodic() {
    let mut imp = sequence(&sym2_pattern(), 1, 60, &|_| 0.0);
    imp.truncate(40); // 20 cycles of sym2, then 40 silent cycles
    let c = collected(imp, 60.0);
    assert_eq!(classify(&c, &Tolerances::default()), Regime::Chaotic);
}

#[test]
fn no_impacts_is_none_and_contact_dominates() {
    let mut c = collected(Vec::new(), 60.0);
    assert_eq!(classify(&c, &Tolerances::default()).as_str(), "none");
    c.mode_time = ModeTime {
        free_s: 0.4,
        stick_s: 0.3,
        contact_s: 0.3,
        ..Default::default()
    };
    assert_eq!(classify(&c, &Tolerances::default()).as_str(), "contact");
    c.mode_time.contact_s = 0.1;
    c.mode_time.free_s = 0.6; // 40 % < 50 %
    assert_eq!(classify(&c, &Tolerances::default()), Regime::None);
}

#[test]
fn stroboscopic_points_must_repeat_too() {
    let mut c = collected(sequence(&sym2_pattern(), 1, 60, &|_| 0.0), 60.0);
    // Bar alternates between two states at phase 0: period 2 although impacts look period 1.
    c.strobe = (0..60)
        .map(|i| State {
            t_s: 0.2 + i as f64 * T,
            u_m: if i % 2 == 0 { 1e-5 } else { 1.2e-5 },
            du_m_s: 0.01,
            ..State::REST
        })
        .collect();
    assert_eq!(classify(&c, &Tolerances::default()).as_str(), "p4/2");
    // Within 1 %: period 1.
    for (i, s) in c.strobe.iter_mut().enumerate() {
        s.u_m = if i % 2 == 0 { 1e-5 } else { 1.005e-5 };
    }
    assert_eq!(classify(&c, &Tolerances::default()), Regime::Sym2);
}

#[test]
fn regime_words_round_trip() {
    for r in [
        Regime::None,
        Regime::Sym2,
        Regime::Contact,
        Regime::Chaotic,
        Regime::Periodic {
            impacts: 12,
            cycles: 7,
        },
    ] {
        assert_eq!(Regime::parse(&r.as_str()), Some(r));
    }
    assert_eq!(Regime::parse("p3"), None);
    assert_eq!(Regime::parse("q1/2"), None);
}

fn real_regime(sys: &System, st: &RunSettings) -> (Regime, Collected) {
    let solver = Rk4 { dt_s: 2e-6 };
    let mut obs = RegimeObserver::new(sys, st.window_start_s(), st.duration_s);
    run_case(sys, &State::REST, st, &solver, &mut obs).unwrap();
    let c = obs.finish();
    (classify(&c, &Tolerances::default()), c)
}

#[test]
fn solid_bar_and_wide_gap_have_no_impacts() {
    let st = RunSettings {
        duration_s: 0.2,
        dt_s: 2e-6,
        rms_fraction: 0.5,
    };
    let (r, c) = real_regime(&System::paper_solid(1.0), &st);
    assert_eq!(r, Regime::None);
    // The observer saw the whole window as `NoBall` and one strobe point per period.
    assert!((c.mode_time.no_ball_s - 0.1).abs() < 1e-9);
    let sys = System::paper_solid(1.0);
    let n = (0.1 / sys.forcing_period_s()).floor() as usize;
    assert!(c.strobe.len() == n || c.strobe.len() == n + 1);
    // Frictionless 1 mm gap at resonance: the paper's "no impacts" case.
    let (r, c) = real_regime(&System::paper_damped(1e-3, FrictionModel::None, 1.0), &st);
    assert_eq!(r, Regime::None);
    assert!((c.mode_time.free_s - 0.1).abs() < 1e-9);
}

#[test]
fn small_gap_at_resonance_impacts() {
    // Frictionless 0.1 mm at r = 1 impacts (paper Fig. 2); whatever its regime, not `none`.
    let st = RunSettings {
        duration_s: 0.3,
        dt_s: 2e-6,
        rms_fraction: 0.5,
    };
    let (r, c) = real_regime(&System::paper_damped(1e-4, FrictionModel::None, 1.0), &st);
    assert!(!c.impacts.is_empty());
    assert_ne!(r, Regime::None);
    assert_ne!(r, Regime::Contact);
}

/// A segment of constant state in a given mode: enough to drive the observer by hand, as an
/// event-driven solver reporting stick and contact modes would.
struct ModeSegment {
    a: f64,
    b: f64,
    mode: vibrobar_core::solver::Mode,
}

impl vibrobar_core::solver::Segment for ModeSegment {
    fn t_start_s(&self) -> f64 {
        self.a
    }
    fn t_end_s(&self) -> f64 {
        self.b
    }
    fn mode(&self) -> vibrobar_core::solver::Mode {
        self.mode
    }
    fn state_at(&self, t_s: f64) -> State {
        State { t_s, ..State::REST }
    }
    fn integral_u2(&self, _a: f64, _b: f64) -> f64 {
        0.0
    }
    fn integrals(&self, _a: f64, _b: f64) -> vibrobar_core::solver::SegmentIntegrals {
        Default::default()
    }
    fn mechanical_energy_j(&self, _t_s: f64) -> f64 {
        0.0
    }
}

#[test]
fn observer_times_modes_inside_the_window_only() {
    use vibrobar_core::solver::{Event, EventKind, Mode};
    use vibrobar_core::Observer;
    let sys = System::paper_damped(1e-4, FrictionModel::Coulomb, 1.0);
    let tp = sys.forcing_period_s();
    let (w0, w1) = (10.0 * tp, 40.0 * tp);
    let mut obs = RegimeObserver::new(&sys, w0, w1);
    // 0 … 20 T free (10 T of it in the window), 20 … 32 T riding the wall, 32 … 40 T stuck.
    let segs = [
        (0.0, 20.0, Mode::Free),
        (20.0, 32.0, Mode::Contact(Wall::Plus)),
        (32.0, 40.0, Mode::Stick),
    ];
    for (a, b, mode) in segs {
        obs.segment(&ModeSegment {
            a: a * tp,
            b: b * tp,
            mode,
        });
        let ev = Event {
            t_s: b * tp,
            kind: EventKind::Impact {
                wall: Wall::Minus,
                dw_m_s: -0.01,
                energy_loss_j: 0.0,
            },
            before: State::REST,
            after: State::REST,
        };
        obs.event(&ev);
    }
    let c = obs.finish();
    assert!((c.mode_time.free_s - 10.0 * tp).abs() < 1e-12);
    assert!((c.mode_time.contact_s - 12.0 * tp).abs() < 1e-12);
    assert!((c.mode_time.stick_s - 8.0 * tp).abs() < 1e-12);
    assert_eq!(c.impacts.len(), 3); // at 20 T, 32 T and 40 T (window end included)
    assert_eq!(c.strobe.len(), 31); // phase-0 points at 10 T … 40 T
                                    // 20 of 30 periods stuck or in contact: 67 % > 50 %.
    assert_eq!(classify(&c, &Tolerances::default()), Regime::Contact);
    let lenient = Tolerances {
        contact_fraction: 0.7,
        ..Default::default()
    };
    assert_eq!(classify(&c, &lenient), Regime::Chaotic);
}
