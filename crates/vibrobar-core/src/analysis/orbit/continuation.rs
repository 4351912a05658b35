//! Pseudo-arclength continuation of a periodic orbit in one parameter, with bifurcation and
//! grazing detection and branch switching at period doublings.
//!
//! **Unknowns** `y = (ξ, p̃)`: the scaled state at the section `ξ = x/s` (the scales of the start,
//! kept along the branch) and the parameter mapped so that the requested interval is `[0, 1]`,
//! `p = from + p̃ (to − from)`. `F(y) = (P(x; p) − x)/s`; its Jacobian `[S⁻¹DPS − I | ∂F/∂p̃]`
//! (the state part from the [`MapJacobian`], the parameter column exact from the variational
//! layer ([`map_param_derivative`], one run; for the ratio with the moving end time `t₀ + kT`),
//! by central differences of the map for the mass ratio (two runs)). Each
//! step predicts along the unit tangent (the kernel of the Jacobian, oriented like the previous
//! one) and corrects with Newton on `F = 0` plus the arclength condition `t·(y − y_pred) = 0`
//! (Keller). The step grows after easy corrections and is halved after a failed one or a turn of
//! the tangent by more than 0.3 rad; below [`ContinuationSettings::step_min`] the branch stops and
//! says why.
//!
//! **Events** (between consecutive points; located by bisection on the step and reported on the
//! first point past them):
//! * `fold` / `branch-point`: the number of real multipliers above 1 changes; a fold when the
//!   tangent's parameter component changes sign there, else a branch point (for the symmetric
//!   orbit, a symmetry-breaking pitchfork);
//! * `period-doubling`: the number of real multipliers below −1 changes;
//! * `torus` (Neimark–Sacker): the number of complex multipliers outside the unit circle changes;
//! * `grazing`: the cyclic event sequence changes (an impact appears or disappears);
//! * `stick-onset`: it changes by a stick or wall-contact phase beginning or ending.
//!
//! Counts are compared only when the number of unstable multipliers changes, so a complex pair
//! outside the circle meeting on the real axis is not an event. The map is exact across a change
//! of event sequence (the solver handles whatever happens), so the branch continues through
//! grazing while the orbit stays confined; a branch whose orbit loses every event (the ball
//! floats, neutral in its position) stops there.
//!
//! **Both bars.** The scheme is written once over [`Flow`] and a [`Family`] (the systems along a
//! branch: the parameter's setter): on the lumped bar an [`AxisFamily`] (ratio, gap, friction
//! force, restitution, mass ratio), on the N-mode bar a [`super::modal::ModalFamily`] (the same
//! axes and the cavity position on a `[beam]`). The parameter column `∂F/∂p̃` is exact where the
//! family's variational layer carries the parameter ([`Family::param_derivative`]); elsewhere it
//! is the central difference `(P(x; p̃ + δ) − P(x; p̃ − δ))/2δ` with `δ` = [`Family::param_step`]
//! of the interval (two runs per corrector iteration): truncation `O(δ²)` times the map's third
//! derivative in `p̃`, rounding ~1e-12/δ of the scale. On the N-mode bar every column is a central
//! difference (`δ` = [`super::modal::PARAM_STEP`]); its accuracy is tested through the
//! implicit-function derivative `dx/dp = −(DP − I)⁻¹ ∂P/∂p` against orbits recomputed by Newton
//! at nearby cavity positions (`tests/orbit_modal.rs`), and against the lumped layer's exact
//! parameter columns on one unit mode.
//!
//! **The section moves with the orbit**: when an event comes within 2 % of the period of the
//! section time, the section is moved to the middle of the longest event-free stretch (the
//! multipliers do not depend on it).

use super::{describe, find_orbit, Flow, MapJacobian, NewtonSettings, Orbit, OrbitEvent, Section};
use crate::analysis::grid::Axis;
use crate::analysis::variational::{flow_with_param_derivative, Param};
use crate::error::{ParamError, SimError};
use crate::params::System;
use crate::solver::Exact;
use nalgebra::{DMatrix, DVector};

/// What happened between two points of a branch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BranchEvent {
    /// A fold (saddle-node): the branch turns back in the parameter.
    Fold,
    /// A multiplier crossed −1.
    PeriodDoubling,
    /// A complex pair crossed the unit circle (Neimark–Sacker).
    Torus,
    /// A real multiplier crossed +1 without a fold (symmetry-breaking pitchfork).
    BranchPoint,
    /// An impact appeared or disappeared.
    Grazing,
    /// A stick or wall-contact phase began or ended.
    StickOnset,
}

impl BranchEvent {
    /// The name in output files: `fold`, `period-doubling`, `torus`, `branch-point`, `grazing`,
    /// `stick-onset`.
    pub fn as_str(&self) -> &'static str {
        match self {
            BranchEvent::Fold => "fold",
            BranchEvent::PeriodDoubling => "period-doubling",
            BranchEvent::Torus => "torus",
            BranchEvent::BranchPoint => "branch-point",
            BranchEvent::Grazing => "grazing",
            BranchEvent::StickOnset => "stick-onset",
        }
    }
}

