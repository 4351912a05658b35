//! Periodic orbits of the lumped and of the N-mode bar: Newton's method on the stroboscopic map,
//! Floquet multipliers, and (in [`continuation`]) pseudo-arclength continuation with bifurcation
//! and grazing detection. Each is written once over [`Flow`] ([`flow`]: the bar's exact flow as
//! these analyses see it), which the lumped [`Section`] and the modal
//! [`modal::ModalSection`] implement.
//!
//! **The map.** A section fixes the system, a section time `t0` (a forcing phase `Ωt0`) and
//! the period `k` in forcing cycles. Its state is `x = (u, u̇, w, ẇ)` at `t0` on the lumped bar
//! ([`Section`]), `(q₁ … q_N, q̇₁ … q̇_N, w, ẇ)` on the N-mode bar ([`modal`]); the stroboscopic
//! map `P(x)` is the exact solver's state at `t0 + kT` (`T = 2π/Ω`). A periodic orbit of period
//! `k` is a fixed point `P(x) = x`; its Floquet multipliers are the eigenvalues of the Jacobian
//! `DP` (the monodromy matrix, saltation at every event included). The Jacobian comes from a
//! [`MapJacobian`]: [`FiniteDifference`] (central differences of the exact solver) or the exact
//! variational flow ([`ExactJacobian`]).
//!
//! **Newton** ([`find_orbit`]) works in scaled coordinates ([`Flow::scales`]: `u/s_u`, `u̇/s_u̇`,
//! `w/l_g`, `ẇ/(ω_n l_g)` on the lumped bar, [`StateScales`]; the modal bar's in [`modal`]) so
//! that one tolerance fits every component; the linear solve
//! is a least-squares one (SVD) because a ball that never touches a wall adds neutral
//! directions (its position and velocity are free: multipliers 1). A step that does not lower the
//! residual is halved. An iteration that does not converge is an error
//! ([`SimError::NoConvergence`], with the residual): a non-orbit is never returned.
//!
//! **Physicality.** Every orbit is a trajectory of the exact solver, whose event search cannot
//! miss a root, so `|w| ≤ l_g` holds along it and no grazing impact is skipped; the orbit still
//! reports the largest penetration seen, the smallest clearance at an interior turning point of
//! `|w|` (how close a new impact is: the grazing margin) and the slowest impact.

pub mod continuation;
pub mod flow;
pub mod modal;
pub mod region;
pub mod symmetric;
pub mod two_param;

use crate::analysis::case::RmsObserver;
use crate::analysis::lyapunov::StateScales;
use crate::error::{ParamError, SimError};
use crate::params::{State, System};
use crate::solver::{Event, EventKind, Exact, Fanout, Mode, Observer, Segment, Solver, Wall};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

pub use flow::{to_relative_coordinates, ExactJacobian, FiniteDifference, Flow, MapJacobian};
pub use symmetric::{symmetric_orbits, SymmetricOrbit};

pub use crate::limits::MAX_ORBIT_PERIOD;

/// Why an orbit needs a lumped bar.
pub const ORBIT_LUMPED_ONLY: &str = "this orbit code is the lumped bar's (a 4-dimensional state): a modal bar's orbits (2N + 2 dimensions) are computed by analysis::orbit::modal";

/// The stroboscopic map of one system: state at `t0_s`, period `periods` forcing cycles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Section {
    /// The system (lumped bar).
    pub system: System,
    /// Section time; the map runs from `t0_s` to `t0_s + periods·T`.
    pub t0_s: f64,
    /// Period `k` in forcing cycles.
    pub periods: u32,
}

/// The map's state vector `(u, u̇, w, ẇ)` of a lumped state.
pub fn to_vector(s: &State) -> [f64; 4] {
    [s.u_m, s.du_m_s, s.w_m(), s.dw_m_s()]
}

impl Section {
    /// A section of `sys` at `t0_s` with period `periods`, checked: a lumped bar with a ball
    /// (either contact law), `1 ≤ periods ≤` [`MAX_ORBIT_PERIOD`], a finite `t0_s`.
    pub fn new(system: System, t0_s: f64, periods: u32) -> Result<Section, SimError> {
        check_system(&system)?;
        check_period(periods)?;
        crate::params::finite("t0_s (section time)", t0_s)?;
        Ok(Section {
            system,
            t0_s,
            periods,
        })
    }

