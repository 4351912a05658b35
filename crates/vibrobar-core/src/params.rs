//! Parameters: plain data in SI units. Names carry their units.
//!
//! Everything here is validated by [`System::validate`] before a solver touches it, so solvers may
//! assume finite, physically meaningful numbers.

use crate::error::ParamError;
use crate::limits;
use crate::structure::ModalModel;
use serde::{Deserialize, Serialize};

pub mod two_plane;

/// Largest `|damper.gravity_along_gap_m_s2|` accepted (about 100 g: a tilted or spun bar,
/// far beyond any gravity along a hole).
pub const MAX_GRAVITY_ALONG_GAP_M_S2: f64 = 1000.0;

/// Standard gravity used for the derived rolling-friction force.
pub const STANDARD_GRAVITY_M_S2: f64 = 9.806_65;

/// Lumped SDOF bar: `M ü + C u̇ + K u = F(t) − F_rf`, with `C = 2ζ√(KM)`.
///
/// Deserialised (scenario files, metadata) with every missing field taken from [`Bar::default`],
/// the paper's bar with the cavity; unknown fields are errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Bar {
    /// Lumped modal mass `M`.
    pub mass_kg: f64,
    /// Lumped stiffness `K`.
    pub stiffness_n_per_m: f64,
    /// Damping ratio `ζ`, so that `C = 2ζ√(KM)`.
    pub damping_ratio: f64,
}

impl Bar {
    /// The paper's bar with the cavity that houses the ball (M = 0.644 kg, K = 9.22 MN/m).
    pub const PAPER_CAVITY: Bar = Bar {
        mass_kg: 0.644,
        stiffness_n_per_m: 9.22e6,
        damping_ratio: 0.01,
    };
    /// The paper's solid (undamped reference) bar (M = 0.668 kg, K = 9.26 MN/m).
    pub const PAPER_SOLID: Bar = Bar {
        mass_kg: 0.668,
        stiffness_n_per_m: 9.26e6,
        damping_ratio: 0.01,
    };

    /// Viscous coefficient `C = 2ζ√(KM)`.
    pub fn damping_n_s_per_m(&self) -> f64 {
        2.0 * self.damping_ratio * (self.stiffness_n_per_m * self.mass_kg).sqrt()
    }

    /// Undamped natural frequency `√(K/M)`.
    pub fn natural_freq_rad_s(&self) -> f64 {
        (self.stiffness_n_per_m / self.mass_kg).sqrt()
    }
}

impl Default for Bar {
    /// The paper's bar with the cavity, [`Bar::PAPER_CAVITY`].
    fn default() -> Self {
        Bar::PAPER_CAVITY
    }
}

/// How the ball–bar friction acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FrictionModel {
    /// Frictionless: the ball flies freely between impacts.
    None,
    /// Exactly the paper's Eqs. 1–3: the ball gets `+F_rf sgn(ẇ)`, the bar `−F_rf sgn(ẇ)`,
    /// `sgn(0) = 0`. This sign puts energy *into* the system (`F_rf·ẇ ≥ 0`).
    AsPublished,
    /// Dissipative dry friction: the force on the ball opposes relative sliding, with sticking
    /// while the needed force stays within the limit.
    Coulomb,
}

impl FrictionModel {
    /// All models, in a stable order.
    pub const ALL: [FrictionModel; 3] = [
        FrictionModel::None,
        FrictionModel::AsPublished,
        FrictionModel::Coulomb,
    ];

    /// The name used in the CLI and in output files.
    pub fn as_str(&self) -> &'static str {
        match self {
            FrictionModel::None => "none",
            FrictionModel::AsPublished => "as-published",
            FrictionModel::Coulomb => "coulomb",
        }
    }

    /// Parse the CLI / file name.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.as_str() == s)
    }
}

