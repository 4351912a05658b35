//! `vibrobar orbit` on a `[two_plane]` scenario: the periodic orbit one member's run settles on,
//! where the planes decouple (frictionless walls, the bar's principal axes along and across the
//! hole): each plane's orbit with its multipliers, and the two-plane run over one period for
//! the RMS along the force. `vibrobar continue` on it: each plane's orbit followed in a
//! parameter.

use anyhow::{bail, Context, Result};
use vibrobar_core::analysis::orbit::continuation::ContinuationSettings;
use vibrobar_core::analysis::two_plane::solid_rms_m;
use vibrobar_core::analysis::two_plane_orbit::{
    two_plane_branches, two_plane_orbit, PlaneBranch, TwoPlaneOrbit, TwoPlaneOrbitOf,
    TWO_PLANE_CONTINUATION_AXES, TWO_PLANE_ORBIT_SCOPE,
};
use vibrobar_core::solver::two_plane_exact::decoupled;
use vibrobar_io::csv::{write_csv, write_json};
use vibrobar_io::two_plane_csv;
use vibrobar_io::Metadata;
use vibrobar_report::figures::branch::BranchDot;

use super::explore::PointArgs;
use super::orbit::{
    axis_of, continued_point, orbit_json, period_of, Bar, ContinueArgs, JacobianArg, OrbitArgs,
    OrbitStartArgs, StartArg,
};
use super::poincare_two_plane::MemberRun;
use super::{check_value, fmt_coord};
use crate::scenario::Scenario;

/// Run the command on a scenario with `[two_plane]`.
pub fn run(a: &OrbitArgs, sc: &Scenario) -> Result<()> {
    let MemberRun {
        scenario: s,
        sys,
        member,
        start,
        ratio,
        gap_mm,
        ..
    } = MemberRun::at(&a.point, sc, a.member)?;
    let settings = s.settings();
    let (periods, settle) = orbit_start(&a.start, &sys, &settings)?;
    if sys.bar.lumped().is_none() && a.start.jacobian != JacobianArg::Exact {
        bail!(
            "--jacobian finite-difference: orbits of a round bar of modes use the exact Jacobian \
             (the modal variational flow); leave --jacobian out"
        );
    }
    let orbit = two_plane_orbit(&sys, periods, &start, settle, a.start.jacobian.get())?;
    let solid = solid_rms_m(&sys, &settings)?;
    let params = serde_json::json!({
        "scenario": &s,
        "member": member,
        "ratio": ratio,
        "axial_gap_m": gap_mm * 1e-3,
        "period": periods,
        "settle_s": settle,
    });
    match &orbit {
        TwoPlaneOrbitOf::Lumped(o) => report(a, o, solid, member, params),
        TwoPlaneOrbitOf::Round(o) => report(a, o, solid, member, params),
    }
}

