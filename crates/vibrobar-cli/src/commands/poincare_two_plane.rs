//! `vibrobar poincare` on a `[two_plane]` scenario: the stroboscopic section of one member's
//! run, the state once per forcing period at a phase, after a transient.

use anyhow::{Context, Result};
use vibrobar_core::analysis::two_plane::{poincare_two_plane, TwoPlaneMethod};
use vibrobar_core::params::two_plane::{direction, TwoPlaneSystem};
use vibrobar_core::solver::two_plane_rk4::TwoPlaneStart;
use vibrobar_core::Frequency;
use vibrobar_io::csv::{
    fmt_coord, two_plane_history_schema, two_plane_history_values, write_csv, Value,
};
use vibrobar_io::{npy, Metadata};

use super::check_value;
use super::explore::{transient_or_default, PoincareArgs, PointArgs};
use crate::scenario::Scenario;

/// One member's run of a `[two_plane]` scenario at a point (`--ratio`, `--gap-mm`): what the
/// one-run analyses (`poincare`, `lyapunov`) start from.
pub struct MemberRun {
    /// The scenario with the point's axial gap and ratio.
    pub scenario: Scenario,
    /// Its two-plane system.
    pub sys: TwoPlaneSystem,
    /// The solver its `[two_plane] solver` asks for (checked against the system).
    pub method: TwoPlaneMethod,
    /// Which member of the ensemble of starts.
    pub member: usize,
    /// That member's start.
    pub start: TwoPlaneStart,
    /// The frequency ratio.
    pub ratio: f64,
    /// The axial gap, mm.
    pub gap_mm: f64,
}

impl MemberRun {
    /// At `point` from member `member` (`--member`, default 0), checked.
    pub fn at(point: &PointArgs, sc: &Scenario, member: Option<usize>) -> Result<MemberRun> {
        super::sweep_two_plane::refuse_system_flags(&point.system)?;
        let ratio = check_value("--ratio", point.ratio, |x| x > 0.0, "(0, ∞)")?;
        let gap_mm = check_value("--gap-mm", point.gap_mm, |x| x > 0.0, "(0, ∞) mm")?;
        let mut s = sc.clone();
        s.damper.gap_m = gap_mm * 1e-3;
        s.forcing.frequency = Frequency::Ratio(ratio);
        let (sys, method) = s.two_plane_run()?;
        let member = member.unwrap_or(0);
        let start = s.two_plane_start(&sys, member, "--member")?;
        s.settings().validate()?;
        Ok(MemberRun {
            scenario: s,
            sys,
            method,
            member,
            start,
            ratio,
            gap_mm,
        })
    }
}

/// Run the command on a scenario with `[two_plane]`.
pub fn run(a: &PoincareArgs, sc: &Scenario) -> Result<()> {
    let MemberRun {
        scenario: s,
        sys,
        method,
        member,
        start,
        ratio,
        gap_mm,
    } = MemberRun::at(&a.point, sc, a.member)?;
    let phase_deg = check_value("--phase-deg", a.phase_deg, |_| true, "finite")?;
    let settings = s.settings();
    let transient = transient_or_default(a.transient, &a.point.system)?;
    let e_f = direction(sys.forcing.angle_deg);
    let points = poincare_two_plane(
        &sys,
        &start,
        method,
        &settings,
        phase_deg.to_radians(),
        transient,
    )?;
    let first = points.first().map_or(f64::NAN, |p| p.t_s);
    let rows: Vec<[f64; 11]> = points
        .iter()
        .map(|p| two_plane_history_values(p, e_f))
        .collect();
    let velocity: Vec<f64> = points
        .iter()
        .map(|p| p.state.du_m_s[0] * e_f[0] + p.state.du_m_s[1] * e_f[1])
        .collect();
    let params = serde_json::json!({
        "scenario": &s,
        "member": member,
        "ratio": ratio,
        "axial_gap_m": gap_mm * 1e-3,
        "phase_rad": phase_deg.to_radians(),
        "transient_s": transient,
        "first_point_s": first,
        "solver": method.solver_for(&sys),
    });
    let schema = two_plane_history_schema();
    write_csv(
        &a.out,
        &schema,
        rows.iter().map(|r| r.map(Value::F).to_vec()),
    )
    .with_context(|| format!("writing {}", a.out.display()))?;
    Metadata::new("poincare", &schema.header(), &params, None)
        .write_beside(&a.out)
        .with_context(|| format!("metadata beside {}", a.out.display()))?;
    let npy_path = a.out.with_extension("npy");
    let data: Vec<f64> = rows.iter().flatten().copied().collect();
    npy::write_f64(&npy_path, &[rows.len(), 11], &data)?;
    Metadata::new("poincare", "", &params, None).write_beside(&npy_path)?;
    let xy: Vec<(f64, f64)> = rows
        .iter()
        .zip(&velocity)
        .map(|(r, v)| (r[5] * 1e6, v * 1e3))
        .collect();
    let title = format!(
        "Poincaré section at Ωt = {}°, r = {}, axial gap = {} mm, two planes",
        fmt_coord(phase_deg),
        fmt_coord(ratio),
        fmt_coord(gap_mm)
    );
    let files = vibrobar_report::figures::scatter_files(
        &a.out.with_extension(""),
        &vibrobar_report::figures::Scatter {
            title: &title,
            x_label: "bar displacement along the force (µm)",
            y_label: "bar velocity along the force (mm/s)",
            points: &xy,
            radius: 3,
        },
    )?;
    println!(
        "{} points (member {member}, solver {}); wrote {}, {}",
        rows.len(),
        method.solver_for(&sys),
        a.out.display(),
        npy_path.display()
    );
    for f in files {
        println!("wrote {}", f.display());
    }
    Ok(())
}
