//! A measured frequency response function (FRF) as plain data: the lines of a tap test, in SI
//! units, checked once on construction. No I/O: the file formats (UFF 58/58b, plain columns)
//! live in `vibrobar-io` and produce a [`MeasuredFrf`]; the lobes ([`crate::analysis::lobes_frf`])
//! and the modal fit take one.
//!
//! **Convention.** `H(ω)` is the response per unit force under `e^{iωt}` time dependence, the
//! convention of every FRF in this project (`G = 1/(k − mω² + icω)` for one mode). Its three
//! kinds ([`FrfKind`]) are receptance `G` (m/N), mobility `Y = iω G` ((m/s)/N) and accelerance
//! `A = −ω² G` ((m/s²)/N).
//!
//! **Passivity of a driving point** (force and response at one point, one direction): the power
//! a force puts into a passive structure is never negative, so `Im G ≤ 0`, `Re Y ≥ 0` and
//! `Im A ≥ 0` at every frequency ([`MeasuredFrf::check_passivity`]). A conjugated sign
//! convention (`e^{−iωt}`) or a reversed hammer or accelerometer breaks it on nearly every line
//! (conjugation keeps `Re Y`, so a mobility shows only the reversed sign).

use num_complex::Complex64;
use std::f64::consts::PI;
use thiserror::Error;

/// Most lines an FRF may hold (bounds the memory a file can ask for: 64 MB of values).
pub const MAX_FRF_LINES: usize = 4_000_000;

/// Largest share of the dissipative part `Σ|q|` (module docs) that may have the wrong sign
/// before [`MeasuredFrf::check_passivity`] refuses the FRF: noise flips the sign of `q` on lines
/// where `|q|` is at the noise level; a conjugated or negated FRF has nearly all of it wrong.
pub const PASSIVITY_MAX_WRONG_SHARE: f64 = 0.1;

/// What the response of an FRF is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrfKind {
    /// Displacement per force `G`, m/N.
    Receptance,
    /// Velocity per force `Y = iω G`, (m/s)/N.
    Mobility,
    /// Acceleration per force `A = −ω² G`, (m/s²)/N.
    Accelerance,
}

impl FrfKind {
    /// The name users type (`receptance`, `mobility`, `accelerance`).
    pub fn name(self) -> &'static str {
        match self {
            FrfKind::Receptance => "receptance",
            FrfKind::Mobility => "mobility",
            FrfKind::Accelerance => "accelerance",
        }
    }

    /// Its SI unit.
    pub fn si_unit(self) -> &'static str {
        match self {
            FrfKind::Receptance => "m/N",
            FrfKind::Mobility => "(m/s)/N",
            FrfKind::Accelerance => "(m/s²)/N",
        }
    }

    /// Parse a name (case-insensitive; `dynamic compliance`, `admittance` and `inertance` are
    /// accepted as the usual synonyms).
    pub fn parse(text: &str) -> Option<FrfKind> {
        match text.trim().to_ascii_lowercase().as_str() {
            "receptance" | "compliance" | "dynamic compliance" => Some(FrfKind::Receptance),
            "mobility" | "admittance" => Some(FrfKind::Mobility),
            "accelerance" | "inertance" => Some(FrfKind::Accelerance),
            _ => None,
        }
    }

    /// The factor `c(ω)` with `H = c(ω)·G`: `1`, `iω`, `−ω²`.
    pub fn factor(self, omega_rad_s: f64) -> Complex64 {
        match self {
            FrfKind::Receptance => Complex64::new(1.0, 0.0),
            FrfKind::Mobility => Complex64::new(0.0, omega_rad_s),
            FrfKind::Accelerance => Complex64::new(-omega_rad_s * omega_rad_s, 0.0),
        }
    }

    /// The dissipative part `q` of a driving-point value, `≥ 0` for a passive structure:
    /// `−Im G`, `Re Y`, `Im A`.
    pub fn dissipative_part(self, h: Complex64) -> f64 {
        match self {
            FrfKind::Receptance => -h.im,
            FrfKind::Mobility => h.re,
            FrfKind::Accelerance => h.im,
        }
    }

    /// The passivity condition in words.
    pub fn passivity_condition(self) -> &'static str {
        match self {
            FrfKind::Receptance => "Im G ≤ 0",
            FrfKind::Mobility => "Re Y ≥ 0",
            FrfKind::Accelerance => "Im A ≥ 0",
        }
    }
}

