//! Modes from a measured FRF: the modal fit behind a tap test.
//!
//! A hammer tap at the tool tip gives the driving-point FRF `H(ω)` (receptance, mobility or
//! accelerance). `[[modes]]` wants each mode's undamped frequency, damping ratio, modal mass in
//! the tip normalisation and the shape at the cavity. The fit gets them in three steps:
//!
//! 1. **Poles by least-squares complex frequency (LSCF)**, the method behind PolyMAX, over a
//!    range of model orders, with a stabilisation chart ([`stabilisation`]).
//! 2. **Residues by least-squares frequency domain (LSFD)**: with the poles fixed, the residues
//!    and the residual terms are linear unknowns.
//! 3. **Refinement:** poles, residues and residuals together by nonlinear least squares
//!    (Levenberg–Marquardt with the analytic Jacobian). LSCF's poles come from a discrete-time
//!    polynomial model that is not exactly a sum of modes; without this step a noise-free
//!    three-mode FRF is recovered to a few 1e-6 (order 40), with it to rounding.
//!
//! # The model
//!
//! In receptance form, with poles `λᵣ = −ζᵣωᵣ + iωᵣ√(1 − ζᵣ²)` and residues `Rᵣ`,
//!
//! `G(ω) = Σᵣ [Rᵣ/(iω − λᵣ) + R̄ᵣ/(iω − λ̄ᵣ)] + U − L/ω²`,
//!
//! with the upper residual `U` (the modes above the band, a compliance) and the lower residual
//! `L` (those below it, a mass line; off by default: a clamped bar has no rigid-body mode).
//! Mobility and accelerance are fitted in their own form, `iω·G` and `−ω²·G`, not converted
//! first: converting noisy accelerance to receptance multiplies the low-frequency noise by `1/ω²`.
//!
//! # From poles and residues to `[[modes]]`
//!
//! For a mode of modal mass `m` with the shape 1 at the tip, `G = 1/(m(iω − λ)(iω − λ̄))`, so
//! `R = 1/(2i·ω_d·m)` with `ω_d = Im λ`. Hence
//!
//! * `frequency_hz = |λ|/2π` (undamped), `damping_ratio = −Re λ/|λ|`;
//! * `modal_mass_kg = Re[1/(2i·ω_d·R)]`, with the modal stiffness `m·ωₙ²` beside it;
//! * the shape at the cavity from a cross FRF (tap at the cavity, response at the tip, or the
//!   reverse by reciprocity): `R_cross = φ_cav/(2i·ω_d·m)`, so `φ_cav = Re(R_cross/R_tip)`.
//!
//! A receptance residue of a lightly damped mode has the phase −90°; the fit reports it per mode
//! ([`FittedMode::residue_phase_deg`]) as a check of the sign convention.
//!
//! # LSCF
//!
//! The FRF on the band `[f₁, f₂]` is modelled as a ratio of polynomials in `z = e^{iωΔt}`,
//! `Δt = 1/(2 f₂)`, with real coefficients, `H ≈ B(z)/A(z)`, of order `n` (an even number: `n/2`
//! conjugate pole pairs). Minimising the linearised error `Σ w²|B(z) − H A(z)|²` with the
//! highest coefficient of `A` fixed to 1 reduces, after eliminating `B`, to the
//! `n × n` system `(T − SᵀR⁻¹S) α = −(T − SᵀR⁻¹S)ₙ`, where
//! `R`, `S` and `T` are the Toeplitz matrices of the sums `Σ w² cos(mωΔt)`,
//! `−Re Σ w² H e^{imωΔt}` and `Σ w²|H|² cos(mωΔt)`. The poles are `λ = ln(z)/Δt` at the roots
//! of `A` (the eigenvalues of its companion matrix). The sums are computed once for the highest
//! order; each lower order uses their leading blocks.
//!
//! **Stability** between consecutive orders `n − 2` and `n`: a pole is stable when the nearest
//! pole of the lower order differs by less than [`StabilityCriteria::freq_rel`] (1 %) in
//! frequency and [`StabilityCriteria::damping_rel`] (5 %) in damping ratio, and its damping is
//! positive. A physical mode shows as a column of stable poles over many orders; numerical poles
//! wander. [`pick_poles`] groups the stable poles by frequency, keeps the groups stable at
//! [`FitSettings::min_stable_orders`] orders or more, and takes each pole at the highest order
//! where it is stable; or the user names the frequencies.
//!
//! # Quality
//!
//! Per mode: the residue phase, FRAC (the frequency response assurance criterion between the
//! measured and the fitted FRF over the mode's band `ωᵣ(1 ± 3ζᵣ)`), MPC of the mode's complex
//! shape over the fitted FRFs (1 for a single FRF: one entry is always collinear), and a flag
//! for negative damping. Overall: the relative fit error `‖w(H_fit − H)‖/‖wH‖` over the band.
//! MAC is not reported: with one or two points it means little.

use crate::error::ParamError;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use std::f64::consts::PI;

pub use super::frf_data::FrfKind;

/// Most lines of one FRF the fit takes (memory and time stay small: the sums are `O(lines ×
/// order)`).
pub const MAX_FIT_LINES: usize = 1_000_000;
/// Highest LSCF model order (poles, counting conjugates).
pub const MAX_MODEL_ORDER: usize = 200;
/// Most modes one fit returns.
pub const MAX_FIT_MODES: usize = crate::limits::MAX_BEAM_MODES;

