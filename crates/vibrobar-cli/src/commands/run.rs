//! `vibrobar run`: one run, its time history and a summary.

use anyhow::Result;

use super::{fmt_secs, run_one, solver, Case};
use crate::cli::RunArgs;
use crate::output::write_history_csv;
use crate::scenario::{check_positive, Scenario};

/// Run the command.
pub fn run(args: &RunArgs) -> Result<()> {
    let t0 = std::time::Instant::now();
    let mut sc = Scenario::from_args(&args.model)?;
    if let Some(g) = args.gap_mm {
        check_positive("--gap-mm", g, "mm")?;
        sc.damper.gap_m = g * 1e-3;
    }
    if let Some(r) = args.ratio {
        check_positive("--ratio", r, "")?;
        sc.forcing.frequency = vibrobar_core::Frequency::Ratio(r);
    }
    sc.override_initial(args.u0_m, args.du0_m_s, args.w0_m, args.dw0_m_s)?;
    if args.sample_every == 0 {
        anyhow::bail!("--sample-every = 0 is outside the allowed range [1, ∞) steps");
    }
    sc.validate()?;
    let settings = sc.settings();
    let solver = solver(&sc.run.solver, &settings)?;
    let sys = sc.damped_system();
    let case = Case {
        system: sys,
        init: sc.initial_state(),
        sample_interval_s: Some(args.sample_every as f64 * settings.dt_s),
        energy_audit: true,
    };
    let out = run_one(&case, &settings, solver.as_ref())?;
    let is_npy = args.out.extension().is_some_and(|e| e == "npy");
    if is_npy {
        let flat: Vec<f64> = out
            .samples
            .iter()
            .flat_map(|s| [s.t_s, s.u_m, s.du_m_s, s.v_m, s.dv_m_s, s.w_m(), s.dw_m_s()])
            .collect();
        crate::store::npy::write_f64(&args.out, &[out.samples.len(), 7], &flat)?;
    } else {
        write_history_csv(&args.out, &out.samples)?;
    }
    let params = serde_json::json!({
        "scenario": sc,
        "system": sys,
        "initial": case.init,
        "settings": settings,
        "solver": solver.name(),
        "sample_interval_s": case.sample_interval_s,
    });
    crate::store::Metadata::new(
        "run",
        if is_npy {
            ""
        } else {
            crate::output::HISTORY_HEADER
        },
        params,
        None,
    )
    .write_beside(&args.out)?;
    if args.energy {
        let e = out.energy.expect("energy audit requested");
        println!("{}", serde_json::to_string_pretty(&e)?);
    }
    // With --energy, stdout carries only the JSON; the summary goes to stderr.
    let say = |line: String| {
        if args.energy {
            eprintln!("{line}");
        } else {
            println!("{line}");
        }
    };
    print_summary(&say, &sc, &sys, &settings, solver.name(), &out, args)?;
    say(format!(
        "  wall time  : {}",
        fmt_secs(t0.elapsed().as_secs_f64())
    ));
    Ok(())
}

fn print_summary(
    say: &dyn Fn(String),
    sc: &Scenario,
    sys: &vibrobar_core::System,
    settings: &vibrobar_core::RunSettings,
    solver_name: &str,
    out: &super::CaseOutcome,
    args: &RunArgs,
) -> Result<()> {
    let d = sys.damper.expect("damped system");
    let r = &out.result;
    say(format!("vibrobar run ({})", crate::VERSION));
    say(format!(
        "  model      : gap {} mm, ratio {}, friction {} ({:.4} N), e = {}, F0 = {} N",
        d.gap_m * 1e3,
        sc.frequency_ratio(),
        d.friction,
        sys.friction_level_n(),
        d.restitution,
        sys.forcing.amplitude_n
    ));
    say(format!(
        "  run        : solver {}, {} s at dt {:e} s, RMS over the last {:.0} %",
        solver_name,
        settings.duration_s,
        settings.dt_s,
        settings.rms_fraction * 100.0
    ));
    say(format!("  RMS u      : {:.4e} m", r.rms_m));
    say(format!(
        "  impacts    : {} total, {} in the RMS window, {:.3} per forcing cycle",
        r.impacts, r.impacts_in_window, r.impacts_per_cycle
    ));
    say(format!(
        "  penetration: max |w| − l_g = {:.3e} m",
        r.summary.max_penetration_m.max(0.0)
    ));
    if let Some(e) = out.energy {
        say(format!(
            "  energy (J) : forcing {:+.4e}, viscous −{:.4e}, impacts −{:.4e}, friction {:+.4e} ({}), ΔE_mech {:+.4e}, residual {:+.2e}",
            e.work_input_j,
            e.viscous_loss_j,
            e.impact_loss_j,
            e.friction_work_j,
            if e.friction_work_j > 0.0 {
                "put in"
            } else if e.friction_work_j < 0.0 {
                "taken out"
            } else {
                "none"
            },
            e.delta_mechanical_j,
            e.residual_j
        ));
    }
    say(format!(
        "  output     : {} rows to {} (+ .meta.json)",
        out.samples.len(),
        args.out.display()
    ));
    Ok(())
}
