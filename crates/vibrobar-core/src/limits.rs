//! Every limit in one place: the sizes a user can inflate (steps, samples, grid points, members,
//! shards, intervals) and the ranges outside which an input gives NaN, inf or numbers that mean
//! nothing. Each bound is checked *before* anything is allocated or run, and the error
//! ([`ParamError::Limit`]) names the field or flag and states the allowed range from the constant
//! itself, so the message cannot drift from the code.
//!
//! | what | limit | why |
//! |---|---|---|
//! | fixed-step (`rk4`) steps per run, `duration/dt` | ≤ [`MAX_STEPS`] = 1e9 | bounded work: about 90 s of `rk4` |
//! | `rk4` step, `ω_n·dt` (`ω_N` of a modal bar's highest mode) | ≤ [`RK4_MAX_OMEGA_DT`] = 2.5 | RK4's stability region (radius ≥ 2.61 for every damping) |
//! | samples of a history, Poincaré points, bifurcation points | ≤ [`MAX_SAMPLES`] = 1e7 | about 1.5 GB in memory |
//! | grid points of a sweep, map, ensemble or bifurcation | ≤ [`MAX_GRID_POINTS`] = 1e7 | memory of the row tables |
//! | ratios of a `sweep` | ≤ [`MAX_SWEEP_RATIOS`] = 1e5 | |
//! | ensemble members per point | ≤ [`MAX_ENSEMBLE_MEMBERS`] = 1e5 | |
//! | runs of one batch (points × members) | ≤ [`MAX_RUNS`] = 1e7 | |
//! | shards `N` of `--shard K/N` | ≤ [`MAX_SHARDS`] = 1e6 | `merge` checks every shard 1..N |
//! | worker threads `--threads` | ≤ [`MAX_THREADS`] = 1024 | OS threads |
//! | Lyapunov renormalisation intervals | ≤ [`MAX_LYAPUNOV_INTERVALS`] = 1e6 | |
//! | forcing phase `max(Ω, ω_max)·t` | ≤ [`MAX_PHASE_RAD`] = 1e10 rad | `sin(Ωt)` keeps 1e-6 rad of phase |
//! | frequency ratio `Ω/ω₁` (`√(K/M)` of a lumped bar) | [[`FREQ_RATIO_MIN`], [`FREQ_RATIO_MAX`]] = [1e-3, 1e3] | a one-mode model; outside, the response underflows or the period overflows |
//! | spindle speed `[cutting] spindle_rpm` | [[`SPINDLE_RPM_MIN`], [`SPINDLE_RPM_MAX`]] = [1, 200 000] rpm | a lathe spindle; the delay `60/n` stays within a run |
//! | spindle speeds of one `lobes` call | ≤ [`MAX_LOBE_SPEEDS`] = 1e6 | about 10 s; the rows stay in memory |
//! | RMS window `rms_fraction·duration` | ≥ `dt` | an empty window has no RMS |
//! | Lyapunov `d0` | [[`LYAPUNOV_D0_MIN`], [`LYAPUNOV_D0_MAX`]] = [1e-12, 1e-2] | representable and still linear |
//! | beam geometry and material | [`BEAM_LENGTH_M`], [`BEAM_DIAMETER_M`], [`BEAM_YOUNGS_MODULUS_PA`], [`BEAM_DENSITY_KG_M3`] | real bars; keeps `M`, `K` finite |
//! | beam modes `N` | [1, [`MAX_BEAM_MODES`]] = [1, 32] | Euler–Bernoulli's range; bounded eigenproblem |
//! | beam finite elements | ≤ [`MAX_FE_ELEMENTS`] = 600 | dense eigenproblem, about 2 s; finer meshes only add rounding |
//! | tip mass, rotary inertia | ≤ [`MAX_TIP_MASS_RATIO`] = 1e3 × `ρAL` (× `ρAL·L²`) | a boring bar, not a spring under a rigid body |
//!
//! Not an error but a warning: `rk4` leaves the ball beyond the wall by up to one step's travel;
//! past [`RK4_PENETRATION_WARN_FRACTION`] of the gap the CLI says so with the figure.

use crate::error::{Compact, ParamError};

