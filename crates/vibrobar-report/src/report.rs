//! REPORT.md: every numerical claim of the paper beside our value. Data-driven: every number and
//! every verdict is computed from the runs; the rules are stated in the report.

use serde::Serialize;
use vibrobar_core::analysis::ensemble::{EnsembleStats, IcRanges};
use vibrobar_core::{FrictionModel, RunSettings};

use vibrobar_core::analysis::case::CaseOutcome;
use vibrobar_core::analysis::{SweepBase, SweepRow};
use vibrobar_core::params::STANDARD_GRAVITY_M_S2;
use vibrobar_io::csv::grid_num;

/// Percentage points within which a reduction counts as reproduced.
pub const REDUCTION_TOL_PP: f64 = 5.0;
/// Largest max/min RMS ratio over the band that counts as "flat".
pub const FLAT_MAX_RATIO: f64 = 1.25;
/// Impacts per cycle that count as "about two".
pub const TWO_PER_CYCLE: (f64, f64) = (1.5, 2.5);
/// Largest |damped/solid − 1| that counts as "same as the solid bar".
pub const SAME_AS_SOLID_TOL: f64 = 0.02;
/// Largest relative spread (std/mean) of the ensemble RMS that counts as "negligible variation".
pub const IC_SPREAD_TOL: f64 = 0.05;
/// Largest |ensemble mean / RMS from rest − 1| that counts as "negligible variation".
pub const IC_MEAN_TOL: f64 = 0.05;
/// Ratios of "impacts only at 0.99–1.01" and of the near-resonance robustness claim.
pub const IMPACT_BAND: [f64; 3] = [0.99, 1.0, 1.01];

/// Largest mean |Δ reduction| (percentage points) between `restitution` and `hertz` over the
/// sweep set for which instantaneous impacts count as an adequate model.
pub const CONTACT_MEAN_PP_TOL: f64 = 2.0;
/// Largest |Δ ensemble mean| / standard error at the chaotic points for the same claim.
pub const CONTACT_Z_TOL: f64 = 3.0;
/// Who checks the contact-law claim (its `Claim::by`).
pub const CONTACT_BY: &str = "exact: restitution vs hertz";
/// `by` of the claims checked on the bar that bends in two planes.
pub const TWO_PLANE_BY: &str = "two planes";
/// A one-plane answer survives in two planes when the two-plane ensemble mean stays within this
/// many percentage points of the one-plane mean.
pub const TWO_PLANE_TOL_PP: f64 = 10.0;

/// One design point of the two-plane check: the paper's bar and ball in a hole across the round
/// bar, frictionless walls, r = 1, reductions against the paper's solid bar.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TwoPlanePoint {
    /// Hole diameter, mm (the 15 mm ball).
    pub hole_mm: f64,
    /// Axial gap, mm.
    pub gap_mm: f64,
    /// The force's angle from the hole, degrees.
    pub force_deg: f64,
    /// The one-plane model from the same starts: mean reduction and its standard error, %.
    pub one_plane_pct: (f64, f64),
    /// Two planes: mean reduction and its standard error, %.
    pub two_plane_pct: (f64, f64),
    /// Members of the ensemble.
    pub members: usize,
    /// The solver of the two-plane runs.
    pub solver: String,
}

/// A percentage rounded to a whole number, without a "-0".
fn whole(x: f64) -> String {
    let r = x.round();
    if r == 0.0 {
        "0".into()
    } else {
        format!("{r:.0}")
    }
}

impl TwoPlanePoint {
    /// The one-plane answer survives here.
    pub fn survives(&self) -> bool {
        (self.two_plane_pct.0 - self.one_plane_pct.0).abs() <= TWO_PLANE_TOL_PP
    }
}

/// `restitution` against `hertz` on the lumped paper cases (issue #9 §5): the numbers behind the
/// claim "instantaneous impacts are an adequate model", one definition for `vibrobar
/// contact-laws` and `vibrobar paper`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ContactComparison {
    /// Points of the sweep set compared.
    pub points: usize,
    /// Mean |Δ reduction| over the sweep set, percentage points.
    pub mean_abs_pp: f64,
    /// Largest Δ (hertz − restitution), percentage points, and where.
    pub worst_pp: f64,
    /// Where the largest Δ is (`variant, gap, ratio`).
    pub worst_at: String,
    /// Largest |Δ ensemble mean| / standard error at the chaotic points.
    pub max_z: f64,
    /// Ensemble members per point.
    pub members: usize,
}

impl ContactComparison {
    /// Compare the sweep rows of the two laws (same points, same order) and their ensembles
    /// (same points, same order, `members` each).
    pub fn new(
        variants: &[Variant],
        restitution: &[SweepRow],
        hertz: &[SweepRow],
        ens_restitution: &[EnsembleStats],
        ens_hertz: &[EnsembleStats],
        members: usize,
    ) -> ContactComparison {
        let mut worst = (0.0f64, String::new());
        let mut sum_abs = 0.0;
        for (r, h) in restitution.iter().zip(hertz) {
            let key = variants
                .iter()
                .find(|v| v.friction == r.point.friction && v.force_n == r.point.friction_force_n)
                .map_or("?".to_string(), |v| v.key.clone());
            let delta = h.reduction_pct() - r.reduction_pct();
            sum_abs += delta.abs();
            if delta.abs() > worst.0.abs() {
                worst = (
                    delta,
                    format!("{key}, {} mm, r = {}", r.point.gap_m * 1e3, r.point.ratio),
                );
            }
        }
        let max_z = ens_restitution
            .iter()
            .zip(ens_hertz)
            .map(|(r, h)| Self::z(r, h, members).abs())
            .fold(0.0, f64::max);
        ContactComparison {
            points: restitution.len(),
            mean_abs_pp: sum_abs / restitution.len().max(1) as f64,
            worst_pp: worst.0,
            worst_at: worst.1,
            max_z,
            members,
        }
    }

    /// `(mean_h − mean_r)/s.e.` of one ensemble pair.
    pub fn z(r: &EnsembleStats, h: &EnsembleStats, members: usize) -> f64 {
        let se = ((r.std_rms_m.powi(2) + h.std_rms_m.powi(2)) / members.max(1) as f64).sqrt();
        (h.mean_rms_m - r.mean_rms_m) / se.max(f64::MIN_POSITIVE)
    }

    /// Whether instantaneous impacts are an adequate model by the stated criterion.
    pub fn adequate(&self) -> bool {
        self.mean_abs_pp < CONTACT_MEAN_PP_TOL && self.max_z < CONTACT_Z_TOL
    }

    /// The criterion, in words.
    pub fn rule() -> String {
        format!(
            "mean |Δ reduction| < {CONTACT_MEAN_PP_TOL} points over the Figs. 3/5 sweep set and \
             every chaotic-point ensemble |Δ mean|/s.e. < {CONTACT_Z_TOL} (exact solver, lumped bar)"
        )
    }
}

/// What a parameter set is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Role {
    /// The paper's stated parameters.
    Stated,
    /// Changed parameters that reproduce the paper's figures.
    Reproducing,
    /// Physically consistent (dissipative) friction at the stated level.
    Physical,
}

/// A friction parameter set.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Variant {
    /// File-name key.
    pub key: String,
    /// Human label.
    pub label: String,
    /// Role.
    pub role: Role,
    /// Friction law.
    pub friction: FrictionModel,
    /// Override of the friction force (None: η/r·m_d·g).
    pub force_n: Option<f64>,
    /// Friction force level in N.
    pub level_n: f64,
}