/// The parameters a branch can follow on the lumped bar, by their CLI names (`--param`).
pub const CONTINUATION_PARAMS: [(&str, Axis); 4] = [
    ("ratio", Axis::FreqRatio),
    ("gap-mm", Axis::GapM),
    ("friction-force-n", Axis::FrictionForceN),
    ("restitution", Axis::Restitution),
];

/// Settings of a continuation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContinuationSettings {
    /// Largest number of points on the main branch (each switched branch gets half).
    pub max_points: usize,
    /// First step, in the units where the interval is 1 (and the state is scaled).
    pub step_initial: f64,
    /// Smallest step before giving up.
    pub step_min: f64,
    /// Largest step.
    pub step_max: f64,
    /// Corrector: iterations and tolerance on `max |F|`.
    pub newton: NewtonSettings,
    /// Locate events by bisection (else they are reported at the first point past them).
    pub locate: bool,
    /// Follow the period-doubled branch from each period doubling found.
    pub switch_branches: bool,
}

impl Default for ContinuationSettings {
    fn default() -> Self {
        ContinuationSettings {
            max_points: 2000,
            step_initial: 0.01,
            step_min: 1e-7,
            step_max: 0.02,
            newton: NewtonSettings {
                max_iterations: 8,
                tolerance: 1e-9,
            },
            locate: true,
            switch_branches: true,
        }
    }
}

pub use crate::limits::MAX_CONTINUATION_POINTS;

/// One point of a branch.
#[derive(Debug, Clone, PartialEq)]
pub struct BranchPoint<F: Flow = Section> {
    /// Parameter value (SI: `gap_m` in metres).
    pub param: f64,
    /// The orbit.
    pub orbit: Orbit<F>,
    /// The event between the previous point and this one.
    pub event: Option<BranchEvent>,
    /// 0 for the main branch, 1, 2, … for branches switched to at period doublings.
    pub branch: usize,
}

/// A computed branch (and the branches switched to).
#[derive(Debug, Clone, PartialEq)]
pub struct Branch<F: Flow = Section> {
    /// The parameter followed, by its name in messages ([`Family::name`]).
    pub param: &'static str,
    /// Points, branch by branch, each in continuation order.
    pub points: Vec<BranchPoint<F>>,
    /// Why each branch ended (main branch first; then one entry per period doubling the switch
    /// was tried at).
    pub stop_reasons: Vec<String>,
}

/// The systems along a branch: a base system and the parameter followed (the continuation's
/// setter), for one bar's [`Flow`].
pub trait Family: Sync {
    /// The bar's map.
    type Flow: Flow;

    /// The parameter's name in stop reasons (`gap_m`, `cavity-position-mm`, …).
    fn name(&self) -> &'static str;

    /// The map at the parameter `value` (SI), section time `t0_s`, period `periods`, checked.
    fn section(&self, value: f64, t0_s: f64, periods: u32) -> Result<Self::Flow, SimError>;

    /// The parameter's value (SI) in `sec`, where the system carries it.
    fn value_of(&self, sec: &Self::Flow) -> Option<f64>;

    /// `∂P(x)/∂p` per SI unit from the variational layer, `None` where it does not carry the
    /// parameter (the continuation then takes central differences of the map).
    fn param_derivative(&self, sec: &Self::Flow, x: &[f64]) -> Result<Option<Vec<f64>>, SimError>;

    /// The central-difference step of the parameter column, in units of the interval (`p̃`).
    fn param_step(&self) -> f64;
}

/// The lumped bar's systems along one [`Axis`] from `base`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisFamily {
    /// The system the axis is set in.
    pub base: System,
    /// The parameter followed.
    pub axis: Axis,
}

impl Family for AxisFamily {
    type Flow = Section;

    fn name(&self) -> &'static str {
        self.axis.as_str()
    }

    fn section(&self, value: f64, t0_s: f64, periods: u32) -> Result<Section, SimError> {
        let mut s = self.base;
        self.axis.apply(&mut s, value)?;
        s.validate()?;
        Section::new(s, t0_s, periods)
    }

    fn value_of(&self, sec: &Section) -> Option<f64> {
        Some(param_of(&sec.system, self.axis))
    }

    fn param_derivative(&self, sec: &Section, x: &[f64]) -> Result<Option<Vec<f64>>, SimError> {
        let x = [x[0], x[1], x[2], x[3]];
        Ok(map_param_derivative(sec, self.axis, &x)?.map(|c| c.to_vec()))
    }

    fn param_step(&self) -> f64 {
        1e-7
    }
}

/// The state of one continuation: the family, interval, Jacobian and scales.
struct Cont<'a, Fm: Family> {
    fam: &'a Fm,
    from: f64,
    to: f64,
    sc: Vec<f64>,
    d: usize,
    jac: &'a dyn MapJacobian<Fm::Flow>,
    settings: ContinuationSettings,
    periods: u32,
}