/// The file, metadata and report line of a two-plane orbit on either bar.
fn report<F: Bar>(
    a: &OrbitArgs,
    o: &TwoPlaneOrbit<F>,
    solid: f64,
    member: usize,
    mut params: serde_json::Value,
) -> Result<()> {
    let periods = o.planes[0].section.periods();
    params["jacobian"] = serde_json::json!(o.planes[0].jacobian_source);
    let m = o.multipliers();
    let max_abs = m.first().map_or(0.0, |l| l.norm());
    let sm = &o.summary;
    let st = &o.start;
    let mut j = serde_json::json!({
        "period": periods,
        "stable": o.stable(),
        "max_abs_multiplier": max_abs,
        "multipliers": m.iter().map(|l| [l.re, l.im]).collect::<Vec<_>>(),
        "spin_multiplier": 1.0,
        "impacts_per_period": o.impacts_per_period(),
        "impacts_per_wall": {
            "plug_plus": sm.impacts[0],
            "plug_minus": sm.impacts[1],
            "wall_plus": sm.impacts[2],
            "wall_minus": sm.impacts[3],
        },
        "rms_along_force_m": sm.rms_along_force_m,
        "rms_radial_m": sm.rms_m[0],
        "rms_tangential_m": sm.rms_m[1],
        "rms_total_m": sm.rms_total_m,
        "solid_rms_m": solid,
        "reduction_pct": 100.0 * (1.0 - sm.rms_along_force_m / solid),
        "flight_fraction": sm.flight_fraction,
        "return_gap": o.return_gap,
        "state": {
            "t_s": o.start_t_s,
            "u_m": st.u_m,
            "du_m_s": st.du_m_s,
            "w_hole_m": st.w_hole_m,
            "dw_hole_m_s": st.dw_hole_m_s,
        },
        "planes": {
            "along_hole": orbit_json(&o.planes[0])?,
            "across_hole": orbit_json(&o.planes[1])?,
        },
    });
    j["parameters"] = params.clone();
    write_json(&a.out, &j).with_context(|| format!("writing {}", a.out.display()))?;
    Metadata::new("orbit", "", &params, None)
        .write_beside(&a.out)
        .with_context(|| format!("metadata beside {}", a.out.display()))?;
    let plane = |k: usize| {
        let p = &o.planes[k];
        format!(
            "{} impacts, max |λ| = {:.6}{}",
            p.impacts_per_period,
            p.max_abs_multiplier(),
            if p.impacts_per_period == 0 && (p.max_abs_multiplier() - 1.0).abs() < 1e-6 {
                " (the ball floats without an impact: neutral)"
            } else {
                ""
            }
        )
    };
    println!(
        "period-{periods} orbit (member {member}): RMS along the force {:.4e} m ({:.1} % below \
         the bar without its ball), along the hole {}, across it {}; {}; the run over one period \
         returns within {:.1e}",
        sm.rms_along_force_m,
        100.0 * (1.0 - sm.rms_along_force_m / solid),
        plane(0),
        plane(1),
        if o.stable() { "stable" } else { "not stable" },
        o.return_gap
    );
    println!("wrote {}", a.out.display());
    Ok(())
}

