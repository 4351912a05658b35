//! The friction law between ball and bar: one definition of its sign, used by `rk4` (force and
//! segment work), `exact` (the constant force of a free flight, the stick and chatter tests)
//! and, through the segments' friction work, the energy audit.

use crate::params::FrictionModel;

/// Sign function with `sgn(0) = 0`, as in the paper's Eq. 3.
#[inline]
pub fn sgn0(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// `s` in `F_ball = s·F·sgn(ẇ)`: `+1` as published (power `F_ball ẇ = F|ẇ| ≥ 0`, it injects
/// energy), `−1` coulomb (power `≤ 0`, it dissipates), `0` frictionless. The friction work of a
/// slide is `s·F` times the distance slid, `∫|ẇ| dt`.
#[inline]
pub fn sign_factor(model: FrictionModel) -> f64 {
    match model {
        FrictionModel::None => 0.0,
        FrictionModel::AsPublished => 1.0,
        FrictionModel::Coulomb => -1.0,
    }
}

/// Friction force on the ball while sliding with relative velocity `dw` (`F_ball`); with
/// `dw = σ ∈ {−1, 0, +1}` it is the force of a slide in direction `σ`.
///
/// * `AsPublished`: `+F sgn(ẇ)` (Eq. 2).
/// * `Coulomb`: `−F sgn(ẇ)`.
///
/// At `ẇ = 0` this returns 0; what holds a ball at rest is [`holding_capacity_n`].
#[inline]
pub fn sliding_friction_on_ball_n(model: FrictionModel, level_n: f64, dw_m_s: f64) -> f64 {
    match model {
        FrictionModel::None => 0.0,
        FrictionModel::AsPublished => level_n * sgn0(dw_m_s),
        FrictionModel::Coulomb => -level_n * sgn0(dw_m_s),
    }
}

/// Whether friction can hold the ball at relative rest (stick): only `Coulomb`. The paper's law
/// has `sgn(0) = 0`, so at `ẇ = 0` it exerts no force and the ball moves on.
#[inline]
pub fn can_stick(model: FrictionModel) -> bool {
    model == FrictionModel::Coulomb
}

/// The largest friction force available to hold the ball at relative rest (against the bar, or
/// on a wall against being pulled off it): `F` for `Coulomb`, else 0.
#[inline]
pub fn holding_capacity_n(model: FrictionModel, level_n: f64) -> f64 {
    if can_stick(model) {
        level_n
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One law: the force of a slide is `s·F·sgn(ẇ)` with the model's sign factor, its power
    /// has that sign, and only a law that dissipates can hold a ball at rest.
    #[test]
    fn sliding_force_power_and_holding_follow_the_sign_factor() {
        for model in FrictionModel::ALL {
            let s = sign_factor(model);
            for dw in [-2.5, -1e-300, 0.0, 1e-300, 3.0] {
                let f = sliding_friction_on_ball_n(model, 0.7, dw);
                // (+ 0.0: the sign of a zero force does not matter)
                let want = s * 0.7 * sgn0(dw) + 0.0;
                assert_eq!((f + 0.0).to_bits(), want.to_bits(), "{model} {dw}");
                assert!(
                    f * dw * s >= 0.0,
                    "{model} {dw}: power has the sign factor's sign"
                );
            }
            let hold = holding_capacity_n(model, 0.7);
            assert_eq!(hold > 0.0, can_stick(model));
            assert_eq!(can_stick(model), s < 0.0);
        }
    }
}