/// One FRF as the fit reads it: lines in Hz (strictly increasing, positive), values in SI units
/// of its form, optional weights per line (e.g. the coherence; 0 drops a line).
#[derive(Debug, Clone, Copy)]
pub struct FrfLines<'a> {
    /// Frequencies, Hz.
    pub freqs_hz: &'a [f64],
    /// Values at those lines.
    pub values: &'a [Complex64],
    /// Weights per line in `[0, 1]` (the fit minimises `Σ (w|H_fit − H|)²`); `None` for 1.
    pub weights: Option<&'a [f64]>,
    /// Receptance, mobility or accelerance.
    pub form: FrfKind,
}

impl<'a> From<&'a super::frf_data::MeasuredFrf> for FrfLines<'a> {
    /// The measured FRF's lines, its coherence as the weights.
    fn from(m: &'a super::frf_data::MeasuredFrf) -> Self {
        FrfLines {
            freqs_hz: &m.freqs_hz,
            values: &m.values,
            weights: m.coherence.as_deref(),
            form: m.kind,
        }
    }
}

/// The stability criteria between consecutive model orders.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StabilityCriteria {
    /// Largest relative change of frequency, `|Δf|/f`.
    pub freq_rel: f64,
    /// Largest relative change of damping ratio, `|Δζ|/ζ`.
    pub damping_rel: f64,
}

impl Default for StabilityCriteria {
    fn default() -> Self {
        Self {
            freq_rel: 0.01,
            damping_rel: 0.05,
        }
    }
}

/// How to fit.
#[derive(Debug, Clone, PartialEq)]
pub struct FitSettings {
    /// The band, Hz; `None` for the whole record.
    pub band_hz: Option<(f64, f64)>,
    /// Highest LSCF model order (even; poles counting conjugates).
    pub max_order: usize,
    /// The stability criteria.
    pub criteria: StabilityCriteria,
    /// Fewest orders at which a pole must be stable to count as a mode (automatic picking).
    pub min_stable_orders: usize,
    /// Pick the stable poles nearest these frequencies instead (Hz).
    pub poles_hz: Option<Vec<f64>>,
    /// Fit an upper residual (modes above the band).
    pub upper_residual: bool,
    /// Fit a lower residual (modes below the band).
    pub lower_residual: bool,
    /// Refine poles and residues together by nonlinear least squares.
    pub refine: bool,
}

impl Default for FitSettings {
    fn default() -> Self {
        Self {
            band_hz: None,
            max_order: 40,
            criteria: StabilityCriteria::default(),
            min_stable_orders: 4,
            poles_hz: None,
            upper_residual: true,
            lower_residual: false,
            refine: true,
        }
    }
}

/// One pole of the stabilisation chart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChartPole {
    /// The model order it came from.
    pub order: usize,
    /// The pole (upper half plane).
    pub pole: Complex64,
    /// Undamped frequency, Hz.
    pub frequency_hz: f64,
    /// Damping ratio.
    pub damping_ratio: f64,
    /// Frequency within the criterion of the lower order's nearest pole.
    pub stable_frequency: bool,
    /// Damping within the criterion as well.
    pub stable_damping: bool,
}

impl ChartPole {
    /// Stable in frequency and damping, with positive damping.
    pub fn stable(&self) -> bool {
        self.stable_frequency && self.stable_damping && self.damping_ratio > 0.0
    }
}

/// The LSCF poles at every order, for the stabilisation chart.
#[derive(Debug, Clone, PartialEq)]
pub struct Stabilisation {
    /// The band fitted, Hz.
    pub band_hz: (f64, f64),
    /// Every pole in the band at every order (2, 4, …, `max_order`).
    pub poles: Vec<ChartPole>,
}

/// One fitted mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FittedMode {
    /// The pole `λ`.
    pub pole: Complex64,
    /// The residue of the driving-point FRF (receptance form).
    pub residue: Complex64,
    /// The residue of the cross FRF, if one was given.
    pub residue_cross: Option<Complex64>,
    /// Undamped frequency `|λ|/2π`, Hz.
    pub frequency_hz: f64,
    /// Damping ratio `−Re λ/|λ|`.
    pub damping_ratio: f64,
    /// Modal mass with the shape 1 at the tip, `Re[1/(2i ω_d R)]`.
    pub modal_mass_kg: f64,
    /// Modal stiffness `m ωₙ²`.
    pub modal_stiffness_n_per_m: f64,
    /// The shape at the cavity, `Re(R_cross/R)`, if a cross FRF was given.
    pub shape_cavity: Option<f64>,
    /// The residue's phase, degrees (−90° for a receptance of a lightly damped mode).
    pub residue_phase_deg: f64,
    /// FRAC between the measured and the fitted driving-point FRF over `ωᵣ(1 ± 3ζᵣ)`.
    pub frac: f64,
    /// Modal phase collinearity of the residues over the fitted FRFs (1 for one FRF).
    pub mpc: f64,
    /// The LSCF model order the pole was taken at.
    pub order: usize,
}

impl FittedMode {
    /// The damping ratio is negative: not a physical mode of a passive bar.
    pub fn negative_damping(&self) -> bool {
        self.damping_ratio <= 0.0
    }
}

