//! The linearised N-mode cutting DDE computed independently of the library (the receptance
//! summed over the modes, the stability limit by lobe crossings, Newton on the characteristic
//! equation): shared by `modal_cutting.rs` and `modal_cutting_three_quarter.rs`, which
//! include it with `#[path]` and have `KF` in scope.
use super::KF;
use num_complex::Complex64 as C;
use vibrobar_core::structure::Mode;

/// The receptance at the force point `Σ φ_f²/(mₙs² + cₙs + kₙ)` and its derivative.
pub fn receptance(modes: &[Mode], s: C) -> (C, C) {
    let (mut g, mut dg) = (C::new(0.0, 0.0), C::new(0.0, 0.0));
    for m in modes {
        let k = m.modal_mass_kg * m.omega_rad_s * m.omega_rad_s;
        let c = 2.0 * m.damping_ratio * (k * m.modal_mass_kg).sqrt();
        let d = s * s * m.modal_mass_kg + s * c + k;
        let phi2 = m.shape_force * m.shape_force;
        g += phi2 / d;
        dg -= phi2 * (s * 2.0 * m.modal_mass_kg + c) / (d * d);
    }
    (g, dg)
}

/// The N-mode stability limit at `rpm`, independently of the library: on each lobe the chatter
/// frequency solves `ωT = 3π + 2 arg G(iω) + 2πj` (a grid for the crossings, then bisection),
/// `b = −1/(2 K_f Re G)`, the minimum over the lobes. Returns `(b_lim, ω_c)`.
pub fn b_lim_n(modes: &[Mode], rpm: f64) -> (f64, f64) {
    let tau = 60.0 / rpm;
    let w_hi = 1.5 * modes.iter().map(|m| m.omega_rad_s).fold(0.0, f64::max);
    let w_lo = 0.5 * modes[0].omega_rad_s;
    let r = |w: f64| {
        let g = receptance(modes, C::new(0.0, w)).0;
        (
            (w * tau - 3.0 * std::f64::consts::PI - 2.0 * g.arg()) / (2.0 * std::f64::consts::PI),
            g,
        )
    };
    let n = 200_000;
    let mut best = (f64::INFINITY, 0.0);
    let mut prev = (w_lo, r(w_lo));
    for i in 1..=n {
        let w = w_lo + (w_hi - w_lo) * i as f64 / n as f64;
        let cur = r(w);
        if cur.0.floor() != prev.1 .0.floor() && cur.1.re < 0.0 && prev.1 .1.re < 0.0 {
            let j = cur.0.floor().max(prev.1 .0.floor());
            let (mut lo, mut hi) = (prev.0, w);
            let up = cur.0 > prev.1 .0;
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                if (r(mid).0 >= j) == up {
                    hi = mid
                } else {
                    lo = mid
                }
            }
            let wm = 0.5 * (lo + hi);
            let g = r(wm).1;
            let b = -1.0 / (2.0 * KF * g.re);
            if b < best.0 {
                best = (b, wm);
            }
        }
        prev = (w, cur);
    }
    best
}

/// Newton on `f(s) = 1 + k_c(1 − e^{−sT})G(s) = 0` from `s`; `None` if it does not converge.
pub fn newton_root(modes: &[Mode], kc: f64, tau: f64, mut s: C) -> Option<C> {
    for _ in 0..100 {
        let (g, dg) = receptance(modes, s);
        let e = (-s * tau).exp();
        let f = 1.0 + kc * (1.0 - e) * g;
        let df = kc * (tau * e * g + (1.0 - e) * dg);
        let ds = f / df;
        s -= ds;
        if !s.re.is_finite() || !s.im.is_finite() {
            return None;
        }
        if ds.norm() < 1e-13 * s.norm() {
            return Some(s);
        }
    }
    None
}

/// The rightmost characteristic root of the N-mode DDE with `Im s` in the modes' band: Newton
/// from `iω_c` and from a grid of starting points `−0.01ω + iω` over `[0.3ω₁, 1.5ω_N]`, the
/// largest real part among the converged roots.
pub fn root_n(modes: &[Mode], b: f64, rpm: f64, w_c: f64) -> C {
    let tau = 60.0 / rpm;
    let kc = KF * b;
    let w_hi = 1.5 * modes.iter().map(|m| m.omega_rad_s).fold(0.0, f64::max);
    let w_lo = 0.3 * modes[0].omega_rad_s;
    let mut best = newton_root(modes, kc, tau, C::new(0.0, w_c)).expect("root near ω_c");
    let n = 3000;
    for i in 0..=n {
        let w = w_lo + (w_hi - w_lo) * i as f64 / n as f64;
        if let Some(r) = newton_root(modes, kc, tau, C::new(-0.01 * w, w)) {
            if r.im > 0.0 && r.re > best.re {
                best = r;
            }
        }
    }
    best
}
