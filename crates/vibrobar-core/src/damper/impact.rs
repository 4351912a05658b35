//! The impact law (Eqs. 4–5) between ball and bar, and its plastic limit: one definition used by
//! `rk4` (in absolute velocities), `exact` (in relative ones, and for chatter summed to its
//! limit) and, through the events' energy losses, the energy audit.
//!
//! The same law on a modal bar ([`modal_impact`]): a point impulse at the cavity `x_d`, put back
//! through the contact row `w = v − Σ φₙ(x_d) qₙ` (the lumped bar is its one-mode case, `φ = 1`).

/// Velocities after an impact in relative coordinates: `u̇+ = u̇− + μ(1+e)/(1+μ) ẇ−`,
/// `ẇ+ = −e ẇ−` (`μ = m_d/M`). Returns `(u̇+, ẇ+)`.
#[inline]
pub fn impact_relative(mass_ratio: f64, restitution: f64, du_m_s: f64, dw_m_s: f64) -> (f64, f64) {
    let du_plus = du_m_s + mass_ratio * (1.0 + restitution) / (1.0 + mass_ratio) * dw_m_s;
    (du_plus, -restitution * dw_m_s)
}

/// Velocities after an impact (Eqs. 4–5): [`impact_relative`] with `ẇ− = v̇− − u̇−`.
///
/// Returns `(u̇+, v̇+)`. Momentum `M u̇ + m_d v̇` is conserved exactly in exact arithmetic; the
/// kinetic-energy loss is [`impact_energy_loss_j`].
#[inline]
pub fn impact_map(mass_ratio: f64, restitution: f64, du_m_s: f64, dv_m_s: f64) -> (f64, f64) {
    let (du_plus, dw_plus) = impact_relative(mass_ratio, restitution, du_m_s, dv_m_s - du_m_s);
    (du_plus, du_plus + dw_plus)
}

/// Kinetic energy lost in one impact with pre-impact relative velocity `dw`:
/// `½ m_eff (1 − e²) ẇ−²`, `m_eff = M m_d / (M + m_d)`.
#[inline]
pub fn impact_energy_loss_j(
    bar_mass_kg: f64,
    ball_mass_kg: f64,
    restitution: f64,
    dw_m_s: f64,
) -> f64 {
    let m_eff = bar_mass_kg * ball_mass_kg / (bar_mass_kg + ball_mass_kg);
    0.5 * m_eff * (1.0 - restitution * restitution) * dw_m_s * dw_m_s
}

/// The limit of a chatter sequence (infinitely many impacts at one wall in a vanishing time):
/// bar and ball take the common momentum-conserving velocity. Returns `(v, loss)`: the common
/// velocity and the kinetic energy the sequence removed.
#[inline]
pub fn plastic_limit(bar_mass_kg: f64, ball_mass_kg: f64, du_m_s: f64, dv_m_s: f64) -> (f64, f64) {
    let (m, md) = (bar_mass_kg, ball_mass_kg);
    let mtot = m + md;
    let v = (m * du_m_s + md * dv_m_s) / mtot;
    let loss = 0.5 * m * du_m_s * du_m_s + 0.5 * md * dv_m_s * dv_m_s - 0.5 * mtot * v * v;
    (v, loss)
}

/// `1/m_eff = 1/m_d + Σ φₙ(x_d)²/mₙ`: the inverse effective mass of the ball–bar pair along the
/// contact row (`shape_cavity[n] = φₙ(x_d)`, `modal_mass_kg[n] = mₙ`, equal lengths). The bar's
/// own share `Σ φₙ²/mₙ` is `4N/(ρAL)` at the tip of a uniform bar: it grows without bound with
/// `N` (issue #8, "honesty about convergence").
#[inline]
pub fn modal_inverse_effective_mass_per_kg(
    ball_mass_kg: f64,
    shape_cavity: &[f64],
    modal_mass_kg: &[f64],
) -> f64 {
    let bar: f64 = shape_cavity
        .iter()
        .zip(modal_mass_kg)
        .map(|(p, m)| p * p / m)
        .sum();
    1.0 / ball_mass_kg + bar
}