impl std::fmt::Display for FrictionModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The free ball in its cavity.
///
/// Deserialised with every missing field taken from [`Damper::default`]; unknown fields are errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Damper {
    /// Ball mass `m_d`.
    pub ball_mass_kg: f64,
    /// Ball radius `r` (enters the rolling-friction force only).
    pub ball_radius_m: f64,
    /// Coefficient of restitution `e`, in [0, 1].
    pub restitution: f64,
    /// Total clearance; the ball can move `±gap/2` (= `±l_g`) about the cavity centre.
    pub gap_m: f64,
    /// Coefficient of rolling friction `η` (a length).
    pub rolling_friction_m: f64,
    /// Friction law.
    pub friction: FrictionModel,
    /// Override of the friction force level; `None` derives `η/r · m_d · g`.
    pub friction_force_n: Option<f64>,
    /// Ball–wall contact law (`[contact]`): instantaneous restitution (the paper's, default) or
    /// compliant Hertz contact. Left out of serialised output while it is the default, so every
    /// existing file stays byte-identical.
    #[serde(skip_serializing_if = "Contact::is_restitution")]
    pub contact: Contact,
    /// The ball's acceleration from gravity along the gap (m/s²), towards the `+` wall when
    /// positive: a constant body force `m_d·g_s` on the ball alone (the bar's own weight is in
    /// its static equilibrium). 0 means gravity acts across the hole, as in the paper. Left out
    /// of serialised output while it is 0, so every existing file stays byte-identical.
    #[serde(skip_serializing_if = "is_zero_f64")]
    pub gravity_along_gap_m_s2: f64,
}

fn is_zero_f64(x: &f64) -> bool {
    *x == 0.0
}

impl Damper {
    /// Carbide density used to turn a diameter into a mass when only the diameter is known.
    pub const CARBIDE_DENSITY_KG_M3: f64 = 14_700.0;

    /// The paper's ball: 26 g carbide, 15 mm diameter, `e = 0.5`, `η = 0.6 mm`.
    pub fn paper(gap_m: f64, friction: FrictionModel) -> Damper {
        Damper {
            ball_mass_kg: 0.026,
            ball_radius_m: 0.0075,
            restitution: 0.5,
            gap_m,
            rolling_friction_m: 0.6e-3,
            friction,
            friction_force_n: None,
            contact: Contact::default(),
            gravity_along_gap_m_s2: 0.0,
        }
    }

    /// Mass of a solid sphere from its diameter and density.
    pub fn sphere_mass_kg(diameter_m: f64, density_kg_m3: f64) -> f64 {
        density_kg_m3 * std::f64::consts::PI * diameter_m.powi(3) / 6.0
    }

    /// Half the total clearance, `l_g`.
    pub fn half_gap_m(&self) -> f64 {
        0.5 * self.gap_m
    }

    /// Friction force level `|F_rf|`: the override, else `η/r · m_d · g`. Zero for `FrictionModel::None`.
    pub fn friction_level_n(&self, gravity_m_s2: f64) -> f64 {
        match self.friction {
            FrictionModel::None => 0.0,
            _ => self.friction_force_n.unwrap_or(
                self.rolling_friction_m / self.ball_radius_m * self.ball_mass_kg * gravity_m_s2,
            ),
        }
    }
}

impl Default for Damper {
    /// The paper's ball at its smaller gap (0.1 mm), frictionless.
    fn default() -> Self {
        Damper::paper(0.1e-3, FrictionModel::None)
    }
}

/// Which ball–wall contact law acts at `w = ±l_g`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum ContactLaw {
    /// Instantaneous impact with restitution `e` (the paper's Eqs. 4–5).
    #[default]
    Restitution,
    /// Compliant Hertz contact with hysteretic (Hunt–Crossley) damping calibrated to `e`
    /// ([`crate::damper::contact`]).
    Hertz,
}

impl ContactLaw {
    /// All laws, in a stable order.
    pub const ALL: [ContactLaw; 2] = [ContactLaw::Restitution, ContactLaw::Hertz];
    /// The name used in the CLI and in files.
    pub fn as_str(&self) -> &'static str {
        match self {
            ContactLaw::Restitution => "restitution",
            ContactLaw::Hertz => "hertz",
        }
    }
    /// Parse the CLI / file name.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.as_str() == s)
    }
}

