//! `vibrobar lyapunov` on a `[two_plane]` scenario: the largest Lyapunov exponent of one
//! member's run by two-trajectory divergence with renormalisation, or (`--spectrum`, where the
//! planes decouple) every exponent: each plane's by QR of its variational flow, and the spin's
//! neutral 0.

use anyhow::{bail, Result};
use std::io::Write as _;
use vibrobar_core::analysis::lyapunov::LyapunovParams;
use vibrobar_core::analysis::lyapunov_spectrum::SpectrumParams;
use vibrobar_core::analysis::two_plane::max_lyapunov_two_plane;
use vibrobar_core::analysis::two_plane_orbit::{
    two_plane_lyapunov_spectrum, TWO_PLANE_ORBIT_SCOPE,
};
use vibrobar_core::params::two_plane::TwoPlaneSystem;
use vibrobar_core::solver::two_plane_rk4::TwoPlaneStart;

use super::check_value;
use super::explore::{transient_or_default, LyapunovArgs};
use super::poincare_two_plane::MemberRun;
use crate::scenario::Scenario;

/// Run the command on a scenario with `[two_plane]`.
pub fn run(a: &LyapunovArgs, sc: &Scenario) -> Result<()> {
    let MemberRun {
        scenario: s,
        sys,
        method,
        member,
        start,
        ratio,
        gap_mm,
    } = MemberRun::at(&a.point, sc, a.member)?;

    if a.spectrum {
        return spectrum(a, &s, &sys, &start, member);
    }
    let periods = check_value("--periods", a.periods, |x| x > 0.0, "(0, ∞)")?;
    let d0 = check_value("--d0", a.d0, |x| x > 0.0, "(0, ∞)")?;
    let settings = s.settings();
    let transient = transient_or_default(a.transient, &a.point.system)?;
    let interval = periods * 2.0 * std::f64::consts::PI / sys.omega_rad_s();
    let intervals = ((settings.duration_s - transient) / interval).floor() as usize;
    if intervals < 2 {
        bail!(
            "--duration {} s leaves {intervals} intervals of {interval:.3e} s after the \
             transient; at least 2 are needed (raise --duration or lower --periods)",
            vibrobar_core::error::Compact(settings.duration_s),
        );
    }
    let p = LyapunovParams {
        transient_s: transient,
        interval_s: interval,
        intervals,
        d0,
        scales: None,
        blocks: 10.min(intervals),
    };
    let r = max_lyapunov_two_plane(&sys, &start, method, &settings, &p)?;
    let solver = method.solver_for(&sys);
    if a.json {
        let j = serde_json::json!({
            "exponent_per_s": r.exponent_per_s,
            "std_error_per_s": r.std_error_per_s,
            "intervals": intervals,
            "interval_s": interval,
            "blocks": r.block_means_per_s.len(),
            "clamped": r.clamped,
            "d0": d0,
            "member": member,
            "solver": solver,
            "ratio": ratio,
            "axial_gap_m": gap_mm * 1e-3,
        });
        let _ = writeln!(std::io::stdout(), "{}", serde_json::to_string_pretty(&j)?);
    } else {
        println!(
            "λ = {:.4} ± {:.4} 1/s ({intervals} intervals of {interval:.3e} s, member {member}, \
             solver {solver}, {} projections into the hole)",
            r.exponent_per_s, r.std_error_per_s, r.clamped
        );
    }
    Ok(())
}

/// `--spectrum`: the planes' spectra over the window after the transient.
fn spectrum(
    a: &LyapunovArgs,
    s: &Scenario,
    sys: &TwoPlaneSystem,
    start: &TwoPlaneStart,
    member: usize,
) -> Result<()> {
    if let Err(why) = vibrobar_core::solver::two_plane_exact::decoupled(sys) {
        bail!("--spectrum: {TWO_PLANE_ORBIT_SCOPE}; here {why}");
    }
    let settings = s.settings();
    let transient = transient_or_default(a.transient, &a.point.system)?;
    let p = SpectrumParams {
        transient_s: transient,
        duration_s: settings.duration_s - transient,
        blocks: 10,
        scales: None,
    };
    let planes = two_plane_lyapunov_spectrum(sys, start, &p)?;
    let names = ["along_hole", "across_hole"];
    if a.json {
        let mut j = serde_json::json!({ "member": member, "spin_exponent_per_s": 0.0 });
        for (name, r) in names.iter().zip(&planes) {
            j[*name] = serde_json::json!({
                "exponents_per_s": r.exponents_per_s,
                "std_error_per_s": r.std_error_per_s,
                "collapsed": r.collapsed,
                "sum_per_s": r.sum_per_s,
                "impacts_per_s": r.impacts_per_s,
                "duration_s": r.duration_s,
            });
        }
        let _ = writeln!(std::io::stdout(), "{}", serde_json::to_string_pretty(&j)?);
    } else {
        for (name, r) in ["along the hole", "across the hole"].iter().zip(&planes) {
            let show = |v: &[Option<f64>], none: &str| -> String {
                v.iter()
                    .map(|x| x.map_or(none.to_string(), |x| format!("{x:.4}")))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            println!(
                "{name}: λ = [{}] 1/s, ± [{}] ({} impacts/s, {} directions collapsed by rest on \
                 a wall)",
                show(&r.exponents_per_s, "−∞"),
                show(&r.std_error_per_s, "–"),
                vibrobar_core::error::Compact(r.impacts_per_s),
                r.collapsed
            );
        }
        println!(
            "spin: λ = 0 (nothing acts on it on frictionless walls); member {member}, {} s window \
             in {} blocks",
            vibrobar_core::error::Compact(p.duration_s),
            p.blocks
        );
    }
    Ok(())
}
