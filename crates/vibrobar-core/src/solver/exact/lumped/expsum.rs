//! Closed forms of the piecewise-linear motion: the "exponential sum"
//!
//! `f(τ) = f(0) + c1 τ + c2 τ² + a (cos Ωτ − 1) + b sin Ωτ + p (e^{−ατ} cos ω_d τ − 1) + q e^{−ατ} sin ω_d τ`
//!
//! which is `c0 + c1 τ + c2 τ² + a cos Ωτ + b sin Ωτ + e^{−ατ}(p cos ω_d τ + q sin ω_d τ)` written
//! around its start value. Storing `f(0)` instead of `c0` keeps the value free of cancellation
//! when the static deflection `c0` is huge compared with the motion (a soft spring under a
//! static load: `c0 = F_s/K`), because `cos x − 1` and `e^{−x} cos y − 1` are evaluated without
//! subtracting nearly equal numbers.

/// `f(0) + c1 τ + c2 τ² + a (cos Ωτ − 1) + b sin Ωτ + p (e^{−ατ} cos ω_d τ − 1) + q e^{−ατ} sin ω_d τ`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ExpSum {
    /// Value at `τ = 0`.
    pub f0: f64,
    /// The standard-form constant `c0` (`= f0 − a − p`), kept exactly where it is known
    /// (`F_s/K`, 0 for a derivative): the closed-form integrals use it.
    pub k0: f64,
    /// Linear coefficient.
    pub c1: f64,
    /// Quadratic coefficient.
    pub c2: f64,
    /// Cosine coefficient of the harmonic part.
    pub a: f64,
    /// Sine coefficient of the harmonic part.
    pub b: f64,
    /// Harmonic frequency `Ω`.
    pub om: f64,
    /// Cosine coefficient of the decaying part.
    pub p: f64,
    /// Sine coefficient of the decaying part.
    pub q: f64,
    /// Decay rate `α ≥ 0`.
    pub al: f64,
    /// Damped frequency `ω_d > 0`.
    pub wd: f64,
}

/// `cos x − 1` from `cos x` and `sin x`, without cancellation near `x = 2πk`.
#[inline]
fn cm1(c: f64, s: f64) -> f64 {
    if c > 0.0 {
        -s * s / (1.0 + c)
    } else {
        c - 1.0
    }
}

/// The transcendental values at one `τ`, shared by all the sums of a segment.
#[derive(Debug, Clone, Copy)]
pub struct Trig {
    /// `cos Ωτ`.
    pub ch: f64,
    /// `sin Ωτ`.
    pub sh: f64,
    /// `e^{−ατ} − 1`.
    pub em1: f64,
    /// `cos ω_d τ`.
    pub cd: f64,
    /// `sin ω_d τ`.
    pub sd: f64,
    /// `cos Ωτ − 1` (without cancellation).
    pub chm1: f64,
    /// `cos ω_d τ − 1` (without cancellation).
    pub cdm1: f64,
    /// `τ`.
    pub tau: f64,
}

impl Trig {
    /// Evaluate at `τ` for frequencies `om`, `wd` and decay `al`.
    #[inline]
    pub fn new(tau: f64, om: f64, al: f64, wd: f64) -> Trig {
        if tau.to_bits() == 0 {
            // τ = +0, the start of every search: the values `sin_cos` and `exp_m1` return there.
            return Trig {
                ch: 1.0,
                sh: 0.0,
                em1: -0.0,
                cd: 1.0,
                sd: 0.0,
                chm1: cm1(1.0, 0.0),
                cdm1: cm1(1.0, 0.0),
                tau,
            };
        }
        // From the half angle: sin x = 2 sin(x/2) cos(x/2), cos x − 1 = −2 sin²(x/2), free of
        // cancellation without a division (x/2 = (Ω/2)τ rounds exactly as Ωτ, halved).
        let (s2, c2) = ((0.5 * om) * tau).sin_cos();
        let chm1 = -2.0 * s2 * s2;
        let sh = 2.0 * s2 * c2;
        let ch = 1.0 + chm1;
        let em1 = (-al * tau).exp_m1();
        // Near resonance ω_d ≈ Ω: e^{iω_dτ} = e^{iΩτ}·e^{iδτ}, δ = ω_d − Ω (exact: Sterbenz),
        // with e^{iδτ} from its series when |δτ| ≤ 1/8 — one `sin_cos` instead of two. The
        // product has absolute errors ~ε(|Ωτ||δτ| + |δτ|), so it keeps the relative accuracy
        // of `sin ω_dτ` and `cos ω_dτ − 1` at small ω_dτ only when |δ| ≪ ω_d: required here
        // (|δ| ≤ min(ω_d, Ω)/8: relative errors ≤ 3ε); else two `sin_cos`.
        let delta = wd - om;
        let x = delta * tau;
        if x.abs() <= 0.125 && 8.0 * delta.abs() <= wd.min(om) {
            let (sx, cxm) = small_sin_cm1(x);
            let dc = ch * cxm - sh * sx;
            return Trig {
                ch,
                sh,
                em1,
                cd: ch + dc,
                sd: sh + (sh * cxm + ch * sx),
                chm1,
                cdm1: chm1 + dc,
                tau,
            };
        }
        let (sd, cd) = (wd * tau).sin_cos();
        Trig {
            ch,
            sh,
            em1,
            cd,
            sd,
            chm1,
            cdm1: cm1(cd, sd),
            tau,
        }
    }
}