/// The result of a fit.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalFit {
    /// The stabilisation chart.
    pub chart: Stabilisation,
    /// The modes by increasing frequency.
    pub modes: Vec<FittedMode>,
    /// Upper residual `U` (receptance form, m/N), 0 when not fitted.
    pub upper_residual: f64,
    /// Lower residual `L` (receptance form, `−L/ω²`, 1/kg), 0 when not fitted.
    pub lower_residual: f64,
    /// The same for the cross FRF.
    pub upper_residual_cross: f64,
    /// The same for the cross FRF.
    pub lower_residual_cross: f64,
    /// Relative fit error of the driving-point FRF over the band, `‖w(H_fit − H)‖/‖wH‖`.
    pub fit_error: f64,
    /// The same for the cross FRF.
    pub fit_error_cross: Option<f64>,
    /// Levenberg–Marquardt iterations of the refinement (0 without it).
    pub refine_iterations: usize,
}

impl ModalFit {
    /// The fitted driving-point receptance at `ω`, with the residuals.
    pub fn receptance(&self, omega_rad_s: f64) -> Complex64 {
        let modes: Vec<(Complex64, Complex64)> =
            self.modes.iter().map(|m| (m.pole, m.residue)).collect();
        synth(
            &modes,
            self.upper_residual,
            self.lower_residual,
            omega_rad_s,
        )
    }

    /// The fitted cross receptance at `ω`, if a cross FRF was fitted.
    pub fn receptance_cross(&self, omega_rad_s: f64) -> Option<Complex64> {
        let modes: Option<Vec<(Complex64, Complex64)>> = self
            .modes
            .iter()
            .map(|m| m.residue_cross.map(|r| (m.pole, r)))
            .collect();
        modes.map(|m| {
            synth(
                &m,
                self.upper_residual_cross,
                self.lower_residual_cross,
                omega_rad_s,
            )
        })
    }

    /// The residuals' share of the fitted driving-point receptance at `ω`:
    /// `|U − L/ω²| / |G(ω)|`.
    pub fn residual_share(&self, omega_rad_s: f64) -> f64 {
        let r = self.upper_residual - self.lower_residual / (omega_rad_s * omega_rad_s);
        r.abs() / self.receptance(omega_rad_s).norm()
    }
}

/// The receptance of poles and residues plus residuals at `ω`.
fn synth(modes: &[(Complex64, Complex64)], upper: f64, lower: f64, w: f64) -> Complex64 {
    let iw = Complex64::new(0.0, w);
    let mut g = Complex64::new(upper - lower / (w * w), 0.0);
    for &(lam, r) in modes {
        g += r / (iw - lam) + r.conj() / (iw - lam.conj());
    }
    g
}

/// Undamped frequency (Hz) and damping ratio of a pole.
pub fn pole_frequency_damping(pole: Complex64) -> (f64, f64) {
    let a = pole.norm();
    (a / (2.0 * PI), -pole.re / a)
}

/// The band's lines: indices into the data, their ω and their weights.
struct Band {
    idx: Vec<usize>,
    omega: Vec<f64>,
    w: Vec<f64>,
    band_hz: (f64, f64),
}

fn check_lines(d: &FrfLines, name: &'static str) -> Result<(), ParamError> {
    let n = d.freqs_hz.len();
    if n != d.values.len() || d.weights.is_some_and(|w| w.len() != n) {
        return Err(ParamError::Limit {
            field: name,
            value: d.values.len() as f64,
            min: n as f64,
            max: n as f64,
            why: "values and weights need one entry per frequency line",
        });
    }
    if !(4..=MAX_FIT_LINES).contains(&n) {
        return Err(ParamError::Limit {
            field: name,
            value: n as f64,
            min: 4.0,
            max: MAX_FIT_LINES as f64,
            why: "frequency lines of one FRF",
        });
    }
    for (k, &f) in d.freqs_hz.iter().enumerate() {
        crate::params::finite("frf frequency_hz", f)?;
        if f <= 0.0 || (k > 0 && f <= d.freqs_hz[k - 1]) {
            return Err(ParamError::OutOfRange {
                field: "frf frequency_hz",
                value: f,
                allowed: "(0, ∞) and strictly increasing line by line",
            });
        }
    }
    for v in d.values {
        crate::params::finite("frf value (real part)", v.re)?;
        crate::params::finite("frf value (imaginary part)", v.im)?;
    }
    if let Some(w) = d.weights {
        for &x in w {
            if !(0.0..=1.0).contains(&x) {
                return Err(ParamError::OutOfRange {
                    field: "frf weight (coherence)",
                    value: x,
                    allowed: "[0, 1]",
                });
            }
        }
    }
    Ok(())
}

fn band(d: &FrfLines, band_hz: Option<(f64, f64)>) -> Result<Band, ParamError> {
    let (lo_d, hi_d) = (d.freqs_hz[0], *d.freqs_hz.last().unwrap());
    let (lo, hi) = band_hz.unwrap_or((lo_d, hi_d));
    crate::params::finite("band_hz low end (--band-hz)", lo)?;
    crate::params::finite("band_hz high end (--band-hz)", hi)?;
    if lo < lo_d || lo >= hi_d {
        return Err(ParamError::Limit {
            field: "band_hz low end (--band-hz)",
            value: lo,
            min: lo_d,
            max: hi_d,
            why: "the band must lie within the measured lines",
        });
    }
    if hi <= lo || hi > hi_d {
        return Err(ParamError::Limit {
            field: "band_hz high end (--band-hz)",
            value: hi,
            min: lo,
            max: hi_d,
            why: "the band must lie within the measured lines, above its low end",
        });
    }
    let mut b = Band {
        idx: vec![],
        omega: vec![],
        w: vec![],
        band_hz: (lo, hi),
    };
    for (k, &f) in d.freqs_hz.iter().enumerate() {
        let w = d.weights.map_or(1.0, |w| w[k]);
        if f >= lo && f <= hi && w > 0.0 {
            b.idx.push(k);
            b.omega.push(2.0 * PI * f);
            b.w.push(w);
        }
    }
    if b.idx.len() < 4 {
        return Err(ParamError::Limit {
            field: "band_hz (--band-hz): lines with a positive weight",
            value: b.idx.len() as f64,
            min: 4.0,
            max: MAX_FIT_LINES as f64,
            why: "widen the band",
        });
    }
    Ok(b)
}

