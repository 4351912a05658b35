//! The clamped–free Euler–Bernoulli bar ([`Beam`]): parameters, validation, and its modes.
//!
//! * Uniform bar without tip mass: closed-form modes ([`super::analytic`]).
//! * With a [`CavitySection`] or a [`TipMass`]: Hermite cubic finite elements ([`super::fe`]).
//!
//! **Mesh rule** (overridable by `fe_elements`): elements no longer than `L/n`, with
//! `n = max(FE_MIN_ELEMENTS, ⌈βₙL / (1440·FE_FREQ_TOLERANCE)^{1/4}⌉)` for the highest mode kept
//! (`βₙL` of the uniform bar), so that the first `N` frequencies are within
//! [`FE_FREQ_TOLERANCE`] of the converged ones (the `h⁴` error constant `1/1440` is measured in the
//! tests); [`FE_CAVITY_ELEMENTS`] or more elements across the cavity hole; nodes at the cavity ends
//! and at the cavity, force and response points (points closer than `h/50` to a node use the
//! node's neighbourhood and are interpolated), so the shapes there are nodal values.
//!
//! **Cavity section** (the transverse hole of [`crate::euler_bernoulli`]): a hole of diameter
//! `d_h` drilled through the bar's axis in the direction of vibration, closed by plugs that leave
//! a cavity of length `ℓ` along the hole, centred on the axis, its centre at `cavity_position_m`.
//! At axial offset `s` from the centre the section loses the rectangle `|y| ≤ ℓ/2`,
//! `|z| ≤ c(s) = √(d_h²/4 − s²)`: area `2ℓc(s)`, second moment `4/3·c(s)·(ℓ/2)³`. An element
//! inside the hole integrates the varying `EI(s)` and `ρA(s)` exactly into its Hermite matrices
//! ([`super::fe::HoleLoss`]). (A section constant per element converged only as `h²`: 32
//! elements across the hole still left 2e-6 on mode 8, while such small elements cost `ω₁` its
//! digits.)
//!
//! **Default number of modes:** the smallest `N ≥ MIN_DEFAULT_MODES` whose modal sum captures
//! [`DEFAULT_CAPTURED_STATIC_FRACTION`] of the static tip compliance (uniform bar: 97.07, 99.54,
//! 99.86 % for N = 1, 2, 3, so N = 3).

use super::analytic::{beta_l, UniformMode};
use super::fe::{HoleLoss, Mesh};
use super::{check_cavity_in_section, CavityFields, ModalModel, Mode};
use crate::error::ParamError;
use crate::limits;
use crate::params::{non_negative, positive};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Fraction of the static tip compliance the default number of modes captures.
pub const DEFAULT_CAPTURED_STATIC_FRACTION: f64 = 0.995;
/// Fewest modes the default rule gives.
pub const MIN_DEFAULT_MODES: usize = 3;
/// Relative frequency tolerance the mesh rule aims at for every retained mode.
pub const FE_FREQ_TOLERANCE: f64 = 1e-6;
/// Fewest elements over the whole bar.
pub const FE_MIN_ELEMENTS: usize = 24;
/// Fewest elements across the whole cavity hole (its varying section is integrated exactly in
/// each element, so few suffice: at 16 the paper's hole is within 4e-7 of the converged
/// frequencies; smaller elements only add rounding, `~ε·(L/h)⁴`).
pub const FE_CAVITY_ELEMENTS: usize = 16;
/// Modes the default rule looks at first (more only if these do not reach the fraction).
const DEFAULT_RULE_PROBE_MODES: usize = 12;

/// Modal damping ratio: one value for every mode, or one per mode (`[ζ₁, ζ₂, …]`; modes beyond
/// the list take its last value).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum DampingRatio {
    /// The same `ζ` for every mode.
    All(f64),
    /// `ζₙ` of mode `n = 1, 2, …`.
    PerMode(Vec<f64>),
}

impl DampingRatio {
    /// `ζ` of mode `n ≥ 1`.
    pub fn of_mode(&self, n: usize) -> f64 {
        match self {
            DampingRatio::All(z) => *z,
            DampingRatio::PerMode(v) => v[(n - 1).min(v.len() - 1)],
        }
    }

