//! Frequency response functions (FRFs) of every model: linear receptances, the stepped sine of
//! the nonlinear damped bar, and a simulated tap test. No I/O.
//!
//! **Linear receptances** ([`linear_receptance`]). A bar's modes give the receptance between
//! any two of its points (force, cavity, response) in closed form,
//! `G(a, b; ω) = Σ φₙ(a) φₙ(b) / (mₙ(ωₙ² − ω² + 2iζₙωₙω))` ([`ModalModel::receptance`]). The
//! damped bar has two linear limits: the ball free (it never touches a wall: the bar alone) and
//! the ball stuck at the cavity (its mass added there, the mass matrix `diag(m) + m_d φ_d φ_dᵀ`).
//! The stuck receptance follows from the free one by the Sherman–Morrison formula, with `d` the
//! cavity:
//!
//! `G_stuck(a, b) = G(a, b) + ω² m_d G(a, d) G(d, b) / (1 − ω² m_d G(d, d))`.
//!
//! **Stepped sine** ([`stepped_sine`]): a force-controlled shaker test of the nonlinear model.
//! At each frequency line the system is forced with `F_s + F0 sin(Ωt)` at the force point from
//! its initial state, run for `settle_s`, then for a whole number `measure_periods` of forcing
//! periods. Over that window the first harmonic of the response `u(t)` is projected out,
//! `H = (2/T_w) ∫ u(t) (sin Ωt + i cos Ωt) dt / F0` (so that `H = G` for a linear system), by
//! 8-point Gauss–Legendre quadrature on pieces of at most 1/8 period inside each smooth segment
//! of the solver (events are segment ends, so the quadrature never straddles a kink). RMS of
//! `u` and impacts over the same window are reported beside it. With a force too small for the
//! ball to reach a wall, frictionless, `H` is the ball-free receptance; under Coulomb friction
//! too small to let the ball slip, the ball-stuck receptance (tested to 1e-9).
//!
//! **Tap test** ([`tap_test`]): a half-sine hammer pulse `P sin(πt/τ)` on `[0, τ]` at the force
//! point, then the free decay, recorded at the response point (or the cavity) at a sample rate
//! `fs` over `record_s`. The pulse is the exact solver's harmonic forcing at `Ω = π/τ` switched
//! off at `t = τ` (the run continued from its full modal state with zero force), so the nonlinear
//! ball is simulated through the tap, impacts and friction included. Each tap starts from rest
//! with the ball at rest at its own place in the gap (tap `k` of `n` at
//! `w = (2(k + ½)/n − 1) · l_g`), which is what makes the taps of a bar with a ball differ. The
//! spectra are those of a data-acquisition system with ideal anti-aliasing filters: the
//! force's is the pulse's exact Fourier transform, the response's the DFT of its samples
//! (`X(f) = Δt Σ x_k e^{−2πi f kΔt}`, at the requested lines). Averaged over the taps,
//! `H1 = S_fx / S_ff` and the coherence `γ² = |S_fx|² / (S_ff S_xx)`. On a bar without a ball,
//! or with the ball never reaching a wall, every tap is the same and `γ² = 1`; with a ball that
//! impacts, H1 depends on the tap force (a harder tap throws the ball into the walls), so a
//! tap test of a damped bar describes that bar at that force only.

use super::batch::{BatchError, Runner};
use super::case::{ImpactCounter, RmsObserver};
use crate::error::{ParamError, SimError};
use crate::params::{Forcing, Frequency, State, System};
use crate::solver::exact::modal::ModalExact;
use crate::solver::{Fanout, Observer, Segment, Solver};
use crate::structure::{ModalModel, ModalState, ModalSystem, Point};
use num_complex::Complex64;
use std::f64::consts::PI;

