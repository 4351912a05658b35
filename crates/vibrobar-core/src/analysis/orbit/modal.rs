//! Periodic orbits of the N-mode bar (`[beam]`, `[[modes]]`): Newton's method on the
//! stroboscopic map of [`ModalExact`] with the exact Jacobian of
//! [`crate::analysis::variational_modal`], Floquet multipliers and the physicality checks, as on
//! the lumped bar ([`super`]).
//!
//! **The map.** Its state is `x = (q₁ … q_N, q̇₁ … q̇_N, w, ẇ)` at the section time `t0`
//! (dimension `D = 2N + 2`; the relative `w = v − φ_dᵀq`, `ẇ`, so that `|w| ≤ l_g` is a bound
//! on one coordinate); `P(x)` is the modal exact solver's state at `t0 + kT`. The Jacobian of
//! the variational layer on `(q, q̇, v, v̇)` is taken to these coordinates as `T J T⁻¹`.
//!
//! **Newton** works in scaled coordinates: every `qₙ` by the tip's static response `s_u` (the
//! force amplitude times the kept modes' tip compliance), every `q̇ₙ` by `ω₁ s_u`, `w` by `l_g`,
//! `ẇ` by `ω₁ l_g` ([`StateScales::for_system`]); one scale for all modes because the impacts
//! drive the higher modes far beyond their static response. The linear solve is least squares
//! (SVD, neutral directions of a free ball get no step); a step that does not lower the residual
//! is halved; no convergence is an error with the residual ([`SimError::NoConvergence`]).
//!
//! **Starting guesses.** A settled run, the section in the middle of the longest event-free
//! stretch of its last `k` periods (the analytic symmetric orbit is the lumped bar's only).
//! Where Newton does not converge from there, the run settled one, two, … periods longer
//! ([`SETTLE_RETRIES`] at most): a chaotic run (the 4-mode beam at r = 1, 0.1 mm) passes near
//! an unstable orbit only now and then, so whether one settling time lands near it depends on
//! the last bits of the run; the first that converges is taken.
//!
//! On a one-mode bar with the lumped bar's `M`, `K` (every shape 1) the map, its Jacobian and the
//! orbit are the lumped ones (tested to 1e-9).

use super::{run_facts, NewtonSettings, OrbitEvent, OrbitRecorder, Physicality, STABILITY_MARGIN};
use crate::analysis::case::RmsObserver;
use crate::analysis::lyapunov::StateScales;
use crate::analysis::variational_modal::modal_flow_with_jacobian;
use crate::error::{ParamError, SimError};
use crate::params::ContactLaw;
use crate::solver::exact::modal::ModalExact;
use crate::solver::{Fanout, Observer};
use crate::structure::{ModalState, ModalSystem, Point};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// The stroboscopic map of a modal system.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalSection {
    /// The system.
    pub system: ModalSystem,
    /// Section time.
    pub t0_s: f64,
    /// Period `k` in forcing cycles.
    pub periods: u32,
}

/// Why an orbit needs the restitution law (shared with the lumped bar's message).
/// Why orbits of the N-mode bar refuse the Hertz law.
pub const ORBIT_RESTITUTION_ONLY: &str = "periodic orbits of the N-mode bar are computed with the instantaneous restitution law only; the hertz law's orbits are the lumped bar's only so far";

fn check_modal_system(sys: &ModalSystem) -> Result<(), SimError> {
    sys.validate()?;
    let Some(d) = sys.damper else {
        return Err(SimError::Unsupported(
            "periodic orbits of the damped bar need a ball (a damper section)",
        ));
    };
    if d.contact.law != ContactLaw::Restitution {
        return Err(SimError::Unsupported(ORBIT_RESTITUTION_ONLY));
    }
    Ok(())
}

