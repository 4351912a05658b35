//! What the ball damper buys against regenerative chatter (issue #14): the time-domain judge of
//! one cutting run, width–amplitude diagrams and time-domain stability lobes.
//!
//! Definitions (every output uses them):
//! - **Start** ([`start_offset`]): the static equilibrium of the cut on a smooth surface, the ball
//!   at rest relative to the bar at the cavity centre, plus a tool velocity `ω_c·A`. `ω_c` is the
//!   linear chatter frequency of the bar being run at that speed (exact lobes, [`super::lobes`]);
//!   the velocity goes to the mode nearest `ω_c` (the lumped bar's one mode; on a modal bar
//!   [`modal_start_offset`]). The ball keeps its absolute velocity (zero). `A` is the small or the large disturbance
//!   ([`TimeDomainSettings::small_disturbance_m`], `large_disturbance_m`).
//! - **Windows** in spindle revolutions: a settling window, then a judging window.
//! - **Acceptable** ([`Judged::acceptable`]), over the judging window: the peak-to-peak tip
//!   vibration below `vibration_limit_m`; the tool never out of the cut; the envelope growth rate
//!   (least-squares slope of `ln` of each revolution's peak-to-peak, per revolution) below
//!   `growth_tolerance_per_rev`, unless the vibration is below [`GROWTH_FLOOR_LIMIT_FRACTION`]
//!   of the limit (a bounded rattle is judged by its size, not by fit noise). A run that hits the event limit is not acceptable and is
//!   counted apart ([`Judged::event_limit`]).
//! - **Regime** ([`classify_revolutions`]): from the tip sampled once per spindle revolution.

use super::batch::{BatchError, Runner};
use super::lobes::{LobeSpec, Lobes};
use crate::error::{ParamError, SimError};
use crate::excitation::Cutting;
use crate::params::{finite, positive, BarModel, State, System};
use crate::solver::exact::cutting::ExactCutting;
use crate::solver::exact::modal::cutting::ModalCutting;
use crate::solver::exact::modal::ModalExact;
use crate::solver::{Event, EventKind, Observer, Segment, Solver};
use crate::structure::{ModalModel, ModalState};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::f64::consts::PI;

/// Default small disturbance, as a fraction of the feed `h0`.
pub const SMALL_DISTURBANCE_FEED_FRACTION: f64 = 0.01;
/// Default large disturbance, as a fraction of the feed `h0`.
pub const LARGE_DISTURBANCE_FEED_FRACTION: f64 = 1.0;
/// Default vibration limit (peak-to-peak tip displacement), as a fraction of the feed: half a
/// chip thickness of waviness is the most a finishing cut tolerates.
pub const VIBRATION_LIMIT_FEED_FRACTION: f64 = 0.5;
/// Shortest settling window, revolutions.
pub const MIN_SETTLE_REVS: f64 = 5.0;
/// Shortest judging window, revolutions (the growth fit needs some revolutions).
pub const MIN_JUDGE_REVS: f64 = 10.0;
/// Longest window, revolutions (bounded work).
pub const MAX_WINDOW_REVS: f64 = 1e6;
/// Most doublings of the width when bracketing (a bar acceptable at `2^N·b_lim` is reported at
/// that width, flagged `capped`).
pub const MAX_DOUBLINGS: u32 = 12;
/// Most re-bisections below a failure found by the monotonicity check.
pub const MAX_REBISECTIONS: u32 = 8;
/// Below this fraction of the vibration limit a run is judged by its size alone, not by its
/// fitted growth: a ball rattling at nanometres (impacts far apart, each a kick) has a
/// meaningless log-slope. A growing instability from the small disturbance (0.02 of the
/// default limit) stays above it.
pub const GROWTH_FLOOR_LIMIT_FRACTION: f64 = 1e-3;
/// Envelope floor, relative to the feed: vibration below it counts as decayed (the log fit
/// would otherwise fit rounding noise).
const ENVELOPE_FLOOR_FEED_FRACTION: f64 = 1e-9;

/// Settings of the time-domain judge and of the lobe search (the `[time_domain]` scenario
/// section). Missing fields take [`TimeDomainSettings::default`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TimeDomainSettings {
    /// Small disturbance `A`, m (`None`: 0.01·h0).
    pub small_disturbance_m: Option<f64>,
    /// Large disturbance `A`, m (`None`: h0).
    pub large_disturbance_m: Option<f64>,
    /// Settling window, spindle revolutions.
    pub settle_revs: f64,
    /// Judging window, spindle revolutions.
    pub judge_revs: f64,
    /// Largest acceptable peak-to-peak tip vibration, m (`None`: 0.5·h0).
    pub vibration_limit_m: Option<f64>,
    /// Largest acceptable envelope growth rate, per revolution (`ln` of the peak-to-peak).
    pub growth_tolerance_per_rev: f64,
    /// Relative tolerance of the bisection on the width, in (0, 0.5).
    pub bisection_tolerance: f64,
    /// Widths checked below each bisection result (non-monotonic acceptability).
    pub monotonic_checks: u32,
}

