//! The structure: what the bar is, reduced once per run to the modes a solver needs.
//!
//! A [`Structure`] is the paper's lumped bar ([`Structure::Lumped`], one mode with `φ = 1`), a
//! clamped–free Euler–Bernoulli [`Beam`] (closed-form modes when uniform, finite elements with a
//! cavity section or a tip mass), or modes given directly ([`Structure::Measured`]). Each gives a
//! [`ModalModel`] through [`Structure::modal_model`], so nothing downstream asks which one it has.
//!
//! **Normalisation (one, everywhere):** every mode shape is 1 at the tip (`x = L`, the free
//! end), and `modal_mass_kg` is `∫ρA φ² dx` (plus the tip mass terms) in that normalisation: a
//! uniform bar has `ρAL/4` in every mode. A physical displacement is `u(x, t) = Σ φₙ(x) qₙ(t)`
//! with `mₙ(q̈ₙ + 2ζₙωₙ q̇ₙ + ωₙ² qₙ) = Σ_points φₙ(x_p) F_p(t)`.

pub mod analytic;
pub mod beam;
pub mod fe;
pub mod fit;
pub mod frf_data;
pub mod nodes;
pub mod system;

pub use beam::{Beam, CavitySection, DampingRatio, TipMass};
pub use frf_data::{FrfDataError, FrfKind, MeasuredFrf};
pub use system::{ModalState, ModalSystem};

use crate::error::ParamError;
use crate::limits::MAX_BEAM_MODES;
use crate::params::{finite, positive, Bar};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// The field names and allowed ranges a caller's errors give for [`check_cavity_in_section`].
pub(crate) struct CavityFields {
    pub hole: &'static str,
    pub hole_allowed: &'static str,
    pub length: &'static str,
    pub length_allowed: &'static str,
}

/// The geometric rule for a transverse cavity (hole diameter `d_h`, length `ℓ` along the hole,
/// centred on the axis) in a round bar of diameter `D`: the hole is smaller than the section, and
/// the cavity's corners (z = d_h/2, y = ℓ/2) lie inside the round bar. One rule for the lumped
/// estimator ([`crate::euler_bernoulli`]) and the [`Beam`]; each names its own fields.
pub(crate) fn check_cavity_in_section(
    bar_diameter_m: f64,
    hole_diameter_m: f64,
    length_m: f64,
    fields: &CavityFields,
) -> Result<(), ParamError> {
    let (r_out, rh) = (0.5 * bar_diameter_m, 0.5 * hole_diameter_m);
    if rh >= r_out {
        return Err(ParamError::OutOfRange {
            field: fields.hole,
            value: hole_diameter_m,
            allowed: fields.hole_allowed,
        });
    }
    if rh * rh + (0.5 * length_m).powi(2) >= r_out * r_out {
        return Err(ParamError::OutOfRange {
            field: fields.length,
            value: length_m,
            allowed: fields.length_allowed,
        });
    }
    Ok(())
}

/// One mode at the points that matter, in the tip normalisation (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mode {
    /// Undamped natural frequency `ωₙ`.
    pub omega_rad_s: f64,
    /// Modal damping ratio `ζₙ`.
    pub damping_ratio: f64,
    /// Modal mass `mₙ` (shapes 1 at the tip).
    pub modal_mass_kg: f64,
    /// `φₙ(x_cavity)`: where the ball acts.
    pub shape_cavity: f64,
    /// `φₙ(x_force)`: where the cutting force acts.
    pub shape_force: f64,
    /// `φₙ(x_response)`: where the response is measured.
    pub shape_response: f64,
}

impl Mode {
    /// The filler of a [`ModalModel`]'s unused entries (all zero; never read as a mode).
    pub const UNUSED: Mode = Mode {
        omega_rad_s: 0.0,
        damping_ratio: 0.0,
        modal_mass_kg: 0.0,
        shape_cavity: 0.0,
        shape_force: 0.0,
        shape_response: 0.0,
    };

    /// Modal stiffness `mₙωₙ²`.
    pub fn modal_stiffness_n_per_m(&self) -> f64 {
        self.modal_mass_kg * self.omega_rad_s * self.omega_rad_s
    }

    /// The shape at a point.
    pub fn shape(&self, p: Point) -> f64 {
        match p {
            Point::Cavity => self.shape_cavity,
            Point::Force => self.shape_force,
            Point::Response => self.shape_response,
        }
    }

    pub(crate) fn validate(&self) -> Result<(), ParamError> {
        positive("modes.omega_rad_s", self.omega_rad_s)?;
        crate::params::non_negative("modes.damping_ratio", self.damping_ratio)?;
        positive("modes.modal_mass_kg", self.modal_mass_kg)?;
        finite("modes.shape_cavity", self.shape_cavity)?;
        finite("modes.shape_force", self.shape_force)?;
        finite("modes.shape_response", self.shape_response)
    }
}