impl ModalSection {
    /// A checked section: a ball under the restitution law, `1 ≤ periods ≤`
    /// [`super::MAX_ORBIT_PERIOD`], a finite `t0_s`.
    pub fn new(system: ModalSystem, t0_s: f64, periods: u32) -> Result<ModalSection, SimError> {
        check_modal_system(&system)?;
        super::check_period(periods)?;
        crate::params::finite("t0_s (section time)", t0_s)?;
        Ok(ModalSection {
            system,
            t0_s,
            periods,
        })
    }

    /// Number of modes `N`.
    pub fn n_modes(&self) -> usize {
        self.system.n_modes()
    }

    /// `D = 2N + 2`.
    pub fn dim(&self) -> usize {
        2 * self.n_modes() + 2
    }

    /// `k·T`.
    pub fn period_s(&self) -> f64 {
        self.periods as f64 * 2.0 * std::f64::consts::PI / self.system.omega_rad_s()
    }

    fn half_gap(&self) -> f64 {
        self.system.damper.map_or(f64::INFINITY, |d| d.half_gap_m())
    }

    /// The modal state of `x` at the section time.
    pub fn state(&self, x: &[f64]) -> ModalState {
        let n = self.n_modes();
        let mut s = ModalState {
            t_s: self.t0_s,
            ..ModalState::REST
        };
        s.q_m[..n].copy_from_slice(&x[..n]);
        s.dq_m_s[..n].copy_from_slice(&x[n..2 * n]);
        let phi = self.system.row(Point::Cavity);
        let (ud, dud): (f64, f64) = (
            (0..n).map(|i| phi[i] * x[i]).sum(),
            (0..n).map(|i| phi[i] * x[n + i]).sum(),
        );
        s.v_m = x[2 * n] + ud;
        s.dv_m_s = x[2 * n + 1] + dud;
        s
    }

    /// `x` of a modal state.
    pub fn to_vector(&self, s: &ModalState) -> Vec<f64> {
        let n = self.n_modes();
        let mut x = Vec::with_capacity(2 * n + 2);
        x.extend_from_slice(&s.q_m[..n]);
        x.extend_from_slice(&s.dq_m_s[..n]);
        x.push(s.w_m(&self.system.model));
        x.push(s.dw_m_s(&self.system.model));
        x
    }

    /// `x` with `w` inside the cavity (the state's own `w`, after `v = w + φ_dᵀq` rounds).
    pub fn clamp(&self, x: &[f64]) -> Vec<f64> {
        let lg = self.half_gap();
        let n = self.n_modes();
        let mut x = x.to_vec();
        x[2 * n] = x[2 * n].clamp(-lg, lg);
        let mut guard = 0;
        while self.state(&x).w_m(&self.system.model).abs() > lg && guard < 64 {
            let big = x[..n].iter().fold(lg, |a, v| a.max(v.abs()));
            x[2 * n] -= x[2 * n].signum() * f64::EPSILON * big;
            guard += 1;
        }
        x
    }

    /// `P(x)`, reported to `obs`.
    pub fn flow_observed(&self, x: &[f64], obs: &mut dyn Observer) -> Result<ModalState, SimError> {
        let r = ModalExact::default().run(
            &self.system,
            &self.state(x),
            self.t0_s + self.period_s(),
            obs,
        )?;
        Ok(r.final_state)
    }

    /// `P(x)`.
    pub fn flow(&self, x: &[f64]) -> Result<Vec<f64>, SimError> {
        Ok(self.to_vector(&self.flow_observed(x, &mut ())?))
    }

    /// `P(x)` and `DP(x)` on `(q, q̇, w, ẇ)`: the variational flow, `T J T⁻¹`.
    pub fn map_and_jacobian(&self, x: &[f64]) -> Result<(Vec<f64>, DMatrix<f64>), SimError> {
        let fj =
            modal_flow_with_jacobian(&self.system, &self.state(x), self.t0_s + self.period_s())?;
        let d = self.dim();
        let j = DMatrix::from_fn(d, d, |r, c| fj.jacobian[r][c]);
        Ok((self.to_vector(&fj.state), to_relative(&self.system, &j)))
    }