/// `(sin x, cos x − 1)` by their Taylor series for `|x| ≤ 1/8` (truncation below `1e-20`
/// relative), as polynomials in `x²` evaluated in Estrin's form (short dependency chains).
#[inline]
pub(in crate::solver::exact) fn small_sin_cm1(x: f64) -> (f64, f64) {
    let y = x * x;
    let y2 = y * y;
    // sin x / x = Σ (−y)^k/(2k+1)!, k = 0..5.
    let s = (1.0 - y / 6.0)
        + y2 * ((1.0 / 120.0 - y / 5040.0) + y2 * (1.0 / 362_880.0 - y / 39_916_800.0));
    // (cos x − 1)/(−x²/2) = Σ 2(−y)^k/(2k+2)!, k = 0..5.
    let c = (1.0 - y / 12.0)
        + y2 * ((2.0 / 720.0 - y * (2.0 / 40_320.0))
            + y2 * (2.0 / 3_628_800.0 - y * (2.0 / 479_001_600.0)));
    (x * s, -0.5 * y * c)
}

impl ExpSum {
    /// Same frequencies, all coefficients zero.
    pub fn zero_like(&self) -> ExpSum {
        ExpSum {
            om: self.om,
            al: self.al,
            wd: self.wd,
            ..Default::default()
        }
    }

    /// True when every time-dependent coefficient is exactly zero: `f(τ) = f(0)` for all `τ`.
    pub fn is_constant(&self) -> bool {
        [self.c1, self.c2, self.a, self.b, self.p, self.q]
            .iter()
            .all(|&x| x == 0.0)
    }

    /// `s·f + k`.
    pub fn affine(&self, s: f64, k: f64) -> ExpSum {
        ExpSum {
            f0: s * self.f0 + k,
            k0: s * self.k0 + k,
            c1: s * self.c1,
            c2: s * self.c2,
            a: s * self.a,
            b: s * self.b,
            p: s * self.p,
            q: s * self.q,
            ..*self
        }
    }

    /// A constant with the frequencies of `like`.
    pub fn constant(v: f64, like: &ExpSum) -> ExpSum {
        ExpSum {
            f0: v,
            k0: v,
            ..like.zero_like()
        }
    }

    /// The derivative, again an exponential sum (its `f0` is `f'(0)`).
    pub fn deriv(&self) -> ExpSum {
        let a = self.om * self.b;
        let b = -self.om * self.a;
        let p = -self.al * self.p + self.wd * self.q;
        let q = -self.al * self.q - self.wd * self.p;
        ExpSum {
            f0: self.c1 + a + p,
            k0: self.c1,
            c1: 2.0 * self.c2,
            c2: 0.0,
            a,
            b,
            p,
            q,
            ..*self
        }
    }

    /// Value from precomputed transcendentals.
    #[inline]
    pub fn value_t(&self, t: &Trig) -> f64 {
        let e = 1.0 + t.em1;
        let dec = self.p * (t.em1 * t.cd + t.cdm1) + self.q * e * t.sd;
        self.f0 + t.tau * (self.c1 + t.tau * self.c2) + self.a * t.chm1 + self.b * t.sh + dec
    }