/// `vibrobar continue` on a scenario with `[two_plane]`, where the planes decouple: each
/// plane's orbit followed in the ratio or the restitution (both planes) or the axial gap (the
/// plane along the hole; the one across it does not feel it).
pub fn run_continue(a: &ContinueArgs, sc: &Scenario) -> Result<()> {
    let (axis, file_scale) = axis_of(&a.param)?;
    if !TWO_PLANE_CONTINUATION_AXES.contains(&axis) {
        bail!(
            "--param {}: a [two_plane] continuation follows ratio, gap-mm (the axial gap) or \
             restitution; friction on the hole's walls couples the planes",
            a.param
        );
    }
    let (ratio, gap_mm) = continued_point(a, Some(axis))?;
    let point = PointArgs {
        system: a.system.clone(),
        ratio,
        gap_mm,
    };
    let MemberRun {
        scenario: s,
        sys,
        member,
        start,
        ..
    } = MemberRun::at(&point, sc, a.member)?;
    let settings = s.settings();
    let (periods, settle) = orbit_start(&a.start, &sys, &settings)?;
    let (from, to) = (a.from * file_scale, a.to * file_scale);
    let cont = ContinuationSettings {
        max_points: a.max_points,
        switch_branches: !a.no_switch,
        ..Default::default()
    };
    let t = std::time::Instant::now();
    let planes = two_plane_branches(
        &sys,
        &start,
        axis,
        from,
        to,
        periods,
        settle,
        a.start.jacobian.get(),
        &cont,
    )
    .map_err(|e| {
        anyhow::anyhow!(
            "{}",
            e.to_string()
                .replace("followed parameter of a two-plane continuation", "--param")
        )
    })?;
    let wall = t.elapsed().as_secs_f64();
    let names = ["along_hole", "across_hole"];
    let schema = two_plane_csv::continuation_schema();
    let mut rows = Vec::new();
    for (name, p) in names.iter().zip(&planes) {
        if let PlaneBranch::Followed { branch, scale } = p {
            let inv = scale / file_scale;
            rows.extend(
                branch
                    .points
                    .iter()
                    .map(|q| two_plane_csv::continuation_values(name, q, inv)),
            );
        }
    }
    let params = serde_json::json!({
        "scenario": &s,
        "member": member,
        "param": a.param,
        "from": a.from,
        "to": a.to,
        "ratio": ratio,
        "axial_gap_m": gap_mm * 1e-3,
        "period": periods,
        "settle_s": settle,
        "max_points": a.max_points,
        "switch_branches": !a.no_switch,
    });
    write_csv(&a.out, &schema, &rows).with_context(|| format!("writing {}", a.out.display()))?;
    Metadata::new("continuation-two-plane", &schema.header(), &params, None)
        .write_beside(&a.out)
        .with_context(|| format!("metadata beside {}", a.out.display()))?;
    println!(
        "{} points in {wall:.3} s (member {member}); the two-plane orbit at a value of {} is the \
         pair of the planes' orbits there, stable where both are",
        rows.len(),
        a.param
    );
    let stem = a.out.with_extension("");
    for ((name, label), p) in names
        .iter()
        .zip(["along the hole", "across the hole"])
        .zip(&planes)
    {
        match p {
            PlaneBranch::Fixed(o) => println!(
                "  {label}: {} does not act here; one orbit, {} impacts per period, max |λ| = \
                 {:.6}, {}",
                a.param,
                o.impacts_per_period,
                o.max_abs_multiplier(),
                if o.stable() { "stable" } else { "not stable" }
            ),
            PlaneBranch::Followed { branch, scale } => {
                let inv = scale / file_scale;
                println!("  {label}: {} points", branch.points.len());
                for q in &branch.points {
                    if let Some(e) = q.event {
                        println!(
                            "    {} at {} = {} (period {}, max |λ| = {:.6})",
                            e.as_str(),
                            a.param,
                            fmt_coord(q.param * inv),
                            q.orbit.section.periods,
                            q.orbit.max_abs_multiplier()
                        );
                    }
                }
                for (i, r) in branch.stop_reasons.iter().enumerate() {
                    println!("    branch {i} ended: {r}");
                }
                let dots: Vec<BranchDot> = branch
                    .points
                    .iter()
                    .map(|q| BranchDot {
                        x: q.param * inv,
                        y: q.orbit.rms_m * 1e6,
                        stable: q.orbit.stable(),
                        branch: q.branch,
                        event: q.event.map(|e| e.as_str()),
                    })
                    .collect();
                let title = format!("Periodic orbits {label} in {}", a.param);
                let files = vibrobar_report::figures::branch::branch_files(
                    &stem.with_extension(name),
                    &vibrobar_report::figures::branch::BranchFigure {
                        title: &title,
                        x_label: &a.param,
                        points: &dots,
                    },
                )?;
                for f in files {
                    println!("wrote {}", f.display());
                }
            }
        }
    }
    println!("wrote {}", a.out.display());
    Ok(())
}

/// What a two-plane orbit starts from, checked: the planes decouple, `--start` is a settled
/// run (not the one-plane analytic orbit); the period and the settling time (`--settle`, or the
/// part of the run before the RMS window).
fn orbit_start(
    a: &OrbitStartArgs,
    sys: &vibrobar_core::params::two_plane::TwoPlaneSystem,
    settings: &vibrobar_core::RunSettings,
) -> Result<(u32, f64)> {
    if a.start == StartArg::Symmetric || a.branch.is_some() {
        bail!(
            "--start symmetric and --branch: the analytic symmetric orbit is the one-plane \
             model's; a [two_plane] orbit starts from the run a member settles on (--member, \
             --settle)"
        );
    }
    if let Err(why) = decoupled(sys) {
        bail!("{TWO_PLANE_ORBIT_SCOPE}; here {why}");
    }
    let periods = period_of(a)?;
    let settle = match a.settle {
        Some(t) => check_value("--settle", t, |x| x > 0.0, "(0, ∞) s")?,
        None => settings.duration_s * (1.0 - settings.rms_fraction),
    };
    Ok((periods, settle))
}