pub use crate::limits::{
    MAX_FRF_FREQUENCY_HZ, MAX_FRF_LINES, MAX_MEASURE_PERIODS, MAX_TAPS, MAX_TAP_SAMPLES,
};
/// The default settling time lets the slowest mode's free decay fall by this factor.
pub const SETTLE_DECAY: f64 = 1e12;
/// The default tap record lets the slowest mode's free decay fall by this factor.
pub const RECORD_DECAY: f64 = 1e8;
/// The default tap sample rate is this multiple of the highest line and of `1/τ`.
pub const SAMPLE_RATE_FACTOR: f64 = 20.0;

/// 8-point Gauss–Legendre nodes on [−1, 1] (half of them; the rule is symmetric) and weights.
const GL8: [(f64, f64); 4] = [
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_3),
];

/// Check frequency lines given as values: one or more, at most [`MAX_FRF_LINES`], each finite
/// in `(0, MAX_FRF_FREQUENCY_HZ]`. `field` names them in the error.
pub fn check_lines_hz(field: &'static str, lines_hz: &[f64]) -> Result<(), ParamError> {
    crate::limits::check_count(
        field,
        lines_hz.len(),
        1,
        MAX_FRF_LINES,
        "frequency lines per FRF: use a coarser step or a narrower band",
    )?;
    for &f in lines_hz {
        crate::params::finite(field, f)?;
        if !(f > 0.0 && f <= MAX_FRF_FREQUENCY_HZ) {
            return Err(ParamError::OutOfRange {
                field,
                value: f,
                allowed: "(0, 1e7] Hz",
            });
        }
    }
    Ok(())
}

/// The lines `start, start + step, …, stop` (stop included within 1e-9 steps), Hz: finite,
/// `0 < start ≤ stop ≤ 1e7`, `step > 0`, at most [`MAX_FRF_LINES`] lines. Errors name
/// `START`, `STOP` or `STEP` of `field`.
pub fn frequency_lines_hz(
    field: &'static str,
    start_hz: f64,
    stop_hz: f64,
    step_hz: f64,
) -> Result<Vec<f64>, ParamError> {
    for x in [start_hz, stop_hz, step_hz] {
        crate::params::finite(field, x)?;
    }
    if start_hz <= 0.0 {
        return Err(ParamError::OutOfRange {
            field,
            value: start_hz,
            allowed: "START in (0, 1e7] Hz",
        });
    }
    if step_hz <= 0.0 {
        return Err(ParamError::OutOfRange {
            field,
            value: step_hz,
            allowed: "STEP in (0, ∞) Hz",
        });
    }
    if !(stop_hz >= start_hz && stop_hz <= MAX_FRF_FREQUENCY_HZ) {
        return Err(ParamError::OutOfRange {
            field,
            value: stop_hz,
            allowed: "STOP in [START, 1e7] Hz",
        });
    }
    let n = ((stop_hz - start_hz) / step_hz + 1e-9).floor();
    crate::limits::check(
        field,
        n + 1.0,
        1.0,
        MAX_FRF_LINES as f64,
        "frequency lines (STOP − START)/STEP + 1: use a larger STEP or a narrower band",
    )?;
    let lines: Vec<f64> = (0..=n as usize)
        .map(|i| start_hz + i as f64 * step_hz)
        .collect();
    check_lines_hz(field, &lines)?;
    Ok(lines)
}

/// The receptance `G(from → to; ω)` of `model` with the ball free (`stuck_ball_kg = None`: the
/// bar alone) or stuck at the cavity (`Some(m_d)`: Sherman–Morrison, module docs), m/N.
pub fn linear_receptance(
    model: &ModalModel,
    stuck_ball_kg: Option<f64>,
    from: Point,
    to: Point,
    omega_rad_s: f64,
) -> Complex64 {
    let g = model.receptance(from, to, omega_rad_s);
    match stuck_ball_kg {
        None => g,
        Some(md) => {
            let mu = md * omega_rad_s * omega_rad_s;
            let g_to_d = model.receptance(Point::Cavity, to, omega_rad_s);
            let g_d_from = model.receptance(from, Point::Cavity, omega_rad_s);
            let g_dd = model.receptance(Point::Cavity, Point::Cavity, omega_rad_s);
            g + mu * g_to_d * g_d_from / (1.0 - mu * g_dd)
        }
    }
}