    /// Scales of `x` (module docs).
    pub fn scales(&self) -> Vec<f64> {
        modal_scales(&self.system)
    }
}

/// Scales of `(q, q̇, w, ẇ)` (module docs).
pub fn modal_scales(sys: &ModalSystem) -> Vec<f64> {
    let s = StateScales::for_system(&sys.to_system());
    let n = sys.n_modes();
    let mut v = vec![s.u_m; n];
    v.extend(std::iter::repeat_n(s.du_m_s, n));
    v.push(s.w_m);
    v.push(s.dw_m_s);
    v
}

/// `T J T⁻¹`, `T: (q, q̇, v, v̇) → (q, q̇, v − φ_dᵀq, v̇ − φ_dᵀq̇)`.
pub fn to_relative(sys: &ModalSystem, j: &DMatrix<f64>) -> DMatrix<f64> {
    let n = sys.n_modes();
    let d = 2 * n + 2;
    let phi = sys.row(Point::Cavity);
    let mut t = DMatrix::identity(d, d);
    let mut ti = DMatrix::identity(d, d);
    for i in 0..n {
        t[(2 * n, i)] = -phi[i];
        t[(2 * n + 1, n + i)] = -phi[i];
        ti[(2 * n, i)] = phi[i];
        ti[(2 * n + 1, n + i)] = phi[i];
    }
    t * j * ti
}

/// A periodic orbit of a modal bar and its stability.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalPeriodicOrbit {
    /// The section it is a fixed point of.
    pub section: ModalSection,
    /// The modal state at the section time.
    pub state: ModalState,
    /// `max |P(x) − x|` in scaled units.
    pub residual: f64,
    /// Newton iterations used.
    pub iterations: usize,
    /// RMS of `u` at the response point over the orbit.
    pub rms_m: f64,
    /// Impacts over the period.
    pub impacts_per_period: u32,
    /// The events over one period.
    pub events: Vec<OrbitEvent>,
    /// The event letters ([`super::event_letter`]).
    pub sequence: String,
    /// Monodromy matrix on `(q, q̇, w, ẇ)` (SI).
    pub jacobian: DMatrix<f64>,
    /// Floquet multipliers, largest modulus first.
    pub multipliers: Vec<Complex64>,
    /// Physicality checks.
    pub physicality: Physicality,
}

impl ModalPeriodicOrbit {
    /// Largest `|λ|`.
    pub fn max_abs_multiplier(&self) -> f64 {
        self.multipliers
            .iter()
            .map(|l| l.norm())
            .fold(0.0, f64::max)
    }

    /// Every `|λ| < 1 −` [`STABILITY_MARGIN`].
    pub fn stable(&self) -> bool {
        self.max_abs_multiplier() < 1.0 - STABILITY_MARGIN
    }

    /// Impacts per forcing cycle.
    pub fn impacts_per_cycle(&self) -> f64 {
        self.impacts_per_period as f64 / self.section.periods as f64
    }

    /// The orbit's state vector `x` at the section.
    pub fn vector(&self) -> Vec<f64> {
        self.section.to_vector(&self.state)
    }
}

/// Eigenvalues, largest modulus first.
pub fn multipliers_of_d(jac: &DMatrix<f64>) -> Vec<Complex64> {
    let ev = jac.complex_eigenvalues();
    let mut v: Vec<Complex64> = ev.iter().map(|c| Complex64::new(c.re, c.im)).collect();
    v.sort_by(|a, b| b.norm().total_cmp(&a.norm()).then(b.im.total_cmp(&a.im)));
    v
}

fn max_abs(r: &[f64]) -> f64 {
    r.iter().map(|v| v.abs()).fold(0.0, f64::max)
}