    /// The map's period in seconds, `k·T`.
    pub fn period_s(&self) -> f64 {
        self.periods as f64 * self.system.forcing_period_s()
    }

    /// The lumped state of `x` at the section time.
    pub fn state(&self, x: &[f64; 4]) -> State {
        State {
            t_s: self.t0_s,
            u_m: x[0],
            du_m_s: x[1],
            v_m: x[0] + x[2],
            dv_m_s: x[1] + x[3],
            cavity: None,
        }
    }

    /// `x` with `w` pulled inside the cavity (`|w| ≤ l_g`; an FD or Newton step may leave it).
    pub fn clamp(&self, mut x: [f64; 4]) -> [f64; 4] {
        let lg = self.system.damper.map_or(f64::INFINITY, |d| d.half_gap_m());
        x[2] = x[2].clamp(-lg, lg);
        // v = u + w rounds: step w inward until the state's own w is inside.
        let mut s = self.state(&x);
        while s.w_m().abs() > lg {
            x[2] -= x[2].signum() * f64::EPSILON * lg.max(x[0].abs());
            s = self.state(&x);
        }
        x
    }

    /// `P(x)`: the state `k` forcing cycles later, reported to `obs`.
    pub fn flow_observed(&self, x: &[f64; 4], obs: &mut dyn Observer) -> Result<State, SimError> {
        let init = self.state(x);
        let r = Exact::default().run(&self.system, &init, self.t0_s + self.period_s(), obs)?;
        Ok(r.final_state)
    }

    /// `P(x)`.
    pub fn flow(&self, x: &[f64; 4]) -> Result<[f64; 4], SimError> {
        Ok(to_vector(&self.flow_observed(x, &mut ())?))
    }
}

fn check_system(sys: &System) -> Result<(), SimError> {
    sys.validate()?;
    if sys.lumped_bar().is_none() {
        return Err(SimError::Unsupported(ORBIT_LUMPED_ONLY));
    }
    // Either contact law: the hertz law's compliant phases have their variational equations
    // (crate::analysis::variational, "Hertz contact phases").
    if sys.damper.is_none() {
        return Err(SimError::Unsupported(
            "periodic orbits of the damped bar need a ball (a damper section)",
        ));
    }
    Ok(())
}

/// `k` in `[1, MAX_ORBIT_PERIOD]`, the error naming the flag.
pub fn check_period(periods: u32) -> Result<(), ParamError> {
    crate::limits::check(
        "period (--period, forcing cycles per orbit)",
        periods as f64,
        1.0,
        MAX_ORBIT_PERIOD as f64,
        "a whole number of forcing cycles; longer orbits are better seen in a Poincaré section",
    )?;
    Ok(())
}

/// `T J T⁻¹` with `T: (u, u̇, v, v̇) → (u, u̇, v − u, v̇ − u̇)` ([`flow::to_relative_coordinates`]
/// with `φ_d = 1`).
pub fn to_relative(j: &crate::analysis::variational::Mat4) -> DMatrix<f64> {
    to_relative_coordinates(&[1.0], &DMatrix::from_fn(4, 4, |r, c| j[r][c]))
}

impl Flow for Section {
    type State = State;
    const START_FIELD: &'static str = "starting guess (u, u̇, w, ẇ)";
    const NO_ORBIT: &'static str = "Newton's method on the stroboscopic map (no periodic orbit near the starting guess; try another start, --period or a nearby parameter)";

    fn dim(&self) -> usize {
        4
    }

    fn t0_s(&self) -> f64 {
        self.t0_s
    }

    fn periods(&self) -> u32 {
        self.periods
    }

    fn at(&self, t0_s: f64, periods: u32) -> Result<Self, SimError> {
        Section::new(self.system, t0_s, periods)
    }

    fn forcing_period_s(&self) -> f64 {
        self.system.forcing_period_s()
    }

    fn period_s(&self) -> f64 {
        Section::period_s(self)
    }

    fn omega_rad_s(&self) -> f64 {
        self.system.omega_rad_s()
    }

    fn half_gap_m(&self) -> f64 {
        self.system.damper.map_or(f64::INFINITY, |d| d.half_gap_m())
    }