impl Default for TimeDomainSettings {
    fn default() -> Self {
        TimeDomainSettings {
            small_disturbance_m: None,
            large_disturbance_m: None,
            settle_revs: 100.0,
            judge_revs: 200.0,
            vibration_limit_m: None,
            growth_tolerance_per_rev: 1e-3,
            bisection_tolerance: 0.01,
            monotonic_checks: 10,
        }
    }
}

/// Which disturbance starts a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Disturbance {
    /// `small_disturbance_m`.
    Small,
    /// `large_disturbance_m`.
    Large,
}

impl Disturbance {
    /// Both, in the column order.
    pub const ALL: [Disturbance; 2] = [Disturbance::Small, Disturbance::Large];
    /// The CSV word.
    pub fn as_str(&self) -> &'static str {
        match self {
            Disturbance::Small => "small",
            Disturbance::Large => "large",
        }
    }
    /// Parse the CSV word.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|d| d.as_str() == s)
    }
}

/// Which bar a run uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BarKind {
    /// The solid reference bar (or the `no_ball` reference), no ball.
    Solid,
    /// The bar with the cavity and the ball.
    Damped,
}

impl BarKind {
    /// Both, in the column order.
    pub const ALL: [BarKind; 2] = [BarKind::Solid, BarKind::Damped];
    /// The CSV word.
    pub fn as_str(&self) -> &'static str {
        match self {
            BarKind::Solid => "solid",
            BarKind::Damped => "damped",
        }
    }
    /// Parse the CSV word (`no_ball` is the solid column of a reference without its own bar).
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "solid" | "no_ball" => Some(BarKind::Solid),
            "damped" => Some(BarKind::Damped),
            _ => None,
        }
    }
}

impl TimeDomainSettings {
    /// Check every field against the feed `h0` it is read with; errors name the field
    /// `time_domain.<name>` and its range.
    pub fn validate(&self) -> Result<(), ParamError> {
        for (field, v) in [
            ("time_domain.small_disturbance_m", self.small_disturbance_m),
            ("time_domain.large_disturbance_m", self.large_disturbance_m),
        ] {
            if let Some(v) = v {
                finite(field, v)?;
                if v < 0.0 {
                    return Err(ParamError::OutOfRange {
                        field,
                        value: v,
                        allowed: "[0, ∞) m",
                    });
                }
            }
        }
        if let Some(v) = self.vibration_limit_m {
            positive("time_domain.vibration_limit_m", v)?;
        }
        finite("time_domain.settle_revs", self.settle_revs)?;
        crate::limits::check(
            "time_domain.settle_revs",
            self.settle_revs,
            MIN_SETTLE_REVS,
            MAX_WINDOW_REVS,
            "spindle revolutions",
        )?;
        finite("time_domain.judge_revs", self.judge_revs)?;
        crate::limits::check(
            "time_domain.judge_revs",
            self.judge_revs,
            MIN_JUDGE_REVS,
            MAX_WINDOW_REVS,
            "spindle revolutions",
        )?;
        positive(
            "time_domain.growth_tolerance_per_rev",
            self.growth_tolerance_per_rev,
        )?;
        let t = self.bisection_tolerance;
        if !(t.is_finite() && t > 0.0 && t < 0.5) {
            return Err(ParamError::OutOfRange {
                field: "time_domain.bisection_tolerance",
                value: t,
                allowed: "(0, 0.5)",
            });
        }
        if self.monotonic_checks > 1000 {
            return Err(ParamError::OutOfRange {
                field: "time_domain.monotonic_checks",
                value: f64::from(self.monotonic_checks),
                allowed: "0–1000",
            });
        }
        Ok(())
    }

    /// The disturbance `A` of `d` for feed `h0`.
    pub fn disturbance_m(&self, d: Disturbance, feed_m: f64) -> f64 {
        match d {
            Disturbance::Small => self
                .small_disturbance_m
                .unwrap_or(SMALL_DISTURBANCE_FEED_FRACTION * feed_m),
            Disturbance::Large => self
                .large_disturbance_m
                .unwrap_or(LARGE_DISTURBANCE_FEED_FRACTION * feed_m),
        }
    }

    /// The vibration limit for feed `h0`.
    pub fn vibration_limit_for(&self, feed_m: f64) -> f64 {
        self.vibration_limit_m
            .unwrap_or(VIBRATION_LIMIT_FEED_FRACTION * feed_m)
    }
}