/// A converged point: unknowns, its section, orbit and tangent.
struct Pt<F: Flow> {
    y: DVector<f64>,
    sec: F,
    orbit: Orbit<F>,
    tangent: DVector<f64>,
}

/// `F(y)`, the extended Jacobian (the `D × (D+1)` block in the top rows of a square matrix) and
/// `DP`.
type Eval = (DVector<f64>, DMatrix<f64>, DMatrix<f64>);

/// Stability class of an orbit: (real > 1, real < −1, complex outside), the cyclic event
/// sequence, and how many stick/contact phases it has.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Class {
    pos: usize,
    neg: usize,
    cplx: usize,
    seq: String,
    sticky: usize,
}

fn class_of<F: Flow>(o: &Orbit<F>) -> Class {
    let (mut pos, mut neg, mut cplx) = (0, 0, 0);
    for l in &o.multipliers {
        if l.norm() > 1.0 {
            if l.im.abs() > 1e-9 * l.norm() {
                cplx += 1;
            } else if l.re > 0.0 {
                pos += 1;
            } else {
                neg += 1;
            }
        }
    }
    Class {
        pos,
        neg,
        cplx,
        seq: cyclic_canonical(&o.sequence),
        sticky: o.sequence.chars().filter(|c| "scur".contains(*c)).count(),
    }
}

/// The smallest rotation of a cyclic sequence: the same orbit seen from another section.
fn cyclic_canonical(s: &str) -> String {
    let c: Vec<char> = s.chars().collect();
    (0..c.len().max(1))
        .map(|r| {
            c[r.min(c.len())..]
                .iter()
                .chain(&c[..r.min(c.len())])
                .collect::<String>()
        })
        .min()
        .unwrap_or_default()
}

/// The event between two classes (`None` if none), with the tangents' parameter components for
/// telling a fold from a branch point.
fn event_between(a: &Class, b: &Class, tp_a: f64, tp_b: f64) -> Option<BranchEvent> {
    if a.sticky != b.sticky {
        return Some(BranchEvent::StickOnset);
    }
    if a.seq != b.seq {
        return Some(BranchEvent::Grazing);
    }
    if a.pos + a.neg + a.cplx == b.pos + b.neg + b.cplx {
        return None;
    }
    if a.neg != b.neg {
        Some(BranchEvent::PeriodDoubling)
    } else if a.cplx != b.cplx {
        Some(BranchEvent::Torus)
    } else if tp_a * tp_b < 0.0 {
        Some(BranchEvent::Fold)
    } else {
        Some(BranchEvent::BranchPoint)
    }
}

