//! Design maps: a grid of frequency ratio × gap (and optionally friction level, restitution, mass
//! ratio), the damped and solid RMS at each point, the impact regime, and the optimum. The grid
//! (index, shards) is [`super::grid`]; the runs go through the batch runner [`Batch`].

use super::batch::{Batch, BatchError, Runner, SweepBase, SweepPoint};
use super::case::run_case;
use super::regime::{classify, Regime, RegimeObserver, Tolerances};
use crate::error::{ParamError, SimError};
use crate::params::{Frequency, FrictionModel, RunSettings, State, System};
use crate::solver::Solver;
use std::collections::BTreeMap;

pub use super::batch::SolidRatios;
pub use super::grid::{Axis, Grid, GridAxis, GridPoint};

/// Everything fixed across a map (serialisable, for typed metadata).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapSpec {
    /// Bars, ball template and forcing; grid axes override fields.
    pub base: SweepBase,
    /// Friction model of the damped bar.
    pub friction: FrictionModel,
    /// Duration, step and RMS window of every run.
    pub settings: RunSettings,
    /// Regime classification tolerances.
    pub tolerances: Tolerances,
}

impl MapSpec {
    /// Ratio of a point (the base forcing's ratio when the grid has no ratio axis).
    pub fn ratio(&self, p: &GridPoint) -> f64 {
        p.get(Axis::FreqRatio)
            .unwrap_or(match self.base.forcing.frequency {
                Frequency::Ratio(r) => r,
                Frequency::RadPerS(w) => w / self.base.damped_bar.omega1_rad_s(),
            })
    }

    /// The damped system at a point.
    pub fn damped_system(&self, p: &GridPoint) -> Result<System, ParamError> {
        let mut sys = self.base.damped_system(&SweepPoint {
            ratio: self.ratio(p),
            gap_m: self.base.ball.gap_m,
            friction: self.friction,
            friction_force_n: self.base.ball.friction_force_n,
        });
        for &(a, v) in &p.coords {
            a.apply(&mut sys, v)?;
        }
        Ok(sys)
    }

    /// The solid bar at a ratio (only the ratio matters for the bar without ball).
    pub fn solid_system(&self, ratio: f64) -> System {
        self.base.solid_system(ratio)
    }

    /// A batch of this map's runs with `solver` (global pool, no cancellation, no progress).
    pub fn batch<'a>(&'a self, solver: &'a dyn Solver) -> Batch<'a> {
        Batch::new(&self.base, &self.settings, solver)
    }
}

/// One computed point of a map.
#[derive(Debug, Clone, PartialEq)]
pub struct MapRow {
    /// The point.
    pub point: GridPoint,
    /// Frequency ratio.
    pub ratio: f64,
    /// Gap of the damped bar.
    pub gap_m: f64,
    /// RMS of the solid bar at this ratio.
    pub rms_solid_m: f64,
    /// RMS of the damped bar.
    pub rms_damped_m: f64,
    /// `100·(1 − rms_damped/rms_solid)`.
    pub reduction_pct: f64,
    /// Impacts per forcing cycle in the RMS window.
    pub impacts_per_cycle: f64,
    /// Steady-state regime over the RMS window.
    pub regime: Regime,
}

/// RMS of the solid bar at `ratio`, from the base's initial state (as [`Batch::solid`]).
pub fn compute_solid(spec: &MapSpec, solver: &dyn Solver, ratio: f64) -> Result<f64, SimError> {
    Ok(spec.batch(solver).solid(ratio)?.rms_m)
}

/// The damped run at a point from `init`, given the solid RMS at its ratio.
pub fn compute_point_from(
    spec: &MapSpec,
    solver: &dyn Solver,
    p: &GridPoint,
    init: &State,
    rms_solid_m: f64,
) -> Result<MapRow, SimError> {
    let sys = spec.damped_system(p)?;
    if !rms_solid_m.is_nan() {
        // NaN means "no reference" (ensembles); 0 would make every reduction 0/0.
        crate::limits::reference_rms(rms_solid_m)?;
    }
    let t_end = init.t_s + spec.settings.duration_s;
    let mut reg = RegimeObserver::new(&sys, init.t_s + spec.settings.window_start_s(), t_end);
    let r = run_case(&sys, init, &spec.settings, solver, &mut reg)?;
    let regime = classify(&reg.finish(), &spec.tolerances);
    Ok(MapRow {
        point: p.clone(),
        ratio: spec.ratio(p),
        gap_m: sys.damper.map_or(0.0, |d| d.gap_m),
        rms_solid_m,
        rms_damped_m: r.rms_m,
        reduction_pct: 100.0 * (1.0 - r.rms_m / rms_solid_m),
        impacts_per_cycle: r.impacts_per_cycle,
        regime,
    })
}

/// One point, solid and damped runs, both from the base's initial state (a whole map shares the
/// solid runs instead: [`run_map`]).
pub fn compute_point(
    spec: &MapSpec,
    solver: &dyn Solver,
    p: &GridPoint,
) -> Result<MapRow, SimError> {
    let solid = compute_solid(spec, solver, spec.ratio(p))?;
    compute_point_from(spec, solver, p, &spec.base.init, solid)
}

