//! Robustness to initial conditions: a seeded ensemble of initial states at each grid point.
//!
//! Member `i` draws its initial state from a [`SplitMix64`] seeded with `seed` and `i`
//! ([`EnsembleParams::initial_state`]), so
//! * the same seed gives the same ensemble, on any machine and for any thread count;
//! * every grid point sees the same members (common random numbers: differences between points
//!   are not sampling noise). The ball position is drawn as a fraction of `l_g`, so it stays
//!   inside the cavity whatever the gap of the point.
//!
//! Per point, the statistics are reduced in member order after all runs finished, so the result
//! is bit-identical for any thread count.

use super::batch::{BatchError, Runner};
use super::grid::GridPoint;
use super::map::{compute_point_from, MapSpec};
use super::regime::Regime;
use crate::error::{ParamError, SimError};
use crate::params::State;
use crate::solver::Solver;

/// SplitMix64 (Steele, Lea & Flood 2014): a small, fast, well-mixed 64-bit generator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    /// Generator with the given seed.
    pub fn new(seed: u64) -> Self {
        SplitMix64 { state: seed }
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)` with 53 random bits.
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[lo, hi)` (`lo` when `lo == hi`).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }
}

/// Ranges `[lo, hi]` of the random initial conditions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IcRanges {
    /// Bar displacement `u`.
    pub u_m: (f64, f64),
    /// Bar velocity `u̇`.
    pub du_m_s: (f64, f64),
    /// Ball position in the cavity, `w / l_g`, within `[−1, 1]`.
    pub w_over_half_gap: (f64, f64),
    /// Relative velocity `ẇ`.
    pub dw_m_s: (f64, f64),
}

/// Ensemble settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnsembleParams {
    /// Seed; the whole ensemble follows from it.
    pub seed: u64,
    /// Members per point.
    pub members: usize,
    /// Ranges of the initial conditions.
    pub ranges: IcRanges,
}

impl EnsembleParams {
    /// Check the fields.
    pub fn validate(&self) -> Result<(), ParamError> {
        if self.members == 0 {
            return Err(ParamError::OutOfRange {
                field: "ensemble.members",
                value: 0.0,
                allowed: "[1, ∞)",
            });
        }
        crate::limits::check_count(
            "ensemble.members (--members, --ensemble-members)",
            self.members,
            1,
            crate::limits::MAX_ENSEMBLE_MEMBERS,
            "",
        )?;
        let r = &self.ranges;
        for (field, (lo, hi)) in [
            ("ensemble.u_m", r.u_m),
            ("ensemble.du_m_s", r.du_m_s),
            ("ensemble.w_over_half_gap", r.w_over_half_gap),
            ("ensemble.dw_m_s", r.dw_m_s),
        ] {
            crate::params::finite(field, lo)?;
            crate::params::finite(field, hi)?;
            if lo > hi {
                return Err(ParamError::OutOfRange {
                    field,
                    value: lo,
                    allowed: "lower bound ≤ upper bound",
                });
            }
        }
        let (lo, hi) = r.w_over_half_gap;
        for v in [lo, hi] {
            crate::params::in_range("ensemble.w_over_half_gap", v, -1.0, 1.0, "[-1, 1]")?;
        }
        Ok(())
    }

    /// Initial state of member `i` (at `t = 0`) in a cavity of half gap `half_gap_m`.
    pub fn initial_state(&self, i: usize, half_gap_m: f64) -> State {
        // Members get decorrelated streams: the member number goes through one SplitMix64 step.
        let mut g = SplitMix64::new(
            SplitMix64::new(self.seed ^ (i as u64).wrapping_mul(0xD1B5_4A32_D192_ED03)).next_u64(),
        );
        let r = &self.ranges;
        let u = g.uniform(r.u_m.0, r.u_m.1);
        let du = g.uniform(r.du_m_s.0, r.du_m_s.1);
        let w = g.uniform(r.w_over_half_gap.0, r.w_over_half_gap.1) * half_gap_m;
        let dw = g.uniform(r.dw_m_s.0, r.dw_m_s.1);
        State {
            t_s: 0.0,
            u_m: u,
            du_m_s: du,
            v_m: u + w,
            dv_m_s: du + dw,
            cavity: None,
        }
    }
}

/// Statistics of one grid point over the ensemble.
#[derive(Debug, Clone, PartialEq)]
pub struct EnsembleStats {
    /// The point.
    pub point: GridPoint,
    /// Members.
    pub members: usize,
    /// Mean damped RMS.
    pub mean_rms_m: f64,
    /// Sample standard deviation of the damped RMS (0 for one member).
    pub std_rms_m: f64,
    /// Smallest damped RMS.
    pub min_rms_m: f64,
    /// Largest damped RMS.
    pub max_rms_m: f64,
    /// How many members ended in each regime, sorted by regime.
    pub regimes: Vec<(Regime, usize)>,
    /// Members with at least one impact inside the RMS window (the steady state). Impacts
    /// before the window are not counted: a ball started with a relative velocity in a narrow
    /// cavity hits a wall within the first milliseconds, so a whole-run count would say nothing
    /// about the steady state.
    pub impacting_members: usize,
}

/// Run the ensemble at each point (damped bar only) through the batch runner ([`Runner::each`]).
pub fn run_ensemble(
    spec: &MapSpec,
    solver: &dyn Solver,
    points: &[GridPoint],
    params: &EnsembleParams,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<EnsembleStats>, BatchError<SimError>> {
    params.validate().map_err(BatchError::Param)?;
    let m = params.members;
    crate::limits::check(
        "ensemble runs (points × members)",
        points.len() as f64 * m as f64,
        0.0,
        crate::limits::MAX_RUNS as f64,
        "fewer points or members",
    )?;
    let jobs: Vec<(usize, usize)> = (0..points.len())
        .flat_map(|p| (0..m).map(move |i| (p, i)))
        .collect();
    let runner = Runner::default().with_progress(progress);
    let results = runner.each(&jobs, |&(p, i)| {
        let pt = &points[p];
        let lg = spec
            .damped_system(pt)?
            .damper
            .map_or(0.0, |d| d.half_gap_m());
        let init = params.initial_state(i, lg);
        compute_point_from(spec, solver, pt, &init, f64::NAN)
            .map(|r| (r.rms_damped_m, r.regime, r.impacts_per_cycle > 0.0))
    })?;
    Ok(points
        .iter()
        .zip(results.chunks(m))
        .map(|(pt, rs)| {
            let n = rs.len() as f64;
            let mean = rs.iter().map(|r| r.0).sum::<f64>() / n;
            let std = if rs.len() > 1 {
                (rs.iter().map(|r| (r.0 - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
            } else {
                0.0
            };
            let mut counts = std::collections::BTreeMap::new();
            for r in rs {
                *counts.entry(r.1).or_insert(0usize) += 1;
            }
            EnsembleStats {
                point: pt.clone(),
                members: rs.len(),
                mean_rms_m: mean,
                std_rms_m: std,
                min_rms_m: rs.iter().map(|r| r.0).fold(f64::INFINITY, f64::min),
                max_rms_m: rs.iter().map(|r| r.0).fold(f64::NEG_INFINITY, f64::max),
                regimes: counts.into_iter().collect(),
                impacting_members: rs.iter().filter(|r| r.2).count(),
            }
        })
        .collect())
}
