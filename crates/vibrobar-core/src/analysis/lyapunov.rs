//! Largest Lyapunov exponent of the non-smooth flow, by two-trajectory divergence with periodic
//! renormalisation (Benettin et al. 1980).
//!
//! After a transient, a reference state `x` and a perturbed state `y = x + d0·e` are run side by
//! side through the solver (`Solver::run` from each state for one renormalisation interval `τ`).
//! Distances are measured in scaled coordinates `(u/s_u, u̇/s_u̇, w/s_w, ẇ/s_ẇ)`
//! ([`StateScales`]), so that `d0` is relative. After each interval `d = |y − x|`, `ln(d/d0)` is
//! accumulated and `y` is put back at distance `d0` along `y − x`. The estimate is
//! `λ = Σ ln(d_i/d0) / (n τ)`; its uncertainty is the spread of the means over blocks of
//! intervals ([`LyapunovResult::std_error_per_s`]).
//!
//! * **Cavity**: a state may only start inside the cavity. Both states are projected onto
//!   `|w| ≤ l_g` (the ball moved, the bar kept) before each interval: `rk4` leaves the ball up to
//!   one step beyond the wall after an impact, and the perturbed ball may be pushed through a
//!   wall by the rescaling. The number of projections of the perturbed state is reported
//!   ([`LyapunovResult::clamped`]); for an event-driven solver it should be zero or tiny.
//! * **Non-smooth flow**: the divergence includes the saltation at impacts only as far as the
//!   solver resolves impact times. `rk4` puts impacts on its step grid, so two trajectories closer
//!   than about `|ẇ|·dt` hit in the same step and the impact-time perturbation is lost, while an
//!   impact that falls one step apart gives a jump of order `|Δẇ|·dt`. In practice, for the
//!   paper's frictionless 0.1 mm case at r = 1 with dt = 1 µs, `d0 ≤ 1e-7` gives `λ = 0` to
//!   two decimals: a pure shift of the ball (`δw`) never changes which step an impact falls in,
//!   so it is neutral, whereas in the flow it shifts the impact times. With `rk4`, choose `d0`
//!   so that `d0·s_w` is at least `|ẇ|·dt`, compare several `d0` and `dt` (a finite-size
//!   exponent), or use an event-driven solver.
//! * **Modal bar** ([`max_lyapunov_modal`]; one loop for both bars): the state is `2N + 2`-dimensional (every mode's
//!   `qₙ`, `q̇ₙ` and the ball's `w`, `ẇ`), so the two trajectories are modal states run by a
//!   [`ModalRun`] and the distance is taken over all of them (scaled `qₙ/s_u`,
//!   `q̇ₙ/(ωₙ s_u)`: the energy norm up to the modal masses). A distance on the public state
//!   (`u`, `u̇` at one point) would not be a norm on that space, so [`max_lyapunov`] refuses a
//!   modal bar. Every norm gives the same exponent in the limit; the first interval also loses
//!   the faster modes' share of the initial direction (`tests/modal_system.rs`).
//! * Without a ball (or with a ball that never hits) the ball is neutral: its velocity
//!   perturbation persists and `w` drifts linearly, so the largest exponent is 0, not `−ζω_n`.

use crate::error::{ParamError, SimError};
use crate::limits::{self, MAX_BEAM_MODES};
use crate::params::{State, System};
use crate::solver::{ModalRun, Solver};
use crate::structure::{ModalState, ModalSystem, Point};

/// Why [`max_lyapunov`] refuses a modal bar (use [`max_lyapunov_modal`]).
pub const LYAPUNOV_LUMPED_ONLY: &str = "max_lyapunov estimates the lumped bar only: a modal bar's state space has 2N + 2 dimensions (every mode's q, q̇, the ball's v, v̇), and restarting a solver from perturbed public states (u, u̇ at the response point, w, ẇ) neither spans that space nor gives a norm on it; a modal bar is estimated on its modal states (max_lyapunov_modal)";