impl std::fmt::Display for ContactLaw {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Elastic constants of one body in contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Young's modulus.
    pub modulus_pa: f64,
    /// Poisson's ratio.
    pub poisson: f64,
}

impl Material {
    /// Cemented tungsten carbide (WC–6 % Co, the usual ball grade): `E = 630 GPa`, `ν = 0.22`
    /// (handbook range 600–650 GPa, 0.21–0.24: ASM Handbook Vol. 2, "Cemented carbides"; the
    /// crate's density 14 700 kg/m³ is the same grade).
    pub const TUNGSTEN_CARBIDE: Material = Material {
        modulus_pa: 630e9,
        poisson: 0.22,
    };
    /// Alloy steel of a boring bar (AISI 4340 class): `E = 205 GPa`, `ν = 0.29` (ASM Handbook
    /// Vol. 1).
    pub const STEEL: Material = Material {
        modulus_pa: 205e9,
        poisson: 0.29,
    };
}

/// The `[contact]` section: the law and, for `hertz`, the elastic constants of ball and wall.
/// The ball's radius is [`Damper::ball_radius_m`] (the paper's 15 mm ball: its 26 g is a
/// carbide sphere of that size); the target restitution is [`Damper::restitution`].
/// Defaults: restitution law, carbide ball on a flat steel wall.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Contact {
    /// Contact law.
    pub law: ContactLaw,
    /// Ball's Young's modulus.
    pub ball_modulus_pa: f64,
    /// Ball's Poisson ratio, in (−1, 0.5).
    pub ball_poisson: f64,
    /// Wall's Young's modulus.
    pub wall_modulus_pa: f64,
    /// Wall's Poisson ratio, in (−1, 0.5).
    pub wall_poisson: f64,
    /// Radius of a concave (bore) wall, larger than the ball's; `None` is a flat wall.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wall_radius_m: Option<f64>,
}

impl Default for Contact {
    fn default() -> Self {
        Contact {
            law: ContactLaw::Restitution,
            ball_modulus_pa: Material::TUNGSTEN_CARBIDE.modulus_pa,
            ball_poisson: Material::TUNGSTEN_CARBIDE.poisson,
            wall_modulus_pa: Material::STEEL.modulus_pa,
            wall_poisson: Material::STEEL.poisson,
            wall_radius_m: None,
        }
    }
}

impl Contact {
    /// The default contact with the `hertz` law.
    pub fn hertz() -> Contact {
        Contact {
            law: ContactLaw::Hertz,
            ..Contact::default()
        }
    }

    /// Serde helper: the default section is left out of serialised output.
    pub fn is_restitution(&self) -> bool {
        *self == Contact::default()
    }

    /// Check the fields (for `hertz`; the restitution law does not use them) against the ball of
    /// radius `ball_radius_m` and restitution `e`; the error names the field.
    pub fn validate(&self, ball_radius_m: f64, restitution: f64) -> Result<(), ParamError> {
        if self.law == ContactLaw::Restitution {
            return Ok(());
        }
        positive("contact.ball_modulus_pa", self.ball_modulus_pa)?;
        positive("contact.wall_modulus_pa", self.wall_modulus_pa)?;
        open_range(
            "contact.ball_poisson",
            self.ball_poisson,
            -1.0,
            0.5,
            "(−1, 0.5)",
        )?;
        open_range(
            "contact.wall_poisson",
            self.wall_poisson,
            -1.0,
            0.5,
            "(−1, 0.5)",
        )?;
        if let Some(r) = self.wall_radius_m {
            positive("contact.wall_radius_m", r)?;
            if r <= ball_radius_m {
                return Err(ParamError::OutOfRange {
                    field: "contact.wall_radius_m",
                    value: r,
                    allowed: "(damper.ball_radius_m, ∞): a concave wall wider than the ball",
                });
            }
        }
        // Hunt–Crossley damping represents 0 < e ≤ 1 only: e = 0 needs infinite damping.
        if !(restitution > 0.0 && restitution <= 1.0) {
            return Err(ParamError::OutOfRange {
                field: "damper.restitution",
                value: restitution,
                allowed: "(0, 1] with contact.law = hertz",
            });
        }
        Ok(())
    }
}

