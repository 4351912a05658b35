//! Cavity placement on a beam (issue #8 §5): where along the bar, and with which gap, the ball
//! damps the response best over a band of forcing frequencies.
//!
//! **The grid.** Cavity positions `x_d` (from the clamp) × gaps; every point runs the damped beam
//! at every ratio of the band. Index: row-major, position outer, gap inner (`i = ip·n_gaps + ig`),
//! stable whatever the shard or thread count (as [`super::grid`]).
//!
//! **The bars.** The damped bar is the spec's beam with its cavity (centre, and section if any) at
//! `x_d`: its modal model is computed ONCE per position, whatever the number of gaps and ratios.
//! The solid reference is the same beam without cavity section and ball; it does not depend on
//! the position, so it runs once per ratio. Ratios are `Ω/ω₁` of each bar (with a cavity section
//! `ω₁` of the damped bar changes with the position). Every run starts at rest, ball centred (the
//! paper's start). RMS at the response point over the settings' window.
//!
//! **A row** (one per position × gap) over the band of ratios `r₁ … r_k`:
//! * `mean_reduction_pct = mean_k 100·(1 − rms_damped(r_k)/rms_solid(r_k))`,
//! * `min_reduction_pct`: the smallest of those (the band's weakest point),
//! * `worst_rms_m`: the largest damped RMS in the band, at `worst_ratio` (ties: the lower ratio),
//! * `mean_impacts_per_cycle`: mean over the band,
//! * `regime`: the steady-state regime ([`super::regime`]) of the run at `worst_ratio`.
//!
//! **Optimum** ([`optimum`]): the largest mean reduction; ties go to the smaller worst RMS, then
//! to the smaller grid index (the position nearer the clamp, then the smaller gap).
//!
//! The runs go through the core's [`Runner`] (pool, cancellation, progress). How one case is
//! run is the caller's [`CaseFn`]; [`solver_case`] runs it with a [`Solver`].

use super::batch::{BatchError, Runner};
use super::case::run_case;
use super::energy::EnergyAudit;
use super::regime::{classify, Regime, RegimeObserver, Tolerances};
use crate::error::{ParamError, SimError};
use crate::limits;
use crate::params::{BarModel, Damper, Forcing, Frequency, RunSettings, State, System};
use crate::solver::{Fanout, Observer, Solver};
use crate::structure::{Beam, ModalModel};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Everything fixed across a placement study (serialisable, for typed metadata).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlacementSpec {
    /// The damped bar: geometry, material, modes, optional cavity section and tip mass, force
    /// and response points. Its `cavity_position_m` is replaced by each grid position.
    pub beam: Beam,
    /// Ball template; each point sets the gap.
    pub ball: Damper,
    /// Forcing template (at the force point); each run sets the ratio `Ω/ω₁`.
    pub forcing: Forcing,
    /// Gravity for the derived friction force.
    pub gravity_m_s2: f64,
    /// Duration, step and RMS window of every run.
    pub settings: RunSettings,
    /// Regime classification tolerances.
    pub tolerances: Tolerances,
}

/// What one run reports to a placement study.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaseStats {
    /// RMS at the response point over the window.
    pub rms_m: f64,
    /// Impacts per forcing cycle in the window.
    pub impacts_per_cycle: f64,
    /// Steady-state regime over the window.
    pub regime: Regime,
    /// Kinetic energy lost in impacts in the window, J (from the energy audit; `None` when the
    /// case did not audit).
    pub impact_loss_j: Option<f64>,
    /// Length of the window, s.
    pub window_s: f64,
}

/// How one case is run: the system from rest over the spec's settings.
pub type CaseFn<'a> = &'a (dyn Fn(&System) -> Result<CaseStats, SimError> + Sync);

/// A point of the grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlacementPoint {
    /// Grid index (row-major, position outer).
    pub index: usize,
    /// Cavity centre from the clamp, m.
    pub position_m: f64,
    /// Total clearance, m.
    pub gap_m: f64,
}

