//! The impact map (Eqs. 4–5) against the laws it must obey: momentum conservation, the
//! closed-form kinetic-energy loss `½ m_eff (1 − e²) ẇ−²`, and `ẇ+ = −e ẇ−`, over many random
//! pre-impact states.

use vibrobar_core::damper::impact::{impact_energy_loss_j, impact_map};

/// SplitMix64: a tiny deterministic generator, so the test needs no extra dependency.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `[lo, hi)`.
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }
}

fn kinetic(m_bar: f64, m_ball: f64, du: f64, dv: f64) -> f64 {
    0.5 * m_bar * du * du + 0.5 * m_ball * dv * dv
}

#[test]
fn momentum_energy_and_relative_velocity_over_random_states() {
    let mut rng = Rng(0x5EED_0001);
    for e in [0.0, 0.5, 1.0] {
        let (mut worst_p, mut worst_e, mut worst_w) = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..10_000 {
            let m_bar = rng.uniform(0.05, 5.0);
            let m_ball = rng.uniform(0.001, 1.0);
            let du = rng.uniform(-2.0, 2.0);
            let dv = rng.uniform(-2.0, 2.0);
            let mu = m_ball / m_bar;
            let (du_p, dv_p) = impact_map(mu, e, du, dv);
            let dw = dv - du;

            // Momentum, relative to the momentum scale of the state.
            let p0 = m_bar * du + m_ball * dv;
            let p1 = m_bar * du_p + m_ball * dv_p;
            let scale = m_bar * du.abs() + m_ball * dv.abs();
            worst_p = worst_p.max((p1 - p0).abs() / scale);

            // Energy lost equals the closed form ½ m_eff (1 − e²) ẇ−².
            let m_eff = m_bar * m_ball / (m_bar + m_ball);
            let loss_closed = 0.5 * m_eff * (1.0 - e * e) * dw * dw;
            let loss = kinetic(m_bar, m_ball, du, dv) - kinetic(m_bar, m_ball, du_p, dv_p);
            let e_scale = kinetic(m_bar, m_ball, du, dv);
            worst_e = worst_e.max((loss - loss_closed).abs() / e_scale);
            // The library's own loss formula agrees with the one written here.
            let lib = impact_energy_loss_j(m_bar, m_ball, e, dw);
            assert!(
                (lib - loss_closed).abs() <= 1e-14 * loss_closed.max(1e-300),
                "impact_energy_loss_j = {lib} vs closed form {loss_closed} (e = {e})"
            );

            // ẇ+ = −e ẇ−.
            let dw_p = dv_p - du_p;
            worst_w = worst_w.max((dw_p + e * dw).abs() / dw.abs().max(1e-300));
        }
        assert!(
            worst_p < 1e-14,
            "e = {e}: worst relative momentum change {worst_p:.3e}, want < 1e-14"
        );
        assert!(
            worst_e < 1e-13,
            "e = {e}: worst relative error of the energy loss {worst_e:.3e}, want < 1e-13"
        );
        assert!(
            worst_w < 1e-13,
            "e = {e}: worst relative error of ẇ+ = −e ẇ− {worst_w:.3e}, want < 1e-13"
        );
    }
}

#[test]
fn elastic_impact_conserves_kinetic_energy() {
    let mut rng = Rng(0x5EED_0002);
    for _ in 0..10_000 {
        let (m_bar, m_ball) = (rng.uniform(0.1, 2.0), rng.uniform(0.005, 0.5));
        let (du, dv) = (rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
        let (du_p, dv_p) = impact_map(m_ball / m_bar, 1.0, du, dv);
        let (k0, k1) = (
            kinetic(m_bar, m_ball, du, dv),
            kinetic(m_bar, m_ball, du_p, dv_p),
        );
        assert!(
            (k1 - k0).abs() <= 1e-14 * k0,
            "e = 1 changed kinetic energy: {k0} J → {k1} J (rel {:.3e})",
            (k1 - k0) / k0
        );
    }
}

#[test]
fn paper_numbers_one_impact() {
    // Paper bar and ball, e = 0.5: ẇ− = 0.1 m/s with the bar at rest.
    let (m_bar, m_ball, e) = (0.644, 0.026, 0.5);
    let (du_p, dv_p) = impact_map(m_ball / m_bar, e, 0.0, 0.1);
    // Hand computation: μ = 0.040373, u̇+ = μ·1.5/(1+μ)·0.1 = 5.8209e-3 m/s, ẇ+ = −0.05 m/s.
    let mu: f64 = 0.026 / 0.644;
    let du_hand = mu * 1.5 / (1.0 + mu) * 0.1;
    assert!(
        (du_p - du_hand).abs() < 1e-17,
        "u̇+ = {du_p}, hand {du_hand}"
    );
    assert!(
        (du_p - 5.8209e-3).abs() < 1e-7,
        "u̇+ = {du_p} m/s, want 5.8209e-3"
    );
    assert!(
        ((dv_p - du_p) + 0.05).abs() < 1e-16,
        "ẇ+ = {}, want −0.05",
        dv_p - du_p
    );
}