fn open_range(
    field: &'static str,
    value: f64,
    lo: f64,
    hi: f64,
    allowed: &'static str,
) -> Result<(), ParamError> {
    finite(field, value)?;
    if value > lo && value < hi {
        Ok(())
    } else {
        Err(ParamError::OutOfRange {
            field,
            value,
            allowed,
        })
    }
}

/// How the forcing frequency is given.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Frequency {
    /// `Ω / ω₁` of the bar being simulated ([`System::omega1_rad_s`]: `√(K/M)` for the lumped
    /// bar, the first mode's frequency for a modal one).
    Ratio(f64),
    /// `Ω` directly.
    RadPerS(f64),
}

/// Cutting force `F(t) = F_s + F0 sin(Ωt)`.
///
/// Deserialised with every missing field taken from [`Forcing::default`]; unknown fields are errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Forcing {
    /// Amplitude `F0` of the oscillatory part.
    pub amplitude_n: f64,
    /// Frequency of the oscillatory part.
    pub frequency: Frequency,
    /// Steady (DC) part `F_s`; the paper leaves it out (0).
    pub static_force_n: f64,
}

impl Forcing {
    /// The paper's forcing: 15 N at the given frequency ratio, no DC part.
    pub fn paper(ratio: f64) -> Forcing {
        Forcing {
            amplitude_n: 15.0,
            frequency: Frequency::Ratio(ratio),
            static_force_n: 0.0,
        }
    }
}

impl Default for Forcing {
    /// The paper's forcing at resonance, `Forcing::paper(1.0)`.
    fn default() -> Self {
        Forcing::paper(1.0)
    }
}

/// What the bar is to a solver: the paper's lumped bar, or a modal model (a beam's modes).
///
/// The lumped [`Bar`] is kept as given (not as its one-mode model): the paper's goldens are
/// pinned on `K` and `C = 2ζ√(KM)`, and `M(√(K/M))² ≠ K` by an ulp for the paper's solid bar, so
/// the lumped solvers read `M`, `K`, `C` from the `Bar` itself.
///
/// Serialised untagged: a lumped bar is written as the [`Bar`] it is (so the metadata of every
/// lumped run is unchanged), a modal one as its modes.
// Not boxed: a `System` stays `Copy` plain data (no allocation per run); the modal variant's
// 1.5 kB are copied once per run, not per step.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum BarModel {
    /// The paper's lumped SDOF bar.
    Lumped(Bar),
    /// A bar reduced to its modes (tip-normalised; see [`crate::structure`]).
    Modal(ModalModel),
}

impl From<Bar> for BarModel {
    fn from(b: Bar) -> Self {
        BarModel::Lumped(b)
    }
}

impl From<ModalModel> for BarModel {
    fn from(m: ModalModel) -> Self {
        BarModel::Modal(m)
    }
}

impl BarModel {
    /// The lumped bar, if this is one.
    pub fn as_lumped(&self) -> Option<&Bar> {
        match self {
            BarModel::Lumped(b) => Some(b),
            BarModel::Modal(_) => None,
        }
    }

    /// The lumped bar, mutable, if this is one.
    pub fn as_lumped_mut(&mut self) -> Option<&mut Bar> {
        match self {
            BarModel::Lumped(b) => Some(b),
            BarModel::Modal(_) => None,
        }
    }

    /// First natural frequency `ω₁`: `√(K/M)` of a lumped bar, the first mode's of a modal one.
    pub fn omega1_rad_s(&self) -> f64 {
        match self {
            BarModel::Lumped(b) => b.natural_freq_rad_s(),
            BarModel::Modal(m) => m.modes().first().map_or(f64::NAN, |m| m.omega_rad_s),
        }
    }

