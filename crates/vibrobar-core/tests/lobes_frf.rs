//! Lobes straight from a measured receptance: sampled from a model on lines Δf ≤ 0.5 Hz apart
//! and interpolated by the natural spline, they equal that model's exact lobes
//! ([`vibrobar_core::analysis::lobes`]) to 1e-6; coarse lines are flagged as under-resolved.

use num_complex::Complex64;
use std::f64::consts::PI;
use vibrobar_core::analysis::lobes::{Linearisation, LobeTable, TipReceptance};
use vibrobar_core::analysis::lobes_frf::{peak_resolution, FrfLobeTable};
use vibrobar_core::structure::frf_data::{FrfKind, MeasuredFrf};
use vibrobar_core::structure::{ModalModel, Mode, Structure};

const K_O: f64 = 2e9;

/// Three modes as a tap test would see them (shapes 1 at the tip).
fn three_modes() -> ModalModel {
    let modes = [
        (620.0, 0.02, 0.25),
        (1830.0, 0.02, 0.4),
        (4100.0, 0.03, 0.9),
    ];
    Structure::Measured(
        modes
            .iter()
            .map(|&(f, z, m)| Mode {
                omega_rad_s: 2.0 * PI * f,
                damping_ratio: z,
                modal_mass_kg: m,
                shape_cavity: 1.0,
                shape_force: 1.0,
                shape_response: 1.0,
            })
            .collect(),
    )
    .modal_model()
    .unwrap()
}

/// The model's receptance on lines `df` apart from `f0` to `f1`, as a kind.
fn sampled(model: &ModalModel, df: f64, f0: f64, f1: f64, kind: FrfKind) -> MeasuredFrf {
    let rec = TipReceptance::new(model, Linearisation::BallFree).unwrap();
    let n = ((f1 - f0) / df).round() as usize;
    let freqs: Vec<f64> = (0..=n).map(|i| f0 + i as f64 * df).collect();
    let values: Vec<Complex64> = freqs.iter().map(|&f| rec.eval(2.0 * PI * f).0).collect();
    MeasuredFrf::new(
        freqs,
        values,
        FrfKind::Receptance,
        None,
        true,
        String::new(),
    )
    .unwrap()
    .to_kind(kind)
    .unwrap()
}

fn rel(a: f64, b: f64) -> f64 {
    (a / b - 1.0).abs()
}

#[test]
fn lobes_of_a_sampled_model_equal_its_exact_lobes() {
    let model = three_modes();
    let mut exact =
        LobeTable::new(TipReceptance::new(&model, Linearisation::BallFree).unwrap()).unwrap();
    // The band holds every resonance with room (2 Hz to 12 kHz), lines 0.5 Hz apart; the
    // accelerance of the same model gives the same lobes after conversion.
    for kind in [FrfKind::Receptance, FrfKind::Accelerance] {
        let frf = sampled(&model, 0.5, 2.0, 12_000.0, kind);
        let table = FrfLobeTable::new(&frf).unwrap();
        let (s_exact, w_exact) = exact.minimum();
        let (s, w) = table.minimum();
        assert!(rel(s, s_exact) < 1e-6, "minimum {s} vs {s_exact}");
        assert!(rel(w, w_exact) < 1e-6, "at {w} vs {w_exact}");
        let mut worst: f64 = 0.0;
        let mut n = 0;
        let mut rpm = 1500.0;
        while rpm <= 60_000.0 {
            let a = exact.boundary_at(rpm, K_O).unwrap();
            let b = table.boundary_at(rpm, K_O).unwrap();
            assert_eq!(a.lobe, b.lobe, "lobe at {rpm} rpm");
            let d =
                rel(b.b_lim_m, a.b_lim_m).max(rel(b.chatter_frequency_hz, a.chatter_frequency_hz));
            worst = worst.max(d);
            n += 1;
            rpm *= 1.01;
        }
        assert!(n > 300);
        assert!(
            worst < 1e-6,
            "{kind:?}: worst relative difference {worst:e}"
        );
        eprintln!("{kind:?}: {n} speeds, worst relative difference {worst:e}");
    }
}

#[test]
fn coarse_lines_are_under_resolved_and_less_accurate() {
    let model = three_modes();
    // ζ·f of the first mode is 0.02·620 = 12.4 Hz: at 4 Hz lines it has 3 lines (< 5).
    let coarse = sampled(&model, 4.0, 4.0, 12_000.0, FrfKind::Receptance);
    let peaks = peak_resolution(&coarse).unwrap();
    let first = peaks
        .iter()
        .find(|p| (p.peak_hz - 620.0).abs() < 10.0)
        .unwrap();
    assert!(first.under_resolved, "{peaks:?}");
    let fine = sampled(&model, 0.5, 2.0, 12_000.0, FrfKind::Receptance);
    let peaks = peak_resolution(&fine).unwrap();
    assert_eq!(peaks.len(), 3, "{peaks:?}");
    assert!(peaks.iter().all(|p| !p.under_resolved), "{peaks:?}");
    // Half the half-power bandwidth ≈ ζ·f (neighbouring modes shift it by a few per cent).
    let mut by_f = peaks.clone();
    by_f.sort_by(|a, b| a.peak_hz.total_cmp(&b.peak_hz));
    // The third, 40× below the first, sits on the others' tails: 15 % off.
    let expect = [
        (0.02 * 620.0, 0.05),
        (0.02 * 1830.0, 0.05),
        (0.03 * 4100.0, 0.2),
    ];
    for (p, (fz, tol)) in by_f.iter().zip(expect) {
        assert!(rel(p.zeta_f_hz, fz) < tol, "{p:?} vs {fz}");
    }
    // Coarse lines (ζ·f ≈ 3 Δf) move the lowest point of the lobes beyond 1e-6 (measured 1.8e-6).
    let exact =
        LobeTable::new(TipReceptance::new(&model, Linearisation::BallFree).unwrap()).unwrap();
    let (s, _) = FrfLobeTable::new(&coarse).unwrap().minimum();
    let e = rel(s, exact.minimum().0);
    assert!(e > 1e-6, "{e:e}");
}

#[test]
fn a_speed_with_no_chatter_frequency_in_the_band_is_an_error() {
    // A band that stops below the only region of Re G < 0 of the lowest mode.
    let model = three_modes();
    let frf = sampled(&model, 0.5, 2.0, 500.0, FrfKind::Receptance);
    let t = FrfLobeTable::new(&frf).unwrap();
    let e = t.boundary_at(3000.0, K_O).unwrap_err().to_string();
    assert!(e.contains("measured band"), "{e}");
    assert!(t.boundary_at(0.5, K_O).is_err());
}
