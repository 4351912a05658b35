//! Typed parameters of the metadata files: the spec types of `vibrobar-core` themselves,
//! serialised by serde, so that what is written is exactly what is reloaded. The JSON is the
//! same as the hand-built one it replaces (serde_json sorts object keys), so fingerprints of
//! existing journals and shards stay valid. Fields that older versions did not write default, so
//! their files (e.g. `docs/maps/*/map.csv.meta.json`) still load.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use vibrobar_core::analysis::map::{Axis, Grid, GridAxis};
use vibrobar_core::analysis::placement::{PlacementGrid, PlacementSpec};
use vibrobar_core::analysis::regime::Tolerances;
use vibrobar_core::params::BarModel;
use vibrobar_core::structure::Beam;
use vibrobar_core::{Damper, Forcing, RunSettings, State, System};

/// The system a command runs, as resolved from its flags: bars, ball, forcing, solver, settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SystemParams {
    /// Says that `ball.gap_m` is a template (absent in files of older versions).
    #[serde(default)]
    pub note: String,
    /// Preset name (`None` when the system comes from a scenario file).
    #[serde(default)]
    pub preset: Option<String>,
    /// Scenario file the system was read from (absent in files of older versions).
    #[serde(default)]
    pub scenario_file: Option<String>,
    /// Friction model name.
    pub friction: String,
    /// Friction force override in N.
    pub friction_force_n: Option<f64>,
    /// Bar with the cavity: a lumped bar is written as the `Bar` it is (as older versions did),
    /// a beam as the modes the runs used, so a job resumed on other modes is refused.
    pub damped_bar: BarModel,
    /// Reference bar without ball (lumped, or the beam's modes without the cavity section).
    pub solid_bar: BarModel,
    /// Ball template.
    pub ball: Damper,
    /// Forcing template.
    pub forcing: Forcing,
    /// Gravity in m/s² (files of older versions ran with standard gravity).
    #[serde(default = "standard_gravity")]
    pub gravity_m_s2: f64,
    /// Initial state of every run (files of older versions started at rest).
    #[serde(default)]
    pub initial: State,
    /// Solver name.
    pub solver: String,
    /// Run settings.
    pub settings: RunSettings,
    /// The `[beam]` the modes come from (geometry, material, modes, positions); absent for the
    /// lumped bar, so the metadata and fingerprints of lumped jobs are unchanged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beam: Option<Beam>,
    /// The `[cutting]` section of a cutting job; absent otherwise, so the metadata and
    /// fingerprints of every other job are unchanged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cutting: Option<vibrobar_core::excitation::Cutting>,
}

fn standard_gravity() -> f64 {
    vibrobar_core::params::STANDARD_GRAVITY_M_S2
}

/// Parameters of a map file (`kind = "map"`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MapParams {
    /// The system.
    #[serde(flatten)]
    pub system: SystemParams,
    /// The grid flags as given (`ratios`, `gaps_mm`, optional axes).
    #[serde(default)]
    pub grid: BTreeMap<String, String>,
    /// The grid's values in SI units, per axis name (absent in files of older versions: the
    /// CSV's coordinates are used then).
    #[serde(default)]
    pub grid_values_si: BTreeMap<String, Vec<f64>>,
    /// Tolerances of the regime classification (files of versions that did not write them
    /// were classified with the defaults).
    #[serde(default)]
    pub regime_tolerances: Tolerances,
    /// Absolute forcing frequencies in Hz when the map was given them (`--freqs-hz`): both bars
    /// run at the same `Ω` and the grid's ratios are `Ω/ω₁` of the damped bar; absent for a map
    /// in ratios (each bar at its own `Ω/ω₁`), so the fingerprints of those are unchanged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frequencies_hz: Option<Vec<f64>>,
}

