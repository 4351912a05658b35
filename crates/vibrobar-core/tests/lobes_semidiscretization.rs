//! An independent check of the exact lobes (issue #13 §5): the zeroth-order averaged
//! semi-discretization of Insperger and Stépán (2002) of the same delay equation, and its
//! convergence to the exact boundary at O(Δt²).
//!
//! Kept in the tests, not in the library: it is a slow, approximate method whose only job is
//! to check [`vibrobar_core::analysis::lobes`] by a computation that shares nothing with it
//! (time domain, Floquet multipliers of a discrete map, no receptance, no phase condition).
//!
//! **The scheme.** Modal state `x = (q, q̇)`, tip `u = φᵀq`:
//! `ẋ = A x + r K_o b u(t − τ)` with `A = [[0, I], [−Ω² − K_o b M⁻¹φφᵀ, −2ZΩ]]`,
//! `r = (0, M⁻¹φ)`. With `τ = mΔt`, on `[tᵢ, tᵢ₊₁]` the delayed tip is held at the average of
//! its two neighbouring samples, `u(t − τ) ≈ (u_{i−m} + u_{i−m+1})/2`, and the rest is solved
//! exactly: `xᵢ₊₁ = P xᵢ + R (u_{i−m} + u_{i−m+1})/2`, `P = e^{AΔt}`,
//! `R = ∫₀^Δt e^{As} ds · r K_o b` (one matrix exponential of the augmented matrix). The cut
//! is stable iff every eigenvalue of the map on `(xᵢ, u_{i−1}, …, u_{i−m})` lies inside the
//! unit circle; the boundary `b` at a speed is where the spectral radius crosses 1.

use nalgebra::DMatrix;
use std::f64::consts::PI;
use vibrobar_core::analysis::lobes::{Linearisation, LobeTable, TipReceptance};
use vibrobar_core::structure::{Beam, ModalModel, Mode, Point, Structure};

const K_F: f64 = 2e9;

/// Spectral radius of the semi-discretized map at width `b`, `m` steps per delay `tau`.
fn spectral_radius(model: &ModalModel, b: f64, tau: f64, m: usize) -> f64 {
    let n = model.len();
    let modes = model.modes();
    let kb = K_F * b;
    let dt = tau / m as f64;
    // Augmented [[A, r], [0, 0]] so that its exponential holds P and ∫e^{As}ds·r.
    let mut a = DMatrix::<f64>::zeros(2 * n + 1, 2 * n + 1);
    for (i, mi) in modes.iter().enumerate() {
        a[(i, n + i)] = 1.0;
        let wn = mi.omega_rad_s;
        a[(n + i, i)] -= wn * wn;
        a[(n + i, n + i)] = -2.0 * mi.damping_ratio * wn;
        for (j, mj) in modes.iter().enumerate() {
            a[(n + i, j)] -=
                kb * mi.shape(Point::Force) * mj.shape(Point::Force) / mi.modal_mass_kg;
        }
        a[(n + i, 2 * n)] = kb * mi.shape(Point::Force) / mi.modal_mass_kg;
    }
    let e = (a * dt).exp();
    let dim = 2 * n + m;
    let mut phi = DMatrix::<f64>::zeros(dim, dim);
    // x_{i+1} = P x_i + R/2 (u_{i−m+1} + u_{i−m}); u_{i−k} sits at 2n + k − 1.
    for i in 0..2 * n {
        for j in 0..2 * n {
            phi[(i, j)] = e[(i, j)];
        }
        let half_r = 0.5 * e[(i, 2 * n)];
        phi[(i, 2 * n + m - 1)] += half_r;
        if m == 1 {
            for (j, mj) in modes.iter().enumerate() {
                phi[(i, j)] += half_r * mj.shape(Point::Force);
            }
        } else {
            phi[(i, 2 * n + m - 2)] += half_r;
        }
    }
    // The new u_i = φᵀ q_i, and the older samples shift by one.
    for (j, mj) in modes.iter().enumerate() {
        phi[(2 * n, j)] = mj.shape(Point::Force);
    }
    for k in 1..m {
        phi[(2 * n + k, 2 * n + k - 1)] = 1.0;
    }
    phi.complex_eigenvalues()
        .iter()
        .map(|z| z.norm())
        .fold(0.0, f64::max)
}

