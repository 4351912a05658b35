//! `vibrobar paper`: reproduce Figs. 2–5 and write REPORT.md.

use anyhow::{bail, Result};
use plotters::style::RGBColor;
use std::path::Path;
use std::time::Instant;
use vibrobar_core::analysis::ensemble::{run_ensemble, EnsembleParams, IcRanges};
use vibrobar_core::analysis::map::{run_map, Axis, Grid, GridAxis, MapSpec};
use vibrobar_core::analysis::regime::Tolerances;
use vibrobar_core::analysis::{SweepBase, SweepPoint};
use vibrobar_core::params::BarModel;
use vibrobar_core::structure::Point;
use vibrobar_core::{FrictionModel, RunSettings, State, System};

use super::{fmt_secs, run_cases, solver, sweep_rows, Case};
use crate::cli::PaperArgs;
use crate::progress::Progress;
use crate::scenario::{check_positive, sweep_ratios};
use vibrobar_io::csv::{
    grid_num, ic_ensemble_schema, regime_counts, write_csv, write_history_csv, write_json,
    write_sweep_csv, write_text, IcEnsembleCsvRow, SweepCsvRow,
};
use vibrobar_report::plot::{rms_vs_ratio, time_history, Curve};
use vibrobar_report::report::{
    claims, render, variants, IcEnsemble, IcPoint, ReportInput, SolverData, Variant,
};

pub use crate::cli::REPRODUCING_FRICTION_N;

/// Gaps of the frictionless sweep: the paper's two plus the ones behind "no impacts ≥ 0.25 mm".
pub const FRICTIONLESS_GAPS_M: [f64; 4] = [0.1e-3, 0.25e-3, 0.5e-3, 1.0e-3];
/// Gaps of the friction sweeps.
pub const FRICTION_GAPS_M: [f64; 2] = [0.1e-3, 1.0e-3];

/// Seed of the initial-condition ensemble.
pub const ENSEMBLE_SEED: u64 = 1;
/// Members of the initial-condition ensemble per point (full run, --quick).
pub const ENSEMBLE_MEMBERS: (usize, usize) = (16, 4);
/// Half range of the initial relative velocity ẇ0 of the ensemble, m/s.
pub const ENSEMBLE_DW_M_S: f64 = 1e-3;
/// Solver of the ensemble: event-driven, milliseconds per run (rk4 would take minutes).
pub const ENSEMBLE_SOLVER: &str = "exact";

/// Initial conditions of the ensemble, after the paper's "nonzero initial values of bar
/// displacement and relative velocity": u0 within ±F0/K (the static deflection under the forcing
/// amplitude), ball anywhere in the cavity, |ẇ0| ≤ 1 mm/s, u̇0 = 0.
pub fn ensemble_ranges(base: &SweepBase) -> IcRanges {
    // A modal bar: the static deflection at the response point under the force at the force
    // point, from the modes kept.
    let u = match &base.damped_bar {
        BarModel::Lumped(b) => base.forcing.amplitude_n / b.stiffness_n_per_m,
        BarModel::Modal(m) => {
            base.forcing.amplitude_n * m.static_compliance_m_per_n(Point::Force, Point::Response)
        }
    };
    IcRanges {
        u_m: (-u, u),
        du_m_s: (0.0, 0.0),
        w_over_half_gap: (-1.0, 1.0),
        dw_m_s: (-ENSEMBLE_DW_M_S, ENSEMBLE_DW_M_S),
    }
}