/// Why FRF data was refused. `index` counts the lines of the FRF from 0; readers of files turn
/// it into a line of the file.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FrfDataError {
    /// Too few or too many lines.
    #[error("the FRF has {lines} line(s); allowed [{min}, {max}]")]
    LineCount {
        /// Lines given.
        lines: usize,
        /// Fewest allowed.
        min: usize,
        /// Most allowed.
        max: usize,
    },
    /// Two arrays that must be as long as the frequencies are not.
    #[error("{what} has {got} entries, the frequencies {expected}")]
    LengthMismatch {
        /// Which array.
        what: &'static str,
        /// Number of frequencies.
        expected: usize,
        /// Its length.
        got: usize,
    },
    /// A frequency is NaN, infinite or negative.
    #[error("frequency at line {index} is {value} Hz; allowed: finite and ≥ 0")]
    BadFrequency {
        /// Line.
        index: usize,
        /// Value.
        value: f64,
    },
    /// The frequencies do not increase.
    #[error("frequency at line {index} ({value} Hz) is not above the one before it ({previous} Hz); the lines must be strictly increasing")]
    NotIncreasing {
        /// Line.
        index: usize,
        /// Its frequency.
        value: f64,
        /// The frequency of the line before.
        previous: f64,
    },
    /// A value is NaN or infinite.
    #[error("value at line {index} ({re} + {im}i) is not finite")]
    NonFiniteValue {
        /// Line.
        index: usize,
        /// Real part.
        re: f64,
        /// Imaginary part.
        im: f64,
    },
    /// A coherence is outside [0, 1] or not finite.
    #[error("coherence at line {index} is {value}; allowed [0, 1]")]
    BadCoherence {
        /// Line.
        index: usize,
        /// Value.
        value: f64,
    },
    /// A conversion or correction that divides by `ω` met the 0 Hz line.
    #[error("{what} divides by the frequency: line {index} is at 0 Hz; drop it first")]
    ZeroFrequency {
        /// What was asked.
        what: &'static str,
        /// Line.
        index: usize,
    },
    /// The lines are not evenly spaced where a method needs it.
    #[error("the lines are not evenly spaced: the step before line {index} is {step} Hz, the first step {first_step} Hz (relative tolerance {rel_tol}); {what} needs an even spacing")]
    UnevenSpacing {
        /// Line.
        index: usize,
        /// Its step.
        step: f64,
        /// The first step.
        first_step: f64,
        /// Tolerance used.
        rel_tol: f64,
        /// The method that needs it.
        what: &'static str,
    },
    /// A driving-point FRF that a passive structure cannot have.
    #[error("the FRF fails the passivity check of a driving point: {kind} of a passive structure has {condition}, but {wrong_lines} of {lines} lines break it, carrying {share_pct:.1} % of the dissipative part (allowed {allowed_pct:.0} %), the worst at {worst_hz} Hz. {diagnosis}")]
    NotPassive {
        /// The kind's name.
        kind: &'static str,
        /// The condition, e.g. `Im G ≤ 0`.
        condition: &'static str,
        /// Lines breaking it.
        wrong_lines: usize,
        /// All lines.
        lines: usize,
        /// Share of `Σ|q|` with the wrong sign, per cent.
        share_pct: f64,
        /// The allowed share, per cent.
        allowed_pct: f64,
        /// Frequency of the largest violation.
        worst_hz: f64,
        /// What probably happened and how to fix it.
        diagnosis: String,
    },
    /// Records that cannot be averaged.
    #[error("records cannot be averaged: {0}")]
    Average(String),
    /// The accelerometer mass is not usable or its cancellation divides by zero.
    #[error("accelerometer mass cancellation: {0}")]
    MassCancellation(String),
}

impl FrfDataError {
    /// The FRF line the error is about, if one.
    pub fn index(&self) -> Option<usize> {
        match self {
            FrfDataError::BadFrequency { index, .. }
            | FrfDataError::NotIncreasing { index, .. }
            | FrfDataError::NonFiniteValue { index, .. }
            | FrfDataError::BadCoherence { index, .. }
            | FrfDataError::ZeroFrequency { index, .. }
            | FrfDataError::UnevenSpacing { index, .. } => Some(*index),
            _ => None,
        }
    }
}

