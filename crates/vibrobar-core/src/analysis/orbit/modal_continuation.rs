//! Pseudo-arclength continuation of a periodic orbit of the N-mode bar in one parameter: the
//! frequency ratio, the gap, the friction force, the restitution, or the **cavity position** on a
//! `[beam]` (the ball moves along the bar: every mode's shape at the cavity changes).
//!
//! The scheme is the lumped bar's ([`super::continuation`]): unknowns `y = (ξ, p̃)` (the state
//! `(q, q̇, w, ẇ)` scaled as in [`super::modal`], the parameter mapped so that the interval is
//! `[0, 1]`), `F(y) = (P(x; p) − x)/s`, Keller's arclength condition, step control (grown after
//! an easy correction, halved after a failed one or a turn of the tangent by more than 0.3 rad),
//! the section moved when an event comes within 2 % of the period of it, and the same events
//! (`fold`, `period-doubling`, `torus`, `branch-point` from the multipliers, `grazing` and
//! `stick-onset` from the event sequence; [`BranchEvent`]), each located by the lumped bar's
//! bisection of the step that brackets it (`continuation::bisect_step`, to 1e-9 of the step),
//! and, with `switch_branches`, the switch to the period-2k branch at each period doubling of
//! the main branch (Newton on the period-2k map from the orbit displaced along the eigenvector
//! of the multiplier closest to −1, as on the lumped bar).
//!
//! **Jacobian.** The state block is exact (the variational flow of
//! [`crate::analysis::variational_modal`]). The parameter column is a central difference of the
//! map, `∂P/∂p̃ ≈ (P(x; p̃ + δ) − P(x; p̃ − δ))/2δ` with `δ` = [`PARAM_STEP`] of the interval (two
//! runs per corrector iteration): truncation `O(δ²)` times the map's third derivative in `p̃`,
//! rounding ~1e-12/δ of the scale; its accuracy is tested through the implicit-function
//! derivative `dx/dp = −(DP − I)⁻¹ ∂P/∂p` against orbits recomputed by Newton at nearby cavity
//! positions (`tests/orbit_modal.rs`), and against the lumped layer's exact parameter columns on
//! one unit mode.
//!
//! **Not done here** (the lumped bar's continuation has it): the jump across a grazing point at
//! fixed parameter.
//!
//! **Cavity position.** The modal model is rebuilt from the `[beam]` at every evaluation
//! (`Structure::Beam(..).modal_model()`: the analytic Euler–Bernoulli modes are cheap; a beam
//! with a section loss or a tip mass is a finite-element model, about 100× slower). With the
//! ratio given as `Ω/ω₁`, `Ω` follows `ω₁` if the position changes it (a section loss at the
//! cavity); on a uniform beam it does not.

use super::continuation::{
    bisect_step, class_from, event_between, rephased_offset, BranchEvent, Class,
    ContinuationSettings,
};
use super::modal::{find_modal_orbit, ModalPeriodicOrbit, ModalSection};
use super::{describe, lstsq, scaled_minus_identity, NewtonSettings};
use crate::analysis::grid::Axis;
use crate::error::{ParamError, SimError};
use crate::solver::exact::modal::ModalExact;
use crate::structure::{Beam, ModalSystem, Structure};
use nalgebra::{DMatrix, DVector};

/// `F(y)`, the extended Jacobian, `DP`.
type Eval = (DVector<f64>, DMatrix<f64>, DMatrix<f64>);

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

/// One point of a modal branch.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalBranchPoint {
    /// Parameter value (SI).
    pub param: f64,
    /// The orbit.
    pub orbit: ModalPeriodicOrbit,
    /// The event between the previous point and this one.
    pub event: Option<BranchEvent>,
    /// 0 for the main branch, 1, 2, … for branches switched to at period doublings.
    pub branch: usize,
}

/// A computed modal branch.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalBranch {
    /// The parameter followed.
    pub param: ModalParam,
    /// Points in continuation order.
    pub points: Vec<ModalBranchPoint>,
    /// Why the main branch ended.
    pub stop_reason: String,
    /// Why each branch switched to at a period doubling ended (branch 1, 2, …).
    pub switched: Vec<String>,
}

struct Cont<'a> {
    fam: &'a ModalFamily,
    from: f64,
    to: f64,
    sc: Vec<f64>,
    d: usize,
    periods: u32,
    settings: ContinuationSettings,
}

#[derive(Clone)]
struct Pt {
    y: DVector<f64>,
    sec: ModalSection,
    orbit: ModalPeriodicOrbit,
    tangent: DVector<f64>,
}

