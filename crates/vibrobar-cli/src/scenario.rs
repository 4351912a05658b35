//! Scenario files on the command line: the scenario type itself (TOML ⇄ core types, `[beam]`,
//! validation naming the field) is the library `vibrobar-scenario`, shared with the Python
//! package; this module adds only what flags need: `--preset`/`--scenario` as a [`Source`],
//! the model flags on top ([`ScenarioArgs::from_args`]) and `--ratios START:STOP:STEP`.

use anyhow::Result;
use std::path::Path;
pub use vibrobar_scenario::*;

/// Where the parameters come from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Source<'a> {
    /// A built-in set.
    Preset(crate::cli::Preset),
    /// A scenario file.
    File(&'a Path),
}

/// A scenario from command-line arguments.
pub trait ScenarioArgs: Sized {
    /// A preset or a file.
    fn from_source(src: Source) -> Result<Self>;
    /// Preset or file, then the flags on top.
    fn from_args(args: &crate::cli::ModelArgs) -> Result<Self>;
}

impl ScenarioArgs for Scenario {
    fn from_source(src: Source) -> Result<Self> {
        match src {
            Source::Preset(crate::cli::Preset::Paper) => Ok(Self::paper()),
            Source::File(p) => Self::load(p),
        }
    }

    fn from_args(args: &crate::cli::ModelArgs) -> Result<Self> {
        let src = match (&args.scenario, args.preset) {
            (Some(p), _) => Source::File(p),
            (None, p) => Source::Preset(p.unwrap_or(crate::cli::Preset::Paper)),
        };
        let mut s = Self::from_source(src)?;
        s.apply(&Overrides {
            friction: args.friction.map(Into::into),
            friction_force_n: args.friction_force_n,
            contact: args.contact.map(Into::into),
            solver: args.solver.clone(),
            dt: args.dt,
            duration: args.duration,
            rms_fraction: None,
            width_mm: args.width_mm,
            spindle_rpm: args.spindle_rpm,
        })?;
        s.apply_beam_flags(args.beam_modes, args.cavity_position_mm)?;
        Ok(s)
    }
}

/// Parse `START:STOP:STEP` (STOP included) into ratios, via core `linspace_inclusive`.
pub fn parse_ratios(spec: &str) -> Result<Vec<f64>> {
    let parts: Vec<&str> = spec.split(':').collect();
    if parts.len() != 3 {
        anyhow::bail!("--ratios must be START:STOP:STEP (e.g. 0.95:1.05:0.01), got {spec:?}");
    }
    let mut v = [0.0; 3];
    for (i, (p, name)) in parts.iter().zip(["START", "STOP", "STEP"]).enumerate() {
        v[i] = p.trim().parse::<f64>().map_err(|_| {
            anyhow::anyhow!("--ratios {name} must be a number, got {p:?} (in {spec:?})")
        })?;
    }
    ratio_range(v[0], v[1], v[2])
}
