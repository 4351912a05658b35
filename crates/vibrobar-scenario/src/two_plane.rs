//! `[two_plane]`: the bar that bends in two planes, with the ball in a hole across it.
//!
//! The section adds what the one-plane model has no place for; everything else comes from the
//! scenario's other sections, so a one-plane scenario becomes a two-plane one by adding it:
//!
//! | what | from |
//! |---|---|
//! | the bar | `[bar]` (round: its K and ζ in both planes, or per principal axis with `stiffness_n_per_m = [K1, K2]`, `damping_ratio = [ζ1, ζ2]`, `principal_axis_deg`), or `[beam]` / `[[modes]]` (a round bar of those modes in each plane; `[[modes]]` entries with `direction_deg`: two perpendicular families, each bending in its direction) |
//! | the ball | `[damper]`: `ball_mass_kg`, `ball_radius_m`, `restitution`, `rolling_friction_m`; friction on the hole's walls here |
//! | the hole | `[damper] gap_m` is the axial gap (the ball moves ±gap/2 along the hole); here its direction and diameter |
//! | the force | `[forcing]`: amplitude and frequency; here its direction |
//! | gravity | `gravity_m_s2`; here its direction |
//! | the runs | `[run]`: `duration_s`, `rms_fraction`, `dt_s` (the reference solver's step); here the solver and the ensemble of starts |
//!
//! ```toml
//! [two_plane]
//! hole_angle_deg = 0.0        # the hole's direction (0 = radial)
//! hole_diameter_m = 0.0151    # radial clearance (d_hole − 2r)/2 across the hole
//! force_ratio = 2.0           # F_t/F_r: the force at atan(2) = 63.4° (or force_angle_deg)
//! gravity_angle_deg = 90.0    # along the tangential force
//! friction_static = 0.0       # μ_s on the hole's walls, [0, 1)
//! friction_kinetic = 0.0      # μ_k, [0, μ_s]
//! solver = "auto"             # exact | reference | auto
//! members = 8                 # the ensemble of starts
//! seed = 1
//! start_speed_m_s = 0.01
//! ```
//!
//! Angles are in the cross-section plane, in degrees from the radial direction towards the
//! tangential one.

use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};
use vibrobar_core::analysis::two_plane::{starts, TwoPlaneEnsemble, TwoPlaneMethod};
use vibrobar_core::params::two_plane::{
    Gravity, Hole, ModalPair, PlanarBall, PlanarBar, PlanarForcing, TwoPlaneBar, TwoPlaneSystem,
};
use vibrobar_core::params::BarModel;
use vibrobar_core::solver::two_plane_rk4::TwoPlaneStart;
use vibrobar_core::structure::MeasuredMode;
use vibrobar_core::{limits, Frequency};

use crate::Scenario;

/// `[two_plane]`. Missing fields: a radial 15.1 mm hole, the force at a tangential/radial ratio
/// of 2, gravity at 90°, frictionless walls, the automatic solver, 8 members from seed 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TwoPlaneSection {
    /// The hole's direction, degrees.
    pub hole_angle_deg: f64,
    /// The hole's diameter, m.
    pub hole_diameter_m: f64,
    /// The force's direction, degrees (exclusive with `force_ratio`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub force_angle_deg: Option<f64>,
    /// The force's tangential/radial ratio (exclusive with `force_angle_deg`; default 2).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub force_ratio: Option<f64>,
    /// Gravity's direction, degrees.
    pub gravity_angle_deg: f64,
    /// Static friction coefficient on the hole's walls.
    pub friction_static: f64,
    /// Kinetic friction coefficient.
    pub friction_kinetic: f64,
    /// A lumped bar's stiffness per principal axis (default: `[bar]`'s in both).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stiffness_n_per_m: Option<[f64; 2]>,
    /// A lumped bar's damping ratio per principal axis (default: `[bar]`'s in both).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub damping_ratio: Option<[f64; 2]>,
    /// The first principal axis' direction, degrees.
    pub principal_axis_deg: f64,
    /// The bar's diameter at the cavity, m, when known: the hole must fit inside it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bar_diameter_m: Option<f64>,
    /// `exact`, `reference` or `auto`.
    pub solver: String,
    /// Members of each design point's ensemble of starts.
    pub members: usize,
    /// Seed of the starts.
    pub seed: u64,
    /// Largest start speed of a member, m/s.
    pub start_speed_m_s: f64,
}