/// Most steps of a fixed-step run (`duration / dt`): about 90 s of `rk4` at 85 ns per step.
pub const MAX_STEPS: f64 = 1e9;
/// Largest `ω_n·dt` for `rk4`. RK4's stability region contains every eigenvalue
/// `ω_n(−ζ ± i√(1−ζ²))` with `ω_n·dt` below 2.6156 (its smallest radius over the left half
/// plane); 2.5 leaves a margin. Accuracy needs far smaller steps (the paper: 0.0038).
pub const RK4_MAX_OMEGA_DT: f64 = 2.5;
/// `rk4` divergence backstop: `|u|` beyond this many times the system's own displacement scale
/// (static deflection under every force, initial state, half gap) is divergence, not physics
/// (linear growth at resonance reaches it only after ~1e12 radians, beyond [`MAX_PHASE_RAD`]).
pub const RK4_DIVERGENCE_FACTOR: f64 = 1e12;
/// `rk4` penetration beyond this fraction of the gap draws a warning (the paper's runs stay
/// below 0.4 %).
pub const RK4_PENETRATION_WARN_FRACTION: f64 = 0.01;
/// Most samples kept in memory: rows of a time history, Poincaré or bifurcation points
/// (about 150 B each: 1.5 GB).
pub const MAX_SAMPLES: f64 = 1e7;
/// Most points of one grid (sweep, map, ensemble, bifurcation values).
pub const MAX_GRID_POINTS: usize = 10_000_000;
/// Most ratios of one `sweep` (each gets a solid and a damped run per gap).
pub const MAX_SWEEP_RATIOS: usize = 100_000;
/// Most spindle speeds of one lobes computation.
pub const MAX_LOBE_SPEEDS: usize = 1_000_000;
/// Most frequency lines of one FRF (`frf --band-hz`, `sweep --freqs-hz`).
pub const MAX_FRF_LINES: usize = 100_000;
/// Highest frequency line of an FRF, Hz.
pub const MAX_FRF_FREQUENCY_HZ: f64 = 1e7;
/// Most forcing periods of a stepped sine's measuring window.
pub const MAX_MEASURE_PERIODS: u32 = 100_000;
/// Most taps of a simulated tap test.
pub const MAX_TAPS: usize = 1000;
/// Most samples of one simulated tap's record (`record_s × sample_rate_hz`).
pub const MAX_TAP_SAMPLES: f64 = 1e7;
/// Most ensemble members per point.
pub const MAX_ENSEMBLE_MEMBERS: usize = 100_000;
/// Most runs of one batch (grid points × ensemble members).
pub const MAX_RUNS: usize = 10_000_000;
/// Most shards of a map (`--shard K/N`).
pub const MAX_SHARDS: usize = 1_000_000;
/// Most worker threads (`--threads`): each is an OS thread with its own stack.
pub const MAX_THREADS: usize = 1024;
/// Most renormalisation intervals of a Lyapunov estimate.
pub const MAX_LYAPUNOV_INTERVALS: usize = 1_000_000;
/// Largest phase `max(Ω, ω_max)·t` of a run (`ω_max` the highest mode kept): beyond it `sin(Ωt)` has lost more than 1e-6 rad.
pub const MAX_PHASE_RAD: f64 = 1e10;
/// Smallest frequency ratio `Ω/ω₁` (`√(K/M)` of a lumped bar).
pub const FREQ_RATIO_MIN: f64 = 1e-3;
/// Largest frequency ratio `Ω/ω₁`.
pub const FREQ_RATIO_MAX: f64 = 1e3;
/// Slowest spindle speed of a cut, rpm (`[cutting] spindle_rpm`, `--spindle-rpm`).
pub const SPINDLE_RPM_MIN: f64 = 1.0;
/// Fastest spindle speed of a cut, rpm: a delay of 0.3 ms, above any lathe spindle.
pub const SPINDLE_RPM_MAX: f64 = 200_000.0;
/// Smallest Lyapunov separation `d0` (scaled units, state components are O(1)–O(100)): below
/// it the perturbation is lost to rounding and the estimate measures round-off.
pub const LYAPUNOV_D0_MIN: f64 = 1e-12;
/// Largest Lyapunov separation `d0`: beyond it the two trajectories no longer see the
/// linearised flow.
pub const LYAPUNOV_D0_MAX: f64 = 1e-2;
/// Range of a beam's overhang length, m.
pub const BEAM_LENGTH_M: (f64, f64) = (1e-3, 100.0);
/// Range of a beam's outer diameter, m.
pub const BEAM_DIAMETER_M: (f64, f64) = (1e-4, 10.0);
/// Range of Young's modulus, Pa (soft polymers to diamond).
pub const BEAM_YOUNGS_MODULUS_PA: (f64, f64) = (1e6, 1e13);
/// Range of density, kg/m³.
pub const BEAM_DENSITY_KG_M3: (f64, f64) = (1.0, 1e5);

