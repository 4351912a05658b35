//! REPORT.md: every numerical claim of the paper beside our value. Data-driven: every number and
//! every verdict is computed from the runs; the rules are stated in the report.

use serde::Serialize;
use vibrobar_core::{FrictionModel, RunSettings};

use crate::commands::{CaseOutcome, SweepResult};

/// Percentage points within which a reduction counts as reproduced.
pub const REDUCTION_TOL_PP: f64 = 5.0;
/// Largest max/min RMS ratio over the band that counts as "flat".
pub const FLAT_MAX_RATIO: f64 = 1.25;
/// Impacts per cycle that count as "about two".
pub const TWO_PER_CYCLE: (f64, f64) = (1.5, 2.5);
/// Largest |damped/solid − 1| that counts as "same as the solid bar".
pub const SAME_AS_SOLID_TOL: f64 = 0.02;

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
    pub sweep: Vec<SweepResult>,
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
    fn rows(&self, v: &Variant, gap_m: f64) -> Vec<&SweepResult> {
        self.sweep
            .iter()
            .filter(|r| {
                r.point.friction == v.friction
                    && r.point.friction_force_n == v.force_n
                    && close(r.point.gap_m, gap_m)
            })
            .collect()
    }

    fn at(&self, v: &Variant, gap_m: f64, ratio: f64) -> Option<&SweepResult> {
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
    out
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
        "- Every run: {} s simulated from rest with the ball centred, dt = {:e} s, RMS over the last {:.0} %.",
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
    for c in claims {
        let _ = write!(s, "| {} | {} | {} |", c.id, cell(&c.text), cell(&c.paper));
        for v in c.verdicts() {
            let _ = write!(s, " {} |", cell(&v));
        }
        let _ = writeln!(s);
    }

    let _ = writeln!(s, "\n## Claims, parameter set by parameter set\n");
    let mut head = "| # | Claim | Paper | Rule | Parameters |".to_string();
    let mut sep = "|---|---|---|---|---|".to_string();
    for n in &solvers {
        let _ = write!(head, " {n}: ours | {n}: holds |");
        sep.push_str("---|---|");
    }
    let _ = writeln!(s, "{head}\n{sep}");
    for c in claims {
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
    let _ = writeln!(s, "- total (including figures): {total_wall_s:.1} s");
    let _ = writeln!(s, "\n## Files\n");
    for f in &input.files {
        let _ = writeln!(s, "- `{f}`");
    }
    s
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
    fn table_cells_escape_pipes() {
        assert_eq!(cell("|a|"), "\\|a\\|");
    }
}