/// What one modal impact did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModalImpact {
    /// Impulse `P = (1+e) ẇ− · m_eff` the ball gives the bar at `x_d` (the ball gets `−P`).
    pub impulse_n_s: f64,
    /// Kinetic energy lost, `½ m_eff (1 − e²) ẇ−²`.
    pub energy_loss_j: f64,
}

/// The impact law on a modal bar, applied in place: with `ẇ− = v̇ − Σ φₙ(x_d) q̇ₙ` (passed in as
/// `dw_m_s`) and `1/m_eff` from [`modal_inverse_effective_mass_per_kg`], the impulse
/// `P = (1+e) ẇ− m_eff` acts on the bar at `x_d` and `−P` on the ball:
/// `Δq̇ₙ = φₙ(x_d) P / mₙ`, `Δv̇ = −P/m_d`, so `ẇ+ = −e ẇ−`. The sign is the lumped law's
/// ([`impact_relative`]: the bar gains `m_eff (1+e) ẇ−` of momentum when the ball runs into it).
/// Each mode's generalised momentum changes by `φₙ P` and the ball's by `−P`, so
/// `mₙ q̇ₙ + φₙ(x_d) m_d v̇` is conserved for every `n`.
#[inline]
pub fn modal_impact(
    ball_mass_kg: f64,
    restitution: f64,
    shape_cavity: &[f64],
    modal_mass_kg: &[f64],
    dw_m_s: f64,
    dq_m_s: &mut [f64],
    dv_m_s: &mut f64,
) -> ModalImpact {
    let m_eff =
        1.0 / modal_inverse_effective_mass_per_kg(ball_mass_kg, shape_cavity, modal_mass_kg);
    let p = (1.0 + restitution) * dw_m_s * m_eff;
    for ((dq, phi), m) in dq_m_s.iter_mut().zip(shape_cavity).zip(modal_mass_kg) {
        *dq += phi * p / m;
    }
    *dv_m_s -= p / ball_mass_kg;
    ModalImpact {
        impulse_n_s: p,
        energy_loss_j: 0.5 * m_eff * (1.0 - restitution * restitution) * dw_m_s * dw_m_s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One mode with `φ = 1` is the lumped law: same velocities, same loss (to rounding; the
    /// two formulas round differently).
    #[test]
    fn modal_impact_with_one_unit_mode_is_the_lumped_law() {
        let (m, md, e) = (0.644, 0.026, 0.5);
        let (du, dv) = (0.31, -1.7);
        let (du_l, dv_l) = impact_map(md / m, e, du, dv);
        let (mut dq, mut dv_m) = ([du], dv);
        let r = modal_impact(md, e, &[1.0], &[m], dv - du, &mut dq, &mut dv_m);
        assert!((dq[0] - du_l).abs() <= 1e-15 && (dv_m - dv_l).abs() <= 1e-15);
        let loss = impact_energy_loss_j(m, md, e, dv - du);
        assert!((r.energy_loss_j - loss).abs() <= 1e-15 * loss);
        assert!(r.impulse_n_s < 0.0, "ẇ− < 0: the ball pulls the bar back");
    }

    /// The plastic limit is the impact map at `e = 0` (common velocity), and both lose the
    /// energy the loss formula gives.
    #[test]
    fn plastic_limit_is_the_impact_map_at_zero_restitution() {
        let (m, md) = (0.644, 0.026);
        let (du, dv) = (0.31, -1.7);
        let (v, loss) = plastic_limit(m, md, du, dv);
        let (du_p, dv_p) = impact_map(md / m, 0.0, du, dv);
        assert!((du_p - v).abs() <= 1e-15 && (dv_p - v).abs() <= 1e-15);
        let want = impact_energy_loss_j(m, md, 0.0, dv - du);
        assert!((loss - want).abs() <= 1e-14 * want, "{loss} {want}");
    }
}
