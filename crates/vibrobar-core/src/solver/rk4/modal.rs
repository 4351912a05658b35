//! The N-mode bar's kernel: classical RK4 on
//! `mₙ q̈ₙ + 2ζₙωₙmₙ q̇ₙ + mₙωₙ² qₙ = φₙ(x_f) F(t) − φₙ(x_d) F_ball`, `m_d v̈ = F_ball`, with the
//! after-step impact check of [`super`] on `w = v − Σ φₙ(x_d) qₙ`, then the modal impact law
//! ([`crate::damper::impact::modal_impact`]). The friction force on the ball is the law of
//! [`crate::damper::friction`] at `ẇ`; the modes get `−φₙ(x_d) F_ball`.
//!
//! With one unit mode ([`ModalSystem::from_lumped`]) every operation is the lumped kernel's in
//! the same order; only the impulse formula rounds differently (tests/modal_rk4.rs).
//!
//! It reports through the ordinary [`Observer`] protocol: a segment's
//! [`Segment::state_at`](crate::solver::Segment::state_at) is the public [`State`] with `u` at
//! the response point; its integrals are the forcing work at the force point, the modal viscous
//! loss `Σ cₙ q̇ₙ²` and the friction work at the cavity. The modal state itself goes to a
//! [`ModalObserver`] (the public `State` cannot carry it: docs/n-mode-design.md).
//!
//! [`super::Rk4`] runs this on a [`crate::params::BarModel::Modal`] system (its step, through
//! [`ModalSystem::from_system`] and [`ModalState::from_public`]).

use super::{BarKernel, Drive, Hermite, StepHooks};
use crate::damper::impact::modal_impact;
use crate::error::{ParamError, SimError};
use crate::limits::{self, MAX_BEAM_MODES};
use crate::params::{CavityMotion, State};
use crate::solver::{Event, Observer, RunSummary, Segment};
use crate::structure::{ModalState, ModalSystem, Point};

const N: usize = MAX_BEAM_MODES;

/// Fixed-step classical RK4 on a [`ModalSystem`] with the paper's after-step impact check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModalRk4 {
    /// Time step.
    pub dt_s: f64,
}

/// [`super::Rk4`]'s default step.
impl Default for ModalRk4 {
    fn default() -> Self {
        let super::Rk4 { dt_s } = super::Rk4::default();
        ModalRk4 { dt_s }
    }
}

/// Sees the modal state of a run besides the ordinary protocol. Methods default to no-ops.
pub trait ModalObserver: Observer {
    /// A step from `a` to `b` (called right after [`Observer::segment`] of that step).
    fn modal_step(&mut self, _a: &ModalState, _b: &ModalState) {}
    /// An impact (called right after [`Observer::event`] of it).
    fn modal_impact(&mut self, _before: &ModalState, _after: &ModalState, _energy_loss_j: f64) {}
    /// Whether the two methods above do anything: a solver may skip forming the modal states
    /// (two 0.5 KB copies per segment) for an observer that ignores them.
    fn wants_modal(&self) -> bool {
        true
    }
}

impl StepHooks<ModalState> for dyn ModalObserver + '_ {
    fn on_step(&mut self, a: &ModalState, b: &ModalState) {
        self.modal_step(a, b)
    }
    fn on_impact(&mut self, before: &ModalState, after: &ModalState, energy_loss_j: f64) {
        self.modal_impact(before, after, energy_loss_j)
    }
}

impl ModalObserver for () {
    fn wants_modal(&self) -> bool {
        false
    }
}

/// A plain [`Observer`] seen as a [`ModalObserver`] that ignores the modal state (so a solver
/// need not form it). One adapter for both modal solvers.
pub(crate) struct Plain<'a>(pub(crate) &'a mut dyn Observer);

impl Observer for Plain<'_> {
    fn segment(&mut self, seg: &dyn Segment) {
        self.0.segment(seg)
    }
    fn event(&mut self, ev: &Event) {
        self.0.event(ev)
    }
}

impl ModalObserver for Plain<'_> {
    fn wants_modal(&self) -> bool {
        false
    }
}

/// What a modal run ends with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModalRunSummary {
    /// The ordinary summary (its `final_state` is the public state at the response point).
    pub summary: RunSummary,
    /// The modal state at the end.
    pub final_state: ModalState,
}

/// Constants of the right-hand side, computed once per run (fixed capacity).
struct Rhs {
    n: usize,
    m: [f64; N],
    c: [f64; N],
    k: [f64; N],
    phi_f: [f64; N],
    phi_d: [f64; N],
    phi_r: [f64; N],
    drive: Drive,
}

