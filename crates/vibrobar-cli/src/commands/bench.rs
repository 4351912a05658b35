//! `vibrobar bench`: wall times of one paper run and of the whole paper sweep set, per solver,
//! in one process, with ratios against `rk4`.

use anyhow::Result;
use std::time::Instant;
use vibrobar_core::solver::SOLVER_NAMES;
use vibrobar_core::{FrictionModel, RunSettings, State, System};

use super::{fmt_secs, run_one, solver, Case};
use crate::cli::BenchArgs;
use crate::commands::paper::{run_solver, variants, REPRODUCING_FRICTION_N};
use crate::scenario::{check_positive, ratio_range};

/// Run the command.
pub fn bench(args: &BenchArgs) -> Result<()> {
    let mut st = RunSettings::default();
    if let Some(d) = args.duration {
        check_positive("--duration", d, "s")?;
        st.duration_s = d;
    }
    if let Some(dt) = args.dt {
        check_positive("--dt", dt, "s")?;
        st.dt_s = dt;
    }
    st.validate()?;
    let names: Vec<String> = if args.solvers.is_empty() {
        SOLVER_NAMES.iter().map(|s| s.to_string()).collect()
    } else {
        args.solvers.clone()
    };
    for n in &names {
        solver(n, &st)?;
    }
    println!(
        "vibrobar bench ({}): {} s simulated per run, dt = {:e} s, {} rayon threads",
        crate::VERSION,
        st.duration_s,
        st.dt_s,
        rayon::current_num_threads()
    );
    let single = Case {
        system: System::paper_damped(0.1e-3, FrictionModel::None, 1.0),
        init: State::REST,
        sample_interval_s: None,
        energy_audit: false,
    };
    let mut rows = Vec::new();
    let mut sweeps = Vec::new();
    for n in &names {
        let s = solver(n, &st)?;
        // Warm-up so the first solver does not pay for page faults and CPU ramp-up.
        let _ = run_one(&single, &st, s.as_ref());
        let t = Instant::now();
        let o = run_one(&single, &st, s.as_ref())?;
        let t_single = t.elapsed().as_secs_f64();
        let t_sweep = if args.single_only {
            None
        } else {
            let v = variants(REPRODUCING_FRICTION_N);
            let ratios = ratio_range(0.95, 1.05, 0.01)?;
            let t = Instant::now();
            let d = run_solver(n, &st, &v, &ratios, None)?;
            let el = t.elapsed().as_secs_f64();
            let npts = d.sweep.len();
            sweeps.push((n.clone(), d.sweep));
            Some((el, npts))
        };
        println!(
            "  {n:<6} single run (r = 1, gap 0.1 mm, frictionless): {} (RMS {:.4e} m, {} impacts)",
            fmt_secs(t_single),
            o.result.rms_m,
            o.result.impacts
        );
        if let Some((ts, npts)) = t_sweep {
            println!(
                "  {n:<6} paper sweep set ({npts} damped points + solid bars): {}",
                fmt_secs(ts)
            );
        }
        rows.push((n.clone(), t_single, t_sweep.map(|x| x.0)));
    }
    if let Some((_, ref_single, ref_sweep)) = rows.iter().find(|r| r.0 == "rk4").cloned() {
        println!("  speed-up over rk4 (rk4 time / solver time, measured in this run):");
        for (n, ts, tw) in &rows {
            print!("    {n:<6} single run {:.1}×", ref_single / ts);
            if let (Some(tw), Some(rw)) = (tw, ref_sweep) {
                print!(", paper sweep set {:.1}×", rw / tw);
            }
            println!();
        }
    }
    print_rms_side_by_side(&sweeps);
    Ok(())
}

/// RMS of every sweep point for each solver, side by side, with the relative difference to the
/// first solver. Chaotic points (impacting, near resonance) differ by a few per cent between any
/// two correct solvers; the others agree to the accuracy of the cruder one.
fn print_rms_side_by_side(sweeps: &[(String, Vec<super::SweepResult>)]) {
    let Some((first, base)) = sweeps.first() else {
        return;
    };
    if sweeps.len() < 2 {
        return;
    }
    print!(
        "  damped-bar RMS per point (m):\n    {:<34}",
        "friction, gap, ratio"
    );
    for (n, _) in sweeps {
        print!(" {n:>11}");
    }
    for (n, _) in &sweeps[1..] {
        print!("  {n}/{first}−1");
    }
    println!();
    let mut worst = vec![(0.0f64, String::new()); sweeps.len()];
    for (i, r) in base.iter().enumerate() {
        let label = format!(
            "{} {}, {} mm, {}",
            r.point.friction,
            r.point
                .friction_force_n
                .map(|f| format!("{f} N"))
                .unwrap_or_else(|| "stated".into()),
            vibrobar_io::csv::grid_num(r.point.gap_m * 1e3),
            vibrobar_io::csv::grid_num(r.point.ratio)
        );
        print!("    {label:<34}");
        for (_, rows) in sweeps {
            print!(" {:>11.4e}", rows[i].damped.rms_m);
        }
        for (k, (_, rows)) in sweeps.iter().enumerate().skip(1) {
            let d = rows[i].damped.rms_m / r.damped.rms_m - 1.0;
            print!("  {:>+10.2}%", 100.0 * d);
            if d.abs() > worst[k].0.abs() {
                worst[k] = (d, label.clone());
            }
        }
        println!();
    }
    for (k, (n, _)) in sweeps.iter().enumerate().skip(1) {
        println!(
            "  largest RMS difference {n} vs {first}: {:+.2} % at {}",
            100.0 * worst[k].0,
            worst[k].1
        );
    }
}
