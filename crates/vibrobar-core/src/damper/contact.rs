//! The compliant ball–wall contact law (`contact.law = "hertz"`): one definition used by the
//! exact solvers' contact phase, the single-impact laboratory and the energy books.
//!
//! Force pressing ball and wall apart, with penetration `δ ≥ 0` and its rate `δ̇`:
//!
//! `P = K_h δ^{3/2} (1 + D δ̇/δ̇₀)`, `K_h = (4/3) E* √R*`,
//!
//! `1/E* = (1−ν_b²)/E_b + (1−ν_w²)/E_w`, `1/R* = 1/r − 1/R_wall` (concave wall; flat: `R* = r`).
//! `δ̇₀` is the approach speed at the start of the contact.
//!
//! **Damping factor `D(e)`.** Hunt–Crossley-type damping, with `D` from the *exact* phase-plane
//! relation of the law itself instead of an approximate fit. With `v = δ̇`, the relative motion
//! `m δ̈ = −P` gives `v dv/(1 + Dv/δ̇₀) = −(K_h/m) δ^{3/2} dδ`; the right side integrates to zero
//! over a whole contact (`δ` goes `0 → δ_max → 0`), so with `x = Dv/δ̇₀`, `h(x) = x − ln(1+x)`:
//!
//! `h(D) = h(−e D)`  (the outgoing speed is `e δ̇₀`).
//!
//! This holds for any mass, stiffness and speed (the law is self-similar), so on a rigid wall the
//! effective restitution equals the target at every speed, to the integrator's tolerance. The
//! same relation is the basis of Gonthier et al. (2004, Multibody Syst. Dyn. 11) and Hu & Guo
//! (2015, Mech. Mach. Theory 85), valid over the whole range `0 < e ≤ 1`. The approximate closed
//! forms [`d_lankarani_nikravesh`] (`3(1−e²)/4`, 1990, for `e → 1`) and [`d_flores`]
//! (`8(1−e)/(5e)`, Flores et al. 2011, Mech. Mach. Theory 46) are kept to show their drift
//! (`vibrobar contact-test` and the tests): at `e = 0.5` the first gives a far too elastic impact.
//!
//! The force never pulls: `1 + Dv/δ̇₀ ≥ 1 − eD > 0` on the way out (`eD < 1` is part of the
//! root's bracket), so the force reaches zero exactly when `δ` does, with `δ̇ = −e δ̇₀ ≠ 0`. The
//! contact therefore ends at `δ = 0`, the same instant as `P = 0`.

use crate::params::{Contact, Damper};

/// `h(x) = x − ln(1 + x)`, accurate near 0.
#[inline]
fn h(x: f64) -> f64 {
    x - x.ln_1p()
}