impl Rhs {
    fn new(sys: &ModalSystem) -> Rhs {
        let mut r = Rhs {
            n: sys.n_modes(),
            m: [0.0; N],
            c: [0.0; N],
            k: [0.0; N],
            phi_f: sys.row(Point::Force),
            phi_d: sys.row(Point::Cavity),
            phi_r: sys.row(Point::Response),
            drive: Drive::new(
                &sys.forcing,
                sys.omega_rad_s(),
                sys.damper.as_ref(),
                sys.friction_level_n(),
            ),
        };
        for (i, mode) in sys.model.modes().iter().enumerate() {
            let (m, k) = (mode.modal_mass_kg, mode.modal_stiffness_n_per_m());
            r.m[i] = m;
            r.k[i] = k;
            // 2ζ√(km), the lumped bar's `C` formula (bit for bit its `C` when `k` is its `K`).
            r.c[i] = 2.0 * mode.damping_ratio * (k * m).sqrt();
        }
        r
    }

    fn force(&self, t: f64) -> f64 {
        self.drive.force(t)
    }

    /// `Σ φₙ xₙ` over the modes (from mode 1: one unit mode gives `x₁` exactly).
    fn dot(&self, phi: &[f64; N], x: &[f64; N]) -> f64 {
        let mut s = 0.0;
        for i in 0..self.n {
            s += phi[i] * x[i];
        }
        s
    }

    /// Modal accelerations into `acc` and the ball's, given the external force at this stage.
    fn acc(&self, f_ext: f64, q: &[f64; N], dq: &[f64; N], dv: f64, acc: &mut [f64; N]) -> f64 {
        let fb = self.drive.friction_on_ball(dv - self.dot(&self.phi_d, dq));
        for i in 0..self.n {
            acc[i] =
                (self.phi_f[i] * f_ext - self.c[i] * dq[i] - self.k[i] * q[i] - self.phi_d[i] * fb)
                    / self.m[i];
        }
        self.drive.ball_acc(fb)
    }

    /// One classical RK4 step of size `h` from `s` (the lumped step's arithmetic, per mode).
    /// Only the first `n` entries of the scratch are used (and the state's beyond `n` stay 0).
    /// Inlined into the step loop (the hot path).
    #[inline(always)]
    fn step(&self, s: &ModalState, h: f64, k: &mut Stages) -> ModalState {
        let n = self.n;
        let t = s.t_s;
        let f_a = self.force(t);
        let f_m = self.force(t + 0.5 * h);
        let f_b = self.force(t + h);
        let (q, dq, dv) = (&s.q_m, &s.dq_m_s, s.dv_m_s);

        let b1 = self.acc(f_a, q, dq, dv, &mut k.a1);
        for i in 0..n {
            k.q2[i] = q[i] + 0.5 * h * dq[i];
            k.dq2[i] = dq[i] + 0.5 * h * k.a1[i];
        }
        let dv2 = dv + 0.5 * h * b1;
        let b2 = self.acc(f_m, &k.q2, &k.dq2, dv2, &mut k.a2);
        for i in 0..n {
            k.q3[i] = q[i] + 0.5 * h * k.dq2[i];
            k.dq3[i] = dq[i] + 0.5 * h * k.a2[i];
        }
        let dv3 = dv + 0.5 * h * b2;
        let b3 = self.acc(f_m, &k.q3, &k.dq3, dv3, &mut k.a3);
        for i in 0..n {
            k.q4[i] = q[i] + h * k.dq3[i];
            k.dq4[i] = dq[i] + h * k.a3[i];
        }
        let dv4 = dv + h * b3;
        let b4 = self.acc(f_b, &k.q4, &k.dq4, dv4, &mut k.a4);

        let mut out = *s;
        out.t_s = t + h;
        out.v_m = s.v_m + h / 6.0 * (dv + 2.0 * dv2 + 2.0 * dv3 + dv4);
        out.dv_m_s = dv + h / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4);
        for i in 0..n {
            out.q_m[i] = q[i] + h / 6.0 * (dq[i] + 2.0 * k.dq2[i] + 2.0 * k.dq3[i] + k.dq4[i]);
            out.dq_m_s[i] = dq[i] + h / 6.0 * (k.a1[i] + 2.0 * k.a2[i] + 2.0 * k.a3[i] + k.a4[i]);
        }
        out
    }

    fn public(&self, s: &ModalState) -> State {
        State {
            t_s: s.t_s,
            u_m: self.dot(&self.phi_r, &s.q_m),
            du_m_s: self.dot(&self.phi_r, &s.dq_m_s),
            v_m: s.v_m,
            dv_m_s: s.dv_m_s,
            cavity: Some(CavityMotion {
                u_cavity_m: self.dot(&self.phi_d, &s.q_m),
                du_cavity_m_s: self.dot(&self.phi_d, &s.dq_m_s),
            }),
        }
    }

    /// `Σ (½ mₙ q̇ₙ² + ½ kₙ qₙ²) + ½ m_d v̇²` (the ball's term only with a ball), with the run's
    /// `kₙ` ([`ModalSystem::mechanical_energy_j`]'s formula).
    fn energy(&self, s: &ModalState, has_ball: bool) -> f64 {
        let mut bar = 0.0;
        for i in 0..self.n {
            bar +=
                0.5 * self.m[i] * s.dq_m_s[i] * s.dq_m_s[i] + 0.5 * self.k[i] * s.q_m[i] * s.q_m[i];
        }
        let ball = if has_ball {
            0.5 * self.drive.md * s.dv_m_s * s.dv_m_s
        } else {
            0.0
        };
        bar + ball
    }

    /// `(w, ẇ)` at the cavity.
    fn relative(&self, s: &ModalState) -> (f64, f64) {
        (
            s.v_m - self.dot(&self.phi_d, &s.q_m),
            s.dv_m_s - self.dot(&self.phi_d, &s.dq_m_s),
        )
    }
}

