//! Cavity placement on a beam (`analysis::placement`): closed-form checks and the physics the
//! study must show, on short modal RK4 runs.

use std::sync::atomic::{AtomicUsize, Ordering};
use vibrobar_core::analysis::placement::{
    mode_convergence, optimum, run, solver_case, summarise, CaseStats, PlacementGrid,
    PlacementPoint, PlacementRow, PlacementSpec, PointFailed,
};
use vibrobar_core::analysis::regime::{Regime, Tolerances};
use vibrobar_core::analysis::Runner;
use vibrobar_core::solver::Rk4;
use vibrobar_core::structure::{Beam, CavitySection};
use vibrobar_core::{Damper, Forcing, FrictionModel, RunSettings, System};

fn spec(beam: Beam, duration_s: f64) -> PlacementSpec {
    PlacementSpec {
        beam,
        ball: Damper::paper(0.1e-3, FrictionModel::None),
        forcing: Forcing::paper(1.0),
        gravity_m_s2: vibrobar_core::params::STANDARD_GRAVITY_M_S2,
        settings: RunSettings {
            duration_s,
            dt_s: 1e-6,
            rms_fraction: 0.5,
        },
        tolerances: Tolerances::default(),
    }
}

fn rows(s: &PlacementSpec, grid: &PlacementGrid) -> Vec<PlacementRow> {
    let rk4 = Rk4 {
        dt_s: s.settings.dt_s,
    };
    let case = solver_case(&rk4, s.settings, s.tolerances, false);
    let points: Vec<PlacementPoint> = (0..grid.len()).filter_map(|i| grid.point(i)).collect();
    run(
        s,
        grid,
        &points,
        Runner::default(),
        &case,
        |r| -> Result<PlacementRow, PointFailed> { Ok(r) },
    )
    .unwrap()
}

/// At the clamp every mode shape is 0 (to rounding: |φₙ(0)| ≤ 6e-17 of the tip value), so the
/// ball, frictionless and at rest, feels nothing and moves nothing: `w` stays below 1e-20 m, far
/// inside the gap, there is no impact, and the damped bar (the same beam: no cavity section) runs
/// the solid bar's equations step for step. Its RMS is the solid one to the bit: reduction 0
/// exactly, at every ratio and gap.
#[test]
fn a_cavity_at_the_clamp_changes_nothing_exactly() {
    let s = spec(Beam::default(), 0.05);
    for m in s.damped_model(0.0).unwrap().modes() {
        assert!(m.shape_cavity.abs() <= 6e-17, "φ(0) = {}", m.shape_cavity);
    }
    let grid = PlacementGrid::new(vec![0.0], vec![0.05e-3, 1e-3], vec![0.9, 1.0, 1.1]).unwrap();
    for r in rows(&s, &grid) {
        assert_eq!(r.mean_reduction_pct, 0.0, "{r:?}");
        assert_eq!(r.min_reduction_pct, 0.0, "{r:?}");
        assert_eq!(r.mean_impacts_per_cycle, 0.0, "{r:?}");
        assert_eq!(r.regime, Regime::None);
    }
}

/// The paper's bar at resonance with a 0.1 mm gap: the ball damps the first mode in proportion
/// to its share `φ₁(x_d)`; at 20 mm from the clamp (φ₁ ≈ 0.03) it barely moves the bar, at the
/// paper's position (38 mm from the free end, φ₁ ≈ 0.7) and at the tip it damps strongly.
#[test]
fn the_tip_beats_the_clamp_at_the_paper_geometry() {
    let s = spec(Beam::default(), 0.2);
    let grid = PlacementGrid::new(vec![0.02, 0.137, 0.175], vec![0.1e-3], vec![1.0]).unwrap();
    let r = rows(&s, &grid);
    eprintln!(
        "reductions near clamp / paper / tip: {:.2} / {:.2} / {:.2} %",
        r[0].mean_reduction_pct, r[1].mean_reduction_pct, r[2].mean_reduction_pct
    );
    assert!(r[0].mean_reduction_pct.abs() < 5.0, "{:?}", r[0]);
    assert!(r[2].mean_reduction_pct > r[0].mean_reduction_pct + 20.0);
    assert!(r[1].mean_reduction_pct > r[0].mean_reduction_pct + 20.0);
    let best = optimum(&r).unwrap();
    assert_ne!(best.point.index, 0);
}