/// The start's offset from the equilibrium of the cut (the form [`ExactCutting`] takes): the
/// tool velocity `ω_c·A`, the ball's absolute velocity unchanged (zero) and at the cavity
/// centre.
pub fn start_offset(chatter_omega_rad_s: f64, disturbance_m: f64) -> State {
    State {
        t_s: 0.0,
        u_m: 0.0,
        du_m_s: chatter_omega_rad_s * disturbance_m,
        v_m: 0.0,
        dv_m_s: 0.0,
        cavity: None,
    }
}

/// The start's offset on a modal bar (the form [`ModalCutting`] takes): the tool velocity
/// `ω_c·A` at the force point given to the mode nearest `ω_c` (`q̇ₙ = ω_c A/φₙ(x_f)`, the
/// nearest mode that moves the force point), the ball at the cavity centre with its absolute
/// velocity unchanged (zero).
pub fn modal_start_offset(
    model: &ModalModel,
    chatter_omega_rad_s: f64,
    disturbance_m: f64,
) -> Result<ModalState, ParamError> {
    let mut s = ModalState::REST;
    let nearest = model
        .modes()
        .iter()
        .enumerate()
        .filter(|(_, m)| m.shape_force != 0.0)
        .min_by(|a, b| {
            (a.1.omega_rad_s - chatter_omega_rad_s)
                .abs()
                .total_cmp(&(b.1.omega_rad_s - chatter_omega_rad_s).abs())
        });
    let Some((i, m)) = nearest else {
        return Err(ParamError::OutOfRange {
            field: "modes.shape_force (the force point's shape of every mode)",
            value: 0.0,
            allowed: "non-zero for at least one mode: the cut must move the bar",
        });
    };
    s.dq_m_s[i] = chatter_omega_rad_s * disturbance_m / m.shape_force;
    Ok(s)
}

/// The settled vibration of one run, over the judging window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Judged {
    /// Peak-to-peak tip displacement over the judging window (the largest of its
    /// revolutions), m. NaN when the run hit the event limit.
    pub peak_to_peak_m: f64,
    /// Fraction of the judging window with the tool out of the cut.
    pub out_of_cut_fraction: f64,
    /// Impacts of the ball per revolution in the judging window.
    pub impacts_per_rev: f64,
    /// Least-squares slope of `ln` of each revolution's peak-to-peak, per revolution.
    pub growth_per_rev: f64,
    /// Regime from the once-per-revolution samples.
    pub regime: RevRegime,
    /// Static deflection of the cut `u_eq`, m.
    pub static_deflection_m: f64,
    /// The run hit the event limit (not acceptable).
    pub event_limit: bool,
    /// Acceptable (module docs).
    pub acceptable: bool,
}

/// Regime of a cutting run, from the tip sampled once per spindle revolution.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RevRegime {
    /// The envelope decays (growth below `−growth_tolerance_per_rev`, or below the floor).
    Decaying,
    /// The samples repeat after `revs` revolutions (steady vibration locked to the spindle).
    Periodic {
        /// Period in revolutions.
        revs: u32,
    },
    /// The samples lie on one closed curve (chatter at a frequency incommensurate with the
    /// spindle).
    QuasiPeriodic,
    /// None of the above.
    Chaotic,
    /// The run hit the event limit.
    EventLimit,
}

impl RevRegime {
    /// The CSV word: `decaying`, `periodic` (1 revolution), `periodic-{k}`, `quasi-periodic`,
    /// `chaotic`, `event-limit`.
    pub fn as_str(&self) -> Cow<'static, str> {
        match self {
            RevRegime::Decaying => "decaying".into(),
            RevRegime::Periodic { revs: 1 } => "periodic".into(),
            RevRegime::Periodic { revs } => format!("periodic-{revs}").into(),
            RevRegime::QuasiPeriodic => "quasi-periodic".into(),
            RevRegime::Chaotic => "chaotic".into(),
            RevRegime::EventLimit => "event-limit".into(),
        }
    }

    /// Parse [`RevRegime::as_str`].
    pub fn parse(s: &str) -> Option<RevRegime> {
        Some(match s {
            "decaying" => RevRegime::Decaying,
            "periodic" => RevRegime::Periodic { revs: 1 },
            "quasi-periodic" => RevRegime::QuasiPeriodic,
            "chaotic" => RevRegime::Chaotic,
            "event-limit" => RevRegime::EventLimit,
            _ => RevRegime::Periodic {
                revs: s.strip_prefix("periodic-")?.parse().ok()?,
            },
        })
    }
}

/// Largest period tried by [`classify_revolutions`], revolutions.
pub const REV_PERIOD_MAX: u32 = 8;
/// Relative tolerance of a repeat of the once-per-revolution samples.
pub const REV_REPEAT_REL: f64 = 1e-3;

