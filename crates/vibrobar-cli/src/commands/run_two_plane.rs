//! `vibrobar run` on a `[two_plane]` scenario: one run of the bar that bends in two planes, its
//! sampled history streamed to disk (`FILE.partial` until the run is complete) and a summary.

use anyhow::{bail, Context, Result};
use std::io::Write as _;
use vibrobar_core::analysis::two_plane::solid_rms_m;
use vibrobar_core::params::two_plane::direction;
use vibrobar_core::solver::two_plane_rk4::{
    HoleWall, Sampling, TwoPlaneSample, TwoPlaneSummary, WallMotion,
};
use vibrobar_io::atomic::AtomicFile;
use vibrobar_io::csv::{fmt_coord, two_plane_history_schema, two_plane_history_values, Value};

use super::fmt_secs;
use crate::cli::RunArgs;
use crate::scenario::Scenario;

/// Run the command on a scenario with `[two_plane]` (gap and ratio already applied).
pub fn run(args: &RunArgs, sc: &Scenario) -> Result<()> {
    let t0 = std::time::Instant::now();
    super::sweep_two_plane::refuse_model_flags(&args.model)?;
    for (flag, given) in [
        ("--u0-m", args.u0_m.is_some()),
        ("--du0-m-s", args.du0_m_s.is_some()),
        ("--w0-m", args.w0_m.is_some()),
        ("--dw0-m-s", args.dw0_m_s.is_some()),
    ] {
        if given {
            bail!(
                "{flag}: a [two_plane] scenario starts from a member of its ensemble of starts; \
                 choose one with --member K"
            );
        }
    }
    if vibrobar_io::history::is_npy(&args.out) {
        bail!(
            "--out {}: the history of a [two_plane] run is written as CSV; give a name ending in \
             .csv",
            args.out.display()
        );
    }
    if args.sample_every == 0 {
        bail!("--sample-every = 0 is outside the allowed range [1, ∞) steps");
    }
    let settings = sc.settings();
    settings.validate()?;
    let (sys, method) = sc.two_plane_run()?;
    let member = args.member.unwrap_or(0);
    let start = sc.two_plane_start(&sys, member, "--member")?;
    let interval_s = args.sample_every as f64 * settings.dt_s;
    vibrobar_core::limits::check_samples(
        "rows = --duration / (--sample-every · --dt)",
        settings.duration_s,
        interval_s,
    )?;

    let mut file = AtomicFile::create(&args.out)?;
    let mut io_error: Option<std::io::Error> = None;
    let mut rows = 0u64;
    let e_f = direction(sys.forcing.angle_deg);
    let schema = two_plane_history_schema();
    let summary = {
        if let Err(e) = writeln!(file, "{}", schema.header()) {
            io_error = Some(e);
        }
        let mut line = String::new();
        let mut on_sample = |s: &TwoPlaneSample| {
            if io_error.is_some() {
                return;
            }
            line.clear();
            schema.format_into(&two_plane_history_values(s, e_f).map(Value::F), &mut line);
            line.push('\n');
            match file.write_all(line.as_bytes()) {
                Ok(()) => rows += 1,
                Err(e) => io_error = Some(e),
            }
        };
        method.run_from(
            &sys,
            &start,
            0.0,
            &settings,
            &mut |_| {},
            Some(Sampling {
                start_s: 0.0,
                interval_s,
                on_sample: &mut on_sample,
            }),
        )
    };
    let summary = match (summary, io_error) {
        (Ok(s), None) => s,
        (Err(e), _) => {
            file.discard();
            return Err(e.into());
        }
        (_, Some(e)) => {
            let err = file.error(e);
            file.discard();
            return Err(err.into());
        }
    };
    file.commit()?;
    let solid = solid_rms_m(&sys, &settings)?;
    let params = serde_json::json!({
        "scenario": sc,
        "member": member,
        "start": {
            "u_m": start.u_m,
            "du_m_s": start.du_m_s,
            "w_hole_m": start.w_hole_m,
            "dw_hole_m_s": start.dw_hole_m_s,
        },
        "solver": method.solver_for(&sys),
        "sample_interval_s": interval_s,
    });
    vibrobar_io::Metadata::new("run", &schema.header(), params, None)
        .write_beside(&args.out)
        .with_context(|| format!("metadata beside {}", args.out.display()))?;
    if args.energy {
        let b = summary.book;
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "forcing_work_j": b.forcing_work_j,
                "viscous_loss_j": b.viscous_loss_j,
                "impact_loss_j": b.impact_loss_j,
                "sliding_loss_j": b.sliding_loss_j,
                "rolling_loss_j": b.rolling_loss_j,
                "delta_mechanical_j": b.energy_change_j,
                "residual_j": b.residual_j(),
            }))?
        );
    }
    let say = |line: String| {
        if args.energy {
            eprintln!("{line}");
        } else {
            println!("{line}");
        }
    };
    print_summary(
        &say,
        sc,
        &sys,
        method.solver_for(&sys),
        member,
        &summary,
        solid,
    )?;
    say(format!(
        "  output     : {rows} rows to {} (+ .meta.json)",
        args.out.display()
    ));
    say(format!(
        "  wall time  : {}",
        fmt_secs(t0.elapsed().as_secs_f64())
    ));
    Ok(())
}

