//! The bar that bends in two planes, with the ball in a cylindrical hole across it: plain data in
//! SI units, and its validation.
//!
//! # Frame and angles
//! Everything lives in the bar's cross-section plane at the cavity. `x` is the **radial**
//! direction (along the radial cutting force on the tool), `y` the **tangential** one (along the
//! tangential cutting force). Every angle (the hole's, the force's, gravity's, the principal
//! axis') is measured from `x` towards `y`, in degrees.
//!
//! - A force with tangential/radial ratio `F_t/F_r` points at `atan(F_t/F_r)`: 63.4° for 2,
//!   71.6° for 3 ([`PlanarForcing::angle_from_ratio_deg`]).
//! - The hole is drilled along its angle: along it the ball has the axial clearance `±l_g` (the
//!   end plugs), across it, in this plane, the radial clearance `±c_r = ±(d_h − d_b)/2` (the
//!   hole's wall). The ball's motion along the bar's axis is not modelled.
//! - Gravity defaults to 90°, along the tangential force: down on a horizontal lathe with the
//!   insert at centre height.
//!
//! The feed force (it acts only through its moment arm) and torsion (its first mode lies far
//! above the band) are neglected.
//!
//! # The bar
//! [`TwoPlaneBar`]: either
//! - a lumped bar with one mass `M` in both planes, whose stiffness and damping ratio may differ
//!   along two principal axes at [`PlanarBar::principal_axis_deg`] (a flat, an oval section, a
//!   clamping that splits the pair); by default both are the same (a round bar). A frequency
//!   ratio `r` refers to the lower principal frequency, `√(min K / M)`;
//! - or a round bar reduced to its modes ([`ModalModel`], e.g. the Euler–Bernoulli beam's): the
//!   same N modes in each plane, the force at the force point, the ball at the cavity, the
//!   response at the response point. A frequency ratio refers to the first mode;
//! - or measured modes in two perpendicular bending directions ([`ModalPair`]): each family
//!   bends only in its direction, as a clamping that splits the pair makes it. A frequency
//!   ratio refers to the lower first mode.

use super::{finite, in_range, non_negative, positive, Bar, Frequency};
use crate::error::ParamError;
use crate::structure::ModalModel;
use serde::{Deserialize, Serialize};

/// A lumped bar in the cross-section plane: one mass, stiffness and damping per principal axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanarBar {
    /// Mass `M` (the same in both planes).
    pub mass_kg: f64,
    /// Stiffness along the first and the second principal axis.
    pub stiffness_n_per_m: [f64; 2],
    /// Damping ratio along each principal axis (`C_i = 2ζ_i√(K_i M)`).
    pub damping_ratio: [f64; 2],
    /// Angle of the first principal axis from the radial direction.
    pub principal_axis_deg: f64,
}

impl PlanarBar {
    /// A round bar: the one-plane bar in both planes.
    pub fn isotropic(bar: &Bar) -> PlanarBar {
        PlanarBar {
            mass_kg: bar.mass_kg,
            stiffness_n_per_m: [bar.stiffness_n_per_m; 2],
            damping_ratio: [bar.damping_ratio; 2],
            principal_axis_deg: 0.0,
        }
    }

    /// The lower principal frequency `√(min K / M)`, which a frequency ratio refers to.
    pub fn omega1_rad_s(&self) -> f64 {
        (self.stiffness_n_per_m[0].min(self.stiffness_n_per_m[1]) / self.mass_kg).sqrt()
    }

    /// The stiffness and damping matrices in the `x, y` frame, row-major `[[xx, xy], [yx, yy]]`.
    pub fn matrices(&self) -> ([[f64; 2]; 2], [[f64; 2]; 2]) {
        let (s, c) = self.principal_axis_deg.to_radians().sin_cos();
        let rot = |d: [f64; 2]| {
            [
                [c * c * d[0] + s * s * d[1], c * s * (d[0] - d[1])],
                [c * s * (d[0] - d[1]), s * s * d[0] + c * c * d[1]],
            ]
        };
        let k = self.stiffness_n_per_m;
        let damping = [
            2.0 * self.damping_ratio[0] * (k[0] * self.mass_kg).sqrt(),
            2.0 * self.damping_ratio[1] * (k[1] * self.mass_kg).sqrt(),
        ];
        (rot(k), rot(damping))
    }