/// Classify once-per-revolution samples `(u − u_eq, u̇)` of the judging window given the
/// fitted growth and the last revolutions' peak-to-peak against the floor:
/// 1. `decaying`: growth below `−tol` or the vibration below the floor;
/// 2. `periodic(-k)`: the samples repeat after `k ≤ 8` revolutions to 1e-3 of their range
///    (the stroboscope test of [`super::regime`]);
/// 3. `quasi-periodic`: sorted by angle about their mean (axes scaled by their spreads), the
///    radius varies along the loop by at most 10 times its range (one closed curve); a cloud
///    makes the loop jump back and forth;
/// 4. `chaotic` otherwise.
pub fn classify_revolutions(
    samples: &[(f64, f64)],
    growth_per_rev: f64,
    growth_tol: f64,
    decayed: bool,
) -> RevRegime {
    if decayed || growth_per_rev < -growth_tol || samples.len() < 4 {
        return RevRegime::Decaying;
    }
    let pts: Vec<State> = samples
        .iter()
        .map(|&(u, du)| State {
            u_m: u,
            du_m_s: du,
            ..State::REST
        })
        .collect();
    for k in 1..=REV_PERIOD_MAX as usize {
        if pts.len() < 3 * k {
            break;
        }
        if super::regime::strobe_periodic(&pts, k, REV_REPEAT_REL) {
            return RevRegime::Periodic { revs: k as u32 };
        }
    }
    let n = samples.len() as f64;
    let (mu, mv) = samples
        .iter()
        .fold((0.0, 0.0), |a, s| (a.0 + s.0 / n, a.1 + s.1 / n));
    let (su, sv) = samples.iter().fold((0.0, 0.0), |a, s| {
        (a.0 + (s.0 - mu).powi(2) / n, a.1 + (s.1 - mv).powi(2) / n)
    });
    let (su, sv) = (
        su.sqrt().max(f64::MIN_POSITIVE),
        sv.sqrt().max(f64::MIN_POSITIVE),
    );
    let mut polar: Vec<(f64, f64)> = samples
        .iter()
        .map(|s| {
            let (x, y) = ((s.0 - mu) / su, (s.1 - mv) / sv);
            (y.atan2(x), x.hypot(y))
        })
        .collect();
    polar.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (rmin, rmax) = polar
        .iter()
        .fold((f64::INFINITY, 0.0f64), |a, p| (a.0.min(p.1), a.1.max(p.1)));
    let tv: f64 = polar
        .iter()
        .zip(polar.iter().cycle().skip(1))
        .map(|(a, b)| (b.1 - a.1).abs())
        .sum();
    if tv <= 10.0 * (rmax - rmin) + 1e-6 * rmax {
        RevRegime::QuasiPeriodic
    } else {
        RevRegime::Chaotic
    }
}

/// Least-squares slope of `y` against its index.
fn slope(y: &[f64]) -> f64 {
    let n = y.len() as f64;
    if y.len() < 2 {
        return 0.0;
    }
    let mx = (n - 1.0) / 2.0;
    let my = y.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (i, v) in y.iter().enumerate() {
        let dx = i as f64 - mx;
        sxy += dx * (v - my);
        sxx += dx * dx;
    }
    sxy / sxx
}

/// Collects, per revolution of the judging window, the extremes of the tip, the time out of the
/// cut, the impacts and the once-per-revolution samples.
struct RevObserver {
    t_judge: f64,
    tau: f64,
    revs: usize,
    u_eq: f64,
    lo: Vec<f64>,
    hi: Vec<f64>,
    samples: Vec<(f64, f64)>,
    out_of_cut_s: f64,
    impacts: u64,
}

impl RevObserver {
    fn new(t_judge: f64, tau: f64, revs: usize, u_eq: f64) -> Self {
        RevObserver {
            t_judge,
            tau,
            revs,
            u_eq,
            lo: vec![f64::INFINITY; revs],
            hi: vec![f64::NEG_INFINITY; revs],
            samples: Vec::with_capacity(revs),
            out_of_cut_s: 0.0,
            impacts: 0,
        }
    }

    fn end(&self) -> f64 {
        self.t_judge + self.revs as f64 * self.tau
    }

    fn note(&mut self, t: f64, u: f64) {
        let r = ((t - self.t_judge) / self.tau).floor();
        if r >= 0.0 && (r as usize) < self.revs {
            let r = r as usize;
            self.lo[r] = self.lo[r].min(u);
            self.hi[r] = self.hi[r].max(u);
        }
    }
}

/// Samples per segment for the extremes (segments are at most 1/64 of a period, so three
/// interior samples put the peak within 0.03 % of the amplitude).
const EXTREMUM_SAMPLES: usize = 4;