/// The initial-condition ensemble: frictionless at gap 0.1 mm at every ratio (the claims on
/// impacts and on robustness near resonance), each friction set at gap 1.0 mm and r = 1. Each
/// point also gets a run from the paper's start with the same solver, as the reference.
pub fn run_ic_ensemble(
    settings: &RunSettings,
    variants: &[Variant],
    ratios: &[f64],
    members: usize,
) -> Result<IcEnsemble> {
    let t0 = Instant::now();
    let solver = solver(ENSEMBLE_SOLVER, settings)?;
    let base = SweepBase::paper();
    let params = EnsembleParams {
        seed: ENSEMBLE_SEED,
        members,
        ranges: ensemble_ranges(&base),
    };
    let mut points = Vec::new();
    for v in variants {
        let (gap_m, rs) = if v.friction == FrictionModel::None {
            (0.1e-3, ratios.to_vec())
        } else {
            (1.0e-3, vec![1.0])
        };
        let spec = MapSpec {
            base: SweepBase {
                ball: vibrobar_core::Damper {
                    friction_force_n: v.force_n,
                    ..base.ball
                },
                ..base
            },
            friction: v.friction,
            settings: *settings,
            tolerances: Tolerances::default(),
        };
        let grid = Grid::new(vec![
            GridAxis {
                axis: Axis::FreqRatio,
                values: rs,
            },
            GridAxis {
                axis: Axis::GapM,
                values: vec![gap_m],
            },
        ])?;
        let pts = grid.points();
        let rest = run_map(&spec, solver.as_ref(), &pts, &|_, _| {})?;
        let bar = Progress::new(&format!("ensemble [{}]", v.key), pts.len() * members, 0);
        let stats = run_ensemble(&spec, solver.as_ref(), &pts, &params, &bar.callback())?;
        bar.finish();
        for (r, st) in rest.into_iter().zip(stats) {
            points.push(IcPoint {
                variant_key: v.key.clone(),
                gap_m,
                ratio: r.ratio,
                rest_rms_m: r.rms_damped_m,
                rest_impacts_per_cycle: r.impacts_per_cycle,
                stats: st,
            });
        }
    }
    Ok(IcEnsemble {
        solver: solver.name().to_string(),
        seed: ENSEMBLE_SEED,
        members,
        ranges: params.ranges,
        points,
        wall_s: t0.elapsed().as_secs_f64(),
    })
}

/// Write `ic_ensemble.csv` (columns: [`vibrobar_io::csv::ic_ensemble_schema`]): one row per
/// point (`regimes` = `regime:count` joined by `;`; `friction_force_n` empty when the level is
/// the stated η/r·m_d·g).
fn write_ic_csv(path: &Path, e: &IcEnsemble, variants: &[Variant]) -> Result<()> {
    let rows = e.points.iter().map(|p| {
        let v = variants.iter().find(|v| v.key == p.variant_key);
        IcEnsembleCsvRow {
            set: p.variant_key.clone(),
            friction: v.map_or(String::new(), |v| v.friction.to_string()),
            friction_force_n: v.and_then(|v| v.force_n),
            gap_mm: p.gap_m * 1e3,
            ratio: p.ratio,
            solver: e.solver.clone(),
            seed: e.seed,
            members: p.stats.members as u64,
            rms_rest_m: p.rest_rms_m,
            impacts_per_cycle_rest: p.rest_impacts_per_cycle,
            mean_rms_m: p.stats.mean_rms_m,
            std_rms_m: p.stats.std_rms_m,
            rel_spread: p.rel_spread(),
            mean_vs_rest: p.mean_vs_rest(),
            min_rms_m: p.stats.min_rms_m,
            max_rms_m: p.stats.max_rms_m,
            impacting_members: p.stats.impacting_members as u64,
            impacting_fraction: p.impacting_fraction(),
            regimes: regime_counts(&p.stats.regimes),
        }
        .values()
    });
    Ok(write_csv(path, &ic_ensemble_schema(), rows)?)
}

/// Run settings of the paper command.
pub fn settings(args: &PaperArgs) -> Result<RunSettings> {
    let mut st = RunSettings::default();
    if args.quick {
        st.duration_s = 0.1;
        st.dt_s = 2e-6;
    }
    if let Some(d) = args.duration {
        check_positive("--duration", d, "s")?;
        st.duration_s = d;
    }
    if let Some(dt) = args.dt {
        check_positive("--dt", dt, "s")?;
        st.dt_s = dt;
    }
    st.validate()?;
    Ok(st)
}

/// The sweep points of every variant.
pub fn paper_points(variants: &[Variant], ratios: &[f64]) -> Vec<SweepPoint> {
    let mut pts = Vec::new();
    for v in variants {
        let gaps: &[f64] = if v.friction == FrictionModel::None {
            &FRICTIONLESS_GAPS_M
        } else {
            &FRICTION_GAPS_M
        };
        for &gap_m in gaps {
            for &ratio in ratios {
                pts.push(SweepPoint {
                    ratio,
                    gap_m,
                    friction: v.friction,
                    friction_force_n: v.force_n,
                });
            }
        }
    }
    pts
}