    fn compliant(&self) -> bool {
        self.system
            .damper
            .is_some_and(|d| d.contact.law == crate::params::ContactLaw::Hertz)
    }

    fn state(&self, x: &[f64]) -> State {
        Section::state(self, &vec4(x))
    }

    fn vector(&self, s: &State) -> Vec<f64> {
        to_vector(s).to_vec()
    }

    fn clamp(&self, x: &[f64]) -> Vec<f64> {
        Section::clamp(self, vec4(x)).to_vec()
    }

    fn scales(&self) -> Vec<f64> {
        scales(&self.system).to_vec()
    }

    fn run(
        &self,
        s: &State,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<(State, f64), SimError> {
        let r = Exact::default().run(&self.system, s, t_end_s, obs)?;
        Ok((r.final_state, r.max_penetration_m))
    }

    fn exact_jacobian(&self, x: &[f64]) -> Result<(Vec<f64>, DMatrix<f64>), SimError> {
        let fj = crate::analysis::variational::flow_with_jacobian(
            &Exact::default(),
            &self.system,
            &Section::state(self, &vec4(x)),
            self.t0_s + Section::period_s(self),
            &mut (),
        )?;
        Ok((to_vector(&fj.state).to_vec(), to_relative(&fj.jacobian)))
    }
}

/// The first four entries of `x` (a lumped state vector).
fn vec4(x: &[f64]) -> [f64; 4] {
    [x[0], x[1], x[2], x[3]]
}

/// Scales of `(u, u̇, w, ẇ)`: [`StateScales::for_system`].
pub fn scales(sys: &System) -> [f64; 4] {
    let s = StateScales::for_system(sys);
    [s.u_m, s.du_m_s, s.w_m, s.dw_m_s]
}

/// Settings of Newton's method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonSettings {
    /// Largest number of iterations.
    pub max_iterations: usize,
    /// Converged when `max |P(x) − x|` in scaled units is below this.
    pub tolerance: f64,
}

impl Default for NewtonSettings {
    /// 40 iterations, tolerance 1e-9 scaled units (the exact solver's map is good to ~1e-12).
    fn default() -> Self {
        NewtonSettings {
            max_iterations: 40,
            tolerance: 1e-9,
        }
    }
}

/// An event of an orbit, relative to the section time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrbitEvent {
    /// Time after the section, in `[0, kT]`.
    pub dt_s: f64,
    /// What happened.
    pub kind: EventKind,
}

/// The letter of an event kind in an event sequence: impacts `+`/`-` (the wall), `f` friction
/// switch, `s` stick, `u` unstick, `c` chatter limit (contact begins), `r` release.
pub fn event_letter(kind: &EventKind) -> char {
    match kind {
        EventKind::Impact {
            wall: Wall::Plus, ..
        } => '+',
        EventKind::Impact { .. } => '-',
        EventKind::FrictionSwitch => 'f',
        EventKind::Stick => 's',
        EventKind::Unstick => 'u',
        EventKind::ChatterLimit { .. } => 'c',
        EventKind::ContactRelease { .. } => 'r',
    }
}

/// How physical an orbit is (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Physicality {
    /// Largest `|w| − l_g` along the orbit (≤ 0: never beyond a wall; under the hertz law the
    /// largest compression `δ` of a contact).
    pub max_penetration_m: f64,
    /// Smallest `l_g − |w|` at an interior turning point of `|w|` in a free flight (how close an
    /// impact is to appearing; infinite when no flight turns).
    pub grazing_margin_m: f64,
    /// Slowest relative impact speed `|ẇ−|` (infinite without impacts): near 0 an impact is
    /// about to disappear.
    pub min_impact_speed_m_s: f64,
    /// `max_penetration_m ≤` [`crate::solver::exact::CONFINEMENT_TOL_M`]; under the hertz law
    /// every excursion past `l_g` is a compliant contact phase of the solver (`δ ≥ 0` is the
    /// contact's compression), so it holds by construction.
    pub confined: bool,
}