impl Default for TwoPlaneSection {
    fn default() -> Self {
        let ens = TwoPlaneEnsemble::default();
        TwoPlaneSection {
            hole_angle_deg: 0.0,
            hole_diameter_m: 0.0151,
            force_angle_deg: None,
            force_ratio: None,
            gravity_angle_deg: 90.0,
            friction_static: 0.0,
            friction_kinetic: 0.0,
            stiffness_n_per_m: None,
            damping_ratio: None,
            principal_axis_deg: 0.0,
            bar_diameter_m: None,
            solver: "auto".into(),
            members: ens.members,
            seed: ens.seed,
            start_speed_m_s: ens.start_speed_m_s,
        }
    }
}

/// Every field's name in errors: `[two_plane] field`.
fn field(e: impl std::fmt::Display) -> String {
    let msg = e.to_string();
    let map = [
        ("hole.angle_deg", "[two_plane] hole_angle_deg"),
        ("hole.diameter_m", "[two_plane] hole_diameter_m"),
        ("hole.axial_gap_m", "[damper] gap_m"),
        ("forcing.angle_deg", "[two_plane] force_angle_deg"),
        ("gravity.angle_deg", "[two_plane] gravity_angle_deg"),
        ("gravity.m_s2", "gravity_m_s2"),
        ("ball.friction_static", "[two_plane] friction_static"),
        ("ball.friction_kinetic", "[two_plane] friction_kinetic"),
        ("bar.stiffness_n_per_m", "[two_plane] stiffness_n_per_m"),
        ("bar.damping_ratio", "[two_plane] damping_ratio"),
        ("bar.principal_axis_deg", "[two_plane] principal_axis_deg"),
        ("bar_diameter_m", "[two_plane] bar_diameter_m"),
        ("ball.", "[damper] ball_"),
        ("bar.", "[bar] "),
    ];
    map.iter().fold(msg, |m, (a, b)| m.replace(a, b))
}

impl TwoPlaneSection {
    /// The force's direction, degrees.
    pub fn force_angle_deg(&self) -> Result<f64> {
        match (self.force_angle_deg, self.force_ratio) {
            (Some(_), Some(_)) => bail!(
                "[two_plane] force_angle_deg and force_ratio both give the force's direction: \
                 keep one of them"
            ),
            (Some(a), None) => Ok(a),
            (None, r) => {
                let r = r.unwrap_or(2.0);
                if !r.is_finite() || r < 0.0 {
                    bail!(
                        "[two_plane] force_ratio = {r} is outside the allowed range [0, ∞) \
                         (tangential over radial force)"
                    );
                }
                Ok(PlanarForcing::angle_from_ratio_deg(r))
            }
        }
    }

    /// The solver.
    pub fn method(&self, dt_s: f64) -> Result<TwoPlaneMethod> {
        Ok(match self.solver.as_str() {
            "auto" => TwoPlaneMethod::Auto { dt_s },
            "exact" => TwoPlaneMethod::Exact,
            "reference" => TwoPlaneMethod::Reference { dt_s },
            s => bail!(
                "[two_plane] solver = {s:?} is not one of the allowed values: exact, reference, \
                 auto"
            ),
        })
    }

    /// The ensemble of starts.
    pub fn ensemble(&self) -> Result<TwoPlaneEnsemble> {
        let e = TwoPlaneEnsemble {
            members: self.members,
            seed: self.seed,
            start_speed_m_s: self.start_speed_m_s,
        };
        e.validate().map_err(|err| {
            anyhow::anyhow!(
                "{}",
                err.to_string()
                    .replace("members (--members)", "[two_plane] members")
                    .replace("start_speed_m_s", "[two_plane] start_speed_m_s")
            )
        })?;
        Ok(e)
    }
}