impl<Fm: Family> Cont<'_, Fm> {
    fn param(&self, pt: f64) -> f64 {
        self.from + pt * (self.to - self.from)
    }

    fn x_of(&self, y: &DVector<f64>) -> Vec<f64> {
        (0..self.d).map(|i| y[i] * self.sc[i]).collect()
    }

    /// The unknowns of the orbit state `x` at `p̃ = pt`.
    fn y_of(&self, x: &[f64], pt: f64) -> DVector<f64> {
        DVector::from_fn(
            self.d + 1,
            |i, _| {
                if i < self.d {
                    x[i] / self.sc[i]
                } else {
                    pt
                }
            },
        )
    }

    fn section(&self, t0: f64, pt: f64) -> Result<Fm::Flow, SimError> {
        self.fam.section(self.param(pt), t0, self.periods)
    }

    /// `F(y)`, its Jacobian and `DP`.
    fn eval(&self, t0: f64, y: &DVector<f64>) -> Result<Eval, SimError> {
        let d = self.d;
        let sec = self.section(t0, y[d])?;
        let x = sec.clamp(&self.x_of(y));
        let (px, dp) = self.jac.map_and_jacobian(&sec, &x)?;
        let mut f = DVector::zeros(d + 1);
        let mut j = DMatrix::zeros(d + 1, d + 1);
        for i in 0..d {
            f[i] = (px[i] - x[i]) / self.sc[i];
            for k in 0..d {
                j[(i, k)] = dp[(i, k)] * self.sc[k] / self.sc[i] - if i == k { 1.0 } else { 0.0 };
            }
        }
        // ∂F/∂p̃: exact where the variational layer carries the parameter, else central
        // differences of the map (one-sided at the interval's natural ends is not needed: the
        // parameter stays valid slightly beyond them or the step fails).
        match self.fam.param_derivative(&sec, &x)? {
            Some(col) => {
                for i in 0..d {
                    j[(i, d)] = col[i] * (self.to - self.from) / self.sc[i];
                }
            }
            None => {
                let h = self.fam.param_step();
                let fp = |pt: f64| -> Result<Vec<f64>, SimError> { self.section(t0, pt)?.flow(&x) };
                let (a, b) = (fp(y[d] + h)?, fp(y[d] - h)?);
                for i in 0..d {
                    j[(i, d)] = (a[i] - b[i]) / (2.0 * h * self.sc[i]);
                }
            }
        }
        Ok((f, j, dp))
    }

    /// Unit tangent: kernel of the `D × (D+1)` Jacobian, oriented along `prev`.
    fn tangent(&self, j: &DMatrix<f64>, prev: &DVector<f64>) -> Option<DVector<f64>> {
        let d = self.d;
        let mut m = j.clone();
        for k in 0..=d {
            m[(d, k)] = prev[k];
        }
        let mut rhs = DVector::zeros(d + 1);
        rhs[d] = 1.0;
        let t = m.lu().solve(&rhs)?;
        let n = t.norm();
        (n.is_finite() && n > 0.0).then(|| t / n)
    }

    /// Correct from the prediction `y_pred` with the arclength condition along `t`.
    fn correct(&self, t0: f64, y_pred: &DVector<f64>, t: &DVector<f64>) -> Result<Eval, SimError> {
        let d = self.d;
        let mut y = y_pred.clone();
        let tol = self.settings.newton.tolerance;
        let mut last = f64::INFINITY;
        for it in 0..=self.settings.newton.max_iterations {
            let (f, mut j, dp) = self.eval(t0, &y)?;
            let r = f.amax();
            if r <= tol && it > 0 {
                return Ok((y, j, dp));
            }
            let diverging = r.is_nan() || r >= 10.0 * last.max(tol);
            if it == self.settings.newton.max_iterations || diverging {
                return Err(SimError::NoConvergence {
                    what: "the continuation corrector",
                    iterations: it,
                    residual: r,
                    tolerance: tol,
                });
            }
            last = r;
            let mut rhs = -f;
            for k in 0..=d {
                j[(d, k)] = t[k];
            }
            rhs[d] = -t.dot(&(&y - y_pred));
            let step = j.lu().solve(&rhs).ok_or(SimError::NoConvergence {
                what: "the continuation corrector (singular Jacobian)",
                iterations: it,
                residual: r,
                tolerance: tol,
            })?;
            y += step;
            // Keep w inside the cavity.
            let lg = self.section(t0, y[d])?.half_gap_m();
            let iw = d - 2;
            y[iw] = y[iw].clamp(-lg / self.sc[iw], lg / self.sc[iw]);
        }
        unreachable!("the loop returns")
    }

    /// A full point at `y` (section time `t0`): orbit description and tangent.
    fn point(
        &self,
        t0: f64,
        y: DVector<f64>,
        j: &DMatrix<f64>,
        dp: DMatrix<f64>,
        prev_t: &DVector<f64>,
    ) -> Result<Pt<Fm::Flow>, SimError> {
        let d = self.d;
        let sec = self.section(t0, y[d])?;
        let x = sec.clamp(&self.x_of(&y));
        let mut orbit = describe(&sec, &x, dp, self.jac.name(), 0.0, 0)?;
        let tangent =
            match self.tangent(j, prev_t) {
                Some(t) => t,
                // A ball that floats without an impact: every nearby place of the ball is an orbit
                // too (a multiplier 1), so the orbit is not isolated and has no tangent.
                None if orbit.impacts_per_period == 0 => return Err(SimError::Unsupported(
                    "the orbit has no impact: the ball floats, and its orbits form a continuum (a \
                     multiplier 1) that no continuation can follow; start where the ball impacts \
                     (another parameter value, a smaller gap or another start)",
                )),
                None => {
                    return Err(SimError::Unsupported(
                        "the continuation tangent does not exist here (the extended Jacobian is \
                     singular: the orbit is not isolated); start from a nearby parameter value",
                    ))
                }
            };
        orbit.residual = {
            let px = sec.flow(&x)?;
            (0..d)
                .map(|i| ((px[i] - x[i]) / self.sc[i]).abs())
                .fold(0.0, f64::max)
        };
        Ok(Pt {
            y,
            sec,
            orbit,
            tangent,
        })
    }

    /// Move the section when an event is within 2 % of the period of it.
    fn rephase(&self, p: Pt<Fm::Flow>) -> Result<Pt<Fm::Flow>, SimError> {
        let Some(mid) = rephased_offset(&p.orbit.events, p.sec.period_s()) else {
            return Ok(p);
        };
        let t_new = p.sec.t0_s() + mid;
        let (s, _) = p.sec.run(&p.orbit.state, t_new, &mut ())?;
        let tt = p.sec.forcing_period_s();
        let t0 = t_new - (t_new / tt).floor() * tt;
        let y = self.y_of(&p.sec.vector(&s), p.y[self.d]);
        let (_, j, dp) = self.eval(t0, &y)?;
        self.point(t0, y, &j, dp, &p.tangent)
    }

    /// The unit vector along `p̃`.
    fn e_param(&self) -> DVector<f64> {
        let mut e = DVector::zeros(self.d + 1);
        e[self.d] = 1.0;
        e
    }
}