/// A periodic orbit of a [`Flow`] and its stability.
#[derive(Debug, Clone, PartialEq)]
pub struct Orbit<F: Flow> {
    /// The section it is a fixed point of.
    pub section: F,
    /// The state at the section time.
    pub state: F::State,
    /// `max |P(x) − x|` in scaled units at the returned state.
    pub residual: f64,
    /// Newton iterations used.
    pub iterations: usize,
    /// RMS of `u` (at the response point) over the orbit.
    pub rms_m: f64,
    /// Impacts over the orbit's period (`k` forcing cycles).
    pub impacts_per_period: u32,
    /// The events over one period, in time order.
    pub events: Vec<OrbitEvent>,
    /// The event letters ([`event_letter`]) in order, e.g. `+-`.
    pub sequence: String,
    /// Monodromy matrix `DP` (SI, the map's coordinates).
    pub jacobian: DMatrix<f64>,
    /// Which [`MapJacobian`] gave it.
    pub jacobian_source: &'static str,
    /// Floquet multipliers, largest modulus first.
    pub multipliers: Vec<Complex64>,
    /// Physicality checks.
    pub physicality: Physicality,
}

/// A periodic orbit of the lumped bar.
pub type PeriodicOrbit = Orbit<Section>;

/// Multipliers inside the unit circle by at least this are stable; within it of 1 they are
/// neutral (a free ball's position), which is not asymptotic stability.
pub const STABILITY_MARGIN: f64 = 1e-7;

impl<F: Flow> Orbit<F> {
    /// Largest `|λ|`.
    pub fn max_abs_multiplier(&self) -> f64 {
        self.multipliers
            .iter()
            .map(|l| l.norm())
            .fold(0.0, f64::max)
    }

    /// Asymptotically stable: every `|λ| < 1 −` [`STABILITY_MARGIN`].
    pub fn stable(&self) -> bool {
        self.max_abs_multiplier() < 1.0 - STABILITY_MARGIN
    }

    /// Impacts per forcing cycle.
    pub fn impacts_per_cycle(&self) -> f64 {
        self.impacts_per_period as f64 / self.section.periods() as f64
    }

    /// The orbit's state vector `x` at the section.
    pub fn vector(&self) -> Vec<f64> {
        self.section.vector(&self.state)
    }
}

impl Orbit<Section> {
    /// `max |x(t0 + kT/2) + x(t0)|` in scaled units: 0 for an orbit with the symmetry
    /// `x(t + kT/2) = −x(t)` (the symmetric two-impact orbit), `None` for an even `k` (the
    /// symmetry maps the forcing onto itself only over an odd number of half cycles).
    pub fn symmetry_defect(&self) -> Result<Option<f64>, SimError> {
        if self.section.periods % 2 == 0 {
            return Ok(None);
        }
        let half = self.section.t0_s + 0.5 * self.section.period_s();
        let s = Exact::default()
            .run(&self.section.system, &self.state, half, &mut ())?
            .final_state;
        let (a, b) = (to_vector(&self.state), to_vector(&s));
        let sc = scales(&self.section.system);
        Ok(Some(
            (0..4)
                .map(|i| ((a[i] + b[i]) / sc[i]).abs())
                .fold(0.0, f64::max),
        ))
    }
}

/// Eigenvalues of a square matrix, largest modulus first.
pub fn multipliers_of(jac: &DMatrix<f64>) -> Vec<Complex64> {
    let ev = jac.complex_eigenvalues();
    let mut v: Vec<Complex64> = ev.iter().map(|c| Complex64::new(c.re, c.im)).collect();
    v.sort_by(|a, b| b.norm().total_cmp(&a.norm()).then(b.im.total_cmp(&a.im)));
    v
}

fn max_abs(r: &[f64]) -> f64 {
    r.iter().map(|v| v.abs()).fold(0.0, f64::max)
}

/// `(DP − I)` in scaled coordinates: `S⁻¹ DP S − I`.
pub(crate) fn scaled_minus_identity(jac: &DMatrix<f64>, sc: &[f64]) -> DMatrix<f64> {
    let d = sc.len();
    DMatrix::from_fn(d, d, |i, j| {
        jac[(i, j)] * sc[j] / sc[i] - if i == j { 1.0 } else { 0.0 }
    })
}

/// Least-squares solution of `a·d = b` (SVD, singular values below 1e-12 of the largest
/// dropped): the neutral directions of a free ball get no step.
pub(crate) fn lstsq(a: &DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    let svd = a.clone().svd(true, true);
    let eps = 1e-12 * svd.singular_values.max();
    let d = svd.solve(b, eps).ok()?;
    d.iter().all(|v| v.is_finite()).then_some(d)
}