/// [`linear_receptance`] at every line (Hz), after checking the lines, the modes (each mode's
/// field and range named) and the ball mass.
pub fn linear_frf(
    model: &ModalModel,
    stuck_ball_kg: Option<f64>,
    from: Point,
    to: Point,
    lines_hz: &[f64],
) -> Result<Vec<Complex64>, ParamError> {
    check_lines_hz("frequency lines", lines_hz)?;
    check_model(model)?;
    if let Some(md) = stuck_ball_kg {
        crate::params::positive("damper.ball_mass_kg", md)?;
    }
    lines_hz
        .iter()
        .map(|&f| {
            let g = linear_receptance(model, stuck_ball_kg, from, to, 2.0 * PI * f);
            crate::limits::finite_result(
                "receptance",
                g.re.abs().max(g.im.abs()) * if g.is_finite() { 1.0 } else { f64::NAN },
                "a line at an undamped resonance (damping_ratio = 0) or modal masses outside floating-point range",
            )?;
            Ok(g)
        })
        .collect()
}

fn check_model(model: &ModalModel) -> Result<(), ParamError> {
    crate::limits::check_count(
        "modes (number of modes)",
        model.len(),
        1,
        crate::limits::MAX_BEAM_MODES,
        "",
    )?;
    for m in model.modes() {
        m.validate()?;
        if m.damping_ratio >= 1.0 {
            return Err(ParamError::OutOfRange {
                field: "modes.damping_ratio",
                value: m.damping_ratio,
                allowed: "[0, 1)",
            });
        }
    }
    Ok(())
}

/// The slowest modal decay rate `min ζₙωₙ` (1/s) of a model; 0 with an undamped mode.
pub fn slowest_decay_rate_per_s(model: &ModalModel) -> f64 {
    model
        .modes()
        .iter()
        .map(|m| m.damping_ratio * m.omega_rad_s)
        .fold(f64::INFINITY, f64::min)
}

/// Where a simulated FRF (stepped sine, tap test) reads the response: the solver reports the
/// bar's motion at the response point and at the cavity ([`State`]); the force acts at the
/// force point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ResponsePoint {
    /// The response point (the tip, for a lumped bar every point).
    Response,
    /// The cavity centre (the ball's reference).
    Cavity,
}

impl ResponsePoint {
    /// The structure's point.
    pub fn point(self) -> Point {
        match self {
            ResponsePoint::Response => Point::Response,
            ResponsePoint::Cavity => Point::Cavity,
        }
    }
}

fn displacement_at(s: &State, p: ResponsePoint) -> f64 {
    match p {
        ResponsePoint::Cavity => s.u_cavity_m(),
        ResponsePoint::Response => s.u_m,
    }
}

/// Settings of a stepped sine ([`stepped_sine`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SteppedSine {
    /// Amplitude `F0` of the harmonic force at the force point.
    pub force_amplitude_n: f64,
    /// Run time before the measuring window; `None`: the time in which the slowest mode's free
    /// decay falls by [`SETTLE_DECAY`] (`ln(1e12)/min ζₙωₙ`; refused for an undamped mode).
    pub settle_s: Option<f64>,
    /// Length of the measuring window in forcing periods, in `[1, MAX_MEASURE_PERIODS]`.
    pub measure_periods: u32,
    /// Where the response is taken.
    pub response: ResponsePoint,
}