/// Results of one solver.
#[derive(Debug, Clone)]
pub struct SolverData {
    /// Solver name.
    pub name: String,
    /// All sweep rows (every variant and gap).
    pub sweep: Vec<SweepRow>,
    /// Time histories at r = 1: (variant key, gap in m, outcome).
    pub histories: Vec<(String, f64, CaseOutcome)>,
    /// Wall time of this solver's runs, s.
    pub wall_s: f64,
}

/// Everything the report needs.
#[derive(Debug, Clone)]
pub struct ReportInput {
    /// Run settings of every run.
    pub settings: RunSettings,
    /// Frictionless set first, then the friction sets.
    pub variants: Vec<Variant>,
    /// One entry per solver.
    pub solvers: Vec<SolverData>,
    /// Ratios of the sweeps.
    pub ratios: Vec<f64>,
    /// Smoke-test settings (not the paper's).
    pub quick: bool,
    /// Files written, relative to the output directory.
    pub files: Vec<String>,
    /// Initial-condition ensemble (None: skipped).
    pub ensemble: Option<IcEnsemble>,
    /// `restitution` against `hertz` on the same cases (None: skipped).
    pub contact: Option<ContactComparison>,
    /// The gap claims on the bar that bends in two planes (None: skipped).
    pub two_plane: Option<Vec<TwoPlanePoint>>,
}

/// One point of the initial-condition ensemble.
#[derive(Debug, Clone)]
pub struct IcPoint {
    /// Key of the parameter set.
    pub variant_key: String,
    /// Gap.
    pub gap_m: f64,
    /// Frequency ratio.
    pub ratio: f64,
    /// Damped RMS from the paper's start (bar at rest, ball centred at rest), same solver.
    pub rest_rms_m: f64,
    /// Impacts per cycle in the RMS window from the paper's start.
    pub rest_impacts_per_cycle: f64,
    /// Ensemble statistics.
    pub stats: EnsembleStats,
}

impl IcPoint {
    /// std/mean of the damped RMS over the members.
    pub fn rel_spread(&self) -> f64 {
        self.stats.std_rms_m / self.stats.mean_rms_m
    }

    /// Ensemble mean over the RMS from rest, minus 1.
    pub fn mean_vs_rest(&self) -> f64 {
        self.stats.mean_rms_m / self.rest_rms_m - 1.0
    }

    /// Fraction of members with ≥ 1 impact in the RMS window.
    pub fn impacting_fraction(&self) -> f64 {
        self.stats.impacting_members as f64 / self.stats.members as f64
    }

    fn robust(&self) -> bool {
        self.rel_spread() <= IC_SPREAD_TOL && self.mean_vs_rest().abs() <= IC_MEAN_TOL
    }
}

/// The seeded initial-condition ensemble of the paper run.
#[derive(Debug, Clone)]
pub struct IcEnsemble {
    /// Solver of every ensemble run.
    pub solver: String,
    /// Seed.
    pub seed: u64,
    /// Members per point.
    pub members: usize,
    /// Ranges of the initial conditions.
    pub ranges: IcRanges,
    /// Points: frictionless gap 0.1 mm at every ratio, each friction set at gap 1.0 mm, r = 1.
    pub points: Vec<IcPoint>,
    /// Wall time of the ensemble runs, s.
    pub wall_s: f64,
}

impl IcEnsemble {
    fn at(&self, v: &Variant, gap_m: f64, ratio: f64) -> Option<&IcPoint> {
        self.points
            .iter()
            .find(|p| p.variant_key == v.key && close(p.gap_m, gap_m) && close(p.ratio, ratio))
    }
}

/// Our value for one parameter set and solver.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Finding {
    /// Value, formatted.
    pub value: String,
    /// Whether the claim holds.
    pub holds: bool,
}

/// One row of the table: a claim under one parameter set.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ClaimRow {
    /// Parameter-set label.
    pub params: String,
    /// Role of the set.
    pub role: Role,
    /// One finding per solver.
    pub findings: Vec<Finding>,
}

/// A claim of the paper.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Claim {
    /// Short id.
    pub id: String,
    /// The claim.
    pub text: String,
    /// The paper's value.
    pub paper: String,
    /// Rule that decides "holds".
    pub rule: String,
    /// Rows.
    pub rows: Vec<ClaimRow>,
    /// What computed the findings when it is not one solver per column (then each row has one
    /// finding), e.g. `exact ensemble`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub by: Option<String>,
}

impl Claim {
    /// Verdict per solver: reproduced (stated parameters), reproduced only with …, or not.
    pub fn verdicts(&self) -> Vec<String> {
        let n = self.rows.first().map_or(0, |r| r.findings.len());
        (0..n)
            .map(|i| {
                let stated = self
                    .rows
                    .iter()
                    .any(|r| r.role == Role::Stated && r.findings[i].holds);
                if stated {
                    return "reproduced".to_string();
                }
                let others: Vec<&str> = self
                    .rows
                    .iter()
                    .filter(|r| r.role != Role::Stated && r.findings[i].holds)
                    .map(|r| r.params.as_str())
                    .collect();
                if others.is_empty() {
                    "not reproduced".to_string()
                } else {
                    format!("reproduced only with {}", others.join("; "))
                }
            })
            .collect()
    }
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-6
}

impl SolverData {
    fn rows(&self, v: &Variant, gap_m: f64) -> Vec<&SweepRow> {
        self.sweep
            .iter()
            .filter(|r| {
                r.point.friction == v.friction
                    && r.point.friction_force_n == v.force_n
                    && close(r.point.gap_m, gap_m)
            })
            .collect()
    }

    fn at(&self, v: &Variant, gap_m: f64, ratio: f64) -> Option<&SweepRow> {
        self.rows(v, gap_m)
            .into_iter()
            .find(|r| close(r.point.ratio, ratio))
    }
}

fn fmt_ratio(r: f64) -> String {
    format!("{r:.2}")
}

/// A ratio with sensible digits.
fn human(x: f64) -> String {
    if x >= 10.0 {
        format!("{x:.0}")
    } else if x >= 0.1 {
        format!("{x:.2}")
    } else {
        format!("{x:.1e}")
    }
}

fn pct_vs(x: f64, paper: f64) -> String {
    format!("{x:.1} % ({:+.1} pp)", x - paper)
}

fn pct(x: f64) -> String {
    format!("{x:.1} %")
}