/// Characteristic sizes that make the state dimensionless.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StateScales {
    /// Bar displacement scale.
    pub u_m: f64,
    /// Bar velocity scale.
    pub du_m_s: f64,
    /// Relative displacement scale.
    pub w_m: f64,
    /// Relative velocity scale.
    pub dw_m_s: f64,
}

impl StateScales {
    /// Defaults: `s_u = F0/K` (static deflection under the force amplitude), `s_u̇ = ω_n s_u`,
    /// `s_w = l_g` (or `s_u` without a ball), `s_ẇ = ω_n s_w`.
    ///
    /// For a modal bar ([`max_lyapunov_modal`]) `ω₁` and the static tip compliance of the kept
    /// modes stand in for `ω_n` and `1/K`.
    pub fn for_system(sys: &System) -> StateScales {
        let wn = sys.omega1_rad_s();
        let f = sys.forcing.amplitude_n.abs() + sys.forcing.static_force_n.abs();
        let su = if f > 0.0 {
            match &sys.bar {
                crate::params::BarModel::Lumped(b) => f / b.stiffness_n_per_m,
                crate::params::BarModel::Modal(m) => f * m.tip_compliance_of_first(m.len()),
            }
        } else {
            1e-6
        };
        let sw = sys.damper.map_or(su, |d| d.half_gap_m());
        StateScales {
            u_m: su,
            du_m_s: wn * su,
            w_m: sw,
            dw_m_s: wn * sw,
        }
    }

    fn to_scaled(self, s: &State) -> [f64; 4] {
        [
            s.u_m / self.u_m,
            s.du_m_s / self.du_m_s,
            s.w_m() / self.w_m,
            s.dw_m_s() / self.dw_m_s,
        ]
    }

    fn unscaled(self, t_s: f64, x: [f64; 4]) -> State {
        let u = x[0] * self.u_m;
        let du = x[1] * self.du_m_s;
        State {
            t_s,
            u_m: u,
            du_m_s: du,
            v_m: u + x[2] * self.w_m,
            dv_m_s: du + x[3] * self.dw_m_s,
            cavity: None,
        }
    }
}

/// Settings of the estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LyapunovParams {
    /// Discarded time before the first renormalisation interval (from `init.t_s`).
    pub transient_s: f64,
    /// Renormalisation interval `τ` (a few forcing periods is usual).
    pub interval_s: f64,
    /// Number of intervals.
    pub intervals: usize,
    /// Initial and renormalised separation, in scaled units (e.g. 1e-9).
    pub d0: f64,
    /// Scales; `None` uses [`StateScales::for_system`].
    pub scales: Option<StateScales>,
    /// Number of blocks for the uncertainty (at least 2).
    pub blocks: usize,
}

impl LyapunovParams {
    /// `intervals` intervals of `periods` forcing periods each after `transient_s`, `d0 = 1e-9`,
    /// 10 blocks.
    pub fn periods(sys: &System, transient_s: f64, periods: f64, intervals: usize) -> Self {
        LyapunovParams {
            transient_s,
            interval_s: periods * sys.forcing_period_s(),
            intervals,
            d0: 1e-9,
            scales: None,
            blocks: 10,
        }
    }
}

/// The estimate and its spread.
#[derive(Debug, Clone, PartialEq)]
pub struct LyapunovResult {
    /// `λ`, in 1/s.
    pub exponent_per_s: f64,
    /// Standard error of `λ` from the spread of block means (`std(block means)/√blocks`).
    pub std_error_per_s: f64,
    /// `ln(d_i/d0)/τ` of each interval.
    pub interval_exponents_per_s: Vec<f64>,
    /// Mean of each block of intervals.
    pub block_means_per_s: Vec<f64>,
    /// Times the perturbed state had to be projected back into the cavity.
    pub clamped: usize,
}

