//! Shared pieces of the design-analysis commands (map, merge, poincare, bifurcation, lyapunov,
//! ensemble): system flags, checked ranges, thread pools, grid-coordinate formatting.

use anyhow::{bail, Context};
use std::path::PathBuf;
use vibrobar_core::analysis::{checked_linspace_inclusive, SweepBase};
use vibrobar_core::error::Compact;
use vibrobar_core::params::{FrictionModel, RunSettings};
use vibrobar_core::solver::{solver_by_name, Solver, SOLVER_NAMES};

pub use crate::cli::{FrictionArg, Preset};
use crate::scenario::{Overrides, Scenario, ScenarioArgs, Source};
pub use crate::DEFAULT_SOLVER;

impl Preset {
    /// Name in output files.
    pub fn as_str(self) -> &'static str {
        match self {
            Preset::Paper => "paper",
        }
    }
}

/// Flags shared by every design command: where the system comes from (a preset or a scenario
/// file), and the friction and run settings on top of it.
#[derive(Debug, Clone, clap::Args)]
pub struct SystemArgs {
    /// Built-in bars, ball and forcing (the default when no --scenario is given).
    #[arg(long, value_enum, conflicts_with = "scenario")]
    pub preset: Option<Preset>,
    /// Scenario file (TOML, SI units, as for `run` and `sweep`; fields not given keep the paper's
    /// values): bars, ball, forcing, gravity, initial state, run settings and solver. The grid or
    /// point flags set the ratio and gap; the flags below override the file.
    #[arg(long, value_name = "FILE.toml")]
    pub scenario: Option<PathBuf>,
    /// Friction law between ball and bar (required without --scenario) [default: the scenario's].
    #[arg(long, value_enum, required_unless_present = "scenario")]
    pub friction: Option<FrictionArg>,
    /// Friction force level in N (default: the scenario's, else η/r·m_d·g = 0.0204 N).
    #[arg(long, allow_negative_numbers = true)]
    pub friction_force_n: Option<f64>,
    /// Ball–wall contact law [default: the scenario's `[contact] law`, else restitution].
    #[arg(long, value_enum)]
    pub contact: Option<crate::cli::ContactArg>,
    /// Solver (`exact` event-driven when available, or `rk4` with fixed step `--dt`)
    /// [default: the scenario's, else exact].
    #[arg(long)]
    pub solver: Option<String>,
    /// Simulated time of each run, in s [default: the scenario's, else 2].
    #[arg(long, allow_negative_numbers = true)]
    pub duration: Option<f64>,
    /// Step of `rk4` (output-grid unit for `exact`), in s [default: the scenario's, else 1e-6].
    #[arg(long, allow_negative_numbers = true)]
    pub dt: Option<f64>,
    /// Fraction of the run, from the end, over which RMS and impact rates are taken
    /// [default: the scenario's, else 0.8].
    #[arg(long, allow_negative_numbers = true)]
    pub rms_fraction: Option<f64>,
    /// Number of modes N of a `[beam]` scenario, overriding `[beam] modes`, in [1, 32]
    /// [default: the fewest (at least 3) capturing 99.5 % of the static tip compliance].
    #[arg(long, value_name = "N")]
    pub beam_modes: Option<usize>,
    /// Cavity centre (the ball) of a `[beam]` scenario in mm from the clamp, in [0, L],
    /// overriding `[beam] cavity_position_m`.
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub cavity_position_mm: Option<f64>,
    /// The scenario, read once: every later use (runs, metadata) sees the same values even if
    /// the file changes meanwhile.
    #[arg(skip)]
    pub loaded: std::sync::OnceLock<Scenario>,
}

impl SystemArgs {
    /// The scenario (preset or file) with the flags applied, checked; the file is read once.
    pub fn scenario(&self) -> anyhow::Result<Scenario> {
        if let Some(s) = self.loaded.get() {
            return Ok(s.clone());
        }
        let s = self.load()?;
        Ok(self.loaded.get_or_init(|| s).clone())
    }

    fn load(&self) -> anyhow::Result<Scenario> {
        let src = match (&self.scenario, self.preset) {
            (Some(p), _) => Source::File(p),
            (None, p) => Source::Preset(p.unwrap_or(Preset::Paper)),
        };
        let mut sc = Scenario::from_source(src)?;
        sc.apply(&Overrides {
            friction: self.friction.map(Into::into),
            friction_force_n: self.friction_force_n,
            contact: self.contact.map(Into::into),
            solver: self.solver.clone(),
            dt: self.dt,
            duration: self.duration,
            rms_fraction: self.rms_fraction,
            ..Overrides::default()
        })?;
        sc.apply_beam_flags(self.beam_modes, self.cavity_position_mm)?;
        let st = sc.settings();
        if self.dt.is_some() && st.dt_s > st.duration_s {
            bail!(
                "--dt must be in (0, --duration = {}] s, got {}",
                Compact(st.duration_s),
                Compact(st.dt_s)
            );
        }
        // The base as loaded (bars, ball, forcing, gravity, initial state, settings) must be
        // valid before any point varies it; errors name the scenario field.
        sc.validate()?;
        Ok(sc)
    }

    /// Checked run settings.
    pub fn settings(&self) -> anyhow::Result<RunSettings> {
        Ok(self.scenario()?.settings())
    }

    /// Bars, ball, forcing, gravity and initial state, with the friction flags applied.
    pub fn base(&self) -> anyhow::Result<SweepBase> {
        self.scenario()?.base()
    }

    /// The friction law the runs use.
    pub fn friction(&self) -> anyhow::Result<FrictionModel> {
        Ok(self.scenario()?.damper.friction)
    }

    /// Name of the solver the runs use.
    pub fn solver_name(&self) -> anyhow::Result<String> {
        Ok(self.scenario()?.run.solver)
    }

    /// The solver named by `--solver` (or the scenario).
    pub fn solver(&self) -> anyhow::Result<Box<dyn Solver>> {
        let sc = self.scenario()?;
        match sc.cutting_solver()? {
            Some(s) => Ok(s),
            None => make_solver(&sc.run.solver, &sc.settings()),
        }
    }

    /// Parameters for metadata (SI units).
    pub fn to_params(&self) -> anyhow::Result<vibrobar_io::params::SystemParams> {
        let sc = self.scenario()?;
        let base = sc.base()?;
        Ok(vibrobar_io::params::SystemParams {
            note:
                "ball.gap_m is a template value: each run's gap is its grid coordinate or --gap-mm"
                    .into(),
            preset: self
                .scenario
                .is_none()
                .then(|| self.preset.unwrap_or(Preset::Paper).as_str().into()),
            scenario_file: self.scenario.as_ref().map(|p| p.display().to_string()),
            friction: sc.damper.friction.as_str().into(),
            friction_force_n: base.ball.friction_force_n,
            damped_bar: base.damped_bar,
            solid_bar: base.solid_bar,
            ball: base.ball,
            forcing: base.forcing,
            gravity_m_s2: base.gravity_m_s2,
            initial: base.init,
            solver: sc.run.solver.clone(),
            settings: sc.settings(),
            beam: sc.beam.clone(),
            cutting: sc.cutting,
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