/// Compute `points` through the batch runner (solid runs shared per ratio, in parallel). Rows
/// come back in the order of `points`; results do not depend on the thread count.
pub fn run_map(
    spec: &MapSpec,
    solver: &dyn Solver,
    points: &[GridPoint],
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<MapRow>, BatchError<SimError>> {
    let batch = spec
        .batch(solver)
        .on(Runner::default().with_progress(progress));
    batch.run(
        points,
        |p| spec.ratio(p),
        |p, solid| compute_point_from(spec, solver, p, &spec.base.init, solid.rms_m),
    )
}

/// The best design over the whole band of ratios.
#[derive(Debug, Clone, PartialEq)]
pub struct BandBest {
    /// The design: every coordinate except the ratio.
    pub design: Vec<(Axis, f64)>,
    /// Mean of `reduction_pct` over the ratios.
    pub mean_reduction_pct: f64,
    /// Largest damped RMS over the ratios.
    pub max_rms_damped_m: f64,
    /// Ratios covered.
    pub ratios: usize,
}

/// Optimum of a map.
#[derive(Debug, Clone, PartialEq)]
pub struct Optimum {
    /// For each ratio (ascending), the row with the largest `reduction_pct`.
    pub per_ratio: Vec<MapRow>,
    /// The design with the largest mean reduction over the band.
    pub best_mean_reduction: Option<BandBest>,
    /// The design with the smallest largest damped RMS over the band (minimax).
    pub best_minimax_rms: Option<BandBest>,
}

/// Best design per ratio and over the band.
///
/// * Per ratio: the largest `reduction_pct`; ties go to the smaller grid index.
/// * Over the band, a design (all coordinates except the ratio; for a ratio × gap map, a gap) is
///   a candidate only if it has a row at every ratio present in `rows`. Two criteria:
///   largest mean `reduction_pct`, and smallest maximum `rms_damped_m` (robust: it bounds the
///   worst vibration in the band). Ties go to the design met first in index order.
///
/// Rows with a NaN reduction or RMS are ignored. The result does not depend on the row order.
pub fn optimum(rows: &[MapRow]) -> Optimum {
    let mut rows: Vec<&MapRow> = rows
        .iter()
        .filter(|r| !r.reduction_pct.is_nan() && !r.rms_damped_m.is_nan())
        .collect();
    rows.sort_by_key(|r| r.point.index);
    let key = |x: f64| x.to_bits();
    let mut per_ratio: BTreeMap<u64, &MapRow> = BTreeMap::new();
    let mut ratio_order: Vec<f64> = Vec::new();
    for r in &rows {
        match per_ratio.get(&key(r.ratio)) {
            Some(b) if b.reduction_pct >= r.reduction_pct => {}
            _ => {
                if !per_ratio.contains_key(&key(r.ratio)) {
                    ratio_order.push(r.ratio);
                }
                per_ratio.insert(key(r.ratio), r);
            }
        }
    }
    ratio_order.sort_by(f64::total_cmp);
    let per_ratio_rows: Vec<MapRow> = ratio_order
        .iter()
        .map(|r| per_ratio[&key(*r)].clone())
        .collect();

    // Designs in order of first appearance (index order).
    type Design = Vec<(Axis, f64)>;
    let mut designs: Vec<(Design, Vec<&MapRow>)> = Vec::new();
    for r in &rows {
        let d: Design = r
            .point
            .coords
            .iter()
            .copied()
            .filter(|(a, _)| *a != Axis::FreqRatio)
            .collect();
        let same = |x: &Design| {
            x.len() == d.len()
                && x.iter()
                    .zip(&d)
                    .all(|(p, q)| p.0 == q.0 && p.1.total_cmp(&q.1).is_eq())
        };
        match designs.iter_mut().find(|(x, _)| same(x)) {
            Some((_, v)) => v.push(r),
            None => designs.push((d, vec![r])),
        }
    }
    let n_ratios = ratio_order.len();
    let band: Vec<BandBest> = designs
        .into_iter()
        .filter_map(|(design, v)| {
            let mut rs: Vec<u64> = v.iter().map(|r| key(r.ratio)).collect();
            rs.sort_unstable();
            rs.dedup();
            if rs.len() != n_ratios || v.len() != n_ratios {
                return None;
            }
            // Sum in index order (deterministic).
            let mean = v.iter().map(|r| r.reduction_pct).sum::<f64>() / n_ratios as f64;
            let max = v
                .iter()
                .fold(f64::NEG_INFINITY, |m, r| m.max(r.rms_damped_m));
            Some(BandBest {
                design,
                mean_reduction_pct: mean,
                max_rms_damped_m: max,
                ratios: n_ratios,
            })
        })
        .collect();
    let best_mean = band
        .iter()
        .fold(None::<&BandBest>, |b, x| match b {
            Some(b) if b.mean_reduction_pct >= x.mean_reduction_pct => Some(b),
            _ => Some(x),
        })
        .cloned();
    let best_minimax = band
        .iter()
        .fold(None::<&BandBest>, |b, x| match b {
            Some(b) if b.max_rms_damped_m <= x.max_rms_damped_m => Some(b),
            _ => Some(x),
        })
        .cloned();
    Optimum {
        per_ratio: per_ratio_rows,
        best_mean_reduction: best_mean,
        best_minimax_rms: best_minimax,
    }
}
