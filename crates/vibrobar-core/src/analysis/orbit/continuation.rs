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
//! **The section moves with the orbit**: when an event comes within 2 % of the period of the
//! section time, the section is moved to the middle of the longest event-free stretch (the
//! multipliers do not depend on it).

use super::{
    describe, find_orbit, scales, to_vector, MapJacobian, NewtonSettings, OrbitEvent,
    PeriodicOrbit, Section,
};
use crate::analysis::grid::Axis;
use crate::analysis::variational::{flow_with_param_derivative, Param};
use crate::error::{ParamError, SimError};
use crate::params::System;
use crate::solver::{Exact, Solver};
use nalgebra::{DMatrix, Matrix4, SMatrix, SVector};

type M5 = SMatrix<f64, 5, 5>;
type V5 = SVector<f64, 5>;

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
pub struct BranchPoint {
    /// Parameter value (SI: `gap_m` in metres).
    pub param: f64,
    /// The orbit.
    pub orbit: PeriodicOrbit,
    /// The event between the previous point and this one.
    pub event: Option<BranchEvent>,
    /// 0 for the main branch, 1, 2, … for branches switched to at period doublings.
    pub branch: usize,
}

/// A computed branch (and the branches switched to).
#[derive(Debug, Clone, PartialEq)]
pub struct Branch {
    /// The parameter followed.
    pub axis: Axis,
    /// Points, branch by branch, each in continuation order.
    pub points: Vec<BranchPoint>,
    /// Why each branch ended (main branch first).
    pub stop_reasons: Vec<String>,
}

/// The state of one continuation: fixed base system, axis, interval and scales.
struct Cont<'a> {
    base: System,
    axis: Axis,
    from: f64,
    to: f64,
    sc: [f64; 4],
    jac: &'a dyn MapJacobian,
    settings: ContinuationSettings,
    periods: u32,
}

/// A converged point: unknowns, its section, orbit and tangent.
#[derive(Clone)]
struct Pt {
    y: V5,
    sec: Section,
    orbit: PeriodicOrbit,
    tangent: V5,
}

/// Stability class of an orbit: (real > 1, real < −1, complex outside), the cyclic event
/// sequence, and how many stick/contact phases it has.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Class {
    pos: usize,
    neg: usize,
    cplx: usize,
    seq: String,
    sticky: usize,
}

fn class_of(o: &PeriodicOrbit) -> Class {
    class_from(&o.multipliers, &o.sequence)
}