#[test]
fn rows_summarise_the_band_and_the_optimum_breaks_ties_as_documented() {
    let st = |rms_m: f64, regime: Regime| CaseStats {
        rms_m,
        impacts_per_cycle: 2.0,
        regime,
        impact_loss_j: None,
        window_s: 1.0,
    };
    let p = PlacementPoint {
        index: 3,
        position_m: 0.1,
        gap_m: 1e-4,
    };
    let r = summarise(
        p,
        &[0.9, 1.0, 1.1],
        &[1.0, 4.0, 2.0],
        &[
            st(0.5, Regime::None),
            st(2.0, Regime::Chaotic),
            st(2.0, Regime::Sym2),
        ],
    );
    // Reductions 50, 50, 0 %: mean 33.3, min 0; worst RMS 2.0 at the lower of the tied ratios.
    assert!((r.mean_reduction_pct - 100.0 / 3.0).abs() < 1e-12);
    assert_eq!(r.min_reduction_pct, 0.0);
    assert_eq!((r.worst_rms_m, r.worst_ratio), (2.0, 1.0));
    assert_eq!(r.regime, Regime::Chaotic);
    assert_eq!(r.mean_impacts_per_cycle, 2.0);
    let row = |index: usize, mean: f64, worst: f64| PlacementRow {
        point: PlacementPoint { index, ..p },
        mean_reduction_pct: mean,
        worst_rms_m: worst,
        ..r
    };
    let rs = [
        row(0, 10.0, 1.0),
        row(1, 30.0, 2.0),
        row(2, 30.0, 1.5),
        row(3, 30.0, 1.5),
        row(4, f64::NAN, 0.1),
    ];
    assert_eq!(optimum(&rs).unwrap().point.index, 2);
    let mut rev = rs;
    rev.reverse();
    assert_eq!(optimum(&rev).unwrap().point.index, 2);
    assert!(optimum(&[]).is_none());
}

#[test]
fn positions_outside_the_bar_are_refused_before_any_run() {
    let holed = Beam {
        cavity_section: Some(CavitySection {
            hole_diameter_m: 0.018,
            length_m: 0.012,
        }),
        ..Beam::default()
    };
    let s = spec(holed, 0.01);
    assert_eq!(s.position_range_m(), (0.009, 0.175 - 0.009));
    let calls = AtomicUsize::new(0);
    let case = |_: &System| {
        calls.fetch_add(1, Ordering::Relaxed);
        Ok(CaseStats {
            rms_m: 1.0,
            impacts_per_cycle: 0.0,
            regime: Regime::None,
            impact_loss_j: None,
            window_s: 1.0,
        })
    };
    for x in [0.0, 0.17, -0.01, 0.2] {
        let grid = PlacementGrid::new(vec![0.1, x], vec![1e-4], vec![1.0]).unwrap();
        let points: Vec<_> = (0..grid.len()).filter_map(|i| grid.point(i)).collect();
        let e = run(&s, &grid, &points, Runner::default(), &case, |r| {
            Ok::<_, PointFailed>(r)
        })
        .unwrap_err()
        .to_string();
        assert!(e.contains("--positions-mm"), "{e}");
    }
    assert_eq!(calls.into_inner(), 0);
    assert!(PlacementGrid::new(vec![], vec![1e-4], vec![1.0])
        .unwrap_err()
        .to_string()
        .contains("--positions-mm"));
}

/// The inverse effective mass at the tip of a uniform bar is `4N/(ρAL)`: the study reports it
/// per N (the reason impacts at a point do not converge in N).
#[test]
fn convergence_rows_carry_the_growing_inverse_effective_mass() {
    let s = spec(Beam::default(), 0.02);
    let rk4 = Rk4 {
        dt_s: s.settings.dt_s,
    };
    let case = solver_case(&rk4, s.settings, s.tolerances, true);
    let rows =
        mode_convergence(&s, 0.175, 0.1e-3, 1.0, &[1, 2, 4], Runner::default(), &case).unwrap();
    let m = Beam::default().mass_kg();
    for r in &rows {
        let want = 4.0 * r.modes as f64 / m;
        assert!(
            (r.inverse_effective_mass_per_kg / want - 1.0).abs() < 1e-9,
            "{r:?}"
        );
        assert!(r.rms_solid_m.is_finite() && r.impact_loss_w >= 0.0);
    }
}