/// What the two-trajectory estimate needs of a bar's state space: scaled coordinates (a norm on
/// the whole state), the projection into the cavity, the solver's run. The estimate itself
/// ([`diverge`]) is one loop for the lumped and the modal bar.
pub(crate) trait Trajectories {
    /// The solver's state.
    type State: Clone;
    /// Coordinates measured (`D`, or the bar's alone without a ball).
    fn dims(&self) -> usize;
    /// A ball is present.
    fn has_ball(&self) -> bool;
    /// The fixed initial direction (scaled, unit, every measured component present).
    fn direction(&self) -> Vec<f64>;
    /// Scaled coordinates of a state (`D` of them).
    fn to_scaled(&self, s: &Self::State) -> Vec<f64>;
    /// The state of scaled coordinates `y` at `t_s`.
    fn unscaled(&self, t_s: f64, y: &[f64]) -> Self::State;
    /// The ball of a bar without one put at rest on the bar's origin.
    fn drop_ball(&self, s: &mut Self::State);
    /// Project `s` into the cavity; whether it was moved.
    fn clamp(&self, s: &mut Self::State) -> bool;
    /// The state at `t_end_s` from `s`.
    fn run(&self, s: &Self::State, t_end_s: f64) -> Result<Self::State, SimError>;
    /// Time of a state.
    fn t_s(s: &Self::State) -> f64;
}

/// The two-trajectory estimate (module docs) from `init` on the bar `tr`.
pub(crate) fn diverge<T: Trajectories>(
    tr: &T,
    init: &T::State,
    p: &LyapunovParams,
) -> Result<LyapunovResult, SimError> {
    let t_init = T::t_s(init);
    let dims = tr.dims();
    let mut x = tr.run(init, t_init + p.transient_s)?;
    if !tr.has_ball() {
        tr.drop_ball(&mut x);
    }
    tr.clamp(&mut x);
    let e = tr.direction();
    let perturb = |x: &T::State, dir: &[f64]| -> T::State {
        let mut ys = tr.to_scaled(x);
        for k in 0..dims {
            ys[k] += p.d0 * dir[k];
        }
        let mut y = tr.unscaled(T::t_s(x), &ys);
        if !tr.has_ball() {
            tr.drop_ball(&mut y);
        }
        y
    };
    let mut y = perturb(&x, &e);
    let mut clamped = usize::from(tr.clamp(&mut y));
    let mut rates = Vec::with_capacity(p.intervals);
    for i in 1..=p.intervals {
        let t_end = t_init + p.transient_s + i as f64 * p.interval_s;
        let mut xn = tr.run(&x, t_end)?;
        let yn = tr.run(&y, t_end)?;
        let (xs, ys) = (tr.to_scaled(&xn), tr.to_scaled(&yn));
        let mut diff = vec![0.0; xs.len()];
        for k in 0..dims {
            diff[k] = ys[k] - xs[k];
        }
        let d = diff.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !d.is_finite() {
            return Err(SimError::NonFinite { t_s: t_end });
        }
        // d = 0: the trajectories merged (e.g. both projected onto the same wall point). Record
        // the collapse at the smallest representable distance and restart along `e`.
        let (d, dir) = if d > 0.0 {
            (d, diff.iter().map(|v| v / d).collect())
        } else {
            (f64::MIN_POSITIVE, e.clone())
        };
        rates.push((d / p.d0).ln() / p.interval_s);
        tr.clamp(&mut xn);
        y = perturb(&xn, &dir);
        clamped += usize::from(tr.clamp(&mut y));
        x = xn;
    }
    summarise(rates, p.blocks, clamped)
}

/// The scales checked positive (every estimate: largest exponent and spectrum).
pub(crate) fn check_scales(sc: &StateScales) -> Result<(), SimError> {
    for (field, v) in [
        ("scales.u_m", sc.u_m),
        ("scales.du_m_s", sc.du_m_s),
        ("scales.w_m", sc.w_m),
        ("scales.dw_m_s", sc.dw_m_s),
    ] {
        crate::params::positive(field, v)?;
    }
    Ok(())
}

/// The lumped bar's trajectories: `(u, u̇, w, ẇ)` scaled by [`StateScales`], any solver.
struct Lumped<'a> {
    sys: &'a System,
    solver: &'a dyn Solver,
    sc: StateScales,
    lg: f64,
}

