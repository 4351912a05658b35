//! A ball on a modal bar: [`ModalSystem`] (modes, ball, forcing) and its state [`ModalState`].
//!
//! The contact relation is the row of the cavity's mode shapes: `w = v − Σ φₙ(x_d) qₙ`; the
//! forcing acts through the force point's row, `φₙ(x_f) F(t)`; the response is read through the
//! response point's row. The laws (impact, friction) are those of [`crate::damper`]. The lumped
//! bar is the one-mode case with every shape 1 ([`ModalSystem::from_lumped`]).
//!
//! This is the model `System` becomes in part 2 of issue #8 (see `docs/n-mode-design.md`).

use super::{ModalModel, Point, Structure};
use crate::error::ParamError;
use crate::limits::MAX_BEAM_MODES;
use crate::params::{finite, BarModel, CavityMotion, Damper, Forcing, Frequency, State, System};

/// Modes of the bar, an optional ball at the cavity, the forcing at the force point.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalSystem {
    /// The bar's modes (tip-normalised, see [`super`]).
    pub model: ModalModel,
    /// The ball; `None` is a bar without damper.
    pub damper: Option<Damper>,
    /// External force at the force point; [`Frequency::Ratio`] is `Ω/ω₁` of this bar.
    pub forcing: Forcing,
    /// Gravity for the derived friction force.
    pub gravity_m_s2: f64,
}

impl ModalSystem {
    /// The modal system of any [`System`]: a modal bar's modes, or the lumped bar's one unit
    /// mode (`ω = √(K/M)`, `m = M`, `ζ`, every shape 1; the bar checked, errors name the field).
    pub fn from_system(sys: &System) -> Result<ModalSystem, ParamError> {
        let model = match &sys.bar {
            BarModel::Lumped(bar) => Structure::Lumped(*bar).modal_model()?,
            BarModel::Modal(m) => *m,
        };
        Ok(ModalSystem {
            model,
            damper: sys.damper,
            forcing: sys.forcing,
            gravity_m_s2: sys.gravity_m_s2,
        })
    }

    /// The one-mode model of a lumped system ([`ModalSystem::from_system`], kept by name).
    pub fn from_lumped(sys: &System) -> Result<ModalSystem, ParamError> {
        Self::from_system(sys)
    }

    /// This modal system as a [`System`] (its bar [`BarModel::Modal`]).
    pub fn to_system(&self) -> System {
        System {
            bar: BarModel::Modal(self.model),
            damper: self.damper,
            forcing: self.forcing,
            gravity_m_s2: self.gravity_m_s2,
        }
    }

    /// Number of modes `N`.
    pub fn n_modes(&self) -> usize {
        self.model.len()
    }

    /// First natural frequency `ω₁`.
    pub fn omega1_rad_s(&self) -> f64 {
        self.model.modes()[0].omega_rad_s
    }

    /// Highest retained natural frequency (the one RK4's stability sees).
    pub fn omega_max_rad_s(&self) -> f64 {
        self.model
            .modes()
            .iter()
            .map(|m| m.omega_rad_s)
            .fold(0.0, f64::max)
    }

    /// Forcing frequency `Ω` in rad/s.
    pub fn omega_rad_s(&self) -> f64 {
        match self.forcing.frequency {
            Frequency::Ratio(r) => r * self.omega1_rad_s(),
            Frequency::RadPerS(w) => w,
        }
    }

    /// External force at time `t` (at the force point).
    pub fn force_n(&self, t_s: f64) -> f64 {
        self.forcing.static_force_n + self.forcing.amplitude_n * (self.omega_rad_s() * t_s).sin()
    }

    /// Friction force level (0 without a ball or without friction).
    pub fn friction_level_n(&self) -> f64 {
        self.damper
            .map(|d| d.friction_level_n(self.gravity_m_s2))
            .unwrap_or(0.0)
    }

    /// `φₙ` at a point, mode by mode, in a fixed-capacity row (unused entries 0).
    pub fn row(&self, p: Point) -> [f64; MAX_BEAM_MODES] {
        let mut r = [0.0; MAX_BEAM_MODES];
        for (x, m) in r.iter_mut().zip(self.model.modes()) {
            *x = m.shape(p);
        }
        r
    }

    /// Modal masses in a fixed-capacity row (unused entries 0).
    pub fn modal_masses_kg(&self) -> [f64; MAX_BEAM_MODES] {
        let mut r = [0.0; MAX_BEAM_MODES];
        for (x, m) in r.iter_mut().zip(self.model.modes()) {
            *x = m.modal_mass_kg;
        }
        r
    }