/// Positions × gaps, and the band of ratios every point runs.
#[derive(Debug, Clone, PartialEq)]
pub struct PlacementGrid {
    positions_m: Vec<f64>,
    gaps_m: Vec<f64>,
    ratios: Vec<f64>,
}

impl PlacementGrid {
    /// A grid; each list non-empty and finite, at most [`limits::MAX_GRID_POINTS`] runs.
    pub fn new(
        positions_m: Vec<f64>,
        gaps_m: Vec<f64>,
        ratios: Vec<f64>,
    ) -> Result<PlacementGrid, ParamError> {
        for (field, v) in [
            ("placement positions (--positions-mm)", &positions_m),
            ("placement gaps (--gaps-mm)", &gaps_m),
            ("placement ratios (--ratios)", &ratios),
        ] {
            if v.is_empty() {
                return Err(ParamError::OutOfRange {
                    field,
                    value: 0.0,
                    allowed: "at least one value",
                });
            }
            for &x in v {
                crate::params::finite(field, x)?;
            }
        }
        limits::check(
            "placement runs (positions × gaps × ratios)",
            positions_m.len() as f64 * gaps_m.len() as f64 * ratios.len() as f64,
            1.0,
            limits::MAX_GRID_POINTS as f64,
            "use a coarser STEP or split the study",
        )?;
        Ok(PlacementGrid {
            positions_m,
            gaps_m,
            ratios,
        })
    }

    /// Positions, m.
    pub fn positions_m(&self) -> &[f64] {
        &self.positions_m
    }

    /// Gaps, m.
    pub fn gaps_m(&self) -> &[f64] {
        &self.gaps_m
    }

    /// Ratios of the band.
    pub fn ratios(&self) -> &[f64] {
        &self.ratios
    }

    /// Points (positions × gaps).
    pub fn len(&self) -> usize {
        self.positions_m.len() * self.gaps_m.len()
    }

    /// Never true (every list has a value).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Point `index`; `None` past the end.
    pub fn point(&self, index: usize) -> Option<PlacementPoint> {
        let ng = self.gaps_m.len();
        Some(PlacementPoint {
            index,
            position_m: *self.positions_m.get(index / ng)?,
            gap_m: self.gaps_m[index % ng],
        })
    }
}

impl PlacementSpec {
    /// The allowed cavity centres `[lo, hi]` from the clamp: `[0, L]`, or with a cavity section
    /// `[d_h/2, L − d_h/2]` (the hole inside the bar).
    pub fn position_range_m(&self) -> (f64, f64) {
        let l = self.beam.length_m;
        match self.beam.cavity_section {
            Some(c) => (0.5 * c.hole_diameter_m, l - 0.5 * c.hole_diameter_m),
            None => (0.0, l),
        }
    }

    /// Check a cavity position; the error names `--positions-mm` and the range.
    pub fn check_position(&self, x_m: f64) -> Result<(), ParamError> {
        let (lo, hi) = self.position_range_m();
        limits::check(
            "cavity position (--positions-mm)",
            x_m,
            lo,
            hi,
            "m from the clamp, inside the bar: [0, L], or [d_h/2, L − d_h/2] with a cavity section",
        )
        .map(|_| ())
    }

    /// The damped bar with its cavity at `x_m`.
    pub fn damped_beam(&self, x_m: f64) -> Beam {
        Beam {
            cavity_position_m: x_m,
            ..self.beam.clone()
        }
    }

    /// The solid reference ([`Beam::solid_reference`]) with as many modes as the bar with the
    /// cavity (the beam's `modes`, or the default rule applied to the bar with its cavity as
    /// given).
    pub fn solid_beam(&self) -> Result<Beam, ParamError> {
        let modes = match self.beam.modes {
            Some(n) => n,
            None => self.beam.modal_model()?.len(),
        };
        Ok(self.beam.solid_reference(modes))
    }

