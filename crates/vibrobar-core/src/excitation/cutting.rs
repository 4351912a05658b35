//! The cutting process at the tool tip (issue #13): a continuous orthogonal cut on a lathe
//! (stationary bar, one bending plane, no process damping).
//!
//! Sign convention: `u_tip` is positive away from the workpiece, the direction in which the
//! cutting force pushes the tool. The chip thickness is
//! `h(t) = h0 + c_chip·(s(t − τ) − u_tip(t))` with `h0` the feed and `τ = 60/n` one revolution;
//! `s` is the machined surface (`s = u_tip` while the tool cuts). The force on the bar at the
//! force point is `c_force·F(h)` with `F` the force law ([`CuttingForceLaw`]), zero out of the
//! cut (`h ≤ 0`).

use crate::error::ParamError;
use crate::limits;
use crate::params::{finite, positive};
use serde::{Deserialize, Serialize};

/// The cutting force law `F(h)` for `h > 0` (`F = 0` for `h ≤ 0`). Both have the slope
/// `dF/dh = K_f·b` at the nominal chip `h0`, hence the same linear stability lobes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CuttingForceLaw {
    /// `F = K_f·b·h`.
    #[default]
    Linear,
    /// `F = (4/3)·K_f·b·h0·(h/h0)^{3/4}` (Kalmár-Nagy, Stépán and Moon, Nonlinear Dynamics 26,
    /// 2001).
    ThreeQuarter,
}

impl CuttingForceLaw {
    /// All laws, in a stable order.
    pub const ALL: [CuttingForceLaw; 2] = [CuttingForceLaw::Linear, CuttingForceLaw::ThreeQuarter];

    /// The name used in scenario files and on the command line.
    pub fn as_str(&self) -> &'static str {
        match self {
            CuttingForceLaw::Linear => "linear",
            CuttingForceLaw::ThreeQuarter => "three-quarter",
        }
    }

    /// Parse the file / CLI name.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.as_str() == s)
    }
}

impl std::fmt::Display for CuttingForceLaw {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

fn one() -> f64 {
    1.0
}

/// The `[cutting]` section: a continuous orthogonal cut at the force point of the bar.
///
/// Coefficient, width, feed and spindle speed have no default (a cut without them means
/// nothing); the direction factors default to 1 and the law to `linear`. Unknown fields are
/// errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cutting {
    /// Cutting coefficient `K_f`: the linearised coefficient `dF/dh / b` at `h0`, for both laws.
    pub coefficient_n_m2: f64,
    /// Width of cut `b`.
    pub width_m: f64,
    /// Feed per revolution `h0`, the nominal chip thickness.
    pub feed_m: f64,
    /// Spindle speed `n` in revolutions per minute; the delay is `τ = 60/n`.
    pub spindle_rpm: f64,
    /// `c_force` in (0, 1]: the share of the cutting force along the bending plane.
    #[serde(default = "one")]
    pub force_direction_factor: f64,
    /// `c_chip` in (0, 1]: how much of the bar's motion changes the chip thickness.
    #[serde(default = "one")]
    pub chip_direction_factor: f64,
    /// Force law.
    #[serde(default)]
    pub force_law: CuttingForceLaw,
}

impl Cutting {
    /// Check every field; the error names the field `cutting.<name>` and its allowed range.
    pub fn validate(&self) -> Result<(), ParamError> {
        positive("cutting.coefficient_n_m2", self.coefficient_n_m2)?;
        positive("cutting.width_m", self.width_m)?;
        positive("cutting.feed_m", self.feed_m)?;
        finite("cutting.spindle_rpm", self.spindle_rpm)?;
        limits::check(
            "cutting.spindle_rpm",
            self.spindle_rpm,
            limits::SPINDLE_RPM_MIN,
            limits::SPINDLE_RPM_MAX,
            "revolutions per minute of a lathe spindle",
        )?;
        for (field, c) in [
            (
                "cutting.force_direction_factor",
                self.force_direction_factor,
            ),
            ("cutting.chip_direction_factor", self.chip_direction_factor),
        ] {
            finite(field, c)?;
            if !(c > 0.0 && c <= 1.0) {
                return Err(ParamError::OutOfRange {
                    field,
                    value: c,
                    allowed: "(0, 1]",
                });
            }
        }
        Ok(())
    }

    /// The delay `τ = 60/n`: one spindle revolution.
    pub fn delay_s(&self) -> f64 {
        60.0 / self.spindle_rpm
    }

    /// `K_f·c_force·c_chip`: the coefficient the linear stability lobes see (times the width
    /// it is the cutting stiffness acting on the tip along the bending plane).
    pub fn oriented_coefficient_n_m2(&self) -> f64 {
        self.coefficient_n_m2 * self.force_direction_factor * self.chip_direction_factor
    }