impl SteppedSine {
    /// Check the fields against `sys`; returns the settling time in use.
    pub fn validate(&self, sys: &System) -> Result<f64, ParamError> {
        crate::params::finite("force amplitude (--force-n)", self.force_amplitude_n)?;
        if self.force_amplitude_n <= 0.0 {
            return Err(ParamError::OutOfRange {
                field: "force amplitude (--force-n)",
                value: self.force_amplitude_n,
                allowed: "(0, ∞) N",
            });
        }
        crate::limits::check_count(
            "measure periods (--measure-periods)",
            self.measure_periods as usize,
            1,
            MAX_MEASURE_PERIODS as usize,
            "",
        )?;
        match self.settle_s {
            Some(t) => {
                crate::params::finite("settle time (--settle-s)", t)?;
                if t < 0.0 {
                    return Err(ParamError::OutOfRange {
                        field: "settle time (--settle-s)",
                        value: t,
                        allowed: "[0, ∞) s",
                    });
                }
                Ok(t)
            }
            None => {
                let rate = slowest_decay_rate_per_s(&sys.modal_model());
                if rate <= 0.0 || !rate.is_finite() {
                    return Err(ParamError::OutOfRange {
                        field: "settle time (--settle-s)",
                        value: rate,
                        allowed:
                            "given explicitly when a mode is undamped (its transient never settles)",
                    });
                }
                Ok(SETTLE_DECAY.ln() / rate)
            }
        }
    }
}

/// One line of a stepped sine.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SteppedSineRow {
    /// Forcing frequency, Hz.
    pub frequency_hz: f64,
    /// First harmonic of the response over the force amplitude, m/N (the receptance of a
    /// linear system).
    pub first_harmonic_m_per_n: Complex64,
    /// RMS of the response over the measuring window (DC and every harmonic included).
    pub rms_m: f64,
    /// Impacts inside the measuring window.
    pub impacts: u64,
    /// Impacts per forcing period inside the window.
    pub impacts_per_cycle: f64,
}

/// A stepped-sine line failed: which frequency, and what the solver said.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("stepped sine at {frequency_hz} Hz failed: {source}")]
pub struct LineFailed {
    /// The line.
    pub frequency_hz: f64,
    /// The error.
    pub source: SimError,
}

/// First harmonic `∫ u (sin Ωt + i cos Ωt) dt` over a window, by Gauss–Legendre on pieces of at
/// most 1/8 period inside each segment.
struct Harmonic {
    omega: f64,
    t0: f64,
    t1: f64,
    piece_s: f64,
    point: ResponsePoint,
    sum: Complex64,
}

/// Gauss–Legendre nodes over the part of `seg` inside `[t0, t1]`, on pieces of at most
/// `piece_s`: `node(t, ½·h·w)` at each node `t` with its weight.
fn window_nodes(
    seg: &dyn Segment,
    (t0, t1): (f64, f64),
    piece_s: f64,
    mut node: impl FnMut(f64, f64),
) {
    let a = seg.t_start_s().max(t0);
    let b = seg.t_end_s().min(t1);
    if b <= a {
        return;
    }
    let n = ((b - a) / piece_s).ceil().max(1.0) as usize;
    let h = (b - a) / n as f64;
    for k in 0..n {
        let mid = a + (k as f64 + 0.5) * h;
        for &(x, w) in &GL8 {
            for t in [mid - 0.5 * h * x, mid + 0.5 * h * x] {
                node(t, 0.5 * h * w);
            }
        }
    }
}

impl Observer for Harmonic {
    fn segment(&mut self, seg: &dyn Segment) {
        let (omega, point, sum) = (self.omega, self.point, &mut self.sum);
        window_nodes(seg, (self.t0, self.t1), self.piece_s, |t, hw| {
            let u = displacement_at(&seg.state_at(t), point);
            let (s, c) = (omega * t).sin_cos();
            *sum += Complex64::new(s, c) * (hw * u);
        });
    }
}