    /// The damped bar's modes with the cavity at `x_m` (checked first).
    pub fn damped_model(&self, x_m: f64) -> Result<ModalModel, ParamError> {
        self.check_position(x_m)?;
        self.damped_beam(x_m).modal_model()
    }

    /// The solid bar's modes.
    pub fn solid_model(&self) -> Result<ModalModel, ParamError> {
        self.solid_beam()?.modal_model()
    }

    /// The ball with gap `gap_m`.
    pub fn damper(&self, gap_m: f64) -> Damper {
        Damper { gap_m, ..self.ball }
    }

    /// A system of this study: `model`, optional ball, forced at `ratio` of its own `ω₁`.
    pub fn system(&self, model: &ModalModel, damper: Option<Damper>, ratio: f64) -> System {
        System {
            bar: BarModel::Modal(*model),
            damper,
            forcing: Forcing {
                frequency: Frequency::Ratio(ratio),
                ..self.forcing
            },
            gravity_m_s2: self.gravity_m_s2,
        }
    }
}

/// One row of a placement study (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlacementRow {
    /// The point.
    pub point: PlacementPoint,
    /// Mean over the band of `100·(1 − rms_damped/rms_solid)`.
    pub mean_reduction_pct: f64,
    /// Smallest reduction in the band.
    pub min_reduction_pct: f64,
    /// Largest damped RMS in the band, m.
    pub worst_rms_m: f64,
    /// Ratio of `worst_rms_m` (the lower one on a tie).
    pub worst_ratio: f64,
    /// Mean over the band of the impacts per forcing cycle.
    pub mean_impacts_per_cycle: f64,
    /// Regime of the run at `worst_ratio`.
    pub regime: Regime,
}

/// The row of `point` from the band's solid RMS and damped runs (same order as `ratios`).
pub fn summarise(
    point: PlacementPoint,
    ratios: &[f64],
    solid_rms_m: &[f64],
    damped: &[CaseStats],
) -> PlacementRow {
    let k = ratios.len() as f64;
    let mut mean = 0.0;
    let mut min = f64::INFINITY;
    let mut worst = 0;
    let mut ipc = 0.0;
    for (i, (s, d)) in solid_rms_m.iter().zip(damped).enumerate() {
        let red = 100.0 * (1.0 - d.rms_m / s);
        mean += red;
        min = min.min(red);
        ipc += d.impacts_per_cycle;
        if d.rms_m > damped[worst].rms_m {
            worst = i;
        }
    }
    PlacementRow {
        point,
        mean_reduction_pct: mean / k,
        min_reduction_pct: min,
        worst_rms_m: damped[worst].rms_m,
        worst_ratio: ratios[worst],
        mean_impacts_per_cycle: ipc / k,
        regime: damped[worst].regime,
    }
}

/// A damped run of a placement study failed: where, and what the solver said.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "damped bar at position {} mm, gap {} mm, ratio {ratio}: {source}",
    position_m * 1e3,
    gap_m * 1e3
)]
pub struct PointFailed {
    /// Cavity position, m.
    pub position_m: f64,
    /// Gap, m.
    pub gap_m: f64,
    /// Ratio.
    pub ratio: f64,
    /// What the run said.
    pub source: SimError,
}