    /// Highest natural frequency kept (what RK4's stability and the phase limit see): `ω₁` of
    /// a lumped bar, `ω_N` of a modal one.
    pub fn omega_max_rad_s(&self) -> f64 {
        match self {
            BarModel::Lumped(b) => b.natural_freq_rad_s(),
            BarModel::Modal(m) => m.modes().iter().map(|m| m.omega_rad_s).fold(0.0, f64::max),
        }
    }

    /// The modal model, if this is one (a lumped bar's one-mode model is
    /// [`System::modal_model`]).
    pub fn as_modal(&self) -> Option<&ModalModel> {
        match self {
            BarModel::Lumped(_) => None,
            BarModel::Modal(m) => Some(m),
        }
    }
}

/// A complete model: bar, optional ball, forcing.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct System {
    /// The bar: lumped or modal.
    pub bar: BarModel,
    /// The ball; `None` is a bar without damper (the solid reference bar).
    pub damper: Option<Damper>,
    /// External force on the bar (at the force point of a modal bar).
    pub forcing: Forcing,
    /// Gravity for the derived friction force.
    pub gravity_m_s2: f64,
}

impl System {
    /// Paper's impact-damped bar at a gap, friction model and frequency ratio.
    pub fn paper_damped(gap_m: f64, friction: FrictionModel, ratio: f64) -> System {
        System {
            bar: BarModel::Lumped(Bar::PAPER_CAVITY),
            damper: Some(Damper::paper(gap_m, friction)),
            forcing: Forcing::paper(ratio),
            gravity_m_s2: STANDARD_GRAVITY_M_S2,
        }
    }

    /// Paper's solid bar (no ball) at a frequency ratio of its own natural frequency.
    pub fn paper_solid(ratio: f64) -> System {
        System {
            bar: BarModel::Lumped(Bar::PAPER_SOLID),
            damper: None,
            forcing: Forcing::paper(ratio),
            gravity_m_s2: STANDARD_GRAVITY_M_S2,
        }
    }

    /// The lumped bar, if the bar is one (shorthand of [`BarModel::as_lumped`]).
    pub fn lumped_bar(&self) -> Option<&Bar> {
        self.bar.as_lumped()
    }

    /// First natural frequency `ω₁` of the bar simulated ([`BarModel::omega1_rad_s`]).
    /// [`Frequency::Ratio`] is `Ω/ω₁` of this.
    pub fn omega1_rad_s(&self) -> f64 {
        self.bar.omega1_rad_s()
    }

    /// Highest natural frequency kept ([`BarModel::omega_max_rad_s`]).
    pub fn omega_max_rad_s(&self) -> f64 {
        self.bar.omega_max_rad_s()
    }

    /// The bar's modal model: a modal bar's own, or the lumped bar's one unit mode
    /// (`ω = √(K/M)`, `m = M`, `ζ`, every shape 1; see [`BarModel`] for why the lumped solvers
    /// do not run on it).
    pub fn modal_model(&self) -> ModalModel {
        match &self.bar {
            BarModel::Lumped(b) => ModalModel::lumped(b),
            BarModel::Modal(m) => *m,
        }
    }

    /// Forcing frequency `Ω` in rad/s.
    pub fn omega_rad_s(&self) -> f64 {
        match self.forcing.frequency {
            Frequency::Ratio(r) => r * self.omega1_rad_s(),
            Frequency::RadPerS(w) => w,
        }
    }

    /// Forcing period `2π/Ω` (infinite for a static load).
    pub fn forcing_period_s(&self) -> f64 {
        2.0 * std::f64::consts::PI / self.omega_rad_s()
    }

    /// External force at time `t`.
    pub fn force_n(&self, t_s: f64) -> f64 {
        self.forcing.static_force_n + self.forcing.amplitude_n * (self.omega_rad_s() * t_s).sin()
    }

