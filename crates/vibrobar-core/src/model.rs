//! The equations of motion and the mechanical energy of the bar–ball system. The ball's laws
//! (friction, impact) are in [`crate::damper`].
//!
//! Sign convention: `w = v − u` (ball relative to bar). The force on the ball is `F_ball`, the
//! force on the bar is `−F_ball` (friction is internal to the bar–ball pair).

use crate::damper::friction::sliding_friction_on_ball_n;
use crate::params::{State, System};

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