    fn validate(&self) -> Result<(), ParamError> {
        positive("bar.mass_kg", self.mass_kg)?;
        positive("bar.stiffness_n_per_m[0]", self.stiffness_n_per_m[0])?;
        positive("bar.stiffness_n_per_m[1]", self.stiffness_n_per_m[1])?;
        below_one("bar.damping_ratio[0]", self.damping_ratio[0])?;
        below_one("bar.damping_ratio[1]", self.damping_ratio[1])?;
        finite("bar.principal_axis_deg", self.principal_axis_deg)
    }
}

/// A bar of measured modes that bend in two perpendicular directions (its principal axes):
/// the modes of a tap test in each direction, as a clamping that splits the pair gives them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModalPair {
    /// The modes bending along `axis_deg`, then those bending along `axis_deg + 90°`.
    pub modes: [ModalModel; 2],
    /// The direction the first family bends in, from the radial direction.
    pub axis_deg: f64,
}

/// The bar of a two-plane system.
// Not boxed: a `TwoPlaneSystem` stays `Copy` plain data, as a `System` does.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TwoPlaneBar {
    /// A lumped bar, possibly with two principal stiffnesses.
    Lumped(PlanarBar),
    /// A round bar of these modes in each plane (tip-normalised, [`crate::structure`]).
    Round(ModalModel),
    /// Measured modes, each family bending in its own direction.
    Measured(ModalPair),
}

impl From<PlanarBar> for TwoPlaneBar {
    fn from(b: PlanarBar) -> Self {
        TwoPlaneBar::Lumped(b)
    }
}

impl TwoPlaneBar {
    /// The lumped bar, if it is one.
    pub fn lumped(&self) -> Option<&PlanarBar> {
        match self {
            TwoPlaneBar::Lumped(b) => Some(b),
            TwoPlaneBar::Round(_) | TwoPlaneBar::Measured(_) => None,
        }
    }

    /// The lumped bar, if it is one, to change.
    pub fn lumped_mut(&mut self) -> Option<&mut PlanarBar> {
        match self {
            TwoPlaneBar::Lumped(b) => Some(b),
            TwoPlaneBar::Round(_) | TwoPlaneBar::Measured(_) => None,
        }
    }

    /// The frequency a ratio refers to: the lumped bar's lower principal frequency, the round
    /// bar's first mode, the lower of the measured families' first modes.
    pub fn omega1_rad_s(&self) -> f64 {
        match self {
            TwoPlaneBar::Lumped(b) => b.omega1_rad_s(),
            TwoPlaneBar::Round(m) => m.modes()[0].omega_rad_s,
            TwoPlaneBar::Measured(p) => p.modes[0].modes()[0]
                .omega_rad_s
                .min(p.modes[1].modes()[0].omega_rad_s),
        }
    }

    /// The highest natural frequency.
    pub fn highest_omega_rad_s(&self) -> f64 {
        match self {
            TwoPlaneBar::Lumped(b) => {
                (b.stiffness_n_per_m[0].max(b.stiffness_n_per_m[1]) / b.mass_kg).sqrt()
            }
            TwoPlaneBar::Round(m) => m.modes().iter().map(|m| m.omega_rad_s).fold(0.0, f64::max),
            TwoPlaneBar::Measured(p) => p
                .modes
                .iter()
                .flat_map(|m| m.modes().iter().map(|m| m.omega_rad_s))
                .fold(0.0, f64::max),
        }
    }

    fn validate(&self) -> Result<(), ParamError> {
        match self {
            TwoPlaneBar::Lumped(b) => b.validate(),
            TwoPlaneBar::Round(m) => validate_modes(m),
            TwoPlaneBar::Measured(p) => {
                validate_modes(&p.modes[0])?;
                validate_modes(&p.modes[1])?;
                finite("bar.axis_deg", p.axis_deg)
            }
        }
    }
}

fn validate_modes(m: &ModalModel) -> Result<(), ParamError> {
    for mode in m.modes() {
        positive("bar.modes.omega_rad_s", mode.omega_rad_s)?;
        positive("bar.modes.modal_mass_kg", mode.modal_mass_kg)?;
        below_one("bar.modes.damping_ratio", mode.damping_ratio)?;
        finite("bar.modes.shape_cavity", mode.shape_cavity)?;
        finite("bar.modes.shape_force", mode.shape_force)?;
        finite("bar.modes.shape_response", mode.shape_response)?;
    }
    Ok(())
}