/// The stages of one RK4 step: scratch kept for the whole run (nothing zeroed or allocated per
/// step).
struct Stages {
    a1: [f64; N],
    a2: [f64; N],
    a3: [f64; N],
    a4: [f64; N],
    q2: [f64; N],
    dq2: [f64; N],
    q3: [f64; N],
    dq3: [f64; N],
    q4: [f64; N],
    dq4: [f64; N],
}

impl Stages {
    fn new() -> Stages {
        Stages {
            a1: [0.0; N],
            a2: [0.0; N],
            a3: [0.0; N],
            a4: [0.0; N],
            q2: [0.0; N],
            dq2: [0.0; N],
            q3: [0.0; N],
            dq3: [0.0; N],
            q4: [0.0; N],
            dq4: [0.0; N],
        }
    }
}

/// The N-mode bar as a [`BarKernel`]: its right-hand side and the restitution.
struct Modal {
    rhs: Rhs,
    e: f64,
}

impl BarKernel for Modal {
    type S = ModalState;
    type Stages = Stages;
    const SOLVER: &'static str = "modal rk4";

    fn drive(&self) -> &Drive {
        &self.rhs.drive
    }
    fn stages(&self) -> Stages {
        Stages::new()
    }
    #[inline(always)]
    fn step(&self, s: &ModalState, h: f64, k: &mut Stages) -> ModalState {
        self.rhs.step(s, h, k)
    }
    fn is_finite(&self, s: &ModalState) -> bool {
        let n = self.rhs.n;
        s.v_m.is_finite()
            && s.dv_m_s.is_finite()
            && s.q_m[..n].iter().all(|x| x.is_finite())
            && s.dq_m_s[..n].iter().all(|x| x.is_finite())
    }
    fn beyond(&self, s: &ModalState, bound: f64) -> Option<f64> {
        s.q_m[..self.rhs.n]
            .iter()
            .copied()
            .find(|q| q.abs() > bound)
    }
    fn contact(&self, s: &ModalState) -> (f64, f64) {
        self.rhs.relative(s)
    }
    fn impact(&self, s: &ModalState, dw: f64) -> (ModalState, f64) {
        let (r, n) = (&self.rhs, self.rhs.n);
        let mut after = *s;
        let law = modal_impact(
            r.drive.md,
            self.e,
            &r.phi_d[..n],
            &r.m[..n],
            dw,
            &mut after.dq_m_s[..n],
            &mut after.dv_m_s,
        );
        (after, law.energy_loss_j)
    }
    fn interpolate(&self, a: &ModalState, b: &ModalState, w: &Hermite) -> ModalState {
        let r = &self.rhs;
        let (mut aa, mut ba) = ([0.0; N], [0.0; N]);
        let ab = r.acc(r.force(a.t_s), &a.q_m, &a.dq_m_s, a.dv_m_s, &mut aa);
        let bb = r.acc(r.force(b.t_s), &b.q_m, &b.dq_m_s, b.dv_m_s, &mut ba);
        let mut out = ModalState {
            t_s: w.t,
            v_m: w.pos(a.v_m, a.dv_m_s, b.v_m, b.dv_m_s),
            dv_m_s: w.pos(a.dv_m_s, ab, b.dv_m_s, bb),
            ..ModalState::REST
        };
        for i in 0..r.n {
            out.q_m[i] = w.pos(a.q_m[i], a.dq_m_s[i], b.q_m[i], b.dq_m_s[i]);
            out.dq_m_s[i] = w.pos(a.dq_m_s[i], aa[i], b.dq_m_s[i], ba[i]);
        }
        out
    }
    fn public(&self, s: &ModalState) -> State {
        self.rhs.public(s)
    }
    fn response(&self, s: &ModalState) -> f64 {
        self.rhs.dot(&self.rhs.phi_r, &s.q_m)
    }
    fn force_point_velocity(&self, s: &ModalState) -> f64 {
        self.rhs.dot(&self.rhs.phi_f, &s.dq_m_s)
    }
    fn viscous_power(&self, s: &ModalState) -> f64 {
        let mut p = 0.0;
        for i in 0..self.rhs.n {
            p += self.rhs.c[i] * s.dq_m_s[i] * s.dq_m_s[i];
        }
        p
    }
    fn energy(&self, s: &ModalState, has_ball: bool) -> f64 {
        self.rhs.energy(s, has_ball)
    }
}