    fn validate(&self) -> Result<(), ParamError> {
        let field = "beam.damping_ratio";
        let check = |z: f64| {
            crate::params::in_range(field, z, 0.0, 1.0, "[0, 1)")?;
            if z >= 1.0 {
                return Err(ParamError::OutOfRange {
                    field,
                    value: z,
                    allowed: "[0, 1)",
                });
            }
            Ok(())
        };
        match self {
            DampingRatio::All(z) => check(*z),
            DampingRatio::PerMode(v) => {
                limits::check_count(
                    "beam.damping_ratio (list length)",
                    v.len(),
                    1,
                    limits::MAX_BEAM_MODES,
                    "one value per mode",
                )?;
                v.iter().try_for_each(|z| check(*z))
            }
        }
    }
}

/// A rigid body at the free end (insert holder): point mass and rotary inertia.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TipMass {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Rotary inertia about the bending axis through the tip, kg·m².
    #[serde(default)]
    pub rotary_inertia_kg_m2: f64,
}

/// The cavity's local loss of section (see the module docs), centred at `cavity_position_m`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CavitySection {
    /// Diameter `d_h` of the transverse hole: the cavity's extent along the bar.
    pub hole_diameter_m: f64,
    /// Length `ℓ` of the cavity along the hole (across the bar, in the vibration direction).
    pub length_m: f64,
}

/// A round clamped–free Euler–Bernoulli bar. Positions are measured from the clamp (`x = 0`);
/// the tip is `x = L`. Deserialised with every missing field from [`Beam::default`] (the paper's
/// bar, cavity 38 mm from the free end); unknown fields are errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Beam {
    /// Overhang `L`, clamp to free end.
    pub length_m: f64,
    /// Outer diameter `D`.
    pub diameter_m: f64,
    /// Young's modulus `E`.
    pub youngs_modulus_pa: f64,
    /// Density `ρ`.
    pub density_kg_m3: f64,
    /// Modal damping ratio(s) (default 0.01 for every mode).
    pub damping_ratio: DampingRatio,
    /// Number of modes `N`; `None`: the default rule (module docs).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub modes: Option<usize>,
    /// Cavity centre (the ball), from the clamp.
    pub cavity_position_m: f64,
    /// Force point from the clamp; `None`: the tip.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub force_position_m: Option<f64>,
    /// Response point from the clamp; `None`: the tip.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub response_position_m: Option<f64>,
    /// Optional rigid body at the tip.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tip_mass: Option<TipMass>,
    /// Optional local loss of section at the cavity.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cavity_section: Option<CavitySection>,
    /// Number of finite elements of the base spacing `L/n`, overriding the mesh rule (FE models
    /// only); the splits at the cavity ends and the points add a few.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fe_elements: Option<usize>,
}

impl Default for Beam {
    /// The paper's bar (L = 175 mm, D = 25 mm, steel), ζ = 0.01, cavity 38 mm from the free end,
    /// force and response at the tip, no section loss, no tip mass.
    fn default() -> Self {
        Beam {
            length_m: 0.175,
            diameter_m: 0.025,
            youngs_modulus_pa: 200e9,
            density_kg_m3: 7850.0,
            damping_ratio: DampingRatio::All(0.01),
            modes: None,
            cavity_position_m: 0.175 - 0.038,
            force_position_m: None,
            response_position_m: None,
            tip_mass: None,
            cavity_section: None,
            fe_elements: None,
        }
    }
}

impl Beam {
    /// The solid reference of this bar with a cavity: the same bar without the cavity's
    /// section loss (the ball is absent from every solid run), with `modes` modes (as many as
    /// the bar with the cavity, so both are compared on the same basis). The one rule for every
    /// command (scenarios, placement).
    pub fn solid_reference(&self, modes: usize) -> Beam {
        Beam {
            cavity_section: None,
            modes: Some(modes),
            ..self.clone()
        }
    }

    /// Cross-section area `πD²/4`.
    pub fn area_m2(&self) -> f64 {
        PI * self.diameter_m.powi(2) / 4.0
    }

    /// Second moment of area `πD⁴/64`.
    pub fn second_moment_m4(&self) -> f64 {
        PI * self.diameter_m.powi(4) / 64.0
    }