/// Most modes of a beam or of measured modes (`beam.modes`, `--beam-modes`): far beyond where
/// Euler–Bernoulli theory holds for a boring bar (shear and rotary inertia matter from about the
/// 5th mode of a slender bar), and the finite-element model of that many modes stays a dense
/// eigenproblem of about 1,000 unknowns.
pub const MAX_BEAM_MODES: usize = 32;
/// Most finite elements of a beam (`beam.fe_elements` or the mesh rule; the rule needs about 530
/// for [`MAX_BEAM_MODES`]): a dense eigenproblem of `2·MAX_FE_ELEMENTS` unknowns, about 2 s and
/// 25 MB. Finer meshes buy nothing: the rounding of the assembled stiffness grows as `ε·n⁴`
/// (measured error of `ω₁`: 1.3e-7 at 500 elements, 4e-5 at 1000).
pub const MAX_FE_ELEMENTS: usize = 600;
/// Largest tip mass as a multiple of the bar's own mass `ρAL` (and tip rotary inertia as a
/// multiple of `ρAL·L²`): beyond it the bar is a spring under a rigid body, not a boring bar.
pub const MAX_TIP_MASS_RATIO: f64 = 1e3;
/// Longest periodic orbit, in forcing cycles (`--period`): beyond it a "periodic orbit" is
/// better studied as a Poincaré section, and the map's sensitivity grows like `|λ|^k`.
pub const MAX_ORBIT_PERIOD: u32 = 64;
/// Most points of one continuation branch (`--max-points`).
pub const MAX_CONTINUATION_POINTS: usize = 100_000;
/// Most ratios and gaps of `orbit-stability`'s grid (each point is a Newton solve and each ratio
/// a continuation).
pub const MAX_ORBIT_STABILITY_AXIS: usize = 1000;

/// `value` must lie in `[min, max]` (NaN never does). `why` says why or how to get within it
/// (may be empty). Returns the value.
pub fn check(
    field: &'static str,
    value: f64,
    min: f64,
    max: f64,
    why: &'static str,
) -> Result<f64, ParamError> {
    if value >= min && value <= max {
        Ok(value)
    } else {
        Err(ParamError::Limit {
            field,
            value,
            min,
            max,
            why,
        })
    }
}

/// A count must lie in `[min, max]`.
pub fn check_count(
    field: &'static str,
    n: usize,
    min: usize,
    max: usize,
    why: &'static str,
) -> Result<usize, ParamError> {
    check(field, n as f64, min as f64, max as f64, why).map(|_| n)
}

/// A quantity derived from inputs must lie in `[min, max]`; the error shows the inputs
/// (`inputs()`, e.g. `"1e308 s / 1e-5 s"`) as given, not only the quantity (which overflows to
/// inf for huge inputs).
pub fn check_derived(
    field: &'static str,
    inputs: impl FnOnce() -> String,
    value: f64,
    min: f64,
    max: f64,
    why: &'static str,
) -> Result<f64, ParamError> {
    if value >= min && value <= max {
        Ok(value)
    } else {
        Err(ParamError::DerivedLimit {
            field,
            inputs: inputs(),
            value,
            min,
            max,
            why,
        })
    }
}

/// A derived input for a message: 4 significant digits, compact (`9.999999999999999e-6` of
/// `10 · 1e-6` prints as `1e-5`).
fn short(x: f64) -> Compact {
    Compact(format!("{x:.3e}").parse().unwrap_or(x))
}

/// The phase `rate·t` of a run reaching time `t_s` (largest `|t|` of the run) at the fastest
/// rate `rate_rad_s = max(Ω, ω_n)` must stay within [`MAX_PHASE_RAD`].
pub fn check_phase(rate_rad_s: f64, t_s: f64) -> Result<f64, ParamError> {
    check_derived(
        "phase max(Ω, ω_n)·t_end in rad (duration_s, --duration)",
        || format!("{} rad/s · {} s", short(rate_rad_s), Compact(t_s)),
        rate_rad_s * t_s,
        0.0,
        MAX_PHASE_RAD,
        "beyond it sin(Ωt) loses its phase: shorten the run or lower the frequency",
    )
}

/// Number of samples `⌊duration/interval⌋ + 1` of a grid `0, interval, …` over `duration`,
/// checked against [`MAX_SAMPLES`] before anything is sampled. `field` names what sets the
/// interval.
pub fn check_samples(
    field: &'static str,
    duration_s: f64,
    interval_s: f64,
) -> Result<u64, ParamError> {
    let n = (duration_s / interval_s + 1e-9).floor() + 1.0;
    check_derived(
        field,
        || format!("{} s / {} s", Compact(duration_s), short(interval_s)),
        n,
        1.0,
        MAX_SAMPLES,
        "samples kept in memory; sample less often or run shorter",
    )
    .map(|n| n as u64)
}