/// One stepped-sine line of `sys` (its forcing's frequency set to `frequency_hz`, amplitude to
/// the spec's) from `init`.
pub fn stepped_sine_line(
    sys: &System,
    init: &State,
    spec: &SteppedSine,
    settle_s: f64,
    frequency_hz: f64,
    solver: &dyn Solver,
) -> Result<SteppedSineRow, SimError> {
    let omega = 2.0 * PI * frequency_hz;
    let sys = System {
        forcing: Forcing {
            amplitude_n: spec.force_amplitude_n,
            frequency: Frequency::RadPerS(omega),
            ..sys.forcing
        },
        ..*sys
    };
    let period = 2.0 * PI / omega;
    let t_end = init.t_s + settle_s + spec.measure_periods as f64 * period;
    let t0 = t_end - spec.measure_periods as f64 * period;
    let mut harmonic = Harmonic {
        omega,
        t0,
        t1: t_end,
        piece_s: period / 8.0,
        point: spec.response,
        sum: Complex64::new(0.0, 0.0),
    };
    let mut rms = RmsObserver::new(t0, t_end);
    let mut imp = ImpactCounter {
        window_start_s: t0,
        ..Default::default()
    };
    // The RMS observer reads the response point's `u`; at the cavity the window's RMS comes
    // from the samples of the harmonic observer's own segments instead.
    let mut cavity_rms = CavityRms {
        t0,
        t1: t_end,
        sum: 0.0,
        piece_s: period / 8.0,
    };
    {
        let mut obs: [&mut dyn Observer; 4] = [&mut harmonic, &mut rms, &mut imp, &mut cavity_rms];
        solver.run(&sys, init, t_end, &mut Fanout(&mut obs))?;
    }
    let window = t_end - t0;
    let h = harmonic.sum * (2.0 / window / spec.force_amplitude_n);
    let rms_m = match spec.response {
        ResponsePoint::Cavity => (cavity_rms.sum / window).sqrt(),
        ResponsePoint::Response => rms.rms_m(),
    };
    let cause = "parameters far outside the model's range (forces, masses or stiffness)";
    crate::limits::finite_result("first harmonic", h.re, cause)?;
    crate::limits::finite_result("first harmonic", h.im, cause)?;
    Ok(SteppedSineRow {
        frequency_hz,
        first_harmonic_m_per_n: h,
        rms_m: crate::limits::finite_result("RMS of u", rms_m, cause)?,
        impacts: imp.in_window,
        impacts_per_cycle: imp.in_window as f64 / spec.measure_periods as f64,
    })
}

/// `∫ u_cavity² dt` over a window (Gauss–Legendre, as [`Harmonic`]).
struct CavityRms {
    t0: f64,
    t1: f64,
    piece_s: f64,
    sum: f64,
}

impl Observer for CavityRms {
    fn segment(&mut self, seg: &dyn Segment) {
        let sum = &mut self.sum;
        window_nodes(seg, (self.t0, self.t1), self.piece_s, |t, hw| {
            let u = seg.state_at(t).u_cavity_m();
            *sum += hw * u * u;
        });
    }
}

/// The stepped sine of `sys` from `init` at every line (Hz), on `runner` (parallel over lines,
/// rows in line order). Errors: bad settings or lines (field named) before any run, else the
/// first failing line.
pub fn stepped_sine(
    sys: &System,
    init: &State,
    spec: &SteppedSine,
    lines_hz: &[f64],
    solver: &dyn Solver,
    runner: Runner<'_>,
) -> Result<Vec<SteppedSineRow>, BatchError<LineFailed>> {
    check_lines_hz("frequency lines", lines_hz)?;
    sys.validate()?;
    let settle_s = spec.validate(sys)?;
    runner.each(lines_hz, |&f| {
        stepped_sine_line(sys, init, spec, settle_s, f, solver).map_err(|source| LineFailed {
            frequency_hz: f,
            source,
        })
    })
}

/// Settings of a simulated tap test ([`tap_test`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TapTest {
    /// Peak force `P` of the half-sine pulse.
    pub peak_force_n: f64,
    /// Pulse duration `τ`.
    pub pulse_duration_s: f64,
    /// Number of taps averaged, in `[1, MAX_TAPS]`.
    pub taps: usize,
    /// Sample rate; `None`: [`SAMPLE_RATE_FACTOR`] × the larger of the highest line and `1/τ`.
    pub sample_rate_hz: Option<f64>,
    /// Record length from the start of the pulse; `None`: the time in which the slowest mode's
    /// free decay falls by [`RECORD_DECAY`] (refused for an undamped mode).
    pub record_s: Option<f64>,
    /// Where the response is recorded.
    pub response: ResponsePoint,
}

