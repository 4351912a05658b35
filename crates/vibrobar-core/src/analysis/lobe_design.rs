//! Design by time-domain lobes (issue #14 §3): which gap and ball mass (lumped bar), or which
//! gap and cavity position (beam), let the bar cut deepest over a band of spindle speeds.
//!
//! **Score.** For each design, at every speed of the band, the largest acceptable width of the
//! damped bar from the large disturbance ([`td_lobe_search`] in the order of
//! [`super::time_domain::SEARCH_ORDER`]: damped, large). The score is its worst case over the
//! band (`worst_width_m`, at `worst_rpm`; ties: the lower speed); the mean over the band is
//! reported beside it. The solid bar's widths from the same disturbance are computed once per
//! speed ([`solid_reference`]), not once per design; every row carries their worst case and
//! mean and the gains (damped over solid).
//!
//! **Designs.** Gaps × a second axis ([`DesignAxis`]): ball masses (the ball's radius and
//! every other field kept, as `map --mass-ratios` does), or cavity centres from the clamp on a
//! `[beam]` (the damped bar's modes recomputed per design, as [`super::placement`] does; the
//! solid reference does not depend on the position). Index row-major, gap outer:
//! `i = i_gap·n_values + i_value`, stable whatever the shard or thread count.
//!
//! **Optimum** ([`optimum`]): the largest worst-case width; ties go to the larger mean, then to
//! the smaller index.
//!
//! The designs are generic over the cutting problem ([`CutProblem`]): whatever structure
//! [`super::time_domain::judge_run`] runs, a design runs.

use super::batch::{BatchError, Runner};
use super::placement::PlacementSpec;
use super::regime::Tolerances;
use super::time_domain::{
    linear_at, td_lobe_search, width_spread, BarKind, CutProblem, Disturbance, LinearAt, RevRegime,
    Search,
};
use crate::error::{ParamError, SimError};
use crate::params::{BarModel, RunSettings};
use crate::structure::Beam;

/// Index of the damped bar's large-disturbance search in
/// [`super::time_domain::SEARCH_ORDER`].
pub const DAMPED_LARGE: usize = 3;
/// Index of the solid bar's large-disturbance search.
pub const SOLID_LARGE: usize = 1;

/// Seeded perturbations of the disturbance behind the spread of a chaotic worst case
/// ([`chaos_spread`]; seeds `1..=SPREAD_SEEDS`).
pub const SPREAD_SEEDS: u64 = 4;
/// Relative perturbation of the disturbance's amplitude for the spread: a uniform factor in
/// `[1 − SPREAD_REL, 1 + SPREAD_REL]` per seed.
pub const SPREAD_REL: f64 = 0.2;

/// The second design variable beside the gap.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DesignAxis {
    /// Ball mass, kg (any structure).
    BallMass,
    /// Cavity centre from the clamp, m (a `[beam]`).
    Position,
}

impl DesignAxis {
    /// Both.
    pub const ALL: [DesignAxis; 2] = [DesignAxis::BallMass, DesignAxis::Position];

    /// The CSV column (SI).
    pub fn column(&self) -> &'static str {
        match self {
            DesignAxis::BallMass => "ball_mass_kg",
            DesignAxis::Position => "position_m",
        }
    }

    /// The command-line flag that gives it.
    pub fn flag(&self) -> &'static str {
        match self {
            DesignAxis::BallMass => "--ball-masses-g",
            DesignAxis::Position => "--positions-mm",
        }
    }

    /// The axis whose column is `name`.
    pub fn from_column(name: &str) -> Option<DesignAxis> {
        Self::ALL.into_iter().find(|a| a.column() == name)
    }
}

/// One design.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DesignPoint {
    /// Grid index (row-major, gap outer).
    pub index: usize,
    /// Total clearance, m.
    pub gap_m: f64,
    /// The second variable (ball mass in kg, or cavity position in m).
    pub value: f64,
}

/// Gaps × values of the second axis.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignGrid {
    axis: DesignAxis,
    gaps_m: Vec<f64>,
    values: Vec<f64>,
}

