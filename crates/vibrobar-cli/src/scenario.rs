//! Scenario files: TOML in SI units with unit-bearing names, mirroring the core parameters.
//! Every field is optional and defaults to the paper's value; unknown fields are errors, so a
//! typo never silently falls back to a default.

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;
use vibrobar_core::analysis::SweepBase;
use vibrobar_core::params::STANDARD_GRAVITY_M_S2;
use vibrobar_core::{Bar, Damper, Forcing, Frequency, FrictionModel, RunSettings, State, System};

use crate::cli::{ModelArgs, Preset};

/// A bar (`[bar]` with the cavity, `[solid_bar]` the reference).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BarToml {
    /// Lumped mass `M` in kg.
    pub mass_kg: f64,
    /// Lumped stiffness `K` in N/m.
    pub stiffness_n_per_m: f64,
    /// Damping ratio ζ, `C = 2ζ√(KM)`.
    pub damping_ratio: f64,
}

impl From<Bar> for BarToml {
    fn from(b: Bar) -> Self {
        BarToml {
            mass_kg: b.mass_kg,
            stiffness_n_per_m: b.stiffness_n_per_m,
            damping_ratio: b.damping_ratio,
        }
    }
}

impl From<BarToml> for Bar {
    fn from(b: BarToml) -> Self {
        Bar {
            mass_kg: b.mass_kg,
            stiffness_n_per_m: b.stiffness_n_per_m,
            damping_ratio: b.damping_ratio,
        }
    }
}

/// `[damper]`: the ball in its cavity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DamperToml {
    /// Ball mass `m_d` in kg.
    pub ball_mass_kg: f64,
    /// Ball radius in m.
    pub ball_radius_m: f64,
    /// Coefficient of restitution, in [0, 1].
    pub restitution: f64,
    /// Total clearance in m (the ball moves ±gap/2).
    pub gap_m: f64,
    /// Coefficient of rolling friction η in m.
    pub rolling_friction_m: f64,
    /// `none`, `as-published` or `coulomb`.
    pub friction: FrictionModel,
    /// Friction force in N overriding η/r·m_d·g.
    pub friction_force_n: Option<f64>,
}

impl Default for DamperToml {
    fn default() -> Self {
        let d = Damper::paper(0.1e-3, FrictionModel::None);
        DamperToml {
            ball_mass_kg: d.ball_mass_kg,
            ball_radius_m: d.ball_radius_m,
            restitution: d.restitution,
            gap_m: d.gap_m,
            rolling_friction_m: d.rolling_friction_m,
            friction: d.friction,
            friction_force_n: d.friction_force_n,
        }
    }
}

/// `[forcing]`: `F(t) = F_s + F0 sin(Ωt)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ForcingToml {
    /// `F0` in N.
    pub amplitude_n: f64,
    /// `F_s` in N.
    pub static_force_n: f64,
    /// `Ω / √(K/M)` of the bar simulated.
    pub frequency_ratio: f64,
}

impl Default for ForcingToml {
    fn default() -> Self {
        ForcingToml {
            amplitude_n: 15.0,
            static_force_n: 0.0,
            frequency_ratio: 1.0,
        }
    }
}

/// `[run]`: duration, step, RMS window, solver.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RunToml {
    /// Simulated time in s.
    pub duration_s: f64,
    /// Time step in s.
    pub dt_s: f64,
    /// Fraction of the run, from the end, over which RMS is taken.
    pub rms_fraction: f64,
    /// Solver name.
    pub solver: String,
}

impl Default for RunToml {
    fn default() -> Self {
        let s = RunSettings::default();
        RunToml {
            duration_s: s.duration_s,
            dt_s: s.dt_s,
            rms_fraction: s.rms_fraction,
            solver: crate::DEFAULT_SOLVER.to_string(),
        }
    }
}

/// `[initial]`: initial conditions (the paper: all zero, ball centred).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InitialToml {
    /// Bar displacement in m.
    pub u_m: f64,
    /// Bar velocity in m/s.
    pub du_m_s: f64,
    /// Ball position relative to the cavity centre, `w = v − u`, in m.
    pub w_m: f64,
    /// Relative velocity `ẇ` in m/s.
    pub dw_m_s: f64,
}