    /// The bar's effective mass at the cavity, `1/Σ φₙ(x_d)²/mₙ`.
    pub fn bar_effective_mass_at_cavity_kg(&self) -> f64 {
        1.0 / self
            .model
            .modes()
            .iter()
            .map(|m| m.shape_cavity * m.shape_cavity / m.modal_mass_kg)
            .sum::<f64>()
    }

    /// Mechanical energy `Σ (½ mₙ q̇ₙ² + ½ mₙωₙ² qₙ²) + ½ m_d v̇²`.
    pub fn mechanical_energy_j(&self, s: &ModalState) -> f64 {
        let bar: f64 = self
            .model
            .modes()
            .iter()
            .enumerate()
            .map(|(i, m)| {
                0.5 * m.modal_mass_kg * s.dq_m_s[i] * s.dq_m_s[i]
                    + 0.5 * m.modal_stiffness_n_per_m() * s.q_m[i] * s.q_m[i]
            })
            .sum();
        let ball = self
            .damper
            .map(|d| 0.5 * d.ball_mass_kg * s.dv_m_s * s.dv_m_s)
            .unwrap_or(0.0);
        bar + ball
    }

    /// Check every field; the error names the field and the allowed range: the checks of
    /// [`System::validate`] on [`ModalSystem::to_system`] (one definition of every range).
    pub fn validate(&self) -> Result<(), ParamError> {
        self.to_system().validate()
    }
}

/// State of a modal bar and its ball, fixed capacity (no allocation per step). Entries beyond
/// the model's `N` modes are 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModalState {
    /// Time.
    pub t_s: f64,
    /// Modal coordinates `qₙ` (tip-normalised: metres at the tip).
    pub q_m: [f64; MAX_BEAM_MODES],
    /// Modal velocities `q̇ₙ`.
    pub dq_m_s: [f64; MAX_BEAM_MODES],
    /// Ball displacement `v` (absolute; the cavity centre is at `u(x_d)`).
    pub v_m: f64,
    /// Ball velocity `v̇`.
    pub dv_m_s: f64,
}

impl Default for ModalState {
    fn default() -> Self {
        ModalState::REST
    }
}

impl ModalState {
    /// At rest at `t = 0`, the ball centred.
    pub const REST: ModalState = ModalState {
        t_s: 0.0,
        q_m: [0.0; MAX_BEAM_MODES],
        dq_m_s: [0.0; MAX_BEAM_MODES],
        v_m: 0.0,
        dv_m_s: 0.0,
    };

    /// The one-mode state of a lumped state (`q₁ = u`).
    pub fn from_lumped(s: &State) -> ModalState {
        let mut m = ModalState {
            t_s: s.t_s,
            v_m: s.v_m,
            dv_m_s: s.dv_m_s,
            ..ModalState::REST
        };
        m.q_m[0] = s.u_m;
        m.dq_m_s[0] = s.du_m_s;
        m
    }

    /// Displacement `u(x) = Σ φₙ(x) qₙ` at a point.
    pub fn u_at(&self, model: &ModalModel, p: Point) -> f64 {
        dot(model, p, &self.q_m)
    }

    /// Velocity `u̇(x) = Σ φₙ(x) q̇ₙ` at a point.
    pub fn du_at(&self, model: &ModalModel, p: Point) -> f64 {
        dot(model, p, &self.dq_m_s)
    }

    /// Relative displacement `w = v − Σ φₙ(x_d) qₙ`.
    pub fn w_m(&self, model: &ModalModel) -> f64 {
        self.v_m - self.u_at(model, Point::Cavity)
    }

    /// Relative velocity `ẇ = v̇ − Σ φₙ(x_d) q̇ₙ`.
    pub fn dw_m_s(&self, model: &ModalModel) -> f64 {
        self.dv_m_s - self.du_at(model, Point::Cavity)
    }

    /// The public [`State`] of the observer protocol: `u` and `u̇` at the response point, the
    /// cavity's motion ([`State::cavity`], always filled), the ball's `v`, `v̇`; its `w_m()` is
    /// the relative motion at the cavity.
    pub fn public(&self, model: &ModalModel) -> State {
        State {
            t_s: self.t_s,
            u_m: self.u_at(model, Point::Response),
            du_m_s: self.du_at(model, Point::Response),
            v_m: self.v_m,
            dv_m_s: self.dv_m_s,
            cavity: Some(CavityMotion {
                u_cavity_m: self.u_at(model, Point::Cavity),
                du_cavity_m_s: self.du_at(model, Point::Cavity),
            }),
        }
    }