impl DesignGrid {
    /// A grid; each list non-empty, finite and positive (positions: ≥ 0, checked against the
    /// bar by [`LobeDesignSpec::problem`]); at most [`crate::limits::MAX_GRID_POINTS`] designs.
    /// Errors name the flag.
    pub fn new(
        axis: DesignAxis,
        gaps_m: Vec<f64>,
        values: Vec<f64>,
    ) -> Result<DesignGrid, ParamError> {
        let second = match axis {
            DesignAxis::BallMass => "ball masses (--ball-masses-g)",
            DesignAxis::Position => "cavity positions (--positions-mm)",
        };
        for (field, v, zero_ok) in [
            ("gaps (--gaps-mm)", &gaps_m, false),
            (second, &values, axis == DesignAxis::Position),
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
                if x < 0.0 || (x == 0.0 && !zero_ok) {
                    return Err(ParamError::OutOfRange {
                        field,
                        value: x,
                        allowed: if zero_ok { "[0, ∞)" } else { "(0, ∞)" },
                    });
                }
            }
        }
        crate::limits::check(
            "designs (gaps × values)",
            gaps_m.len() as f64 * values.len() as f64,
            1.0,
            crate::limits::MAX_GRID_POINTS as f64,
            "use a coarser STEP",
        )?;
        Ok(DesignGrid {
            axis,
            gaps_m,
            values,
        })
    }

    /// The second axis.
    pub fn axis(&self) -> DesignAxis {
        self.axis
    }

    /// Gaps, m.
    pub fn gaps_m(&self) -> &[f64] {
        &self.gaps_m
    }

    /// Values of the second axis (SI).
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Number of designs.
    pub fn len(&self) -> usize {
        self.gaps_m.len() * self.values.len()
    }

    /// True without designs (never, for a grid from [`DesignGrid::new`]).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Design `index`; `None` past the end.
    pub fn point(&self, index: usize) -> Option<DesignPoint> {
        let nv = self.values.len();
        Some(DesignPoint {
            index,
            gap_m: *self.gaps_m.get(index / nv)?,
            value: self.values[index % nv],
        })
    }

    /// Every design, in index order.
    pub fn points(&self) -> Vec<DesignPoint> {
        (0..self.len()).filter_map(|i| self.point(i)).collect()
    }
}

/// Everything fixed across a design study.
#[derive(Debug, Clone, PartialEq)]
pub struct LobeDesignSpec {
    /// The cutting problem each design modifies (its damper's gap, and its ball mass or its
    /// damped bar).
    pub base: CutProblem,
    /// The beam whose cavity moves ([`DesignAxis::Position`] only).
    pub beam: Option<Beam>,
    /// The second axis.
    pub axis: DesignAxis,
}

impl LobeDesignSpec {
    /// The cutting problem of design `d`, checked; errors name the field or flag.
    pub fn problem(&self, d: &DesignPoint) -> Result<CutProblem, ParamError> {
        let mut p = self.base;
        let mut ball = p.damped.damper.ok_or(ParamError::OutOfRange {
            field: "damper (a design needs the ball)",
            value: 0.0,
            allowed: "a [damper] section",
        })?;
        ball.gap_m = d.gap_m;
        match self.axis {
            DesignAxis::BallMass => ball.ball_mass_kg = d.value,
            DesignAxis::Position => {
                let beam = self.beam.as_ref().ok_or(ParamError::OutOfRange {
                    field: "cavity positions (--positions-mm)",
                    value: d.value,
                    allowed: "a [beam] scenario (the lumped bar has no position)",
                })?;
                // The placement study's definition of the allowed positions and of the bar
                // with its cavity there.
                let place = PlacementSpec {
                    beam: beam.clone(),
                    ball,
                    forcing: p.damped.forcing,
                    gravity_m_s2: p.damped.gravity_m_s2,
                    settings: RunSettings::default(),
                    tolerances: Tolerances::default(),
                };
                p.damped.bar = BarModel::Modal(place.damped_model(d.value)?);
            }
        }
        p.damped.damper = Some(ball);
        p.damped.validate()?;
        p.validate()?;
        Ok(p)
    }
}

/// Check the band of speeds: at least one, each in the spindle range; errors name `--rpm`.
pub fn check_speeds(rpms: &[f64]) -> Result<(), ParamError> {
    if rpms.is_empty() {
        return Err(ParamError::OutOfRange {
            field: "spindle speeds (--rpm)",
            value: 0.0,
            allowed: "at least one speed",
        });
    }
    for &n in rpms {
        crate::limits::check(
            "spindle speed (--rpm)",
            n,
            crate::limits::SPINDLE_RPM_MIN,
            crate::limits::SPINDLE_RPM_MAX,
            "revolutions per minute",
        )?;
    }
    Ok(())
}