/// Evaluate every claim.
pub fn claims(input: &ReportInput) -> Vec<Claim> {
    let none = input
        .variants
        .iter()
        .find(|v| v.friction == FrictionModel::None)
        .cloned();
    let fric: Vec<Variant> = input
        .variants
        .iter()
        .filter(|v| v.friction != FrictionModel::None)
        .cloned()
        .collect();
    let mut out = Vec::new();
    let claim = |id: &str,
                 text: &str,
                 paper: &str,
                 rule: String,
                 variants: &[Variant],
                 f: &dyn Fn(&SolverData, &Variant) -> Finding|
     -> Claim {
        Claim {
            id: id.to_string(),
            text: text.to_string(),
            paper: paper.to_string(),
            rule,
            rows: variants
                .iter()
                .map(|v| ClaimRow {
                    params: v.label.clone(),
                    role: v.role,
                    findings: input.solvers.iter().map(|s| f(s, v)).collect(),
                })
                .collect(),
            by: None,
        }
    };
    let missing = || Finding {
        value: "n/a (not computed)".into(),
        holds: false,
    };
    let below: Vec<f64> = input
        .ratios
        .iter()
        .copied()
        .filter(|&r| r < 0.98 - 1e-9)
        .collect();

    if let Some(none) = none {
        let nv = std::slice::from_ref(&none);
        out.push(claim(
            "F1",
            "RMS reduction at resonance (r = 1), gap 0.1 mm, frictionless",
            "83 %",
            format!("within ±{REDUCTION_TOL_PP} percentage points"),
            nv,
            &|s, v| match s.at(v, 0.1e-3, 1.0) {
                Some(r) => Finding {
                    value: pct_vs(r.reduction_pct(), 83.0),
                    holds: (r.reduction_pct() - 83.0).abs() <= REDUCTION_TOL_PP,
                },
                None => missing(),
            },
        ));
        out.push(claim(
            "F2",
            "Impacts only at r = 0.99, 1.00, 1.01 (gap 0.1 mm, frictionless)",
            "0.99–1.01",
            "the ratios with ≥ 1 impact are exactly 0.99, 1.00, 1.01".into(),
            nv,
            &|s, v| {
                let rows = s.rows(v, 0.1e-3);
                let hit: Vec<f64> = rows
                    .iter()
                    .filter(|r| r.damped.impacts > 0)
                    .map(|r| r.point.ratio)
                    .collect();
                let want = [0.99, 1.0, 1.01];
                Finding {
                    value: if hit.is_empty() {
                        "no impacts at any ratio".into()
                    } else {
                        hit.iter()
                            .map(|&r| fmt_ratio(r))
                            .collect::<Vec<_>>()
                            .join(", ")
                    },
                    holds: hit.len() == want.len()
                        && hit.iter().zip(want).all(|(&a, b)| close(a, b)),
                }
            },
        ));
        out.push(claim(
            "F3",
            "No impacts for gaps ≥ 0.25 mm, frictionless (checked: 0.25, 0.5, 1.0 mm, every ratio)",
            "0 impacts",
            "zero impacts in every run".into(),
            nv,
            &|s, v| {
                let parts: Vec<(f64, u64)> = [0.25e-3, 0.5e-3, 1.0e-3]
                    .iter()
                    .map(|&g| (g, s.rows(v, g).iter().map(|r| r.damped.impacts).sum()))
                    .collect();
                let computed = [0.25e-3, 0.5e-3, 1.0e-3]
                    .iter()
                    .all(|&g| !s.rows(v, g).is_empty());
                Finding {
                    value: parts
                        .iter()
                        .map(|(g, n)| format!("{} mm: {n}", g * 1e3))
                        .collect::<Vec<_>>()
                        .join("; "),
                    holds: computed && parts.iter().all(|p| p.1 == 0),
                }
            },
        ));
        out.push(claim(
            "F4",
            "Gap 1.0 mm, frictionless: the damped bar responds like the solid bar",
            "curves coincide",
            format!(
                "max |RMS_damped/RMS_solid − 1| ≤ {:.0} % over the band",
                SAME_AS_SOLID_TOL * 100.0
            ),
            nv,
            &|s, v| {
                let rows = s.rows(v, 1.0e-3);
                let dev = rows
                    .iter()
                    .map(|r| (r.damped.rms_m / r.solid.rms_m - 1.0).abs())
                    .fold(0.0, f64::max);
                Finding {
                    value: format!("max deviation {:.2} %", dev * 100.0),
                    holds: !rows.is_empty() && dev <= SAME_AS_SOLID_TOL,
                }
            },
        ));
    }

    out.push(claim(
        "R1",
        "RMS reduction at resonance (r = 1) with friction, gap 1.0 mm",
        "56 %",
        format!("within ±{REDUCTION_TOL_PP} percentage points"),
        &fric,
        &|s, v| match s.at(v, 1.0e-3, 1.0) {
            Some(r) => Finding {
                value: pct_vs(r.reduction_pct(), 56.0),
                holds: (r.reduction_pct() - 56.0).abs() <= REDUCTION_TOL_PP,
            },
            None => missing(),
        },
    ));
    out.push(claim(
        "R2",
        "Near resonance both gaps give about the same reduction: gap 0.1 mm at r = 1, with friction",
        "≈ 56 %",
        format!("within ±{REDUCTION_TOL_PP} percentage points of 56 %"),
        &fric,
        &|s, v| match s.at(v, 0.1e-3, 1.0) {
            Some(r) => Finding {
                value: pct_vs(r.reduction_pct(), 56.0),
                holds: (r.reduction_pct() - 56.0).abs() <= REDUCTION_TOL_PP,
            },
            None => missing(),
        },
    ));
    out.push(claim(
        "R3",
        "Flat response over the band at gap 1.0 mm with friction",
        "RMS unchanged across ratios",
        format!("max/min of the damped RMS over the band ≤ {FLAT_MAX_RATIO}"),
        &fric,
        &|s, v| {
            let rows = s.rows(v, 1.0e-3);
            let (lo, hi) = rows.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), r| {
                (lo.min(r.damped.rms_m), hi.max(r.damped.rms_m))
            });
            let (slo, shi) = rows.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), r| {
                (lo.min(r.solid.rms_m), hi.max(r.solid.rms_m))
            });
            Finding {
                value: format!(
                    "max/min = {:.2} (RMS {:.2}–{:.2} µm; solid bar {:.2})",
                    hi / lo,
                    lo * 1e6,
                    hi * 1e6,
                    shi / slo
                ),
                holds: !rows.is_empty() && hi / lo <= FLAT_MAX_RATIO,
            }
        },
    ));
    out.push(claim(
        "R4",
        "Worse than the solid bar below r = 0.98 with friction (gaps 0.1 and 1.0 mm)",
        "damped RMS > solid RMS for r < 0.98",
        "damped RMS > solid RMS at every ratio < 0.98, both gaps".into(),
        &fric,
        &|s, v| {
            let mut parts = Vec::new();
            let mut all = !below.is_empty();
            for g in [1.0e-3, 0.1e-3] {
                let worse: Vec<String> = below
                    .iter()
                    .filter_map(|&r| s.at(v, g, r))
                    .filter(|r| r.damped.rms_m > r.solid.rms_m)
                    .map(|r| fmt_ratio(r.point.ratio))
                    .collect();
                all &= worse.len() == below.len();
                parts.push(format!(
                    "{} mm: worse at {}/{}",
                    g * 1e3,
                    worse.len(),
                    below.len()
                ));
            }
            Finding {
                value: parts.join("; "),
                holds: all,
            }
        },
    ));
    out.push(claim(
        "R5",
        "With friction, impacts across the whole ratio range at gap 0.1 mm",
        "impacts at every ratio",
        "≥ 1 impact at every ratio".into(),
        &fric,
        &|s, v| {
            let rows = s.rows(v, 0.1e-3);
            let n = rows.iter().filter(|r| r.damped.impacts > 0).count();
            Finding {
                value: format!("impacts at {n}/{} ratios", rows.len()),
                holds: !rows.is_empty() && n == rows.len(),
            }
        },
    ));
    out.push(claim(
        "R6",
        "About two impacts per forcing cycle at gap 1.0 mm, r = 1, with friction",
        "≈ 2 per cycle",
        format!(
            "{}–{} impacts per cycle in the RMS window",
            TWO_PER_CYCLE.0, TWO_PER_CYCLE.1
        ),
        &fric,
        &|s, v| match s.at(v, 1.0e-3, 1.0) {
            Some(r) => Finding {
                value: format!("{:.2} per cycle", r.damped.impacts_per_cycle),
                holds: r.damped.impacts_per_cycle >= TWO_PER_CYCLE.0
                    && r.damped.impacts_per_cycle <= TWO_PER_CYCLE.1,
            },
            None => missing(),
        },
    ));
    out.push(claim(
        "R7",
        "Gap 0.1 mm with friction: response shifted left, peak above the solid bar's",
        "leftward shift, higher peak",
        "damped peak RMS > solid peak RMS and the damped peak lies at r < 1".into(),
        &fric,
        &|s, v| {
            let rows = s.rows(v, 0.1e-3);
            let peak = rows
                .iter()
                .max_by(|a, b| a.damped.rms_m.total_cmp(&b.damped.rms_m));
            let solid_peak = rows.iter().map(|r| r.solid.rms_m).fold(0.0, f64::max);
            match peak {
                Some(p) => Finding {
                    value: format!(
                        "peak {:.2}× solid peak, at r = {}",
                        p.damped.rms_m / solid_peak,
                        fmt_ratio(p.point.ratio)
                    ),
                    holds: p.damped.rms_m > solid_peak && p.point.ratio < 1.0 - 1e-9,
                },
                None => missing(),
            }
        },
    ));
    out.push(claim(
        "R8",
        "Friction takes energy out of the system (\"part of the bar's energy is dissipated through dry friction\"), gap 1.0 mm, r = 1",
        "dissipates",
        "friction work ∫F_ball·ẇ dt < 0 over the run".into(),
        &fric,
        &|s, v| match s.at(v, 1.0e-3, 1.0) {
            Some(r) => Finding {
                value: format!(
                    "{:+.3e} J ({})",
                    r.friction_work_j,
                    if r.friction_work_j > 0.0 {
                        "puts energy in"
                    } else {
                        "takes energy out"
                    }
                ),
                holds: r.friction_work_j < 0.0,
            },
            None => missing(),
        },
    ));
    let none_v = input
        .variants
        .iter()
        .find(|v| v.friction == FrictionModel::None)
        .cloned();
    if let Some(nv) = none_v {
        out.push(claim(
            "R9",
            "Frictionless damping at resonance exceeds the damping with friction (neglecting friction overestimates damping)",
            "83 % vs 56 %",
            format!(
                "reduction at r = 1: frictionless 0.1 mm exceeds the best friction gap (0.1, 1.0 mm) \
                 by more than {REDUCTION_TOL_PP} percentage points"
            ),
            &fric,
            &|s, v| {
                let f = s.at(&nv, 0.1e-3, 1.0).map(|r| r.reduction_pct());
                let best = [0.1e-3, 1.0e-3]
                    .iter()
                    .filter_map(|&g| s.at(v, g, 1.0))
                    .map(|r| r.reduction_pct())
                    .fold(f64::NEG_INFINITY, f64::max);
                match f {
                    Some(f) if best.is_finite() => Finding {
                        value: format!("{} vs {} ({:+.1} pp)", pct(f), pct(best), f - best),
                        holds: f - best > REDUCTION_TOL_PP,
                    },
                    _ => missing(),
                }
            },
        ));
    }
    out.extend(ic_claims(input));
    if let Some(c) = &input.contact {
        out.push(Claim {
            id: "C1".into(),
            text: "Instantaneous impacts are an adequate model (the paper's Eqs. 4–5 against a \
                   compliant Hertz contact calibrated to the same e)"
                .into(),
            paper: "assumed".into(),
            rule: ContactComparison::rule(),
            rows: vec![ClaimRow {
                params: "all sets, lumped bar".into(),
                role: Role::Stated,
                findings: vec![Finding {
                    value: format!(
                        "mean |Δ| {:.2} points over {} points (largest {:+.2} at {}); ensembles \
                         ({} members) up to {:.1} s.e.",
                        c.mean_abs_pp, c.points, c.worst_pp, c.worst_at, c.members, c.max_z
                    ),
                    holds: c.adequate(),
                }],
            }],
            by: Some(CONTACT_BY.into()),
        });
    }
    if let Some(points) = &input.two_plane {
        for (id, gap_mm, text, paper) in [
            (
                "T1",
                1.0,
                "The 1.0 mm gap gives little reduction at resonance (frictionless)",
                "one-plane model",
            ),
            (
                "T2",
                0.1,
                "The 0.1 mm gap damps strongly at resonance (frictionless)",
                "one-plane model",
            ),
        ] {
            let rows: Vec<ClaimRow> = points
                .iter()
                .filter(|p| (p.gap_mm - gap_mm).abs() < 1e-12)
                .map(|p| ClaimRow {
                    params: format!(
                        "{} mm hole, force at {}° from the hole ({} members, {})",
                        p.hole_mm, p.force_deg, p.members, p.solver
                    ),
                    role: Role::Physical,
                    findings: vec![Finding {
                        value: format!(
                            "one plane {} ± {} %, two planes {} ± {} %",
                            whole(p.one_plane_pct.0),
                            whole(p.one_plane_pct.1),
                            whole(p.two_plane_pct.0),
                            whole(p.two_plane_pct.1)
                        ),
                        holds: p.survives(),
                    }],
                })
                .collect();
            if rows.is_empty() {
                continue;
            }
            out.push(Claim {
                id: id.into(),
                text: text.into(),
                paper: paper.into(),
                rule: format!(
                    "the paper's bar and ball in a hole across the round bar (gravity at 90°, r = \
                     1): the two-plane ensemble mean within {TWO_PLANE_TOL_PP} points of the \
                     one-plane mean from the same starts"
                ),
                rows,
                by: Some(TWO_PLANE_BY.into()),
            });
        }
    }
    out
}