impl Cont<'_> {
    fn param(&self, pt: f64) -> f64 {
        self.from + pt * (self.to - self.from)
    }

    fn section(&self, t0: f64, pt: f64) -> Result<ModalSection, SimError> {
        ModalSection::new(self.fam.system_at(self.param(pt))?, t0, self.periods)
    }

    fn x_of(&self, y: &DVector<f64>) -> Vec<f64> {
        (0..self.d).map(|i| y[i] * self.sc[i]).collect()
    }

    /// `F(y)`, the `D × (D+1)` Jacobian in the top rows of a square matrix, and `DP`.
    fn eval(&self, t0: f64, y: &DVector<f64>) -> Result<Eval, SimError> {
        let d = self.d;
        let sec = self.section(t0, y[d])?;
        let x = sec.clamp(&self.x_of(y));
        let (px, dp) = sec.map_and_jacobian(&x)?;
        let f = DVector::from_fn(d + 1, |i, _| {
            if i < d {
                (px[i] - x[i]) / self.sc[i]
            } else {
                0.0
            }
        });
        let a = scaled_minus_identity(&dp, &self.sc);
        let mut j = DMatrix::zeros(d + 1, d + 1);
        j.view_mut((0, 0), (d, d)).copy_from(&a);
        let h = PARAM_STEP;
        let (pa, pb) = (
            self.section(t0, y[d] + h)?.flow(&x)?,
            self.section(t0, y[d] - h)?.flow(&x)?,
        );
        for i in 0..d {
            j[(i, d)] = (pa[i] - pb[i]) / (2.0 * h * self.sc[i]);
        }
        Ok((f, j, dp))
    }

    fn tangent(&self, j: &DMatrix<f64>, prev: &DVector<f64>) -> Option<DVector<f64>> {
        let d = self.d;
        let mut m = j.clone();
        for k in 0..=d {
            m[(d, k)] = prev[k];
        }
        let mut rhs = DVector::zeros(d + 1);
        rhs[d] = 1.0;
        let t = lstsq(&m, &rhs)?;
        let n = t.norm();
        (n.is_finite() && n > 0.0).then(|| t / n)
    }

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
            if it == self.settings.newton.max_iterations || r.is_nan() || r >= 10.0 * last.max(tol)
            {
                return Err(SimError::NoConvergence {
                    what: "the continuation corrector (modal bar)",
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
            let step = lstsq(&j, &rhs).ok_or(SimError::NoConvergence {
                what: "the continuation corrector (modal bar; singular Jacobian)",
                iterations: it,
                residual: r,
                tolerance: tol,
            })?;
            y += step;
            let lg = self
                .fam
                .system_at(self.param(y[d]))?
                .damper
                .map_or(f64::INFINITY, |dm| dm.half_gap_m());
            let iw = d - 2;
            y[iw] = y[iw].clamp(-lg / self.sc[iw], lg / self.sc[iw]);
        }
        unreachable!("the loop returns")
    }

    fn point(
        &self,
        t0: f64,
        y: DVector<f64>,
        j: &DMatrix<f64>,
        dp: DMatrix<f64>,
        prev_t: &DVector<f64>,
    ) -> Result<Pt, SimError> {
        let d = self.d;
        let sec = self.section(t0, y[d])?;
        let x = sec.clamp(&self.x_of(&y));
        let px = sec.flow(&x)?;
        let residual = (0..d)
            .map(|i| ((px[i] - x[i]) / self.sc[i]).abs())
            .fold(0.0, f64::max);
        let orbit = describe(&sec, &x, dp, "variational", residual, 0)?;
        let tangent = self.tangent(j, prev_t).ok_or(SimError::NoConvergence {
            what: "the continuation tangent (modal bar; singular extended Jacobian)",
            iterations: 0,
            residual: f64::NAN,
            tolerance: 0.0,
        })?;
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
        let s = ModalExact::default()
            .run(&p.sec.system, &p.orbit.state, t_new, &mut ())?
            .final_state;
        let tt = p.sec.period_s() / p.sec.periods as f64;
        let t0 = t_new - (t_new / tt).floor() * tt;
        let x = p.sec.to_vector(&s);
        let mut y = p.y.clone();
        for i in 0..self.d {
            y[i] = x[i] / self.sc[i];
        }
        let (_, j, dp) = self.eval(t0, &y)?;
        self.point(t0, y, &j, dp, &p.tangent)
    }
}

