//! Design maps: a grid of frequency ratio × gap (and optionally friction level, restitution, mass
//! ratio), the damped and solid RMS at each point, the impact regime, and the optimum.
//!
//! **Grid index**: row-major over the axes in the order given, the last axis varying fastest.
//! With axes `[ratio (n_r values), gap (n_g values)]`, point `i` has ratio index `i / n_g` and gap
//! index `i % n_g`. The index is stable: it depends only on the axes, never on sharding or on the
//! thread count, so a CLI can resume by index.
//!
//! **Shards**: [`Grid::shard`]`(k, n)` holds the points with `index ≡ k − 1 (mod n)`
//! (round-robin, so expensive regions such as the resonance band spread over all shards).

use super::regime::{classify, Regime, RegimeObserver, Tolerances};
use super::{par_map_with_progress, run_case, SweepBase};
use crate::error::{ParamError, SimError};
use crate::params::{Frequency, FrictionModel, RunSettings, State, System};
use crate::solver::Solver;
use std::collections::BTreeMap;

/// A parameter a grid (or a bifurcation diagram) can vary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Axis {
    /// Forcing frequency over the natural frequency of the bar simulated.
    FreqRatio,
    /// Total clearance `gap_m`.
    GapM,
    /// Friction force level (sets the override `friction_force_n`).
    FrictionForceN,
    /// Coefficient of restitution.
    Restitution,
    /// Mass ratio `μ = m_d / M` (sets the ball mass from the damped bar's mass).
    MassRatio,
}

impl Axis {
    /// All axes, in a stable order.
    pub const ALL: [Axis; 5] = [
        Axis::FreqRatio,
        Axis::GapM,
        Axis::FrictionForceN,
        Axis::Restitution,
        Axis::MassRatio,
    ];

    /// Column name: `freq_ratio`, `gap_m`, `friction_force_n`, `restitution`, `mass_ratio`.
    pub fn as_str(&self) -> &'static str {
        match self {
            Axis::FreqRatio => "freq_ratio",
            Axis::GapM => "gap_m",
            Axis::FrictionForceN => "friction_force_n",
            Axis::Restitution => "restitution",
            Axis::MassRatio => "mass_ratio",
        }
    }

    /// Parse [`Axis::as_str`].
    pub fn parse(s: &str) -> Option<Axis> {
        Self::ALL.into_iter().find(|a| a.as_str() == s)
    }

    /// Set this parameter of `sys` to `value`. Axes other than the ratio need a damper.
    /// The value itself is checked later by [`System::validate`].
    pub fn apply(&self, sys: &mut System, value: f64) -> Result<(), ParamError> {
        if *self == Axis::FreqRatio {
            sys.forcing.frequency = Frequency::Ratio(value);
            return Ok(());
        }
        let bar_mass = sys.bar.mass_kg;
        let d = sys.damper.as_mut().ok_or(ParamError::OutOfRange {
            field: self.as_str(),
            value,
            allowed: "only with a damper (the system has no ball)",
        })?;
        match self {
            Axis::FreqRatio => unreachable!("handled above"),
            Axis::GapM => d.gap_m = value,
            Axis::FrictionForceN => d.friction_force_n = Some(value),
            Axis::Restitution => d.restitution = value,
            Axis::MassRatio => d.ball_mass_kg = value * bar_mass,
        }
        Ok(())
    }
}

/// One axis of a grid: a parameter and its values.
#[derive(Debug, Clone, PartialEq)]
pub struct GridAxis {
    /// Parameter.
    pub axis: Axis,
    /// Values, in the order they index.
    pub values: Vec<f64>,
}

/// A point of a grid: its stable index and the value of each axis.
#[derive(Debug, Clone, PartialEq)]
pub struct GridPoint {
    /// Row-major index.
    pub index: usize,
    /// `(axis, value)` in the grid's axis order.
    pub coords: Vec<(Axis, f64)>,
}

impl GridPoint {
    /// Value of `axis` at this point, if the grid has that axis.
    pub fn get(&self, axis: Axis) -> Option<f64> {
        self.coords.iter().find(|(a, _)| *a == axis).map(|c| c.1)
    }
}

/// A rectangular grid over several axes.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    axes: Vec<GridAxis>,
}