/// The LSCF poles at orders 2, 4, …, `settings.max_order` over the band.
pub fn stabilisation(d: &FrfLines, settings: &FitSettings) -> Result<Stabilisation, ParamError> {
    check_lines(d, "frf lines")?;
    let b = band(d, settings.band_hz)?;
    lscf(d, &b, settings)
}

fn lscf(d: &FrfLines, b: &Band, settings: &FitSettings) -> Result<Stabilisation, ParamError> {
    let n = settings.max_order;
    // The linear system has 2(n+1) real unknowns from 2 equations per line.
    let max_n = (b.idx.len() - 1).min(MAX_MODEL_ORDER);
    if n < 2 || n % 2 != 0 || n > max_n {
        return Err(ParamError::Limit {
            field: "max_order (--max-order)",
            value: n as f64,
            min: 2.0,
            max: (max_n - max_n % 2) as f64,
            why: "an even number below the number of lines in the band (and at most 200)",
        });
    }
    let dt = 1.0 / (2.0 * b.band_hz.1);
    // Toeplitz generators: r_m = Σ w² cos(mθ), t_m = Σ w²|H|² cos(mθ),
    // s_m = −Re Σ w² H e^{imθ} for m = −n..n (θ = ωΔt).
    let mut r = vec![0.0; n + 1];
    let mut t = vec![0.0; n + 1];
    let mut s = vec![0.0; 2 * n + 1];
    for (j, &k) in b.idx.iter().enumerate() {
        let th = b.omega[j] * dt;
        let w2 = b.w[j] * b.w[j];
        let h = d.values[k];
        let h2 = h.norm_sqr();
        let step = Complex64::from_polar(1.0, th);
        let mut z = Complex64::new(1.0, 0.0);
        for m in 0..=n {
            r[m] += w2 * z.re;
            t[m] += w2 * h2 * z.re;
            let hz = h * z;
            let hzc = h * z.conj();
            s[n + m] -= w2 * hz.re;
            if m > 0 {
                s[n - m] -= w2 * hzc.re;
            }
            // Recompute every 32 powers to keep the recurrence's rounding small.
            z = if m % 32 == 31 {
                Complex64::from_polar(1.0, th * (m + 1) as f64)
            } else {
                z * step
            };
        }
    }
    // R_jl = r_|l−j|, T_jl = t_|l−j|, S_jl = s_(l−j) (S = Re ΓᴴΥ, Γ_j = w z^j, Υ_l = −w H z^l).
    let big_r = DMatrix::from_fn(n + 1, n + 1, |j, l| r[j.abs_diff(l)]);
    let big_t = DMatrix::from_fn(n + 1, n + 1, |j, l| t[j.abs_diff(l)]);
    let big_s = DMatrix::from_fn(n + 1, n + 1, |j, l| s[n + l - j]);
    let mut poles = Vec::new();
    let mut prev: Vec<(f64, f64)> = Vec::new();
    for order in (2..=n).step_by(2) {
        let k = order + 1;
        let rr = big_r.view((0, 0), (k, k)).into_owned();
        let ss = big_s.view((0, 0), (k, k)).into_owned();
        let tt = big_t.view((0, 0), (k, k)).into_owned();
        let Some(rinv_s) = rr.clone().lu().solve(&ss) else {
            break;
        };
        let m = tt - ss.transpose() * rinv_s;
        let a = m.view((0, 0), (order, order)).into_owned();
        let rhs = -m.view((0, order), (order, 1)).into_owned();
        let Some(alpha) = a.lu().solve(&rhs) else {
            continue;
        };
        // Companion matrix of A(z) = z^n + α_{n−1} z^{n−1} + … + α₀.
        let mut c = DMatrix::<f64>::zeros(order, order);
        for i in 0..order {
            c[(0, i)] = -alpha[order - 1 - i];
            if i + 1 < order {
                c[(i + 1, i)] = 1.0;
            }
        }
        let roots = c.complex_eigenvalues();
        let mut here = Vec::new();
        for zr in roots.iter() {
            if zr.norm() == 0.0 || !zr.re.is_finite() || !zr.im.is_finite() {
                continue;
            }
            let lam = zr.ln() / dt;
            if lam.im <= 0.0 {
                continue;
            }
            let (f, zeta) = pole_frequency_damping(lam);
            if f < b.band_hz.0 || f > b.band_hz.1 {
                continue;
            }
            let near = prev
                .iter()
                .min_by(|p, q| (p.0 - f).abs().partial_cmp(&(q.0 - f).abs()).unwrap());
            let (sf, sd) = match near {
                Some(&(pf, pz)) => (
                    ((f - pf) / f).abs() < settings.criteria.freq_rel,
                    ((zeta - pz) / zeta).abs() < settings.criteria.damping_rel,
                ),
                None => (false, false),
            };
            here.push((f, zeta));
            poles.push(ChartPole {
                order,
                pole: lam,
                frequency_hz: f,
                damping_ratio: zeta,
                stable_frequency: sf,
                stable_damping: sd,
            });
        }
        prev = here;
    }
    Ok(Stabilisation {
        band_hz: b.band_hz,
        poles,
    })
}

