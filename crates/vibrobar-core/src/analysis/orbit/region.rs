//! The stability region of the symmetric two-impact orbit over ratio × gap: at each ratio, the
//! symmetric orbit at a grid of gaps (Newton from the analytic orbit of the frictionless bar, so
//! it works with friction too), and the interval of gaps where it is stable, its ends located by
//! continuation ([`super::continuation`]) with the bifurcation type at each end.

use super::continuation::{continue_orbit, BranchEvent, ContinuationSettings};
use super::{
    find_orbit, starting_guess, symmetric_orbits, MapJacobian, NewtonSettings, PeriodicOrbit, Start,
};
use crate::analysis::grid::Axis;
use crate::error::SimError;
use crate::params::{FrictionModel, System};

/// The symmetric orbit of `sys` with the smallest largest multiplier (`None` when no analytic
/// orbit of the frictionless system exists or Newton finds none near it).
pub fn symmetric_orbit_at(sys: &System, jac: &dyn MapJacobian) -> Option<PeriodicOrbit> {
    let mut frictionless = *sys;
    frictionless.damper.as_mut()?.friction = FrictionModel::None;
    let n = symmetric_orbits(&frictionless).ok()?.len();
    (0..n)
        .filter_map(|i| {
            let (sec, x0) = starting_guess(sys, 1, &Start::Symmetric(i)).ok()?;
            let o = find_orbit(&sec, &x0, jac, &NewtonSettings::default()).ok()?;
            // The symmetric orbit only (Newton may slide to another one from a poor guess).
            (o.impacts_per_period == 2 && o.symmetry_defect().ok()?? < 1e-6).then_some(o)
        })
        .min_by(|a, b| a.max_abs_multiplier().total_cmp(&b.max_abs_multiplier()))
}

/// One end of a stability interval.
#[derive(Debug, Clone, PartialEq)]
pub struct IntervalEnd {
    /// Gap at the end, m.
    pub gap_m: f64,
    /// What happens there (`None`: the orbit is still stable at the end of the searched range,
    /// or the branch ended without an event).
    pub event: Option<BranchEvent>,
    /// The continuation's own account (why the branch ended, when it did).
    pub note: String,
}

/// The gaps where the symmetric orbit is stable at one ratio, found from `seed_gap_m`.
#[derive(Debug, Clone, PartialEq)]
pub struct StabilityInterval {
    /// Lower end.
    pub lo: IntervalEnd,
    /// Upper end.
    pub hi: IntervalEnd,
}

/// The stability interval in the gap of the symmetric orbit of `sys` (its gap is ignored)
/// containing `seed_gap_m`, searched within `[gap_min_m, gap_max_m]`. `None` when the orbit at
/// the seed is not stable.
pub fn stability_interval(
    sys: &System,
    seed_gap_m: f64,
    gap_min_m: f64,
    gap_max_m: f64,
    jac: &dyn MapJacobian,
) -> Result<Option<StabilityInterval>, SimError> {
    let mut s = *sys;
    Axis::GapM.apply(&mut s, seed_gap_m)?;
    let Some(start) = symmetric_orbit_at(&s, jac) else {
        return Ok(None);
    };
    if !start.stable() {
        return Ok(None);
    }
    let settings = ContinuationSettings {
        max_points: 3000,
        switch_branches: false,
        ..Default::default()
    };
    let end = |to: f64| -> Result<IntervalEnd, SimError> {
        let b = continue_orbit(&start, Axis::GapM, seed_gap_m, to, jac, &settings)?;
        let first_unstable = b.points.iter().find(|p| !p.orbit.stable());
        Ok(match first_unstable {
            Some(p) => IntervalEnd {
                gap_m: p.param,
                event: p.event,
                note: String::new(),
            },
            None => {
                let last = b.points.last().map_or(seed_gap_m, |p| p.param);
                IntervalEnd {
                    gap_m: last,
                    event: b.points.last().and_then(|p| p.event),
                    note: b.stop_reasons.first().cloned().unwrap_or_default(),
                }
            }
        })
    };
    Ok(Some(StabilityInterval {
        lo: end(gap_min_m)?,
        hi: end(gap_max_m)?,
    }))
}
