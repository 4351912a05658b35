//! Shared pieces of the design-analysis commands (map, merge, poincare, bifurcation, lyapunov,
//! ensemble): system flags, checked ranges, thread pools, grid-coordinate formatting.

use anyhow::{bail, Context};
use vibrobar_core::analysis::{checked_linspace_inclusive, SweepBase};
use vibrobar_core::error::Compact;
use vibrobar_core::params::{FrictionModel, RunSettings};
use vibrobar_core::solver::{solver_by_name, Solver, SOLVER_NAMES};

pub use crate::cli::{FrictionArg, Preset};
pub use crate::DEFAULT_SOLVER;

impl Preset {
    /// The bars, ball and forcing of the preset.
    pub fn base(self) -> SweepBase {
        match self {
            Preset::Paper => SweepBase::paper(),
        }
    }

    /// Name in output files.
    pub fn as_str(self) -> &'static str {
        match self {
            Preset::Paper => "paper",
        }
    }
}

/// Flags shared by every design command: system, friction and solver settings.
#[derive(Debug, Clone, clap::Args)]
pub struct SystemArgs {
    /// Bars, ball and forcing.
    #[arg(long, value_enum, default_value = "paper")]
    pub preset: Preset,
    /// Friction law between ball and bar.
    #[arg(long, value_enum)]
    pub friction: FrictionArg,
    /// Friction force level in N (default: the preset's η/r·m_d·g = 0.0204 N).
    #[arg(long, allow_negative_numbers = true)]
    pub friction_force_n: Option<f64>,
    /// Solver (`exact` event-driven when available, or `rk4` with fixed step `--dt`).
    #[arg(long, default_value = DEFAULT_SOLVER)]
    pub solver: String,
    /// Simulated time of each run, in s.
    #[arg(long, allow_negative_numbers = true, default_value_t = 2.0)]
    pub duration: f64,
    /// Step of `rk4` (output-grid unit for `exact`), in s.
    #[arg(long, allow_negative_numbers = true, default_value_t = 1e-6)]
    pub dt: f64,
    /// Fraction of the run, from the end, over which RMS and impact rates are taken.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.8)]
    pub rms_fraction: f64,
}

impl SystemArgs {
    /// Checked run settings.
    pub fn settings(&self) -> anyhow::Result<RunSettings> {
        if !(self.duration.is_finite() && self.duration > 0.0) {
            bail!(
                "--duration must be in (0, ∞) s, got {}",
                Compact(self.duration)
            );
        }
        if !(self.dt.is_finite() && self.dt > 0.0 && self.dt <= self.duration) {
            bail!(
                "--dt must be in (0, --duration = {}] s, got {}",
                Compact(self.duration),
                Compact(self.dt)
            );
        }
        if !(self.rms_fraction > 0.0 && self.rms_fraction <= 1.0) {
            bail!(
                "--rms-fraction must be in (0, 1], got {}",
                Compact(self.rms_fraction)
            );
        }
        let settings = RunSettings {
            duration_s: self.duration,
            dt_s: self.dt,
            rms_fraction: self.rms_fraction,
        };
        // The core's limits (an RMS window of at least one step), before any file is opened.
        settings.validate()?;
        Ok(settings)
    }

    /// Preset base with the friction override applied and checked.
    pub fn base(&self) -> anyhow::Result<SweepBase> {
        let mut base = self.preset.base();
        if let Some(f) = self.friction_force_n {
            if !(f.is_finite() && f >= 0.0) {
                bail!("--friction-force-n must be in [0, ∞) N, got {}", Compact(f));
            }
            base.ball.friction_force_n = Some(f);
        }
        Ok(base)
    }

    /// The solver named by `--solver`.
    pub fn solver(&self) -> anyhow::Result<Box<dyn Solver>> {
        make_solver(&self.solver, &self.settings()?)
    }

    /// Parameters for metadata (SI units).
    pub fn to_params(&self) -> anyhow::Result<vibrobar_io::params::SystemParams> {
        let mut base = self.base()?;
        // The ball is a template: its gap is set per grid point (or by --gap-mm). Its friction
        // fields are made to say what the runs use, so the file does not contradict itself.
        base.ball.friction = self.friction.into();
        base.ball.friction_force_n = self.friction_force_n;
        Ok(vibrobar_io::params::SystemParams {
            note:
                "ball.gap_m is a template value: each run's gap is its grid coordinate or --gap-mm"
                    .into(),
            preset: self.preset.as_str().into(),
            friction: FrictionModel::from(self.friction).as_str().into(),
            friction_force_n: self.friction_force_n,
            damped_bar: base.damped_bar,
            solid_bar: base.solid_bar,
            ball: base.ball,
            forcing: base.forcing,
            solver: self.solver.clone(),
            settings: self.settings()?,
        })
    }

    /// [`to_params`](Self::to_params) as JSON.
    pub fn to_json(&self) -> anyhow::Result<serde_json::Value> {
        Ok(serde_json::to_value(self.to_params()?)?)
    }
}