/// The modes' poles from a stabilisation chart: each group of stable poles (by frequency) seen
/// at `min_stable_orders` orders or more, taken at the highest order where it is stable; or, with
/// `poles_hz`, the stable pole nearest each frequency (within 5 %), at its highest order.
pub fn pick_poles(
    chart: &Stabilisation,
    settings: &FitSettings,
) -> Result<Vec<ChartPole>, ParamError> {
    let mut stable: Vec<ChartPole> = chart.poles.iter().copied().filter(|p| p.stable()).collect();
    stable.sort_by(|a, b| a.frequency_hz.partial_cmp(&b.frequency_hz).unwrap());
    if let Some(want) = &settings.poles_hz {
        if want.is_empty() || want.len() > MAX_FIT_MODES {
            return Err(ParamError::Limit {
                field: "poles_hz (--poles-hz)",
                value: want.len() as f64,
                min: 1.0,
                max: MAX_FIT_MODES as f64,
                why: "",
            });
        }
        let mut out = Vec::new();
        for &f in want {
            crate::params::finite("poles_hz (--poles-hz)", f)?;
            let best = stable
                .iter()
                .filter(|p| ((p.frequency_hz - f) / f).abs() < 0.05)
                .max_by(|a, b| {
                    a.order.cmp(&b.order).then(
                        (b.frequency_hz - f)
                            .abs()
                            .partial_cmp(&(a.frequency_hz - f).abs())
                            .unwrap(),
                    )
                });
            match best {
                Some(p) => out.push(*p),
                None => {
                    return Err(ParamError::OutOfRange {
                        field: "poles_hz (--poles-hz)",
                        value: f,
                        allowed:
                            "within 5 % of a stable pole of the chart (see the stabilisation CSV)",
                    })
                }
            }
        }
        out.sort_by(|a, b| a.frequency_hz.partial_cmp(&b.frequency_hz).unwrap());
        return Ok(out);
    }
    // Group by frequency: a pole joins the group while within the frequency criterion of the
    // group's first member.
    let mut out: Vec<ChartPole> = Vec::new();
    let mut i = 0;
    while i < stable.len() {
        let f0 = stable[i].frequency_hz;
        let mut j = i;
        while j < stable.len() && (stable[j].frequency_hz - f0) / f0 < settings.criteria.freq_rel {
            j += 1;
        }
        let group = &stable[i..j];
        let mut orders: Vec<usize> = group.iter().map(|p| p.order).collect();
        orders.sort_unstable();
        orders.dedup();
        if orders.len() >= settings.min_stable_orders {
            let top = *orders.last().unwrap();
            // At the top order, the member nearest the group's median frequency.
            let mut fs: Vec<f64> = group.iter().map(|p| p.frequency_hz).collect();
            fs.sort_by(|a, b| a.partial_cmp(b).unwrap());
            let med = fs[fs.len() / 2];
            let p = group
                .iter()
                .filter(|p| p.order == top)
                .min_by(|a, b| {
                    (a.frequency_hz - med)
                        .abs()
                        .partial_cmp(&(b.frequency_hz - med).abs())
                        .unwrap()
                })
                .unwrap();
            out.push(*p);
        }
        i = j;
    }
    if out.len() > MAX_FIT_MODES {
        out.truncate(MAX_FIT_MODES);
    }
    Ok(out)
}

/// Real least-squares columns of the model at one line (receptance form times the FRF form's
/// factor): per mode `Re R`, `Im R`, then `U`, then `L`.
fn lsfd_row(
    poles: &[Complex64],
    upper: bool,
    lower: bool,
    form: FrfKind,
    w: f64,
    out: &mut Vec<Complex64>,
) {
    out.clear();
    let iw = Complex64::new(0.0, w);
    let f = form.factor(w);
    for &lam in poles {
        let a = 1.0 / (iw - lam);
        let b = 1.0 / (iw - lam.conj());
        out.push(f * (a + b));
        out.push(f * Complex64::new(0.0, 1.0) * (a - b));
    }
    if upper {
        out.push(f);
    }
    if lower {
        out.push(-f / (w * w));
    }
}

