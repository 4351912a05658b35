//! The impact law (Eqs. 4–5) between ball and bar, and its plastic limit: one definition used by
//! `rk4` (in absolute velocities), `exact` (in relative ones, and for chatter summed to its
//! limit) and, through the events' energy losses, the energy audit.

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

#[cfg(test)]
mod tests {
    use super::*;

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