/// The result of a passed passivity check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Passivity {
    /// Lines with the wrong sign of the dissipative part (noise).
    pub wrong_lines: usize,
    /// Their share of `Σ|q|`, in [0, 1].
    pub wrong_share: f64,
}

/// A measured FRF: lines in Hz, complex values in SI units of its [`FrfKind`].
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredFrf {
    /// Frequencies, Hz: finite, ≥ 0, strictly increasing.
    pub freqs_hz: Vec<f64>,
    /// Values at those frequencies, SI units of `kind` (m/N, (m/s)/N or (m/s²)/N).
    pub values: Vec<Complex64>,
    /// Receptance, mobility or accelerance.
    pub kind: FrfKind,
    /// Coherence per line in [0, 1], if measured (used as weights).
    pub coherence: Option<Vec<f64>>,
    /// Force and response at the same point and direction (the passivity check applies).
    pub driving_point: bool,
    /// Where the units and the kind came from, for the user (e.g. "dataset 164: mm, N").
    pub units_note: String,
}

impl MeasuredFrf {
    /// Check and build: at least 2 and at most [`MAX_FRF_LINES`] lines, frequencies finite,
    /// `≥ 0` and strictly increasing, values finite, coherence (if any) as long and in [0, 1].
    pub fn new(
        freqs_hz: Vec<f64>,
        values: Vec<Complex64>,
        kind: FrfKind,
        coherence: Option<Vec<f64>>,
        driving_point: bool,
        units_note: String,
    ) -> Result<Self, FrfDataError> {
        let n = freqs_hz.len();
        if !(2..=MAX_FRF_LINES).contains(&n) {
            return Err(FrfDataError::LineCount {
                lines: n,
                min: 2,
                max: MAX_FRF_LINES,
            });
        }
        if values.len() != n {
            return Err(FrfDataError::LengthMismatch {
                what: "values",
                expected: n,
                got: values.len(),
            });
        }
        for (i, &f) in freqs_hz.iter().enumerate() {
            if !(f.is_finite() && f >= 0.0) {
                return Err(FrfDataError::BadFrequency { index: i, value: f });
            }
            if i > 0 && f <= freqs_hz[i - 1] {
                return Err(FrfDataError::NotIncreasing {
                    index: i,
                    value: f,
                    previous: freqs_hz[i - 1],
                });
            }
        }
        for (i, v) in values.iter().enumerate() {
            if !(v.re.is_finite() && v.im.is_finite()) {
                return Err(FrfDataError::NonFiniteValue {
                    index: i,
                    re: v.re,
                    im: v.im,
                });
            }
        }
        if let Some(c) = &coherence {
            if c.len() != n {
                return Err(FrfDataError::LengthMismatch {
                    what: "coherence",
                    expected: n,
                    got: c.len(),
                });
            }
            for (i, &g) in c.iter().enumerate() {
                if !(0.0..=1.0).contains(&g) {
                    return Err(FrfDataError::BadCoherence { index: i, value: g });
                }
            }
        }
        Ok(MeasuredFrf {
            freqs_hz,
            values,
            kind,
            coherence,
            driving_point,
            units_note,
        })
    }

    /// Number of lines.
    pub fn len(&self) -> usize {
        self.freqs_hz.len()
    }

    /// Never true for a checked FRF (at least 2 lines); here for the usual pairing with `len`.
    pub fn is_empty(&self) -> bool {
        self.freqs_hz.is_empty()
    }

    /// The same FRF as `kind` (`H_new = c_new(ω)/c_old(ω) · H`, [`FrfKind::factor`]). Errors on
    /// a 0 Hz line when the conversion divides by `ω`.
    pub fn to_kind(&self, kind: FrfKind) -> Result<MeasuredFrf, FrfDataError> {
        if kind == self.kind {
            return Ok(self.clone());
        }
        let mut out = self.clone();
        for (i, (v, &f)) in out.values.iter_mut().zip(&self.freqs_hz).enumerate() {
            let w = 2.0 * PI * f;
            let from = self.kind.factor(w);
            if from.norm() == 0.0 {
                return Err(FrfDataError::ZeroFrequency {
                    what: "conversion of the FRF kind",
                    index: i,
                });
            }
            *v = *v * kind.factor(w) / from;
        }
        out.kind = kind;
        Ok(out)
    }