/// What a tap test used and saw besides its lines.
#[derive(Debug, Clone, PartialEq)]
pub struct TapSummary {
    /// Sample rate used.
    pub sample_rate_hz: f64,
    /// Record length used.
    pub record_s: f64,
    /// Samples per tap.
    pub samples: usize,
    /// Impacts of each tap over its record.
    pub impacts_per_tap: Vec<u64>,
    /// Largest `|u|` of each tap's record at the response.
    pub peak_response_m: Vec<f64>,
}

/// One line of a tap test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TapRow {
    /// Frequency, Hz.
    pub frequency_hz: f64,
    /// `H1 = S_fx / S_ff`, m/N.
    pub h1_m_per_n: Complex64,
    /// `γ² = |S_fx|² / (S_ff S_xx)`, in [0, 1].
    pub coherence: f64,
}

/// The half-sine pulse's exact Fourier transform `∫₀^τ P sin(πt/τ) e^{−iωt} dt`, written
/// without the removable singularity at `ω = π/τ`.
pub fn half_sine_spectrum(peak_force_n: f64, duration_s: f64, omega_rad_s: f64) -> Complex64 {
    let a = PI / duration_s;
    let delta = (omega_rad_s - a) * duration_s;
    let x = 0.5 * delta;
    let sinc = if x.abs() < 1e-8 { 1.0 } else { x.sin() / x };
    let rot = Complex64::new(x.cos(), -x.sin());
    Complex64::new(
        0.0,
        -peak_force_n * a * duration_s * sinc / (a + omega_rad_s),
    ) * rot
}

impl TapTest {
    /// Check the fields against `sys` and the lines; returns `(fs, record_s, samples)`.
    pub fn validate(
        &self,
        sys: &System,
        lines_hz: &[f64],
    ) -> Result<(f64, f64, usize), ParamError> {
        check_lines_hz("frequency lines", lines_hz)?;
        for (field, x) in [
            ("tap peak force (--tap-force-n)", self.peak_force_n),
            (
                "tap pulse duration (--tap-duration-s)",
                self.pulse_duration_s,
            ),
        ] {
            crate::params::finite(field, x)?;
            if x <= 0.0 {
                return Err(ParamError::OutOfRange {
                    field,
                    value: x,
                    allowed: "(0, ∞)",
                });
            }
        }
        crate::limits::check_count("taps (--taps)", self.taps, 1, MAX_TAPS, "")?;
        let f_max = lines_hz.iter().copied().fold(0.0, f64::max);
        let fs = match self.sample_rate_hz {
            Some(fs) => {
                crate::params::finite("sample rate (--sample-rate-hz)", fs)?;
                if fs <= 2.0 * f_max {
                    return Err(ParamError::OutOfRange {
                        field: "sample rate (--sample-rate-hz)",
                        value: fs,
                        allowed: "(2 × the highest frequency line, ∞) Hz (Nyquist)",
                    });
                }
                fs
            }
            None => SAMPLE_RATE_FACTOR * f_max.max(1.0 / self.pulse_duration_s),
        };
        let record = match self.record_s {
            Some(t) => {
                crate::params::finite("record length (--record-s)", t)?;
                if t <= self.pulse_duration_s {
                    return Err(ParamError::OutOfRange {
                        field: "record length (--record-s)",
                        value: t,
                        allowed: "(pulse duration, ∞) s",
                    });
                }
                t
            }
            None => {
                let rate = slowest_decay_rate_per_s(&sys.modal_model());
                if rate <= 0.0 || !rate.is_finite() {
                    return Err(ParamError::OutOfRange {
                        field: "record length (--record-s)",
                        value: rate,
                        allowed: "given explicitly when a mode is undamped (its decay never ends)",
                    });
                }
                (RECORD_DECAY.ln() / rate).max(2.0 * self.pulse_duration_s)
            }
        };
        let samples = (record * fs).floor() + 1.0;
        crate::limits::check(
            "tap samples (--record-s × --sample-rate-hz)",
            samples,
            2.0,
            MAX_TAP_SAMPLES,
            "shorten the record or lower the sample rate",
        )?;
        Ok((fs, record, samples as usize))
    }
}

