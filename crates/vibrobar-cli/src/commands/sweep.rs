//! `vibrobar sweep`: RMS of the damped and the solid bar over ratios and gaps.
//!
//! Rows are in grid order: gap-major (every ratio of the first gap, then of the next gap), so the
//! grid index of (gap k, ratio j) is `k · n_ratios + j`. Rows go through a journal
//! (`FILE.journal`) as they finish: a killed sweep loses at most the runs in flight, `--resume`
//! completes it, and the final `FILE` is byte-identical whether or not it was interrupted.
//! `FILE.meta.json` beside it holds every parameter, the solver settings, the version, a time
//! stamp and the job's fingerprint (which `--resume` checks).

use anyhow::{Context, Result};
use vibrobar_core::analysis::{Batch, Runner, SolidRatios};

use super::{batch_error, fmt_secs, run_one, solver, Case, SweepRow};
use crate::cli::SweepArgs;
use crate::progress::Progress;
use crate::scenario::{check_positive, parse_ratios, sweep_ratios, Scenario, ScenarioArgs};
use vibrobar_io::csv::{sweep_csv_line, sweep_key, sweep_schema, SweepCsvRow};
use vibrobar_io::{GridInfo, Metadata};

/// Run the command.
pub fn sweep(args: &SweepArgs) -> Result<()> {
    let t0 = std::time::Instant::now();
    let sc = Scenario::from_args(&args.model)?;
    if sc.two_plane.is_some() {
        return super::sweep_two_plane::sweep(args, &sc);
    }
    let gaps_m: Vec<f64> = if args.gap_mm.is_empty() {
        sc.sweep.gaps_m.clone()
    } else {
        args.gap_mm.iter().map(|g| g * 1e-3).collect()
    };
    for g_mm in &args.gap_mm {
        check_positive("--gap-mm", *g_mm, "mm")?;
    }
    if gaps_m.is_empty() {
        // `--gap-mm` given is never empty: the empty list came from the scenario file.
        anyhow::bail!(
            "sweep.gaps_m = [] in the scenario file: no gap to sweep (allowed: one or more gaps > 0 m; or give --gap-mm)"
        );
    }
    // In Hz: each bar's ratio of the one Ω (the damped bar's in the rows, the solid bar's for
    // its shared runs); in ratios: the same ratio of each bar's own ω₁.
    let (ratios, solid, frequencies_hz) = match (&args.ratios, &args.freqs_hz) {
        (_, Some(spec)) => {
            let (r, solid, f) = super::ratios_at_hz(spec, &sc.base()?)?;
            (r, solid, Some(f))
        }
        (Some(spec), None) => (parse_ratios(spec)?, SolidRatios::default(), None),
        (None, None) => (sweep_ratios(&sc.sweep)?, SolidRatios::default(), None),
    };
    // Grid order (= row order and journal index): gap-major.
    let points = sc.sweep_points(&gaps_m, &ratios);
    // Validate every point before starting, so bad input fails fast with the field's name.
    // The bars (a beam's modes) are computed here, once: every clone below shares them.
    for p in &points {
        let mut s = sc.clone();
        s.damper.gap_m = p.gap_m;
        s.forcing.frequency = vibrobar_core::Frequency::Ratio(p.ratio);
        s.validate()?;
    }
    let settings = sc.settings();
    let boxed = solver(&sc.run.solver, &settings)?;
    let watch = super::PenetrationWatch::new(boxed.as_ref());
    let solver: &dyn vibrobar_core::Solver = &watch;
    let params = vibrobar_io::params::SweepParams {
        scenario: &sc,
        solver: solver.name().to_string(),
        settings,
        gaps_m: gaps_m.clone(),
        ratios: ratios.clone(),
        order: "gap-major".into(),
        frequencies_hz: frequencies_hz.clone(),
    };
    let indices: Vec<usize> = (0..points.len()).collect();
    let schema = sweep_schema();
    let meta = Metadata::new(
        "sweep",
        &schema.header(),
        params,
        Some(GridInfo {
            total: points.len(),
            shard: None,
            indices: None,
        }),
    );
    let key = |i: usize| sweep_key(points[i].ratio, points[i].gap_m * 1e3);
    let journal = super::open_journal(&args.out, &meta, &schema, &indices, &key, args.resume)?;
    let pending = journal.pending();
    let base = sc.base()?;
    let bar = Progress::new("sweep", points.len(), journal.done_count());
    let progress = bar.callback();
    let batch = Batch::new(&base, &settings, solver).on(Runner::default().with_progress(&progress));
    // The solid bar's ratio of a row: the row's own, or (in Hz) the solid bar's at the same Ω.
    let solid_ratio = |i: usize| solid.of(points[i].ratio);
    let n_solid = batch.distinct_ratios(&pending, |&i| solid_ratio(i)).len();
    let res = batch.run(
        &pending,
        |&i| solid_ratio(i),
        |&i, solid| -> Result<()> {
            let p = &points[i];
            let case = Case {
                system: base.damped_system(p),
                init: base.init,
                sample_interval_s: None,
                energy_audit: false,
            };
            let d = run_one(&case, &settings, solver).map_err(|e| {
                anyhow::anyhow!(
                    "sweep: run at ratio {:.4}, gap {} mm failed: {e}",
                    p.ratio,
                    p.gap_m * 1e3
                )
            })?;
            let row = SweepRow {
                point: *p,
                solver: solver.name().to_string(),
                solid: *solid,
                damped: d.result,
                friction_work_j: d.friction_work_j,
            };
            journal.append(i, &sweep_csv_line(&SweepCsvRow::from(&row)))?;
            Ok(())
        },
    );
    bar.finish();
    res.map_err(batch_error)?;
    journal.finish()?;
    if let Some(w) = watch.warning() {
        eprintln!("{w}");
    }
    meta.write_beside(&args.out)
        .with_context(|| format!("writing metadata beside {}", args.out.display()))?;
    eprintln!(
        "sweep: {} points ({} runs this time, solver {}, {} s at dt {:e} s) written to {} in {}",
        points.len(),
        n_solid + pending.len(),
        solver.name(),
        settings.duration_s,
        settings.dt_s,
        args.out.display(),
        fmt_secs(t0.elapsed().as_secs_f64())
    );
    Ok(())
}