/// Time-history case of a variant: gap 0.1 mm without friction (Fig. 2), 1 mm with (Fig. 4).
fn history_gap_m(v: &Variant) -> f64 {
    if v.friction == FrictionModel::None {
        0.1e-3
    } else {
        1.0e-3
    }
}

/// All runs of the paper for one solver.
pub fn run_solver(
    name: &str,
    settings: &RunSettings,
    variants: &[Variant],
    ratios: &[f64],
    sample_interval_s: Option<f64>,
) -> Result<SolverData> {
    let t0 = Instant::now();
    let solver = solver(name, settings)?;
    let base = SweepBase::paper();
    let points = paper_points(variants, ratios);
    let sweep = sweep_rows(
        &points,
        &base,
        settings,
        solver.as_ref(),
        &format!("paper [{name}]"),
        true,
    )?;
    let mut cases = Vec::new();
    if let Some(dt) = sample_interval_s {
        for v in variants {
            cases.push(Case {
                system: base.damped_system(&SweepPoint {
                    ratio: 1.0,
                    gap_m: history_gap_m(v),
                    friction: v.friction,
                    friction_force_n: v.force_n,
                }),
                init: State::REST,
                sample_interval_s: Some(dt),
                energy_audit: true,
            });
        }
    }
    let outcomes = run_cases(
        &cases,
        settings,
        solver.as_ref(),
        &format!("paper [{name}] histories"),
    )?;
    let histories = variants
        .iter()
        .zip(outcomes)
        .map(|(v, o)| (v.key.clone(), history_gap_m(v), o))
        .collect();
    Ok(SolverData {
        name: solver.name().to_string(),
        sweep,
        histories,
        wall_s: t0.elapsed().as_secs_f64(),
    })
}

const SOLID: RGBColor = RGBColor(0, 0, 0);
const GAP01: RGBColor = RGBColor(214, 39, 40);
const GAP10: RGBColor = RGBColor(31, 119, 180);