/// Least squares (SVD, singular values below 1e-12 of the largest dropped).
pub(crate) fn lstsq(a: &DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    let svd = a.clone().svd(true, true);
    let eps = 1e-12 * svd.singular_values.max();
    let d = svd.solve(b, eps).ok()?;
    d.iter().all(|v| v.is_finite()).then_some(d)
}

/// `S⁻¹ DP S − I`.
pub(crate) fn scaled_minus_identity(jac: &DMatrix<f64>, sc: &[f64]) -> DMatrix<f64> {
    let d = sc.len();
    DMatrix::from_fn(d, d, |i, j| {
        jac[(i, j)] * sc[j] / sc[i] - if i == j { 1.0 } else { 0.0 }
    })
}

/// Newton's method on `P(x) = x` from `x0` (module docs).
pub fn find_modal_orbit(
    sec: &ModalSection,
    x0: &[f64],
    settings: &NewtonSettings,
) -> Result<ModalPeriodicOrbit, SimError> {
    crate::params::positive("newton.tolerance", settings.tolerance)?;
    let d = sec.dim();
    if x0.len() != d {
        return Err(ParamError::OutOfRange {
            field: "starting guess (length of (q, q̇, w, ẇ))",
            value: x0.len() as f64,
            allowed: "2N + 2",
        }
        .into());
    }
    for &v in x0 {
        crate::params::finite("starting guess (q, q̇, w, ẇ)", v)?;
    }
    let sc = sec.scales();
    let mut x = sec.clamp(x0);
    let (mut px, mut dp) = sec.map_and_jacobian(&x)?;
    let res =
        |px: &[f64], x: &[f64]| -> Vec<f64> { (0..d).map(|i| (px[i] - x[i]) / sc[i]).collect() };
    let mut r = res(&px, &x);
    let mut iterations = 0;
    while max_abs(&r) > settings.tolerance {
        if iterations >= settings.max_iterations {
            return Err(no_convergence(iterations, max_abs(&r), settings.tolerance));
        }
        iterations += 1;
        let a = scaled_minus_identity(&dp, &sc);
        let rhs = DVector::from_iterator(d, r.iter().map(|v| -v));
        let Some(step) = lstsq(&a, &rhs) else {
            return Err(no_convergence(iterations, max_abs(&r), settings.tolerance));
        };
        let mut lambda = 1.0;
        let accepted = loop {
            let trial: Vec<f64> = (0..d).map(|i| x[i] + lambda * step[i] * sc[i]).collect();
            let trial = sec.clamp(&trial);
            if let Ok(pt) = sec.flow(&trial) {
                if max_abs(&res(&pt, &trial)) < max_abs(&r) || lambda < 1e-3 {
                    break Some(trial);
                }
            }
            lambda *= 0.5;
            if lambda < 1e-4 {
                break None;
            }
        };
        let Some(trial) = accepted else {
            return Err(no_convergence(iterations, max_abs(&r), settings.tolerance));
        };
        x = trial;
        (px, dp) = sec.map_and_jacobian(&x)?;
        r = res(&px, &x);
    }
    describe_modal(sec, &x, dp, max_abs(&r), iterations)
}

fn no_convergence(iterations: usize, residual: f64, tolerance: f64) -> SimError {
    SimError::NoConvergence {
        what: "Newton's method on the stroboscopic map of the modal bar (no periodic orbit near the starting guess; try another --settle, --period or a nearby parameter)",
        iterations,
        residual,
        tolerance,
    }
}