/// Parameters of a placement file (`kind = "placement"`): the study's spec (beam, ball,
/// forcing, gravity, run settings, regime tolerances: the core type itself), where it came from,
/// the solver, and the grid (the flags as given and the values in SI units, in grid order).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlacementParams {
    /// Preset name (`None` when the study comes from a scenario file).
    pub preset: Option<String>,
    /// Scenario file the study was read from.
    pub scenario_file: Option<String>,
    /// Solver name.
    pub solver: String,
    /// Everything fixed across the study.
    pub spec: PlacementSpec,
    /// The grid flags as given (`positions_mm`, `gaps_mm`, `ratios`).
    pub grid: BTreeMap<String, String>,
    /// Cavity positions from the clamp, m.
    pub positions_m: Vec<f64>,
    /// Gaps, m.
    pub gaps_m: Vec<f64>,
    /// Ratios `Ω/ω₁` of the band.
    pub ratios: Vec<f64>,
}

impl PlacementParams {
    /// The study's grid; `None` if the stored values do not make one.
    pub fn grid(&self) -> Option<PlacementGrid> {
        PlacementGrid::new(
            self.positions_m.clone(),
            self.gaps_m.clone(),
            self.ratios.clone(),
        )
        .ok()
    }

    /// The key columns (position, gap) of grid index `i`, as the row writes them.
    pub fn key(&self, i: usize) -> Option<String> {
        let p = self.grid()?.point(i)?;
        Some(
            crate::csv::placement_schema()
                .format(&crate::csv::placement_key(p.position_m, p.gap_m)),
        )
    }
}

/// Parameters of a `run` history file (`kind = "run"`); `S` is the scenario type of the caller.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunParams<S> {
    /// The scenario as resolved (file, preset and flags).
    pub scenario: S,
    /// The damped system that ran.
    pub system: System,
    /// Initial state.
    pub initial: State,
    /// Run settings.
    pub settings: RunSettings,
    /// Solver name.
    pub solver: String,
    /// Output interval in s.
    pub sample_interval_s: Option<f64>,
}

/// Parameters of a sweep file (`kind = "sweep"`); `S` is the scenario type of the caller.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepParams<S> {
    /// The scenario as resolved.
    pub scenario: S,
    /// Solver name.
    pub solver: String,
    /// Run settings.
    pub settings: RunSettings,
    /// Gaps in m, in row order.
    pub gaps_m: Vec<f64>,
    /// Frequency ratios, in row order within a gap (with `frequencies_hz`: `Ω/ω₁` of the damped
    /// bar).
    pub ratios: Vec<f64>,
    /// Row order (`gap-major`).
    pub order: String,
    /// Absolute forcing frequencies in Hz when the sweep was given them (`--freqs-hz`): both
    /// bars run at the same `Ω`; absent for a sweep in ratios (each bar at its own `Ω/ω₁`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frequencies_hz: Option<Vec<f64>>,
}

impl MapParams {
    /// The map's grid from `grid_values_si` (axes in [`Axis::ALL`] order, as `map` builds
    /// them); `None` if absent or invalid.
    pub fn grid(&self) -> Option<Grid> {
        let axes = Axis::ALL
            .iter()
            .filter_map(|a| {
                Some(GridAxis {
                    axis: *a,
                    values: self.grid_values_si.get(a.as_str())?.clone(),
                })
            })
            .collect();
        Grid::new(axes).ok()
    }
}

impl<S> SweepParams<S> {
    /// The key columns (ratio, gap) of grid index `i` (gap-major), as the row writes them.
    pub fn key(&self, i: usize) -> Option<String> {
        let n = self.ratios.len();
        let ratio = *self.ratios.get(i.checked_rem(n)?)?;
        let gap_m = *self.gaps_m.get(i / n)?;
        Some(crate::csv::sweep_key(ratio, gap_m * 1e3))
    }
}

/// Parameters of one design point (`lyapunov`, and the base of [`PoincareParams`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointParams {
    /// The system.
    #[serde(flatten)]
    pub system: SystemParams,
    /// Frequency ratio of the point.
    pub ratio: f64,
    /// Gap of the point in m.
    pub gap_m: f64,
}