impl Scenario {
    /// The two-plane system of a `[two_plane]` scenario (`None` without the section); errors
    /// name the scenario's field.
    pub fn two_plane_system(&self) -> Result<Option<TwoPlaneSystem>> {
        let Some(t) = &self.two_plane else {
            return Ok(None);
        };
        let bar = match self.bars()?.0 {
            BarModel::Lumped(b) => TwoPlaneBar::Lumped(PlanarBar {
                mass_kg: b.mass_kg,
                stiffness_n_per_m: t.stiffness_n_per_m.unwrap_or([b.stiffness_n_per_m; 2]),
                damping_ratio: t.damping_ratio.unwrap_or([b.damping_ratio; 2]),
                principal_axis_deg: t.principal_axis_deg,
            }),
            BarModel::Modal(m) => {
                if t.stiffness_n_per_m.is_some() || t.damping_ratio.is_some() {
                    bail!(
                        "[two_plane] stiffness_n_per_m and damping_ratio apply to a lumped [bar]; \
                         a bar of modes ([beam] or [[modes]]) is round, the same in both planes, \
                         or its [[modes]] give each mode's direction_deg"
                    );
                }
                match self
                    .modes
                    .as_deref()
                    .map(measured_pair)
                    .transpose()?
                    .flatten()
                {
                    Some(pair) => TwoPlaneBar::Measured(pair),
                    None => TwoPlaneBar::Round(m),
                }
            }
        };
        let d = &self.damper;
        let sys = TwoPlaneSystem {
            bar,
            ball: PlanarBall {
                mass_kg: d.ball_mass_kg,
                radius_m: d.ball_radius_m,
                restitution: d.restitution,
                friction_static: t.friction_static,
                friction_kinetic: t.friction_kinetic,
                rolling_friction_m: d.rolling_friction_m,
            },
            hole: Hole {
                angle_deg: t.hole_angle_deg,
                axial_gap_m: d.gap_m,
                diameter_m: t.hole_diameter_m,
            },
            forcing: PlanarForcing {
                amplitude_n: self.forcing.amplitude_n,
                frequency: self.forcing.frequency,
                angle_deg: t.force_angle_deg()?,
            },
            gravity: Gravity {
                m_s2: self.gravity_m_s2,
                angle_deg: t.gravity_angle_deg,
            },
            bar_diameter_m: t.bar_diameter_m,
        };
        sys.validate()
            .map_err(|e| anyhow::anyhow!("{}", field(e)))?;
        Ok(Some(sys))
    }

    /// The two-plane system this scenario runs and the solver its `[two_plane] solver` asks
    /// for, checked: `exact` on a system whose planes do not decouple is refused with the
    /// reason. An error without the section.
    pub fn two_plane_run(&self) -> Result<(TwoPlaneSystem, TwoPlaneMethod)> {
        let Some(t) = &self.two_plane else {
            bail!("the scenario has no [two_plane] section");
        };
        let sys = self.two_plane_system()?.expect("the section is there");
        let method = t.method(self.settings().dt_s)?;
        if let TwoPlaneMethod::Exact = method {
            vibrobar_core::solver::two_plane_exact::decoupled(&sys)
                .map_err(|why| anyhow::anyhow!("[two_plane] solver = \"exact\": {why}"))?;
        }
        Ok((sys, method))
    }

    /// Member `member` of the `[two_plane]` ensemble of starts of `sys` (`flag` names the
    /// argument that chose it in errors).
    pub fn two_plane_start(
        &self,
        sys: &TwoPlaneSystem,
        member: usize,
        flag: &str,
    ) -> Result<TwoPlaneStart> {
        let Some(t) = &self.two_plane else {
            bail!("the scenario has no [two_plane] section");
        };
        let ens = t.ensemble()?;
        if member >= ens.members {
            bail!(
                "{flag} = {member} is outside the allowed range [0, {}] (the [two_plane] \
                 ensemble has {} members)",
                ens.members - 1,
                ens.members
            );
        }
        Ok(starts(sys, &ens).map_err(|e| anyhow::anyhow!("{e}"))?[member])
    }
}

