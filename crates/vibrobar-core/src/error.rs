//! Errors of the core crate. Variants carry the numbers that went wrong.

use thiserror::Error;

/// A parameter outside its allowed range, a size beyond its limit, or an input that made a
/// result meaningless. Numbers are printed compactly ([`Compact`]).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ParamError {
    /// NaN or infinite.
    #[error("{field} must be a finite number, got {}", Compact(*value))]
    NotFinite {
        /// Field name, as in the scenario file.
        field: &'static str,
        /// Offending value.
        value: f64,
    },
    /// Finite but outside the allowed range.
    #[error("{field} = {} is outside the allowed range {allowed}", Compact(*value))]
    OutOfRange {
        /// Field name, as in the scenario file.
        field: &'static str,
        /// Offending value.
        value: f64,
        /// Allowed range, in interval notation.
        allowed: &'static str,
    },
    /// A size or derived quantity outside a limit of [`crate::limits`] (the bounds come from its
    /// constants, so the message always states the limit in force).
    #[error("{field} = {} is outside the allowed range [{}, {}]{}", Compact(*value), Compact(*min), Compact(*max), why_suffix(why))]
    Limit {
        /// Field or flag name, e.g. `ensemble.members (--members)`.
        field: &'static str,
        /// Offending value (a count, or the derived quantity).
        value: f64,
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
        /// Why the limit exists or how to get within it (may be empty).
        why: &'static str,
    },
    /// A fixed-step integration blew up although its step passed the stability check.
    #[error("{solver} diverged at t = {} s: |u| = {} m exceeds {} m; {field} = {} is too large for this system, lower it", Compact(*t_s), Compact(*u_m), Compact(*bound_m), Compact(*value))]
    Diverged {
        /// Solver name.
        solver: &'static str,
        /// The step's field name.
        field: &'static str,
        /// The step.
        value: f64,
        /// Time reached.
        t_s: f64,
        /// Bar displacement reached.
        u_m: f64,
        /// The bound it crossed.
        bound_m: f64,
    },
    /// A result came out NaN or infinite: the last line of defence before anything is written.
    #[error("{quantity} is not finite (from {}); likely cause: {cause}", Compact(*value))]
    NonFiniteResult {
        /// What was computed.
        quantity: &'static str,
        /// Its value.
        value: f64,
        /// The inputs that most likely produced it.
        cause: &'static str,
    },
}

impl ParamError {
    /// The field (or quantity) the error is about.
    pub fn field(&self) -> &'static str {
        match self {
            ParamError::NotFinite { field, .. }
            | ParamError::OutOfRange { field, .. }
            | ParamError::Limit { field, .. }
            | ParamError::Diverged { field, .. } => field,
            ParamError::NonFiniteResult { quantity, .. } => quantity,
        }
    }
}

fn why_suffix(why: &str) -> String {
    if why.is_empty() {
        String::new()
    } else {
        format!(" ({why})")
    }
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
    /// An event search did not converge within its iteration limit (never expected).
    #[error("event search did not converge near t = {t_s} s")]
    RootIsolation {
        /// Time reached.
        t_s: f64,
    },
    /// The closed form has no bounded solution (undamped bar forced exactly at resonance).
    #[error("undamped bar forced exactly at its natural frequency ({omega_rad_s} rad/s): the response is unbounded; give damping_ratio > 0 or another frequency")]
    UndampedResonance {
        /// Forcing frequency.
        omega_rad_s: f64,
    },
}

/// A number for a message: plain below a million and from 1e-3 up (`0.25`, `3783.4`), else in
/// exponent form (`1e308`, `1e-320`, `5.8e79`) instead of hundreds of digits. The same digits as
/// `{}` otherwise (shortest round-trip form), so nothing is rounded away.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Compact(pub f64);

impl std::fmt::Display for Compact {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let x = self.0;
        let a = x.abs();
        if !x.is_finite() || a == 0.0 || (1e-3..1e6).contains(&a) {
            write!(f, "{x}")
        } else {
            write!(f, "{x:e}")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regression_huge_values_print_compactly() {
        for (x, want) in [
            (1e308, "1e308"),
            (1e-320, "1e-320"),
            (-5.8e79, "-5.8e79"),
            (0.25, "0.25"),
            (3783.5, "3783.5"),
            (0.0, "0"),
            (1e6, "1e6"),
            (999_999.5, "999999.5"),
            (0.001, "0.001"),
            (0.000_999, "9.99e-4"),
            (f64::NAN, "NaN"),
            (f64::NEG_INFINITY, "-inf"),
        ] {
            assert_eq!(Compact(x).to_string(), want, "{x:?}");
        }
        let e = ParamError::OutOfRange {
            field: "x",
            value: 1e308,
            allowed: "(0, 1]",
        };
        assert_eq!(
            e.to_string(),
            "x = 1e308 is outside the allowed range (0, 1]"
        );
        assert!(e.to_string().len() < 60);
    }
}