/// Parameters of a Poincaré section (`kind = "poincare"`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoincareParams {
    /// The point.
    #[serde(flatten)]
    pub point: PointParams,
    /// Forcing phase Ωt of the section, rad.
    pub phase_rad: f64,
    /// Discarded time at the start, s.
    pub transient_s: f64,
}

/// Parameters of a bifurcation diagram (`kind = "bifurcation"` and `"bifurcation-impacts"`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BifurcationParams {
    /// The system.
    #[serde(flatten)]
    pub system: SystemParams,
    /// Swept parameter's column (`ratio` or `gap_mm`).
    pub param: String,
    /// Its values as given (mm for gaps).
    pub values: Vec<f64>,
    /// Fixed ratio (when sweeping the gap).
    pub fixed_ratio: Option<f64>,
    /// Fixed gap in m (when sweeping the ratio).
    pub fixed_gap_m: Option<f64>,
    /// Forcing phase of the section, rad.
    pub phase_rad: f64,
    /// Discarded time at the start of each run, s.
    pub transient_s: f64,
}

/// Parameters of a periodic orbit (`kind = "orbit"`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrbitParams {
    /// The point.
    #[serde(flatten)]
    pub point: PointParams,
    /// Period in forcing cycles.
    pub period: u32,
    /// Starting guess: `symmetric` (with `branch`) or `settled` (with `settle_s`).
    pub start: String,
    /// Index of the analytic symmetric orbit used as the start.
    pub branch: Option<usize>,
    /// Settling time of a `settled` start, s.
    pub settle_s: Option<f64>,
    /// Jacobian of the map: `variational` or `finite-difference`.
    pub jacobian: String,
}

/// Parameters of a continuation (`kind = "continuation"`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ContinuationParams {
    /// The starting orbit's point and settings.
    #[serde(flatten)]
    pub orbit: OrbitParams,
    /// Followed parameter (`--param`: `ratio`, `gap-mm`, `friction-force-n`, `restitution`).
    pub param: String,
    /// Interval start, in the parameter's unit.
    pub from: f64,
    /// Interval end, in the parameter's unit.
    pub to: f64,
    /// Largest number of points of the main branch.
    pub max_points: usize,
    /// Branches switched to at period doublings.
    pub switch_branches: bool,
}

/// Half ranges of an ensemble's initial conditions (uniform in ±).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IcHalfRanges {
    /// Bar displacement, m.
    pub u_m: f64,
    /// Bar velocity, m/s.
    pub du_m_s: f64,
    /// Relative velocity ẇ, m/s.
    pub dw_m_s: f64,
    /// Ball position over half the gap (1: the whole cavity).
    pub w_over_half_gap: f64,
}

/// Parameters of an initial-condition ensemble (`kind = "ensemble"`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EnsembleFileParams {
    /// The system.
    #[serde(flatten)]
    pub system: SystemParams,
    /// Ratios of the grid.
    pub ratios: Vec<f64>,
    /// Gaps of the grid in m.
    pub gaps_m: Vec<f64>,
    /// Members per point.
    pub members: usize,
    /// Seed.
    pub seed: u64,
    /// Ranges of the initial conditions.
    pub ic_half_ranges: IcHalfRanges,
}

impl EnsembleFileParams {
    /// The grid (ratio outer, gap inner), or `None` if the lists do not make one.
    pub fn grid(&self) -> Option<Grid> {
        Grid::new(vec![
            GridAxis {
                axis: Axis::FreqRatio,
                values: self.ratios.clone(),
            },
            GridAxis {
                axis: Axis::GapM,
                values: self.gaps_m.clone(),
            },
        ])
        .ok()
    }

    /// The key columns (ratio, gap) of grid index `i`, as the row writes them.
    pub fn key(&self, i: usize) -> Option<String> {
        let p = self.grid()?.point(i)?;
        Some(crate::csv::ensemble_schema().format(&crate::csv::map_key(&p, &[])))
    }
}