/// The claims about initial conditions, from the ensemble (none when it was skipped).
fn ic_claims(input: &ReportInput) -> Vec<Claim> {
    let Some(e) = &input.ensemble else {
        return Vec::new();
    };
    let none: Vec<&Variant> = input
        .variants
        .iter()
        .filter(|v| v.friction == FrictionModel::None)
        .collect();
    let fric: Vec<&Variant> = input
        .variants
        .iter()
        .filter(|v| v.friction != FrictionModel::None)
        .collect();
    let claim = |id: &str, text: &str, paper: &str, rule: String, rows: Vec<ClaimRow>| Claim {
        id: id.to_string(),
        text: text.to_string(),
        paper: paper.to_string(),
        rule,
        rows,
        by: Some(format!("{} ensemble", e.solver)),
    };
    let row = |v: &Variant, finding: Finding| ClaimRow {
        params: v.label.clone(),
        role: v.role,
        findings: vec![finding],
    };
    // Spread and mean-vs-rest at each ratio; holds when every ratio was computed and passes.
    let robust = |v: &Variant, gap_m: f64, ratios: &[f64]| -> Finding {
        let pts: Vec<Option<&IcPoint>> = ratios.iter().map(|&r| e.at(v, gap_m, r)).collect();
        Finding {
            value: ratios
                .iter()
                .zip(&pts)
                .map(|(&r, p)| match p {
                    Some(p) => format!(
                        "r = {}: spread {:.1} %, mean {:+.1} % vs rest",
                        fmt_ratio(r),
                        100.0 * p.rel_spread(),
                        100.0 * p.mean_vs_rest()
                    ),
                    None => format!("r = {}: n/a", fmt_ratio(r)),
                })
                .collect::<Vec<_>>()
                .join("; "),
            holds: pts.iter().all(|p| p.is_some_and(IcPoint::robust)),
        }
    };
    let rule = |at: &str| {
        format!(
            "at {at}: std/mean of the ensemble RMS ≤ {:.0} % and |ensemble mean / RMS from rest − 1| ≤ {:.0} %",
            IC_SPREAD_TOL * 100.0,
            IC_MEAN_TOL * 100.0
        )
    };
    let mut out = Vec::new();
    if !none.is_empty() {
        let band = IMPACT_BAND
            .iter()
            .map(|&r| fmt_ratio(r))
            .collect::<Vec<_>>()
            .join(", ");
        out.push(claim(
            "F5",
            "Robust to initial conditions near resonance (gap 0.1 mm, frictionless): \"negligible variation in RMS values\"",
            "negligible variation",
            rule(&format!("r = {band}")),
            none.iter().map(|v| row(v, robust(v, 0.1e-3, &IMPACT_BAND))).collect(),
        ));
        out.push(claim(
            "F6",
            "Impacts only at r = 0.99–1.01 also for perturbed starts (gap 0.1 mm, frictionless): \"results remained consistent\"",
            "0.99–1.01",
            "at every ratio outside 0.99–1.01, no member has an impact in the RMS window \
             (shown: impacting members / members, per ratio)"
                .into(),
            none.iter()
                .map(|v| {
                    let mut pts: Vec<&IcPoint> = e
                        .points
                        .iter()
                        .filter(|p| p.variant_key == v.key && close(p.gap_m, 0.1e-3))
                        .collect();
                    pts.sort_by(|a, b| a.ratio.total_cmp(&b.ratio));
                    let outside: Vec<&&IcPoint> = pts
                        .iter()
                        .filter(|p| !IMPACT_BAND.iter().any(|&r| close(p.ratio, r)))
                        .collect();
                    row(
                        v,
                        Finding {
                            value: if pts.is_empty() {
                                "n/a (not computed)".into()
                            } else {
                                pts.iter()
                                    .map(|p| {
                                        format!(
                                            "{}: {}/{}",
                                            fmt_ratio(p.ratio),
                                            p.stats.impacting_members,
                                            p.stats.members
                                        )
                                    })
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            },
                            holds: !outside.is_empty()
                                && outside.iter().all(|p| p.stats.impacting_members == 0),
                        },
                    )
                })
                .collect(),
        ));
    }
    if !fric.is_empty() {
        out.push(claim(
            "R10",
            "With friction, \"almost no changes\" with the initial conditions (gap 1.0 mm, r = 1)",
            "almost no changes",
            rule("r = 1.00"),
            fric.iter()
                .map(|v| row(v, robust(v, 1.0e-3, &[1.0])))
                .collect(),
        ));
    }
    out
}