/// Where to move the section of an orbit whose `events` (times from the section, orbit period
/// `kt`) come within 2 % of the period of it: the offset of the middle of the longest
/// event-free stretch; `None` where no event is near.
fn rephased_offset(events: &[OrbitEvent], kt: f64) -> Option<f64> {
    let near = events
        .iter()
        .any(|e| e.dt_s < 0.02 * kt || e.dt_s > 0.98 * kt);
    if !near || events.is_empty() {
        return None;
    }
    let mut times: Vec<f64> = events.iter().map(|e| e.dt_s).collect();
    times.push(events[0].dt_s + kt);
    Some(super::longest_gap_mid(&times, 0.5 * kt))
}

/// Follow the orbit `start` (a fixed point at parameter `from`) in `axis` from `from` to `to`
/// (module docs): [`follow_branch`] on the lumped bar.
pub fn continue_orbit(
    start: &Orbit<Section>,
    axis: Axis,
    from: f64,
    to: f64,
    jac: &dyn MapJacobian,
    settings: &ContinuationSettings,
) -> Result<Branch, SimError> {
    let fam = AxisFamily {
        base: start.section.system,
        axis,
    };
    follow_branch(start, &fam, from, to, jac, settings)
}

/// Follow the orbit `start` of a system of `fam` (a fixed point at the parameter `from`, SI)
/// from `from` to `to` (module docs), either bar; with `settings.switch_branches`, the
/// period-doubled branch from each period doubling of the main branch too (points with
/// `branch` 1, 2, …). The branch ends at `to`, when it turns back past `from`, at
/// `settings.max_points`, when the orbit loses every event, or when the step falls below its
/// minimum; the reason is in [`Branch::stop_reasons`].
pub fn follow_branch<Fm: Family>(
    start: &Orbit<Fm::Flow>,
    fam: &Fm,
    from: f64,
    to: f64,
    jac: &dyn MapJacobian<Fm::Flow>,
    settings: &ContinuationSettings,
) -> Result<Branch<Fm::Flow>, SimError> {
    check_ends(from, to)?;
    crate::limits::check_count(
        "points (--max-points)",
        settings.max_points,
        2,
        MAX_CONTINUATION_POINTS,
        "",
    )?;
    let c = Cont {
        fam,
        from,
        to,
        sc: start.section.scales(),
        d: start.section.dim(),
        jac,
        settings: *settings,
        periods: start.section.periods(),
    };
    let mut out = Branch {
        param: fam.name(),
        points: Vec::new(),
        stop_reasons: Vec::new(),
    };
    let p0 = fam.value_of(&start.section).unwrap_or(from);
    let reason = follow(&c, start, p0, 0, &mut out.points)?;
    out.stop_reasons.push(reason);
    if settings.switch_branches {
        let pds: Vec<(f64, Orbit<Fm::Flow>)> = out
            .points
            .iter()
            .filter(|p| p.event == Some(BranchEvent::PeriodDoubling))
            .map(|p| (p.param, p.orbit.clone()))
            .collect();
        for (param, orbit) in pds {
            if 2 * c.periods > super::MAX_ORBIT_PERIOD {
                break;
            }
            let id = out.stop_reasons.len();
            match switch_at_doubling(&c, param, &orbit, id, &mut out.points)? {
                Some(r) => out.stop_reasons.push(r),
                None => out.stop_reasons.push(format!(
                    "no period-{} orbit found next to the period doubling at {}",
                    2 * c.periods,
                    param
                )),
            }
        }
    }
    Ok(out)
}

/// Check a continuation interval: finite, not empty, both ends valid for the axis.
pub fn check_interval(axis: Axis, from: f64, to: f64) -> Result<(), ParamError> {
    let _ = axis;
    check_ends(from, to)
}

/// Check a continuation interval's ends: finite and not equal.
fn check_ends(from: f64, to: f64) -> Result<(), ParamError> {
    crate::params::finite("--from", from)?;
    crate::params::finite("--to", to)?;
    // An empty interval (the ends equal).
    if (to - from).abs() <= 0.0 {
        return Err(ParamError::OutOfRange {
            field: "--to",
            value: to,
            allowed: "a value other than --from (the interval is empty)",
        });
    }
    Ok(())
}