/// Check a continuation interval: finite and not empty.
fn check_interval(from: f64, to: f64) -> Result<(), ParamError> {
    crate::params::finite("--from", from)?;
    crate::params::finite("--to", to)?;
    if (to - from).abs() <= 0.0 {
        return Err(ParamError::OutOfRange {
            field: "--to",
            value: to,
            allowed: "a value other than --from (the interval is empty)",
        });
    }
    Ok(())
}

/// Follow the orbit `start` of `fam.base` (a fixed point at the parameter `from`, SI) from
/// `from` to `to` (module docs); with `settings.switch_branches`, the period-doubled branch
/// from each period doubling of the main branch too (points with `branch` 1, 2, …).
pub fn continue_modal_orbit(
    start: &ModalPeriodicOrbit,
    fam: &ModalFamily,
    from: f64,
    to: f64,
    settings: &ContinuationSettings,
) -> Result<ModalBranch, SimError> {
    check_interval(from, to)?;
    crate::limits::check_count(
        "points (--max-points)",
        settings.max_points,
        2,
        super::continuation::MAX_CONTINUATION_POINTS,
        "",
    )?;
    let c = Cont {
        fam,
        from,
        to,
        sc: start.section.scales(),
        d: start.section.dim(),
        periods: start.section.periods,
        settings: *settings,
    };
    let mut out = Vec::new();
    let reason = follow(&c, start, fam.value_of_base()?, 0, &mut out)?;
    let mut switched = Vec::new();
    if settings.switch_branches {
        let pds: Vec<ModalBranchPoint> = out
            .iter()
            .filter(|p| p.event == Some(BranchEvent::PeriodDoubling))
            .cloned()
            .collect();
        for pd in pds {
            let k = switched.len() + 1;
            if let Some(r) = switch_at_doubling(&c, &pd, k, &mut out)? {
                switched.push(r);
            }
        }
    }
    Ok(ModalBranch {
        param: fam.param,
        points: out,
        stop_reason: reason,
        switched,
    })
}

/// Follow one branch from `start` (at the parameter `p0`, SI), appending its points (numbered
/// `branch`); why it ended.
fn follow(
    c: &Cont,
    start: &ModalPeriodicOrbit,
    p0: f64,
    branch: usize,
    out: &mut Vec<ModalBranchPoint>,
) -> Result<String, SimError> {
    let d = c.d;
    let settings = &c.settings;
    let x0 = start.vector();
    let mut y = DVector::zeros(d + 1);
    for i in 0..d {
        y[i] = x0[i] / c.sc[i];
    }
    y[d] = (p0 - c.from) / (c.to - c.from);
    let t0 = start.section.t0_s;
    let (_, j, dp) = c.eval(t0, &y)?;
    let mut e = DVector::zeros(d + 1);
    e[d] = 1.0;
    let first = c.point(t0, y, &j, dp, &e)?;
    let n0 = out.len();
    out.push(ModalBranchPoint {
        param: c.param(first.y[d]),
        orbit: first.orbit.clone(),
        event: None,
        branch,
    });
    let max_points = if branch == 0 {
        settings.max_points
    } else {
        (settings.max_points / 2).max(2)
    };
    let mut cur = c.rephase(first)?;
    let mut h = settings.step_initial;
    let reason = loop {
        if out.len() - n0 >= max_points {
            break format!("{max_points} points reached (--max-points)");
        }
        if cur.orbit.impacts_per_period == 0 && cur.orbit.events.is_empty() {
            break "the orbit has no event left (the ball floats: its position is neutral)".into();
        }
        if h < settings.step_min {
            break format!(
                "step below {:e} at {} = {} (the corrector fails: a nonsmooth point the branch cannot pass)",
                settings.step_min,
                c.fam.param.flag(),
                c.param(cur.y[d])
            );
        }
        let end = if cur.tangent[d] > 0.0 { 1.0 } else { 0.0 };
        let mut hh = h;
        let mut to_end = false;
        if cur.tangent[d].abs() > 1e-3 && (end - cur.y[d]) / cur.tangent[d] < hh {
            hh = (end - cur.y[d]) / cur.tangent[d];
            to_end = true;
        }
        let next = match step(c, &cur, hh, to_end.then_some(end)) {
            Ok(p) => p,
            Err(_) => {
                h *= 0.5;
                continue;
            }
        };
        if next.tangent.dot(&cur.tangent) < 0.3f64.cos() && hh > 4.0 * settings.step_min {
            h = hh * 0.5;
            continue;
        }
        let (ca, cb) = (class_of(&cur.orbit), class_of(&next.orbit));
        let ev = event_between(&ca, &cb, cur.tangent[d], next.tangent[d]);
        // As on the lumped bar: the event's row is the located first point past it, and the
        // branch goes on from the full step's point.
        let mut next_event = ev;
        if let (Some(e), true) = (ev, settings.locate) {
            let located = bisect_step(
                hh,
                &ca,
                |mid| step(c, &cur, mid, None).ok(),
                |p| class_of(&p.orbit),
            );
            if let Some(l) = located {
                let cl = class_of(&l.orbit);
                let e = event_between(&ca, &cl, cur.tangent[d], next.tangent[d]).unwrap_or(e);
                if (&l.y - &next.y).amax() > 1e-12 {
                    out.push(ModalBranchPoint {
                        param: c.param(l.y[d]),
                        orbit: l.orbit,
                        event: Some(e),
                        branch,
                    });
                    next_event = None;
                } else {
                    next_event = Some(e);
                }
            }
        }
        out.push(ModalBranchPoint {
            param: c.param(next.y[d]),
            orbit: next.orbit.clone(),
            event: next_event,
            branch,
        });
        cur = c.rephase(next)?;
        if to_end {
            break "end of the interval reached".into();
        }
        if cur.y[d] < -0.02 || cur.y[d] > 1.02 {
            break "the branch left the interval".into();
        }
        h = (h * 1.3).min(settings.step_max);
    };
    Ok(reason)
}