/// Run `points` of `grid`: the modal model once per position among them (every position is
/// checked before any run), the solid bar once per ratio, then every point's band of ratios
/// (in parallel; a point's runs too). `keep` stores each row as soon as it is done (e.g. in a
/// journal); rows come back in the order of `points`, independent of the thread count.
pub fn run<R, E>(
    spec: &PlacementSpec,
    grid: &PlacementGrid,
    points: &[PlacementPoint],
    runner: Runner<'_>,
    case: CaseFn<'_>,
    keep: impl Fn(PlacementRow) -> Result<R, E> + Sync,
) -> Result<Vec<R>, BatchError<E>>
where
    R: Send,
    E: Send + From<PointFailed>,
{
    let ratios = grid.ratios();
    // Models first: a position that does not fit stops the study before any run.
    let mut models: Vec<(f64, ModalModel)> = Vec::new();
    for p in points {
        if !models
            .iter()
            .any(|(x, _)| x.total_cmp(&p.position_m).is_eq())
        {
            models.push((p.position_m, spec.damped_model(p.position_m)?));
        }
    }
    let solid_model = spec.solid_model()?;
    let n_solid = ratios.len();
    let total = n_solid + points.len();
    let outer = runner.progress;
    let solid_progress = |d: usize, _: usize| outer(d, total);
    let solid = runner
        .with_progress(&solid_progress)
        .each(ratios, |&r| {
            case(&spec.system(&solid_model, None, r)).map_err(|e| (r, e))
        })
        .map_err(|e| match e {
            BatchError::Point((ratio, source)) | BatchError::Solid { ratio, source } => {
                BatchError::Solid { ratio, source }
            }
            BatchError::Cancelled { done, .. } => BatchError::Cancelled { done, total },
            BatchError::Threads(t) => BatchError::Threads(t),
            BatchError::Param(p) => BatchError::Param(p),
        })?;
    let solid_rms: Vec<f64> = solid.iter().map(|s| s.rms_m).collect();
    for (r, s) in ratios.iter().zip(&solid_rms) {
        limits::reference_rms(*s).map_err(|e| BatchError::Solid {
            ratio: *r,
            source: e.into(),
        })?;
    }
    let point_progress = |d: usize, _: usize| outer(n_solid + d, total);
    runner
        .with_progress(&point_progress)
        .each(points, |p| {
            let model = &models
                .iter()
                .find(|(x, _)| x.total_cmp(&p.position_m).is_eq())
                .expect("a model per position")
                .1;
            let damper = Some(spec.damper(p.gap_m));
            let damped = ratios
                .par_iter()
                .map(|&r| {
                    case(&spec.system(model, damper, r)).map_err(|source| PointFailed {
                        position_m: p.position_m,
                        gap_m: p.gap_m,
                        ratio: r,
                        source,
                    })
                })
                .collect::<Result<Vec<_>, _>>()?;
            keep(summarise(*p, ratios, &solid_rms, &damped))
        })
        .map_err(|e| match e {
            BatchError::Cancelled { done, .. } => BatchError::Cancelled {
                done: n_solid + done,
                total,
            },
            other => other,
        })
}

/// The best row: largest mean reduction; ties go to the smaller worst RMS, then to the smaller
/// grid index. Rows with a NaN are ignored; `None` without rows. Independent of the row order.
pub fn optimum(rows: &[PlacementRow]) -> Option<PlacementRow> {
    rows.iter()
        .filter(|r| !r.mean_reduction_pct.is_nan() && !r.worst_rms_m.is_nan())
        .copied()
        .reduce(|b, r| {
            let better = r
                .mean_reduction_pct
                .total_cmp(&b.mean_reduction_pct)
                .then(b.worst_rms_m.total_cmp(&r.worst_rms_m))
                .then(b.point.index.cmp(&r.point.index));
            if better.is_gt() {
                r
            } else {
                b
            }
        })
}