    /// The bar's own mass `ρAL` (without cavity or tip mass).
    pub fn mass_kg(&self) -> f64 {
        self.density_kg_m3 * self.area_m2() * self.length_m
    }

    /// Force point (default: the tip).
    pub fn force_x_m(&self) -> f64 {
        self.force_position_m.unwrap_or(self.length_m)
    }

    /// Response point (default: the tip).
    pub fn response_x_m(&self) -> f64 {
        self.response_position_m.unwrap_or(self.length_m)
    }

    /// True when the closed-form modes apply (no section loss, no tip mass).
    pub fn is_uniform(&self) -> bool {
        self.cavity_section.is_none() && self.tip_mass.is_none()
    }

    /// Check every field; the error names the field and its allowed range.
    pub fn validate(&self) -> Result<(), ParamError> {
        for (field, v, (lo, hi)) in [
            ("beam.length_m", self.length_m, limits::BEAM_LENGTH_M),
            ("beam.diameter_m", self.diameter_m, limits::BEAM_DIAMETER_M),
            (
                "beam.youngs_modulus_pa",
                self.youngs_modulus_pa,
                limits::BEAM_YOUNGS_MODULUS_PA,
            ),
            (
                "beam.density_kg_m3",
                self.density_kg_m3,
                limits::BEAM_DENSITY_KG_M3,
            ),
        ] {
            positive(field, v)?;
            limits::check(field, v, lo, hi, "in SI units: m, Pa, kg/m³")?;
        }
        self.damping_ratio.validate()?;
        if let Some(n) = self.modes {
            limits::check_count(
                "beam.modes (--beam-modes)",
                n,
                1,
                limits::MAX_BEAM_MODES,
                "modes of the beam",
            )?;
        }
        if let Some(n) = self.fe_elements {
            limits::check_count(
                "beam.fe_elements",
                n,
                FE_MIN_ELEMENTS,
                limits::MAX_FE_ELEMENTS,
                "finite elements over the bar",
            )?;
        }
        let l = self.length_m;
        let from_clamp = "measured from the clamp: 0 is the clamp, beam.length_m the tip";
        for (field, x) in [
            (
                "beam.cavity_position_m (--cavity-position-mm)",
                Some(self.cavity_position_m),
            ),
            ("beam.force_position_m", self.force_position_m),
            ("beam.response_position_m", self.response_position_m),
        ] {
            if let Some(x) = x {
                limits::check(field, x, 0.0, l, from_clamp)?;
            }
        }
        if let Some(t) = self.tip_mass {
            let m = self.mass_kg();
            non_negative("beam.tip_mass.mass_kg", t.mass_kg)?;
            limits::check(
                "beam.tip_mass.mass_kg",
                t.mass_kg,
                0.0,
                limits::MAX_TIP_MASS_RATIO * m,
                "up to MAX_TIP_MASS_RATIO times the bar's mass ρAL",
            )?;
            non_negative("beam.tip_mass.rotary_inertia_kg_m2", t.rotary_inertia_kg_m2)?;
            limits::check(
                "beam.tip_mass.rotary_inertia_kg_m2",
                t.rotary_inertia_kg_m2,
                0.0,
                limits::MAX_TIP_MASS_RATIO * m * l * l,
                "up to MAX_TIP_MASS_RATIO times ρAL·L²",
            )?;
        }
        if let Some(c) = self.cavity_section {
            positive("beam.cavity_section.hole_diameter_m", c.hole_diameter_m)?;
            positive("beam.cavity_section.length_m", c.length_m)?;
            let rh = 0.5 * c.hole_diameter_m;
            limits::check(
                "beam.cavity_section.hole_diameter_m",
                c.hole_diameter_m,
                0.0,
                self.diameter_m.min(l),
                "smaller than the bar's diameter_m and its length_m",
            )?;
            check_cavity_in_section(
                self.diameter_m,
                c.hole_diameter_m,
                c.length_m,
                &CavityFields {
                    hole: "beam.cavity_section.hole_diameter_m",
                    hole_allowed: "(0, diameter_m) (a hole smaller than the bar's section)",
                    length: "beam.cavity_section.length_m",
                    length_allowed: "(0, √(D² − d_h²)) (cavity inside the bar's section)",
                },
            )?;
            limits::check(
                "beam.cavity_position_m (--cavity-position-mm)",
                self.cavity_position_m,
                rh,
                l - rh,
                "with a cavity_section, the hole [x − d_h/2, x + d_h/2] must lie inside the bar",
            )?;
        }
        Ok(())
    }

