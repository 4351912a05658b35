//! The physics shared by every solver: friction law, impact law, equations of motion.
//!
//! Sign convention: `w = v − u` (ball relative to bar). The force on the ball is `F_ball`, the
//! force on the bar is `−F_ball` (friction is internal to the bar–ball pair).

use crate::params::{FrictionModel, State, System};

/// Sign function with `sgn(0) = 0`, as in the paper's Eq. 3.
pub fn sgn0(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// Friction force on the ball while sliding with relative velocity `dw` (`F_ball`).
///
/// * `AsPublished`: `+F sgn(ẇ)` (Eq. 2): power `F_ball·ẇ ≥ 0`, it injects energy.
/// * `Coulomb`: `−F sgn(ẇ)`: power `≤ 0`, it dissipates.
///
/// At `ẇ = 0` this returns 0; the sticking force of `Coulomb` is the solvers' business.
pub fn sliding_friction_on_ball_n(model: FrictionModel, level_n: f64, dw_m_s: f64) -> f64 {
    match model {
        FrictionModel::None => 0.0,
        FrictionModel::AsPublished => level_n * sgn0(dw_m_s),
        FrictionModel::Coulomb => -level_n * sgn0(dw_m_s),
    }
}

/// Velocities after an impact (Eqs. 4–5): `u̇+ = u̇− + μ(1+e)/(1+μ) ẇ−`, `ẇ+ = −e ẇ−`.
///
/// Returns `(u̇+, v̇+)`. Momentum `M u̇ + m_d v̇` is conserved exactly in exact arithmetic; the
/// kinetic-energy loss is `½ m_eff (1 − e²) ẇ−²` with `m_eff = M m_d / (M + m_d)`.
pub fn impact_map(mass_ratio: f64, restitution: f64, du_m_s: f64, dv_m_s: f64) -> (f64, f64) {
    let dw = dv_m_s - du_m_s;
    let du_plus = du_m_s + mass_ratio * (1.0 + restitution) / (1.0 + mass_ratio) * dw;
    let dw_plus = -restitution * dw;
    (du_plus, du_plus + dw_plus)
}

/// Kinetic energy lost in one impact with pre-impact relative velocity `dw`.
pub fn impact_energy_loss_j(
    bar_mass_kg: f64,
    ball_mass_kg: f64,
    restitution: f64,
    dw_m_s: f64,
) -> f64 {
    let m_eff = bar_mass_kg * ball_mass_kg / (bar_mass_kg + ball_mass_kg);
    0.5 * m_eff * (1.0 - restitution * restitution) * dw_m_s * dw_m_s
}

/// Mechanical energy: kinetic of bar and ball plus spring energy.
pub fn mechanical_energy_j(sys: &System, s: &State) -> f64 {
    let bar = 0.5 * sys.bar.mass_kg * s.du_m_s * s.du_m_s
        + 0.5 * sys.bar.stiffness_n_per_m * s.u_m * s.u_m;
    let ball = sys
        .damper
        .map(|d| 0.5 * d.ball_mass_kg * s.dv_m_s * s.dv_m_s)
        .unwrap_or(0.0);
    bar + ball
}

/// Right-hand side of Eqs. 1–3 for a sliding ball, as the paper integrates it:
/// returns `(ü, v̈)` at state `s` with the friction evaluated from this very state.
pub fn accelerations(sys: &System, s: &State) -> (f64, f64) {
    let c = sys.bar.damping_n_s_per_m();
    let f_ext = sys.force_n(s.t_s);
    let (f_ball, m_d) = match &sys.damper {
        Some(d) => (
            sliding_friction_on_ball_n(
                d.friction,
                d.friction_level_n(sys.gravity_m_s2),
                s.dw_m_s(),
            ),
            d.ball_mass_kg,
        ),
        None => (0.0, 1.0),
    };
    let ddu = (f_ext - c * s.du_m_s - sys.bar.stiffness_n_per_m * s.u_m - f_ball) / sys.bar.mass_kg;
    let ddv = f_ball / m_d;
    (ddu, ddv)
}