/// Residues and residuals for fixed poles (LSFD). Returns the residues (receptance form) and
/// `(U, L)`.
fn lsfd(
    d: &FrfLines,
    b: &Band,
    poles: &[Complex64],
    settings: &FitSettings,
) -> Result<(Vec<Complex64>, f64, f64), ParamError> {
    let p = 2 * poles.len() + settings.upper_residual as usize + settings.lower_residual as usize;
    let rows = 2 * b.idx.len();
    if p >= rows {
        return Err(ParamError::Limit {
            field: "modes to fit",
            value: poles.len() as f64,
            min: 1.0,
            max: ((rows - 1) / 2) as f64,
            why: "more unknowns than the band's lines can determine",
        });
    }
    let mut a = DMatrix::<f64>::zeros(rows, p);
    let mut y = DVector::<f64>::zeros(rows);
    let mut row = Vec::with_capacity(p);
    for (j, &k) in b.idx.iter().enumerate() {
        lsfd_row(
            poles,
            settings.upper_residual,
            settings.lower_residual,
            d.form,
            b.omega[j],
            &mut row,
        );
        let w = b.w[j];
        for (c, v) in row.iter().enumerate() {
            a[(2 * j, c)] = w * v.re;
            a[(2 * j + 1, c)] = w * v.im;
        }
        y[2 * j] = w * d.values[k].re;
        y[2 * j + 1] = w * d.values[k].im;
    }
    // Column scaling keeps the normal equations of residues and residuals balanced.
    let scale: Vec<f64> = (0..p)
        .map(|c| a.column(c).norm().max(f64::MIN_POSITIVE))
        .collect();
    for (c, s) in scale.iter().enumerate() {
        a.column_mut(c).scale_mut(1.0 / s);
    }
    let x = a
        .svd(true, true)
        .solve(&y, 1e-14)
        .map_err(|_| ParamError::NonFiniteResult {
            quantity: "residues (LSFD)",
            value: f64::NAN,
            cause: "a singular least-squares problem: poles too close together or outside the band",
        })?;
    let x: Vec<f64> = x.iter().zip(&scale).map(|(v, s)| v / s).collect();
    let res = (0..poles.len())
        .map(|r| Complex64::new(x[2 * r], x[2 * r + 1]))
        .collect();
    let mut c = 2 * poles.len();
    let u = if settings.upper_residual {
        c += 1;
        x[c - 1]
    } else {
        0.0
    };
    let l = if settings.lower_residual { x[c] } else { 0.0 };
    Ok((res, u, l))
}

/// Parameters of the refinement: per mode `(Re λ, Im λ)` shared by every FRF, then per FRF per
/// mode `(Re R, Im R)` and its residuals.
struct Refine<'a> {
    data: Vec<(&'a FrfLines<'a>, &'a Band)>,
    modes: usize,
    upper: bool,
    lower: bool,
}

impl Refine<'_> {
    fn per_frf(&self) -> usize {
        2 * self.modes + self.upper as usize + self.lower as usize
    }
    fn n_params(&self) -> usize {
        2 * self.modes + self.data.len() * self.per_frf()
    }
    fn n_rows(&self) -> usize {
        self.data.iter().map(|(_, b)| 2 * b.idx.len()).sum()
    }
    /// Residual vector and (optionally) Jacobian.
    fn eval(&self, x: &[f64], res: &mut DVector<f64>, jac: Option<&mut DMatrix<f64>>) {
        let nm = self.modes;
        let mut jac = jac;
        if let Some(j) = jac.as_deref_mut() {
            j.fill(0.0);
        }
        let mut row = 0;
        let i = Complex64::new(0.0, 1.0);
        for (fi, (d, b)) in self.data.iter().enumerate() {
            let base = 2 * nm + fi * self.per_frf();
            for (jj, &k) in b.idx.iter().enumerate() {
                let w = b.omega[jj];
                let wt = b.w[jj];
                let iw = Complex64::new(0.0, w);
                let f = d.form.factor(w);
                let mut g = Complex64::new(0.0, 0.0);
                for r in 0..nm {
                    let lam = Complex64::new(x[2 * r], x[2 * r + 1]);
                    let rr = Complex64::new(x[base + 2 * r], x[base + 2 * r + 1]);
                    let a = 1.0 / (iw - lam);
                    let bb = 1.0 / (iw - lam.conj());
                    g += rr * a + rr.conj() * bb;
                    if let Some(jm) = jac.as_deref_mut() {
                        let da = rr * a * a + rr.conj() * bb * bb;
                        let db = i * (rr * a * a - rr.conj() * bb * bb);
                        let dre = a + bb;
                        let dim = i * (a - bb);
                        for (c, v) in [
                            (2 * r, da),
                            (2 * r + 1, db),
                            (base + 2 * r, dre),
                            (base + 2 * r + 1, dim),
                        ] {
                            let v = f * v * wt;
                            jm[(row, c)] = v.re;
                            jm[(row + 1, c)] = v.im;
                        }
                    }
                }
                let mut c = base + 2 * nm;
                if self.upper {
                    g += x[c];
                    if let Some(jm) = jac.as_deref_mut() {
                        let v = f * wt;
                        jm[(row, c)] = v.re;
                        jm[(row + 1, c)] = v.im;
                    }
                    c += 1;
                }
                if self.lower {
                    g -= x[c] / (w * w);
                    if let Some(jm) = jac.as_deref_mut() {
                        let v = -f * wt / (w * w);
                        jm[(row, c)] = v.re;
                        jm[(row + 1, c)] = v.im;
                    }
                }
                let e = (f * g - d.values[k]) * wt;
                res[row] = e.re;
                res[row + 1] = e.im;
                row += 2;
            }
        }
    }
}

/// Levenberg–Marquardt on the refinement's parameters; returns the iterations taken.
fn levenberg_marquardt(p: &Refine, x: &mut [f64]) -> usize {
    let (m, n) = (p.n_rows(), p.n_params());
    let mut res = DVector::zeros(m);
    let mut jac = DMatrix::zeros(m, n);
    let mut trial_res = DVector::zeros(m);
    p.eval(x, &mut res, Some(&mut jac));
    let mut cost = res.norm_squared();
    let mut mu = 1e-3;
    let mut it = 0;
    while it < 200 {
        it += 1;
        let jt = jac.transpose();
        let jtj = &jt * &jac;
        let g = &jt * &res;
        let mut improved = false;
        for _ in 0..30 {
            let mut a = jtj.clone();
            for k in 0..n {
                a[(k, k)] += mu * jtj[(k, k)].max(f64::MIN_POSITIVE);
            }
            let Some(step) = a.cholesky().map(|c| c.solve(&(-&g))) else {
                mu *= 10.0;
                continue;
            };
            let trial: Vec<f64> = x.iter().zip(step.iter()).map(|(a, b)| a + b).collect();
            p.eval(&trial, &mut trial_res, None);
            let tc = trial_res.norm_squared();
            if tc.is_finite() && tc < cost {
                let small = step
                    .iter()
                    .zip(x.iter())
                    .all(|(s, v)| s.abs() <= 1e-15 * v.abs().max(1e-300));
                x.copy_from_slice(&trial);
                let rel = (cost - tc) / cost.max(f64::MIN_POSITIVE);
                cost = tc;
                mu = (mu * 0.3).max(1e-15);
                improved = true;
                if small || rel < 1e-14 {
                    return it;
                }
                break;
            }
            mu *= 10.0;
        }
        if !improved {
            return it;
        }
        p.eval(x, &mut res, Some(&mut jac));
    }
    it
}

