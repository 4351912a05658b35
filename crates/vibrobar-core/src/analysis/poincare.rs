//! Poincaré sections and bifurcation data.
//!
//! * [`Stroboscope`]: the state at `t_k = (φ + 2πk)/Ω`, i.e. once per forcing period at a fixed
//!   forcing phase `φ` (the forcing is `F_s + F0 sin(Ωt)`, so its phase at `t` is `Ωt`), from a
//!   given time on. Segments are evaluated only at those instants, like [`super::Sampler`].
//! * [`ImpactSection`]: the state at each impact (on one wall or both), from the events.
//! * [`bifurcation`]: for each value of a swept parameter, the stroboscopic points after the
//!   transient and the impact velocities, as rows `(param, …)`.

use super::batch::{BatchError, Runner};
use super::grid::Axis;
use crate::error::{ParamError, SimError};
use crate::params::{State, System};
use crate::solver::{Event, EventKind, Fanout, Observer, Segment, Solver, Wall};
use std::f64::consts::TAU;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Stroboscopic (period-`T`) Poincaré section at a fixed forcing phase.
#[derive(Debug, Clone, PartialEq)]
pub struct Stroboscope {
    period_s: f64,
    offset_s: f64,
    until_s: f64,
    next_k: i64,
    /// Sampled states, in time order.
    pub points: Vec<State>,
}

impl Stroboscope {
    /// Sample at `t_k = φ/Ω + k·T` (`T = 2π/Ω`) for every `k` with `after_s ≤ t_k ≤ until_s`.
    /// `phase_rad` is taken modulo 2π. Each `t_k` is computed from `k` (no accumulated drift).
    pub fn new(period_s: f64, phase_rad: f64, after_s: f64, until_s: f64) -> Self {
        let offset_s = phase_rad.rem_euclid(TAU) / TAU * period_s;
        let mut k = ((after_s - offset_s) / period_s).ceil() as i64;
        // Rounding of the division can land one period early or late: fix it from the times.
        while offset_s + (k as f64) * period_s < after_s {
            k += 1;
        }
        while k > i64::MIN && offset_s + ((k - 1) as f64) * period_s >= after_s {
            k -= 1;
        }
        Stroboscope {
            period_s,
            offset_s,
            until_s,
            next_k: k,
            points: Vec::new(),
        }
    }

    /// The section of `sys` (its forcing period) at phase `phase_rad`, for `t ≥ after_s`.
    pub fn for_system(sys: &System, phase_rad: f64, after_s: f64) -> Self {
        Self::new(sys.forcing_period_s(), phase_rad, after_s, f64::INFINITY)
    }

    /// Time of the next sample.
    pub fn next_t_s(&self) -> f64 {
        self.offset_s + self.next_k as f64 * self.period_s
    }
}

impl Observer for Stroboscope {
    fn segment(&mut self, seg: &dyn Segment) {
        // A sample exactly at an event time belongs to the segment that ends there (pre-event),
        // as in `Sampler`.
        loop {
            let t = self.next_t_s();
            if t > seg.t_end_s() || t > self.until_s {
                break;
            }
            if t >= seg.t_start_s() {
                self.points.push(seg.state_at(t));
            }
            self.next_k += 1;
        }
    }
}

/// The state at one impact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpactPoint {
    /// Impact time.
    pub t_s: f64,
    /// Wall hit.
    pub wall: Wall,
    /// Forcing phase `Ωt mod 2π` at the impact, in `[0, 2π)`.
    pub phase_rad: f64,
    /// Pre-impact relative velocity `ẇ−`.
    pub dw_m_s: f64,
    /// State just before the impact.
    pub before: State,
    /// State just after.
    pub after: State,
}

/// Impact-map section: the state at each impact on the chosen wall (`None`: both walls) at
/// `t ≥ after_s`.
#[derive(Debug, Clone, PartialEq)]
pub struct ImpactSection {
    wall: Option<Wall>,
    after_s: f64,
    omega_rad_s: f64,
    /// Impacts, in time order.
    pub points: Vec<ImpactPoint>,
}

impl ImpactSection {
    /// Collect impacts of `sys` on `wall` (`None`: both) from `after_s` on.
    pub fn new(sys: &System, wall: Option<Wall>, after_s: f64) -> Self {
        ImpactSection {
            wall,
            after_s,
            omega_rad_s: sys.omega_rad_s(),
            points: Vec::new(),
        }
    }
}