    /// The cutting force `F(h)` of the law along the cutting direction (before `c_force`); zero
    /// for `h ≤ 0` (the tool out of the cut).
    pub fn force_n(&self, h_m: f64) -> f64 {
        if h_m <= 0.0 {
            return 0.0;
        }
        let kb = self.coefficient_n_m2 * self.width_m;
        match self.force_law {
            CuttingForceLaw::Linear => kb * h_m,
            CuttingForceLaw::ThreeQuarter => {
                4.0 / 3.0 * kb * self.feed_m * (h_m / self.feed_m).powf(0.75)
            }
        }
    }

    /// `dF/dh` at `h` (`h > 0`; zero out of the cut).
    pub fn force_slope_n_per_m(&self, h_m: f64) -> f64 {
        if h_m <= 0.0 {
            return 0.0;
        }
        let kb = self.coefficient_n_m2 * self.width_m;
        match self.force_law {
            CuttingForceLaw::Linear => kb,
            CuttingForceLaw::ThreeQuarter => kb * (h_m / self.feed_m).powf(-0.25),
        }
    }

    /// `dF/dh` at the nominal chip `h0`: `K_f·b` for both laws.
    pub fn force_slope_at_feed_n_per_m(&self) -> f64 {
        self.force_slope_n_per_m(self.feed_m)
    }

    /// The force on the bar at the force point for a chip `h`: `c_force·F(h)`.
    pub fn force_on_bar_n(&self, h_m: f64) -> f64 {
        self.force_direction_factor * self.force_n(h_m)
    }
}

