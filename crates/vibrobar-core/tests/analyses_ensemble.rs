//! Seeded initial-condition ensembles: reproducible, seed-sensitive, thread-count independent.

use vibrobar_core::analysis::ensemble::{run_ensemble, EnsembleParams, IcRanges, SplitMix64};
use vibrobar_core::analysis::map::{Axis, Grid, GridAxis, MapSpec};
use vibrobar_core::analysis::regime::{Regime, Tolerances};
use vibrobar_core::analysis::SweepBase;
use vibrobar_core::solver::Rk4;
use vibrobar_core::{FrictionModel, RunSettings};

#[test]
fn splitmix64_matches_the_reference_sequence() {
    // Reference outputs of SplitMix64 (Vigna's splitmix64.c) from seed 0.
    let mut g = SplitMix64::new(0);
    assert_eq!(g.next_u64(), 0xE220_A839_7B1D_CDAF);
    assert_eq!(g.next_u64(), 0x6E78_9E6A_A1B9_65F4);
    assert_eq!(g.next_u64(), 0x06C4_5D18_8009_454F);
    let mut g = SplitMix64::new(42);
    for _ in 0..1000 {
        let x = g.next_f64();
        assert!((0.0..1.0).contains(&x));
        let y = g.uniform(-2.0, 3.0);
        assert!((-2.0..3.0).contains(&y));
    }
}

fn params(seed: u64, members: usize) -> EnsembleParams {
    EnsembleParams {
        seed,
        members,
        ranges: IcRanges {
            u_m: (-5e-5, 5e-5),
            du_m_s: (0.0, 0.0),
            w_over_half_gap: (-1.0, 1.0),
            dw_m_s: (-0.05, 0.05),
        },
    }
}

#[test]
fn initial_states_respect_the_ranges() {
    let p = params(1, 0);
    let lg = 5e-5;
    for i in 0..200 {
        let s = p.initial_state(i, lg);
        assert!(s.u_m.abs() <= 5e-5);
        assert!(s.du_m_s.abs() < 1e-300);
        assert!(s.w_m().abs() <= lg * (1.0 + 1e-12));
        assert!(s.dw_m_s().abs() <= 0.05 * (1.0 + 1e-12));
        assert_eq!(s, p.initial_state(i, lg));
    }
    assert_ne!(p.initial_state(0, lg), p.initial_state(1, lg));
    assert_ne!(p.initial_state(0, lg), params(2, 0).initial_state(0, lg));
    assert!(params(1, 0).validate().is_err()); // zero members
    let mut bad = params(1, 3);
    bad.ranges.w_over_half_gap = (-1.5, 0.0);
    assert!(bad.validate().is_err());
    bad.ranges.w_over_half_gap = (0.5, 0.0);
    assert!(bad.validate().is_err());
}

fn spec() -> MapSpec {
    MapSpec {
        base: SweepBase::paper(),
        friction: FrictionModel::None,
        settings: RunSettings {
            duration_s: 0.04,
            dt_s: 2e-6,
            rms_fraction: 0.5,
        },
        tolerances: Tolerances::default(),
    }
}

fn grid() -> Grid {
    Grid::new(vec![
        GridAxis {
            axis: Axis::FreqRatio,
            values: vec![1.0],
        },
        GridAxis {
            axis: Axis::GapM,
            values: vec![1e-4, 1e-3],
        },
    ])
    .unwrap()
}

#[test]
fn ensemble_is_reproducible_seed_sensitive_and_thread_count_independent() {
    let solver = Rk4 { dt_s: 2e-6 };
    let pts = grid().points();
    let run = |seed: u64, threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| run_ensemble(&spec(), &solver, &pts, &params(seed, 5), &|_, _| {}))
            .unwrap()
    };
    let a = run(11, 1);
    let b = run(11, 2);
    let c = run(12, 2);
    // Bit-identical for the same seed, whatever the thread count.
    assert_eq!(a, b);
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.mean_rms_m.to_bits(), y.mean_rms_m.to_bits());
        assert_eq!(x.std_rms_m.to_bits(), y.std_rms_m.to_bits());
    }
    assert_ne!(a[0].mean_rms_m.to_bits(), c[0].mean_rms_m.to_bits());
    for s in &a {
        assert_eq!(s.members, 5);
        assert_eq!(s.regimes.iter().map(|r| r.1).sum::<usize>(), 5);
        assert!(s.min_rms_m <= s.mean_rms_m && s.mean_rms_m <= s.max_rms_m);
        assert!(s.std_rms_m > 0.0); // different initial states, different transients
    }
    assert_eq!(a[0].point.index, 0);
    assert_eq!(a[1].point.index, 1);
}

fn one_point(ratio: f64, gap_m: f64) -> Vec<vibrobar_core::analysis::map::GridPoint> {
    Grid::new(vec![
        GridAxis {
            axis: Axis::FreqRatio,
            values: vec![ratio],
        },
        GridAxis {
            axis: Axis::GapM,
            values: vec![gap_m],
        },
    ])
    .unwrap()
    .points()
}

#[test]
fn impacting_members_counts_steady_state_impacts() {
    let solver = vibrobar_core::solver::Exact::default();
    let mut sp = spec();
    sp.settings = RunSettings {
        duration_s: 0.5,
        dt_s: 1e-6,
        rms_fraction: 0.8,
    };
    // Ball at rest (ẇ = u̇ = 0) within half of l_g of the centre of a 1 mm cavity, bar within
    // ±2 µm: frictionless, the ball never moves and the bar's amplitude (≈ 17 µm at r = 0.95)
    // stays far below the 250 µm of clearance left: no member can impact.
    let still = EnsembleParams {
        seed: 3,
        members: 8,
        ranges: IcRanges {
            u_m: (-2e-6, 2e-6),
            du_m_s: (0.0, 0.0),
            w_over_half_gap: (-0.5, 0.5),
            dw_m_s: (0.0, 0.0),
        },
    };
    let s = run_ensemble(&sp, &solver, &one_point(0.95, 1e-3), &still, &|_, _| {}).unwrap();
    assert_eq!(s[0].impacting_members, 0);
    assert_eq!(s[0].regimes, vec![(Regime::None, 8)]);
    // Same point, gap 0.1 mm, every ball started with 0.1–1 mm/s relative velocity: a free ball
    // without friction can only stay off the walls with a velocity exactly equal to the bar's
    // mean velocity (0); after impacts it keeps a nonzero one, crosses the 0.1 mm cavity in
    // ≲ 0.1 s and keeps hitting the walls throughout the window. Every member impacts.
    let moving = EnsembleParams {
        ranges: IcRanges {
            dw_m_s: (1e-4, 1e-3),
            ..still.ranges
        },
        ..still
    };
    let s = run_ensemble(&sp, &solver, &one_point(0.95, 1e-4), &moving, &|_, _| {}).unwrap();
    assert_eq!(s[0].impacting_members, 8);
    assert!(s[0].regimes.iter().all(|(r, _)| *r != Regime::None));
}