    /// The receptance `G` (m/N): `Y/(iω)` from mobility, `−A/ω²` from accelerance.
    pub fn to_receptance(&self) -> Result<MeasuredFrf, FrfDataError> {
        self.to_kind(FrfKind::Receptance)
    }

    /// The FRF without its lines at 0 Hz (at most the first), e.g. before [`Self::to_kind`].
    pub fn without_zero_frequency(&self) -> Result<MeasuredFrf, FrfDataError> {
        if self.freqs_hz[0] > 0.0 {
            return Ok(self.clone());
        }
        MeasuredFrf::new(
            self.freqs_hz[1..].to_vec(),
            self.values[1..].to_vec(),
            self.kind,
            self.coherence.as_ref().map(|c| c[1..].to_vec()),
            self.driving_point,
            self.units_note.clone(),
        )
    }

    /// The complex conjugate (an FRF written under `e^{−iωt}`, brought to `e^{iωt}`).
    pub fn conjugated(&self) -> MeasuredFrf {
        let mut out = self.clone();
        out.values.iter_mut().for_each(|v| *v = v.conj());
        out
    }

    /// The negated FRF (a reversed hammer or sensor direction).
    pub fn negated(&self) -> MeasuredFrf {
        let mut out = self.clone();
        out.values.iter_mut().for_each(|v| *v = -*v);
        out
    }

    /// The step of evenly spaced lines, Hz: every step within `rel_tol` of the first; else
    /// [`FrfDataError::UnevenSpacing`] naming the first line off and `what` needs it.
    pub fn even_step_hz(&self, rel_tol: f64, what: &'static str) -> Result<f64, FrfDataError> {
        let f = &self.freqs_hz;
        let first = f[1] - f[0];
        for i in 2..f.len() {
            let step = f[i] - f[i - 1];
            if (step - first).abs() > rel_tol * first {
                return Err(FrfDataError::UnevenSpacing {
                    index: i,
                    step,
                    first_step: first,
                    rel_tol,
                    what,
                });
            }
        }
        Ok(first)
    }

    /// The passivity check of a driving point (module docs): the dissipative part `q`
    /// ([`FrfKind::dissipative_part`]) must not have the wrong sign on more than
    /// [`PASSIVITY_MAX_WRONG_SHARE`] of `Σ|q|`. A cross FRF passes unchecked.
    pub fn check_passivity(&self) -> Result<Passivity, FrfDataError> {
        if !self.driving_point {
            return Ok(Passivity {
                wrong_lines: 0,
                wrong_share: 0.0,
            });
        }
        let (mut total, mut wrong, mut n_wrong) = (0.0, 0.0, 0usize);
        let (mut worst, mut worst_hz) = (0.0, f64::NAN);
        for (v, &f) in self.values.iter().zip(&self.freqs_hz) {
            let q = self.kind.dissipative_part(*v);
            total += q.abs();
            if q < 0.0 {
                wrong += -q;
                n_wrong += 1;
                if -q > worst {
                    worst = -q;
                    worst_hz = f;
                }
            }
        }
        let share = if total > 0.0 { wrong / total } else { 0.0 };
        if share <= PASSIVITY_MAX_WRONG_SHARE {
            return Ok(Passivity {
                wrong_lines: n_wrong,
                wrong_share: share,
            });
        }
        // Conjugation keeps the conservative part, negation flips it: at the lowest line
        // (stiffness-controlled, below every resonance) the receptance of a passive bar has
        // Re G > 0.
        let low = self
            .freqs_hz
            .iter()
            .zip(&self.values)
            .find(|(f, _)| **f > 0.0)
            .map(|(f, v)| v / self.kind.factor(2.0 * PI * f));
        let diagnosis = match low {
            Some(g) if g.re > 0.0 => "Its real part looks right, so the values are probably conjugated (written under the e^{−iωt} convention): conjugate them (--frf-conjugate).",
            Some(_) => "Its real part is negative at the lowest line too, so the sign is probably reversed (hammer or sensor pointing the other way, or a response or reference direction of the wrong sign): negate it (--frf-negate).",
            None => "It is probably conjugated (e^{−iωt} convention: --frf-conjugate) or negated (a reversed hammer or sensor: --frf-negate).",
        };
        Err(FrfDataError::NotPassive {
            kind: self.kind.name(),
            condition: self.kind.passivity_condition(),
            wrong_lines: n_wrong,
            lines: self.len(),
            share_pct: 100.0 * share,
            allowed_pct: 100.0 * PASSIVITY_MAX_WRONG_SHARE,
            worst_hz,
            diagnosis: diagnosis.to_string(),
        })
    }