/// Follow one branch from `start` (at the parameter `p0`, SI), appending its points (numbered
/// `branch`); returns why it ended.
fn follow<Fm: Family>(
    c: &Cont<Fm>,
    start: &Orbit<Fm::Flow>,
    p0: f64,
    branch: usize,
    out: &mut Vec<BranchPoint<Fm::Flow>>,
) -> Result<String, SimError> {
    let d = c.d;
    // p̃ of the start (0 for the main branch).
    let y = c.y_of(&start.vector(), (p0 - c.from) / (c.to - c.from));
    let t0 = start.section.t0_s();
    let (_, j, dp) = c.eval(t0, &y)?;
    let mut cur = c.rephase(c.point(t0, y, &j, dp, &c.e_param())?)?;
    out.push(BranchPoint {
        param: c.param(cur.y[d]),
        orbit: cur.orbit.clone(),
        event: None,
        branch,
    });
    let mut h = c.settings.step_initial;
    let mut n = 1;
    let mut jumped = false;
    let mut jumps = 0;
    let max_points = if branch == 0 {
        c.settings.max_points
    } else {
        (c.settings.max_points / 2).max(2)
    };
    loop {
        if n >= max_points {
            return Ok(format!("{max_points} points reached"));
        }
        if cur.orbit.events.is_empty() {
            return Ok("the orbit lost every event (the ball floats freely; its position is neutral and the branch is not continued)".into());
        }
        if h < c.settings.step_min {
            // Near grazing the map has a square-root singularity and the corrector cannot follow
            // the tangent: try to step across at fixed parameter.
            if !jumped && jumps < MAX_JUMPS {
                jumps += 1;
                // Only a point with another event sequence is a crossing (the same sequence
                // would be the branch folding back at the nonsmooth point).
                let ca = class_of(&cur.orbit);
                let across = jump_across(c, &cur).filter(|p| class_of(&p.orbit).seq != ca.seq);
                if let Some(p) = across {
                    let cb = class_of(&p.orbit);
                    let ev = event_between(&ca, &cb, cur.tangent[d], p.tangent[d])
                        .or(Some(BranchEvent::Grazing));
                    out.push(BranchPoint {
                        param: c.param(p.y[d]),
                        orbit: p.orbit.clone(),
                        event: ev,
                        branch,
                    });
                    n += 1;
                    cur = c.rephase(p)?;
                    h = c.settings.step_initial * 0.1;
                    jumped = true;
                    continue;
                }
            }
            let lg = cur.sec.half_gap_m();
            let ph = cur.orbit.physicality;
            let slow = ph.min_impact_speed_m_s < 1e-2 * c.sc[d - 1];
            if ph.grazing_margin_m < 1e-2 * lg || slow {
                if let Some(last) = out.last_mut() {
                    last.event.get_or_insert(BranchEvent::Grazing);
                }
                let what = if slow {
                    format!(
                        "an impact at {:.2e} m/s is about to disappear",
                        ph.min_impact_speed_m_s
                    )
                } else {
                    format!(
                        "a free flight turns {:.2e} m from a wall (a new impact appears)",
                        ph.grazing_margin_m
                    )
                };
                return Ok(format!(
                    "grazing at {} = {}: {what}, and no orbit was found past it",
                    c.fam.name(),
                    c.param(cur.y[d]),
                ));
            }
            return Ok(format!(
                "step below {:e} at {} = {} (the corrector fails: a nonsmooth point the branch cannot pass)",
                c.settings.step_min,
                c.fam.name(),
                c.param(cur.y[d])
            ));
        }
        // Land exactly on the end of the interval.
        let end = if cur.tangent[d] > 0.0 { 1.0 } else { 0.0 };
        let mut hh = h;
        let mut to_end = false;
        if cur.tangent[d].abs() > 1e-3 && (end - cur.y[d]) / cur.tangent[d] < hh {
            hh = (end - cur.y[d]) / cur.tangent[d];
            to_end = true;
        }
        let next = match step(c, &cur, hh, to_end.then_some(end)) {
            Ok(p) => {
                jumped = false;
                p
            }
            Err(_) => {
                h *= 0.5;
                continue;
            }
        };
        // Turn of the tangent: too sharp a step is redone shorter.
        let cos = next.tangent.dot(&cur.tangent);
        if cos < 0.3f64.cos() && hh > c.settings.step_min * 4.0 {
            h = hh * 0.5;
            continue;
        }
        let (ca, cb) = (class_of(&cur.orbit), class_of(&next.orbit));
        let ev = event_between(&ca, &cb, cur.tangent[d], next.tangent[d]);
        // The event's row: the located first point past it (the branch goes on from the full
        // step's point, so that tiny steps near a branch point do not hop onto the other branch).
        let mut next_event = ev;
        if let (Some(e), true) = (ev, c.settings.locate) {
            if let Some(l) = locate(c, &cur, hh, &ca) {
                let cl = class_of(&l.orbit);
                // The kind from the located point's class; a fold from the tangents of the full
                // step (at the singular point itself the tangent is ill-conditioned).
                let e = event_between(&ca, &cl, cur.tangent[d], next.tangent[d]).unwrap_or(e);
                if (&l.y - &next.y).amax() > 1e-12 {
                    out.push(BranchPoint {
                        param: c.param(l.y[d]),
                        orbit: l.orbit,
                        event: Some(e),
                        branch,
                    });
                    n += 1;
                    next_event = None;
                } else {
                    next_event = Some(e);
                }
            }
        }
        out.push(BranchPoint {
            param: c.param(next.y[d]),
            orbit: next.orbit.clone(),
            event: next_event,
            branch,
        });
        n += 1;
        cur = c.rephase(next)?;
        if to_end {
            return Ok("end of the interval reached".into());
        }
        if cur.y[d] < -0.02 || cur.y[d] > 1.02 {
            return Ok("the branch left the interval".into());
        }
        h = (h * 1.3).min(c.settings.step_max);
    }
}