/// `[sweep]`: ratio range and gaps of `vibrobar sweep`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SweepToml {
    /// First ratio.
    pub ratio_start: f64,
    /// Last ratio (included).
    pub ratio_stop: f64,
    /// Ratio step.
    pub ratio_step: f64,
    /// Total clearances in m.
    pub gaps_m: Vec<f64>,
}

impl Default for SweepToml {
    fn default() -> Self {
        SweepToml {
            ratio_start: 0.95,
            ratio_stop: 1.05,
            ratio_step: 0.01,
            gaps_m: vec![0.1e-3, 1.0e-3],
        }
    }
}

/// A whole scenario. Missing fields keep the paper's values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Scenario {
    /// Gravity in m/s² (enters the derived friction force).
    pub gravity_m_s2: f64,
    /// Bar with the cavity.
    pub bar: BarToml,
    /// Solid reference bar.
    pub solid_bar: BarToml,
    /// The ball.
    pub damper: DamperToml,
    /// External force.
    pub forcing: ForcingToml,
    /// Run settings.
    pub run: RunToml,
    /// Initial conditions.
    pub initial: InitialToml,
    /// Sweep range.
    pub sweep: SweepToml,
}

impl Default for Scenario {
    fn default() -> Self {
        Scenario {
            gravity_m_s2: STANDARD_GRAVITY_M_S2,
            bar: Bar::PAPER_CAVITY.into(),
            solid_bar: Bar::PAPER_SOLID.into(),
            damper: DamperToml::default(),
            forcing: ForcingToml::default(),
            run: RunToml::default(),
            initial: InitialToml::default(),
            sweep: SweepToml::default(),
        }
    }
}

impl Scenario {
    /// The paper's values.
    pub fn paper() -> Self {
        Self::default()
    }

    /// Parse TOML text.
    pub fn from_toml(text: &str) -> Result<Self> {
        Ok(toml::from_str(text)?)
    }

    /// Read a scenario file.
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read scenario file {}", path.display()))?;
        Self::from_toml(&text).with_context(|| format!("invalid scenario file {}", path.display()))
    }

    /// Preset or file, then the flags on top.
    pub fn from_args(args: &ModelArgs) -> Result<Self> {
        let mut s = match (&args.scenario, args.preset) {
            (Some(p), _) => Self::load(p)?,
            (None, Some(Preset::Paper)) | (None, None) => Self::paper(),
        };
        if let Some(f) = args.friction {
            s.damper.friction = f.into();
        }
        if let Some(f) = args.friction_force_n {
            check_non_negative("--friction-force-n", f, "N")?;
            s.damper.friction_force_n = Some(f);
        }
        if let Some(name) = &args.solver {
            s.run.solver = name.clone();
        }
        if let Some(dt) = args.dt {
            check_positive("--dt", dt, "s")?;
            s.run.dt_s = dt;
        }
        if let Some(d) = args.duration {
            check_positive("--duration", d, "s")?;
            s.run.duration_s = d;
        }
        Ok(s)
    }

    /// Run settings.
    pub fn settings(&self) -> RunSettings {
        RunSettings {
            duration_s: self.run.duration_s,
            dt_s: self.run.dt_s,
            rms_fraction: self.run.rms_fraction,
        }
    }

    /// Bars, ball and forcing of a sweep.
    pub fn base(&self) -> SweepBase {
        let d = &self.damper;
        SweepBase {
            damped_bar: self.bar.into(),
            solid_bar: self.solid_bar.into(),
            ball: Damper {
                ball_mass_kg: d.ball_mass_kg,
                ball_radius_m: d.ball_radius_m,
                restitution: d.restitution,
                gap_m: d.gap_m,
                rolling_friction_m: d.rolling_friction_m,
                friction: d.friction,
                friction_force_n: d.friction_force_n,
            },
            forcing: Forcing {
                amplitude_n: self.forcing.amplitude_n,
                frequency: Frequency::Ratio(self.forcing.frequency_ratio),
                static_force_n: self.forcing.static_force_n,
            },
            gravity_m_s2: self.gravity_m_s2,
            init: self.initial_state(),
        }
    }

    /// The damped system as given (gap, friction, ratio from the scenario).
    pub fn damped_system(&self) -> System {
        let b = self.base();
        System {
            bar: b.damped_bar,
            damper: Some(b.ball),
            forcing: b.forcing,
            gravity_m_s2: self.gravity_m_s2,
        }
    }

    /// Initial state from `[initial]`.
    pub fn initial_state(&self) -> State {
        let i = &self.initial;
        State {
            t_s: 0.0,
            u_m: i.u_m,
            du_m_s: i.du_m_s,
            v_m: i.u_m + i.w_m,
            dv_m_s: i.du_m_s + i.dw_m_s,
        }
    }

    /// Validate everything a run needs; errors name the scenario field and its allowed range.
    pub fn validate(&self) -> Result<()> {
        positive("gravity_m_s2", self.gravity_m_s2)?;
        self.damped_system().validate()?;
        let solid = System {
            bar: self.solid_bar.into(),
            damper: None,
            ..self.damped_system()
        };
        solid.validate().map_err(|e| anyhow::anyhow!("solid_{e}"))?;
        self.settings().validate()?;
        self.initial_state().validate(&self.damped_system())?;
        Ok(())
    }
}