/// [`class_of`] from the multipliers and the event sequence (shared with the modal bar's
/// continuation).
pub(super) fn class_from(multipliers: &[num_complex::Complex64], sequence: &str) -> Class {
    let (mut pos, mut neg, mut cplx) = (0, 0, 0);
    for l in multipliers {
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
        seq: cyclic_canonical(sequence),
        sticky: sequence.chars().filter(|c| "scur".contains(*c)).count(),
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
pub(super) fn event_between(a: &Class, b: &Class, tp_a: f64, tp_b: f64) -> Option<BranchEvent> {
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

impl Cont<'_> {
    fn param(&self, pt: f64) -> f64 {
        self.from + pt * (self.to - self.from)
    }

    fn system(&self, pt: f64) -> Result<System, SimError> {
        let mut s = self.base;
        self.axis.apply(&mut s, self.param(pt))?;
        s.validate()?;
        Ok(s)
    }

    fn x_of(&self, y: &V5) -> [f64; 4] {
        [0, 1, 2, 3].map(|i| y[i] * self.sc[i])
    }

    fn section(&self, t0: f64, pt: f64) -> Result<Section, SimError> {
        Section::new(self.system(pt)?, t0, self.periods)
    }

    /// `F(y)` and its 4 × 5 Jacobian (as the top of a 5 × 5 matrix), plus `DP`.
    fn eval(&self, t0: f64, y: &V5) -> Result<(V5, M5, DMatrix<f64>), SimError> {
        let sec = self.section(t0, y[4])?;
        let x = sec.clamp(self.x_of(y));
        let (px, dp) = self.jac.map_and_jacobian(&sec, &x)?;
        let mut f = V5::zeros();
        let mut j = M5::zeros();
        for i in 0..4 {
            f[i] = (px[i] - x[i]) / self.sc[i];
            for k in 0..4 {
                j[(i, k)] = dp[(i, k)] * self.sc[k] / self.sc[i] - if i == k { 1.0 } else { 0.0 };
            }
        }
        // ∂F/∂p̃: exact where the variational layer carries the parameter, else central
        // differences of the map (one-sided at the interval's natural ends is not needed: the
        // parameter stays valid slightly beyond them or the step fails).
        match map_param_derivative(&sec, self.axis, &x)? {
            Some(col) => {
                for i in 0..4 {
                    j[(i, 4)] = col[i] * (self.to - self.from) / self.sc[i];
                }
            }
            None => {
                let d = 1e-7;
                let fp = |pt: f64| -> Result<[f64; 4], SimError> {
                    let s = self.section(t0, pt)?;
                    s.flow(&x)
                };
                let (a, b) = (fp(y[4] + d)?, fp(y[4] - d)?);
                for i in 0..4 {
                    j[(i, 4)] = (a[i] - b[i]) / (2.0 * d * self.sc[i]);
                }
            }
        }
        Ok((f, j, dp))
    }

    /// Unit tangent: kernel of the 4 × 5 Jacobian, oriented along `prev`.
    fn tangent(&self, j: &M5, prev: &V5) -> Option<V5> {
        let mut m = *j;
        for k in 0..5 {
            m[(4, k)] = prev[k];
        }
        let mut rhs = V5::zeros();
        rhs[4] = 1.0;
        let t = m.lu().solve(&rhs)?;
        let n = t.norm();
        (n.is_finite() && n > 0.0).then(|| t / n)
    }

    /// Correct from the prediction `y_pred` with the arclength condition along `t`.
    fn correct(&self, t0: f64, y_pred: &V5, t: &V5) -> Result<(V5, M5, DMatrix<f64>), SimError> {
        let mut y = *y_pred;
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
            for k in 0..5 {
                j[(4, k)] = t[k];
            }
            rhs[4] = -t.dot(&(y - y_pred));
            let d = j.lu().solve(&rhs).ok_or(SimError::NoConvergence {
                what: "the continuation corrector (singular Jacobian)",
                iterations: it,
                residual: r,
                tolerance: tol,
            })?;
            y += d;
            // Keep w inside the cavity.
            let lg = self
                .system(y[4])?
                .damper
                .map_or(f64::INFINITY, |d| d.half_gap_m());
            y[2] = y[2].clamp(-lg / self.sc[2], lg / self.sc[2]);
        }
        unreachable!("the loop returns")
    }

    /// A full point at `y` (section time `t0`): orbit description and tangent.
    fn point(&self, t0: f64, y: V5, j: &M5, dp: DMatrix<f64>, prev_t: &V5) -> Result<Pt, SimError> {
        let sec = self.section(t0, y[4])?;
        let x = sec.clamp(self.x_of(&y));
        let orbit = describe(&sec, &x, dp, self.jac.name(), 0.0, 0)?;
        let tangent = self.tangent(j, prev_t).ok_or(SimError::NoConvergence {
            what: "the continuation tangent (singular extended Jacobian)",
            iterations: 0,
            residual: f64::NAN,
            tolerance: 0.0,
        })?;
        let mut orbit = orbit;
        orbit.residual = {
            let px = sec.flow(&x)?;
            (0..4)
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
    fn rephase(&self, p: Pt) -> Result<Pt, SimError> {
        let Some(mid) = rephased_offset(&p.orbit.events, p.sec.period_s()) else {
            return Ok(p);
        };
        let t_new = p.sec.t0_s + mid;
        let s = Exact::default()
            .run(&p.sec.system, &p.orbit.state, t_new, &mut ())?
            .final_state;
        let tt = p.sec.system.forcing_period_s();
        let t0 = t_new - (t_new / tt).floor() * tt;
        let x = to_vector(&s);
        let mut y = p.y;
        for i in 0..4 {
            y[i] = x[i] / self.sc[i];
        }
        let (_, j, dp) = self.eval(t0, &y)?;
        self.point(t0, y, &j, dp, &p.tangent)
    }
}

/// Where to move the section of an orbit whose `events` (times from the section, orbit period
/// `kt`) come within 2 % of the period of it: the offset of the middle of the longest
/// event-free stretch; `None` where no event is near. The rule of lumped and modal branches.
pub(super) fn rephased_offset(events: &[OrbitEvent], kt: f64) -> Option<f64> {
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
/// (module docs). The branch ends at `to`, when it turns back past `from`, at
/// `settings.max_points`, when the orbit loses every event, or when the step falls below its
/// minimum; the reason is in [`Branch::stop_reasons`].
pub fn continue_orbit(
    start: &PeriodicOrbit,
    axis: Axis,
    from: f64,
    to: f64,
    jac: &dyn MapJacobian,
    settings: &ContinuationSettings,
) -> Result<Branch, SimError> {
    check_interval(axis, from, to)?;
    crate::limits::check_count(
        "points (--max-points)",
        settings.max_points,
        2,
        MAX_CONTINUATION_POINTS,
        "",
    )?;
    let c = Cont {
        base: start.section.system,
        axis,
        from,
        to,
        sc: scales(&start.section.system),
        jac,
        settings: *settings,
        periods: start.section.periods,
    };
    let mut out = Branch {
        axis,
        points: Vec::new(),
        stop_reasons: Vec::new(),
    };
    let reason = follow(&c, start, 0, &mut out.points)?;
    out.stop_reasons.push(reason);
    if settings.switch_branches {
        let pds: Vec<BranchPoint> = out
            .points
            .iter()
            .filter(|p| p.event == Some(BranchEvent::PeriodDoubling))
            .cloned()
            .collect();
        for pd in pds {
            if 2 * c.periods > super::MAX_ORBIT_PERIOD {
                break;
            }
            let id = out.stop_reasons.len();
            match switch_at_doubling(&c, &pd, id, &mut out.points)? {
                Some(r) => out.stop_reasons.push(r),
                None => out.stop_reasons.push(format!(
                    "no period-{} orbit found next to the period doubling at {}",
                    2 * c.periods,
                    pd.param
                )),
            }
        }
    }
    Ok(out)
}

/// Check a continuation interval: finite, not empty, both ends valid for the axis.
pub fn check_interval(axis: Axis, from: f64, to: f64) -> Result<(), ParamError> {
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
    let _ = axis;
    Ok(())
}

/// Follow one branch, appending its points; returns why it ended.
fn follow(
    c: &Cont,
    start: &PeriodicOrbit,
    branch: usize,
    out: &mut Vec<BranchPoint>,
) -> Result<String, SimError> {
    let x0 = to_vector(&start.state);
    let mut y = V5::zeros();
    for i in 0..4 {
        y[i] = x0[i] / c.sc[i];
    }
    // p̃ of the start (0 for the main branch).
    y[4] = (param_of(&start.section.system, c.axis) - c.from) / (c.to - c.from);
    let t0 = start.section.t0_s;
    let (_, j, dp) = c.eval(t0, &y)?;
    let mut e5 = V5::zeros();
    e5[4] = 1.0;
    let mut cur = c.rephase(c.point(t0, y, &j, dp, &e5)?)?;
    out.push(BranchPoint {
        param: c.param(cur.y[4]),
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
                    let ev = event_between(&ca, &cb, cur.tangent[4], p.tangent[4])
                        .or(Some(BranchEvent::Grazing));
                    out.push(BranchPoint {
                        param: c.param(p.y[4]),
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
            let lg = cur
                .sec
                .system
                .damper
                .map_or(f64::INFINITY, |d| d.half_gap_m());
            let ph = cur.orbit.physicality;
            let slow = ph.min_impact_speed_m_s < 1e-2 * c.sc[3];
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
                    c.axis.as_str(),
                    c.param(cur.y[4]),
                ));
            }
            return Ok(format!(
                "step below {:e} at {} = {} (the corrector fails: a nonsmooth point the branch cannot pass)",
                c.settings.step_min,
                c.axis.as_str(),
                c.param(cur.y[4])
            ));
        }
        // Land exactly on the end of the interval.
        let end = if cur.tangent[4] > 0.0 { 1.0 } else { 0.0 };
        let mut hh = h;
        let mut to_end = false;
        if cur.tangent[4].abs() > 1e-3 && (end - cur.y[4]) / cur.tangent[4] < hh {
            hh = (end - cur.y[4]) / cur.tangent[4];
            to_end = true;
        }
        let attempt = step(c, &cur, hh, to_end.then_some(end));
        let next = match attempt {
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
        let ev = event_between(&ca, &cb, cur.tangent[4], next.tangent[4]);
        // The event's row: the located first point past it (the branch goes on from the full
        // step's point, so that tiny steps near a branch point do not hop onto the other branch).
        let mut next_event = ev;
        if let (Some(e), true) = (ev, c.settings.locate) {
            if let Some(l) = locate(c, &cur, hh, &ca) {
                let cl = class_of(&l.orbit);
                // The kind from the located point's class; a fold from the tangents of the full
                // step (at the singular point itself the tangent is ill-conditioned).
                let e = event_between(&ca, &cl, cur.tangent[4], next.tangent[4]).unwrap_or(e);
                let fresh = (l.y - next.y).amax() > 1e-12;
                out.push(BranchPoint {
                    param: c.param(l.y[4]),
                    orbit: l.orbit,
                    event: Some(e),
                    branch,
                });
                n += 1;
                next_event = if fresh { None } else { Some(e) };
                if !fresh {
                    out.pop();
                    n -= 1;
                }
            }
        }
        out.push(BranchPoint {
            param: c.param(next.y[4]),
            orbit: next.orbit.clone(),
            event: next_event,
            branch,
        });
        n += 1;
        let done_end = to_end;
        cur = c.rephase(next)?;
        if done_end || (to_end && (cur.y[4] - end).abs() < 1e-12) {
            return Ok("end of the interval reached".into());
        }
        if cur.y[4] < -0.02 || cur.y[4] > 1.02 {
            return Ok("the branch left the interval".into());
        }
        h = (h * 1.3).min(c.settings.step_max);
    }
}

/// One predictor–corrector step of length `h` from `cur`; `pin` fixes `p̃` (the interval's end).
fn step(c: &Cont, cur: &Pt, h: f64, pin: Option<f64>) -> Result<Pt, SimError> {
    let t0 = cur.sec.t0_s;
    let y_pred = cur.y + cur.tangent * h;
    let (y, j, dp) = match pin {
        None => c.correct(t0, &y_pred, &cur.tangent)?,
        Some(p) => {
            // Natural-parameter correction at p̃ = p: the arclength row fixes p̃ only.
            let mut e5 = V5::zeros();
            e5[4] = 1.0;
            let mut yp = y_pred;
            yp[4] = p;
            c.correct(t0, &yp, &e5)?
        }
    };
    c.point(t0, y, &j, dp, &cur.tangent)
}

/// Bisect the step between `cur` (class `ca`) and `next` for the first point of the new class.
fn locate(c: &Cont, cur: &Pt, h: f64, ca: &Class) -> Option<Pt> {
    bisect_step(
        h,
        ca,
        |mid| step(c, cur, mid, None).ok(),
        |p| class_of(&p.orbit),
    )
}

/// The bisection of an event between a point of class `ca` (step 0) and the step `h` past it
/// (shared with the modal bar's continuation): `step(s)` corrects the point at arclength `s`
/// (`None` if it fails, which ends the search); the first point found of another class, to
/// 1e-9 of the step.
pub(super) fn bisect_step<P>(
    h: f64,
    ca: &Class,
    mut step: impl FnMut(f64) -> Option<P>,
    class: impl Fn(&P) -> Class,
) -> Option<P> {
    let (mut lo, mut hi) = (0.0, h);
    let mut best: Option<P> = None;
    for _ in 0..30 {
        if hi - lo < 1e-9 * h.max(1e-12) {
            break;
        }
        let mid = 0.5 * (lo + hi);
        match step(mid) {
            Some(p) => {
                if class(&p) == *ca {
                    lo = mid;
                } else {
                    hi = mid;
                    best = Some(p);
                }
            }
            None => break,
        }
    }
    best
}

/// Most fixed-parameter jumps across nonsmooth points per branch.
const MAX_JUMPS: usize = 20;

/// Past a point where the tangent cannot be followed (grazing): Newton at fixed parameters a
/// little further along the branch's direction, from the current orbit.
fn jump_across(c: &Cont, cur: &Pt) -> Option<Pt> {
    let dir = if cur.tangent[4] >= 0.0 { 1.0 } else { -1.0 };
    let x = to_vector(&cur.orbit.state);
    for d in [1e-4, 1e-3, 1e-2] {
        let q = cur.y[4] + dir * d;
        let sec = c.section(cur.sec.t0_s, q).ok()?;
        let Ok(orb) = find_orbit(&sec, &x, c.jac, &NewtonSettings::default()) else {
            continue;
        };
        let xs = to_vector(&orb.state);
        let mut y = V5::zeros();
        for i in 0..4 {
            y[i] = xs[i] / c.sc[i];
        }
        y[4] = q;
        let Ok((_, j, dp)) = c.eval(sec.t0_s, &y) else {
            continue;
        };
        if let Ok(p) = c.point(sec.t0_s, y, &j, dp, &cur.tangent) {
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

/// Try to start the period-doubled branch next to a period doubling and follow it to the
/// interval's end on the side it exists.
fn switch_at_doubling(
    c: &Cont,
    pd: &BranchPoint,
    branch: usize,
    out: &mut Vec<BranchPoint>,
) -> Result<Option<String>, SimError> {
    let o = &pd.orbit;
    // Eigenvector of the multiplier closest to −1 (scaled coordinates): the smallest singular
    // vector of S⁻¹DPS + I.
    let mut a = Matrix4::zeros();
    for i in 0..4 {
        for k in 0..4 {
            a[(i, k)] = o.jacobian[(i, k)] * c.sc[k] / c.sc[i] + if i == k { 1.0 } else { 0.0 };
        }
    }
    let svd = a.svd(false, true);
    let Some(vt) = svd.v_t else {
        return Ok(None);
    };
    let (imin, _) = svd.singular_values.argmin();
    let v: [f64; 4] = [0, 1, 2, 3].map(|k| vt[(imin, k)]);
    let pt = (pd.param - c.from) / (c.to - c.from);
    let x = to_vector(&o.state);
    for side in [1.0, -1.0] {
        for (dp, eps) in [(2e-3, 0.05), (5e-3, 0.1), (1e-3, 0.02)] {
            let q = pt + side * dp;
            let Ok(sys) = c.system(q) else { continue };
            let Ok(sec) = Section::new(sys, o.section.t0_s, 2 * c.periods) else {
                continue;
            };
            let guess = [0, 1, 2, 3].map(|k| x[k] + eps * v[k] * c.sc[k]);
            let Ok(orb) = find_orbit(&sec, &guess, c.jac, &NewtonSettings::default()) else {
                continue;
            };
            // A genuine period-2k orbit: not the period-k one seen twice.
            let half = Section {
                periods: c.periods,
                ..sec
            };
            let xs = to_vector(&orb.state);
            let Ok(ph) = half.flow(&xs) else { continue };
            let dist = (0..4)
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
                ..*c
            };
            if (sub.to - sub.from).abs() <= 0.0 {
                continue;
            }
            let r = follow(&sub, &orb, branch, out)?;
            return Ok(Some(format!(
                "period-{} branch from the period doubling at {}: {r}",
                2 * c.periods,
                pd.param
            )));
        }
    }
    Ok(None)
}