/// The exact Hunt–Crossley damping factor for restitution `e ∈ (0, 1]`: the root of
/// `h(D) = h(−eD)` in `(0, 1/e)` (0 for `e = 1`). Bisection to rounding.
pub fn damping_factor(e: f64) -> f64 {
    if e >= 1.0 {
        return 0.0;
    }
    // g(D) = h(D) − h(−eD): > 0 for small D (≈ D²(1−e²)/2), → −∞ as eD → 1.
    let g = |d: f64| h(d) - h(-e * d);
    let (mut lo, mut hi) = (0.0_f64, 1.0 / e);
    for _ in 0..300 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if g(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Lankarani & Nikravesh (1990): `D = 3(1 − e²)/4` (derived for `e` near 1).
pub fn d_lankarani_nikravesh(e: f64) -> f64 {
    0.75 * (1.0 - e * e)
}

/// Flores, Machado, Silva & Martins (2011): `D = 8(1 − e)/(5e)`.
pub fn d_flores(e: f64) -> f64 {
    1.6 * (1.0 - e) / e
}

/// `∫₀¹ (1 − x^{5/2})^{−1/2} dx = (2/5) B(2/5, 1/2) = (2/5) Γ(2/5) Γ(1/2)/Γ(9/10)`: the undamped
/// contact time is `2 × this × δ_max/v₀`.
pub const HERTZ_TIME_INTEGRAL: f64 = 1.471_637_592_162_352;

/// Hertz's law of one ball on one wall, ready to evaluate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hertz {
    /// `K_h = (4/3) E* √R*`, N/m^{3/2}.
    pub stiffness_n_m32: f64,
    /// `D(e)`, dimensionless.
    pub damping: f64,
    /// Effective modulus `E*`.
    pub effective_modulus_pa: f64,
    /// Effective radius `R*`.
    pub effective_radius_m: f64,
}

impl Hertz {
    /// The law of a (validated) contact section, ball radius `r` and target restitution `e`.
    pub fn new(c: &Contact, ball_radius_m: f64, restitution: f64) -> Hertz {
        let inv_e = (1.0 - c.ball_poisson * c.ball_poisson) / c.ball_modulus_pa
            + (1.0 - c.wall_poisson * c.wall_poisson) / c.wall_modulus_pa;
        let e_star = 1.0 / inv_e;
        let r_star = match c.wall_radius_m {
            Some(rw) => 1.0 / (1.0 / ball_radius_m - 1.0 / rw),
            None => ball_radius_m,
        };
        Hertz {
            stiffness_n_m32: 4.0 / 3.0 * e_star * r_star.sqrt(),
            damping: damping_factor(restitution),
            effective_modulus_pa: e_star,
            effective_radius_m: r_star,
        }
    }

    /// The law of a damper's `[contact]` section.
    pub fn of_damper(d: &Damper) -> Hertz {
        Hertz::new(&d.contact, d.ball_radius_m, d.restitution)
    }

    /// The same law with damping `D` replaced (the undamped `D = 0`, or an approximate `D(e)`).
    pub fn with_damping(self, damping: f64) -> Hertz {
        Hertz { damping, ..self }
    }

    /// Elastic part `K_h δ^{3/2}` (0 for `δ ≤ 0`).
    #[inline]
    pub fn elastic_force_n(&self, delta_m: f64) -> f64 {
        let d = delta_m.max(0.0);
        self.stiffness_n_m32 * d * d.sqrt()
    }

    /// Contact force `P = K_h δ^{3/2}(1 + D δ̇/δ̇₀)` with approach speed `δ̇₀ > 0`.
    #[inline]
    pub fn force_n(&self, delta_m: f64, ddelta_m_s: f64, approach_m_s: f64) -> f64 {
        self.elastic_force_n(delta_m) * (1.0 + self.damping * ddelta_m_s / approach_m_s)
    }

    /// [`Hertz::force_n`] and [`Hertz::damping_force_n`] from one evaluation of the elastic part
    /// (the same values: the contact phase's right-hand side).
    #[inline]
    pub fn forces_n(&self, delta_m: f64, ddelta_m_s: f64, approach_m_s: f64) -> (f64, f64) {
        let el = self.elastic_force_n(delta_m);
        (
            el * (1.0 + self.damping * ddelta_m_s / approach_m_s),
            el * self.damping * ddelta_m_s / approach_m_s,
        )
    }

    /// Damping part of the force (its power `· δ̇` is the contact's dissipation).
    #[inline]
    pub fn damping_force_n(&self, delta_m: f64, ddelta_m_s: f64, approach_m_s: f64) -> f64 {
        self.elastic_force_n(delta_m) * self.damping * ddelta_m_s / approach_m_s
    }

    /// Elastic energy stored at penetration `δ`: `(2/5) K_h δ^{5/2}`.
    #[inline]
    pub fn elastic_energy_j(&self, delta_m: f64) -> f64 {
        0.4 * self.elastic_force_n(delta_m) * delta_m.max(0.0)
    }

    /// Closed-form maximum penetration of a body of mass `m` arriving at `v₀` (exact for this
    /// law, damped or not): `δ_max = (5 m v₀² h(D)/(2 K_h D²))^{2/5}`, `→ (5 m v₀²/(4 K_h))^{2/5}`
    /// as `D → 0`.
    pub fn max_penetration_m(&self, mass_kg: f64, v0_m_s: f64) -> f64 {
        let d = self.damping;
        // h(D)/D² → 1/2 as D → 0; the series keeps it accurate for small D.
        let ratio = if d < 1e-4 {
            0.5 - d / 3.0 + d * d / 4.0
        } else {
            h(d) / (d * d)
        };
        (5.0 * mass_kg * v0_m_s * v0_m_s * ratio / (2.0 * self.stiffness_n_m32)).powf(0.4)
    }

    /// Undamped Hertz contact time `2 I δ_max/v₀` ([`HERTZ_TIME_INTEGRAL`]), i.e.
    /// `≈ 2.868 (m²/(R* E*² v₀))^{1/5}`.
    pub fn undamped_contact_time_s(&self, mass_kg: f64, v0_m_s: f64) -> f64 {
        let und = self.with_damping(0.0);
        2.0 * HERTZ_TIME_INTEGRAL * und.max_penetration_m(mass_kg, v0_m_s) / v0_m_s
    }

    /// Undamped peak force `K_h δ_max^{3/2}`.
    pub fn undamped_max_force_n(&self, mass_kg: f64, v0_m_s: f64) -> f64 {
        let und = self.with_damping(0.0);
        und.elastic_force_n(und.max_penetration_m(mass_kg, v0_m_s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{Contact, Material};

    /// `D(e)` satisfies its defining relation, is 0 at `e = 1`, falls with `e`, and the
    /// approximate laws meet it as `e → 1` (their common limit `D ≈ 3(1−e)/2`... to first order).
    #[test]
    fn damping_factor_solves_the_phase_plane_relation() {
        assert!(damping_factor(1.0) == 0.0, "e = 1 is undamped");
        let mut last = f64::INFINITY;
        for e in [0.05, 0.2, 0.5, 0.8, 0.95, 0.999] {
            let d = damping_factor(e);
            assert!(d > 0.0 && d < last && e * d < 1.0, "{e} {d}");
            // A bracket of the root at relative width 1e-8 (near e → 0 the relation is steep,
            // eD → 1, and its residual is ill-conditioned; the bracket is not).
            let g = |x: f64| h(x) - h(-e * x);
            assert!(g(d * (1.0 - 1e-8)) > 0.0, "{e} {d}");
            let up = d * (1.0 + 1e-8);
            assert!(e * up >= 1.0 || g(up) <= 0.0, "{e} {d}");
            last = d;
        }
        // Near e = 1 all three agree to first order in (1 − e): D ≈ 3(1−e)/2.
        let e = 0.999;
        let d = damping_factor(e);
        assert!((d / (1.5 * (1.0 - e)) - 1.0).abs() < 2e-3, "{d}");
        assert!((d_lankarani_nikravesh(e) / d - 1.0).abs() < 2e-3);
        assert!((d_flores(e) / d - 1.0).abs() < 0.1);
    }

    /// `E*`, `R*`, `K_h` of the paper's carbide ball on steel, by hand; a concave wall softens
    /// the curvature (larger `R*`).
    #[test]
    fn effective_modulus_radius_and_stiffness() {
        let c = Contact::hertz();
        let hz = Hertz::new(&c, 0.0075, 0.5);
        let (b, w) = (Material::TUNGSTEN_CARBIDE, Material::STEEL);
        let e_star = 1.0
            / ((1.0 - b.poisson.powi(2)) / b.modulus_pa + (1.0 - w.poisson.powi(2)) / w.modulus_pa);
        assert!((hz.effective_modulus_pa / e_star - 1.0).abs() < 1e-15);
        assert!(
            (hz.effective_modulus_pa - 167.3e9).abs() < 1e8,
            "{}",
            hz.effective_modulus_pa
        );
        assert!((hz.effective_radius_m - 0.0075).abs() < 1e-18);
        let want = 4.0 / 3.0 * e_star * 0.0075_f64.sqrt();
        assert!((hz.stiffness_n_m32 / want - 1.0).abs() < 1e-15);
        let concave = Hertz::new(
            &Contact {
                wall_radius_m: Some(0.015),
                ..c
            },
            0.0075,
            0.5,
        );
        assert!((concave.effective_radius_m - 0.015).abs() < 1e-15);
    }

    /// The contact-time constant is Hertz's `2.868` once `K_h` is written out.
    #[test]
    fn time_constant_is_hertz_2_868() {
        let c = 2.0 * HERTZ_TIME_INTEGRAL * (15.0_f64 / 16.0).powf(0.4);
        assert!((c - 2.868).abs() < 5e-4, "{c}");
    }
}