fn positive(field: &str, v: f64) -> Result<()> {
    if !v.is_finite() || v <= 0.0 {
        bail!("{field} = {v} is outside the allowed range (0, ∞)");
    }
    Ok(())
}

/// A flag that must be finite and > 0.
pub fn check_positive(flag: &str, v: f64, unit: &str) -> Result<()> {
    if !v.is_finite() || v <= 0.0 {
        bail!("{flag} = {v} {unit} is outside the allowed range (0, ∞) {unit}");
    }
    Ok(())
}

/// A flag that must be finite and ≥ 0.
pub fn check_non_negative(flag: &str, v: f64, unit: &str) -> Result<()> {
    if !v.is_finite() || v < 0.0 {
        bail!("{flag} = {v} {unit} is outside the allowed range [0, ∞) {unit}");
    }
    Ok(())
}

/// A flag that must be finite.
pub fn check_finite(flag: &str, v: f64) -> Result<()> {
    if !v.is_finite() {
        bail!("{flag} must be a finite number, got {v}");
    }
    Ok(())
}

/// Parse `START:STOP:STEP` (STOP included) into ratios, via core `linspace_inclusive`.
pub fn parse_ratios(spec: &str) -> Result<Vec<f64>> {
    let parts: Vec<&str> = spec.split(':').collect();
    if parts.len() != 3 {
        bail!("--ratios must be START:STOP:STEP (e.g. 0.95:1.05:0.01), got {spec:?}");
    }
    let mut v = [0.0; 3];
    for (i, (p, name)) in parts.iter().zip(["START", "STOP", "STEP"]).enumerate() {
        v[i] = p.trim().parse::<f64>().map_err(|_| {
            anyhow::anyhow!("--ratios {name} must be a number, got {p:?} (in {spec:?})")
        })?;
    }
    ratio_range(v[0], v[1], v[2])
}

/// Check and expand a ratio range.
pub fn ratio_range(start: f64, stop: f64, step: f64) -> Result<Vec<f64>> {
    for (name, x) in [("START", start), ("STOP", stop), ("STEP", step)] {
        if !x.is_finite() {
            bail!("--ratios {name} must be a finite number, got {x}");
        }
    }
    if start <= 0.0 {
        bail!("--ratios START = {start} is outside the allowed range (0, ∞)");
    }
    if step <= 0.0 {
        bail!("--ratios STEP = {step} is outside the allowed range (0, ∞)");
    }
    if stop < start {
        bail!("--ratios range is empty: STOP = {stop} < START = {start} (allowed: STOP ≥ START)");
    }
    let n = (stop - start) / step;
    if n > 100_000.0 {
        bail!("--ratios gives {n:.0} points; the allowed maximum is 100000 (raise STEP)");
    }
    Ok(vibrobar_core::analysis::linspace_inclusive(
        start, stop, step,
    ))
}
