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
    #[error("more than {limit} events before t = {t_s} s (raise the event limit, or check the parameters)")]
    TooManyEvents {
        /// The limit.
        limit: u64,
        /// Time reached.
        t_s: f64,
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
    /// The closed form has no bounded solution (undamped bar forced exactly at resonance).
    #[error("undamped bar forced exactly at its natural frequency ({omega_rad_s} rad/s): the response is unbounded; give damping_ratio > 0 or another frequency")]
    UndampedResonance {
        /// Forcing frequency.
        omega_rad_s: f64,
    },
}