    /// `f(τ) − f(0)` from precomputed transcendentals, without forming `f(0) + …` first: the
    /// change of a position stays accurate when it is below the rounding of the position itself.
    #[inline]
    pub fn increment_t(&self, t: &Trig) -> f64 {
        let e = 1.0 + t.em1;
        let dec = self.p * (t.em1 * t.cd + t.cdm1) + self.q * e * t.sd;
        t.tau * (self.c1 + t.tau * self.c2) + self.a * t.chm1 + self.b * t.sh + dec
    }

    /// `f(b) − f(a)`, free of the cancellation against `f(0)` (exactly 0 − 0 at `a = 0`).
    pub fn increment(&self, a: f64, b: f64) -> f64 {
        let at = |tau: f64| self.increment_t(&Trig::new(tau, self.om, self.al, self.wd));
        at(b) - at(a)
    }

    /// The second derivative from precomputed transcendentals (`derivs_t::<3>`'s last, to the
    /// bit, without the value and the first derivative).
    #[inline]
    pub fn second_derivative_t(&self, t: &Trig) -> f64 {
        let e = 1.0 + t.em1;
        let (mut a, mut b, mut p, mut q) = (self.a, self.b, self.p, self.q);
        for _ in 0..2 {
            let (na, nb) = (self.om * b, -self.om * a);
            let (np, nq) = (-self.al * p + self.wd * q, -self.al * q - self.wd * p);
            (a, b, p, q) = (na, nb, np, nq);
        }
        2.0 * self.c2 + a * t.ch + b * t.sh + e * (p * t.cd + q * t.sd)
    }

    /// Value at `τ`.
    pub fn value(&self, tau: f64) -> f64 {
        self.value_t(&Trig::new(tau, self.om, self.al, self.wd))
    }

    /// Value and the first `N − 1` derivatives at one point.
    #[inline]
    pub fn derivs_t<const N: usize>(&self, t: &Trig) -> [f64; N] {
        let mut out = [0.0; N];
        if N == 0 {
            return out;
        }
        out[0] = self.value_t(t);
        let e = 1.0 + t.em1;
        let (mut a, mut b, mut p, mut q) = (self.a, self.b, self.p, self.q);
        let poly = [self.c1 + 2.0 * self.c2 * t.tau, 2.0 * self.c2];
        for (n, o) in out.iter_mut().enumerate().skip(1) {
            let (na, nb) = (self.om * b, -self.om * a);
            let (np, nq) = (-self.al * p + self.wd * q, -self.al * q - self.wd * p);
            a = na;
            b = nb;
            p = np;
            q = nq;
            let pl = if n <= 2 { poly[n - 1] } else { 0.0 };
            *o = pl + a * t.ch + b * t.sh + e * (p * t.cd + q * t.sd);
        }
        out
    }

    /// Value and first `N − 1` derivatives at `τ`.
    pub fn derivs<const N: usize>(&self, tau: f64) -> [f64; N] {
        self.derivs_t::<N>(&Trig::new(tau, self.om, self.al, self.wd))
    }

    /// Bound on `|f^(n)|` over `[t0, t1]` (`n ≥ 1`): polynomial part exactly, the oscillating
    /// parts by their amplitudes, the decaying part at its largest (at `t0`).
    pub fn deriv_bound(&self, n: u32, t0: f64, t1: f64) -> f64 {
        let poly = match n {
            1 => (self.c1 + 2.0 * self.c2 * t0)
                .abs()
                .max((self.c1 + 2.0 * self.c2 * t1).abs()),
            2 => 2.0 * self.c2.abs(),
            _ => 0.0,
        };
        let wn2 = self.al * self.al + self.wd * self.wd;
        let harm = self.om.powi(n as i32) * self.a.hypot(self.b);
        let dec = wn2.sqrt().powi(n as i32) * (-self.al * t0).exp() * self.p.hypot(self.q);
        // A relative margin covers the rounding of the bound itself.
        (poly + harm + dec) * (1.0 + 1e-12)
    }