/// One predictor–corrector step of length `h` from `cur`; `pin` fixes `p̃` (the interval's end).
fn step<Fm: Family>(
    c: &Cont<Fm>,
    cur: &Pt<Fm::Flow>,
    h: f64,
    pin: Option<f64>,
) -> Result<Pt<Fm::Flow>, SimError> {
    let t0 = cur.sec.t0_s();
    let y_pred = &cur.y + &cur.tangent * h;
    let (y, j, dp) = match pin {
        None => c.correct(t0, &y_pred, &cur.tangent)?,
        Some(p) => {
            // Natural-parameter correction at p̃ = p: the arclength row fixes p̃ only.
            let mut yp = y_pred;
            yp[c.d] = p;
            c.correct(t0, &yp, &c.e_param())?
        }
    };
    c.point(t0, y, &j, dp, &cur.tangent)
}

/// Bisect the step between `cur` (class `ca`, step 0) and the step `h` past it for the first
/// point of another class, to 1e-9 of the step (a failed correction ends the search).
fn locate<Fm: Family>(
    c: &Cont<Fm>,
    cur: &Pt<Fm::Flow>,
    h: f64,
    ca: &Class,
) -> Option<Pt<Fm::Flow>> {
    let (mut lo, mut hi) = (0.0, h);
    let mut best = None;
    for _ in 0..30 {
        if hi - lo < 1e-9 * h.max(1e-12) {
            break;
        }
        let mid = 0.5 * (lo + hi);
        match step(c, cur, mid, None) {
            Ok(p) => {
                if class_of(&p.orbit) == *ca {
                    lo = mid;
                } else {
                    hi = mid;
                    best = Some(p);
                }
            }
            Err(_) => break,
        }
    }
    best
}

/// Most fixed-parameter jumps across nonsmooth points per branch.
const MAX_JUMPS: usize = 20;

/// Past a point where the tangent cannot be followed (grazing): Newton at fixed parameters a
/// little further along the branch's direction, from the current orbit.
fn jump_across<Fm: Family>(c: &Cont<Fm>, cur: &Pt<Fm::Flow>) -> Option<Pt<Fm::Flow>> {
    let d = c.d;
    let dir = if cur.tangent[d] >= 0.0 { 1.0 } else { -1.0 };
    let x = cur.orbit.vector();
    for dq in [1e-4, 1e-3, 1e-2] {
        let q = cur.y[d] + dir * dq;
        let sec = c.section(cur.sec.t0_s(), q).ok()?;
        let Ok(orb) = find_orbit(&sec, &x, c.jac, &NewtonSettings::default()) else {
            continue;
        };
        let y = c.y_of(&orb.vector(), q);
        let Ok((_, j, dp)) = c.eval(sec.t0_s(), &y) else {
            continue;
        };
        if let Ok(p) = c.point(sec.t0_s(), y, &j, dp, &cur.tangent) {
            return Some(p);
        }
    }
    None
}

/// The variational layer's parameter for `axis`, where it carries one (not the mass ratio).
pub fn exact_param(axis: Axis) -> Option<Param> {
    match axis {
        Axis::Restitution => Some(Param::Restitution),
        Axis::FrictionForceN => Some(Param::FrictionForceN),
        Axis::GapM => Some(Param::GapM),
        Axis::FreqRatio => Some(Param::FreqRatio),
        Axis::MassRatio => None,
    }
}

/// `∂P(x)/∂p` of the stroboscopic map at fixed `x = (u, u̇, w, ẇ)`, per SI unit of `axis`,
/// from one run of the variational layer; `None` where it carries no such parameter
/// ([`exact_param`]) and under the hertz law (the column is not built through compliant
/// contact phases): the continuation then takes central differences of the map.
pub fn map_param_derivative(
    sec: &Section,
    axis: Axis,
    x: &[f64; 4],
) -> Result<Option<[f64; 4]>, SimError> {
    let Some(p) = exact_param(axis) else {
        return Ok(None);
    };
    if sec
        .system
        .damper
        .is_some_and(|d| d.contact.law == crate::params::ContactLaw::Hertz)
    {
        // The parameter column is not built through compliant contact phases: the caller
        // takes central differences of the map.
        return Ok(None);
    }
    let (fj, mut d) = flow_with_param_derivative(
        &Exact::default(),
        &sec.system,
        &sec.state(x),
        sec.t0_s + sec.period_s(),
        p,
        &mut (),
    )?;
    if p == Param::FreqRatio {
        // The end time t₀ + 2πk/(r ω₁) moves: ∂t_end/∂r = −kT/r.
        let dt = -sec.period_s() / param_of(&sec.system, axis);
        for (di, fi) in d.iter_mut().zip(fj.end_field) {
            *di += fi * dt;
        }
    }
    // To the map's relative coordinates (w = v − u).
    Ok(Some([d[0], d[1], d[2] - d[0], d[3] - d[1]]))
}

