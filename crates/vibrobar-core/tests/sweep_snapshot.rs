//! A small deterministic sweep pinned to stored numbers, plus physics and determinism checks.

mod common;

use common::linear_bar_from_rest;
use vibrobar_core::analysis::{linspace_inclusive, sweep, SweepBase, SweepPoint, SweepRow};
use vibrobar_core::solver::Rk4;
use vibrobar_core::{FrictionModel, RunSettings};

const RATIOS: [f64; 3] = [0.99, 1.0, 1.01];

fn settings() -> RunSettings {
    RunSettings {
        duration_s: 0.1,
        dt_s: 1e-6,
        rms_fraction: 0.8,
    }
}

fn points() -> Vec<SweepPoint> {
    RATIOS
        .iter()
        .map(|&ratio| SweepPoint {
            ratio,
            gap_m: 0.1e-3,
            friction: FrictionModel::None,
            friction_force_n: None,
        })
        .collect()
}

fn run() -> Vec<SweepRow> {
    sweep(
        &points(),
        &SweepBase::paper(),
        &settings(),
        &Rk4 { dt_s: 1e-6 },
        &|_, _| {},
    )
    .unwrap()
}

/// Stored results of this sweep (rk4, dt = 1 µs, 0.1 s, RMS over the last 80 %):
/// `(ratio, solid RMS m, damped RMS m, damped impacts)`. The scheme is deterministic, so a change
/// beyond 1e-9 relative means the numerics changed: look why before updating these.
const EXPECTED: [(f64, f64, f64, u64); 3] = [
    (0.99, 4.1231373524278394e-5, 2.0190117321405234e-5, 84),
    (1.0, 4.9114732837010765e-5, 1.8297339463332543e-5, 86),
    (1.01, 4.0838941693659755e-5, 1.759106159518326e-5, 82),
];

#[test]
fn sweep_matches_stored_values() {
    let rows = run();
    for (r, &(ratio, solid, damped, impacts)) in rows.iter().zip(EXPECTED.iter()) {
        assert!((r.point.ratio - ratio).abs() < 1e-15);
        let es = (r.solid.rms_m / solid - 1.0).abs();
        let ed = (r.damped.rms_m / damped - 1.0).abs();
        assert!(
            es < 1e-9 && ed < 1e-9 && r.damped.impacts == impacts,
            "ratio {ratio}: solid {} m (stored {solid}, rel {es:.2e}), damped {} m (stored \
             {damped}, rel {ed:.2e}), impacts {} (stored {impacts})",
            r.solid.rms_m,
            r.damped.rms_m,
            r.damped.impacts
        );
    }
}

/// Solid-bar RMS of the sweep against the closed form from rest (transient included), whose
/// `∫u²` over the window is taken here by a fine composite Simpson rule.
#[test]
fn solid_rms_matches_closed_form() {
    let rows = run();
    let st = settings();
    let base = SweepBase::paper();
    for r in &rows {
        let sys = base.solid_system(r.point.ratio);
        let u = |t: f64| linear_bar_from_rest(&sys, t).0;
        let (t0, t1) = (st.window_start_s(), st.duration_s);
        let n = 200_000;
        let h = (t1 - t0) / n as f64;
        let mut acc = u(t0).powi(2) + u(t1).powi(2);
        for i in 1..n {
            let wgt = if i % 2 == 1 { 4.0 } else { 2.0 };
            acc += wgt * u(t0 + i as f64 * h).powi(2);
        }
        let rms = (acc * h / 3.0 / (t1 - t0)).sqrt();
        let rel = (r.solid.rms_m / rms - 1.0).abs();
        assert!(
            rel < 1e-8,
            "ratio {}: solid RMS {} m vs closed form {rms} m (rel {rel:.2e})",
            r.point.ratio,
            r.solid.rms_m
        );
        // And the damper helps near resonance (frictionless, 0.1 mm gap).
        assert!(
            r.reduction_pct() > 20.0,
            "ratio {}: reduction {:.1} %, want > 20 %",
            r.point.ratio,
            r.reduction_pct()
        );
    }
}

#[test]
fn paper_ratio_grid_is_eleven_points_from_the_index() {
    let g = linspace_inclusive(0.95, 1.05, 0.01);
    assert_eq!(g.len(), 11, "{g:?}");
    for (i, &r) in g.iter().enumerate() {
        let want = 0.95 + i as f64 * 0.01;
        assert!(
            r.to_bits() == want.to_bits(),
            "point {i}: {r} is not 0.95 + {i}·0.01 = {want}"
        );
    }
    assert!((g[10] - 1.05).abs() < 1e-12, "last point {}", g[10]);
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let with = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
            .install(run)
    };
    let (one, two) = (with(1), with(2));
    assert_eq!(one, two, "1 thread vs 2 threads differ");
}