impl Observer for RevObserver {
    fn segment(&mut self, seg: &dyn Segment) {
        let (a0, b0) = (seg.t_start_s(), seg.t_end_s());
        let (a, b) = (a0.max(self.t_judge), b0.min(self.end()));
        if b < a {
            return;
        }
        for i in 0..=EXTREMUM_SAMPLES {
            let t = a + (b - a) * i as f64 / EXTREMUM_SAMPLES as f64;
            self.note(t, seg.state_at(t).u_m - self.u_eq);
        }
        if b > a && seg.cutting_at(0.5 * (a + b)).is_some_and(|c| !c.in_cut) {
            self.out_of_cut_s += b - a;
        }
        // Once-per-revolution samples at t_judge + r·τ.
        let next = self.samples.len();
        if next < self.revs {
            let ts = self.t_judge + next as f64 * self.tau;
            if ts >= a0 && ts <= b0 {
                let st = seg.state_at(ts);
                self.samples.push((st.u_m - self.u_eq, st.du_m_s));
            }
        }
    }

    fn event(&mut self, ev: &Event) {
        if matches!(ev.kind, EventKind::Impact { .. })
            && ev.t_s >= self.t_judge
            && ev.t_s <= self.end()
        {
            self.impacts += 1;
        }
    }
}

/// One cutting run of `sys` (a lumped or modal bar; with or without the ball) with the cut
/// `cutting`, started by [`start_offset`] (lumped) or [`modal_start_offset`] (modal) at
/// `(ω_c, A)`, judged over the windows of `settings`.
pub fn judge_run(
    sys: &System,
    cutting: &Cutting,
    solver: &ExactCutting,
    chatter_omega_rad_s: f64,
    disturbance_m: f64,
    settings: &TimeDomainSettings,
) -> Result<Judged, SimError> {
    settings.validate()?;
    let tau = cutting.delay_s();
    let revs = settings.judge_revs.ceil() as usize;
    let t_judge = settings.settle_revs * tau;
    let (u_eq, out, obs) = match &sys.bar {
        BarModel::Lumped(b) => {
            let run = ExactCutting {
                cutting: *cutting,
                ..*solver
            };
            let u_eq = run.equilibrium_u_m(sys, b.stiffness_n_per_m);
            let mut obs = RevObserver::new(t_judge, tau, revs, u_eq);
            let t_end = obs.end();
            let start = start_offset(chatter_omega_rad_s, disturbance_m);
            let out = run.run(sys, &start, t_end, &mut obs).map(|_| ());
            (u_eq, out, obs)
        }
        BarModel::Modal(model) => {
            // The modal cutting run: the tip is the response point (`u_eq` the static
            // deflection there), the start's velocity in the mode nearest `ω_c`.
            let msys = crate::structure::ModalSystem::from_system(sys)?;
            let run = ModalCutting {
                exact: ModalExact {
                    max_events: solver.exact.max_events,
                    check_invariants: solver.exact.check_invariants,
                },
                cutting: *cutting,
                steps_per_period: solver.steps_per_period,
            };
            let q_eq = run.equilibrium_q_m(&msys);
            let u_eq: f64 = model
                .modes()
                .iter()
                .zip(&q_eq)
                .map(|(m, q)| m.shape_response * q)
                .sum();
            let mut obs = RevObserver::new(t_judge, tau, revs, u_eq);
            let t_end = obs.end();
            let start = modal_start_offset(model, chatter_omega_rad_s, disturbance_m)?;
            let out = run.run(&msys, &start, t_end, &mut obs).map(|_| ());
            (u_eq, out, obs)
        }
    };
    match out {
        Err(SimError::TooManyEvents { .. }) => {
            return Ok(Judged {
                peak_to_peak_m: f64::NAN,
                out_of_cut_fraction: f64::NAN,
                impacts_per_rev: f64::NAN,
                growth_per_rev: f64::NAN,
                regime: RevRegime::EventLimit,
                static_deflection_m: u_eq,
                event_limit: true,
                acceptable: false,
            })
        }
        Err(e) => return Err(e),
        Ok(()) => {}
    }
    let floor = ENVELOPE_FLOOR_FEED_FRACTION * cutting.feed_m;
    let p2p: Vec<f64> = obs
        .lo
        .iter()
        .zip(&obs.hi)
        .map(|(l, h)| (h - l).max(0.0))
        .collect();
    let peak = p2p.iter().copied().fold(0.0, f64::max);
    let logs: Vec<f64> = p2p.iter().map(|p| p.max(floor).ln()).collect();
    let growth = slope(&logs);
    let decayed = peak <= floor;
    let judge_s = revs as f64 * tau;
    let out_frac = (obs.out_of_cut_s / judge_s).clamp(0.0, 1.0);
    let tol = settings.growth_tolerance_per_rev;
    let regime = classify_revolutions(&obs.samples, growth, tol, decayed);
    let limit = settings.vibration_limit_for(cutting.feed_m);
    let by_size = peak < GROWTH_FLOOR_LIMIT_FRACTION * limit;
    let acceptable =
        peak < limit && obs.out_of_cut_s == 0.0 && (decayed || by_size || growth < tol);
    Ok(Judged {
        peak_to_peak_m: peak,
        out_of_cut_fraction: out_frac,
        impacts_per_rev: obs.impacts as f64 / revs as f64,
        growth_per_rev: if decayed { 0.0 } else { growth },
        regime,
        static_deflection_m: u_eq,
        event_limit: false,
        acceptable,
    })
}