/// One mode as a tap test gives it (a scenario's `[[modes]]` entry), in the tip normalisation
/// (module docs): the force acts and the response is read at the tool tip, where every shape is
/// 1, so only the cavity's shape is given. Field names are the columns of `vibrobar modes`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasuredMode {
    /// Undamped natural frequency, Hz.
    pub frequency_hz: f64,
    /// Modal damping ratio `ζ`.
    pub damping_ratio: f64,
    /// Modal mass with the shape 1 at the tip.
    pub modal_mass_kg: f64,
    /// The shape at the cavity centre (the ball).
    pub shape_cavity: f64,
    /// The direction the mode bends in, in the bar's cross-section from the radial direction
    /// (a `[two_plane]` scenario: two perpendicular families, as a clamping that splits the
    /// pair gives them); left out, the bar is round and every mode bends in both planes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub direction_deg: Option<f64>,
}

impl MeasuredMode {
    /// Check every field; the error names the field (a caller prefixes which entry) and its
    /// range: frequency and mass in (0, ∞), damping in [0, 1), the shape finite.
    pub fn validate(&self) -> Result<(), ParamError> {
        positive("frequency_hz", self.frequency_hz)?;
        positive("modal_mass_kg", self.modal_mass_kg)?;
        finite("damping_ratio", self.damping_ratio)?;
        if !(self.damping_ratio >= 0.0 && self.damping_ratio < 1.0) {
            return Err(ParamError::OutOfRange {
                field: "damping_ratio",
                value: self.damping_ratio,
                allowed: "[0, 1)",
            });
        }
        finite("shape_cavity", self.shape_cavity)?;
        match self.direction_deg {
            Some(d) => finite("direction_deg", d),
            None => Ok(()),
        }
    }

    /// The mode: `ω = 2πf`, shapes 1 at the force and response points (the tip).
    pub fn mode(&self) -> Mode {
        Mode {
            omega_rad_s: 2.0 * std::f64::consts::PI * self.frequency_hz,
            damping_ratio: self.damping_ratio,
            modal_mass_kg: self.modal_mass_kg,
            shape_cavity: self.shape_cavity,
            shape_force: 1.0,
            shape_response: 1.0,
        }
    }
}

/// A point of the bar that a solver or an analysis looks at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Point {
    /// The cavity centre (the ball).
    Cavity,
    /// The force point.
    Force,
    /// The response point.
    Response,
}

/// The structure reduced to its modes, computed once per run.
///
/// Fixed capacity ([`MAX_BEAM_MODES`] modes, `len` used; the unused entries are
/// [`Mode::UNUSED`]), so that it is `Copy` and a [`crate::params::System`] holding it stays plain
/// data. Read the modes through [`ModalModel::modes`]; build one with [`ModalModel::new`], which
/// checks the count.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ModalModelRepr", into = "ModalModelRepr")]
pub struct ModalModel {
    /// Modes by increasing frequency in `[..len]`, [`Mode::UNUSED`] beyond.
    modes: [Mode; MAX_BEAM_MODES],
    /// Number of modes used.
    len: usize,
    /// The exact static tip compliance (all modes: closed form or the full FE model), m/N;
    /// the reference of [`ModalModel::captured_static_fraction`].
    pub static_tip_compliance_m_per_n: f64,
}

/// How a [`ModalModel`] is written (metadata): the used modes only.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModalModelRepr {
    modes: Vec<Mode>,
    static_tip_compliance_m_per_n: f64,
}

impl TryFrom<ModalModelRepr> for ModalModel {
    type Error = ParamError;
    fn try_from(r: ModalModelRepr) -> Result<Self, ParamError> {
        ModalModel::new(&r.modes, r.static_tip_compliance_m_per_n)
    }
}

impl From<ModalModel> for ModalModelRepr {
    fn from(m: ModalModel) -> Self {
        ModalModelRepr {
            modes: m.modes().to_vec(),
            static_tip_compliance_m_per_n: m.static_tip_compliance_m_per_n,
        }
    }
}

impl ModalModel {
    /// A model of the given modes (in the order given), `1 ≤ len ≤` [`MAX_BEAM_MODES`]; the
    /// error names the count and its range. The modes themselves are checked by the users'
    /// `validate` (e.g. [`ModalSystem::validate`]).
    pub fn new(modes: &[Mode], static_tip_compliance_m_per_n: f64) -> Result<Self, ParamError> {
        crate::limits::check_count(
            "modes (number of modes of a modal model)",
            modes.len(),
            1,
            MAX_BEAM_MODES,
            "",
        )?;
        let mut m = ModalModel {
            modes: [Mode::UNUSED; MAX_BEAM_MODES],
            len: modes.len(),
            static_tip_compliance_m_per_n,
        };
        m.modes[..modes.len()].copy_from_slice(modes);
        Ok(m)
    }