/// The ball, with the friction of its contact with the hole's walls.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanarBall {
    /// Mass `m_d`.
    pub mass_kg: f64,
    /// Radius `r` (the moment of inertia is `2/5·m_d·r²`).
    pub radius_m: f64,
    /// Coefficient of restitution `e` on every wall, in [0, 1].
    pub restitution: f64,
    /// Static friction coefficient `μ_s` of ball on wall, in [0, 1).
    pub friction_static: f64,
    /// Kinetic friction coefficient `μ_k`, in [0, μ_s].
    pub friction_kinetic: f64,
    /// Coefficient of rolling resistance `η` (a length): a torque up to `η·N` against rolling.
    pub rolling_friction_m: f64,
}

impl PlanarBall {
    /// The paper's ball (26 g, 15 mm, `e = 0.5`) on frictionless walls.
    pub fn paper_frictionless() -> PlanarBall {
        PlanarBall {
            mass_kg: 0.026,
            radius_m: 0.0075,
            restitution: 0.5,
            friction_static: 0.0,
            friction_kinetic: 0.0,
            rolling_friction_m: 0.0,
        }
    }

    /// Moment of inertia about a diameter, `2/5·m_d·r²`.
    pub fn inertia_kg_m2(&self) -> f64 {
        0.4 * self.mass_kg * self.radius_m * self.radius_m
    }

    /// No friction of any kind on the walls.
    pub fn frictionless(&self) -> bool {
        self.friction_static == 0.0
            && self.friction_kinetic == 0.0
            && self.rolling_friction_m == 0.0
    }

    fn validate(&self) -> Result<(), ParamError> {
        positive("ball.mass_kg", self.mass_kg)?;
        positive("ball.radius_m", self.radius_m)?;
        in_range("ball.restitution", self.restitution, 0.0, 1.0, "[0, 1]")?;
        below_one("ball.friction_static", self.friction_static)?;
        in_range(
            "ball.friction_kinetic",
            self.friction_kinetic,
            0.0,
            self.friction_static,
            "[0, ball.friction_static]",
        )?;
        non_negative("ball.rolling_friction_m", self.rolling_friction_m)
    }
}

/// The cylindrical hole across the bar that holds the ball.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Hole {
    /// Direction the hole is drilled in, from the radial direction.
    pub angle_deg: f64,
    /// Total axial clearance along the hole (between the end plugs and the ball): the ball moves
    /// `±l_g = ±gap/2` about the centre.
    pub axial_gap_m: f64,
    /// The hole's diameter `d_h`; across the hole the ball moves `±c_r = ±(d_h − 2r)/2`.
    pub diameter_m: f64,
}

impl Hole {
    /// `l_g`.
    pub fn half_axial_gap_m(&self) -> f64 {
        0.5 * self.axial_gap_m
    }

    /// `c_r = (d_h − d_b)/2` for a ball of radius `ball_radius_m`.
    pub fn radial_clearance_m(&self, ball_radius_m: f64) -> f64 {
        0.5 * self.diameter_m - ball_radius_m
    }

    /// The hole that leaves radial clearance `c_r_m` around a ball of radius `ball_radius_m`.
    pub fn diameter_for_clearance_m(ball_radius_m: f64, c_r_m: f64) -> f64 {
        2.0 * (ball_radius_m + c_r_m)
    }
}

/// The harmonic force `F0 sin(Ωt)` on the bar, along a direction of the cross-section plane.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanarForcing {
    /// `F0`.
    pub amplitude_n: f64,
    /// `Ω`, or its ratio to the bar's lower principal frequency.
    pub frequency: Frequency,
    /// Direction of the force, from the radial direction.
    pub angle_deg: f64,
}

impl PlanarForcing {
    /// The direction of a force with tangential/radial ratio `F_t/F_r`: `atan(F_t/F_r)`.
    pub fn angle_from_ratio_deg(tangential_over_radial: f64) -> f64 {
        tangential_over_radial.atan().to_degrees()
    }
}