    /// Remove the mass `m_a` of an accelerometer at the response point of a driving-point FRF:
    /// `G = G_m/(1 + m_a ω² G_m)` for the receptance, in the FRF's own kind
    /// (`Y = Y_m/(1 − i m_a ω Y_m)`, `A = A_m/(1 − m_a A_m)`).
    pub fn cancel_accelerometer_mass(&self, mass_kg: f64) -> Result<MeasuredFrf, FrfDataError> {
        if !(0.0..=1e3).contains(&mass_kg) {
            return Err(FrfDataError::MassCancellation(format!(
                "the accelerometer mass is {mass_kg} kg; allowed [0, 1000] kg"
            )));
        }
        if !self.driving_point {
            return Err(FrfDataError::MassCancellation(
                "it applies to a driving-point FRF (the accelerometer at the force point); this FRF is a cross FRF".into(),
            ));
        }
        let mut out = self.clone();
        for (i, (v, &f)) in out.values.iter_mut().zip(&self.freqs_hz).enumerate() {
            let w = 2.0 * PI * f;
            let d = match self.kind {
                FrfKind::Receptance => 1.0 + mass_kg * w * w * *v,
                FrfKind::Mobility => 1.0 - Complex64::new(0.0, mass_kg * w) * *v,
                FrfKind::Accelerance => 1.0 - mass_kg * *v,
            };
            let h = *v / d;
            if !(h.re.is_finite() && h.im.is_finite()) || d.norm() == 0.0 {
                return Err(FrfDataError::MassCancellation(format!(
                    "1 + m_a ω² G_m is zero at line {i} ({f} Hz): the mass {mass_kg} kg is not the accelerometer's"
                )));
            }
            *v = h;
        }
        Ok(out)
    }