/// Samples `u(k/fs)`, `k = 0..n`, at a point; each sample taken once (a time on a segment end
/// belongs to the first segment that holds it).
struct Recorder {
    dt: f64,
    point: ResponsePoint,
    values: Vec<f64>,
    filled: Vec<bool>,
}

impl Observer for Recorder {
    fn segment(&mut self, seg: &dyn Segment) {
        let n = self.values.len();
        let k0 = (seg.t_start_s() / self.dt).ceil().max(0.0) as usize;
        let mut k = k0;
        while k < n {
            let t = k as f64 * self.dt;
            if t > seg.t_end_s() {
                break;
            }
            if !self.filled[k] && t >= seg.t_start_s() {
                self.values[k] = displacement_at(&seg.state_at(t), self.point);
                self.filled[k] = true;
            }
            k += 1;
        }
    }
}

/// One tap: the record of `u` at the point, and the impacts.
fn one_tap(
    sys: &ModalSystem,
    spec: &TapTest,
    w0_m: f64,
    fs: f64,
    record_s: f64,
    samples: usize,
) -> Result<(Vec<f64>, u64), SimError> {
    let solver = ModalExact::default();
    let pulse = ModalSystem {
        forcing: Forcing {
            amplitude_n: spec.peak_force_n,
            frequency: Frequency::RadPerS(PI / spec.pulse_duration_s),
            static_force_n: 0.0,
        },
        ..sys.clone()
    };
    let free = ModalSystem {
        forcing: Forcing {
            amplitude_n: 0.0,
            ..pulse.forcing
        },
        ..sys.clone()
    };
    let init = ModalState {
        v_m: w0_m,
        ..ModalState::REST
    };
    let mut rec = Recorder {
        dt: 1.0 / fs,
        point: spec.response,
        values: vec![0.0; samples],
        filled: vec![false; samples],
    };
    let mut imp = ImpactCounter::default();
    let first = {
        let mut obs: [&mut dyn Observer; 2] = [&mut rec, &mut imp];
        solver.run(&pulse, &init, spec.pulse_duration_s, &mut Fanout(&mut obs))?
    };
    {
        let mut obs: [&mut dyn Observer; 2] = [&mut rec, &mut imp];
        solver.run(&free, &first.final_state, record_s, &mut Fanout(&mut obs))?;
    }
    Ok((rec.values, imp.total))
}

/// `Δt Σ x_k e^{−iωkΔt}` (a rotating phasor, re-anchored every 1024 samples).
fn dft(x: &[f64], dt: f64, omega: f64) -> Complex64 {
    let step = Complex64::from_polar(1.0, -omega * dt);
    let mut acc = Complex64::new(0.0, 0.0);
    for (block, chunk) in x.chunks(1024).enumerate() {
        let mut p = Complex64::from_polar(1.0, -omega * dt * (block * 1024) as f64);
        for &v in chunk {
            acc += p * v;
            p *= step;
        }
    }
    acc * dt
}

