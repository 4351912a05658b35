//! The impact of a spinning ball on a wall of its hole, with Coulomb friction, after Stronge
//! (*Impact Mechanics*, 2000): the law of the bar that bends in two planes.
//!
//! In the wall's frame (unit normal `n` from the ball's centre to the wall, tangent
//! `t = ẑ × n`, `ẑ` along the bar's axis) the contact point's relative velocity is the
//! approach `v_n = (v̇ − u̇)·n` and the slip `σ = (v̇ − u̇)·t + r·ω`. For a sphere on a bar
//! translating with the same mass `M` in every direction of its plane, the contact's
//! inverse-mass matrix is diagonal:
//!
//! * `W_nn = 1/m_d + 1/M`;
//! * `W_tt = 7/(2 m_d) + 1/M` (the ball's `1/m_d` and its spin's `r²/I = 5/(2 m_d)`).
//!
//! The normal impulse is Newton's, `P_n = (1 + e)·v_n⁻/W_nn`. The tangential impulse stops the
//! slip if friction can: if `|σ⁻| ≤ μ·W_tt·P_n`, `P_t = −σ⁻/W_tt` and the ball leaves rolling
//! (`σ⁺ = 0`); otherwise it slides through the whole impact, `P_t = −μ·P_n·sgn σ⁻`. There is no
//! tangential restitution. With a diagonal `W` Newton's and Stronge's energetic restitution
//! agree and the impact never gains energy; with `μ = 0` this is the one-plane law
//! ([`super::impact::impact_relative`]).

/// The impulses of one impact, on the ball (the bar takes the opposite ones).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallImpact {
    /// Normal impulse `P_n ≥ 0` on the ball, pointing away from the wall (along `−n`).
    pub normal_n_s: f64,
    /// Tangential impulse `P_t` on the ball along `t`, at the contact point.
    pub tangential_n_s: f64,
    /// The slip was stopped: the ball leaves the wall rolling.
    pub rolls: bool,
}

/// `W_nn = 1/m_d + 1/M`.
pub fn inverse_mass_normal_per_kg(ball_mass_kg: f64, bar_mass_kg: f64) -> f64 {
    1.0 / ball_mass_kg + 1.0 / bar_mass_kg
}

/// `W_tt = 7/(2 m_d) + 1/M` (a solid sphere).
pub fn inverse_mass_tangential_per_kg(ball_mass_kg: f64, bar_mass_kg: f64) -> f64 {
    3.5 / ball_mass_kg + 1.0 / bar_mass_kg
}