/// Worst case and mean of the widths over the band.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BandScore {
    /// The smallest width over the band, m.
    pub worst_width_m: f64,
    /// Its speed (ties: the lower speed), rpm.
    pub worst_rpm: f64,
    /// Mean width over the band, m.
    pub mean_width_m: f64,
}

impl BandScore {
    /// The score of `widths_m[k]` at `rpms[k]` (non-empty, same length).
    pub fn of(rpms: &[f64], widths_m: &[f64]) -> BandScore {
        let mut worst = (f64::INFINITY, f64::NAN);
        for (&n, &w) in rpms.iter().zip(widths_m) {
            if w.total_cmp(&worst.0).then(n.total_cmp(&worst.1)).is_lt() {
                worst = (w, n);
            }
        }
        BandScore {
            worst_width_m: worst.0,
            worst_rpm: worst.1,
            mean_width_m: widths_m.iter().sum::<f64>() / widths_m.len() as f64,
        }
    }
}

/// The solid bar's large-disturbance widths at every speed of the band, computed once.
#[derive(Debug, Clone, PartialEq)]
pub struct SolidReference {
    /// The speeds, rpm.
    pub rpms: Vec<f64>,
    /// The linear boundaries at each speed (the solid ones start every search).
    pub linear: Vec<LinearAt>,
    /// The solid bar's search at each speed.
    pub searches: Vec<Search>,
    /// Worst case and mean over the band.
    pub score: BandScore,
}

/// The solid reference of `base` over `rpms`, one search per speed on `runner`.
pub fn solid_reference(
    base: &CutProblem,
    rpms: &[f64],
    runner: &Runner,
) -> Result<SolidReference, BatchError<SimError>> {
    base.validate()?;
    check_speeds(rpms)?;
    let linear = linear_at(base, rpms)?;
    let idx: Vec<usize> = (0..rpms.len()).collect();
    let searches = runner.each(&idx, |&i| {
        td_lobe_search(base, rpms[i], &linear[i], SOLID_LARGE)
    })?;
    let widths: Vec<f64> = searches.iter().map(|s| s.width_m).collect();
    Ok(SolidReference {
        rpms: rpms.to_vec(),
        score: BandScore::of(rpms, &widths),
        linear,
        searches,
    })
}

/// One row of a design study.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DesignRow {
    /// The design.
    pub point: DesignPoint,
    /// The damped bar's score (large disturbance).
    pub damped: BandScore,
    /// The solid bar's score over the same band.
    pub solid: BandScore,
    /// Runs of the damped searches that hit the event limit.
    pub event_limit_runs: u32,
    /// Speeds where a width below the bisection result failed.
    pub non_monotonic: u32,
    /// Speeds still acceptable at the doubling cap (the width is a lower bound).
    pub capped: u32,
    /// Runs made by the damped searches.
    pub runs: u32,
    /// Regime of the damped run at the worst case (its worst width and speed, from the large
    /// disturbance); `None` without an acceptable width or before [`chaos_spread`].
    pub worst_regime: Option<RevRegime>,
    /// Where that run is chaotic: the worst speed's width over seeded perturbations of the
    /// disturbance ([`chaos_spread`]).
    pub spread: Option<WidthSpread>,
}

/// The acceptable width over seeded perturbations of the disturbance
/// ([`super::time_domain::width_spread`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WidthSpread {
    /// Smallest width, m.
    pub min_width_m: f64,
    /// Mean width, m.
    pub mean_width_m: f64,
    /// Largest width, m.
    pub max_width_m: f64,
}

impl DesignRow {
    /// Worst-case width of the damped bar over the solid bar's (`None` when the solid bar has
    /// no acceptable width at some speed).
    pub fn worst_gain(&self) -> Option<f64> {
        (self.solid.worst_width_m > 0.0)
            .then(|| self.damped.worst_width_m / self.solid.worst_width_m)
    }

    /// Mean width of the damped bar over the solid bar's.
    pub fn mean_gain(&self) -> Option<f64> {
        (self.solid.mean_width_m > 0.0).then(|| self.damped.mean_width_m / self.solid.mean_width_m)
    }
}

/// The damped bar's large-disturbance search of design `d` at every speed of `solid`'s band,
/// in order (the widths behind its score; [`DesignRow::from_searches`] scores them).
pub fn design_searches(
    spec: &LobeDesignSpec,
    d: &DesignPoint,
    solid: &SolidReference,
) -> Result<Vec<Search>, SimError> {
    let p = spec.problem(d)?;
    let lin = linear_at(&p, &solid.rpms)?;
    solid
        .rpms
        .iter()
        .zip(&lin)
        .map(|(&n, l)| td_lobe_search(&p, n, l, DAMPED_LARGE))
        .collect()
}