    /// The one-mode model of the paper's lumped bar: `ω = √(K/M)`, `m = M`, `ζ`, every shape 1,
    /// static compliance `1/K` (not validated: [`Structure::modal_model`] and
    /// `System::validate` check the bar).
    pub fn lumped(bar: &Bar) -> ModalModel {
        let mut m = ModalModel {
            modes: [Mode::UNUSED; MAX_BEAM_MODES],
            len: 1,
            static_tip_compliance_m_per_n: 1.0 / bar.stiffness_n_per_m,
        };
        m.modes[0] = Mode {
            omega_rad_s: bar.natural_freq_rad_s(),
            damping_ratio: bar.damping_ratio,
            modal_mass_kg: bar.mass_kg,
            shape_cavity: 1.0,
            shape_force: 1.0,
            shape_response: 1.0,
        };
        m
    }

    /// The modes, by increasing frequency.
    pub fn modes(&self) -> &[Mode] {
        &self.modes[..self.len]
    }

    /// The modes, mutable (to change a damping ratio or a shape in a study; the count is fixed).
    pub fn modes_mut(&mut self) -> &mut [Mode] {
        &mut self.modes[..self.len]
    }

    /// Number of modes.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True without modes (never for a model from [`ModalModel::new`]).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Receptance `G(iω) = Σ φₙ(to) φₙ(from) / (mₙ(ωₙ² − ω² + 2iζₙωₙω))`: the displacement at
    /// `to` per unit harmonic force at `from`, m/N.
    pub fn receptance(&self, from: Point, to: Point, omega_rad_s: f64) -> Complex64 {
        self.modes()
            .iter()
            .map(|m| {
                let wn = m.omega_rad_s;
                let den = Complex64::new(
                    wn * wn - omega_rad_s * omega_rad_s,
                    2.0 * m.damping_ratio * wn * omega_rad_s,
                ) * m.modal_mass_kg;
                m.shape(from) * m.shape(to) / den
            })
            .sum()
    }

    /// Static compliance of the retained modes between two points, `Σ φₙ(from)φₙ(to)/(mₙωₙ²)`.
    pub fn static_compliance_m_per_n(&self, from: Point, to: Point) -> f64 {
        self.modes()
            .iter()
            .map(|m| m.shape(from) * m.shape(to) / m.modal_stiffness_n_per_m())
            .sum()
    }

    /// Static tip compliance of the first `n` modes, `Σ 1/(mₖωₖ²)` (tip shapes are 1).
    pub fn tip_compliance_of_first(&self, n: usize) -> f64 {
        self.modes()
            .iter()
            .take(n)
            .map(|m| 1.0 / m.modal_stiffness_n_per_m())
            .sum()
    }

    /// Fraction of the exact static tip compliance the retained modes capture.
    pub fn captured_static_fraction(&self) -> f64 {
        self.tip_compliance_of_first(self.len()) / self.static_tip_compliance_m_per_n
    }

    /// Keep the first `n` modes.
    pub fn truncate(&mut self, n: usize) {
        if n < self.len {
            self.modes[n..self.len].fill(Mode::UNUSED);
            self.len = n;
        }
    }
}

/// What the bar is (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub enum Structure {
    /// The paper's lumped bar: one mode, `ω = √(K/M)`, `m = M`, every shape 1.
    Lumped(Bar),
    /// A clamped–free Euler–Bernoulli bar.
    Beam(Beam),
    /// Modes given directly (e.g. measured by a tap test), in the tip normalisation; the static
    /// tip compliance is that of the modes given.
    Measured(Vec<Mode>),
}

impl Structure {
    /// The modal model of this structure, validated; errors name the field and its range.
    pub fn modal_model(&self) -> Result<ModalModel, ParamError> {
        match self {
            Structure::Lumped(bar) => {
                positive("bar.mass_kg", bar.mass_kg)?;
                positive("bar.stiffness_n_per_m", bar.stiffness_n_per_m)?;
                crate::params::non_negative("bar.damping_ratio", bar.damping_ratio)?;
                Ok(ModalModel::lumped(bar))
            }
            Structure::Beam(b) => b.modal_model(),
            Structure::Measured(modes) => {
                crate::limits::check_count(
                    "modes (number of [[modes]])",
                    modes.len(),
                    1,
                    crate::limits::MAX_BEAM_MODES,
                    "",
                )?;
                for m in modes {
                    m.validate()?;
                }
                let mut modes = modes.clone();
                modes.sort_by(|a, b| a.omega_rad_s.total_cmp(&b.omega_rad_s));
                let c = modes
                    .iter()
                    .map(|m| 1.0 / m.modal_stiffness_n_per_m())
                    .sum();
                crate::limits::finite_result(
                    "static tip compliance of the modes",
                    c,
                    "modal masses or frequencies outside floating-point range",
                )?;
                ModalModel::new(&modes, c)
            }
        }
    }
}