impl Trajectories for Lumped<'_> {
    type State = State;

    fn dims(&self) -> usize {
        // Without a ball the ball coordinates are meaningless: measure (u, u̇) only.
        if self.has_ball() {
            4
        } else {
            2
        }
    }

    fn has_ball(&self) -> bool {
        self.sys.damper.is_some()
    }

    fn direction(&self) -> Vec<f64> {
        if self.has_ball() {
            vec![0.5; 4]
        } else {
            vec![
                std::f64::consts::FRAC_1_SQRT_2,
                std::f64::consts::FRAC_1_SQRT_2,
                0.0,
                0.0,
            ]
        }
    }

    fn to_scaled(&self, s: &State) -> Vec<f64> {
        self.sc.to_scaled(s).to_vec()
    }

    fn unscaled(&self, t_s: f64, y: &[f64]) -> State {
        self.sc.unscaled(t_s, [y[0], y[1], y[2], y[3]])
    }

    fn drop_ball(&self, s: &mut State) {
        s.v_m = 0.0;
        s.dv_m_s = 0.0;
    }

    fn clamp(&self, s: &mut State) -> bool {
        onto_cavity(s, self.lg)
    }

    fn run(&self, s: &State, t_end_s: f64) -> Result<State, SimError> {
        Ok(self.solver.run(self.sys, s, t_end_s, &mut ())?.final_state)
    }

    fn t_s(s: &State) -> f64 {
        s.t_s
    }
}

/// Estimate the largest Lyapunov exponent of `sys` starting from `init`.
pub fn max_lyapunov(
    sys: &System,
    init: &State,
    solver: &dyn Solver,
    p: &LyapunovParams,
) -> Result<LyapunovResult, SimError> {
    if sys.lumped_bar().is_none() {
        return Err(SimError::Unsupported(LYAPUNOV_LUMPED_ONLY));
    }
    check_params(p)?;
    let sc = p.scales.unwrap_or_else(|| StateScales::for_system(sys));
    check_scales(&sc)?;
    let tr = Lumped {
        sys,
        solver,
        sc,
        lg: sys.damper.map_or(f64::INFINITY, |d| d.half_gap_m()),
    };
    diverge(&tr, init, p)
}

/// Put a ball that reads outside the cavity (`|v − u| > l_g`) back on the wall it crossed:
/// `v = u ± l_g`, then stepped inwards by ulps while the recomputed `v − u` is still outside
/// (`(u + l_g) − u` can exceed `l_g` by an ulp, which the next run's initial-state check
/// refuses). Returns whether the state was moved.
pub(crate) fn onto_cavity(s: &mut State, lg: f64) -> bool {
    let w = s.w_m();
    if w.abs() <= lg {
        return false;
    }
    s.v_m = s.u_m + lg.copysign(w);
    // Bounded: each step moves v by one ulp of v towards u; a few suffice.
    for _ in 0..64 {
        if s.w_m().abs() <= lg {
            break;
        }
        s.v_m -= w.signum() * f64::EPSILON * s.v_m.abs().max(f64::MIN_POSITIVE);
    }
    true
}

/// [`onto_cavity`] for a modal state: a ball beyond a wall (a run that ended inside a compliant
/// contact, or `v = w + φ_dᵀq` rounded) is put back on it, stepped inwards by ulps.
pub(crate) fn onto_cavity_modal(s: &mut ModalState, sys: &ModalSystem) -> bool {
    let Some(lg) = sys.damper.map(|d| d.half_gap_m()) else {
        return false;
    };
    let w = s.w_m(&sys.model);
    if w.abs() <= lg {
        return false;
    }
    s.v_m = s.u_at(&sys.model, Point::Cavity) + lg.copysign(w);
    for _ in 0..64 {
        if s.w_m(&sys.model).abs() <= lg {
            break;
        }
        s.v_m -= w.signum() * f64::EPSILON * s.v_m.abs().max(f64::MIN_POSITIVE);
    }
    true
}