/// Newton's method on `P(x) = x` from `x0` (module docs), on either bar. Returns the orbit with
/// its multipliers and checks, or [`SimError::NoConvergence`] with the residual.
pub fn find_orbit<F: Flow>(
    sec: &F,
    x0: &[f64],
    jac: &dyn MapJacobian<F>,
    settings: &NewtonSettings,
) -> Result<Orbit<F>, SimError> {
    crate::params::positive("newton.tolerance", settings.tolerance)?;
    let d = sec.dim();
    if x0.len() != d {
        return Err(ParamError::OutOfRange {
            field: "starting guess (length of the state vector)",
            value: x0.len() as f64,
            allowed: "the map's dimension (4 on the lumped bar, 2N + 2 on an N-mode bar)",
        }
        .into());
    }
    for &v in x0 {
        crate::params::finite(F::START_FIELD, v)?;
    }
    let sc = sec.scales();
    let mut x = sec.clamp(x0);
    let (mut px, mut dp) = jac.map_and_jacobian(sec, &x)?;
    let res =
        |px: &[f64], x: &[f64]| -> Vec<f64> { (0..d).map(|i| (px[i] - x[i]) / sc[i]).collect() };
    let mut r = res(&px, &x);
    let mut iterations = 0;
    let fail = |iterations: usize, r: &[f64]| SimError::NoConvergence {
        what: F::NO_ORBIT,
        iterations,
        residual: max_abs(r),
        tolerance: settings.tolerance,
    };
    while max_abs(&r) > settings.tolerance {
        if iterations >= settings.max_iterations {
            return Err(fail(iterations, &r));
        }
        iterations += 1;
        let a = scaled_minus_identity(&dp, &sc);
        let rhs = DVector::from_iterator(d, r.iter().map(|v| -v));
        let Some(step) = lstsq(&a, &rhs) else {
            return Err(fail(iterations, &r));
        };
        // Halve a step that does not lower the residual (or leaves the solver's domain).
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
            return Err(fail(iterations, &r));
        };
        x = trial;
        (px, dp) = jac.map_and_jacobian(sec, &x)?;
        r = res(&px, &x);
    }
    describe(sec, &x, dp, jac.name(), max_abs(&r), iterations)
}

/// Records the events of one period and the free-flight turning points of `|w|`.
struct OrbitRecorder {
    t0_s: f64,
    lg: f64,
    events: Vec<OrbitEvent>,
    margin_m: f64,
    min_speed: f64,
}

impl Observer for OrbitRecorder {
    fn segment(&mut self, seg: &dyn Segment) {
        if seg.mode() != Mode::Free {
            return;
        }
        let (a, b) = (seg.t_start_s(), seg.t_end_s());
        if b <= a {
            return;
        }
        // Interior maxima of |w|: sample, then refine each by golden section.
        const N: usize = 48;
        let h = (b - a) / N as f64;
        let aw = |t: f64| seg.state_at(t).w_m().abs();
        let vals: Vec<f64> = (0..=N).map(|i| aw(a + h * i as f64)).collect();
        for i in 1..N {
            if vals[i] >= vals[i - 1] && vals[i] >= vals[i + 1] {
                let (mut lo, mut hi) = (a + h * (i - 1) as f64, a + h * (i + 1) as f64);
                let g = 0.5 * (5f64.sqrt() - 1.0);
                for _ in 0..60 {
                    let (m1, m2) = (hi - g * (hi - lo), lo + g * (hi - lo));
                    if aw(m1) >= aw(m2) {
                        hi = m2;
                    } else {
                        lo = m1;
                    }
                }
                let t = 0.5 * (lo + hi);
                // A maximum at the flight's end is the next impact, not a turning point.
                if t - a > 1e-3 * (b - a) && b - t > 1e-3 * (b - a) {
                    self.margin_m = self.margin_m.min(self.lg - aw(t));
                }
            }
        }
    }

    fn event(&mut self, ev: &Event) {
        if let EventKind::Impact { dw_m_s, .. } = ev.kind {
            self.min_speed = self.min_speed.min(dw_m_s.abs());
        }
        self.events.push(OrbitEvent {
            dt_s: ev.t_s - self.t0_s,
            kind: ev.kind,
        });
    }
}