/// The section on the initial-condition ensemble: what was drawn, the claims, every point.
/// One table row per finding of `claims`: id, claim, paper, rule, (the row's parameters when
/// `with_params`), the finding and whether it holds.
fn finding_rows(s: &mut String, claims: &[&Claim], with_params: bool, yes: &str, no: &str) {
    use std::fmt::Write as _;
    for c in claims {
        for row in &c.rows {
            for f in &row.findings {
                let _ = write!(
                    s,
                    "| {} | {} | {} | {} |",
                    c.id,
                    cell(&c.text),
                    cell(&c.paper),
                    cell(&c.rule)
                );
                if with_params {
                    let _ = write!(s, " {} |", cell(&row.params));
                }
                let _ = writeln!(
                    s,
                    " {} | {} |",
                    cell(&f.value),
                    if f.holds { yes } else { no }
                );
            }
        }
    }
}

fn render_ensemble(s: &mut String, input: &ReportInput, e: &IcEnsemble, claims: &[&Claim]) {
    use std::fmt::Write;
    let r = &e.ranges;
    // `scale` converts SI to the unit shown; 4 decimals, trailing zeros dropped.
    let num = |x: f64| {
        let t = format!("{x:.4}");
        t.trim_end_matches('0').trim_end_matches('.').to_string()
    };
    let span = |(lo, hi): (f64, f64), scale: f64, unit: &str| {
        let (lo, hi) = (lo * scale, hi * scale);
        let t = if hi - lo == 0.0 {
            format!("{} {unit}", num(lo))
        } else {
            format!("uniform in [{}, {}] {unit}", num(lo), num(hi))
        };
        t.trim_end().to_string()
    };
    let _ = writeln!(
        s,
        "\n## Robustness to initial conditions\n\n\
         The paper repeats its runs \"with nonzero initial values of bar displacement and relative \
         velocity\" and reports \"negligible variation in RMS values\" (frictionless) and \"almost no \
         changes\" (with friction). We repeat each point below from {} seeded random initial states \
         (seed {}; the same members at every point):\n\n\
         - bar displacement u0: {} (±F0/K of the bar with the cavity);\n\
         - bar velocity u̇0: {};\n\
         - ball position w0/l_g: {} (anywhere in the cavity);\n\
         - relative velocity ẇ0: {}.\n\n\
         Every ensemble run uses the `{}` solver, whatever `--solvers` says (with `rk4` the {} runs \
         would take minutes). *From rest* is the same solver from the paper's start (bar at rest, \
         ball centred at rest). A member *impacts* when it has ≥ 1 impact in the RMS window (the \
         last {:.0} % of the run): with a relative velocity the ball hits a wall within the first \
         milliseconds of any run in a 0.1 mm cavity, so impacts of the start-up transient are not \
         counted. Per-point statistics: `ic_ensemble.csv`.\n",
        e.members,
        e.seed,
        span(r.u_m, 1e6, "µm"),
        span(r.du_m_s, 1e3, "mm/s"),
        span(r.w_over_half_gap, 1.0, ""),
        span(r.dw_m_s, 1e3, "mm/s"),
        e.solver,
        e.points.len() * e.members,
        input.settings.rms_fraction * 100.0
    );
    let _ = writeln!(
        s,
        "| # | Claim | Paper | Rule | Parameters | {0} ensemble: ours | {0} ensemble: holds |\n\
         |---|---|---|---|---|---|---|",
        e.solver
    );
    for c in claims {
        for row in &c.rows {
            for f in &row.findings {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {} | {} |",
                    c.id,
                    cell(&c.text),
                    cell(&c.paper),
                    cell(&c.rule),
                    cell(&row.params),
                    cell(&f.value),
                    if f.holds { "yes" } else { "no" }
                );
            }
        }
    }
    let _ = writeln!(
        s,
        "\n| Parameters | Gap | Ratio | RMS from rest (µm) | From rest: impacts/cycle | Ensemble mean (µm) | std/mean | \
         Mean vs rest | Min–max (µm) | Impacting members | Regimes |\n\
         |---|---|---|---|---|---|---|---|---|---|---|"
    );
    for p in &e.points {
        let label = input
            .variants
            .iter()
            .find(|v| v.key == p.variant_key)
            .map_or(p.variant_key.as_str(), |v| v.label.as_str());
        let regimes: Vec<String> = p
            .stats
            .regimes
            .iter()
            .map(|(r, n)| format!("{r}:{n}"))
            .collect();
        let _ = writeln!(
            s,
            "| {} | {} mm | {} | {:.3} | {:.2} | {:.3} | {:.1} % | {:+.1} % | {:.3}–{:.3} | {}/{} | {} |",
            cell(label),
            p.gap_m * 1e3,
            fmt_ratio(p.ratio),
            p.rest_rms_m * 1e6,
            p.rest_impacts_per_cycle,
            p.stats.mean_rms_m * 1e6,
            100.0 * p.rel_spread(),
            100.0 * p.mean_vs_rest(),
            p.stats.min_rms_m * 1e6,
            p.stats.max_rms_m * 1e6,
            p.stats.impacting_members,
            p.stats.members,
            regimes.join(" ")
        );
    }
    // Where the paper's start never reaches a wall but perturbed starts do.
    let quiet: Vec<&IcPoint> = e
        .points
        .iter()
        .filter(|p| p.rest_impacts_per_cycle == 0.0 && p.stats.impacting_members > 0)
        .collect();
    if !quiet.is_empty() {
        let (lo, hi) = quiet
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| {
                (a.0.min(p.mean_vs_rest()), a.1.max(p.mean_vs_rest()))
            });
        let _ = writeln!(
            s,
            "\nAt {} point(s) the run from the paper's start has no impact in the RMS window while \
             {} of {} perturbed members do; there the ensemble mean RMS is {:+.1} … {:+.1} % off \
             the RMS from rest.",
            quiet.len(),
            quiet
                .iter()
                .map(|p| p.stats.impacting_members)
                .sum::<usize>(),
            quiet.iter().map(|p| p.stats.members).sum::<usize>(),
            100.0 * lo,
            100.0 * hi
        );
    }
}