/// `∂P(x)/∂p` by central differences of the map with step `h` in the SI value of `axis` (the
/// check on [`map_param_derivative`], and the path for the axes it does not cover).
pub fn map_param_derivative_fd(
    sec: &Section,
    axis: Axis,
    x: &[f64; 4],
    h: f64,
) -> Result<[f64; 4], SimError> {
    let p0 = param_of(&sec.system, axis);
    let at = |p: f64| -> Result<[f64; 4], SimError> {
        let mut s = sec.system;
        axis.apply(&mut s, p)?;
        Section::new(s, sec.t0_s, sec.periods)?.flow(x)
    };
    let (a, b) = (at(p0 + h)?, at(p0 - h)?);
    Ok([0, 1, 2, 3].map(|i| (a[i] - b[i]) / (2.0 * h)))
}

/// The value of `axis` in `sys`.
pub fn param_of(sys: &System, axis: Axis) -> f64 {
    let d = sys.damper.unwrap_or_default();
    match axis {
        Axis::FreqRatio => sys.omega_rad_s() / sys.omega1_rad_s(),
        Axis::GapM => d.gap_m,
        Axis::FrictionForceN => d.friction_level_n(sys.gravity_m_s2),
        Axis::Restitution => d.restitution,
        Axis::MassRatio => d.ball_mass_kg / sys.lumped_bar().map_or(f64::NAN, |b| b.mass_kg),
    }
}

/// Try to start the period-doubled branch next to the period doubling at `pd_param` (orbit `o`)
/// and follow it to the interval's end on the side it exists: Newton for a period-2k orbit from
/// `o` displaced along the eigenvector of the multiplier closest to −1, on each side; the first
/// genuine one (not the period-k orbit seen twice) is followed.
fn switch_at_doubling<Fm: Family>(
    c: &Cont<Fm>,
    pd_param: f64,
    o: &Orbit<Fm::Flow>,
    branch: usize,
    out: &mut Vec<BranchPoint<Fm::Flow>>,
) -> Result<Option<String>, SimError> {
    let dd = c.d;
    // Eigenvector of the multiplier closest to −1 (scaled coordinates): the smallest singular
    // vector of S⁻¹DPS + I.
    let a = DMatrix::from_fn(dd, dd, |i, k| {
        o.jacobian[(i, k)] * c.sc[k] / c.sc[i] + if i == k { 1.0 } else { 0.0 }
    });
    let svd = a.svd(false, true);
    let Some(vt) = svd.v_t else {
        return Ok(None);
    };
    let (imin, _) = svd.singular_values.argmin();
    let pt = (pd_param - c.from) / (c.to - c.from);
    let x = o.vector();
    for side in [1.0, -1.0] {
        for (dp, eps) in [(2e-3, 0.05), (5e-3, 0.1), (1e-3, 0.02)] {
            let q = pt + side * dp;
            let Ok(sec) = c.fam.section(c.param(q), o.section.t0_s(), 2 * c.periods) else {
                continue;
            };
            let guess: Vec<f64> = (0..dd)
                .map(|k| x[k] + eps * vt[(imin, k)] * c.sc[k])
                .collect();
            let Ok(orb) = find_orbit(&sec, &guess, c.jac, &NewtonSettings::default()) else {
                continue;
            };
            // A genuine period-2k orbit: not the period-k orbit seen twice.
            let Ok(half) = sec.at(sec.t0_s(), c.periods) else {
                continue;
            };
            let xs = orb.vector();
            let Ok(ph) = half.flow(&xs) else { continue };
            let dist = (0..dd)
                .map(|k| ((ph[k] - xs[k]) / c.sc[k]).abs())
                .fold(0.0, f64::max);
            if dist < 1e-5 {
                continue;
            }
            let sub = Cont {
                from: c.param(q),
                to: if side > 0.0 { c.to } else { c.from },
                periods: 2 * c.periods,
                settings: ContinuationSettings {
                    max_points: c.settings.max_points / 2,
                    switch_branches: false,
                    ..c.settings
                },
                sc: c.sc.clone(),
                ..*c
            };
            if (sub.to - sub.from).abs() <= 0.0 {
                continue;
            }
            let p0 = c.fam.value_of(&orb.section).unwrap_or(sub.from);
            let r = follow(&sub, &orb, p0, branch, out)?;
            return Ok(Some(format!(
                "period-{} branch from the period doubling at {}: {r}",
                2 * c.periods,
                pd_param
            )));
        }
    }
    Ok(None)
}