/// The two bending families of measured modes whose `[[modes]]` entries give `direction_deg`
/// (`None` when none does: a round bar). Every entry must give one, and the directions must
/// form two perpendicular families (to 1e-9°, modulo 180°), each with at least one mode.
pub(crate) fn measured_pair(modes: &[MeasuredMode]) -> Result<Option<ModalPair>> {
    let given = modes.iter().filter(|m| m.direction_deg.is_some()).count();
    if given == 0 {
        return Ok(None);
    }
    if given < modes.len() {
        bail!(
            "[[modes]] direction_deg: {given} of {} entries give it; give every mode's bending \
             direction (two perpendicular families), or none for a round bar",
            modes.len()
        );
    }
    let dirs: Vec<f64> = modes
        .iter()
        .map(|m| m.direction_deg.expect("every entry gives one"))
        .collect();
    for (i, d) in dirs.iter().enumerate() {
        if !d.is_finite() {
            bail!("modes[{i}].direction_deg = {d} is not a finite angle (degrees)");
        }
    }
    let axis = dirs[0];
    let off = |d: f64| (d - axis).rem_euclid(180.0);
    let near = |x: f64, y: f64| (x - y).abs() <= 1e-9 || (x - y).abs() >= 180.0 - 1e-9;
    let mut families: [Vec<MeasuredMode>; 2] = [Vec::new(), Vec::new()];
    for (i, (m, &d)) in modes.iter().zip(&dirs).enumerate() {
        let o = off(d);
        if near(o, 0.0) {
            families[0].push(*m);
        } else if near(o, 90.0) {
            families[1].push(*m);
        } else {
            bail!(
                "modes[{i}].direction_deg = {d}: the measured modes bend in two perpendicular \
                 directions (the bar's principal axes); allowed: {axis}° or {}° (modulo 180°)",
                axis + 90.0
            );
        }
    }
    if families[1].is_empty() {
        bail!(
            "[[modes]] direction_deg: every mode bends along {axis}°; give the modes of the \
             perpendicular direction too (the bar bends in both), or leave direction_deg out \
             for a round bar"
        );
    }
    Ok(Some(ModalPair {
        modes: [
            crate::measured_model("modes", &families[0])?,
            crate::measured_model("modes", &families[1])?,
        ],
        axis_deg: axis,
    }))
}

/// `[[modes]] direction_deg` belongs to a `[two_plane]` scenario, never to `[[solid_modes]]`.
pub(crate) fn check_mode_directions(s: &Scenario) -> Result<()> {
    if let Some(i) = s
        .solid_modes
        .iter()
        .flatten()
        .position(|m| m.direction_deg.is_some())
    {
        bail!(
            "solid_modes[{i}].direction_deg: the solid reference is the one-plane bar; leave \
             direction_deg out of [[solid_modes]]"
        );
    }
    if s.two_plane.is_none() {
        if let Some(i) = s
            .modes
            .iter()
            .flatten()
            .position(|m| m.direction_deg.is_some())
        {
            bail!(
                "modes[{i}].direction_deg: a mode's bending direction applies to a scenario \
                 with [two_plane] (the bar that bends in two planes); leave it out for one plane"
            );
        }
    }
    Ok(())
}

/// The axes of a grid of two-plane design points, and how errors name the hole's axes.
#[derive(Debug, Clone, Copy)]
pub struct TwoPlaneAxes<'a> {
    /// Frequency ratios.
    pub ratios: &'a [f64],
    /// Total axial clearances.
    pub gaps_m: &'a [f64],
    /// Hole directions (`None`: the scenario's).
    pub hole_angles_deg: Option<&'a [f64]>,
    /// Hole diameters (`None`: the scenario's).
    pub hole_diameters_m: Option<&'a [f64]>,
    /// The names of the hole-angle and hole-diameter axes in errors (a flag, a keyword).
    pub names: [&'a str; 2],
}

impl<'a> TwoPlaneAxes<'a> {
    /// Gaps × ratios at the scenario's hole.
    pub fn gaps_and_ratios(gaps_m: &'a [f64], ratios: &'a [f64]) -> Self {
        TwoPlaneAxes {
            ratios,
            gaps_m,
            hole_angles_deg: None,
            hole_diameters_m: None,
            names: ["", ""],
        }
    }
}

