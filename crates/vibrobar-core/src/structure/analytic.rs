//! Closed-form bending modes of a uniform clamped–free Euler–Bernoulli bar, stable for high modes.
//!
//! `βₙL` are the roots of `1 + cos βL cosh βL = 0`, solved here as `cos x + sech x = 0` (the same
//! roots, but every term bounded) by bisection on `[(n−1)π, nπ]`, where the function changes sign
//! once, to the last bit; for `x > 710` `sech x` underflows and the root is `(2n−1)π/2` to rounding.
//!
//! The textbook shape `Φ(x) = cosh βx − cos βx − σ(sinh βx − sin βx)`,
//! `σ = (cosh βL + cos βL)/(sinh βL + sin βL)`, loses every digit to `cosh − σ sinh` for high
//! modes (both ~ e^{βL}/2, σ → 1). Written with exponentials,
//! `cosh βx − σ sinh βx = ½[(1−σ) e^{βx} + (1+σ) e^{−βx}]`, and
//! `(1−σ) e^{βL} = ε = 2(sin βL − cos βL − e^{−βL}) / (1 − e^{−2βL} + 2 sin βL e^{−βL})`,
//! so `Φ(x) = ½[ε e^{β(x−L)} + (1+σ) e^{−βx}] − cos βx + σ sin βx` with bounded terms only.
//! `∫₀ᴸ Φ² dx = L` and `|Φ(L)| = 2`, so normalised to 1 at the tip every mode has modal mass
//! `ρAL/4`.

use std::f64::consts::PI;

/// `βₙL` of the uniform clamped–free bar, mode `n ≥ 1` (root of `1 + cos βL cosh βL = 0`).
pub fn beta_l(n: usize) -> f64 {
    assert!(n >= 1, "modes are numbered from 1");
    let f = |x: f64| x.cos() + 1.0 / x.cosh();
    let (mut lo, mut hi) = ((n - 1) as f64 * PI, n as f64 * PI);
    let f_lo = f(lo);
    // Bisection until the bracket stops shrinking: the last bit, whatever n.
    loop {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if (f(mid) > 0.0) == (f_lo > 0.0) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    if f(lo).abs() <= f(hi).abs() {
        lo
    } else {
        hi
    }
}

/// `σₙ = (cosh βL + cos βL)/(sinh βL + sin βL)`, as `1 − ε e^{−βL}` (no overflow).
pub fn sigma(beta_l: f64) -> f64 {
    1.0 - epsilon(beta_l) * (-beta_l).exp()
}

/// `ε = (1 − σ) e^{βL}` (see the module docs).
fn epsilon(b: f64) -> f64 {
    let e = (-b).exp();
    2.0 * (b.sin() - b.cos() - e) / (1.0 - e * e + 2.0 * b.sin() * e)
}

/// One uniform clamped–free mode in closed form, evaluated at `ξ = x/L ∈ [0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UniformMode {
    /// `βₙL`.
    pub beta_l: f64,
    sigma: f64,
    eps: f64,
    tip: f64,
}

impl UniformMode {
    /// Mode `n ≥ 1`.
    pub fn new(n: usize) -> UniformMode {
        let b = beta_l(n);
        let mut m = UniformMode {
            beta_l: b,
            sigma: sigma(b),
            eps: epsilon(b),
            tip: 1.0,
        };
        m.tip = m.raw(1.0);
        m
    }

    /// `σₙ`.
    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// The textbook-normalised shape `Φ(ξ)` (`|Φ(1)| = 2`, `∫₀¹ Φ² dξ = 1`).
    pub fn raw(&self, xi: f64) -> f64 {
        let bx = self.beta_l * xi;
        0.5 * (self.eps * (self.beta_l * (xi - 1.0)).exp() + (1.0 + self.sigma) * (-bx).exp())
            - bx.cos()
            + self.sigma * bx.sin()
    }

    /// The shape normalised to 1 at the tip, `Φ(ξ)/Φ(1)`.
    pub fn shape(&self, xi: f64) -> f64 {
        self.raw(xi) / self.tip
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roots_are_the_tabulated_ones_and_tend_to_the_asymptote() {
        for (n, want) in [
            (1, 1.875_104_069),
            (2, 4.694_091_133),
            (3, 7.854_757_438),
            (4, 10.995_540_735),
            (5, 14.137_168_391),
        ] {
            assert!((beta_l(n) - want).abs() < 1e-9, "n = {n}: {}", beta_l(n));
        }
        assert!((beta_l(1) - crate::euler_bernoulli::CANTILEVER_BETA1_L).abs() < 1e-14);
        for n in [10usize, 30, 100, 300, 1000] {
            let a = (2 * n - 1) as f64 * PI / 2.0;
            let b = beta_l(n);
            assert!(
                (b - a).abs() <= 1e-12 * a.max(1.0) + 2.0 / a.cosh(),
                "n = {n}"
            );
            // It is a root of the textbook equation to rounding, scaled by cosh.
            assert!((b.cos() + 1.0 / b.cosh()).abs() < 1e-14 * b, "n = {n}");
        }
    }

    #[test]
    fn sigma_and_tip_value_as_tabulated() {
        for (n, want) in [
            (1, 0.734_095_5),
            (2, 1.018_467_3),
            (3, 0.999_224_5),
            (4, 1.000_033_6),
            (5, 0.999_998_6),
        ] {
            let s = UniformMode::new(n).sigma();
            assert!((s - want).abs() < 1e-7, "σ{n} = {s}");
            // Against the textbook quotient, fine for low n.
            let b = beta_l(n);
            let t = (b.cosh() + b.cos()) / (b.sinh() + b.sin());
            assert!((s - t).abs() < 1e-12, "σ{n}: {s} vs {t}");
        }
        for n in 1..=60 {
            let m = UniformMode::new(n);
            assert!(
                (m.raw(1.0).abs() - 2.0).abs() < 1e-9,
                "|Φ{n}(L)| = {}",
                m.raw(1.0)
            );
        }
    }
}