impl Grid {
    /// Build a grid. Each axis needs at least one finite value; an axis may appear only once.
    pub fn new(axes: Vec<GridAxis>) -> Result<Grid, ParamError> {
        for (i, a) in axes.iter().enumerate() {
            if a.values.is_empty() {
                return Err(ParamError::OutOfRange {
                    field: a.axis.as_str(),
                    value: 0.0,
                    allowed: "at least one value",
                });
            }
            for &v in &a.values {
                crate::params::finite(a.axis.as_str(), v)?;
            }
            if axes[..i].iter().any(|b| b.axis == a.axis) {
                return Err(ParamError::OutOfRange {
                    field: a.axis.as_str(),
                    value: a.values[0],
                    allowed: "each axis once per grid",
                });
            }
        }
        // Checked in floating point before anything is built: 1e5 × 1e5 points would
        // overflow nothing but memory.
        let n: f64 = axes.iter().map(|a| a.values.len() as f64).product();
        crate::limits::check(
            "grid points (product of the axis lengths)",
            n,
            1.0,
            crate::limits::MAX_GRID_POINTS as f64,
            "use a coarser STEP or split the grid",
        )?;
        Ok(Grid { axes })
    }

    /// The axes.
    pub fn axes(&self) -> &[GridAxis] {
        &self.axes
    }

    /// Number of points (product of the axis lengths; 1 for no axes).
    pub fn len(&self) -> usize {
        self.axes.iter().map(|a| a.values.len()).product()
    }

    /// True when the grid has no point (never: every axis has a value).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Point `index` (row-major, last axis fastest); `None` past the end.
    pub fn point(&self, index: usize) -> Option<GridPoint> {
        if index >= self.len() {
            return None;
        }
        let mut coords = vec![(Axis::FreqRatio, 0.0); self.axes.len()];
        let mut rest = index;
        for (slot, a) in coords.iter_mut().zip(&self.axes).rev() {
            let n = a.values.len();
            *slot = (a.axis, a.values[rest % n]);
            rest /= n;
        }
        Some(GridPoint { index, coords })
    }

    /// All points, in index order.
    pub fn points(&self) -> Vec<GridPoint> {
        (0..self.len()).filter_map(|i| self.point(i)).collect()
    }

    /// Shard `k` of `n` (1-based `k`): the points with `index ≡ k − 1 (mod n)`, in index order.
    pub fn shard(&self, k: usize, n: usize) -> Result<Vec<GridPoint>, ParamError> {
        if n == 0 {
            return Err(ParamError::OutOfRange {
                field: "shard count",
                value: 0.0,
                allowed: "[1, ∞)",
            });
        }
        if k == 0 || k > n {
            return Err(ParamError::OutOfRange {
                field: "shard index",
                value: k as f64,
                allowed: "[1, shard count]",
            });
        }
        Ok((k - 1..self.len())
            .step_by(n)
            .filter_map(|i| self.point(i))
            .collect())
    }
}

/// Everything fixed across a map.
#[derive(Debug, Clone, Copy, PartialEq)]
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
                Frequency::RadPerS(w) => w / self.base.damped_bar.natural_freq_rad_s(),
            })
    }

    /// The damped system at a point.
    pub fn damped_system(&self, p: &GridPoint) -> Result<System, ParamError> {
        let mut sys = self.base.damped_system(&super::SweepPoint {
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

/// RMS of the solid bar at `ratio`, from rest.
pub fn compute_solid(spec: &MapSpec, solver: &dyn Solver, ratio: f64) -> Result<f64, SimError> {
    Ok(run_case(
        &spec.solid_system(ratio),
        &State::REST,
        &spec.settings,
        solver,
        &mut (),
    )?
    .rms_m)
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

/// One point, solid and damped runs, both from rest: what a CLI calls to write rows as they
/// finish (it may cache [`compute_solid`] per ratio and call [`compute_point_from`] instead).
pub fn compute_point(
    spec: &MapSpec,
    solver: &dyn Solver,
    p: &GridPoint,
) -> Result<MapRow, SimError> {
    let solid = compute_solid(spec, solver, spec.ratio(p))?;
    compute_point_from(spec, solver, p, &State::REST, solid)
}

/// Compute `points` in parallel; solid runs are shared between points with the same ratio.
/// Rows come back in the order of `points`; results do not depend on the thread count.
pub fn run_map(
    spec: &MapSpec,
    solver: &dyn Solver,
    points: &[GridPoint],
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<MapRow>, SimError> {
    let mut ratios: Vec<f64> = points.iter().map(|p| spec.ratio(p)).collect();
    ratios.sort_by(f64::total_cmp);
    ratios.dedup_by(|a, b| a.total_cmp(b).is_eq());
    let solids = par_map_with_progress(&ratios, |&r| compute_solid(spec, solver, r), &|d, _| {
        progress(d, ratios.len() + points.len())
    });
    let solids = solids.into_iter().collect::<Result<Vec<f64>, SimError>>()?;
    let n_solid = ratios.len();
    let rows = par_map_with_progress(
        points,
        |p| {
            let r = spec.ratio(p);
            let i = ratios
                .binary_search_by(|x| x.total_cmp(&r))
                .expect("ratio listed");
            compute_point_from(spec, solver, p, &State::REST, solids[i])
        },
        &|d, t| progress(n_solid + d, n_solid + t),
    );
    rows.into_iter().collect()
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