/// The whole fit: chart, picked poles, LSFD residues, refinement, quality. `cross` is a cross
/// FRF between the cavity and the tip (same lines, same form); it gives the cavity shape.
pub fn fit_modes(
    d: &FrfLines,
    cross: Option<&FrfLines>,
    settings: &FitSettings,
) -> Result<ModalFit, ParamError> {
    check_lines(d, "frf lines")?;
    let b = band(d, settings.band_hz)?;
    let bc = match cross {
        Some(c) => {
            check_lines(c, "cross frf lines")?;
            Some(band(c, Some(b.band_hz))?)
        }
        None => None,
    };
    let chart = lscf(d, &b, settings)?;
    let picked = pick_poles(&chart, settings)?;
    if picked.is_empty() {
        return Err(ParamError::OutOfRange {
            field: "stable poles in the band",
            value: 0.0,
            allowed: "at least one; raise --max-order, widen the band, or name --poles-hz",
        });
    }
    let poles: Vec<Complex64> = picked.iter().map(|p| p.pole).collect();
    let (res, u, l) = lsfd(d, &b, &poles, settings)?;
    let cres = match (cross, &bc) {
        (Some(c), Some(bc)) => Some(lsfd(c, bc, &poles, settings)?),
        _ => None,
    };
    // Refinement.
    let mut data = vec![(d, &b)];
    if let (Some(c), Some(bc)) = (cross, &bc) {
        data.push((c, bc));
    }
    let prob = Refine {
        data,
        modes: poles.len(),
        upper: settings.upper_residual,
        lower: settings.lower_residual,
    };
    let mut x = Vec::with_capacity(prob.n_params());
    for p in &poles {
        x.extend([p.re, p.im]);
    }
    let push = |res: &[Complex64], u: f64, l: f64, x: &mut Vec<f64>| {
        for r in res {
            x.extend([r.re, r.im]);
        }
        if settings.upper_residual {
            x.push(u);
        }
        if settings.lower_residual {
            x.push(l);
        }
    };
    push(&res, u, l, &mut x);
    if let Some((cr, cu, cl)) = &cres {
        push(cr, *cu, *cl, &mut x);
    }
    let iterations = if settings.refine {
        levenberg_marquardt(&prob, &mut x)
    } else {
        0
    };
    let nm = poles.len();
    let per = prob.per_frf();
    let unpack = |fi: usize| -> (Vec<Complex64>, f64, f64) {
        let base = 2 * nm + fi * per;
        let r = (0..nm)
            .map(|k| Complex64::new(x[base + 2 * k], x[base + 2 * k + 1]))
            .collect();
        let mut c = base + 2 * nm;
        let u = if settings.upper_residual {
            c += 1;
            x[c - 1]
        } else {
            0.0
        };
        let l = if settings.lower_residual { x[c] } else { 0.0 };
        (r, u, l)
    };
    let (res, u, l) = unpack(0);
    let cres = cross.map(|_| unpack(1));
    let mut modes = Vec::with_capacity(nm);
    for k in 0..nm {
        let lam = Complex64::new(x[2 * k], x[2 * k + 1]);
        let r = res[k];
        let (f, zeta) = pole_frequency_damping(lam);
        let m = (1.0 / (Complex64::new(0.0, 2.0 * lam.im) * r)).re;
        let wn = lam.norm();
        let rc = cres.as_ref().map(|c| c.0[k]);
        let shape = rc.map(|rc| (rc / r).re);
        let mpc = match rc {
            Some(rc) => mpc(&[r, rc]),
            None => 1.0,
        };
        modes.push(FittedMode {
            pole: lam,
            residue: r,
            residue_cross: rc,
            frequency_hz: f,
            damping_ratio: zeta,
            modal_mass_kg: m,
            modal_stiffness_n_per_m: m * wn * wn,
            shape_cavity: shape,
            residue_phase_deg: r.arg().to_degrees(),
            frac: 0.0,
            mpc,
            order: picked[k].order,
        });
    }
    modes.sort_by(|a, b| a.frequency_hz.partial_cmp(&b.frequency_hz).unwrap());
    let mut fit = ModalFit {
        chart,
        modes,
        upper_residual: u,
        lower_residual: l,
        upper_residual_cross: cres.as_ref().map_or(0.0, |c| c.1),
        lower_residual_cross: cres.as_ref().map_or(0.0, |c| c.2),
        fit_error: 0.0,
        fit_error_cross: None,
        refine_iterations: iterations,
    };
    fit.fit_error = fit_error(d, &b, |w| fit.receptance(w));
    if let (Some(c), Some(bc)) = (cross, &bc) {
        fit.fit_error_cross = Some(fit_error(c, bc, |w| fit.receptance_cross(w).unwrap()));
    }
    for k in 0..fit.modes.len() {
        let (wn, z) = (
            2.0 * PI * fit.modes[k].frequency_hz,
            fit.modes[k].damping_ratio,
        );
        let span = 3.0 * z.abs().max(1e-4);
        let (lo, hi) = (wn * (1.0 - span), wn * (1.0 + span));
        fit.modes[k].frac = frac(d, &b, lo, hi, |w| fit.receptance(w));
    }
    for m in &fit.modes {
        for v in [m.frequency_hz, m.damping_ratio, m.modal_mass_kg] {
            if !v.is_finite() {
                return Err(ParamError::NonFiniteResult {
                    quantity: "fitted mode",
                    value: v,
                    cause:
                        "the refinement diverged: try --no-refine, a narrower band or fewer modes",
                });
            }
        }
    }
    Ok(fit)
}