/// Gravity on the ball, in the cross-section plane.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Gravity {
    /// Magnitude (0 allowed: no gravity).
    pub m_s2: f64,
    /// Direction, from the radial direction (90°: along the tangential force).
    pub angle_deg: f64,
}

impl Default for Gravity {
    fn default() -> Self {
        Gravity {
            m_s2: super::STANDARD_GRAVITY_M_S2,
            angle_deg: 90.0,
        }
    }
}

/// A complete two-plane model: the bar, the ball in its hole, the force and gravity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TwoPlaneSystem {
    /// The bar.
    pub bar: TwoPlaneBar,
    /// The ball.
    pub ball: PlanarBall,
    /// The hole.
    pub hole: Hole,
    /// The harmonic force.
    pub forcing: PlanarForcing,
    /// Gravity on the ball.
    pub gravity: Gravity,
    /// The bar's diameter at the cavity, when known: the hole must stay inside it.
    pub bar_diameter_m: Option<f64>,
}

impl TwoPlaneSystem {
    /// `Ω` in rad/s.
    pub fn omega_rad_s(&self) -> f64 {
        match self.forcing.frequency {
            Frequency::Ratio(r) => r * self.bar.omega1_rad_s(),
            Frequency::RadPerS(w) => w,
        }
    }

    /// `c_r`.
    pub fn radial_clearance_m(&self) -> f64 {
        self.hole.radial_clearance_m(self.ball.radius_m)
    }

    /// Check every field; the error names the field and its allowed range.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.bar.validate()?;
        self.ball.validate()?;
        finite("hole.angle_deg", self.hole.angle_deg)?;
        positive("hole.axial_gap_m", self.hole.axial_gap_m)?;
        positive("hole.diameter_m", self.hole.diameter_m)?;
        let ball_d = 2.0 * self.ball.radius_m;
        if self.hole.diameter_m < ball_d {
            return Err(ParamError::DerivedLimit {
                field: "hole.diameter_m (must hold the ball: at least 2·ball.radius_m)",
                inputs: format!("{} m hole, {} m ball", self.hole.diameter_m, ball_d),
                value: self.hole.diameter_m - ball_d,
                min: 0.0,
                max: f64::INFINITY,
                why: "",
            });
        }
        if let Some(d_bar) = self.bar_diameter_m {
            positive("bar_diameter_m", d_bar)?;
            if self.hole.diameter_m >= d_bar {
                return Err(ParamError::DerivedLimit {
                    field: "hole.diameter_m (must be smaller than bar_diameter_m)",
                    inputs: format!("{} m hole, {} m bar", self.hole.diameter_m, d_bar),
                    value: self.hole.diameter_m,
                    min: 0.0,
                    max: d_bar,
                    why: "",
                });
            }
            // The hole runs across the bar, so along it the ball and the plugs need the length
            // `2r + gap` inside the bar's diameter.
            let length = ball_d + self.hole.axial_gap_m;
            if length >= d_bar {
                return Err(ParamError::DerivedLimit {
                    field: "hole.axial_gap_m + 2·ball.radius_m (must fit across bar_diameter_m)",
                    inputs: format!("{} m gap + {} m ball", self.hole.axial_gap_m, ball_d),
                    value: length,
                    min: 0.0,
                    max: d_bar,
                    why: "",
                });
            }
        }
        finite("forcing.amplitude_n", self.forcing.amplitude_n)?;
        finite("forcing.angle_deg", self.forcing.angle_deg)?;
        match self.forcing.frequency {
            Frequency::Ratio(r) => positive("forcing.frequency_ratio", r)?,
            Frequency::RadPerS(w) => positive("forcing.omega_rad_s", w)?,
        }
        non_negative("gravity.m_s2", self.gravity.m_s2)?;
        finite("gravity.angle_deg", self.gravity.angle_deg)
    }
}

/// `value` in `[0, 1)`.
fn below_one(field: &'static str, value: f64) -> Result<(), ParamError> {
    in_range(field, value, 0.0, 1.0, "[0, 1)")?;
    if value < 1.0 {
        Ok(())
    } else {
        Err(ParamError::OutOfRange {
            field,
            value,
            allowed: "[0, 1)",
        })
    }
}

/// Unit vector at `deg` from the radial direction.
pub fn direction(deg: f64) -> [f64; 2] {
    let (s, c) = deg.to_radians().sin_cos();
    [c, s]
}
