//! `vibrobar ensemble` on a `[two_plane]` scenario: every member of each point's ensemble of
//! starts, one row each, beside the one-plane model from the same start and the bar without its
//! ball; the mean and spread per point on the screen. The file is written whole at the end
//! (atomically), after every run.

use anyhow::{bail, Context, Result};
use vibrobar_core::analysis::two_plane::Spread;

use super::explore::{axis_values, EnsembleArgs};
use super::sweep_two_plane::run_points;
use crate::scenario::Scenario;
use vibrobar_io::csv::fmt_coord;
use vibrobar_io::two_plane_csv;
use vibrobar_scenario::TwoPlaneAxes;

/// Run the command on a scenario with `[two_plane]`.
pub fn ensemble(a: &EnsembleArgs, sc: &Scenario) -> Result<()> {
    let t0 = std::time::Instant::now();
    let Some(section) = &sc.two_plane else {
        bail!("no [two_plane] section");
    };
    super::sweep_two_plane::refuse_system_flags(&a.system)?;
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
    let gaps_m: Vec<f64> = gaps_mm.iter().map(|g| g * 1e-3).collect();
    let cells = sc.two_plane_cells(
        &TwoPlaneAxes::gaps_and_ratios(&gaps_m, &ratios),
        ens.members,
        "ensemble runs (points × members)",
    )?;
    let systems: Vec<_> = cells.iter().map(|c| c.system).collect();
    let answers = run_points(
        "ensemble",
        &systems,
        &ens,
        method,
        &settings,
        a.threads,
        &section.solver,
    )?;
    let mut rows = Vec::with_capacity(systems.len() * ens.members);
    for (c, p) in cells.iter().zip(&answers) {
        let (gap_m, ratio) = (c.axial_gap_m, c.ratio);
        rows.extend(two_plane_csv::ensemble_rows(gap_m, ratio, p));
        let red = p.reductions_pct();
        let one_red = p.one_plane_reductions_pct();
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
    vibrobar_io::csv::write_csv(&a.out, &two_plane_csv::ensemble_schema(), &rows)
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