fn fit_error(d: &FrfLines, b: &Band, g: impl Fn(f64) -> Complex64) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (j, &k) in b.idx.iter().enumerate() {
        let w = b.omega[j];
        let h = d.values[k];
        let e = d.form.factor(w) * g(w) - h;
        num += b.w[j].powi(2) * e.norm_sqr();
        den += b.w[j].powi(2) * h.norm_sqr();
    }
    (num / den).sqrt()
}

/// FRAC `|Σ H̄_fit H|² / (Σ|H_fit|² Σ|H|²)` over the lines in `[lo, hi]` (rad/s); 1 where no
/// line falls in it is not claimed: NaN then.
fn frac(d: &FrfLines, b: &Band, lo: f64, hi: f64, g: impl Fn(f64) -> Complex64) -> f64 {
    let (mut c, mut a, mut e) = (Complex64::new(0.0, 0.0), 0.0, 0.0);
    for (j, &k) in b.idx.iter().enumerate() {
        let w = b.omega[j];
        if w < lo || w > hi {
            continue;
        }
        let f = d.form.factor(w) * g(w);
        let h = d.values[k];
        c += f.conj() * h;
        a += f.norm_sqr();
        e += h.norm_sqr();
    }
    if a == 0.0 || e == 0.0 {
        return f64::NAN;
    }
    c.norm_sqr() / (a * e)
}

/// Modal phase collinearity of a complex shape: 1 for a real (normal) mode, 0 for a purely
/// circular one.
pub fn mpc(v: &[Complex64]) -> f64 {
    let sxx: f64 = v.iter().map(|c| c.re * c.re).sum();
    let syy: f64 = v.iter().map(|c| c.im * c.im).sum();
    let sxy: f64 = v.iter().map(|c| c.re * c.im).sum();
    if sxx + syy == 0.0 {
        return f64::NAN;
    }
    ((sxx - syy).powi(2) + 4.0 * sxy * sxy) / (sxx + syy).powi(2)
}

impl ModalFit {
    /// The upper residual as one mode at `frequency_hz` (above the band): its static compliance
    /// is `U`, so `m = 1/(U ω²)`; the cavity shape is `U_cross/U` when a cross FRF was fitted,
    /// else 1 (the tip: say so to the user). `None` when `U ≤ 0` (no positive compliance to
    /// represent). Its damping ratio is the highest fitted mode's. Below half its frequency the
    /// pseudo-mode's receptance is within 33 % of `U`; it stands in for the modes above the band
    /// and is not a measured mode.
    pub fn pseudo_mode(&self, frequency_hz: f64) -> Option<super::MeasuredMode> {
        if self.upper_residual <= 0.0 || !(frequency_hz > 0.0 && frequency_hz.is_finite()) {
            return None;
        }
        let w = 2.0 * PI * frequency_hz;
        let m = 1.0 / (self.upper_residual * w * w);
        let zeta = self.modes.last().map_or(0.01, |m| m.damping_ratio.max(0.0));
        let shape = self
            .modes
            .first()
            .and_then(|m| m.residue_cross)
            .map_or(1.0, |_| self.upper_residual_cross / self.upper_residual);
        Some(super::MeasuredMode {
            frequency_hz,
            damping_ratio: zeta,
            modal_mass_kg: m,
            shape_cavity: shape,
            direction_deg: None,
        })
    }
}

/// The cavity shape of the `k`-th bending mode (`k` from 1) of a uniform clamped–free bar of
/// length `length_m`, the cavity at `cavity_from_clamp_m` from the clamp, in the tip
/// normalisation: the fallback when no cross FRF was measured (the `k`-th fitted mode is taken
/// as the bar's `k`-th bending mode).
pub fn uniform_beam_shape(
    k: usize,
    cavity_from_clamp_m: f64,
    length_m: f64,
) -> Result<f64, ParamError> {
    crate::params::positive("bar length (--length-mm)", length_m)?;
    if !(cavity_from_clamp_m > 0.0 && cavity_from_clamp_m <= length_m) {
        return Err(ParamError::OutOfRange {
            field: "cavity position from the clamp (--cavity-from-clamp-mm)",
            value: cavity_from_clamp_m,
            allowed: "(0, length]",
        });
    }
    if k == 0 || k > MAX_FIT_MODES {
        return Err(ParamError::Limit {
            field: "bending mode number",
            value: k as f64,
            min: 1.0,
            max: MAX_FIT_MODES as f64,
            why: "",
        });
    }
    Ok(super::analytic::UniformMode::new(k).shape(cavity_from_clamp_m / length_m))
}