    /// Complex-exponential terms `c_k e^{λ_k τ}` (standard form). Only for sums without the
    /// `c1`, `c2` polynomial terms (the bar displacement, velocity and the forcing).
    fn terms(&self) -> [(C, C); 5] {
        debug_assert!(self.c1 == 0.0 && self.c2 == 0.0);
        let ih = C(0.0, self.om);
        let dd = C(-self.al, self.wd);
        [
            (C(self.k0, 0.0), C(0.0, 0.0)),
            (C(0.5 * self.a, -0.5 * self.b), ih),
            (C(0.5 * self.a, 0.5 * self.b), ih.conj()),
            (C(0.5 * self.p, -0.5 * self.q), dd),
            (C(0.5 * self.p, 0.5 * self.q), dd.conj()),
        ]
    }

    /// The exponentials `e^{λ_k τ}` of [`ExpSum::terms`] at `τ` (two `sin_cos` and one `exp`).
    fn exponentials(&self, tau: f64) -> [C; 5] {
        let (sh, ch) = (self.om * tau).sin_cos();
        let (sd, cd) = (self.wd * tau).sin_cos();
        let e = (-self.al * tau).exp();
        [
            C(1.0, 0.0),
            C(ch, sh),
            C(ch, -sh),
            C(e * cd, e * sd),
            C(e * cd, -e * sd),
        ]
    }
}

/// `∫_a^b x(τ) y(τ) dτ` in closed form, for sums without polynomial terms and with the same
/// frequencies: `Σ_jk c_j d_k ∫ e^{(λ_j+λ_k)τ}`, each integral `(e^{νb} − e^{νa})/ν`, or
/// `e^{νa}(b−a) φ1(ν(b−a))` with a series when `|ν(b−a)| < 1/2`, so that no term loses precision.
/// The exponentials of the five `λ` at `a` and `b` are computed once (two `sin_cos` and one `exp`
/// per end).
pub fn integral_product(x: &ExpSum, y: &ExpSum, a: f64, b: f64) -> f64 {
    let h = b - a;
    if h <= 0.0 {
        return 0.0;
    }
    debug_assert!(
        x.om.to_bits() == y.om.to_bits()
            && x.al.to_bits() == y.al.to_bits()
            && x.wd.to_bits() == y.wd.to_bits()
    );
    let (ea, eb) = (x.exponentials(a), x.exponentials(b));
    sum_of_products(x, y, (&ea, &ea), (&eb, &eb), h)
}

/// `∫_a^b x(t − x0) y(t − y0) dt` in closed form, for sums without polynomial terms whose
/// frequencies and decay rates may differ and whose origins `x0, y0 ≤ a` may differ: the product
/// of the displacements of two bars (or two planes of one bar) over the time they share. Each
/// sum's exponentials are taken at its own local times of `a` and `b` (the shifts decay, so no
/// term grows), and the 25 products are integrated as in [`integral_product`].
pub fn integral_product_shifted(x: &ExpSum, x0: f64, y: &ExpSum, y0: f64, a: f64, b: f64) -> f64 {
    let h = b - a;
    if h <= 0.0 {
        return 0.0;
    }
    debug_assert!(a >= x0 && a >= y0);
    let (xa, xb) = (x.exponentials(a - x0), x.exponentials(b - x0));
    let (ya, yb) = (y.exponentials(a - y0), y.exponentials(b - y0));
    sum_of_products(x, y, (&xa, &ya), (&xb, &yb), h)
}

/// `Σ_jk c_j d_k ∫ e^{λ_j τ_x + μ_k τ_y}` over an interval of length `h`, from the sums'
/// exponentials at its start (`ea`) and end (`eb`), `x`'s first and `y`'s second. The sums are
/// real, so the term of `(j, k)` is the conjugate of that of their conjugate pair: 13 of the 25
/// are computed, the others as twice their real parts.
fn sum_of_products(
    x: &ExpSum,
    y: &ExpSum,
    ea: (&[C; 5], &[C; 5]),
    eb: (&[C; 5], &[C; 5]),
    h: f64,
) -> f64 {
    // The index of each term's conjugate in `terms`.
    const CONJ: [usize; 5] = [0, 2, 1, 4, 3];
    let tx = x.terms();
    let ty = y.terms();
    let mut sum = 0.0;
    for (j, &(cj, lj)) in tx.iter().enumerate() {
        if cj.0 == 0.0 && cj.1 == 0.0 {
            continue;
        }
        for (k, &(dk, lk)) in ty.iter().enumerate() {
            let pair = (CONJ[j], CONJ[k]);
            if (dk.0 == 0.0 && dk.1 == 0.0) || pair < (j, k) {
                continue;
            }
            let nu = lj.add(lk);
            let z = nu.scale(h);
            let int = if z.0 * z.0 + z.1 * z.1 < 0.25 {
                ea.0[j].mul(ea.1[k]).mul(phi1(z)).scale(h)
            } else {
                let d = eb.0[j].mul(eb.1[k]);
                let c = ea.0[j].mul(ea.1[k]);
                C(d.0 - c.0, d.1 - c.1).div(nu)
            };
            let re = cj.mul(dk).mul(int).0;
            sum += if pair == (j, k) { re } else { 2.0 * re };
        }
    }
    sum
}