/// A cutting problem: the two bars, the ball, the cut, the solver and the judge's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CutProblem {
    /// The damped system (bar with the cavity and the ball); its forcing is the runout / static
    /// load on top of the cut.
    pub damped: System,
    /// The solid reference system (no ball).
    pub solid: System,
    /// The cut; its `width_m` and `spindle_rpm` are set per run.
    pub cutting: Cutting,
    /// The exact solver template (steps per period, event limit).
    pub solver: ExactCutting,
    /// The judge.
    pub settings: TimeDomainSettings,
}

fn modal_of(bar: &BarModel) -> ModalModel {
    match bar {
        BarModel::Lumped(b) => ModalModel::lumped(b),
        BarModel::Modal(m) => *m,
    }
}

impl CutProblem {
    /// The exact lobes' spec of this problem.
    pub fn lobe_spec(&self) -> LobeSpec {
        LobeSpec {
            damped: modal_of(&self.damped.bar),
            solid: modal_of(&self.solid.bar),
            ball_mass_kg: self.damped.damper.map_or(0.0, |d| d.ball_mass_kg),
            oriented_coefficient_n_m2: self.cutting.oriented_coefficient_n_m2(),
        }
    }

    /// Check the cut and the settings.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.cutting.validate()?;
        self.settings.validate()
    }

    fn system(&self, bar: BarKind) -> &System {
        match bar {
            BarKind::Solid => &self.solid,
            BarKind::Damped => &self.damped,
        }
    }

    /// One judged run of `bar` at `width_m`, `spindle_rpm`, from `disturbance`, with the chatter
    /// frequency `omega_c` of that bar at that speed.
    pub fn judge(
        &self,
        bar: BarKind,
        disturbance: Disturbance,
        width_m: f64,
        spindle_rpm: f64,
        omega_c: f64,
    ) -> Result<Judged, SimError> {
        let cutting = Cutting {
            width_m,
            spindle_rpm,
            ..self.cutting
        };
        judge_run(
            self.system(bar),
            &cutting,
            &self.solver,
            omega_c,
            self.settings
                .disturbance_m(disturbance, self.cutting.feed_m),
            &self.settings,
        )
    }
}

/// The linear boundaries and chatter frequencies at one speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearAt {
    /// `b_lim` of the damped bar, ball free, m.
    pub b_lim_m: f64,
    /// Its chatter frequency, rad/s.
    pub omega_damped_rad_s: f64,
    /// `b_lim` of the solid bar, m.
    pub b_lim_solid_m: f64,
    /// Its chatter frequency, rad/s.
    pub omega_solid_rad_s: f64,
}

/// The linear boundaries of `p` at every speed of `rpms`.
pub fn linear_at(p: &CutProblem, rpms: &[f64]) -> Result<Vec<LinearAt>, ParamError> {
    let mut l = Lobes::new(&p.lobe_spec())?;
    rpms.iter()
        .map(|&n| {
            let r = l.row(n)?;
            Ok(LinearAt {
                b_lim_m: r.ball_free.b_lim_m,
                omega_damped_rad_s: 2.0 * PI * r.ball_free.chatter_frequency_hz,
                b_lim_solid_m: r.solid.b_lim_m,
                omega_solid_rad_s: 2.0 * PI * r.solid.chatter_frequency_hz,
            })
        })
        .collect()
}

/// One row of a width–amplitude diagram.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiagramRow {
    /// Width of cut, m.
    pub width_m: f64,
    /// The disturbance.
    pub disturbance: Disturbance,
    /// The bar.
    pub bar: BarKind,
    /// The judged run.
    pub judged: Judged,
}

