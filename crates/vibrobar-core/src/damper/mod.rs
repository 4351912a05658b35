//! The ball's laws, each defined once and used by both solvers and by the energy audit:
//!
//! * [`friction`]: the sliding friction force on the ball (the paper's sign, which injects
//!   energy, or dissipative Coulomb), and what can hold the ball at relative rest;
//! * [`impact`]: the impact law (Eqs. 4–5), its plastic limit (a chatter sequence summed to
//!   its accumulation point), and the kinetic energy each removes;
//! * [`wall_impact`]: the impact of a spinning ball on a wall of its hole with Coulomb friction
//!   (the bar that bends in two planes).
//!
//! Sign convention: `w = v − u` (ball relative to bar). The force on the ball is `F_ball`, the
//! force on the bar `−F_ball` (friction is internal to the bar–ball pair), so the friction power
//! on the pair is `F_ball ẇ`.

pub mod contact;
pub mod friction;
pub mod impact;
pub mod wall_impact;