/// `∫_a^b x(τ)² dτ` in closed form, for a sum without polynomial terms: the hot path of RMS.
///
/// With `x = k0 + Re(Ĥ e^{iΩτ}) + Re(D̂ e^{λτ})` (`Ĥ = a − ib`, `D̂ = p − iq`, `λ = −α + iω_d`),
/// `Re(z)² = (|z|² + Re z²)/2` and `2 Re z Re y = Re(zy) + Re(z ȳ)` turn the 25 products of
/// [`integral_product`] into seven exponentials `e^{ντ}` (`ν = iΩ, λ, 2iΩ, −2α, 2λ, iΩ+λ,
/// iΩ+λ̄`) and a constant, each integrated as there (the series `φ1` when `|ν(b−a)| < 1/2`, so
/// that no term loses precision). The exponentials at an end are products of `e^{iΩτ}` and
/// `e^{λτ}`; at `a = 0` they are 1 and cost nothing.
pub fn integral_square(x: &ExpSum, a: f64, b: f64) -> f64 {
    integral_square_to(x, a, b, None)
}

/// [`integral_square`] with the transcendentals at `b` given (`end.tau` must be `b`).
pub fn integral_square_to(x: &ExpSum, a: f64, b: f64, end: Option<&Trig>) -> f64 {
    let h = b - a;
    if h <= 0.0 {
        return 0.0;
    }
    debug_assert!(x.c1 == 0.0 && x.c2 == 0.0);
    let hh = C(x.a, -x.b);
    let dd = C(x.p, -x.q);
    let e1 = C(0.0, x.om);
    let l = C(-x.al, x.wd);
    // e^{iΩτ}, e^{λτ} at an end.
    let ends = |t: f64| -> (C, C) {
        if t == 0.0 {
            return (C(1.0, 0.0), C(1.0, 0.0));
        }
        let (sh, ch) = (x.om * t).sin_cos();
        let (sd, cd) = (x.wd * t).sin_cos();
        let e = (-x.al * t).exp();
        (C(ch, sh), C(e * cd, e * sd))
    };
    let (ha, da) = ends(a);
    let (hb, db) = match end {
        Some(t) => {
            debug_assert!(t.tau.to_bits() == b.to_bits());
            let e = 1.0 + t.em1;
            (C(t.ch, t.sh), C(e * t.cd, e * t.sd))
        }
        None => ends(b),
    };
    // ∫_a^b e^{ντ} dτ from e^{νa}, e^{νb}.
    let int = |nu: C, ea: C, eb: C| -> C {
        let z = nu.scale(h);
        if z.0 * z.0 + z.1 * z.1 < 0.25 {
            ea.mul(phi1(z)).scale(h)
        } else {
            C(eb.0 - ea.0, eb.1 - ea.1).div(nu)
        }
    };
    let h2 = hh.0 * hh.0 + hh.1 * hh.1;
    let d2 = dd.0 * dd.0 + dd.1 * dd.1;
    let mut sum = (x.k0 * x.k0 + 0.5 * h2) * h;
    if h2 != 0.0 {
        sum += 2.0 * x.k0 * hh.mul(int(e1, ha, hb)).0;
        sum += 0.5 * hh.mul(hh).mul(int(e1.scale(2.0), ha.mul(ha), hb.mul(hb))).0;
    }
    if d2 != 0.0 {
        sum += 2.0 * x.k0 * dd.mul(int(l, da, db)).0;
        let (ra, rb) = (da.0 * da.0 + da.1 * da.1, db.0 * db.0 + db.1 * db.1);
        sum += 0.5 * d2 * int(C(-2.0 * x.al, 0.0), C(ra, 0.0), C(rb, 0.0)).0;
        sum += 0.5 * dd.mul(dd).mul(int(l.scale(2.0), da.mul(da), db.mul(db))).0;
        if h2 != 0.0 {
            sum += hh.mul(dd).mul(int(e1.add(l), ha.mul(da), hb.mul(db))).0;
            sum += hh
                .mul(dd.conj())
                .mul(int(e1.add(l.conj()), ha.mul(da.conj()), hb.mul(db.conj())))
                .0;
        }
    }
    sum
}

