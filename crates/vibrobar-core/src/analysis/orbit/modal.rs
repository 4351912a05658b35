//! Periodic orbits of the N-mode bar (`[beam]`, `[[modes]]`): Newton's method on the
//! stroboscopic map of [`ModalExact`] with the exact Jacobian of
//! [`crate::analysis::variational::modal`], Floquet multipliers and the physicality checks, as on
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
//! drive the higher modes far beyond their static response. The iteration itself is the one of
//! both bars ([`super::find_orbit`] over [`Flow`]).
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
//!
//! **Branches** ([`continue_modal_orbit`]: the continuation of both bars,
//! [`super::continuation::follow_branch`], over a [`ModalFamily`]) follow the frequency ratio,
//! the gap, the friction force, the restitution, or the **cavity position** on a `[beam]` (the
//! ball moves along the bar: every mode's shape at the cavity changes). The parameter column is a
//! central difference of the map with step [`PARAM_STEP`] of the interval (its accuracy:
//! [`super::continuation`]). For the cavity position the modal model is rebuilt from the
//! `[beam]` at every evaluation (`Structure::Beam(..).modal_model()`: the analytic
//! Euler–Bernoulli modes are cheap; a beam with a section loss or a tip mass is a finite-element
//! model, about 100× slower). With the ratio given as `Ω/ω₁`, `Ω` follows `ω₁` if the position
//! changes it (a section loss at the cavity); on a uniform beam it does not.

use super::continuation::{follow_branch, Branch, BranchPoint, ContinuationSettings, Family};
use super::{find_orbit, to_relative_coordinates, ExactJacobian, Flow, NewtonSettings, Orbit};
use crate::analysis::grid::Axis;
use crate::analysis::lyapunov::StateScales;
use crate::analysis::variational::modal::modal_flow_with_jacobian;
use crate::error::SimError;
use crate::params::ContactLaw;
use crate::solver::exact::modal::ModalExact;
use crate::solver::Observer;
use crate::structure::{Beam, ModalState, ModalSystem, Point, Structure};
use nalgebra::DMatrix;

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

fn check_modal_system(sys: &ModalSystem) -> Result<(), SimError> {
    sys.validate()?;
    // Either contact law: the hertz law's compliant phases have their variational equations
    // (crate::analysis::variational::modal).
    if sys.damper.is_none() {
        return Err(SimError::Unsupported(
            "periodic orbits of the damped bar need a ball (a damper section)",
        ));
    }
    Ok(())
}

impl ModalSection {
    /// A checked section: a ball (either contact law), `1 ≤ periods ≤`
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

impl Flow for ModalSection {
    type State = ModalState;
    const START_FIELD: &'static str = "starting guess (q, q̇, w, ẇ)";
    const NO_ORBIT: &'static str = "Newton's method on the stroboscopic map of the modal bar (no periodic orbit near the starting guess; try another --settle, --period or a nearby parameter)";

    fn dim(&self) -> usize {
        ModalSection::dim(self)
    }

    fn t0_s(&self) -> f64 {
        self.t0_s
    }

    fn periods(&self) -> u32 {
        self.periods
    }

    fn at(&self, t0_s: f64, periods: u32) -> Result<Self, SimError> {
        ModalSection::new(self.system.clone(), t0_s, periods)
    }

    fn forcing_period_s(&self) -> f64 {
        ModalSection::period_s(self) / self.periods as f64
    }

    fn period_s(&self) -> f64 {
        ModalSection::period_s(self)
    }

    fn omega_rad_s(&self) -> f64 {
        self.system.omega_rad_s()
    }

    fn half_gap_m(&self) -> f64 {
        self.half_gap()
    }

    fn compliant(&self) -> bool {
        self.system
            .damper
            .is_some_and(|d| d.contact.law == ContactLaw::Hertz)
    }

    fn state(&self, x: &[f64]) -> ModalState {
        ModalSection::state(self, x)
    }

    fn vector(&self, s: &ModalState) -> Vec<f64> {
        self.to_vector(s)
    }

    fn clamp(&self, x: &[f64]) -> Vec<f64> {
        ModalSection::clamp(self, x)
    }

    fn scales(&self) -> Vec<f64> {
        ModalSection::scales(self)
    }

