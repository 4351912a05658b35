//! `vibrobar lyapunov` on a `[two_plane]` scenario: the largest Lyapunov exponent of one
//! member's run by two-trajectory divergence with renormalisation.

use anyhow::{bail, Result};
use std::io::Write as _;
use vibrobar_core::analysis::lyapunov::LyapunovParams;
use vibrobar_core::analysis::two_plane::max_lyapunov_two_plane;

use super::check_value;
use super::explore::{transient_or_default, LyapunovArgs};
use super::poincare_two_plane::MemberRun;
use crate::scenario::Scenario;

/// Run the command on a scenario with `[two_plane]`.
pub fn run(a: &LyapunovArgs, sc: &Scenario) -> Result<()> {
    if a.spectrum {
        bail!(
            "--spectrum: the spectrum needs the saltation matrix of every transition of the \
             two-plane bar (impacts and rests on the plugs and on the hole's wall, lift-offs, \
             corners), which is not derived; the largest exponent (without --spectrum) runs"
        );
    }
    let MemberRun {
        scenario: s,
        sys,
        method,
        member,
        start,
        ratio,
        gap_mm,
    } = MemberRun::at(&a.point, sc, a.member)?;
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