/// `1/(k+1)!`, `k = 0..15` (the φ₁ series here, and `expsum_n`'s `exp_m1`).
pub(in crate::solver::exact) const INV_FACT: [f64; 16] = [
    1.0,
    1.0 / 2.0,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5_040.0,
    1.0 / 40_320.0,
    1.0 / 362_880.0,
    1.0 / 3_628_800.0,
    1.0 / 39_916_800.0,
    1.0 / 479_001_600.0,
    1.0 / 6_227_020_800.0,
    1.0 / 87_178_291_200.0,
    1.0 / 1_307_674_368_000.0,
    1.0 / 20_922_789_888_000.0,
];

/// `(e^z − 1)/z` for `|z| < 1/2` by its series `Σ z^k/(k+1)!`, truncated where the next term
/// is below `2e-18` (degree 5, 10 or 15 by `|z|`), evaluated as even and odd parts in `z²`
/// (two independent Horner chains of half the length).
pub(in crate::solver::exact) fn phi1(z: C) -> C {
    let r2 = z.0 * z.0 + z.1 * z.1;
    // |z|^(n+1)/(n+2)! < 2e-18 for: |z| ≤ 1e-3 → n = 5, ≤ 0.1 → n = 10, < 0.5 → n = 15.
    let n = if r2 <= 1e-6 {
        5
    } else if r2 <= 1e-2 {
        10
    } else {
        15
    };
    let w = z.mul(z);
    // Highest even and odd indices ≤ n.
    let (mut ke, mut ko) = if n % 2 == 0 { (n, n - 1) } else { (n - 1, n) };
    let mut e = C(INV_FACT[ke], 0.0);
    let mut o = C(INV_FACT[ko], 0.0);
    while ke >= 2 {
        ke -= 2;
        e = w.mul(e).add(C(INV_FACT[ke], 0.0));
    }
    while ko >= 2 {
        ko -= 2;
        o = w.mul(o).add(C(INV_FACT[ko], 0.0));
    }
    e.add(z.mul(o))
}

/// Minimal complex number (no dependency needed for five terms).
#[derive(Debug, Clone, Copy)]
pub(in crate::solver::exact) struct C(
    pub(in crate::solver::exact) f64,
    pub(in crate::solver::exact) f64,
);