    /// Friction force level (0 without a ball or without friction).
    pub fn friction_level_n(&self) -> f64 {
        self.damper
            .map(|d| d.friction_level_n(self.gravity_m_s2))
            .unwrap_or(0.0)
    }

    /// Check every field; the error names the field and the allowed range.
    pub fn validate(&self) -> Result<(), ParamError> {
        let ratio_meaning = match &self.bar {
            BarModel::Lumped(bar) => {
                positive("bar.mass_kg", bar.mass_kg)?;
                positive("bar.stiffness_n_per_m", bar.stiffness_n_per_m)?;
                in_range("bar.damping_ratio", bar.damping_ratio, 0.0, 1.0, "[0, 1)")?;
                if bar.damping_ratio >= 1.0 {
                    return Err(ParamError::OutOfRange {
                        field: "bar.damping_ratio",
                        value: bar.damping_ratio,
                        allowed: "[0, 1)",
                    });
                }
                "Ω/√(K/M) of a one-mode bar"
            }
            BarModel::Modal(model) => {
                limits::check_count(
                    "modes (number of modes of the modal system)",
                    model.len(),
                    1,
                    limits::MAX_BEAM_MODES,
                    "",
                )?;
                for m in model.modes() {
                    m.validate()?;
                    in_range("modes.damping_ratio", m.damping_ratio, 0.0, 1.0, "[0, 1)")?;
                    if m.damping_ratio >= 1.0 {
                        return Err(ParamError::OutOfRange {
                            field: "modes.damping_ratio",
                            value: m.damping_ratio,
                            allowed: "[0, 1)",
                        });
                    }
                }
                "Ω/ω₁ of the modal bar"
            }
        };
        finite("forcing.amplitude_n", self.forcing.amplitude_n)?;
        finite("forcing.static_force_n", self.forcing.static_force_n)?;
        match self.forcing.frequency {
            Frequency::Ratio(r) => {
                positive("forcing.frequency_ratio", r)?;
                limits::check(
                    "forcing.frequency_ratio",
                    r,
                    limits::FREQ_RATIO_MIN,
                    limits::FREQ_RATIO_MAX,
                    ratio_meaning,
                )?;
            }
            Frequency::RadPerS(w) => positive("forcing.omega_rad_s", w)?,
        }
        positive("gravity_m_s2", self.gravity_m_s2)?;
        if let Some(d) = &self.damper {
            positive("damper.ball_mass_kg", d.ball_mass_kg)?;
            positive("damper.ball_radius_m", d.ball_radius_m)?;
            positive("damper.gap_m", d.gap_m)?;
            in_range("damper.restitution", d.restitution, 0.0, 1.0, "[0, 1]")?;
            non_negative("damper.rolling_friction_m", d.rolling_friction_m)?;
            if let Some(f) = d.friction_force_n {
                non_negative("damper.friction_force_n", f)?;
            }
            d.contact.validate(d.ball_radius_m, d.restitution)?;
            in_range(
                "damper.gravity_along_gap_m_s2",
                d.gravity_along_gap_m_s2,
                -MAX_GRAVITY_ALONG_GAP_M_S2,
                MAX_GRAVITY_ALONG_GAP_M_S2,
                "[-1000, 1000] m/s²",
            )?;
        }
        Ok(())
    }

    /// Check that a run to `t_end_s` keeps the phase of `sin(Ωt)` and of the bar's own
    /// oscillation accurate: `max(Ω, ω_max)·max(|t0|, |t_end|) ≤` [`limits::MAX_PHASE_RAD`]
    /// (`ω_max` the highest mode kept, [`System::omega_max_rad_s`]).
    pub fn validate_horizon(&self, t0_s: f64, t_end_s: f64) -> Result<(), ParamError> {
        let rate = self.omega_rad_s().max(self.omega_max_rad_s());
        limits::check_phase(rate, t0_s.abs().max(t_end_s.abs()))?;
        Ok(())
    }