impl DesignRow {
    /// The row of design `d` from its searches (one per speed of `solid`'s band, in order).
    pub fn from_searches(d: &DesignPoint, solid: &SolidReference, searches: &[Search]) -> Self {
        let widths: Vec<f64> = searches.iter().map(|s| s.width_m).collect();
        let mut row = DesignRow {
            point: *d,
            damped: BandScore::of(&solid.rpms, &widths),
            solid: solid.score,
            event_limit_runs: 0,
            non_monotonic: 0,
            capped: 0,
            runs: 0,
            worst_regime: None,
            spread: None,
        };
        for s in searches {
            row.event_limit_runs += s.event_limit_runs;
            row.non_monotonic += u32::from(s.non_monotonic);
            row.capped += u32::from(s.capped);
            row.runs += s.runs;
        }
        row
    }
}

/// Score design `d` over the band of `solid` (its speeds, one search per speed, in order).
pub fn score_design(
    spec: &LobeDesignSpec,
    d: &DesignPoint,
    solid: &SolidReference,
) -> Result<DesignRow, SimError> {
    let searches = design_searches(spec, d, solid)?;
    let mut row = DesignRow::from_searches(d, solid, &searches);
    chaos_spread(spec, &mut row)?;
    Ok(row)
}

/// Judge the damped run at `row`'s worst case (its worst width at its worst speed, from the
/// large disturbance) and set `worst_regime`; where it is chaotic, search the width at that
/// speed again over [`SPREAD_SEEDS`] seeded perturbations of the disturbance (±[`SPREAD_REL`])
/// and set `spread`, as the maps report chaotic points. Nothing without an acceptable width.
pub fn chaos_spread(spec: &LobeDesignSpec, row: &mut DesignRow) -> Result<(), SimError> {
    let (w, n) = (row.damped.worst_width_m, row.damped.worst_rpm);
    if w.is_nan() || w <= 0.0 {
        return Ok(());
    }
    let p = spec.problem(&row.point)?;
    let lin = linear_at(&p, &[n])?[0];
    let j = p.judge(
        BarKind::Damped,
        Disturbance::Large,
        w,
        n,
        lin.omega_damped_rad_s,
    )?;
    row.worst_regime = Some(j.regime);
    if j.regime == RevRegime::Chaotic {
        let (lo, mean, hi) = width_spread(&p, n, &lin, DAMPED_LARGE, SPREAD_SEEDS, SPREAD_REL)?;
        row.spread = Some(WidthSpread {
            min_width_m: lo,
            mean_width_m: mean,
            max_width_m: hi,
        });
    }
    Ok(())
}

/// The whole study: the solid reference once, then every design of `grid` (in parallel on
/// `runner`; progress counts the speeds of the reference, then the designs).
pub fn lobe_design(
    spec: &LobeDesignSpec,
    grid: &DesignGrid,
    rpms: &[f64],
    runner: &Runner,
) -> Result<(SolidReference, Vec<DesignRow>), BatchError<SimError>> {
    if grid.axis() != spec.axis {
        return Err(BatchError::Param(ParamError::OutOfRange {
            field: "design axis (--ball-masses-g or --positions-mm)",
            value: 0.0,
            allowed: "the axis of the study",
        }));
    }
    let points = grid.points();
    // Every design checked before any run, naming the field.
    for d in &points {
        spec.problem(d)?;
    }
    let total = rpms.len() + points.len();
    let first = |done: usize, _: usize| (runner.progress)(done, total);
    let solid = solid_reference(&spec.base, rpms, &runner.with_progress(&first))?;
    let second = |done: usize, _: usize| (runner.progress)(rpms.len() + done, total);
    let rows = runner
        .with_progress(&second)
        .each(&points, |d| score_design(spec, d, &solid))?;
    Ok((solid, rows))
}

/// The optimum of `rows`: the largest worst-case width; ties go to the larger mean, then to
/// the smaller index. `None` for no rows.
pub fn optimum(rows: &[DesignRow]) -> Option<&DesignRow> {
    rows.iter().reduce(|best, r| {
        let better = r
            .damped
            .worst_width_m
            .total_cmp(&best.damped.worst_width_m)
            .then(r.damped.mean_width_m.total_cmp(&best.damped.mean_width_m))
            .then(best.point.index.cmp(&r.point.index));
        if better.is_gt() {
            r
        } else {
            best
        }
    })
}