/// The orbit at the fixed point `x` (RMS, events, multipliers, checks).
pub fn describe_modal(
    sec: &ModalSection,
    x: &[f64],
    jacobian: DMatrix<f64>,
    residual: f64,
    iterations: usize,
) -> Result<ModalPeriodicOrbit, SimError> {
    let t_end = sec.t0_s + sec.period_s();
    let mut rms = RmsObserver::new(sec.t0_s, t_end);
    let mut rec = OrbitRecorder {
        t0_s: sec.t0_s,
        lg: sec.half_gap(),
        events: Vec::new(),
        margin_m: f64::INFINITY,
        min_speed: f64::INFINITY,
    };
    let init = sec.state(x);
    let summary = {
        let mut obs: [&mut dyn Observer; 2] = [&mut rms, &mut rec];
        ModalExact::default()
            .run(&sec.system, &init, t_end, &mut Fanout(&mut obs))?
            .summary
    };
    let multipliers = multipliers_of_d(&jacobian);
    let (rms_m, impacts, sequence) = run_facts(rms.rms_m(), &multipliers, &rec.events)?;
    Ok(ModalPeriodicOrbit {
        section: sec.clone(),
        state: init,
        residual,
        iterations,
        rms_m,
        impacts_per_period: impacts,
        events: rec.events,
        sequence,
        jacobian,
        multipliers,
        physicality: Physicality {
            max_penetration_m: summary.max_penetration_m,
            grazing_margin_m: rec.margin_m,
            min_impact_speed_m_s: rec.min_speed,
            confined: summary.max_penetration_m <= crate::solver::exact::CONFINEMENT_TOL_M,
        },
    })
}

/// A section and a starting state for `sys` with period `periods` from a run of `settle_s`
/// from `init`: the section in the middle of the longest event-free stretch of the last `k`
/// periods, brought into `[0, T)`.
pub fn modal_starting_guess(
    sys: &ModalSystem,
    periods: u32,
    init: &ModalState,
    settle_s: f64,
) -> Result<(ModalSection, Vec<f64>), SimError> {
    check_modal_system(sys)?;
    super::check_period(periods)?;
    let t = 2.0 * std::f64::consts::PI / sys.omega_rad_s();
    let kt = periods as f64 * t;
    let (from, end) = super::settle_window(init.t_s, settle_s, kt)?;
    let mut times = super::EventTimes::new(from);
    ModalExact::default().run(sys, init, end, &mut times)?;
    times.t.push(end);
    let mid = super::longest_gap_mid(&times.t, from + 0.5 * kt);
    let mut s = ModalExact::default()
        .run(sys, init, mid, &mut ())?
        .final_state;
    let shift = (mid / t).floor() * t;
    s.t_s = mid - shift;
    let sec = ModalSection::new(sys.clone(), mid - shift, periods)?;
    let x = sec.clamp(&sec.to_vector(&s));
    Ok((sec, x))
}

/// Longest extra settling, in periods of the orbit, [`modal_orbit_settled`] tries.
pub const SETTLE_RETRIES: u32 = 16;

/// Newton from a settled run, and where it does not converge from runs settled one, two, …
/// periods longer (module docs): the orbit and the settling time it came from. The error is
/// the first attempt's if none converges.
pub fn modal_orbit_settled_at(
    sys: &ModalSystem,
    periods: u32,
    init: &ModalState,
    settle_s: f64,
) -> Result<(ModalPeriodicOrbit, f64), SimError> {
    let kt = periods as f64 * 2.0 * std::f64::consts::PI / sys.omega_rad_s();
    let mut first = None;
    for j in 0..=SETTLE_RETRIES {
        let settle = settle_s + j as f64 * kt;
        let (sec, x0) = modal_starting_guess(sys, periods, init, settle)?;
        match find_modal_orbit(&sec, &x0, &NewtonSettings::default()) {
            Ok(o) => return Ok((o, settle)),
            Err(e @ SimError::NoConvergence { .. }) => {
                first.get_or_insert(e);
            }
            Err(e) => return Err(e),
        }
    }
    Err(first.expect("at least one attempt"))
}

/// [`modal_orbit_settled_at`] without the settling time used.
pub fn modal_orbit_settled(
    sys: &ModalSystem,
    periods: u32,
    init: &ModalState,
    settle_s: f64,
) -> Result<ModalPeriodicOrbit, SimError> {
    modal_orbit_settled_at(sys, periods, init, settle_s).map(|(o, _)| o)
}