/// The impact at approach speed `approach_m_s = v_n⁻ ≥ 0` and slip `slip_m_s = σ⁻`, with
/// inverse masses `w_nn`, `w_tt`, restitution `e` and friction coefficient `μ`.
pub fn wall_impact(
    approach_m_s: f64,
    slip_m_s: f64,
    w_nn: f64,
    w_tt: f64,
    restitution: f64,
    mu: f64,
) -> WallImpact {
    let p_n = (1.0 + restitution) * approach_m_s.max(0.0) / w_nn;
    let stop = slip_m_s / w_tt;
    if stop.abs() <= mu * p_n {
        WallImpact {
            normal_n_s: p_n,
            tangential_n_s: -stop,
            rolls: true,
        }
    } else {
        WallImpact {
            normal_n_s: p_n,
            tangential_n_s: -mu * p_n * slip_m_s.signum(),
            rolls: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::damper::impact::impact_relative;

    const M: f64 = 0.644;
    const MD: f64 = 0.026;

    /// Apply an impact to (bar velocity, ball velocity, spin) in the wall frame `[n, t]`.
    fn apply(
        du: [f64; 2],
        dv: [f64; 2],
        om: f64,
        r: f64,
        p: &WallImpact,
    ) -> ([f64; 2], [f64; 2], f64) {
        let i = 0.4 * MD * r * r;
        let dv2 = [dv[0] - p.normal_n_s / MD, dv[1] + p.tangential_n_s / MD];
        let du2 = [du[0] + p.normal_n_s / M, du[1] - p.tangential_n_s / M];
        (du2, dv2, om + r * p.tangential_n_s / i)
    }

    fn kinetic(du: [f64; 2], dv: [f64; 2], om: f64, r: f64) -> f64 {
        0.5 * M * (du[0] * du[0] + du[1] * du[1])
            + 0.5 * MD * (dv[0] * dv[0] + dv[1] * dv[1])
            + 0.5 * 0.4 * MD * r * r * om * om
    }

    #[test]
    fn frictionless_impact_is_the_one_plane_law() {
        let (du, dv) = (0.01, 0.3);
        let (w_nn, w_tt) = (
            inverse_mass_normal_per_kg(MD, M),
            inverse_mass_tangential_per_kg(MD, M),
        );
        let p = wall_impact(dv - du, 0.2, w_nn, w_tt, 0.5, 0.0);
        let (du2, dv2, _) = apply([du, 0.0], [dv, 0.1], 5.0, 0.0075, &p);
        let (du_ref, dw_ref) = impact_relative(MD / M, 0.5, du, dv - du);
        assert!((du2[0] - du_ref).abs() < 1e-15);
        assert!((dv2[0] - du2[0] - dw_ref).abs() < 1e-15);
        assert!(p.tangential_n_s.abs() < 1e-300);
    }

    #[test]
    fn small_slip_leaves_the_ball_rolling_and_large_slip_slides() {
        let r = 0.0075;
        let (w_nn, w_tt) = (
            inverse_mass_normal_per_kg(MD, M),
            inverse_mass_tangential_per_kg(MD, M),
        );
        // Rolling exit: the contact point's slip after the impact is zero.
        let (du, dv, om) = ([0.0, 0.0], [0.2, 0.05], 0.0);
        let p = wall_impact(0.2, 0.05, w_nn, w_tt, 0.5, 0.3);
        assert!(p.rolls);
        let (du2, dv2, om2) = apply(du, dv, om, r, &p);
        let slip = dv2[1] - du2[1] + r * om2;
        assert!(slip.abs() < 1e-15, "slip after {slip}");
        assert!(kinetic(du2, dv2, om2, r) < kinetic(du, dv, om, r));
        // Sliding: the tangential impulse is μ·P_n against the slip, which keeps its sign.
        let p = wall_impact(0.2, 1.0, w_nn, w_tt, 0.5, 0.1);
        assert!(!p.rolls);
        assert!((p.tangential_n_s + 0.1 * p.normal_n_s).abs() < 1e-18);
        let (du2, dv2, om2) = apply(du, [0.2, 1.0], 0.0, r, &p);
        let slip = dv2[1] - du2[1] + r * om2;
        assert!(slip > 0.0 && slip < 1.0);
        assert!(kinetic(du2, dv2, om2, r) < kinetic(du, [0.2, 1.0], 0.0, r));
    }

    #[test]
    fn no_impact_gains_energy() {
        let r = 0.0075;
        let (w_nn, w_tt) = (
            inverse_mass_normal_per_kg(MD, M),
            inverse_mass_tangential_per_kg(MD, M),
        );
        let mut worst: f64 = f64::NEG_INFINITY;
        for i in 0..40 {
            for j in 0..40 {
                let slip = -2.0 + 0.1 * i as f64;
                let mu = 0.025 * j as f64;
                let dv = [0.3, slip];
                for e in [0.0, 0.5, 1.0] {
                    let p = wall_impact(0.3, slip, w_nn, w_tt, e, mu);
                    let (du2, dv2, om2) = apply([0.0; 2], dv, 0.0, r, &p);
                    let gain = kinetic(du2, dv2, om2, r) - kinetic([0.0; 2], dv, 0.0, r);
                    worst = worst.max(gain);
                }
            }
        }
        assert!(worst <= 1e-15, "an impact gained {worst} J");
    }
}