fn class_of(o: &ModalPeriodicOrbit) -> Class {
    class_from(&o.multipliers, &o.sequence)
}

/// One predictor–corrector step of length `h` from `cur`; `pin` fixes `p̃` (the interval's end).
fn step(c: &Cont, cur: &Pt, h: f64, pin: Option<f64>) -> Result<Pt, SimError> {
    let d = c.d;
    let t0 = cur.sec.t0_s;
    let y_pred = &cur.y + &cur.tangent * h;
    let (y, j, dp) = match pin {
        None => c.correct(t0, &y_pred, &cur.tangent)?,
        Some(p) => {
            let mut e = DVector::zeros(d + 1);
            e[d] = 1.0;
            let mut yp = y_pred;
            yp[d] = p;
            c.correct(t0, &yp, &e)?
        }
    };
    c.point(t0, y, &j, dp, &cur.tangent)
}

/// The lumped bar's switch (`continuation::switch_at_doubling`) on the modal bar: Newton for a
/// period-2k orbit next to the period doubling `pd`, from its orbit displaced along the
/// eigenvector of the multiplier closest to −1, on each side; the first genuine one (not the
/// period-k orbit seen twice) is followed to the interval's end on its side.
fn switch_at_doubling(
    c: &Cont,
    pd: &ModalBranchPoint,
    branch: usize,
    out: &mut Vec<ModalBranchPoint>,
) -> Result<Option<String>, SimError> {
    let o = &pd.orbit;
    let dd = c.d;
    // The smallest singular vector of S⁻¹DPS + I (scaled coordinates).
    let mut a = scaled_minus_identity(&o.jacobian, &c.sc);
    for i in 0..dd {
        a[(i, i)] += 2.0;
    }
    let svd = a.svd(false, true);
    let Some(vt) = svd.v_t else {
        return Ok(None);
    };
    let (imin, _) = svd.singular_values.argmin();
    let pt = (pd.param - c.from) / (c.to - c.from);
    let x = o.vector();
    for side in [1.0, -1.0] {
        for (dp, eps) in [(2e-3, 0.05), (5e-3, 0.1), (1e-3, 0.02)] {
            let q = pt + side * dp;
            let Ok(sys) = c.fam.system_at(c.param(q)) else {
                continue;
            };
            let Ok(sec) = ModalSection::new(sys, o.section.t0_s, 2 * c.periods) else {
                continue;
            };
            let guess: Vec<f64> = (0..dd)
                .map(|k| x[k] + eps * vt[(imin, k)] * c.sc[k])
                .collect();
            let Ok(orb) = find_modal_orbit(&sec, &guess, &NewtonSettings::default()) else {
                continue;
            };
            let half = ModalSection {
                periods: c.periods,
                ..sec.clone()
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
                    switch_branches: false,
                    ..c.settings
                },
                sc: c.sc.clone(),
                ..*c
            };
            if (sub.to - sub.from).abs() <= 0.0 {
                continue;
            }
            let r = follow(&sub, &orb, sub.from, branch, out)?;
            return Ok(Some(format!(
                "period-{} branch from the period doubling at {}: {r}",
                2 * c.periods,
                pd.param
            )));
        }
    }
    Ok(None)
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