impl Observer for ImpactSection {
    fn event(&mut self, ev: &Event) {
        if let EventKind::Impact { wall, dw_m_s, .. } = ev.kind {
            let on_wall = match self.wall {
                Some(w) => w == wall,
                None => true,
            };
            if ev.t_s >= self.after_s && on_wall {
                self.points.push(ImpactPoint {
                    t_s: ev.t_s,
                    wall,
                    phase_rad: (self.omega_rad_s * ev.t_s).rem_euclid(TAU),
                    dw_m_s,
                    before: ev.before,
                    after: ev.after,
                });
            }
        }
    }
}

/// What a bifurcation run does at each parameter value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BifurcationSpec {
    /// The system; the swept [`Axis`] overrides one of its fields.
    pub system: System,
    /// Swept parameter.
    pub axis: Axis,
    /// Initial state of every run.
    pub init: State,
    /// Simulated time of each run (from `init.t_s`).
    pub duration_s: f64,
    /// Points before `init.t_s + transient_s` are discarded.
    pub transient_s: f64,
    /// Forcing phase of the stroboscopic section.
    pub phase_rad: f64,
    /// Also collect impacts on this wall (`None`: both walls).
    pub impact_wall: Option<Wall>,
}

/// One stroboscopic point of a bifurcation diagram.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BifurcationPoint {
    /// Parameter value.
    pub param: f64,
    /// Time of the point.
    pub t_s: f64,
    /// Bar displacement.
    pub u_m: f64,
    /// Bar velocity.
    pub du_m_s: f64,
}

/// One impact of a bifurcation diagram.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BifurcationImpact {
    /// Parameter value.
    pub param: f64,
    /// Impact time.
    pub t_s: f64,
    /// Wall.
    pub wall: Wall,
    /// Pre-impact relative velocity `ẇ−`.
    pub dw_m_s: f64,
}

/// Bifurcation data: rows in parameter order, then time order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Bifurcation {
    /// Stroboscopic points `(param, u)` after the transient.
    pub points: Vec<BifurcationPoint>,
    /// Impacts after the transient.
    pub impacts: Vec<BifurcationImpact>,
}

/// Impacts of one bifurcation run after the transient, counted against a budget shared by all
/// runs: past it nothing more is stored and the batch is cancelled (runs not yet started are
/// skipped), so memory stays bounded whatever the impact rate (rk4 in wall contact counts one
/// impact per step).
struct BudgetedImpacts<'a> {
    param: f64,
    wall: Option<Wall>,
    after_s: f64,
    used: &'a AtomicUsize,
    budget: usize,
    over: &'a AtomicBool,
    kept: Vec<BifurcationImpact>,
}

impl Observer for BudgetedImpacts<'_> {
    fn event(&mut self, ev: &Event) {
        if let EventKind::Impact { wall, dw_m_s, .. } = ev.kind {
            if ev.t_s < self.after_s || self.wall.is_some_and(|w| w != wall) {
                return;
            }
            if self.used.fetch_add(1, Ordering::Relaxed) >= self.budget {
                self.over.store(true, Ordering::Relaxed);
                return;
            }
            self.kept.push(BifurcationImpact {
                param: self.param,
                t_s: ev.t_s,
                wall,
                dw_m_s,
            });
        }
    }
}

