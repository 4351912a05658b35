//! Design maps: grid indexing, shards, optimum on a synthetic table, a small real map.

use std::collections::BTreeSet;
use vibrobar_core::analysis::map::{
    compute_point, compute_solid, optimum, run_map, Axis, Grid, GridAxis, GridPoint, MapRow,
    MapSpec,
};
use vibrobar_core::analysis::regime::{Regime, Tolerances};
use vibrobar_core::analysis::SweepBase;
use vibrobar_core::solver::Rk4;
use vibrobar_core::{FrictionModel, RunSettings};

fn grid3() -> Grid {
    Grid::new(vec![
        GridAxis {
            axis: Axis::FreqRatio,
            values: vec![0.98, 0.99, 1.0],
        },
        GridAxis {
            axis: Axis::GapM,
            values: vec![1e-4, 2e-4, 5e-4, 1e-3],
        },
        GridAxis {
            axis: Axis::Restitution,
            values: vec![0.5, 0.8],
        },
    ])
    .unwrap()
}

#[test]
fn grid_index_is_row_major_last_axis_fastest() {
    let g = grid3();
    assert_eq!(g.len(), 24);
    let p = g.point(13).unwrap(); // 13 = 1·8 + 2·2 + 1
    assert_eq!(p.index, 13);
    assert_eq!(
        p.coords,
        vec![
            (Axis::FreqRatio, 0.99),
            (Axis::GapM, 5e-4),
            (Axis::Restitution, 0.8)
        ]
    );
    assert!(g.point(24).is_none());
    let pts = g.points();
    assert!(pts.iter().enumerate().all(|(i, p)| p.index == i));
    // Every coordinate combination exactly once.
    let combos: BTreeSet<Vec<u64>> = pts
        .iter()
        .map(|p| p.coords.iter().map(|c| c.1.to_bits()).collect())
        .collect();
    assert_eq!(combos.len(), 24);
}

#[test]
fn shards_partition_the_grid() {
    let g = grid3();
    for n in [1, 2, 3, 5, 7, 24, 30] {
        let mut seen = Vec::new();
        for k in 1..=n {
            let s = g.shard(k, n).unwrap();
            assert!(s.iter().all(|p| p.index % n == k - 1));
            assert!(s.windows(2).all(|w| w[0].index < w[1].index));
            // Shard sizes differ by at most one.
            assert!(s.len() == 24 / n || s.len() == 24 / n + 1);
            seen.extend(s);
        }
        seen.sort_by_key(|p| p.index);
        assert_eq!(seen, g.points(), "n = {n}");
    }
    assert!(g.shard(0, 3).is_err());
    assert!(g.shard(4, 3).is_err());
    assert!(g.shard(1, 0).is_err());
}

#[test]
fn bad_grids_are_rejected() {
    let ax = |axis, values| GridAxis { axis, values };
    assert!(Grid::new(vec![ax(Axis::GapM, vec![])]).is_err());
    assert!(Grid::new(vec![ax(Axis::GapM, vec![f64::NAN])]).is_err());
    assert!(Grid::new(vec![ax(Axis::GapM, vec![1e-4]), ax(Axis::GapM, vec![2e-4])]).is_err());
    for a in Axis::ALL {
        assert_eq!(Axis::parse(a.as_str()), Some(a));
    }
}

fn row(index: usize, ratio: f64, gap: f64, rms: f64, solid: f64) -> MapRow {
    MapRow {
        point: GridPoint {
            index,
            coords: vec![(Axis::FreqRatio, ratio), (Axis::GapM, gap)],
        },
        ratio,
        gap_m: gap,
        rms_solid_m: solid,
        rms_damped_m: rms,
        reduction_pct: 100.0 * (1.0 - rms / solid),
        impacts_per_cycle: 0.0,
        regime: Regime::None,
    }
}

