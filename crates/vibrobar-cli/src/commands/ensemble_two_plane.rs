//! `vibrobar ensemble` on a `[two_plane]` scenario: every member of each point's ensemble of
//! starts, one row each, beside the one-plane model from the same start and the bar without its
//! ball; the mean and spread per point on the screen. The file is written whole at the end
//! (atomically), after every run.

use anyhow::{bail, Context, Result};
use std::fmt::Write as _;
use vibrobar_core::analysis::two_plane::Spread;
use vibrobar_core::Frequency;

use super::explore::{axis_values, EnsembleArgs};
use super::sweep_two_plane::run_points;
use crate::scenario::Scenario;
use vibrobar_io::csv::fmt_coord;

/// The columns.
pub const HEADER: &str = "axial_gap_m,ratio,member,solver,w_along_start_m,w_across_start_m,\
dw_along_start_m_s,dw_across_start_m_s,rms_along_force_m,reduction_pct,one_plane_rms_m,\
one_plane_reduction_pct,solid_rms_m,rms_radial_m,rms_tangential_m,rms_total_m,impacts_plug_plus,\
impacts_plug_minus,impacts_wall_plus,impacts_wall_minus,flight_fraction";

/// Run the command on a scenario with `[two_plane]`.
pub fn ensemble(a: &EnsembleArgs, sc: &Scenario) -> Result<()> {
    let t0 = std::time::Instant::now();
    let Some(section) = &sc.two_plane else {
        bail!("no [two_plane] section");
    };
    for (flag, given) in [
        ("--u-m", a.u_m.is_some()),
        ("--du-m-s", a.du_m_s.is_some()),
        ("--dw-m-s", a.dw_m_s.is_some()),
    ] {
        if given {
            bail!(
                "{flag}: the members of a [two_plane] scenario start with the bar at rest and the \
                 ball resting where gravity presses it, at a random place along the hole and with \
                 a speed up to [two_plane] start_speed_m_s; set that instead"
            );
        }
    }
    if a.shard.is_some() || a.resume {
        bail!(
            "--shard and --resume: an ensemble of a [two_plane] scenario writes its file whole at \
             the end; run it without them"
        );
    }
    let ratios = axis_values("--ratio", a.ratio, "--ratios", &a.ratios, "(0, ∞)")?;
    let gaps_mm = axis_values("--gap-mm", a.gap_mm, "--gaps-mm", &a.gaps_mm, "(0, ∞) mm")?;
    let mut ens = section.ensemble()?;
    if let Some(m) = a.members {
        ens.members = m;
    }
    if let Some(s) = a.seed {
        ens.seed = s;
    }
    ens.validate().map_err(|e| {
        anyhow::anyhow!(
            "{}",
            e.to_string().replace("members (--members)", "--members")
        )
    })?;
    let settings = sc.settings();
    settings.validate()?;
    let method = section.method(settings.dt_s)?;
    let mut points = Vec::with_capacity(gaps_mm.len() * ratios.len());
    let mut systems = Vec::with_capacity(points.capacity());
    for &gap_mm in &gaps_mm {
        for &ratio in &ratios {
            let mut s = sc.clone();
            s.damper.gap_m = gap_mm * 1e-3;
            s.forcing.frequency = Frequency::Ratio(ratio);
            points.push((gap_mm * 1e-3, ratio));
            systems.push(s.two_plane_run()?.0);
        }
    }
    vibrobar_core::limits::check(
        "ensemble runs (points × members)",
        (systems.len() * ens.members) as f64,
        0.0,
        vibrobar_core::limits::MAX_RUNS as f64,
        "fewer points or members",
    )?;
    let answers = run_points(
        "ensemble",
        &systems,
        &ens,
        method,
        &settings,
        a.threads,
        &section.solver,
    )?;
    let mut csv = format!("{HEADER}\n");
    for (&(gap_m, ratio), p) in points.iter().zip(&answers) {
        let red = p.reductions_pct();
        let one_red = p.one_plane_reductions_pct();
        for (k, (m, st)) in p.members.iter().zip(&p.starts).enumerate() {
            writeln!(
                csv,
                "{gap_m},{ratio},{k},{},{:e},{:e},{:e},{:e},{:e},{:.4},{:e},{:.4},{:e},{:e},{:e},{:e},\
                 {},{},{},{},{:.6}",
                p.solver,
                st.w_hole_m[0],
                st.w_hole_m[1],
                st.dw_hole_m_s[0],
                st.dw_hole_m_s[1],
                m.rms_along_force_m,
                red[k],
                p.one_plane_rms_m[k],
                one_red[k],
                p.solid_rms_m,
                m.rms_m[0],
                m.rms_m[1],
                m.rms_total_m,
                m.impacts[0],
                m.impacts[1],
                m.impacts[2],
                m.impacts[3],
                m.flight_fraction,
            )?;
        }
        let r = Spread::of(&red);
        let o = Spread::of(&one_red);
        println!(
            "  gap {} mm, r = {}: reduction along the force {:.1} ± {:.1} % (range {:.1} to \
             {:.1}); one plane {:.1} ± {:.1} %; {} members, solver {}",
            fmt_coord(gap_m * 1e3),
            fmt_coord(ratio),
            r.mean,
            r.std_err,
            r.min,
            r.max,
            o.mean,
            o.std_err,
            r.n,
            p.solver
        );
    }
    vibrobar_io::csv::write_text(&a.out, &csv)
        .with_context(|| format!("writing {}", a.out.display()))?;
    println!(
        "wrote {} ({} points × {} members, {:.1} s)",
        a.out.display(),
        answers.len(),
        ens.members,
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