/// The checks of the settings every estimate makes.
pub(crate) fn check_params(p: &LyapunovParams) -> Result<(), SimError> {
    crate::params::non_negative("transient_s", p.transient_s)?;
    crate::params::positive("interval_s", p.interval_s)?;
    crate::params::positive("d0", p.d0)?;
    // Below the minimum `x + d0·e` rounds back to `x` and the estimate measures round-off.
    limits::check(
        "d0 (--d0)",
        p.d0,
        limits::LYAPUNOV_D0_MIN,
        limits::LYAPUNOV_D0_MAX,
        "the separation must survive rounding and stay in the linear range",
    )?;
    if p.intervals == 0 {
        return Err(ParamError::OutOfRange {
            field: "intervals",
            value: 0.0,
            allowed: "[1, ∞)",
        }
        .into());
    }
    limits::check_count(
        "intervals (--duration / (--periods · T))",
        p.intervals,
        1,
        limits::MAX_LYAPUNOV_INTERVALS,
        "raise --periods or shorten --duration",
    )?;
    if p.blocks < 2 || p.blocks > p.intervals {
        return Err(ParamError::OutOfRange {
            field: "blocks",
            value: p.blocks as f64,
            allowed: "[2, intervals]",
        }
        .into());
    }
    Ok(())
}

/// The estimate and its spread from the interval rates.
fn summarise(rates: Vec<f64>, blocks: usize, clamped: usize) -> Result<LyapunovResult, SimError> {
    let n = rates.len();
    let exponent = rates.iter().sum::<f64>() / n as f64;
    let b = blocks;
    let block_means: Vec<f64> = (0..b)
        .map(|j| {
            let (lo, hi) = (j * n / b, (j + 1) * n / b);
            rates[lo..hi].iter().sum::<f64>() / (hi - lo) as f64
        })
        .collect();
    let bm = block_means.iter().sum::<f64>() / b as f64;
    let var = block_means.iter().map(|m| (m - bm).powi(2)).sum::<f64>() / (b - 1) as f64;
    limits::finite_result(
        "Lyapunov exponent",
        exponent,
        "a renormalisation interval too short for the solver's step",
    )?;
    Ok(LyapunovResult {
        exponent_per_s: exponent,
        std_error_per_s: (var / b as f64).sqrt(),
        interval_exponents_per_s: rates,
        block_means_per_s: block_means,
        clamped,
    })
}

/// Scaled coordinates of a modal state: `qₙ/s_u`, `q̇ₙ/(ωₙ s_u)` for every mode (the energy norm
/// up to the modal masses), `w/s_w`, `ẇ/(ω₁ s_w)` for the ball; `2N + 2` of them.
const MODAL_DIMS: usize = 2 * MAX_BEAM_MODES + 2;

struct ModalScales {
    n: usize,
    /// Per coordinate: q₁…q_N, q̇₁…q̇_N, w, ẇ.
    s: [f64; MODAL_DIMS],
    phi_d: [f64; MAX_BEAM_MODES],
}

impl ModalScales {
    fn new(sys: &ModalSystem, sc: &StateScales) -> ModalScales {
        let n = sys.n_modes();
        let w1 = sys.omega1_rad_s();
        let mut s = [1.0; MODAL_DIMS];
        for (i, m) in sys.model.modes().iter().enumerate() {
            s[i] = sc.u_m;
            s[n + i] = sc.du_m_s * m.omega_rad_s / w1;
        }
        s[2 * n] = sc.w_m;
        s[2 * n + 1] = sc.dw_m_s;
        ModalScales {
            n,
            s,
            phi_d: sys.row(Point::Cavity),
        }
    }

    fn to_scaled(&self, x: &ModalState) -> [f64; MODAL_DIMS] {
        let n = self.n;
        let mut out = [0.0; MODAL_DIMS];
        let (mut ud, mut dud) = (0.0, 0.0);
        for i in 0..n {
            out[i] = x.q_m[i] / self.s[i];
            out[n + i] = x.dq_m_s[i] / self.s[n + i];
            ud += self.phi_d[i] * x.q_m[i];
            dud += self.phi_d[i] * x.dq_m_s[i];
        }
        out[2 * n] = (x.v_m - ud) / self.s[2 * n];
        out[2 * n + 1] = (x.dv_m_s - dud) / self.s[2 * n + 1];
        out
    }