/// A table cell: `|` would end the cell.
fn cell(s: &str) -> String {
    s.replace('|', "\\|")
}

/// Render REPORT.md.
pub fn render(input: &ReportInput, claims: &[Claim], total_wall_s: f64) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let st = &input.settings;
    let solvers: Vec<&str> = input.solvers.iter().map(|s| s.name.as_str()).collect();
    let _ = writeln!(
        s,
        "# vibrobar: reproduction of the paper's numerical claims\n"
    );
    let _ = writeln!(
        s,
        "Paper: *The effect of rolling friction on vibro-impact damped boring bars*. Generated by \
         `vibrobar paper` (vibrobar {}). Every number below is computed by this run; verdicts follow \
         the rules in the table.\n",
        crate::VERSION
    );
    if input.quick || (st.duration_s - 2.0).abs() > 1e-12 || (st.dt_s - 1e-6).abs() > 1e-18 {
        let _ = writeln!(
            s,
            "> **Warning: these are NOT the paper's run settings** ({} s at dt = {} s). Use the \
             numbers only as a smoke test.\n",
            st.duration_s, st.dt_s
        );
    }
    let _ = writeln!(s, "## Run settings\n");
    let _ = writeln!(
        s,
        "- Every run: {} s simulated from rest with the ball centred (except the initial-condition \
         ensemble), dt = {:e} s, RMS over the last {:.0} %.",
        st.duration_s,
        st.dt_s,
        st.rms_fraction * 100.0
    );
    let _ = writeln!(
        s,
        "- Solver(s): {}. `rk4` is the paper's scheme (classical RK4, fixed step, impact applied \
         after the step in which `|w| ≥ l_g`).",
        solvers.join(", ")
    );
    let _ =
        writeln!(
        s,
        "- Paper parameters: bar with cavity M = 0.644 kg, K = 9.22 MN/m; solid bar M = 0.668 kg, \
         K = 9.26 MN/m; ζ = 0.01; ball 26 g, r = 7.5 mm, e = 0.5, η = 0.6 mm; F0 = 15 N; ratios \
         {}–{} (against each bar's own √(K/M))."
    ,
        input.ratios.first().map_or(String::new(), |r| fmt_ratio(*r)),
        input.ratios.last().map_or(String::new(), |r| fmt_ratio(*r))
    );
    let _ = writeln!(s, "- Parameter sets:");
    for v in &input.variants {
        let _ = writeln!(
            s,
            "  - **{}**: friction `{}`, |F| = {:.4} N.",
            v.label, v.friction, v.level_n
        );
    }
    let _ = writeln!(
        s,
        "- **The as-published friction sign injects energy.** The paper's Eq. 2 gives the ball \
         F_ball = +F sgn(ẇ), so the friction power F_ball·ẇ = F|ẇ| ≥ 0: friction pushes the ball \
         along its relative motion. `coulomb` uses the dissipative sign −F sgn(ẇ) with sticking \
         (\"physically consistent\"). At the stated F = 0.0204 N the paper's friction figures are \
         not reproduced; with the as-published sign at {} N they are (see the table).",
        input
            .variants
            .iter()
            .find(|v| v.role == Role::Reproducing)
            .map_or("—".to_string(), |v| format!("{}", v.level_n))
    );
    if solvers.contains(&"rk4") {
        let _ = writeln!(
            s,
            "- `rk4` has no sticking mode: with `coulomb` its sgn(ẇ) chatters about ẇ = 0 step by \
             step (a fixed-step scheme with a discontinuous right-hand side), so its `coulomb` \
             numbers approximate sticking rather than resolve it."
        );
    }
    let _ = writeln!(
        s,
        "- Friction work ∫F_ball·ẇ dt is summed over every segment the solver reports \
         (`SegmentIntegrals::friction_work_j`). For `rk4` it is ±F times the variation of w along \
         each step's cubic Hermite interpolant: an approximation, with O(dt) errors at the steps \
         where impacts are applied.\n"
    );

    let _ = writeln!(s, "## Summary\n");
    let mut head = "| # | Claim | Paper |".to_string();
    let mut sep = "|---|---|---|".to_string();
    for n in &solvers {
        let _ = write!(head, " {n}: verdict |");
        sep.push_str("---|");
    }
    let _ = writeln!(s, "{head}\n{sep}");
    let (per_solver, by_other): (Vec<&Claim>, Vec<&Claim>) =
        claims.iter().partition(|c| c.by.is_none());
    let (by_contact, by_other): (Vec<&Claim>, Vec<&Claim>) = by_other
        .into_iter()
        .partition(|c| c.by.as_deref() == Some(CONTACT_BY));
    let (by_two_plane, by_other): (Vec<&Claim>, Vec<&Claim>) = by_other
        .into_iter()
        .partition(|c| c.by.as_deref() == Some(TWO_PLANE_BY));
    for c in &per_solver {
        let _ = write!(s, "| {} | {} | {} |", c.id, cell(&c.text), cell(&c.paper));
        for v in c.verdicts() {
            let _ = write!(s, " {} |", cell(&v));
        }
        let _ = writeln!(s);
    }
    if let Some(e) = &input.ensemble {
        let _ = writeln!(
            s,
            "\nChecked with the initial-condition ensemble (solver `{}` whatever the solvers \
             above; see *Robustness to initial conditions*):\n\n\
             | # | Claim | Paper | {} ensemble: verdict |\n|---|---|---|---|",
            e.solver, e.solver
        );
        for c in &by_other {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} |",
                c.id,
                cell(&c.text),
                cell(&c.paper),
                cell(&c.verdicts().join(" "))
            );
        }
    }
    if !by_contact.is_empty() {
        let _ = writeln!(
            s,
            "\nChecked against the compliant contact law (`{CONTACT_BY}`, the cases and criterion \
             of `docs/contact-laws.md`, computed by this run):\n\n\
             | # | Claim | Paper | Rule | Ours | Holds |\n|---|---|---|---|---|---|"
        );
        finding_rows(&mut s, &by_contact, false, "yes", "**no**");
    }

    if !by_two_plane.is_empty() {
        let _ = writeln!(
            s,
            "\nChecked on the bar that bends in two planes (the round bar, the ball in a hole \
             across it with the axial gap along it and a radial clearance across it, the cutting \
             force at 63–72° from a radial hole; `docs/two-plane.md`, computed by this run). The \
             paper's model is one-plane:\n\n\
             | # | Claim | Paper | Rule | Where | Ours | Survives |\n|---|---|---|---|---|---|---|"
        );
        finding_rows(&mut s, &by_two_plane, true, "yes", "**no**");
    }

    let _ = writeln!(s, "\n## Claims, parameter set by parameter set\n");
    let mut head = "| # | Claim | Paper | Rule | Parameters |".to_string();
    let mut sep = "|---|---|---|---|---|".to_string();
    for n in &solvers {
        let _ = write!(head, " {n}: ours | {n}: holds |");
        sep.push_str("---|---|");
    }
    let _ = writeln!(s, "{head}\n{sep}");
    for c in &per_solver {
        for row in &c.rows {
            let _ = write!(
                s,
                "| {} | {} | {} | {} | {} |",
                c.id,
                cell(&c.text),
                cell(&c.paper),
                cell(&c.rule),
                cell(&row.params)
            );
            for f in &row.findings {
                let _ = write!(
                    s,
                    " {} | {} |",
                    cell(&f.value),
                    if f.holds { "yes" } else { "no" }
                );
            }
            let _ = writeln!(s);
        }
    }

    if let Some(e) = &input.ensemble {
        render_ensemble(&mut s, input, e, &by_other);
    }

    let _ = writeln!(
        s,
        "\n## Energy: friction work per run (gap 1.0 mm and 0.1 mm)\n"
    );
    let _ = writeln!(
        s,
        "Positive = friction put energy into the bar–ball system; negative = it took energy out.\n"
    );
    let mut head = "| Parameters | Gap |".to_string();
    let mut sep = "|---|---|".to_string();
    for n in &solvers {
        let _ = write!(head, " {n}: W at r = 1 (J) | {n}: W over the band (J) |");
        sep.push_str("---|---|");
    }
    let _ = writeln!(s, "{head}\n{sep}");
    for v in input
        .variants
        .iter()
        .filter(|v| v.friction != FrictionModel::None)
    {
        for g in [1.0e-3, 0.1e-3] {
            let _ = write!(s, "| {} | {} mm |", v.label, g * 1e3);
            for sd in &input.solvers {
                let rows = sd.rows(v, g);
                let at1 = sd
                    .at(v, g, 1.0)
                    .map_or("n/a".into(), |r| format!("{:+.3e}", r.friction_work_j));
                let (lo, hi) = rows
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |a, r| {
                        (a.0.min(r.friction_work_j), a.1.max(r.friction_work_j))
                    });
                let _ = write!(s, " {at1} | {lo:+.3e} … {hi:+.3e} |");
            }
            let _ = writeln!(s);
        }
    }

    if let Some(sd) = input.solvers.first() {
        let _ = writeln!(
            s,
            "\n## Energy books of the r = 1 time-history runs ({})\n\n\
             Core `EnergyAudit` over the whole run, in J: ΔE_mech = forcing − viscous − impacts + \
             friction + residual.\n\n\
             | Parameters | Gap | Forcing work | Viscous loss | Impact loss | Friction work | ΔE_mech | Residual |\n\
             |---|---|---|---|---|---|---|---|",
            sd.name
        );
        for (key, gap_m, o) in &sd.histories {
            let label = input
                .variants
                .iter()
                .find(|v| &v.key == key)
                .map_or(key.as_str(), |v| v.label.as_str());
            if let Some(e) = o.energy {
                let _ = writeln!(
                    s,
                    "| {} | {} mm | {:+.4e} | {:.4e} | {:.4e} | {:+.4e} | {:+.4e} | {:+.2e} |",
                    cell(label),
                    gap_m * 1e3,
                    e.work_input_j,
                    e.viscous_loss_j,
                    e.impact_loss_j,
                    e.friction_work_j,
                    e.delta_mechanical_j,
                    e.residual_j
                );
            }
        }
    }

    if let Some(sd) = input.solvers.first() {
        s.push('\n');
        for (key, _, o) in &sd.histories {
            let label = input
                .variants
                .iter()
                .find(|v| &v.key == key)
                .map_or(key.as_str(), |v| v.label.as_str());
            if let Some(e) = o.energy.filter(|e| e.friction_work_j != 0.0) {
                let _ = writeln!(
                    s,
                    "- {label}: friction {} {:.3e} J, {}× the work of the cutting force.",
                    if e.friction_work_j > 0.0 {
                        "puts in"
                    } else {
                        "takes out"
                    },
                    e.friction_work_j.abs(),
                    human(e.friction_work_j.abs() / e.work_input_j.abs())
                );
            }
        }
    }

    let _ = writeln!(
        s,
        "\n## Sweep values (first solver: {})\n",
        solvers.first().unwrap_or(&"")
    );
    if let Some(sd) = input.solvers.first() {
        let mut head = "| Ratio | Solid RMS (µm) |".to_string();
        let mut sep = "|---|---|".to_string();
        let mut cols: Vec<(&Variant, f64)> = Vec::new();
        for v in &input.variants {
            for g in [0.1e-3, 1.0e-3] {
                if !sd.rows(v, g).is_empty() {
                    cols.push((v, g));
                    let _ = write!(head, " {}, {} mm |", v.label, g * 1e3);
                    sep.push_str("---|");
                }
            }
        }
        let _ = writeln!(
            s,
            "Damped RMS in µm (reduction vs the solid bar, impacts over the run).\n\n{head}\n{sep}"
        );
        for &r in &input.ratios {
            let solid = cols
                .iter()
                .find_map(|(v, g)| sd.at(v, *g, r))
                .map_or(f64::NAN, |x| x.solid.rms_m);
            let _ = write!(s, "| {} | {:.3} |", fmt_ratio(r), solid * 1e6);
            for (v, g) in &cols {
                match sd.at(v, *g, r) {
                    Some(x) => {
                        let _ = write!(
                            s,
                            " {:.3} ({:+.1} %, {}) |",
                            x.damped.rms_m * 1e6,
                            x.reduction_pct(),
                            x.damped.impacts
                        );
                    }
                    None => s.push_str(" n/a |"),
                }
            }
            let _ = writeln!(s);
        }
    }

    let _ = writeln!(s, "\n## Wall time\n");
    for sd in &input.solvers {
        let _ = writeln!(
            s,
            "- {}: {:.1} s for {} sweep rows and {} time histories",
            sd.name,
            sd.wall_s,
            sd.sweep.len(),
            sd.histories.len()
        );
    }
    if let Some(e) = &input.ensemble {
        let _ = writeln!(
            s,
            "- initial-condition ensemble ({}): {:.1} s for {} points × {} members",
            e.solver,
            e.wall_s,
            e.points.len(),
            e.members
        );
    }
    let _ = writeln!(s, "- total (including figures): {total_wall_s:.1} s");
    let _ = writeln!(s, "\n## Files\n");
    for f in &input.files {
        let _ = writeln!(s, "- `{f}`");
    }
    s
}