/// The orbit of `sec` at the fixed point `x` (RMS, events, multipliers, checks), either bar.
pub fn describe<F: Flow>(
    sec: &F,
    x: &[f64],
    jacobian: DMatrix<f64>,
    jacobian_source: &'static str,
    residual: f64,
    iterations: usize,
) -> Result<Orbit<F>, SimError> {
    let t_end = sec.t0_s() + sec.period_s();
    let mut rms = RmsObserver::new(sec.t0_s(), t_end);
    let mut rec = OrbitRecorder {
        t0_s: sec.t0_s(),
        lg: sec.half_gap_m(),
        events: Vec::new(),
        margin_m: f64::INFINITY,
        min_speed: f64::INFINITY,
    };
    let init = sec.state(x);
    let (_, max_penetration_m) = {
        let mut obs: [&mut dyn Observer; 2] = [&mut rms, &mut rec];
        sec.run(&init, t_end, &mut Fanout(&mut obs))?
    };
    let multipliers = multipliers_of(&jacobian);
    let rms_m = crate::limits::finite_result(
        "RMS of the orbit",
        rms.rms_m(),
        "an orbit the exact solver could not follow",
    )?;
    for l in &multipliers {
        crate::limits::finite_result(
            "Floquet multiplier",
            l.norm(),
            "a Jacobian across a grazing event",
        )?;
    }
    let impacts = rec
        .events
        .iter()
        .filter(|e| matches!(e.kind, EventKind::Impact { .. }))
        .count() as u32;
    let sequence = rec.events.iter().map(|e| event_letter(&e.kind)).collect();
    Ok(Orbit {
        section: sec.clone(),
        state: init,
        residual,
        iterations,
        rms_m,
        impacts_per_period: impacts,
        events: rec.events,
        sequence,
        jacobian,
        jacobian_source,
        multipliers,
        physicality: Physicality {
            max_penetration_m,
            grazing_margin_m: rec.margin_m,
            min_impact_speed_m_s: rec.min_speed,
            confined: sec.compliant()
                || max_penetration_m <= crate::solver::exact::CONFINEMENT_TOL_M,
        },
    })
}

/// Where a starting guess comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Start {
    /// The analytic symmetric orbit ([`symmetric_orbits`]) with this index (in the order of
    /// their impact phase); a quarter period after its `+` impact. With friction or the hertz
    /// law, that of the same system without friction under the restitution law.
    Symmetric(usize),
    /// A run from `init` over `settle_s`; the section is put in the middle of the longest
    /// event-free stretch of the last `k` periods.
    Settled {
        /// Initial state of the run.
        init: State,
        /// Simulated time before the section.
        settle_s: f64,
    },
}

/// `sys` without friction, with the restitution law and without a body force on the ball: the
/// model of the analytic symmetric orbit, whose orbit is the starting guess for `sys`.
fn analytic_model(sys: &System) -> System {
    let mut m = *sys;
    if let Some(d) = m.damper.as_mut() {
        d.friction = crate::params::FrictionModel::None;
        d.contact.law = crate::params::ContactLaw::Restitution;
        d.gravity_along_gap_m_s2 = 0.0;
    }
    m
}

/// A section and a starting state for `sys` with period `periods`, from `start`. The section
/// time is brought into `[0, T)` (the forcing is `T`-periodic).
pub fn starting_guess(
    sys: &System,
    periods: u32,
    start: &Start,
) -> Result<(Section, [f64; 4]), SimError> {
    check_system(sys)?;
    check_period(periods)?;
    let t = sys.forcing_period_s();
    let (t_sec, state) = match *start {
        Start::Symmetric(i) => {
            // With friction or the hertz law the frictionless restitution-law orbit is the
            // guess (Newton then finds the orbit of `sys`, when it is near).
            let os = symmetric_orbits(&analytic_model(sys))?;
            let Some(o) = os.get(i) else {
                return Err(ParamError::OutOfRange {
                    field: "symmetric orbit index (--branch)",
                    value: i as f64,
                    allowed: if os.is_empty() {
                        "none: no admissible symmetric orbit at this point (start from a settled run: --start settled)"
                    } else {
                        "[0, number of symmetric orbits − 1] (the orbit command lists them)"
                    },
                }
                .into());
            };
            let s = o.state_at_quarter(sys);
            (s.t_s, s)
        }
        Start::Settled { init, settle_s } => {
            let kt = periods as f64 * t;
            let (from, end) = settle_window(init.t_s, settle_s, kt)?;
            let mut times = EventTimes::new(from);
            Exact::default().run(sys, &init, end, &mut times)?;
            times.t.push(end);
            let mid = longest_gap_mid(&times.t, from + 0.5 * kt);
            let s = Exact::default().run(sys, &init, mid, &mut ())?.final_state;
            (mid, s)
        }
    };
    let shift = (t_sec / t).floor() * t;
    let sec = Section::new(*sys, t_sec - shift, periods)?;
    Ok((sec, sec.clamp(to_vector(&state))))
}