    /// The modal state a public initial state stands for (the mapping of `docs/n-mode-design.md`,
    /// "initial state"): the response point's `u`, `u̇` put into mode 1
    /// (`q₁ = u/φ₁(x_r)`, `q̇₁ = u̇/φ₁(x_r)`, every other mode at rest) and the ball where the
    /// state puts it relative to the cavity (`v = φ₁(x_d)q₁ + w`, `v̇ = φ₁(x_d)q̇₁ + ẇ`). For the
    /// lumped bar's unit mode this is the state itself.
    ///
    /// Refused, with the field named: a state that carries the cavity's own motion
    /// ([`State::cavity`], e.g. a modal run's final state) unless the bar is at rest (the modes
    /// it came from cannot be recovered from it), and a bar not at rest when the response point
    /// is a node of mode 1.
    pub fn from_public(model: &ModalModel, s: &State) -> Result<ModalState, ParamError> {
        for (field, x) in [
            ("initial.u_m", s.u_m),
            ("initial.du_m_s", s.du_m_s),
            ("initial.u_cavity_m", s.u_cavity_m()),
            ("initial.du_cavity_m_s", s.du_cavity_m_s()),
            ("initial.w_m", s.w_m()),
            ("initial.dw_m_s", s.dw_m_s()),
        ] {
            finite(field, x)?;
        }
        let moving = s.u_m != 0.0 || s.du_m_s != 0.0;
        if let Some(c) = &s.cavity {
            if moving || c.u_cavity_m != 0.0 || c.du_cavity_m_s != 0.0 {
                return Err(ParamError::OutOfRange {
                    field: "initial.cavity (the cavity's motion of a modal state)",
                    value: c.u_cavity_m.abs().max(c.du_cavity_m_s.abs()),
                    allowed: "0: a modal bar starts from u, u̇ at the response point (put into mode 1) or at rest, not from another run's public state",
                });
            }
        }
        let mode1 = model
            .modes()
            .first()
            .copied()
            .unwrap_or(super::Mode::UNUSED);
        let phi_r = mode1.shape_response;
        let mut m = ModalState {
            t_s: s.t_s,
            v_m: s.w_m(),
            dv_m_s: s.dw_m_s(),
            ..ModalState::REST
        };
        if moving {
            if phi_r == 0.0 || !(1.0 / phi_r).is_finite() {
                return Err(ParamError::OutOfRange {
                    field: "initial.u_m (put into mode 1 through its shape at the response point)",
                    value: s.u_m.abs().max(s.du_m_s.abs()),
                    allowed: "0 when the response point is a node of mode 1",
                });
            }
            m.q_m[0] = s.u_m / phi_r;
            m.dq_m_s[0] = s.du_m_s / phi_r;
            m.v_m = mode1.shape_cavity * m.q_m[0] + s.w_m();
            m.dv_m_s = mode1.shape_cavity * m.dq_m_s[0] + s.dw_m_s();
        }
        Ok(m)
    }

    /// Check the initial condition: finite, modes beyond `N` at rest, the ball inside the gap.
    pub fn validate(&self, sys: &ModalSystem) -> Result<(), ParamError> {
        finite("initial.t_s", self.t_s)?;
        for i in 0..MAX_BEAM_MODES {
            finite("initial.q_m", self.q_m[i])?;
            finite("initial.dq_m_s", self.dq_m_s[i])?;
            if i >= sys.n_modes() && (self.q_m[i] != 0.0 || self.dq_m_s[i] != 0.0) {
                return Err(ParamError::OutOfRange {
                    field: "initial.q_m (modes beyond N)",
                    value: self.q_m[i].abs().max(self.dq_m_s[i].abs()),
                    allowed: "0 beyond the model's modes",
                });
            }
        }
        finite("initial.v_m", self.v_m)?;
        finite("initial.dv_m_s", self.dv_m_s)?;
        if let Some(d) = &sys.damper {
            let w = self.w_m(&sys.model);
            if w.abs() > d.half_gap_m() {
                return Err(ParamError::OutOfRange {
                    field: "initial.w_m (v − u(x_d))",
                    value: w,
                    allowed: "[−gap/2, +gap/2]",
                });
            }
        }
        Ok(())
    }
}

/// `Σ φₙ(p) xₙ` over the model's modes (summed from mode 1, so one unit mode gives `x₁` exactly).
fn dot(model: &ModalModel, p: Point, x: &[f64; MAX_BEAM_MODES]) -> f64 {
    let mut s = 0.0;
    for (m, xi) in model.modes().iter().zip(x) {
        s += m.shape(p) * xi;
    }
    s
}