/// Build a solver by name, with an error listing the known names.
pub fn make_solver(name: &str, settings: &RunSettings) -> anyhow::Result<Box<dyn Solver>> {
    solver_by_name(name, settings).with_context(|| {
        format!(
            "--solver must be one of {}, got {name:?}",
            SOLVER_NAMES.join(", ")
        )
    })
}

/// Parse `START:STOP:STEP` (inclusive) for `flag`, checking every value with `ok`
/// (`allowed` describes the allowed values in the error message).
pub fn parse_range(
    flag: &str,
    text: &str,
    ok: impl Fn(f64) -> bool,
    allowed: &str,
) -> anyhow::Result<Vec<f64>> {
    let form = "START:STOP:STEP with START ≤ STOP and STEP > 0";
    let parts: Vec<&str> = text.split(':').collect();
    let nums: Vec<f64> = match parts.as_slice() {
        [a, b, c] => [a, b, c]
            .iter()
            .map(|s| s.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| anyhow::anyhow!("{flag} must be {form}, got {text:?}"))?,
        _ => bail!("{flag} must be {form}, got {text:?}"),
    };
    let (start, stop, step) = (nums[0], nums[1], nums[2]);
    if !(start.is_finite() && stop.is_finite() && step.is_finite()) {
        bail!("{flag} must be {form} with finite numbers, got {text:?}");
    }
    if stop < start {
        bail!(
            "{flag}: STOP {} is below START {}; {flag} must be {form}",
            Compact(stop),
            Compact(start)
        );
    }
    if step <= 0.0 {
        bail!(
            "{flag}: STEP {} must be > 0; {flag} must be {form}",
            Compact(step)
        );
    }
    let v = checked_linspace_inclusive(start, stop, step)
        .map_err(|e| anyhow::anyhow!("{flag}: {e}"))?;
    for &x in &v {
        if !ok(x) {
            bail!(
                "{flag}: value {} is outside the allowed range {allowed}",
                Compact(x)
            );
        }
    }
    Ok(v)
}

/// Check a single value for `flag`.
pub fn check_value(
    flag: &str,
    x: f64,
    ok: impl Fn(f64) -> bool,
    allowed: &str,
) -> anyhow::Result<f64> {
    if x.is_finite() && ok(x) {
        Ok(x)
    } else {
        bail!(
            "{flag} = {} is outside the allowed range {allowed}",
            Compact(x)
        )
    }
}

/// A grid coordinate as the map CSV writes it (12 significant digits), defined by the schema.
pub use vibrobar_io::csv::fmt_coord;

/// Run `f` on a pool of `threads` threads, or on rayon's global pool (`RAYON_NUM_THREADS`).
pub fn with_threads<R: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> R + Send,
) -> anyhow::Result<R> {
    match threads {
        None => Ok(f()),
        Some(0) => bail!("--threads must be in [1, ∞), got 0"),
        Some(n) => Ok(rayon::ThreadPoolBuilder::new()
            .num_threads(vibrobar_core::limits::check_count(
                "--threads",
                n,
                1,
                vibrobar_core::limits::MAX_THREADS,
                "",
            )?)
            .build()
            .context("--threads: cannot start the thread pool")?
            .install(f)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_solver_is_exact_exactly_when_the_core_has_it() {
        assert_eq!(DEFAULT_SOLVER == "exact", SOLVER_NAMES.contains(&"exact"));
        assert!(SOLVER_NAMES.contains(&DEFAULT_SOLVER));
    }

    #[test]
    fn ranges_are_inclusive_and_errors_name_the_flag() {
        let v = parse_range("--ratios", "0.95:1.05:0.01", |x| x > 0.0, "(0, ∞)").unwrap();
        assert_eq!(v.len(), 11);
        assert_eq!(fmt_coord(v[10]), "1.05");
        assert_eq!(fmt_coord(v[1]), "0.96");
        let one = parse_range("--gaps-mm", "0.1:0.1:0.1", |x| x > 0.0, "(0, ∞)").unwrap();
        assert_eq!(one.len(), 1);
        for (text, want) in [
            ("1:0.5:0.1", "below START"),
            ("0.5:1:-0.1", "STEP"),
            ("0.5:1", "START:STOP:STEP"),
            ("a:1:0.1", "START:STOP:STEP"),
            ("-1:1:0.5", "outside the allowed range (0, ∞)"),
            ("0.1:1:1e-12", "at most 1e7 points"),
        ] {
            let e = parse_range("--x", text, |x| x > 0.0, "(0, ∞)")
                .unwrap_err()
                .to_string();
            assert!(e.starts_with("--x"), "{e}");
            assert!(e.contains(want), "{text}: {e}");
        }
    }

    #[test]
    fn coordinates_print_without_rounding_noise_but_keep_real_digits() {
        assert_eq!(fmt_coord(0.1 + 0.2), "0.3");
        assert_eq!(fmt_coord(1.234_567_890_12), "1.23456789012");
        assert_eq!(fmt_coord(1e-7), "0.0000001");
        assert_eq!(fmt_coord(1.0), "1");
    }
}
