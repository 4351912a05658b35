//! Errors of the core crate. Variants carry the numbers that went wrong.

use thiserror::Error;

/// A parameter outside its allowed range.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ParamError {
    /// NaN or infinite.
    #[error("{field} must be a finite number, got {value}")]
    NotFinite {
        /// Field name, as in the scenario file.
        field: &'static str,
        /// Offending value.
        value: f64,
    },
    /// Finite but outside the allowed range.
    #[error("{field} = {value} is outside the allowed range {allowed}")]
    OutOfRange {
        /// Field name, as in the scenario file.
        field: &'static str,
        /// Offending value.
        value: f64,
        /// Allowed range, in interval notation.
        allowed: &'static str,
    },
}

/// A simulation that could not be completed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SimError {
    /// Invalid input.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// More events than the configured limit: bounded work instead of a hang.
    #[error(
        "more than {limit} events before t = {t_s} s ({events_per_period:.3e} per forcing period \
         at the end): {cause}"
    )]
    TooManyEvents {
        /// The limit.
        limit: u64,
        /// Time reached.
        t_s: f64,
        /// Event rate over the last events before the limit, per forcing period.
        events_per_period: f64,
        /// What those last events were doing.
        cause: EventLimitCause,
    },
    /// The ball left the cavity by more than the tolerance.
    #[error("ball outside the cavity at t = {t_s} s: |w| = {w_m} m > l_g = {half_gap_m} m")]
    Confinement {
        /// Time.
        t_s: f64,
        /// Relative displacement.
        w_m: f64,
        /// Half gap.
        half_gap_m: f64,
    },
    /// The state became NaN or infinite.
    #[error("state is not finite at t = {t_s} s")]
    NonFinite {
        /// Time.
        t_s: f64,
    },
    /// The closed form has no bounded solution: an undamped bar (`damping_ratio = 0`) forced at
    /// its natural frequency, to rounding.
    #[error("undamped bar (damping_ratio = 0) forced at its natural frequency ({omega_rad_s:e} rad/s) to rounding: the response grows without bound; give damping_ratio > 0 or another frequency")]
    UndampedResonance {
        /// Forcing frequency.
        omega_rad_s: f64,
    },
    /// The forced response cannot be computed in floating point: the dynamic stiffness
    /// `|K − MΩ² + iCΩ|` is so small that its square leaves the normal range of `f64` (e.g. a
    /// bar of `K = 1e-300 N/m`, damped or not), or the response amplitude overflows.
    #[error("forced response outside floating-point range: the dynamic stiffness |K − MΩ² + iCΩ| = {dynamic_stiffness_n_per_m:e} N/m (mass {mass_kg:e} kg, Ω = {omega_rad_s:e} rad/s) gives an amplitude F0/|…| = {amplitude_m:e} m; give a realistic stiffness_n_per_m, mass or force")]
    ResponseOutOfRange {
        /// `|K − MΩ² + iCΩ|` of the oscillating mass.
        dynamic_stiffness_n_per_m: f64,
        /// The oscillating mass (bar, or bar and ball together).
        mass_kg: f64,
        /// Forcing frequency.
        omega_rad_s: f64,
        /// `F0/|K − MΩ² + iCΩ|` (may be infinite).
        amplitude_m: f64,
    },
}

/// The likely cause of [`SimError::TooManyEvents`], read off the last events before the limit.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum EventLimitCause {
    /// `e = 1` without friction: the ball bounces elastically on a wall the bar presses it
    /// onto; the bounces shrink towards nothing but, elastic, never end.
    #[error("the ball micro-bounces elastically (restitution = 1, no friction) on a wall, impacts at up to {largest_dw_m_s:.3e} m/s that never die out; with restitution < 1 (or coulomb friction) such a sequence is summed to its end")]
    ElasticMicroBouncing {
        /// Largest relative impact speed among the last events.
        largest_dw_m_s: f64,
    },
    /// The as-published friction law puts energy in (`F_ball ẇ ≥ 0`); the relative motion ran
    /// away to large speeds.
    #[error("the as-published friction law injects energy: the relative speed of the ball ran away to {largest_dw_m_s:.3e} m/s; use friction = coulomb for dissipative friction, or a smaller friction force")]
    FrictionRunaway {
        /// Largest relative speed at an impact among the last events.
        largest_dw_m_s: f64,
    },
    /// The ball rests on a wall: contact, release and grazing impacts follow each other.
    #[error("the ball rests on a wall: contact, release and grazing touches alternate")]
    RestingOnWall,
    /// Stick and slip alternate (`coulomb`).
    #[error("the ball alternates between sticking and sliding")]
    StickSlip,
    /// None of the above: simply a dense sequence of events.
    #[error("a dense sequence of impacts and friction switches; raise the event limit if the run is meant to have that many")]
    Dense,
}