impl C {
    pub(in crate::solver::exact) fn add(self, o: C) -> C {
        C(self.0 + o.0, self.1 + o.1)
    }
    pub(in crate::solver::exact) fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    pub(in crate::solver::exact) fn scale(self, s: f64) -> C {
        C(self.0 * s, self.1 * s)
    }
    pub(in crate::solver::exact) fn conj(self) -> C {
        C(self.0, -self.1)
    }
    pub(in crate::solver::exact) fn div(self, o: C) -> C {
        let d = o.0 * o.0 + o.1 * o.1;
        C(
            (self.0 * o.0 + self.1 * o.1) / d,
            (self.1 * o.0 - self.0 * o.1) / d,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> ExpSum {
        ExpSum {
            f0: 0.3,
            k0: 0.3 - 0.7 - 0.5,
            c1: 0.0,
            c2: 0.0,
            a: 0.7,
            b: -0.2,
            om: 3.0,
            p: 0.5,
            q: 0.4,
            al: 0.2,
            wd: 5.0,
        }
    }

    fn naive(f: &ExpSum, t: f64) -> f64 {
        f.k0 + f.c1 * t
            + f.c2 * t * t
            + f.a * (f.om * t).cos()
            + f.b * (f.om * t).sin()
            + (-f.al * t).exp() * (f.p * (f.wd * t).cos() + f.q * (f.wd * t).sin())
    }

    #[test]
    fn value_and_derivatives_match_naive_and_finite_differences() {
        let mut f = sample();
        f.c1 = 0.1;
        f.c2 = -0.3;
        for &t in &[0.0, 0.1, 1.3, 7.7] {
            assert!((f.value(t) - naive(&f, t)).abs() < 1e-14);
            let d: [f64; 4] = f.derivs(t);
            let df = f.deriv();
            assert!(
                (d[1] - df.value(t)).abs() < 1e-13,
                "{} {}",
                d[1],
                df.value(t)
            );
            assert!((d[2] - df.deriv().value(t)).abs() < 1e-12);
            let h = 1e-5;
            let fd = (f.value(t + h) - f.value(t - h)) / (2.0 * h);
            assert!((fd - d[1]).abs() < 1e-8);
            let fd3 = (f.derivs::<3>(t + h)[2] - f.derivs::<3>(t - h)[2]) / (2.0 * h);
            assert!((fd3 - d[3]).abs() < 1e-6);
        }
    }

    #[test]
    fn transcendentals_near_resonance_match_direct_ones() {
        // δτ inside and outside the series range, short and long τ.
        for (om, al, wd) in [
            (3784.0, 37.8, 3783.5),
            (3784.0, 37.0, 3700.0),
            (3.0, 0.2, 5.0),
        ] {
            for &tau in &[1e-7, 3e-4, 1.4e-3, 2.9e-3, 0.01, 0.7, 1.9] {
                let t = Trig::new(tau, om, al, wd);
                let (sd, cd) = (wd * tau).sin_cos();
                // Rounding of the phase ω_dτ itself is ~ulp(ω_dτ) ≤ 1e-12 here.
                let tol = 4.0 * f64::EPSILON * (1.0 + wd * tau);
                assert!((t.cd - cd).abs() <= tol, "{tau} {} {cd}", t.cd);
                assert!((t.sd - sd).abs() <= tol, "{tau} {} {sd}", t.sd);
                assert!((t.cdm1 - (cd - 1.0)).abs() <= tol, "{tau}");
                let x = 1e-4;
                let s = Trig::new(x / om, om, 0.0, om);
                assert!((s.cdm1 - (-2.0 * (0.5 * x).sin().powi(2))).abs() <= 1e-20);
                // A nearly free mass (ω_d ≪ Ω): sin ω_dτ and cos ω_dτ − 1 keep their relative
                // accuracy (the coefficients multiplying them are huge).
                let wd = 1e-6;
                let t = Trig::new(tau, om, al, wd);
                let sd = (wd * tau).sin();
                let cdm1 = -2.0 * (0.5 * wd * tau).sin().powi(2);
                assert!((t.sd - sd).abs() <= 4.0 * f64::EPSILON * sd.abs(), "{tau}");
                assert!(
                    (t.cdm1 - cdm1).abs() <= 4.0 * f64::EPSILON * cdm1.abs(),
                    "{tau}"
                );
            }
        }
        // The series itself against libm over its range.
        for i in -100..=100 {
            let x = 0.125 * i as f64 / 100.0;
            let (s, cm) = small_sin_cm1(x);
            assert!((s - x.sin()).abs() <= 2.0 * f64::EPSILON * x.abs(), "{x}");
            let want = -2.0 * (0.5 * x).sin().powi(2);
            assert!((cm - want).abs() <= 4.0 * f64::EPSILON * want.abs(), "{x}");
        }
    }

    #[test]
    fn phi1_matches_its_definition() {
        // (e^z − 1)/z directly where that is accurate enough (|z| not tiny), in each tier.
        for &(re, im) in &[
            (0.3, -0.35),
            (-0.49, 0.0),
            (0.05, 0.07),
            (-0.02, 0.0),
            (8e-4, -5e-4),
        ] {
            let z = C(re, im);
            let p = phi1(z);
            let (s, c) = im.sin_cos();
            let e = re.exp_m1();
            // e^z − 1 = (e^x − 1)cos y + (cos y − 1) + i e^x sin y.
            let num = C(e * c - 2.0 * (0.5 * im).sin().powi(2), (1.0 + e) * s);
            let want = num.div(z);
            let err = (p.0 - want.0).hypot(p.1 - want.1);
            assert!(err < 1e-15, "{re} {im}: {err}");
        }
        let t = phi1(C(1e-9, 0.0));
        assert!((t.0 - (1.0 + 0.5e-9)).abs() < 1e-16 && t.1 == 0.0);
    }

    #[test]
    fn bounds_hold() {
        let mut f = sample();
        f.c1 = 0.1;
        f.c2 = -0.3;
        for n in 1..5u32 {
            let bnd = f.deriv_bound(n, 0.5, 3.0);
            let mut g = f;
            for _ in 0..n {
                g = g.deriv();
            }
            for i in 0..=1000 {
                let t = 0.5 + 2.5 * i as f64 / 1000.0;
                assert!(g.value(t).abs() <= bnd);
            }
        }
    }

    #[test]
    fn square_integral_matches_the_product_integral() {
        // Near resonance (ω_d ≈ Ω, the slow beat term), away from it, undamped, and with a large
        // static part; short, long and offset intervals.
        let mut cases = vec![sample()];
        let mut near = sample();
        near.wd = 3.0001;
        near.al = 0.01;
        cases.push(near);
        let mut und = sample();
        und.al = 0.0;
        cases.push(und);
        let mut stat = sample();
        stat.k0 = 1e3;
        stat.f0 = stat.k0 + stat.a + stat.p;
        cases.push(stat);
        let mut only_h = sample();
        only_h.p = 0.0;
        only_h.q = 0.0;
        cases.push(only_h);
        for x in cases {
            for &(a, b) in &[
                (0.0, 2.0),
                (0.0, 1e-4),
                (1.0, 1.0001),
                (3.0, 10.0),
                (0.0, 40.0),
            ] {
                let p = integral_product(&x, &x, a, b);
                let s = integral_square(&x, a, b);
                assert!((p - s).abs() <= 1e-13 * p.abs(), "{p} {s}");
                let tb = Trig::new(b, x.om, x.al, x.wd);
                let st = integral_square_to(&x, a, b, Some(&tb));
                assert!((st - s).abs() <= 1e-14 * s.abs(), "{st} {s}");
            }
        }
    }

    /// Simpson's rule for `∫_a^b f` on `n` (even) intervals.
    fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
        let h = (b - a) / n as f64;
        let s: f64 = (0..=n)
            .map(|i| {
                let w = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                w * f(a + i as f64 * h)
            })
            .sum();
        s * h / 3.0
    }

    #[test]
    fn product_integral_matches_simpson() {
        let x = sample();
        let y = x.deriv();
        for &(a, b) in &[(0.0, 2.0), (1.0, 1.0001), (3.0, 10.0)] {
            let s = simpson(|t| naive(&x, t) * naive(&y, t), a, b, 20000);
            let c = integral_product(&x, &y, a, b);
            assert!((c - s).abs() < 1e-11 * (1.0 + s.abs()), "{c} {s}");
        }
    }

    #[test]
    fn shifted_product_integral_matches_simpson_across_frequencies_and_origins() {
        // Two sums with different decay, damped frequency and origins, both with a constant
        // part, over a long interval, a short one and one that starts late; the shifts are
        // where the sums were started, as two planes' segments.
        let x = sample();
        let mut y = sample();
        y.k0 = 0.05;
        y.f0 = y.k0 + y.a + y.p;
        y.a = -0.4;
        y.b = 0.9;
        y.p = 0.2;
        y.q = -0.6;
        y.al = 0.35;
        y.wd = 4.2;
        let (x0, y0) = (0.4, -1.1);
        for &(a, b) in &[(0.4, 3.0), (1.0, 1.0001), (2.5, 9.0)] {
            let s = simpson(|t| naive(&x, t - x0) * naive(&y, t - y0), a, b, 40000);
            let c = integral_product_shifted(&x, x0, &y, y0, a, b);
            assert!((c - s).abs() < 1e-11 * (1.0 + s.abs()), "{c} {s}");
            // Swapped, and equal to the common-origin form where the sums agree.
            let d = integral_product_shifted(&y, y0, &x, x0, a, b);
            assert!((c - d).abs() <= 1e-14 * (1.0 + c.abs()), "{c} {d}");
        }
        let z = x.deriv();
        let p = integral_product(&x, &z, 0.5, 4.0);
        let q = integral_product_shifted(&x, 0.0, &z, 0.0, 0.5, 4.0);
        assert!((p - q).abs() <= 1e-15 * (1.0 + p.abs()), "{p} {q}");
    }
}