impl ModalRk4 {
    /// Check the step for a run over `span_s`: positive, at most [`limits::MAX_STEPS`] steps, and
    /// `ω_N·dt` of the highest mode within RK4's stability limit [`limits::RK4_MAX_OMEGA_DT`].
    pub fn validate_step(&self, sys: &ModalSystem, span_s: f64) -> Result<(), ParamError> {
        crate::params::positive("dt_s", self.dt_s)?;
        limits::check(
            "dt_s (--dt)",
            self.dt_s,
            0.0,
            limits::RK4_MAX_OMEGA_DT / sys.omega_max_rad_s(),
            "rk4's stability limit ω_N·dt ≤ 2.5 for the highest mode kept; a larger step diverges",
        )?;
        limits::check(
            "steps duration/dt (--duration, --dt)",
            (span_s / self.dt_s).ceil(),
            0.0,
            limits::MAX_STEPS,
            "bounded work: raise --dt or shorten the run",
        )?;
        Ok(())
    }

    /// Integrate `sys` from `init` until `t_end_s`, reporting to an ordinary [`Observer`].
    pub fn run(
        &self,
        sys: &ModalSystem,
        init: &ModalState,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<ModalRunSummary, SimError> {
        self.run_modal(sys, init, t_end_s, &mut Plain(obs))
    }

    /// [`ModalRk4::run`], also reporting the modal states to `obs`.
    pub fn run_modal(
        &self,
        sys: &ModalSystem,
        init: &ModalState,
        t_end_s: f64,
        obs: &mut dyn ModalObserver,
    ) -> Result<ModalRunSummary, SimError> {
        crate::solver::validate_modal_run(
            sys,
            init,
            t_end_s,
            Some("contact.law = hertz: the modal rk4 solver applies the restitution law only; use --solver exact"),
        )?;
        self.validate_step(sys, t_end_s - init.t_s)?;

        let kernel = Modal {
            rhs: Rhs::new(sys),
            e: sys.damper.map_or(0.0, |d| d.restitution),
        };
        let bound = divergence_bound_m(sys, init);
        let half_gap = sys.damper.map(|d| d.half_gap_m());
        let (summary, final_state) =
            super::run_steps(&kernel, init, t_end_s, self.dt_s, bound, half_gap, obs)?;
        Ok(ModalRunSummary {
            summary,
            final_state,
        })
    }
}

/// `|qₙ|` beyond which a run has diverged: [`limits::RK4_DIVERGENCE_FACTOR`] times the largest
/// modal displacement scale (static deflection of a mode under every force, initial state over
/// the mode's frequency, half gap).
pub fn divergence_bound_m(sys: &ModalSystem, init: &ModalState) -> f64 {
    let forces = sys.forcing.static_force_n.abs() + sys.forcing.amplitude_n.abs();
    let level = sys.friction_level_n();
    let dw0 = init.dw_m_s(&sys.model).abs();
    let gap = sys.damper.map_or(0.0, |d| d.half_gap_m());
    let scale = sys
        .model
        .modes()
        .iter()
        .enumerate()
        .map(|(i, m)| {
            (forces * m.shape_force.abs() + level * m.shape_cavity.abs())
                / m.modal_stiffness_n_per_m()
                + init.q_m[i].abs()
                + (init.dq_m_s[i].abs() + dw0) / m.omega_rad_s
        })
        .fold(0.0, f64::max)
        + gap;
    limits::RK4_DIVERGENCE_FACTOR * scale
}