    /// Check a fixed step `dt_s` for a run over `span_s`: positive, at most
    /// [`limits::MAX_STEPS`] steps, and `ω_max·dt` of the highest mode kept within RK4's
    /// stability limit [`limits::RK4_MAX_OMEGA_DT`] (a larger step diverges).
    pub fn validate_fixed_step(&self, dt_s: f64, span_s: f64) -> Result<(), ParamError> {
        positive("dt_s", dt_s)?;
        let wn = self.omega_max_rad_s();
        limits::check(
            "dt_s (--dt)",
            dt_s,
            0.0,
            limits::RK4_MAX_OMEGA_DT / wn,
            match self.bar {
                BarModel::Lumped(_) => {
                    "rk4's stability limit ω_n·dt ≤ 2.5 for this bar; a larger step diverges"
                }
                BarModel::Modal(_) => {
                    "rk4's stability limit ω_N·dt ≤ 2.5 for the highest mode kept; a larger step diverges (or keep fewer modes, --beam-modes)"
                }
            },
        )?;
        limits::check(
            "steps duration/dt (--duration, --dt)",
            (span_s / dt_s).ceil(),
            0.0,
            limits::MAX_STEPS,
            "bounded work: raise --dt or shorten the run",
        )?;
        Ok(())
    }
}

/// Full state of bar and ball. Without a damper the ball fields are ignored.
///
/// `u`, `u̇` are the bar's motion at the response point (where RMS and histories look); the
/// ball's relative motion is taken at the cavity, whose motion is [`State::cavity`]: `None` when
/// the cavity is where `u` is measured (the lumped bar, and every state built from
/// [`State::REST`]), so a lumped state reads exactly as before.
///
/// The default is [`State::REST`]; missing fields deserialise to it, unknown fields are errors.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct State {
    /// Time.
    pub t_s: f64,
    /// Bar displacement `u` (at the response point).
    pub u_m: f64,
    /// Bar velocity `u̇` (at the response point).
    pub du_m_s: f64,
    /// Ball displacement `v` (absolute; the cavity centre is at [`State::u_cavity_m`]).
    pub v_m: f64,
    /// Ball velocity `v̇`.
    pub dv_m_s: f64,
    /// The cavity's motion when it differs from the response point's (a modal bar);
    /// `None`: the cavity moves with `u`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cavity: Option<CavityMotion>,
}

/// The bar's motion at the cavity (the ball's reference), when it is not the response point's.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CavityMotion {
    /// Bar displacement at the cavity, `u(x_d)`.
    pub u_cavity_m: f64,
    /// Bar velocity at the cavity, `u̇(x_d)`.
    pub du_cavity_m_s: f64,
}

impl State {
    /// At rest at `t = 0` with the ball centred: the paper's initial condition.
    pub const REST: State = State {
        t_s: 0.0,
        u_m: 0.0,
        du_m_s: 0.0,
        v_m: 0.0,
        dv_m_s: 0.0,
        cavity: None,
    };

    /// Bar displacement at the cavity, `u(x_d)` (`u` when [`State::cavity`] is `None`).
    pub fn u_cavity_m(&self) -> f64 {
        self.cavity.map_or(self.u_m, |c| c.u_cavity_m)
    }

    /// Bar velocity at the cavity, `u̇(x_d)` (`u̇` when [`State::cavity`] is `None`).
    pub fn du_cavity_m_s(&self) -> f64 {
        self.cavity.map_or(self.du_m_s, |c| c.du_cavity_m_s)
    }

    /// Relative displacement `w = v − u(x_d)`.
    pub fn w_m(&self) -> f64 {
        self.v_m - self.u_cavity_m()
    }

    /// Relative velocity `ẇ = v̇ − u̇(x_d)`.
    pub fn dw_m_s(&self) -> f64 {
        self.dv_m_s - self.du_cavity_m_s()
    }