/// For each value of `spec.axis`, run `spec.system` and collect the stroboscopic points and
/// impacts after the transient. Runs are independent and in parallel through the batch runner
/// ([`Runner::each`]); the result does not depend on the thread count. At most
/// [`crate::limits::MAX_SAMPLES`] stroboscopic points (checked before any run) and as many
/// impacts (over all values; more is an error) are kept.
pub fn bifurcation(
    spec: &BifurcationSpec,
    values: &[f64],
    solver: &dyn Solver,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Bifurcation, BatchError<SimError>> {
    bifurcation_with_budget(
        spec,
        values,
        solver,
        progress,
        crate::limits::MAX_SAMPLES as usize,
    )
}

fn bifurcation_with_budget(
    spec: &BifurcationSpec,
    values: &[f64],
    solver: &dyn Solver,
    progress: &(dyn Fn(usize, usize) + Sync),
    impact_budget: usize,
) -> Result<Bifurcation, BatchError<SimError>> {
    crate::params::positive("duration_s", spec.duration_s)?;
    crate::params::non_negative("transient_s", spec.transient_s)?;
    crate::params::finite("phase_rad", spec.phase_rad)?;
    if spec.transient_s >= spec.duration_s {
        return Err(ParamError::OutOfRange {
            field: "transient_s",
            value: spec.transient_s,
            allowed: "[0, duration_s)",
        }
        .into());
    }
    // Every stroboscopic point is kept: bound their number before any run.
    let mut points = 0.0;
    for &p in values {
        let mut sys = spec.system;
        spec.axis.apply(&mut sys, p)?;
        points += (spec.duration_s - spec.transient_s) / sys.forcing_period_s() + 1.0;
    }
    crate::limits::check(
        "stroboscopic points (values × forcing periods after the transient)",
        points,
        0.0,
        crate::limits::MAX_SAMPLES,
        "fewer values or a shorter run",
    )?;
    let used = AtomicUsize::new(0);
    let over = AtomicBool::new(false);
    let per_value = Runner::default()
        .with_progress(progress)
        .with_cancel(&over)
        .each(
            values,
            |&p| -> Result<(Vec<State>, Vec<BifurcationImpact>), SimError> {
                let mut sys = spec.system;
                spec.axis.apply(&mut sys, p)?;
                let t0 = spec.init.t_s;
                let after = t0 + spec.transient_s;
                let mut strobe = Stroboscope::for_system(&sys, spec.phase_rad, after);
                let mut imp = BudgetedImpacts {
                    param: p,
                    wall: spec.impact_wall,
                    after_s: after,
                    used: &used,
                    budget: impact_budget,
                    over: &over,
                    kept: Vec::new(),
                };
                {
                    let mut obs: [&mut dyn Observer; 2] = [&mut strobe, &mut imp];
                    solver.run(
                        &sys,
                        &spec.init,
                        t0 + spec.duration_s,
                        &mut Fanout(&mut obs),
                    )?;
                }
                Ok((strobe.points, imp.kept))
            },
        );
    // The budget is a total over every run, so whether it is exceeded does not depend on the
    // thread count.
    if over.load(Ordering::Relaxed) {
        return Err(ParamError::Limit {
            field: "impacts after the transient, over all values (bifurcation)",
            value: used.load(Ordering::Relaxed) as f64,
            min: 0.0,
            max: impact_budget as f64,
            why: "counted until the runs were stopped; use fewer values, a longer transient or a shorter run (rk4 in wall contact counts an impact per step: --solver exact)",
        }
        .into());
    }
    let per_value = per_value?;
    let mut out = Bifurcation::default();
    for (&p, (pts, imps)) in values.iter().zip(per_value) {
        out.points.extend(pts.iter().map(|s| BifurcationPoint {
            param: p,
            t_s: s.t_s,
            u_m: s.u_m,
            du_m_s: s.du_m_s,
        }));
        out.impacts.extend(imps);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::{SweepBase, SweepPoint};
    use crate::params::FrictionModel;
    use crate::solver::Exact;

    fn spec() -> BifurcationSpec {
        BifurcationSpec {
            system: SweepBase::paper().damped_system(&SweepPoint {
                ratio: 1.0,
                gap_m: 1e-4,
                friction: FrictionModel::None,
                friction_force_n: None,
            }),
            axis: Axis::FreqRatio,
            init: State::REST,
            duration_s: 0.1,
            transient_s: 0.02,
            phase_rad: 0.0,
            impact_wall: None,
        }
    }

    /// The impacts of a bifurcation diagram were collected without any bound (rk4 in wall
    /// contact counts one per step): they are now counted against a total budget.
    #[test]
    fn regression_bifurcation_impacts_are_bounded_with_a_clear_error() {
        let values = [0.99, 1.0, 1.01];
        let s = spec();
        let all = bifurcation(&s, &values, &Exact::default(), &|_, _| {}).unwrap();
        let n = all.impacts.len();
        assert!(n > 20, "{n} impacts");
        // The budget changes nothing below it: same impacts as an unbounded section.
        let mut sys = s.system;
        sys.forcing.frequency = crate::params::Frequency::Ratio(0.99);
        let mut sec = ImpactSection::new(&sys, None, s.transient_s);
        Exact::default()
            .run(&sys, &s.init, s.duration_s, &mut sec)
            .unwrap();
        let first: Vec<f64> = all
            .impacts
            .iter()
            .filter(|i| i.param < 0.995)
            .map(|i| i.t_s)
            .collect();
        assert_eq!(first, sec.points.iter().map(|p| p.t_s).collect::<Vec<_>>());
        let exact = bifurcation_with_budget(&s, &values, &Exact::default(), &|_, _| {}, n);
        assert_eq!(exact.unwrap().impacts.len(), n);
        let e = bifurcation_with_budget(&s, &values, &Exact::default(), &|_, _| {}, n - 1)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("impacts after the transient") && e.contains(&format!(", {}]", n - 1)),
            "{e}"
        );
    }
}