/// Run the command.
pub fn paper(args: &PaperArgs) -> Result<()> {
    let t0 = Instant::now();
    let settings = settings(args)?;
    if let Some(m) = args.ensemble_members {
        // Before the sweeps, not after them.
        vibrobar_core::limits::check_count(
            "--ensemble-members",
            m,
            0,
            vibrobar_core::limits::MAX_ENSEMBLE_MEMBERS,
            "",
        )?;
    }
    check_positive("--reproducing-friction-n", args.reproducing_friction_n, "N")?;
    check_positive("--sample-interval-s", args.sample_interval_s, "s")?;
    vibrobar_core::limits::check_samples(
        "history samples = --duration / --sample-interval-s",
        settings.duration_s,
        args.sample_interval_s,
    )?;
    let solvers: Vec<String> = if args.solvers.is_empty() {
        vec![crate::DEFAULT_SOLVER.to_string()]
    } else {
        args.solvers.clone()
    };
    for name in &solvers {
        solver(name, &settings)?;
    }
    if solvers
        .iter()
        .enumerate()
        .any(|(i, a)| solvers[..i].contains(a))
    {
        bail!("--solvers lists a solver twice: {}", solvers.join(","));
    }
    let variants = variants(args.reproducing_friction_n);
    let ratios = sweep_ratios(&vibrobar_core::analysis::sweep::SweepRange::paper())?;
    let sample = args.sample_interval_s.max(settings.dt_s);
    let out = &args.out;
    eprintln!(
        "vibrobar paper: {} runs per solver ({} s each at dt {:e} s), solvers: {}",
        paper_points(&variants, &ratios).len() + ratios.len() + variants.len(),
        settings.duration_s,
        settings.dt_s,
        solvers.join(", ")
    );
    let mut data = Vec::new();
    for (i, name) in solvers.iter().enumerate() {
        // Time histories only for the first solver: the figures use it.
        let d = run_solver(
            name,
            &settings,
            &variants,
            &ratios,
            (i == 0).then_some(sample),
        )?;
        eprintln!("  {name}: runs done in {}", fmt_secs(d.wall_s));
        data.push(d);
    }
    let members = args.ensemble_members.unwrap_or(if args.quick {
        ENSEMBLE_MEMBERS.1
    } else {
        ENSEMBLE_MEMBERS.0
    });
    let ensemble = if members == 0 {
        None
    } else {
        let e = run_ic_ensemble(&settings, &variants, &ratios, members)?;
        eprintln!(
            "  initial-condition ensemble ({ENSEMBLE_SOLVER}, {} points × {members}): done in {}",
            e.points.len(),
            fmt_secs(e.wall_s)
        );
        Some(e)
    };
    // Claim C1: the same cases under the compliant contact law (exact solver, both laws).
    let contact = {
        let m = if members == 0 {
            ENSEMBLE_MEMBERS.1
        } else {
            members
        };
        let t = Instant::now();
        let runs = super::contact_laws::law_runs(&settings, &ratios, m, &variants)?;
        eprintln!(
            "  contact laws (exact, restitution vs hertz, ensembles of {m}): done in {}",
            fmt_secs(t.elapsed().as_secs_f64())
        );
        Some(runs.comparison(&variants))
    };
    // Claims T1, T2: the gaps' verdicts on the bar that bends in two planes.
    let two_plane = {
        let m = if members == 0 {
            ENSEMBLE_MEMBERS.1
        } else {
            members
        };
        let t = Instant::now();
        let points = super::two_plane::paper_check(&settings, m)?;
        eprintln!(
            "  two planes (ensembles of {m}): done in {}",
            fmt_secs(t.elapsed().as_secs_f64())
        );
        Some(points)
    };

    let mut files = Vec::new();
    let first = &data[0];
    let title_settings = format!(
        "{} s, dt = {:e} s, {}",
        settings.duration_s, settings.dt_s, first.name
    );
    // Figs. 2 and 4: time histories.
    for (key, gap_m, o) in &first.histories {
        let v = variants.iter().find(|v| &v.key == key).expect("variant");
        let (fig, what) = if v.friction == FrictionModel::None {
            ("fig2", "without friction".to_string())
        } else {
            ("fig4", format!("with friction: {}", v.label))
        };
        let stem = format!("{fig}_{key}_gap{}mm_r1", grid_num(gap_m * 1e3));
        let title = format!(
            "Fig. {} — {what}; gap {} mm, r = 1 ({title_settings})",
            &fig[3..],
            grid_num(gap_m * 1e3)
        );
        // Zoom on the last ten forcing periods.
        let zoom_s = 10.0 * history_system(v).forcing_period_s();
        time_history(&out.join(&stem), &title, &o.samples, 0.5 * gap_m, zoom_s)?;
        write_history_csv(&out.join(format!("{stem}.csv")), &o.samples)?;
        for ext in ["png", "svg", "csv"] {
            files.push(format!("{stem}.{ext}"));
        }
    }
    // Figs. 3 and 5: RMS vs ratio.
    for v in &variants {
        let (fig, what) = if v.friction == FrictionModel::None {
            ("fig3", "without friction".to_string())
        } else {
            ("fig5", v.label.clone())
        };
        let stem = format!("{fig}_rms_{}", v.key);
        let rows_of = |d: &SolverData, g: f64| -> Vec<super::SweepRow> {
            d.sweep
                .iter()
                .filter(|r| {
                    r.point.friction == v.friction
                        && r.point.friction_force_n == v.force_n
                        && (r.point.gap_m - g).abs() < 1e-9
                })
                .cloned()
                .collect()
        };
        let gaps: &[f64] = if v.friction == FrictionModel::None {
            &FRICTIONLESS_GAPS_M
        } else {
            &FRICTION_GAPS_M
        };
        let mut csv = Vec::new();
        for d in &data {
            for &g in gaps {
                csv.extend(rows_of(d, g).iter().map(SweepCsvRow::from));
            }
        }
        write_sweep_csv(&out.join(format!("{stem}.csv")), &csv)?;
        let r01 = rows_of(first, 0.1e-3);
        let r10 = rows_of(first, 1.0e-3);
        let curve = |label: String, rows: &[super::SweepRow], color, solid: bool| Curve {
            label,
            points: rows
                .iter()
                .map(|r| {
                    (
                        r.point.ratio,
                        if solid { r.solid.rms_m } else { r.damped.rms_m },
                    )
                })
                .collect(),
            color,
            markers: true,
            dashed: solid,
            width: 2,
        };
        // Solid bar last, dashed, so it stays visible where a damped curve coincides with it.
        let curves = vec![
            curve("impact damper, gap 0.1 mm".into(), &r01, GAP01, false),
            curve("impact damper, gap 1.0 mm".into(), &r10, GAP10, false),
            curve("solid bar (dashed)".into(), &r01, SOLID, true),
        ];
        let title = format!(
            "Fig. {} — RMS displacement, {what} ({title_settings})",
            &fig[3..]
        );
        rms_vs_ratio(&out.join(&stem), &title, &curves)?;
        for ext in ["png", "svg", "csv"] {
            files.push(format!("{stem}.{ext}"));
        }
    }

    if let Some(e) = &ensemble {
        write_ic_csv(&out.join("ic_ensemble.csv"), e, &variants)?;
        files.push("ic_ensemble.csv".into());
    }
    let input = ReportInput {
        settings,
        variants: variants.clone(),
        solvers: data,
        ratios,
        quick: args.quick,
        files: {
            let mut f = files.clone();
            f.push("results.json".into());
            f.push("REPORT.md".into());
            f
        },
        ensemble,
        contact,
        two_plane,
    };
    let cl = claims(&input);
    write_json(
        &out.join("results.json"),
        &serde_json::json!({
            "tool_version": crate::VERSION,
            "settings": settings,
            "variants": variants,
            "claims": cl,
            "sweeps": input.solvers.iter().map(|d| serde_json::json!({
                "solver": d.name,
                "wall_s": d.wall_s,
                "rows": d.sweep.iter().map(|r| serde_json::json!({
                    "row": SweepCsvRow::from(r),
                    "friction_force_n": r.point.friction_force_n,
                    "impacts_per_cycle": r.damped.impacts_per_cycle,
                    "friction_work_j": r.friction_work_j,
                })).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
            "contact_laws": input.contact,
            "two_plane": input.two_plane,
            "ic_ensemble": input.ensemble.as_ref().map(|e| serde_json::json!({
                "solver": e.solver,
                "seed": e.seed,
                "members": e.members,
                "ranges": {
                    "u_m": e.ranges.u_m,
                    "du_m_s": e.ranges.du_m_s,
                    "w_over_half_gap": e.ranges.w_over_half_gap,
                    "dw_m_s": e.ranges.dw_m_s,
                },
                "impacts_counted": "members with >= 1 impact in the RMS window",
                "wall_s": e.wall_s,
                "points": e.points.iter().map(|p| serde_json::json!({
                    "set": p.variant_key,
                    "gap_m": p.gap_m,
                    "ratio": p.ratio,
                    "rms_rest_m": p.rest_rms_m,
                    "impacts_per_cycle_rest": p.rest_impacts_per_cycle,
                    "mean_rms_m": p.stats.mean_rms_m,
                    "std_rms_m": p.stats.std_rms_m,
                    "min_rms_m": p.stats.min_rms_m,
                    "max_rms_m": p.stats.max_rms_m,
                    "impacting_members": p.stats.impacting_members,
                    "regimes": p.stats.regimes.iter().map(|(r, n)| (r.to_string(), *n)).collect::<Vec<_>>(),
                })).collect::<Vec<_>>(),
            })),
        }),
    )?;
    let report = render(&input, &cl, t0.elapsed().as_secs_f64());
    write_text(&out.join("REPORT.md"), &report)?;
    print_summary(out, &input, &cl, t0.elapsed().as_secs_f64());
    Ok(())
}

fn print_summary(
    out: &Path,
    input: &ReportInput,
    cl: &[vibrobar_report::report::Claim],
    wall: f64,
) {
    println!(
        "vibrobar paper ({}): wrote {} files to {}",
        crate::VERSION,
        input.files.len(),
        out.display()
    );
    println!("  report : {}", out.join("REPORT.md").display());
    for c in cl {
        let by = c.by.as_ref().map_or(String::new(), |b| format!(" [{b}]"));
        println!("  {:<3} {}: {}{by}", c.id, c.text, c.verdicts().join(" | "));
    }
    println!("  total wall time: {}", fmt_secs(wall));
}

/// The damped system of a history case (exposed for tests and `bench`).
pub fn history_system(v: &Variant) -> System {
    SweepBase::paper().damped_system(&SweepPoint {
        ratio: 1.0,
        gap_m: history_gap_m(v),
        friction: v.friction,
        friction_force_n: v.force_n,
    })
}