    fn run(
        &self,
        s: &ModalState,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<(ModalState, f64), SimError> {
        let r = ModalExact::default().run(&self.system, s, t_end_s, obs)?;
        Ok((r.final_state, r.summary.max_penetration_m))
    }

    fn flow(&self, x: &[f64]) -> Result<Vec<f64>, SimError> {
        ModalSection::flow(self, x)
    }

    fn exact_jacobian(&self, x: &[f64]) -> Result<(Vec<f64>, DMatrix<f64>), SimError> {
        self.map_and_jacobian(x)
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
    let phi = sys.row(Point::Cavity);
    to_relative_coordinates(&phi[..sys.n_modes()], j)
}

/// A periodic orbit of a modal bar and its stability.
pub type ModalPeriodicOrbit = Orbit<ModalSection>;

/// Newton's method on the modal map from `x0` with the exact Jacobian ([`super::find_orbit`]).
pub fn find_modal_orbit(
    sec: &ModalSection,
    x0: &[f64],
    settings: &NewtonSettings,
) -> Result<ModalPeriodicOrbit, SimError> {
    find_orbit(sec, x0, &ExactJacobian, settings)
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
    // Under the hertz law a contact phase is not event-free: its touch counts too.
    let mut times = super::EventTimes::new(from);
    times.contacts = true;
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

/// Central-difference step of the parameter column, in units of the interval (`p̃`).
pub const PARAM_STEP: f64 = 1e-6;

/// A parameter of a modal bar's branch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ModalParam {
    /// One of the lumped bar's axes (ratio, gap, friction force, restitution), SI.
    Axis(Axis),
    /// The cavity centre's distance from the clamp, m (a `[beam]` only).
    CavityPositionM,
}

impl ModalParam {
    /// The name in output files and flags (`--param`): `ratio`, `gap-mm`, `friction-force-n`,
    /// `restitution`, `cavity-position-mm`.
    pub fn flag(&self) -> &'static str {
        match self {
            ModalParam::Axis(a) => super::continuation::CONTINUATION_PARAMS
                .iter()
                .find(|(_, b)| b == a)
                .map_or(a.as_str(), |(n, _)| n),
            ModalParam::CavityPositionM => "cavity-position-mm",
        }
    }
}

/// The systems along a branch: the base system and, for the cavity position, its beam.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalFamily {
    /// The system at the start.
    pub base: ModalSystem,
    /// The beam the modal model comes from (needed for [`ModalParam::CavityPositionM`]).
    pub beam: Option<Beam>,
    /// The parameter followed.
    pub param: ModalParam,
}

/// Why the cavity position needs a beam.
pub const CAVITY_NEEDS_BEAM: &str = "the cavity position (--param cavity-position-mm) is a parameter of a [beam]: its modes are recomputed at every position; measured [[modes]] give the shapes at one cavity only";

impl ModalFamily {
    /// The system at parameter `value` (SI), validated.
    pub fn system_at(&self, value: f64) -> Result<ModalSystem, SimError> {
        let sys = match self.param {
            ModalParam::Axis(a) => {
                let mut s = self.base.to_system();
                a.apply(&mut s, value)?;
                ModalSystem::from_system(&s)?
            }
            ModalParam::CavityPositionM => {
                let beam = self
                    .beam
                    .as_ref()
                    .ok_or(SimError::Unsupported(CAVITY_NEEDS_BEAM))?;
                let b = Beam {
                    cavity_position_m: value,
                    ..beam.clone()
                };
                ModalSystem {
                    model: Structure::Beam(b).modal_model()?,
                    ..self.base.clone()
                }
            }
        };
        sys.validate()?;
        Ok(sys)
    }

    /// The parameter's value in the base system (SI).
    pub fn value_of_base(&self) -> Result<f64, SimError> {
        Ok(match self.param {
            ModalParam::Axis(a) => super::continuation::param_of(&self.base.to_system(), a),
            ModalParam::CavityPositionM => {
                self.beam
                    .as_ref()
                    .ok_or(SimError::Unsupported(CAVITY_NEEDS_BEAM))?
                    .cavity_position_m
            }
        })
    }
}

impl Family for ModalFamily {
    type Flow = ModalSection;

    fn name(&self) -> &'static str {
        self.param.flag()
    }

    fn section(&self, value: f64, t0_s: f64, periods: u32) -> Result<ModalSection, SimError> {
        ModalSection::new(self.system_at(value)?, t0_s, periods)
    }

    fn value_of(&self, sec: &ModalSection) -> Option<f64> {
        match self.param {
            ModalParam::Axis(a) => Some(super::continuation::param_of(&sec.system.to_system(), a)),
            // The system does not carry where its modes were computed.
            ModalParam::CavityPositionM => None,
        }
    }

    fn param_derivative(&self, _: &ModalSection, _: &[f64]) -> Result<Option<Vec<f64>>, SimError> {
        // The modal variational layer carries no parameter column: central differences.
        Ok(None)
    }

    fn param_step(&self) -> f64 {
        PARAM_STEP
    }
}

/// One point of a modal branch.
pub type ModalBranchPoint = BranchPoint<ModalSection>;

/// A computed modal branch.
pub type ModalBranch = Branch<ModalSection>;

/// Follow the orbit `start` of `fam.base` (a fixed point at the parameter `from`, SI) from
/// `from` to `to` with the exact Jacobian ([`follow_branch`]).
pub fn continue_modal_orbit(
    start: &ModalPeriodicOrbit,
    fam: &ModalFamily,
    from: f64,
    to: f64,
    settings: &ContinuationSettings,
) -> Result<ModalBranch, SimError> {
    follow_branch(start, fam, from, to, &ExactJacobian, settings)
}

/// `∂P(x)/∂p` (SI parameter) of the modal map at `x` by central differences with step `h`
/// (SI), on `(q, q̇, w, ẇ)`: the parameter column of [`continue_modal_orbit`] (there with `h`
/// = [`PARAM_STEP`] of the interval).
pub fn modal_map_param_derivative_fd(
    fam: &ModalFamily,
    sec: &ModalSection,
    x: &[f64],
    value: f64,
    h: f64,
) -> Result<Vec<f64>, SimError> {
    let run = |p: f64| -> Result<Vec<f64>, SimError> {
        ModalSection::new(fam.system_at(p)?, sec.t0_s, sec.periods)?.flow(x)
    };
    let (a, b) = (run(value + h)?, run(value - h)?);
    Ok(a.iter().zip(&b).map(|(a, b)| (a - b) / (2.0 * h)).collect())
}

/// Newton at the parameter `value` from `x0` at the section time of `sec` (a point of a branch
/// recomputed independently).
pub fn modal_orbit_at(
    fam: &ModalFamily,
    sec: &ModalSection,
    x0: &[f64],
    value: f64,
) -> Result<ModalPeriodicOrbit, SimError> {
    let s = ModalSection::new(fam.system_at(value)?, sec.t0_s, sec.periods)?;
    find_modal_orbit(&s, x0, &NewtonSettings::default())
}
