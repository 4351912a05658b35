//! The equations of motion and the mechanical energy of the bar–ball system. The ball's laws
//! (friction, impact) are in [`crate::damper`].
//!
//! Sign convention: `w = v − u` (ball relative to bar). The force on the ball is `F_ball`, the
//! force on the bar is `−F_ball` (friction is internal to the bar–ball pair).

use crate::damper::friction::sliding_friction_on_ball_n;
use crate::params::{State, System};

/// Mechanical energy of a lumped system: kinetic of bar and ball plus spring energy. `None` for
/// a modal bar, whose energy a public [`State`] cannot give (ask the segment:
/// [`crate::solver::Segment::mechanical_energy_j`]).
pub fn mechanical_energy_j(sys: &System, s: &State) -> Option<f64> {
    let bar = sys.lumped_bar()?;
    Some(lumped_mechanical_energy_j(
        bar.mass_kg,
        bar.stiffness_n_per_m,
        sys.damper.map(|d| d.ball_mass_kg),
        s,
    ))
}

/// `½Mu̇² + ½Ku² + ½m_d v̇²` (the ball's term only with a ball): the lumped formula, one
/// definition for the audit and the lumped solvers' segments.
pub fn lumped_mechanical_energy_j(
    mass_kg: f64,
    stiffness_n_per_m: f64,
    ball_mass_kg: Option<f64>,
    s: &State,
) -> f64 {
    let bar = 0.5 * mass_kg * s.du_m_s * s.du_m_s + 0.5 * stiffness_n_per_m * s.u_m * s.u_m;
    let ball = ball_mass_kg
        .map(|md| 0.5 * md * s.dv_m_s * s.dv_m_s)
        .unwrap_or(0.0);
    bar + ball
}

/// Right-hand side of Eqs. 1–3 for a sliding ball, as the paper integrates it (plus the ball's
/// body force along the gap, `damper.gravity_along_gap_m_s2`): returns `(ü, v̈)` at state `s` with the friction evaluated from this very state; `None` for
/// a modal bar (its right-hand side is in [`crate::solver::modal_rk4`]).
pub fn accelerations(sys: &System, s: &State) -> Option<(f64, f64)> {
    let bar = sys.lumped_bar()?;
    let c = bar.damping_n_s_per_m();
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
    let ddu = (f_ext - c * s.du_m_s - bar.stiffness_n_per_m * s.u_m - f_ball) / bar.mass_kg;
    let ddv = f_ball / m_d;
    // The ball's body force along the gap, `g_s` (nothing added without one).
    let ddv = match &sys.damper {
        Some(d) if d.gravity_along_gap_m_s2 != 0.0 => ddv + d.gravity_along_gap_m_s2,
        _ => ddv,
    };
    Some((ddu, ddv))
}