/// The last line of defence: a result must be finite before it is written.
pub fn finite_result(
    quantity: &'static str,
    value: f64,
    cause: &'static str,
) -> Result<f64, ParamError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ParamError::NonFiniteResult {
            quantity,
            value,
            cause,
        })
    }
}

/// The solid bar's RMS as the reference of a reduction `100(1 − damped/solid)`: it must be
/// positive, or every reduction is 0/0 (a bar without any force, started at rest).
pub fn reference_rms(rms_solid_m: f64) -> Result<f64, ParamError> {
    if rms_solid_m > 0.0 && rms_solid_m.is_finite() {
        Ok(rms_solid_m)
    } else {
        Err(ParamError::NonFiniteResult {
            quantity: "reduction_pct = 100(1 − rms_damped/rms_solid)",
            value: rms_solid_m,
            cause: "the solid bar does not move (rms_solid = 0): forcing.amplitude_n and static_force_n are 0 and it starts at rest",
        })
    }
}

/// Penetration as a fraction of the gap when it exceeds [`RK4_PENETRATION_WARN_FRACTION`]
/// (`None` otherwise): what the CLI warns about after an `rk4` run.
pub fn excessive_penetration(max_penetration_m: f64, gap_m: f64) -> Option<f64> {
    let f = max_penetration_m / gap_m;
    (f > RK4_PENETRATION_WARN_FRACTION).then_some(f)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// RK4's amplification factor `R(z) = 1 + z + z²/2 + z³/6 + z⁴/24` stays within the unit
    /// circle for every `|z| ≤ RK4_MAX_OMEGA_DT` in the left half plane (every damping ratio).
    #[test]
    fn rk4_limit_is_inside_the_stability_region() {
        for k in 0..=2000 {
            let th = std::f64::consts::FRAC_PI_2 * (1.0 + k as f64 / 2000.0);
            for j in 1..=250 {
                let r = RK4_MAX_OMEGA_DT * j as f64 / 250.0;
                let (x, y) = (r * th.cos(), r * th.sin());
                // Complex powers by hand.
                let mul =
                    |a: (f64, f64), b: (f64, f64)| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
                let z = (x, y);
                let z2 = mul(z, z);
                let z3 = mul(z2, z);
                let z4 = mul(z3, z);
                let re = 1.0 + z.0 + z2.0 / 2.0 + z3.0 / 6.0 + z4.0 / 24.0;
                let im = z.1 + z2.1 / 2.0 + z3.1 / 6.0 + z4.1 / 24.0;
                assert!(
                    re * re + im * im <= 1.0 + 1e-12,
                    "|R| > 1 at r = {r}, θ = {th}"
                );
            }
        }
    }

    #[test]
    fn checks_name_the_field_and_the_range_from_the_constant() {
        let e = check_count(
            "ensemble.members (--members)",
            1_000_000_000,
            1,
            MAX_ENSEMBLE_MEMBERS,
            "",
        )
        .unwrap_err()
        .to_string();
        assert_eq!(
            e,
            "ensemble.members (--members) = 1e9 is outside the allowed range [1, 100000]"
        );
        assert!(check("x", f64::NAN, 0.0, 1.0, "").is_err());
        assert_eq!(check_samples("s", 2.0, 1e-5).unwrap(), 200_001);
        assert!(check_samples("s", 2.0, 1e-320).is_err());
        assert!(finite_result("RMS", f64::NAN, "c").is_err());
        // `--duration 1e308` was reported as `= inf`: the value given is shown, compactly.
        let e = check_samples("rows", 1e308, 1e-5).unwrap_err().to_string();
        assert_eq!(
            e,
            "rows = 1e308 s / 1e-5 s is outside the allowed range [1, 1e7] (samples kept in \
             memory; sample less often or run shorter)"
        );
        let e = check_phase(3783.5, 1e308).unwrap_err().to_string();
        assert!(
            e.contains("= 3784 rad/s · 1e308 s is outside the allowed range [0, 1e10]"),
            "{e}"
        );
        assert!(!e.contains("inf"), "{e}");
        let e = check_phase(3783.5, 1e7).unwrap_err().to_string();
        assert!(
            e.contains("3784 rad/s · 1e7 s = 3.7835e10 is outside"),
            "{e}"
        );
        assert_eq!(excessive_penetration(3.6e-7, 1e-4), None);
        assert!(excessive_penetration(1.3e-4, 1e-4).unwrap() > 1.0);
    }
}