/// One cell of a grid of two-plane design points: where it lies and its system.
#[derive(Debug, Clone, Copy)]
pub struct TwoPlaneCell {
    /// Frequency ratio.
    pub ratio: f64,
    /// Total axial clearance.
    pub axial_gap_m: f64,
    /// The hole's direction.
    pub hole_angle_deg: f64,
    /// The hole's diameter.
    pub hole_diameter_m: f64,
    /// The system at the cell.
    pub system: TwoPlaneSystem,
}

impl Scenario {
    /// Every cell of the grid `axes` of this `[two_plane]` scenario, in file order (hole
    /// diameter, hole angle, gap, then ratio fastest), each system checked before anything
    /// runs: a hole wider than the bar or a ball larger than the hole is refused naming the
    /// axis. `members` runs per cell must stay within [`limits::MAX_RUNS`] (`what` names the
    /// count in that error).
    pub fn two_plane_cells(
        &self,
        axes: &TwoPlaneAxes,
        members: usize,
        what: &'static str,
    ) -> Result<Vec<TwoPlaneCell>> {
        let Some(t) = &self.two_plane else {
            bail!("the scenario has no [two_plane] section");
        };
        let angles = axes
            .hole_angles_deg
            .unwrap_or(std::slice::from_ref(&t.hole_angle_deg));
        let diameters = axes
            .hole_diameters_m
            .unwrap_or(std::slice::from_ref(&t.hole_diameter_m));
        let cells = [
            axes.ratios.len(),
            axes.gaps_m.len(),
            angles.len(),
            diameters.len(),
        ]
        .iter()
        .fold(1usize, |n, &k| n.saturating_mul(k));
        limits::check(
            what,
            cells.saturating_mul(members) as f64,
            0.0,
            limits::MAX_RUNS as f64,
            "fewer cells or members",
        )?;
        let mut out = Vec::with_capacity(cells);
        for &d in diameters {
            for &angle in angles {
                for &gap_m in axes.gaps_m {
                    for &ratio in axes.ratios {
                        let mut s = self.clone();
                        s.damper.gap_m = gap_m;
                        s.forcing.frequency = Frequency::Ratio(ratio);
                        if let Some(t) = s.two_plane.as_mut() {
                            t.hole_angle_deg = angle;
                            t.hole_diameter_m = d;
                        }
                        let (system, _) = s.two_plane_run().map_err(|e| {
                            let msg = e.to_string();
                            let msg = match axes.hole_diameters_m {
                                Some(_) => {
                                    msg.replace("[two_plane] hole_diameter_m", axes.names[1])
                                }
                                None => msg,
                            };
                            let msg = match axes.hole_angles_deg {
                                Some(_) => msg.replace("[two_plane] hole_angle_deg", axes.names[0]),
                                None => msg,
                            };
                            anyhow::anyhow!("{msg}")
                        })?;
                        out.push(TwoPlaneCell {
                            ratio,
                            axial_gap_m: gap_m,
                            hole_angle_deg: angle,
                            hole_diameter_m: d,
                            system,
                        });
                    }
                }
            }
        }
        Ok(out)
    }
}

/// The commands that run a `[two_plane]` scenario.
pub const TWO_PLANE_COMMANDS: [&str; 9] = [
    "run",
    "sweep",
    "ensemble",
    "map",
    "poincare",
    "placement",
    "lyapunov",
    "orbit",
    "continue",
];

/// The error for a `[two_plane]` scenario given to `command`.
pub fn two_plane_refusal(command: &str) -> String {
    format!(
        "vibrobar {command} does not run a [two_plane] scenario (the bar that bends in two planes \
         runs with vibrobar {}, the design document vibrobar two-plane, and Python's \
         vibrobar.two_plane and vibrobar.two_plane_run); remove [two_plane] for the one-plane model",
        TWO_PLANE_COMMANDS.join(", ")
    )
}

/// Whether the TOML text has a `[two_plane]` section (unparsable text: no; its command reports
/// the parse error).
pub fn text_has_two_plane(text: &str) -> bool {
    toml::from_str::<toml::Table>(text).is_ok_and(|t| t.contains_key("two_plane"))
}