/// The parameter sets of the paper run.
pub fn variants(reproducing_n: f64) -> Vec<Variant> {
    let stated = vibrobar_core::Damper {
        friction: FrictionModel::AsPublished,
        ..SweepBase::paper().ball
    }
    .friction_level_n(STANDARD_GRAVITY_M_S2);
    let v = |key: &str, label: String, role, friction, force_n: Option<f64>| Variant {
        key: key.to_string(),
        label,
        role,
        friction,
        force_n,
        level_n: force_n.unwrap_or(if friction == FrictionModel::None {
            0.0
        } else {
            stated
        }),
    };
    vec![
        v(
            "frictionless",
            "frictionless (stated)".into(),
            Role::Stated,
            FrictionModel::None,
            None,
        ),
        v(
            "as-published_stated",
            format!("as published, F = {stated:.4} N (stated)"),
            Role::Stated,
            FrictionModel::AsPublished,
            None,
        ),
        v(
            &format!("as-published_{}N", grid_num(reproducing_n)),
            format!(
                "as published, F = {} N (reproduces the paper)",
                grid_num(reproducing_n)
            ),
            Role::Reproducing,
            FrictionModel::AsPublished,
            Some(reproducing_n),
        ),
        v(
            "coulomb_stated",
            format!("coulomb, F = {stated:.4} N (physically consistent)"),
            Role::Physical,
            FrictionModel::Coulomb,
            None,
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn claim(holds: &[(Role, bool)]) -> Claim {
        Claim {
            id: "X".into(),
            text: "t".into(),
            paper: "p".into(),
            rule: "r".into(),
            rows: holds
                .iter()
                .enumerate()
                .map(|(i, &(role, h))| ClaimRow {
                    params: format!("set{i}"),
                    role,
                    findings: vec![Finding {
                        value: String::new(),
                        holds: h,
                    }],
                })
                .collect(),
            by: None,
        }
    }

    #[test]
    fn verdicts_follow_the_rows() {
        use Role::*;
        assert_eq!(claim(&[(Stated, true)]).verdicts(), ["reproduced"]);
        assert_eq!(
            claim(&[(Stated, false), (Reproducing, true), (Physical, false)]).verdicts(),
            ["reproduced only with set1"]
        );
        assert_eq!(
            claim(&[(Stated, false), (Reproducing, true), (Physical, true)]).verdicts(),
            ["reproduced only with set1; set2"]
        );
        assert_eq!(
            claim(&[(Stated, false), (Reproducing, false)]).verdicts(),
            ["not reproduced"]
        );
    }

    #[test]
    fn gap_claims_in_two_planes_survive_within_ten_points() {
        let point = |hole_mm: f64, gap_mm: f64, one: f64, two: f64| TwoPlanePoint {
            hole_mm,
            gap_mm,
            force_deg: 63.4,
            one_plane_pct: (one, 1.0),
            two_plane_pct: (two, 0.4),
            members: 8,
            solver: "exact".into(),
        };
        let mut input = ic_input(&[(1.0, 4)], 0.01);
        input.two_plane = Some(vec![
            point(15.1, 1.0, 26.0, 66.0),
            point(15.1, 0.1, 79.0, 75.0),
            point(17.0, 0.1, 79.0, 25.0),
        ]);
        let cs = claims(&input);
        let get = |id: &str| cs.iter().find(|c| c.id == id).expect(id);
        let holds =
            |c: &Claim| -> Vec<bool> { c.rows.iter().map(|r| r.findings[0].holds).collect() };
        assert_eq!(holds(get("T1")), [false]);
        assert_eq!(holds(get("T2")), [true, false]);
        assert_eq!(get("T1").by.as_deref(), Some(TWO_PLANE_BY));
        // The edge of the rule: 10 points survive, 10.5 do not.
        assert!(point(15.1, 0.1, 70.0, 80.0).survives());
        assert!(!point(15.1, 0.1, 70.0, 80.5).survives());
        let text = render(&input, &cs, 1.0);
        assert!(text.contains("Checked on the bar that bends in two planes"));
        assert!(
            text.contains("one plane 26 ± 1 %, two planes 66 ± 0 %"),
            "{text}"
        );
        input.two_plane = None;
        assert!(!claims(&input).iter().any(|c| c.id.starts_with('T')));
    }

    fn ic_input(impacting: &[(f64, usize)], spread: f64) -> ReportInput {
        use vibrobar_core::analysis::map::{Axis, GridPoint};
        let variants = variants(20.0);
        let stats = |ratio: f64, k: usize, mean: f64| EnsembleStats {
            point: GridPoint {
                index: 0,
                coords: vec![(Axis::FreqRatio, ratio)],
            },
            members: 4,
            mean_rms_m: mean,
            std_rms_m: spread * mean,
            min_rms_m: mean,
            max_rms_m: mean,
            regimes: Vec::new(),
            impacting_members: k,
        };
        let mut points: Vec<IcPoint> = impacting
            .iter()
            .map(|&(ratio, k)| IcPoint {
                variant_key: "frictionless".into(),
                gap_m: 0.1e-3,
                ratio,
                rest_rms_m: 1e-5,
                rest_impacts_per_cycle: 0.0,
                stats: stats(ratio, k, 1.02e-5),
            })
            .collect();
        for v in variants
            .iter()
            .filter(|v| v.friction != FrictionModel::None)
        {
            points.push(IcPoint {
                variant_key: v.key.clone(),
                gap_m: 1e-3,
                ratio: 1.0,
                rest_rms_m: 2e-5,
                rest_impacts_per_cycle: 2.0,
                stats: stats(1.0, 4, 2e-5),
            });
        }
        ReportInput {
            settings: RunSettings::default(),
            variants,
            solvers: Vec::new(),
            ratios: vec![0.98, 0.99, 1.0, 1.01],
            quick: false,
            files: Vec::new(),
            ensemble: Some(IcEnsemble {
                solver: "exact".into(),
                seed: 1,
                members: 4,
                ranges: IcRanges {
                    u_m: (-1e-6, 1e-6),
                    du_m_s: (0.0, 0.0),
                    w_over_half_gap: (-1.0, 1.0),
                    dw_m_s: (-1e-3, 1e-3),
                },
                points,
                wall_s: 0.0,
            }),
            contact: None,
            two_plane: None,
        }
    }

    fn verdict(input: &ReportInput, id: &str) -> Vec<String> {
        claims(input)
            .into_iter()
            .find(|c| c.id == id)
            .unwrap_or_else(|| panic!("no claim {id}"))
            .verdicts()
    }

    #[test]
    fn initial_condition_claims_follow_their_rules() {
        let band = [(0.99, 4), (1.0, 4), (1.01, 4)];
        let quiet = [&[(0.98, 0)][..], &band].concat();
        let input = ic_input(&quiet, 0.03);
        assert_eq!(verdict(&input, "F5"), ["reproduced"]);
        assert_eq!(verdict(&input, "F6"), ["reproduced"]);
        assert_eq!(verdict(&input, "R10"), ["reproduced"]);
        // One member impacting outside the band breaks F6.
        let input = ic_input(&[&[(0.98, 1)][..], &band].concat(), 0.03);
        assert_eq!(verdict(&input, "F6"), ["not reproduced"]);
        // No ratio outside the band: nothing supports F6.
        assert_eq!(verdict(&ic_input(&band, 0.03), "F6"), ["not reproduced"]);
        // Spread above 5 % breaks F5 and R10.
        let input = ic_input(&quiet, 0.06);
        assert_eq!(verdict(&input, "F5"), ["not reproduced"]);
        assert_eq!(verdict(&input, "R10"), ["not reproduced"]);
        // Mean 2 % off the RMS from rest passes; 13 % off breaks F5.
        let mut off = ic_input(&quiet, 0.03);
        let e = off.ensemble.as_mut().unwrap();
        e.points[2].rest_rms_m = 0.9e-5;
        assert!((e.points[2].ratio - 1.0).abs() < 1e-12);
        assert_eq!(verdict(&off, "F5"), ["not reproduced"]);
        // The claims say who computed them.
        let c = claims(&input);
        assert!(c
            .iter()
            .filter(|c| ["F5", "F6", "R10"].contains(&c.id.as_str()))
            .all(|c| c.by.as_deref() == Some("exact ensemble")));
        // Skipped ensemble: no such claims.
        let mut none = ic_input(&quiet, 0.03);
        none.ensemble = None;
        assert!(claims(&none).iter().all(|c| c.by.is_none()));
        let md = render(
            &ic_input(&quiet, 0.03),
            &claims(&ic_input(&quiet, 0.03)),
            0.0,
        );
        assert!(md.contains("| F6 |") && md.contains("0.98: 0/4"));
    }

    #[test]
    fn table_cells_escape_pipes() {
        assert_eq!(cell("|a|"), "\\|a\\|");
    }
}