/// One case with `solver`: from rest (ball centred), RMS at the response point, impacts and
/// regime over the settings' window; with `audit`, also the impact loss in the window from the
/// energy audit (which costs the full segment integrals of every step).
pub fn solver_case<'a>(
    solver: &'a dyn Solver,
    settings: RunSettings,
    tolerances: Tolerances,
    audit: bool,
) -> impl Fn(&System) -> Result<CaseStats, SimError> + Sync + 'a {
    move |sys: &System| {
        let w0 = settings.window_start_s();
        let t_end = settings.duration_s;
        let mut reg = RegimeObserver::new(sys, w0, t_end);
        let mut energy = audit.then(|| EnergyAudit::with_window(sys, w0));
        let r = {
            let mut nothing = ();
            let books: &mut dyn Observer = match energy.as_mut() {
                Some(e) => e,
                None => &mut nothing,
            };
            let mut obs: [&mut dyn Observer; 2] = [&mut reg, books];
            run_case(sys, &State::REST, &settings, solver, &mut Fanout(&mut obs))?
        };
        let impact_loss_j = match energy.map(|e| e.balance()) {
            Some(Some(b)) => Some(limits::finite_result(
                "impact loss",
                b.impact_loss_j,
                "parameters far outside the model's range (forces, masses or stiffness)",
            )?),
            Some(None) => Some(0.0),
            None => None,
        };
        Ok(CaseStats {
            rms_m: r.rms_m,
            impacts_per_cycle: r.impacts_per_cycle,
            regime: classify(&reg.finish(), &tolerances),
            impact_loss_j,
            window_s: t_end - w0,
        })
    }
}

/// One line of the N-convergence study (issue #8 §4): a design point with the first `modes`
/// modes of the damped and the solid bar.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConvergenceRow {
    /// Modes kept, N.
    pub modes: usize,
    /// `Σ φₙ(x_d)²/mₙ` of the damped bar, 1/kg (the bar's inverse effective mass at the cavity).
    pub inverse_effective_mass_per_kg: f64,
    /// RMS of the solid bar at the response point, m.
    pub rms_solid_m: f64,
    /// RMS of the damped bar, m.
    pub rms_damped_m: f64,
    /// `100·(1 − damped/solid)`.
    pub reduction_pct: f64,
    /// Impact loss per second in the window, W.
    pub impact_loss_w: f64,
    /// Impacts per forcing cycle in the window.
    pub impacts_per_cycle: f64,
    /// Regime of the damped run.
    pub regime: Regime,
}

/// The design point `(x_m, gap_m, ratio)` with N = each of `modes` (the spec's beam with its mode
/// count replaced): solid and damped runs, all in parallel on `runner`. `case` must audit the
/// energy ([`solver_case`] with `audit`): the rows carry the impact loss.
pub fn mode_convergence(
    spec: &PlacementSpec,
    x_m: f64,
    gap_m: f64,
    ratio: f64,
    modes: &[usize],
    runner: Runner<'_>,
    case: CaseFn<'_>,
) -> Result<Vec<ConvergenceRow>, BatchError<SimError>> {
    let mut jobs = Vec::with_capacity(2 * modes.len());
    for &n in modes {
        let s = PlacementSpec {
            beam: spec.beam.clone().with_modes(n),
            ..spec.clone()
        };
        let damped = s.damped_model(x_m)?;
        let solid = s.solid_model()?;
        jobs.push(s.system(&solid, None, ratio));
        jobs.push(s.system(&damped, Some(s.damper(gap_m)), ratio));
    }
    let stats = runner.each(&jobs, |sys| {
        let st = case(sys)?;
        match st.impact_loss_j {
            Some(_) => Ok(st),
            None => Err(SimError::Unsupported(
                "mode_convergence needs a case that audits the energy (solver_case with audit)",
            )),
        }
    })?;
    Ok(modes
        .iter()
        .enumerate()
        .map(|(k, &n)| {
            let (s, d) = (stats[2 * k], stats[2 * k + 1]);
            let model = jobs[2 * k + 1].modal_model();
            ConvergenceRow {
                modes: n,
                inverse_effective_mass_per_kg: model
                    .modes()
                    .iter()
                    .map(|m| m.shape_cavity * m.shape_cavity / m.modal_mass_kg)
                    .sum(),
                rms_solid_m: s.rms_m,
                rms_damped_m: d.rms_m,
                reduction_pct: 100.0 * (1.0 - d.rms_m / s.rms_m),
                impact_loss_w: d.impact_loss_j.unwrap_or(0.0) / d.window_s,
                impacts_per_cycle: d.impacts_per_cycle,
                regime: d.regime,
            }
        })
        .collect())
}