/// The linear stability limit `b_lim` of this cut (its width ignored) on a one-mode bar of mass
/// `m`, stiffness `k` and damping ratio `ζ` at its spindle speed, with the chatter frequency:
/// on lobe `j` the frequency `ω > ω_n` solves `ωT = 3π + 2 arg G(iω) + 2πj` (bisection to
/// rounding; `ωT` grows with `ω` there), `b = −1/(2 K_f c_force c_chip Re G(iω))`, and the limit
/// is the minimum over the lobes. For the bench and the tests of the time-domain solver; the
/// lobes of N-mode and measured structures are `analysis::lobes`'s.
pub fn one_mode_limit_width_m(cut: &Cutting, m: f64, k: f64, zeta: f64) -> (f64, f64) {
    use std::f64::consts::PI;
    let tau = cut.delay_s();
    let wn = (k / m).sqrt();
    let kf = cut.oriented_coefficient_n_m2();
    let arg_g = |w: f64| {
        let r = w / wn;
        -(2.0 * zeta * r).atan2(1.0 - r * r)
    };
    let b_of = |w: f64| {
        let r = w / wn;
        let d = (1.0 - r * r).powi(2) + (2.0 * zeta * r).powi(2);
        -k * d / (2.0 * kf * (1.0 - r * r))
    };
    let mut best = (f64::INFINITY, f64::NAN);
    // ωT − 3π − 2 arg G runs from about −π at ω_n to ∞: lobes j = 0, 1, … up to where ω_n T
    // passes them.
    let j_max = (wn * tau / (2.0 * PI)).ceil() as u64 + 1;
    for j in 0..=j_max.min(1_000_000) {
        let f = |w: f64| w * tau - 3.0 * PI - 2.0 * arg_g(w) - 2.0 * PI * j as f64;
        let (mut lo, mut hi) = (wn * (1.0 + 1e-12), wn * 2.0);
        while f(hi) < 0.0 && hi < wn * 1e6 {
            hi *= 2.0;
        }
        if f(lo) > 0.0 || f(hi) < 0.0 {
            continue;
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if f(mid) > 0.0 {
                hi = mid
            } else {
                lo = mid
            }
            if hi - lo <= 4.0 * f64::EPSILON * hi {
                break;
            }
        }
        let w = 0.5 * (lo + hi);
        let b = b_of(w);
        if b < best.0 {
            best = (b, w);
        }
    }
    best
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // exact values: products of given numbers
mod tests {
    use super::*;

    fn cut() -> Cutting {
        Cutting {
            coefficient_n_m2: 2e9,
            width_m: 1e-3,
            feed_m: 1e-4,
            spindle_rpm: 5000.0,
            force_direction_factor: 1.0,
            chip_direction_factor: 1.0,
            force_law: CuttingForceLaw::Linear,
        }
    }

    #[test]
    fn bad_inputs_name_the_field_and_range() {
        let ok = cut();
        ok.validate().unwrap();
        let cases: Vec<(Cutting, &str, &str)> = vec![
            (
                Cutting {
                    coefficient_n_m2: 0.0,
                    ..ok
                },
                "cutting.coefficient_n_m2",
                "(0, ∞)",
            ),
            (
                Cutting {
                    coefficient_n_m2: -1.0,
                    ..ok
                },
                "cutting.coefficient_n_m2",
                "(0, ∞)",
            ),
            (Cutting { width_m: 0.0, ..ok }, "cutting.width_m", "(0, ∞)"),
            (
                Cutting {
                    width_m: -1e-3,
                    ..ok
                },
                "cutting.width_m",
                "(0, ∞)",
            ),
            (Cutting { feed_m: 0.0, ..ok }, "cutting.feed_m", "(0, ∞)"),
            (
                Cutting {
                    feed_m: f64::NAN,
                    ..ok
                },
                "cutting.feed_m",
                "finite",
            ),
            (
                Cutting {
                    spindle_rpm: 0.5,
                    ..ok
                },
                "cutting.spindle_rpm",
                "[1, 200000]",
            ),
            (
                Cutting {
                    spindle_rpm: 2.1e5,
                    ..ok
                },
                "cutting.spindle_rpm",
                "[1, 200000]",
            ),
            (
                Cutting {
                    spindle_rpm: f64::INFINITY,
                    ..ok
                },
                "cutting.spindle_rpm",
                "finite",
            ),
            (
                Cutting {
                    force_direction_factor: 0.0,
                    ..ok
                },
                "cutting.force_direction_factor",
                "(0, 1]",
            ),
            (
                Cutting {
                    force_direction_factor: 1.5,
                    ..ok
                },
                "cutting.force_direction_factor",
                "(0, 1]",
            ),
            (
                Cutting {
                    chip_direction_factor: -0.2,
                    ..ok
                },
                "cutting.chip_direction_factor",
                "(0, 1]",
            ),
            (
                Cutting {
                    chip_direction_factor: 1.0000001,
                    ..ok
                },
                "cutting.chip_direction_factor",
                "(0, 1]",
            ),
        ];
        for (c, field, range) in cases {
            let e = c.validate().unwrap_err();
            assert_eq!(e.field(), field);
            let msg = e.to_string();
            assert!(msg.contains(field) && msg.contains(range), "{msg}");
        }
        // The range's ends are allowed.
        for n in [limits::SPINDLE_RPM_MIN, limits::SPINDLE_RPM_MAX] {
            Cutting {
                spindle_rpm: n,
                ..ok
            }
            .validate()
            .unwrap();
        }
    }

    #[test]
    fn laws_share_the_slope_at_the_feed_and_vanish_out_of_the_cut() {
        let lin = cut();
        let tq = Cutting {
            force_law: CuttingForceLaw::ThreeQuarter,
            ..lin
        };
        let kb = 2e9 * 1e-3;
        assert_eq!(lin.force_slope_at_feed_n_per_m(), kb);
        assert!((tq.force_slope_at_feed_n_per_m() / kb - 1.0).abs() < 1e-15);
        // The derivative is the law's: central difference at h0 and at 0.3 h0.
        for law in [lin, tq] {
            for h in [1e-4, 3e-5] {
                let d = 1e-9;
                let fd = (law.force_n(h + d) - law.force_n(h - d)) / (2.0 * d);
                assert!(
                    (fd / law.force_slope_n_per_m(h) - 1.0).abs() < 1e-7,
                    "{law:?} {h}"
                );
            }
            assert_eq!(law.force_n(0.0), 0.0);
            assert_eq!(law.force_n(-1e-5), 0.0);
            assert_eq!(law.force_slope_n_per_m(-1e-5), 0.0);
        }
        // At h0 the three-quarter law gives 4/3 of the linear force.
        assert!((tq.force_n(1e-4) / lin.force_n(1e-4) - 4.0 / 3.0).abs() < 1e-15);
        assert_eq!(lin.delay_s(), 60.0 / 5000.0);
        let o = Cutting {
            force_direction_factor: 0.8,
            chip_direction_factor: 0.5,
            ..lin
        };
        assert!((o.oriented_coefficient_n_m2() - 2e9 * 0.4).abs() < 1e-3);
        assert!((o.force_on_bar_n(1e-4) - 0.8 * kb * 1e-4).abs() < 1e-12);
    }

    #[test]
    fn section_defaults_and_unknown_fields() {
        let c: Cutting = serde_json::from_str(
            r#"{"coefficient_n_m2": 2e9, "width_m": 1e-3, "feed_m": 1e-4, "spindle_rpm": 5000}"#,
        )
        .unwrap();
        assert_eq!(c, cut());
        let c: Cutting = serde_json::from_str(
            r#"{"coefficient_n_m2": 2e9, "width_m": 1e-3, "feed_m": 1e-4, "spindle_rpm": 5000, "force_law": "three-quarter"}"#,
        )
        .unwrap();
        assert_eq!(c.force_law, CuttingForceLaw::ThreeQuarter);
        assert!(serde_json::from_str::<Cutting>(
            r#"{"coefficient_n_m2": 2e9, "width_m": 1e-3, "feed_m": 1e-4, "spindle_rpm": 5000, "widht_m": 1}"#,
        )
        .is_err());
        assert!(serde_json::from_str::<Cutting>(
            r#"{"width_m": 1e-3, "feed_m": 1e-4, "spindle_rpm": 5000}"#
        )
        .is_err());
    }
}