/// The width–amplitude diagram at `spindle_rpm` over `widths_m`: every width from both
/// disturbances for both bars (rows width-major, then disturbance, then bar), on `runner`.
pub fn width_diagram(
    p: &CutProblem,
    spindle_rpm: f64,
    widths_m: &[f64],
    runner: &Runner,
) -> Result<Vec<DiagramRow>, BatchError<SimError>> {
    p.validate()?;
    if widths_m.is_empty() {
        return Err(BatchError::Param(ParamError::OutOfRange {
            field: "widths (--widths-mm)",
            value: 0.0,
            allowed: "at least one width",
        }));
    }
    for &w in widths_m {
        positive("width (--widths-mm)", w)?;
    }
    let lin = linear_at(p, &[spindle_rpm])?[0];
    let mut jobs = Vec::with_capacity(widths_m.len() * 4);
    for &w in widths_m {
        for d in Disturbance::ALL {
            for b in BarKind::ALL {
                jobs.push((w, d, b));
            }
        }
    }
    runner.each(&jobs, |&(w, d, b)| {
        let om = match b {
            BarKind::Solid => lin.omega_solid_rad_s,
            BarKind::Damped => lin.omega_damped_rad_s,
        };
        Ok(DiagramRow {
            width_m: w,
            disturbance: d,
            bar: b,
            judged: p.judge(b, d, w, spindle_rpm, om)?,
        })
    })
}

/// The largest acceptable width of one bar from one disturbance at one speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Search {
    /// The largest `b` with every checked width in (0, b] acceptable, m.
    pub width_m: f64,
    /// Runs that hit the event limit.
    pub event_limit_runs: u32,
    /// A failure was found below a bisection result.
    pub non_monotonic: bool,
    /// Acceptable up to the doubling cap (`2^MAX_DOUBLINGS·b_lim_solid`).
    pub capped: bool,
    /// Runs made.
    pub runs: u32,
}