    /// The average of several records of one FRF (repeated taps): the same lines and kind.
    /// With a coherence on every record each line is weighted by it,
    /// `H = Σ γ²ₖ Hₖ / Σ γ²ₖ` (a plain mean where every weight is 0), and the result carries
    /// the mean coherence; otherwise the plain mean, without coherence.
    pub fn average(records: &[MeasuredFrf]) -> Result<MeasuredFrf, FrfDataError> {
        let first = records
            .first()
            .ok_or_else(|| FrfDataError::Average("no record given".into()))?;
        for (k, r) in records.iter().enumerate().skip(1) {
            if r.kind != first.kind {
                return Err(FrfDataError::Average(format!(
                    "record {} is a {}, record 1 a {}",
                    k + 1,
                    r.kind.name(),
                    first.kind.name()
                )));
            }
            if r.freqs_hz != first.freqs_hz {
                return Err(FrfDataError::Average(format!(
                    "record {} has other frequency lines than record 1",
                    k + 1
                )));
            }
            if r.driving_point != first.driving_point {
                return Err(FrfDataError::Average(format!(
                    "record {} and record 1 are not both driving-point FRFs",
                    k + 1
                )));
            }
        }
        let n = first.len();
        let k = records.len() as f64;
        let weighted = records.iter().all(|r| r.coherence.is_some());
        let mut values = Vec::with_capacity(n);
        let mut coh = Vec::with_capacity(if weighted { n } else { 0 });
        for i in 0..n {
            let plain = records.iter().map(|r| r.values[i]).sum::<Complex64>() / k;
            if weighted {
                let w: Vec<f64> = records
                    .iter()
                    .map(|r| r.coherence.as_ref().expect("checked")[i])
                    .collect();
                let sw: f64 = w.iter().sum();
                let v = if sw > 0.0 {
                    records
                        .iter()
                        .zip(&w)
                        .map(|(r, &wk)| r.values[i] * wk)
                        .sum::<Complex64>()
                        / sw
                } else {
                    plain
                };
                values.push(v);
                coh.push((sw / k).clamp(0.0, 1.0));
            } else {
                values.push(plain);
            }
        }
        MeasuredFrf::new(
            first.freqs_hz.clone(),
            values,
            first.kind,
            weighted.then_some(coh),
            first.driving_point,
            format!(
                "{} (average of {} records{})",
                first.units_note,
                records.len(),
                if weighted {
                    ", weighted by coherence"
                } else {
                    ""
                }
            ),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One mode, `G = 1/(k − mω² + icω)`.
    fn sdof(f: f64, m: f64, k: f64, c: f64) -> Complex64 {
        let w = 2.0 * PI * f;
        1.0 / Complex64::new(k - m * w * w, c * w)
    }

    fn frf(freqs: &[f64], m: f64, kind: FrfKind) -> MeasuredFrf {
        let g: Vec<Complex64> = freqs.iter().map(|&f| sdof(f, m, 1e6, 20.0)).collect();
        MeasuredFrf::new(
            freqs.to_vec(),
            g,
            FrfKind::Receptance,
            None,
            true,
            String::new(),
        )
        .unwrap()
        .to_kind(kind)
        .unwrap()
    }

    #[test]
    fn constructor_names_the_line() {
        let ok = || vec![Complex64::new(1.0, -1.0); 3];
        let e = MeasuredFrf::new(
            vec![1.0, 2.0, 2.0],
            ok(),
            FrfKind::Receptance,
            None,
            true,
            String::new(),
        )
        .unwrap_err();
        assert_eq!(e.index(), Some(2));
        let mut v = ok();
        v[1].im = f64::NAN;
        let e = MeasuredFrf::new(
            vec![1.0, 2.0, 3.0],
            v,
            FrfKind::Receptance,
            None,
            true,
            String::new(),
        )
        .unwrap_err();
        assert!(matches!(e, FrfDataError::NonFiniteValue { index: 1, .. }));
        let e = MeasuredFrf::new(
            vec![1.0, 2.0, 3.0],
            ok(),
            FrfKind::Receptance,
            Some(vec![0.5, 1.5, 1.0]),
            true,
            String::new(),
        )
        .unwrap_err();
        assert!(matches!(e, FrfDataError::BadCoherence { index: 1, .. }));
        let e = MeasuredFrf::new(
            vec![-1.0, 2.0],
            ok()[..2].to_vec(),
            FrfKind::Receptance,
            None,
            true,
            String::new(),
        )
        .unwrap_err();
        assert!(matches!(e, FrfDataError::BadFrequency { index: 0, .. }));
    }

    #[test]
    fn kinds_convert_as_closed_forms_and_back() {
        let freqs: Vec<f64> = (1..200).map(|i| i as f64 * 1.5).collect();
        let g = frf(&freqs, 0.5, FrfKind::Receptance);
        let y = g.to_kind(FrfKind::Mobility).unwrap();
        let a = g.to_kind(FrfKind::Accelerance).unwrap();
        for (i, &f) in freqs.iter().enumerate() {
            let w = 2.0 * PI * f;
            // Y = iω/(k − mω² + icω), A = −ω²/(…): the closed forms.
            let gi = sdof(f, 0.5, 1e6, 20.0);
            assert!((y.values[i] - Complex64::new(0.0, w) * gi).norm() <= 1e-15 * (w * gi.norm()));
            assert!((a.values[i] + w * w * gi).norm() <= 1e-15 * (w * w * gi.norm()));
        }
        let back = a.to_receptance().unwrap();
        for i in 0..freqs.len() {
            assert!((back.values[i] - g.values[i]).norm() <= 1e-15 * g.values[i].norm());
        }
        // The 0 Hz line cannot be converted, and is named.
        let mut z = g.clone();
        z.freqs_hz[0] = 0.0;
        let z = z.to_kind(FrfKind::Accelerance).unwrap();
        let e = z.to_receptance().unwrap_err();
        assert_eq!(e.index(), Some(0));
        assert_eq!(z.without_zero_frequency().unwrap().len(), freqs.len() - 1);
    }

    #[test]
    fn passivity_passes_the_model_and_refuses_conjugate_and_negation() {
        let freqs: Vec<f64> = (1..2000).map(|i| i as f64).collect();
        for kind in [FrfKind::Receptance, FrfKind::Mobility, FrfKind::Accelerance] {
            let h = frf(&freqs, 0.1, kind);
            let p = h.check_passivity().unwrap();
            assert_eq!(p.wrong_lines, 0);
            // Conjugation keeps Re Y: a conjugated mobility passes (it is passive under
            // either convention); the receptance and the accelerance catch it.
            let conj = h.conjugated().check_passivity();
            if kind == FrfKind::Mobility {
                assert!(conj.is_ok());
            } else {
                let e = conj.unwrap_err().to_string();
                assert!(
                    e.contains("conjugate") && e.contains(kind.passivity_condition()),
                    "{e}"
                );
            }
            let e = h.negated().check_passivity().unwrap_err().to_string();
            assert!(e.contains("negate"), "{e}");
            // A cross FRF is not checked.
            let mut cross = h.conjugated();
            cross.driving_point = false;
            assert!(cross.check_passivity().is_ok());
        }
        // Noise that flips Im G far from the resonance (|Im G| at the noise level) passes.
        let mut h = frf(&freqs, 0.1, FrfKind::Receptance);
        let scale = h.values.iter().map(|v| v.norm()).fold(0.0, f64::max);
        for (i, v) in h.values.iter_mut().enumerate() {
            v.im += if i % 2 == 0 { 1e-3 } else { -1e-3 } * scale;
        }
        let p = h.check_passivity().unwrap();
        assert!(p.wrong_lines > 100 && p.wrong_share < PASSIVITY_MAX_WRONG_SHARE);
    }

    #[test]
    fn accelerometer_mass_is_removed_exactly() {
        // Measured with the accelerometer: the mass m + m_a; cancelled: the bar alone.
        let (m, ma) = (0.4, 0.012);
        let freqs: Vec<f64> = (1..400).map(|i| i as f64 * 0.7).collect();
        let truth = frf(&freqs, m, FrfKind::Receptance);
        for kind in [FrfKind::Receptance, FrfKind::Mobility, FrfKind::Accelerance] {
            let measured = frf(&freqs, m + ma, kind);
            let fixed = measured
                .cancel_accelerometer_mass(ma)
                .unwrap()
                .to_receptance()
                .unwrap();
            for i in 0..freqs.len() {
                let d = (fixed.values[i] - truth.values[i]).norm() / truth.values[i].norm();
                assert!(d < 1e-11, "{kind:?} line {i}: {d:e}");
            }
        }
        let mut cross = truth.clone();
        cross.driving_point = false;
        assert!(cross.cancel_accelerometer_mass(ma).is_err());
        assert!(truth.cancel_accelerometer_mass(f64::NAN).is_err());
    }

    #[test]
    fn average_weights_by_coherence() {
        let f = vec![1.0, 2.0];
        let mk = |v: [f64; 2], c: Option<[f64; 2]>| {
            MeasuredFrf::new(
                f.clone(),
                v.iter().map(|&x| Complex64::new(x, -x)).collect(),
                FrfKind::Receptance,
                c.map(|c| c.to_vec()),
                true,
                "SI".into(),
            )
            .unwrap()
        };
        let a = mk([1.0, 2.0], Some([0.9, 0.0]));
        let b = mk([3.0, 6.0], Some([0.3, 0.0]));
        let avg = MeasuredFrf::average(&[a.clone(), b.clone()]).unwrap();
        // (0.9·1 + 0.3·3)/1.2 = 1.5; all weights zero: the plain mean 4.
        assert!((avg.values[0].re - 1.5).abs() < 1e-15);
        assert!((avg.values[1].re - 4.0).abs() < 1e-15);
        assert_eq!(avg.coherence.as_ref().unwrap(), &vec![0.6, 0.0]);
        let plain = MeasuredFrf::average(&[a, mk([3.0, 6.0], None)]).unwrap();
        assert!((plain.values[0].re - 2.0).abs() < 1e-15);
        assert!(plain.coherence.is_none());
        let other = MeasuredFrf::new(
            vec![1.0, 2.5],
            vec![Complex64::new(1.0, -1.0); 2],
            FrfKind::Receptance,
            None,
            true,
            String::new(),
        )
        .unwrap();
        assert!(MeasuredFrf::average(&[b, other]).is_err());
    }

    #[test]
    fn even_spacing_names_the_first_uneven_line() {
        let h = frf(&[1.0, 2.0, 3.0, 4.5, 5.5], 0.1, FrfKind::Receptance);
        let e = h.even_step_hz(1e-9, "the fit").unwrap_err();
        assert_eq!(e.index(), Some(3));
        let h = frf(&[1.0, 2.0, 3.0, 4.0], 0.1, FrfKind::Receptance);
        assert!((h.even_step_hz(1e-9, "the fit").unwrap() - 1.0).abs() < 1e-15);
    }
}