#[test]
fn optimum_of_a_synthetic_table() {
    // Ratios 0.9, 1.0, 1.1 (solid RMS 1, 4, 1) × gaps A = 0.1 mm, B = 0.5 mm, C = 1 mm.
    // Reductions (%):   A: 10, 80, 10 (mean 33.3, max RMS 0.9)
    //                   B: 40, 60, 40 (mean 46.7, max RMS 1.6)
    //                   C: 30, 75, 20 (mean 41.7, max RMS 1.0)
    let (a, b, c) = (1e-4, 5e-4, 1e-3);
    let rows = vec![
        row(0, 0.9, a, 0.9, 1.0),
        row(1, 0.9, b, 0.6, 1.0),
        row(2, 0.9, c, 0.7, 1.0),
        row(3, 1.0, a, 0.8, 4.0),
        row(4, 1.0, b, 1.6, 4.0),
        row(5, 1.0, c, 1.0, 4.0),
        row(6, 1.1, a, 0.9, 1.0),
        row(7, 1.1, b, 0.6, 1.0),
        row(8, 1.1, c, 0.8, 1.0),
    ];
    let mut shuffled = rows.clone();
    shuffled.reverse();
    shuffled.swap(1, 5);
    for table in [&rows, &shuffled] {
        let o = optimum(table);
        let best: Vec<(f64, f64)> = o.per_ratio.iter().map(|r| (r.ratio, r.gap_m)).collect();
        assert_eq!(best, vec![(0.9, b), (1.0, a), (1.1, b)]);
        let m = o.best_mean_reduction.unwrap();
        assert_eq!(m.design, vec![(Axis::GapM, b)]);
        assert!((m.mean_reduction_pct - 140.0 / 3.0).abs() < 1e-9);
        assert_eq!(m.ratios, 3);
        let mm = o.best_minimax_rms.unwrap();
        assert_eq!(mm.design, vec![(Axis::GapM, a)]);
        assert!((mm.max_rms_damped_m - 0.9).abs() < 1e-12);
    }
    // A design missing a ratio is not a band candidate; NaN rows are ignored.
    let mut partial = rows.clone();
    partial.retain(|r| !(r.gap_m == a && r.ratio == 1.1));
    partial.push(row(9, 1.1, a, f64::NAN, 1.0));
    let o = optimum(&partial);
    assert_eq!(o.best_minimax_rms.unwrap().design, vec![(Axis::GapM, c)]);
    assert_eq!(o.per_ratio.len(), 3);
}

#[test]
fn small_real_map_shares_solid_runs_and_matches_single_points() {
    let spec = MapSpec {
        base: SweepBase::paper(),
        friction: FrictionModel::None,
        settings: RunSettings {
            duration_s: 0.06,
            dt_s: 2e-6,
            rms_fraction: 0.5,
        },
        tolerances: Tolerances::default(),
    };
    let g = Grid::new(vec![
        GridAxis {
            axis: Axis::FreqRatio,
            values: vec![0.9, 1.0],
        },
        GridAxis {
            axis: Axis::GapM,
            values: vec![1e-4, 1e-3],
        },
    ])
    .unwrap();
    let solver = Rk4 { dt_s: 2e-6 };
    let calls = std::sync::atomic::AtomicUsize::new(0);
    let rows = run_map(&spec, &solver, &g.points(), &|_, total| {
        assert_eq!(total, 6); // 2 solid runs + 4 points
        calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    })
    .unwrap();
    assert_eq!(calls.into_inner(), 6);
    assert_eq!(rows.len(), 4);
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r.point.index, i);
        let single = compute_point(&spec, &solver, &r.point).unwrap();
        assert_eq!(&single, r, "point {i}");
        let solid = compute_solid(&spec, &solver, r.ratio).unwrap();
        assert_eq!(solid.to_bits(), r.rms_solid_m.to_bits());
        assert!((r.reduction_pct - 100.0 * (1.0 - r.rms_damped_m / r.rms_solid_m)).abs() < 1e-12);
    }
    // 1 mm gap: no impact at either ratio, the damped bar is just a lighter, softer bar.
    for r in rows.iter().filter(|r| r.gap_m == 1e-3) {
        assert_eq!(r.regime, Regime::None);
        assert!(r.impacts_per_cycle.abs() < 1e-12);
    }
    // 0.1 mm at resonance impacts and helps.
    let res = &rows[2];
    assert_eq!((res.ratio, res.gap_m), (1.0, 1e-4));
    assert!(res.impacts_per_cycle > 0.0);
    assert_ne!(res.regime, Regime::None);
    assert!(res.reduction_pct > 20.0, "{}", res.reduction_pct);
    // One thread or two: the same rows, bit for bit.
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| run_map(&spec, &solver, &g.points(), &|_, _| {}))
        .unwrap();
    assert_eq!(one, rows);
    // The shard of a grid runs the same rows.
    let shard = run_map(&spec, &solver, &g.shard(2, 2).unwrap(), &|_, _| {}).unwrap();
    assert_eq!(shard, vec![rows[1].clone(), rows[3].clone()]);
}
