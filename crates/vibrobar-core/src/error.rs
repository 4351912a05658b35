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
    /// A quantity derived from several inputs (a product, a quotient) outside a limit of
    /// [`crate::limits`]. The inputs are shown as given: from huge inputs the quantity itself
    /// overflows to inf, which would not say what was given.
    #[error("{field} = {inputs}{} is outside the allowed range [{}, {}]{}", derived_value(*value), Compact(*min), Compact(*max), why_suffix(why))]
    DerivedLimit {
        /// The quantity and the flags it comes from.
        field: &'static str,
        /// The inputs as given, e.g. `3783.6 rad/s · 1e308 s`.
        inputs: String,
        /// The quantity (may be inf).
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
            | ParamError::DerivedLimit { field, .. }
            | ParamError::Diverged { field, .. } => field,
            ParamError::NonFiniteResult { quantity, .. } => quantity,
        }
    }
}

/// ` = value` when the value is finite (an overflow to inf says nothing the inputs do not).
fn derived_value(value: f64) -> String {
    if value.is_finite() {
        format!(" = {}", Compact(value))
    } else {
        String::new()
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
    /// The solver does not handle this system (the message says what and what to use instead).
    #[error("{0}")]
    Unsupported(&'static str),
    /// A compliant (`hertz`) contact phase took more integrator steps than its bound (a
    /// grazing contact that does not end, or a ball resting on a wall for good).
    #[error("a hertz contact starting at t = {t_s} s took more than {steps} integrator steps without ending (a ball resting on or grazing a wall for a long time); use contact.law = restitution for this case")]
    ContactStepLimit {
        /// Start of the contact.
        t_s: f64,
        /// The bound.
        steps: u64,
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
    /// An iteration (Newton's method on a periodic orbit, a continuation step) did not reach
    /// its tolerance: nothing is returned as if it had.
    #[error("{what} did not converge after {iterations} iterations: residual {} > tolerance {}", Compact(*residual), Compact(*tolerance))]
    NoConvergence {
        /// What was iterated, and what to try.
        what: &'static str,
        /// Iterations done.
        iterations: usize,
        /// The last residual.
        residual: f64,
        /// The tolerance.
        tolerance: f64,
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
