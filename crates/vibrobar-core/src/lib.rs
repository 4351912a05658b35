//! # vibrobar-core
//!
//! Model, solvers and analyses of a vibro-impact (impact-damped) boring bar: a lumped SDOF bar
//! with a free ball in a cavity, after the seed paper "The effect of rolling friction on
//! vibro-impact damped boring bars".
//!
//! * [`params`]: plain-data parameters in SI units, presets, validation.
//! * [`damper`]: the ball's laws, each in one place: friction (as published and dissipative),
//!   impact (Eqs. 4–5) and its plastic limit.
//! * [`model`]: the equations of motion and the mechanical energy.
//! * [`solver`]: the [`solver::Solver`] trait and its implementations.
//! * [`analysis`]: RMS, impact statistics, time histories, sweeps, energy audit.
//! * [`excitation`]: the cutting process (a delay equation), besides the harmonic forcing.
//! * [`structure`]: the bar as modes (lumped, Euler–Bernoulli beam, measured), computed once
//!   per run.
//! * [`euler_bernoulli`]: lumped `M`, `K` of a cantilever bar from its geometry.
//! * [`limits`]: every size limit and input range, with the one checking helper.
//!
//! No I/O happens here: progress is reported through callbacks, results are returned as data.

#![warn(missing_docs)]
#![deny(clippy::float_cmp)]

pub mod analysis;
pub mod damper;
pub mod error;
pub mod euler_bernoulli;
pub mod excitation;
pub mod limits;
pub mod model;
pub mod params;
pub mod solver;
pub mod structure;

pub use error::{EventLimitCause, ParamError, SimError};
pub use params::{
    Bar, Contact, ContactLaw, Damper, Forcing, Frequency, FrictionModel, Material, RunSettings,
    State, System,
};
pub use solver::{Observer, Solver};