/// The semi-discretized boundary near `b_guess`: the root of `ρ(b) − 1` (bisection on a
/// bracket that starts stable and ends unstable), to 1e-12 relative.
fn sd_boundary(model: &ModalModel, b_guess: f64, tau: f64, m: usize) -> f64 {
    let f = |b: f64| spectral_radius(model, b, tau, m) - 1.0;
    let (mut lo, mut hi) = (0.7 * b_guess, 1.3 * b_guess);
    assert!(
        f(lo) < 0.0 && f(hi) > 0.0,
        "bracket [{lo}, {hi}] at m = {m}"
    );
    while hi - lo > 1e-12 * hi {
        let mid = 0.5 * (lo + hi);
        if f(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

fn one_mode() -> ModalModel {
    let w = 2.0 * PI * 600.0;
    Structure::Measured(vec![Mode {
        omega_rad_s: w,
        damping_ratio: 0.01,
        modal_mass_kg: 2.2e6 / (w * w),
        shape_cavity: 1.0,
        shape_force: 1.0,
        shape_response: 1.0,
    }])
    .modal_model()
    .unwrap()
}

/// At each speed: the exact boundary and its chatter period `T_c`; the semi-discretization at
/// `Δt = τ/m` for `m = m₀, 2m₀, 4m₀` with `Δt(m₀) ≤ T_c/20`; the errors against the exact
/// boundary shrink by 4 per halving (observed order in [1.8, 2.2]).
#[test]
fn semi_discretization_converges_to_the_exact_boundary_at_second_order() {
    let two_modes = Beam {
        modes: Some(2),
        ..Beam::default()
    }
    .modal_model()
    .unwrap();
    // One mode: at the lowest point of lobe 1, on a steep flank between lobes 0 and 1, on
    // lobe 0, and at a high speed; two modes (the paper's beam) at one speed.
    let mut cases: Vec<(ModalModel, f64)> = Vec::new();
    let one = one_mode();
    let t1 = LobeTable::new(TipReceptance::new(&one, Linearisation::BallFree).unwrap()).unwrap();
    cases.push((one, t1.lobe_minimum_rpm(1)));
    cases.push((one, 0.5 * (t1.lobe_minimum_rpm(0) + t1.lobe_minimum_rpm(1))));
    cases.push((one, 0.93 * t1.lobe_minimum_rpm(0)));
    cases.push((one, 52_000.0));
    cases.push((two_modes, 30_000.0));
    for (model, rpm) in cases {
        let mut t =
            LobeTable::new(TipReceptance::new(&model, Linearisation::BallFree).unwrap()).unwrap();
        let exact = t.boundary_at(rpm, K_F).unwrap();
        let tau = 60.0 / rpm;
        let t_c = 1.0 / exact.chatter_frequency_hz;
        let m0 = (20.0 * tau / t_c).ceil() as usize;
        let errs: Vec<f64> = [m0, 2 * m0, 4 * m0]
            .iter()
            .map(|&m| {
                assert!(tau / m as f64 <= t_c / 20.0);
                sd_boundary(&model, exact.b_lim_m, tau, m) / exact.b_lim_m - 1.0
            })
            .collect();
        let orders: Vec<f64> = errs.windows(2).map(|e| (e[0] / e[1]).log2()).collect();
        println!(
            "N = {} at {rpm:.1} rpm: b_lim = {:.6e} m, lobe {}, m0 = {m0}; relative errors {:.3e} {:.3e} {:.3e}; observed orders {:.3} {:.3}",
            model.len(),
            exact.b_lim_m,
            exact.lobe,
            errs[0],
            errs[1],
            errs[2],
            orders[0],
            orders[1]
        );
        for p in orders {
            assert!((1.8..=2.2).contains(&p), "order {p} at {rpm} rpm");
        }
    }
}