    /// The modal model: validated, `N` modes (given or by the default rule), tip-normalised.
    pub fn modal_model(&self) -> Result<ModalModel, ParamError> {
        self.validate()?;
        let model = match self.modes {
            Some(n) => self.compute(n)?,
            None => {
                let mut m = self.compute(DEFAULT_RULE_PROBE_MODES)?;
                if default_mode_count(&m).is_none() {
                    m = self.compute(limits::MAX_BEAM_MODES)?;
                }
                let n = default_mode_count(&m).unwrap_or(m.len());
                m.truncate(n);
                m
            }
        };
        for m in model.modes() {
            for v in [
                m.omega_rad_s,
                m.modal_mass_kg,
                m.shape_cavity,
                m.shape_force,
                m.shape_response,
            ] {
                limits::finite_result(
                    "beam mode",
                    v,
                    "beam dimensions or material outside the range of real bars",
                )?;
            }
        }
        limits::finite_result(
            "static tip compliance",
            model.static_tip_compliance_m_per_n,
            "beam dimensions or material outside the range of real bars",
        )?;
        Ok(model)
    }

    /// The first `n` modes, closed form or FE.
    fn compute(&self, n: usize) -> Result<ModalModel, ParamError> {
        if self.is_uniform() {
            self.analytic(n)
        } else {
            self.finite_elements(n)
        }
    }

    /// Closed-form modes of the uniform bar.
    fn analytic(&self, n: usize) -> Result<ModalModel, ParamError> {
        let (l, ei, ra) = (
            self.length_m,
            self.youngs_modulus_pa * self.second_moment_m4(),
            self.density_kg_m3 * self.area_m2(),
        );
        let modes = (1..=n)
            .map(|k| {
                let m = UniformMode::new(k);
                let b = m.beta_l / l;
                Mode {
                    omega_rad_s: b * b * (ei / ra).sqrt(),
                    damping_ratio: self.damping_ratio.of_mode(k),
                    modal_mass_kg: 0.25 * ra * l,
                    shape_cavity: m.shape(self.cavity_position_m / l),
                    shape_force: m.shape(self.force_x_m() / l),
                    shape_response: m.shape(self.response_x_m() / l),
                }
            })
            .collect::<Vec<_>>();
        ModalModel::new(&modes, l.powi(3) / (3.0 * ei))
    }

    /// Elements of the mesh rule for `n` modes (module docs), or the override.
    pub fn fe_element_target(&self, n: usize) -> usize {
        self.fe_elements.unwrap_or_else(|| {
            let bh = (1440.0 * FE_FREQ_TOLERANCE).powf(0.25);
            ((beta_l(n) / bh).ceil() as usize).max(FE_MIN_ELEMENTS)
        })
    }

    /// The finite-element mesh for `n` modes (module docs).
    pub fn mesh(&self, n: usize) -> Result<Mesh, ParamError> {
        self.mesh_with(self.fe_element_target(n), FE_CAVITY_ELEMENTS)
    }