/// A tap test of `sys` (its bar and ball; its harmonic forcing is not used) at every line
/// (Hz), with the exact solver; the taps run in parallel on `runner`. Errors: bad settings or
/// lines (field named) before any run, else the first failing tap.
pub fn tap_test(
    sys: &System,
    spec: &TapTest,
    lines_hz: &[f64],
    runner: Runner<'_>,
) -> Result<(Vec<TapRow>, TapSummary), BatchError<SimError>> {
    sys.validate()?;
    let (fs, record_s, samples) = spec.validate(sys, lines_hz)?;
    let msys = ModalSystem::from_system(sys)?;
    let lg = sys.damper.map_or(0.0, |d| d.half_gap_m());
    let n = spec.taps;
    let starts: Vec<f64> = (0..n)
        .map(|k| (2.0 * (k as f64 + 0.5) / n as f64 - 1.0) * lg)
        .collect();
    let records = runner.each(&starts, |&w0| {
        one_tap(&msys, spec, w0, fs, record_s, samples)
    })?;
    let dt = 1.0 / fs;
    let rows = runner.each(lines_hz, |&f| -> Result<TapRow, SimError> {
        let omega = 2.0 * PI * f;
        let ff = half_sine_spectrum(spec.peak_force_n, spec.pulse_duration_s, omega);
        let (mut sff, mut sxx, mut sfx) = (0.0, 0.0, Complex64::new(0.0, 0.0));
        for (x, _) in &records {
            let xf = dft(x, dt, omega);
            sff += ff.norm_sqr();
            sxx += xf.norm_sqr();
            sfx += ff.conj() * xf;
        }
        let h1 = sfx / sff;
        let coherence = if sxx > 0.0 {
            (sfx.norm_sqr() / (sff * sxx)).min(1.0)
        } else {
            0.0
        };
        let cause = "a line where the pulse has no energy (f = k/τ, k ≥ 1: choose a shorter pulse)";
        crate::limits::finite_result("H1", h1.re, cause)?;
        crate::limits::finite_result("H1", h1.im, cause)?;
        Ok(TapRow {
            frequency_hz: f,
            h1_m_per_n: h1,
            coherence,
        })
    })?;
    let summary = TapSummary {
        sample_rate_hz: fs,
        record_s,
        samples,
        impacts_per_tap: records.iter().map(|r| r.1).collect(),
        peak_response_m: records
            .iter()
            .map(|r| r.0.iter().fold(0.0, |m: f64, v| m.max(v.abs())))
            .collect(),
    };
    Ok((rows, summary))
}

/// The complex type of every receptance here (`num_complex`'s), for the crates that store them.
pub use num_complex::Complex64 as Receptance;

/// One curve of an FRF table: a receptance per line and the per-line quantities beside it.
#[derive(Debug, Clone, PartialEq)]
pub struct FrfCurve {
    /// Column prefix: `solid`, `ball_free`, `ball_stuck`, `stepped_sine` or `tap`.
    pub name: &'static str,
    /// The receptance (or first harmonic, or H1) at each line, m/N.
    pub values_m_per_n: Vec<Complex64>,
    /// Further columns, `(suffix, value per line)`: `rms_m`, `impacts_per_cycle` of a stepped
    /// sine, `coherence` of a tap test.
    pub extra: Vec<(&'static str, Vec<f64>)>,
}

impl FrfCurve {
    /// A linear curve (no extra columns).
    pub fn linear(name: &'static str, values_m_per_n: Vec<Complex64>) -> FrfCurve {
        FrfCurve {
            name,
            values_m_per_n,
            extra: Vec::new(),
        }
    }

    /// The stepped sine's curve: first harmonic, RMS and impacts per cycle.
    pub fn stepped_sine(rows: &[SteppedSineRow]) -> FrfCurve {
        FrfCurve {
            name: "stepped_sine",
            values_m_per_n: rows.iter().map(|r| r.first_harmonic_m_per_n).collect(),
            extra: vec![
                ("rms_m", rows.iter().map(|r| r.rms_m).collect()),
                (
                    "impacts_per_cycle",
                    rows.iter().map(|r| r.impacts_per_cycle).collect(),
                ),
            ],
        }
    }

    /// The tap test's curve: H1 and its coherence.
    pub fn tap(rows: &[TapRow]) -> FrfCurve {
        FrfCurve {
            name: "tap",
            values_m_per_n: rows.iter().map(|r| r.h1_m_per_n).collect(),
            extra: vec![("coherence", rows.iter().map(|r| r.coherence).collect())],
        }
    }
}