    /// Check the initial condition against the system.
    ///
    /// On a modal bar the state must map onto the modes
    /// ([`crate::structure::ModalState::from_public`]: `u`, `u̇` into mode 1).
    pub fn validate(&self, sys: &System) -> Result<(), ParamError> {
        finite("initial.t_s", self.t_s)?;
        finite("initial.u_m", self.u_m)?;
        finite("initial.du_m_s", self.du_m_s)?;
        finite("initial.v_m", self.v_m)?;
        finite("initial.dv_m_s", self.dv_m_s)?;
        if let Some(c) = &self.cavity {
            finite("initial.u_cavity_m", c.u_cavity_m)?;
            finite("initial.du_cavity_m_s", c.du_cavity_m_s)?;
        }
        if let BarModel::Modal(model) = &sys.bar {
            crate::structure::ModalState::from_public(model, self)?;
        }
        if let Some(d) = &sys.damper {
            let lg = d.half_gap_m();
            if self.w_m().abs() > lg {
                return Err(ParamError::OutOfRange {
                    field: "initial.w_m (v − u)",
                    value: self.w_m(),
                    allowed: "[−gap/2, +gap/2]",
                });
            }
        }
        Ok(())
    }
}

/// Settings shared by every run: duration, step, RMS window.
///
/// Missing fields deserialise to [`RunSettings::default`] (the paper's); unknown fields are errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RunSettings {
    /// Simulated time.
    pub duration_s: f64,
    /// Fixed step for `rk4` (also the output-grid unit for `exact`).
    pub dt_s: f64,
    /// Fraction of the run, counted from the end, over which RMS and impact rates are taken.
    pub rms_fraction: f64,
}

impl Default for RunSettings {
    /// The paper: 2 s, dt = 1 µs, RMS over the last 80 %.
    fn default() -> Self {
        RunSettings {
            duration_s: 2.0,
            dt_s: 1e-6,
            rms_fraction: 0.8,
        }
    }
}

impl RunSettings {
    /// Check every field.
    pub fn validate(&self) -> Result<(), ParamError> {
        positive("duration_s", self.duration_s)?;
        positive("dt_s", self.dt_s)?;
        if self.dt_s > self.duration_s {
            return Err(ParamError::OutOfRange {
                field: "dt_s",
                value: self.dt_s,
                allowed: "(0, duration_s]",
            });
        }
        if !(self.rms_fraction > 0.0 && self.rms_fraction <= 1.0) {
            return Err(ParamError::OutOfRange {
                field: "rms_fraction",
                value: self.rms_fraction,
                allowed: "(0, 1]",
            });
        }
        // An RMS window shorter than one step holds no sample of the motion: its RMS is 0/0.
        limits::check(
            "rms_fraction (--rms-fraction)",
            self.rms_fraction,
            self.dt_s / self.duration_s,
            1.0,
            "the RMS window rms_fraction·duration_s must cover at least one step dt_s",
        )?;
        Ok(())
    }

    /// Start of the RMS window.
    pub fn window_start_s(&self) -> f64 {
        self.duration_s * (1.0 - self.rms_fraction)
    }
}

pub(crate) fn finite(field: &'static str, value: f64) -> Result<(), ParamError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(ParamError::NotFinite { field, value })
    }
}

pub(crate) fn positive(field: &'static str, value: f64) -> Result<(), ParamError> {
    finite(field, value)?;
    if value > 0.0 {
        Ok(())
    } else {
        Err(ParamError::OutOfRange {
            field,
            value,
            allowed: "(0, ∞)",
        })
    }
}

pub(crate) fn non_negative(field: &'static str, value: f64) -> Result<(), ParamError> {
    finite(field, value)?;
    if value >= 0.0 {
        Ok(())
    } else {
        Err(ParamError::OutOfRange {
            field,
            value,
            allowed: "[0, ∞)",
        })
    }
}

pub(crate) fn in_range(
    field: &'static str,
    value: f64,
    lo: f64,
    hi: f64,
    allowed: &'static str,
) -> Result<(), ParamError> {
    finite(field, value)?;
    if value >= lo && value <= hi {
        Ok(())
    } else {
        Err(ParamError::OutOfRange {
            field,
            value,
            allowed,
        })
    }
}
