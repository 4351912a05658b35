//! `vibrobar sweep`: RMS of the damped and the solid bar over ratios and gaps.

use anyhow::Result;
use vibrobar_core::analysis::SweepPoint;

use super::{assemble_sweep, fmt_secs, run_cases, solver, sweep_cases};
use crate::cli::SweepArgs;
use crate::output::write_sweep_csv;
use crate::scenario::{check_positive, parse_ratios, ratio_range, Scenario};

/// Run the command.
pub fn sweep(args: &SweepArgs) -> Result<()> {
    let t0 = std::time::Instant::now();
    let sc = Scenario::from_args(&args.model)?;
    let gaps_m: Vec<f64> = if args.gap_mm.is_empty() {
        sc.sweep.gaps_m.clone()
    } else {
        args.gap_mm.iter().map(|g| g * 1e-3).collect()
    };
    for (g_mm, g) in args.gap_mm.iter().zip(&gaps_m) {
        check_positive("--gap-mm", *g_mm, "mm")?;
        let _ = g;
    }
    if gaps_m.is_empty() {
        anyhow::bail!("--gap-mm: no gap given (allowed: one or more values > 0 mm)");
    }
    let ratios = match &args.ratios {
        Some(spec) => parse_ratios(spec)?,
        None => ratio_range(
            sc.sweep.ratio_start,
            sc.sweep.ratio_stop,
            sc.sweep.ratio_step,
        )?,
    };
    let points: Vec<SweepPoint> = gaps_m
        .iter()
        .flat_map(|&gap_m| {
            ratios.iter().map(move |&ratio| SweepPoint {
                ratio,
                gap_m,
                friction: sc.damper.friction,
                friction_force_n: sc.damper.friction_force_n,
            })
        })
        .collect();
    // Validate every point before starting, so bad input fails fast with the field's name.
    for p in &points {
        let mut s = sc.clone();
        s.damper.gap_m = p.gap_m;
        s.forcing.frequency_ratio = p.ratio;
        s.validate()?;
    }
    let settings = sc.settings();
    let solver = solver(&sc.run.solver, &settings)?;
    let (cases, solid_index) = sweep_cases(
        &points,
        &sc.base(),
        sc.gravity_m_s2,
        &sc.initial_state(),
        false,
    );
    let outcomes = run_cases(&cases, &settings, solver.as_ref(), "sweep")?;
    let rows = assemble_sweep(&points, &solid_index, &outcomes, 0, solver.name());
    let csv: Vec<_> = rows.iter().map(|r| r.csv_row()).collect();
    write_sweep_csv(&args.out, &csv)?;
    eprintln!(
        "sweep: {} points ({} runs, solver {}, {} s at dt {:e} s) written to {} in {}",
        rows.len(),
        cases.len(),
        solver.name(),
        settings.duration_s,
        settings.dt_s,
        args.out.display(),
        fmt_secs(t0.elapsed().as_secs_f64())
    );
    Ok(())
}