    fn unscaled(&self, t_s: f64, y: &[f64; MODAL_DIMS]) -> ModalState {
        let n = self.n;
        let mut x = ModalState {
            t_s,
            ..ModalState::REST
        };
        let (mut ud, mut dud) = (0.0, 0.0);
        for i in 0..n {
            x.q_m[i] = y[i] * self.s[i];
            x.dq_m_s[i] = y[n + i] * self.s[n + i];
            ud += self.phi_d[i] * x.q_m[i];
            dud += self.phi_d[i] * x.dq_m_s[i];
        }
        x.v_m = ud + y[2 * n] * self.s[2 * n];
        x.dv_m_s = dud + y[2 * n + 1] * self.s[2 * n + 1];
        x
    }
}

/// The largest Lyapunov exponent of a modal bar, by the same two-trajectory method as
/// [`max_lyapunov`], on the modal states themselves: the distance is a norm on the whole
/// `2N + 2`-dimensional state (module docs; scales [`StateScales::for_system`] of
/// `sys.to_system()`, the velocities of mode `n` over `ωₙ` instead of `ω₁`), so every direction
/// the flow can stretch is seen. The cavity projection and the caveats of `rk4` are those of
/// [`max_lyapunov`]. With one unit mode it is `max_lyapunov`'s estimate (the same scaled
/// coordinates).
pub fn max_lyapunov_modal(
    sys: &ModalSystem,
    init: &ModalState,
    run: &ModalRun<'_>,
    p: &LyapunovParams,
) -> Result<LyapunovResult, SimError> {
    sys.validate()?;
    init.validate(sys)?;
    check_params(p)?;
    let st = p
        .scales
        .unwrap_or_else(|| StateScales::for_system(&sys.to_system()));
    check_scales(&st)?;
    let tr = Modal {
        sys,
        run,
        sc: ModalScales::new(sys, &st),
        lg: sys.damper.map_or(f64::INFINITY, |d| d.half_gap_m()),
    };
    diverge(&tr, init, p)
}

/// A modal bar's trajectories: the modal states scaled by [`ModalScales`], run by a
/// [`ModalRun`].
struct Modal<'a, 'r> {
    sys: &'a ModalSystem,
    run: &'a ModalRun<'r>,
    sc: ModalScales,
    lg: f64,
}

impl Trajectories for Modal<'_, '_> {
    type State = ModalState;

    fn dims(&self) -> usize {
        // Without a ball: the modes only.
        if self.has_ball() {
            2 * self.sc.n + 2
        } else {
            2 * self.sc.n
        }
    }

    fn has_ball(&self) -> bool {
        self.sys.damper.is_some()
    }

    fn direction(&self) -> Vec<f64> {
        let dims = self.dims();
        let mut e = vec![0.0; 2 * self.sc.n + 2];
        for v in e.iter_mut().take(dims) {
            *v = 1.0 / (dims as f64).sqrt();
        }
        e
    }

    fn to_scaled(&self, s: &ModalState) -> Vec<f64> {
        self.sc.to_scaled(s)[..2 * self.sc.n + 2].to_vec()
    }

    fn unscaled(&self, t_s: f64, y: &[f64]) -> ModalState {
        let mut a = [0.0; MODAL_DIMS];
        a[..y.len()].copy_from_slice(y);
        self.sc.unscaled(t_s, &a)
    }

    fn drop_ball(&self, s: &mut ModalState) {
        s.v_m = 0.0;
        s.dv_m_s = 0.0;
    }

    fn clamp(&self, s: &mut ModalState) -> bool {
        let w = s.w_m(&self.sys.model);
        if w.abs() > self.lg {
            s.v_m = s.u_at(&self.sys.model, Point::Cavity) + self.lg.copysign(w);
            true
        } else {
            false
        }
    }

    fn run(&self, s: &ModalState, t_end_s: f64) -> Result<ModalState, SimError> {
        (self.run)(self.sys, s, t_end_s)
    }

    fn t_s(s: &ModalState) -> f64 {
        s.t_s
    }
}