    /// A mesh of base spacing `L/base_elements` with at least `hole_elements` elements across
    /// the cavity hole (convergence studies; [`Beam::mesh`] applies the rule).
    pub fn mesh_with(
        &self,
        base_elements: usize,
        hole_elements: usize,
    ) -> Result<Mesh, ParamError> {
        let l = self.length_m;
        let h_max = l / base_elements.max(1) as f64;
        let (e, i0, a0, rho) = (
            self.youngs_modulus_pa,
            self.second_moment_m4(),
            self.area_m2(),
            self.density_kg_m3,
        );
        // Fixed breakpoints: ends, cavity ends. Points: snapped if within h/50 of a breakpoint.
        let mut breaks = vec![0.0, l];
        let hole = self.cavity_section.map(|c| {
            let rh = 0.5 * c.hole_diameter_m;
            (self.cavity_position_m - rh, self.cavity_position_m + rh, c)
        });
        if let Some((a, b, _)) = hole {
            breaks.extend([a, b]);
        }
        let snap = h_max / 50.0;
        for x in [
            self.cavity_position_m,
            self.force_x_m(),
            self.response_x_m(),
        ] {
            if breaks.iter().all(|&p| (p - x).abs() > snap) {
                breaks.push(x);
            }
        }
        breaks.sort_by(f64::total_cmp);
        breaks.dedup_by(|a, b| (*a - *b).abs() <= snap * 1e-6);
        let mut nodes = vec![0.0];
        for w in breaks.windows(2) {
            let (a, b) = (w[0], w[1]);
            // Inside the hole: its share of `hole_elements` at least (points split the hole).
            let min = match hole {
                Some((ha, hb, c)) if a >= ha - snap && b <= hb + snap => {
                    ((hole_elements as f64 * (b - a) / c.hole_diameter_m).ceil() as usize).max(1)
                }
                _ => 1,
            };
            let k = (((b - a) / h_max).ceil() as usize).max(min);
            nodes.extend((1..=k).map(|j| a + (b - a) * j as f64 / k as f64));
        }
        *nodes.last_mut().expect("nodes") = l;
        // The spacing L/n gives n elements; the (at most 6) segments between breakpoints add at
        // most one each by rounding up, and the (at most 4) segments inside the hole at most
        // FE_CAVITY_ELEMENTS each: the size is bounded by the validated n.
        limits::check_count(
            "finite elements of the mesh (beam.fe_elements or the mesh rule, plus the splits at the cavity and the points)",
            nodes.len() - 1,
            1,
            limits::MAX_FE_ELEMENTS + 6 + hole_elements + 4,
            "fewer modes or a coarser fe_elements",
        )?;
        let ne = nodes.len() - 1;
        let tip = self.tip_mass.unwrap_or(TipMass {
            mass_kg: 0.0,
            rotary_inertia_kg_m2: 0.0,
        });
        Ok(Mesh {
            nodes_m: nodes,
            ei_n_m2: vec![e * i0; ne],
            rho_a_kg_m: vec![rho * a0; ne],
            tip_mass_kg: tip.mass_kg,
            tip_inertia_kg_m2: tip.rotary_inertia_kg_m2,
            hole: hole.map(|(_, _, c)| HoleLoss {
                centre_m: self.cavity_position_m,
                radius_m: 0.5 * c.hole_diameter_m,
                ei_per_c: e * 4.0 / 3.0 * (0.5 * c.length_m).powi(3),
                rho_a_per_c: rho * 2.0 * c.length_m,
            }),
        })
    }

    /// Finite-element modes.
    fn finite_elements(&self, n: usize) -> Result<ModalModel, ParamError> {
        let mesh = self.mesh(n)?;
        let fe = mesh.modes(n)?;
        let at = |k: usize, x: f64| mesh.interpolate(&fe.deflection[k], &fe.slope[k], x);
        let modes = (0..fe.omega_rad_s.len())
            .map(|k| Mode {
                omega_rad_s: fe.omega_rad_s[k],
                damping_ratio: self.damping_ratio.of_mode(k + 1),
                modal_mass_kg: fe.modal_mass_kg[k],
                shape_cavity: at(k, self.cavity_position_m),
                shape_force: at(k, self.force_x_m()),
                shape_response: at(k, self.response_x_m()),
            })
            .collect::<Vec<_>>();
        ModalModel::new(&modes, fe.static_tip_compliance_m_per_n)
    }
}

/// The smallest `N ≥ MIN_DEFAULT_MODES` of `m` capturing the default fraction, if any.
pub fn default_mode_count(m: &ModalModel) -> Option<usize> {
    (MIN_DEFAULT_MODES.min(m.len())..=m.len()).find(|&n| {
        n >= MIN_DEFAULT_MODES
            && m.tip_compliance_of_first(n)
                >= DEFAULT_CAPTURED_STATIC_FRACTION * m.static_tip_compliance_m_per_n
    })
}

impl Beam {
    /// This beam with `N` modes.
    pub fn with_modes(self, n: usize) -> Beam {
        Beam {
            modes: Some(n),
            ..self
        }
    }
}