fn print_summary(
    say: &dyn Fn(String),
    sc: &Scenario,
    sys: &vibrobar_core::params::two_plane::TwoPlaneSystem,
    solver: &str,
    member: usize,
    s: &TwoPlaneSummary,
    solid_rms_m: f64,
) -> Result<()> {
    let settings = sc.settings();
    say(format!("vibrobar run ({}), two planes", crate::VERSION));
    say(format!(
        "  model      : hole at {}°, {} mm across (radial clearance {} mm), axial gap {} mm; \
         force {} N at {}°, ratio {}; gravity {} m/s² at {}°; walls μ_s {}, μ_k {}",
        fmt_coord(sys.hole.angle_deg),
        fmt_coord(sys.hole.diameter_m * 1e3),
        fmt_coord(sys.radial_clearance_m() * 1e3),
        fmt_coord(sys.hole.axial_gap_m * 1e3),
        fmt_coord(sys.forcing.amplitude_n),
        fmt_coord(sys.forcing.angle_deg),
        fmt_coord(sc.frequency_ratio()?),
        fmt_coord(sys.gravity.m_s2),
        fmt_coord(sys.gravity.angle_deg),
        fmt_coord(sys.ball.friction_static),
        fmt_coord(sys.ball.friction_kinetic),
    ));
    say(format!(
        "  run        : solver {solver}, member {member}, {} s, RMS over the last {:.0} %",
        settings.duration_s,
        settings.rms_fraction * 100.0
    ));
    say(format!(
        "  RMS        : along the force {:.4e} m ({:.1} % below the bar without its ball, \
         {:.4e} m); x {:.4e} m, y {:.4e} m, |u| {:.4e} m",
        s.rms_along_force_m,
        100.0 * (1.0 - s.rms_along_force_m / solid_rms_m),
        solid_rms_m,
        s.rms_m[0],
        s.rms_m[1],
        s.rms_total_m
    ));
    let wall = |w: HoleWall| {
        let f = s.contact_fraction[w as usize];
        format!(
            "{} impacts, resting {:.1} % (rolling {:.1}, sliding {:.1}, stuck {:.1})",
            s.impacts[w as usize],
            100.0 * s.rest_fraction(w),
            100.0 * f[WallMotion::Rolling as usize],
            100.0 * f[WallMotion::Sliding as usize],
            100.0 * f[WallMotion::Stuck as usize],
        )
    };
    say(format!(
        "  plugs      : + {}; − {}",
        wall(HoleWall::AxialPlus),
        wall(HoleWall::AxialMinus)
    ));
    say(format!(
        "  hole wall  : + {}; − {}",
        wall(HoleWall::AcrossPlus),
        wall(HoleWall::AcrossMinus)
    ));
    say(format!(
        "  flight     : {:.1} % of the window; {} events",
        100.0 * s.flight_fraction,
        s.events
    ));
    let b = s.book;
    say(format!(
        "  energy (J) : forcing {:+.4e}, viscous −{:.4e}, impacts −{:.4e}, sliding −{:.4e}, \
         rolling −{:.4e}, ΔE_mech {:+.4e}, residual {:+.2e}",
        b.forcing_work_j,
        b.viscous_loss_j,
        b.impact_loss_j,
        b.sliding_loss_j,
        b.rolling_loss_j,
        b.energy_change_j,
        b.residual_j()
    ));
    say(format!(
        "  penetration: max {:.3e} m beyond a wall",
        s.max_penetration_m.max(0.0)
    ));
    Ok(())
}