/// The last `kt` seconds `(from, end)` of a settling run of `settle_s` from `t0_s`, checked to
/// hold one orbit period (shared by the lumped and the modal starting guess).
fn settle_window(t0_s: f64, settle_s: f64, kt: f64) -> Result<(f64, f64), SimError> {
    crate::params::positive("settle time (--settle)", settle_s)?;
    let end = t0_s + settle_s;
    let from = end - kt;
    if from < t0_s {
        return Err(ParamError::OutOfRange {
            field: "settle time (--settle)",
            value: settle_s,
            allowed: "[period·T, ∞): at least one orbit period",
        }
        .into());
    }
    Ok((from, end))
}

/// The middle of the longest stretch between consecutive `times` (sorted), `default` if there
/// is none: where a section lies farthest from events (starting guesses, continuation's moving
/// section, lumped and modal).
fn longest_gap_mid(times: &[f64], default: f64) -> f64 {
    let (mut best, mut mid) = (-1.0, default);
    for w in times.windows(2) {
        if w[1] - w[0] > best {
            best = w[1] - w[0];
            mid = 0.5 * (w[0] + w[1]);
        }
    }
    mid
}

/// The event times after `from` (starting with `from` itself).
struct EventTimes {
    from: f64,
    t: Vec<f64>,
    /// Also the start of every step of a compliant contact phase, so that no stretch between
    /// two times holds a contact (the N-mode bar's starting guess; the lumped bar's keeps its
    /// section times).
    contacts: bool,
}

impl EventTimes {
    fn new(from: f64) -> Self {
        EventTimes {
            from,
            t: vec![from],
            contacts: false,
        }
    }

    fn push(&mut self, t_s: f64) {
        if t_s > self.from && self.t.len() < 1_000_000 {
            self.t.push(t_s);
        }
    }
}

impl Observer for EventTimes {
    fn segment(&mut self, seg: &dyn Segment) {
        if self.contacts && seg.compliant_contact().is_some() {
            self.push(seg.t_start_s());
        }
    }
    fn event(&mut self, ev: &Event) {
        self.push(ev.t_s);
    }
}

/// Newton from the best available guess: the stable analytic symmetric orbit (of the
/// frictionless system, for an odd period) if one converges, else the first that converges, else
/// a run from `init` over `settle_s`. Returns the orbit and the start it used.
pub fn orbit_auto(
    sys: &System,
    periods: u32,
    init: &State,
    settle_s: f64,
    jac: &dyn MapJacobian,
) -> Result<(PeriodicOrbit, Start), SimError> {
    check_system(sys)?;
    check_period(periods)?;
    let newton = NewtonSettings::default();
    let n = if periods % 2 == 1 {
        symmetric_orbits(&analytic_model(sys)).map_or(0, |v| v.len())
    } else {
        0
    };
    let mut found: Vec<(usize, PeriodicOrbit)> = (0..n)
        .filter_map(|i| {
            let (sec, x0) = starting_guess(sys, periods, &Start::Symmetric(i)).ok()?;
            find_orbit(&sec, &x0, jac, &newton).ok().map(|o| (i, o))
        })
        .collect();
    found.sort_by_key(|(_, o)| !o.stable());
    if let Some((i, o)) = found.into_iter().next() {
        return Ok((o, Start::Symmetric(i)));
    }
    let start = Start::Settled {
        init: *init,
        settle_s,
    };
    let (sec, x0) = starting_guess(sys, periods, &start)?;
    Ok((find_orbit(&sec, &x0, jac, &newton)?, start))
}