/// The search of issue #14 for one bar and disturbance at one speed: double from `b_start`
/// until a width fails (halve when `b_start` fails), bisect to the relative tolerance, then check
/// `monotonic_checks` widths evenly below the result and re-bisect below the smallest failure.
/// `accept` judges one width (`Ok(None)`: the event limit, not acceptable).
pub fn largest_acceptable_width(
    b_start: f64,
    settings: &TimeDomainSettings,
    mut accept: impl FnMut(f64) -> Result<Option<bool>, SimError>,
) -> Result<Search, SimError> {
    let mut s = Search {
        width_m: 0.0,
        event_limit_runs: 0,
        non_monotonic: false,
        capped: false,
        runs: 0,
    };
    let mut judge = |b: f64, s: &mut Search| -> Result<bool, SimError> {
        s.runs += 1;
        Ok(match accept(b)? {
            Some(a) => a,
            None => {
                s.event_limit_runs += 1;
                false
            }
        })
    };
    // Bracket: lo acceptable (or 0), hi failing.
    let (mut lo, mut hi);
    if judge(b_start, &mut s)? {
        lo = b_start;
        hi = f64::NAN;
        for _ in 0..MAX_DOUBLINGS {
            let b = 2.0 * lo;
            if judge(b, &mut s)? {
                lo = b;
            } else {
                hi = b;
                break;
            }
        }
        if hi.is_nan() {
            s.capped = true;
            s.width_m = lo;
            return Ok(s);
        }
    } else {
        hi = b_start;
        lo = 0.0;
        for _ in 0..MAX_DOUBLINGS {
            let b = 0.5 * hi;
            if judge(b, &mut s)? {
                lo = b;
                break;
            }
            hi = b;
        }
        if lo == 0.0 {
            return Ok(s);
        }
    }
    let tol = settings.bisection_tolerance;
    for round in 0..=MAX_REBISECTIONS {
        while hi - lo > tol * hi {
            let mid = 0.5 * (lo + hi);
            if judge(mid, &mut s)? {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        // Every checked width in (0, lo] must pass.
        let n = settings.monotonic_checks;
        let mut failure = None;
        let mut below = 0.0;
        for i in 1..=n {
            let b = lo * f64::from(i) / f64::from(n + 1);
            if judge(b, &mut s)? {
                below = b;
            } else {
                failure = Some(b);
                break;
            }
        }
        match failure {
            None => {
                s.width_m = lo;
                return Ok(s);
            }
            Some(f) => {
                s.non_monotonic = true;
                if below == 0.0 || round == MAX_REBISECTIONS {
                    s.width_m = below;
                    return Ok(s);
                }
                lo = below;
                hi = f;
            }
        }
    }
    s.width_m = lo;
    Ok(s)
}

/// One row of the time-domain lobes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TdLobeRow {
    /// Spindle speed, rpm.
    pub spindle_rpm: f64,
    /// Linear boundaries at that speed.
    pub linear: LinearAt,
    /// Solid small, solid large, damped small, damped large.
    pub searches: [Search; 4],
}

impl TdLobeRow {
    /// Event-limit runs over the four searches.
    pub fn event_limit_runs(&self) -> u32 {
        self.searches.iter().map(|s| s.event_limit_runs).sum()
    }
    /// Any of the four searches found a failure below its result.
    pub fn non_monotonic(&self) -> bool {
        self.searches.iter().any(|s| s.non_monotonic)
    }
}

/// The order of [`TdLobeRow::searches`].
pub const SEARCH_ORDER: [(BarKind, Disturbance); 4] = [
    (BarKind::Solid, Disturbance::Small),
    (BarKind::Solid, Disturbance::Large),
    (BarKind::Damped, Disturbance::Small),
    (BarKind::Damped, Disturbance::Large),
];

/// The four searches at one speed given its linear boundaries.
pub fn td_lobe_search(
    p: &CutProblem,
    spindle_rpm: f64,
    lin: &LinearAt,
    which: usize,
) -> Result<Search, SimError> {
    let (bar, d) = SEARCH_ORDER[which];
    let om = match bar {
        BarKind::Solid => lin.omega_solid_rad_s,
        BarKind::Damped => lin.omega_damped_rad_s,
    };
    largest_acceptable_width(lin.b_lim_solid_m, &p.settings, |b| {
        let j = p.judge(bar, d, b, spindle_rpm, om)?;
        Ok(if j.event_limit {
            None
        } else {
            Some(j.acceptable)
        })
    })
}

/// The row of one speed: its four searches in [`SEARCH_ORDER`], one after the other.
pub fn td_lobe_row(
    p: &CutProblem,
    spindle_rpm: f64,
    lin: &LinearAt,
) -> Result<TdLobeRow, SimError> {
    let mut searches = [None; 4];
    for (k, s) in searches.iter_mut().enumerate() {
        *s = Some(td_lobe_search(p, spindle_rpm, lin, k)?);
    }
    Ok(TdLobeRow {
        spindle_rpm,
        linear: *lin,
        searches: searches.map(|s| s.expect("all four searched")),
    })
}

/// The time-domain lobes at every speed of `rpms` (each speed's four searches run in parallel
/// on `runner`; progress counts searches).
pub fn td_lobes(
    p: &CutProblem,
    rpms: &[f64],
    runner: &Runner,
) -> Result<Vec<TdLobeRow>, BatchError<SimError>> {
    p.validate()?;
    if rpms.is_empty() {
        return Err(BatchError::Param(ParamError::OutOfRange {
            field: "spindle speeds (--rpm)",
            value: 0.0,
            allowed: "at least one speed",
        }));
    }
    let lin = linear_at(p, rpms)?;
    let jobs: Vec<(usize, usize)> = (0..rpms.len())
        .flat_map(|i| (0..4).map(move |k| (i, k)))
        .collect();
    let found = runner.each(&jobs, |&(i, k)| td_lobe_search(p, rpms[i], &lin[i], k))?;
    Ok(rpms
        .iter()
        .enumerate()
        .map(|(i, &n)| TdLobeRow {
            spindle_rpm: n,
            linear: lin[i],
            searches: [
                found[4 * i],
                found[4 * i + 1],
                found[4 * i + 2],
                found[4 * i + 3],
            ],
        })
        .collect())
}

/// Spread of one search's width over `seeds` seeded perturbations of its disturbance
/// (amplitude scaled by a uniform factor in `[1 − rel, 1 + rel]`, seeds `1..=seeds`), as the
/// maps' ensembles report chaotic points: `(min, mean, max)` of the widths, m.
pub fn width_spread(
    p: &CutProblem,
    spindle_rpm: f64,
    lin: &LinearAt,
    which: usize,
    seeds: u64,
    rel: f64,
) -> Result<(f64, f64, f64), SimError> {
    if !(rel.is_finite() && (0.0..1.0).contains(&rel)) || seeds == 0 {
        return Err(SimError::Param(ParamError::OutOfRange {
            field: "spread (seeds ≥ 1, relative perturbation in [0, 1))",
            value: rel,
            allowed: "[0, 1)",
        }));
    }
    let d = SEARCH_ORDER[which].1;
    let base = p.settings.disturbance_m(d, p.cutting.feed_m);
    let (mut lo, mut hi, mut sum) = (f64::INFINITY, 0.0f64, 0.0);
    for seed in 1..=seeds {
        let f = super::ensemble::SplitMix64::new(seed).uniform(1.0 - rel, 1.0 + rel);
        let mut q = *p;
        match d {
            Disturbance::Small => q.settings.small_disturbance_m = Some(base * f),
            Disturbance::Large => q.settings.large_disturbance_m = Some(base * f),
        }
        let w = td_lobe_search(&q, spindle_rpm, lin, which)?.width_m;
        lo = lo.min(w);
        hi = hi.max(w);
        sum += w;
    }
    Ok((lo, sum / seeds as f64, hi))
}
