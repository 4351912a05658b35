//! The paper's scheme, exactly: classical RK4 with a fixed step `dt` on the grid `t₀ + i·dt` (a
//! last partial step closes the run); after each step, if `w ≥ l_g` with `ẇ > 0` or `w ≤ −l_g`
//! with `ẇ < 0`, the impact law is applied (Eqs. 4–5 on the lumped bar).
//!
//! It is the independent check of the [`super::exact`] solver: a different method (fixed steps,
//! impacts detected after the step) that converges to the exact solution as `dt → 0`.
//!
//! Nothing is done about the penetration this leaves (the ball may sit slightly beyond the wall):
//! that is the scheme as published, and [`RunSummary::max_penetration_m`] reports it.
//! With `coulomb` friction, sticking is not modelled as a mode: `sgn(ẇ)` chatters about `ẇ = 0`,
//! as any fixed-step scheme with a discontinuous right-hand side does. The step must keep `ω·dt`
//! of the bar's fastest mode within RK4's stability limit [`crate::limits::RK4_MAX_OMEGA_DT`]; a
//! larger step is refused.
//!
//! One step loop (`run_steps`), one impact check (`wall_hit`) and one step segment (cubic
//! Hermite interpolation between the step's ends, for observers) serve every bar, through a
//! `BarKernel`: what the loop needs from a bar (its state, the RK4 stage arithmetic, the contact
//! row `w, ẇ`, the impact through it, the public [`State`], the response, the energy). Kernels:
//! - [`lumped`]: the one-mode bar of the paper ([`Rk4`] on a [`BarModel::Lumped`] system);
//! - [`modal`]: the N-mode bar ([`ModalRk4`]; [`Rk4`] runs it on a [`BarModel::Modal`] system).
//!
//! Each kernel keeps its own arithmetic, so the lumped bar's results are those of the paper's
//! reproduction bit for bit.
//!
//! [`ModalRk4`]: modal::ModalRk4

pub mod lumped;
pub mod modal;

pub use lumped::divergence_bound_m;

use super::{
    Event, EventKind, Mode, Observer, RunSummary, Segment, SegmentIntegrals, Solver, Wall,
};
use crate::damper::friction::{sign_factor, sliding_friction_on_ball_n};
use crate::error::{ParamError, SimError};
use crate::params::{BarModel, Damper, Forcing, FrictionModel, State, System};
use crate::structure::{ModalState, ModalSystem};

/// Fixed-step classical Runge–Kutta 4 with the paper's after-step impact check, on every bar.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rk4 {
    /// Time step.
    pub dt_s: f64,
}

impl Default for Rk4 {
    fn default() -> Self {
        Rk4 { dt_s: 1e-6 }
    }
}

impl Solver for Rk4 {
    fn name(&self) -> &'static str {
        "rk4"
    }

    fn run(
        &self,
        sys: &System,
        init: &State,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<RunSummary, SimError> {
        super::validate_run(sys, init, t_end_s)?;
        super::refuse_hertz(
            sys.damper.as_ref(),
            "contact.law = hertz: the rk4 solver applies the restitution law only; use --solver exact",
        )?;
        sys.validate_fixed_step(self.dt_s, t_end_s - init.t_s)?;
        match &sys.bar {
            BarModel::Lumped(bar) => lumped::run(sys, bar, init, t_end_s, self.dt_s, obs),
            // The same scheme mode by mode (its own step check: ω_N·dt).
            BarModel::Modal(model) => {
                let msys = ModalSystem::from_system(sys)?;
                let minit = ModalState::from_public(model, init)?;
                Ok(modal::ModalRk4 { dt_s: self.dt_s }
                    .run(&msys, &minit, t_end_s, obs)?
                    .summary)
            }
        }
    }
}

/// The constants of the right-hand side every bar shares: the harmonic force, the ball's mass
/// and its friction law.
#[derive(Clone, Copy)]
struct Drive {
    f0: f64,
    fs: f64,
    omega: f64,
    md: f64,
    friction: FrictionModel,
    level: f64,
    /// `g_s`: the ball's acceleration from its body force along the gap (`+0.0` without one).
    gs: f64,
}

impl Drive {
    fn new(forcing: &Forcing, omega: f64, damper: Option<&Damper>, level: f64) -> Drive {
        let (md, friction) = match damper {
            Some(d) => (d.ball_mass_kg, d.friction),
            None => (1.0, FrictionModel::None),
        };
        Drive {
            f0: forcing.amplitude_n,
            fs: forcing.static_force_n,
            omega,
            md,
            friction,
            level,
            gs: match damper {
                Some(d) if d.gravity_along_gap_m_s2 != 0.0 => d.gravity_along_gap_m_s2,
                _ => 0.0,
            },
        }
    }

    /// The ball's acceleration under the friction force `fb`: `fb/m_d + g_s` (`fb/m_d` to the
    /// bit without a body force).
    #[inline(always)]
    fn ball_acc(&self, fb: f64) -> f64 {
        if self.gs == 0.0 {
            fb / self.md
        } else {
            fb / self.md + self.gs
        }
    }

    fn force(&self, t: f64) -> f64 {
        self.fs + self.f0 * (self.omega * t).sin()
    }

    /// The sliding friction force on the ball at relative velocity `dw`.
    fn friction_on_ball(&self, dw: f64) -> f64 {
        sliding_friction_on_ball_n(self.friction, self.level, dw)
    }
}

/// What the step loop needs from a bar. Implemented by [`lumped::Lumped`] and [`modal::Modal`];
/// the loop is generic over it (monomorphised, nothing dynamic on the hot path).
trait BarKernel {
    /// The state the scheme steps.
    type S: StepState;
    /// Scratch for the stages of one step, kept for the whole run.
    type Stages;
    /// The solver's name in a divergence error.
    const SOLVER: &'static str;

    /// The shared constants of the right-hand side.
    fn drive(&self) -> &Drive;
    /// Fresh stage scratch.
    fn stages(&self) -> Self::Stages;
    /// One classical RK4 step of size `h` from `s`.
    fn step(&self, s: &Self::S, h: f64, k: &mut Self::Stages) -> Self::S;
    /// Every coordinate of `s` is finite.
    fn is_finite(&self, s: &Self::S) -> bool;
    /// A bar displacement of `s` beyond `bound` (the run has diverged), if any.
    fn beyond(&self, s: &Self::S, bound: f64) -> Option<f64>;
    /// `(w, ẇ)`: the ball relative to the cavity.
    fn contact(&self, s: &Self::S) -> (f64, f64);
    /// The impact law at pre-impact relative velocity `dw`: the state after and the energy lost.
    fn impact(&self, s: &Self::S, dw: f64) -> (Self::S, f64);
    /// The cubic Hermite interpolant between the step's ends `a` and `b` with weights `w`.
    fn interpolate(&self, a: &Self::S, b: &Self::S, w: &Hermite) -> Self::S;
    /// The public state of `s` (`u` at the response point).
    fn public(&self, s: &Self::S) -> State;
    /// `u` at the response point.
    fn response(&self, s: &Self::S) -> f64;
    /// `u̇` at the force point.
    fn force_point_velocity(&self, s: &Self::S) -> f64;
    /// The viscous dissipation rate `Σ cₙ q̇ₙ²`.
    fn viscous_power(&self, s: &Self::S) -> f64;
    /// The mechanical energy (the ball's term only with a ball).
    fn energy(&self, s: &Self::S, has_ball: bool) -> f64;
}

/// What the loop reads and sets on a kernel's state (the lumped [`State`] and the
/// [`ModalState`] alike: written once, by `step_state!`).
trait StepState: Copy {
    /// Time.
    fn time(&self) -> f64;
    /// Move the state to time `t` (nothing else changed).
    fn set_time(&mut self, t: f64);
    /// A copy of the state moved to time `t`.
    fn at_time(&self, t: f64) -> Self {
        let mut s = *self;
        s.set_time(t);
        s
    }
    /// The state with the ball at rest at 0 (a bar without damper).
    fn without_ball(&self) -> Self;
}

macro_rules! step_state {
    ($($state:ty),*) => {$(
        impl StepState for $state {
            fn time(&self) -> f64 {
                self.t_s
            }
            fn set_time(&mut self, t: f64) {
                self.t_s = t;
            }
            fn without_ball(&self) -> Self {
                Self {
                    v_m: 0.0,
                    dv_m_s: 0.0,
                    ..*self
                }
            }
        }
    )*};
}

step_state!(State, ModalState);

/// What a run tells its observer besides the ordinary protocol: the kernel's own states (the
/// modal states for a [`modal::ModalObserver`]; nothing for a plain [`Observer`]).
trait StepHooks<S> {
    /// A step from `a` to `b` (right after the segment of that step).
    fn on_step(&mut self, _a: &S, _b: &S) {}
    /// An impact (right after its event).
    fn on_impact(&mut self, _before: &S, _after: &S, _energy_loss_j: f64) {}
}

impl StepHooks<State> for dyn Observer + '_ {}

/// The cubic Hermite basis at one instant of a step of length `h`.
struct Hermite {
    t: f64,
    h: f64,
    h00: f64,
    h10: f64,
    h01: f64,
    h11: f64,
}

impl Hermite {
    /// The cubic through `p0` (slope `v0`) at the step's start and `p1` (slope `v1`) at its end.
    fn pos(&self, p0: f64, v0: f64, p1: f64, v1: f64) -> f64 {
        self.h00 * p0 + self.h10 * self.h * v0 + self.h01 * p1 + self.h11 * self.h * v1
    }
}

/// One step seen as a segment: cubic Hermite interpolation of every coordinate between the ends
/// (positions with velocity slopes, velocities with acceleration slopes).
struct StepSegment<'a, K: BarKernel> {
    kernel: &'a K,
    a: &'a K::S,
    b: &'a K::S,
    has_ball: bool,
}

impl<K: BarKernel> StepSegment<'_, K> {
    fn hermite(&self, t: f64) -> K::S {
        let (ta, tb) = (self.a.time(), self.b.time());
        let h = tb - ta;
        if t <= ta || h <= 0.0 {
            return self.a.at_time(t);
        }
        if t >= tb {
            return self.b.at_time(t);
        }
        let s = (t - ta) / h;
        let w = Hermite {
            t,
            h,
            h00: (1.0 + 2.0 * s) * (1.0 - s) * (1.0 - s),
            h10: s * (1.0 - s) * (1.0 - s),
            h01: s * s * (3.0 - 2.0 * s),
            h11: s * s * (s - 1.0),
        };
        self.kernel.interpolate(self.a, self.b, &w)
    }
}

impl<K: BarKernel> Segment for StepSegment<'_, K> {
    fn t_start_s(&self) -> f64 {
        self.a.time()
    }
    fn t_end_s(&self) -> f64 {
        self.b.time()
    }
    fn mode(&self) -> Mode {
        if self.has_ball {
            Mode::Free
        } else {
            Mode::NoBall
        }
    }
    fn state_at(&self, t_s: f64) -> State {
        self.kernel.public(&self.hermite(t_s))
    }
    fn mechanical_energy_j(&self, t_s: f64) -> f64 {
        self.kernel.energy(&self.hermite(t_s), self.has_ball)
    }
    fn integral_u2(&self, a_s: f64, b_s: f64) -> f64 {
        // Trapezoid over one step: matches the paper's RMS of the sampled history to O(dt²).
        let (sa, sb) = if a_s <= self.a.time() && b_s >= self.b.time() {
            (*self.a, *self.b)
        } else {
            (self.hermite(a_s), self.hermite(b_s))
        };
        let (ua, ub) = (self.kernel.response(&sa), self.kernel.response(&sb));
        0.5 * (b_s - a_s) * (ua * ua + ub * ub)
    }
    fn integrals(&self, a_s: f64, b_s: f64) -> SegmentIntegrals {
        let (sa, sb) = (self.hermite(a_s), self.hermite(b_s));
        let h = b_s - a_s;
        let k = self.kernel;
        let d = k.drive();
        let trap = |f: &dyn Fn(&K::S) -> f64| 0.5 * h * (f(&sa) + f(&sb));
        // `F_ball ẇ = ±F|ẇ|`, so the friction work is ±F times the total variation of `w`: this
        // keeps its sign on steps where ẇ reverses (the start-of-step force times Δw did not).
        let sign = sign_factor(d.friction);
        SegmentIntegrals {
            u2_m2_s: trap(&|s| {
                let u = k.response(s);
                u * u
            }),
            forcing_work_j: trap(&|s| d.force(s.time()) * k.force_point_velocity(s)),
            viscous_loss_j: trap(&|s| k.viscous_power(s)),
            friction_work_j: if sign == 0.0 || d.level == 0.0 {
                0.0
            } else {
                let (ta, tb) = (self.a.time(), self.b.time());
                sign * d.level
                    * hermite_total_variation(
                        ta,
                        tb - ta,
                        k.contact(self.a),
                        k.contact(self.b),
                        a_s,
                        b_s,
                    )
            },
        }
    }
}

/// The step loop of every bar: `n` steps on the grid `t₀ + i·dt` (no accumulated drift; a last
/// partial step closes the run at `t_end_s`), each checked for a non-finite state and for a
/// displacement beyond `bound_m`, reported as a segment, then the after-step impact check with the
/// ball's `half_gap_m` (`None`: no ball). Returns the summary and the kernel's final state.
fn run_steps<K, O>(
    kernel: &K,
    init: &K::S,
    t_end_s: f64,
    dt_s: f64,
    bound_m: f64,
    half_gap_m: Option<f64>,
    obs: &mut O,
) -> Result<(RunSummary, K::S), SimError>
where
    K: BarKernel,
    O: Observer + StepHooks<K::S> + ?Sized,
{
    let has_ball = half_gap_m.is_some();
    let lg = half_gap_m.unwrap_or(f64::INFINITY);
    let t0 = init.time();
    let span = t_end_s - t0;
    let n_steps = if span > 0.0 {
        (span / dt_s - 1e-9).ceil().max(1.0) as u64
    } else {
        0
    };
    let mut summary = RunSummary {
        final_state: kernel.public(init),
        max_penetration_m: f64::NEG_INFINITY,
        ..Default::default()
    };
    let mut stages = kernel.stages();
    let mut s = if has_ball { *init } else { init.without_ball() };
    for i in 1..=n_steps {
        let t_next = if i == n_steps {
            t_end_s
        } else {
            t0 + i as f64 * dt_s
        };
        let mut next = kernel.step(&s, t_next - s.time(), &mut stages);
        next.set_time(t_next);
        if !kernel.is_finite(&next) {
            return Err(SimError::NonFinite { t_s: t_next });
        }
        if let Some(u_m) = kernel.beyond(&next, bound_m) {
            return Err(ParamError::Diverged {
                solver: K::SOLVER,
                field: "dt_s (--dt)",
                value: dt_s,
                t_s: t_next,
                u_m,
                bound_m,
            }
            .into());
        }
        obs.segment(&StepSegment {
            kernel,
            a: &s,
            b: &next,
            has_ball,
        });
        obs.on_step(&s, &next);
        if has_ball {
            let (w, dw) = kernel.contact(&next);
            summary.max_penetration_m = summary.max_penetration_m.max(w.abs() - lg);
            if let Some(wall) = wall_hit(w, dw, lg) {
                let (after, energy_loss_j) = kernel.impact(&next, dw);
                obs.event(&Event {
                    t_s: t_next,
                    kind: EventKind::Impact {
                        wall,
                        dw_m_s: dw,
                        energy_loss_j,
                    },
                    before: kernel.public(&next),
                    after: kernel.public(&after),
                });
                obs.on_impact(&next, &after, energy_loss_j);
                summary.impacts += 1;
                summary.events += 1;
                next = after;
            }
        }
        s = next;
    }
    summary.final_state = kernel.public(&s);
    if !has_ball {
        summary.max_penetration_m = f64::NEG_INFINITY;
    }
    Ok((summary, s))
}

/// `∫|ẇ| dt` over `[a, b]` of the cubic Hermite `w` of one step from `t_a` of length `h` with
/// end values and slopes `(w, ẇ)`: split at the roots of its quadratic derivative and sum `|Δw|`
/// over the pieces.
fn hermite_total_variation(
    t_a: f64,
    h: f64,
    (p0, d0): (f64, f64),
    (p1, d1): (f64, f64),
    a_s: f64,
    b_s: f64,
) -> f64 {
    if h <= 0.0 || b_s <= a_s {
        return 0.0;
    }
    let (m0, m1) = (h * d0, h * d1);
    // w(s) = c0 + c1 s + c2 s² + c3 s³, s = (t − t_a)/h.
    let (c0, c1) = (p0, m0);
    let c2 = 3.0 * (p1 - p0) - 2.0 * m0 - m1;
    let c3 = 2.0 * (p0 - p1) + m0 + m1;
    let w = |s: f64| c0 + s * (c1 + s * (c2 + s * c3));
    let (sa, sb) = (
        ((a_s - t_a) / h).clamp(0.0, 1.0),
        ((b_s - t_a) / h).clamp(0.0, 1.0),
    );
    // Roots of w'(s) = c1 + 2c2 s + 3c3 s² inside (sa, sb).
    let (qa, qb, qc) = (3.0 * c3, 2.0 * c2, c1);
    let mut cuts = [sa, sb, sb, sb];
    let mut n = 1;
    let mut push = |s: f64| {
        if s > sa && s < sb {
            cuts[n] = s;
            n += 1;
        }
    };
    if qa.abs() <= 1e-300 {
        if qb.abs() > 1e-300 {
            push(-qc / qb);
        }
    } else {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc > 0.0 {
            // Stable quadratic roots.
            let q = -0.5 * (qb + qb.signum() * disc.sqrt());
            let (r1, r2) = (q / qa, if q != 0.0 { qc / q } else { 0.0 });
            let (lo, hi) = if r1 <= r2 { (r1, r2) } else { (r2, r1) };
            push(lo);
            push(hi);
        }
    }
    cuts[n] = sb;
    cuts[..=n]
        .windows(2)
        .map(|p| (w(p[1]) - w(p[0])).abs())
        .sum()
}

/// The paper's after-step impact check: the wall the ball is at or beyond while still moving
/// into it (`w ≥ l_g` with `ẇ > 0`, or `w ≤ −l_g` with `ẇ < 0`).
fn wall_hit(w_m: f64, dw_m_s: f64, half_gap_m: f64) -> Option<Wall> {
    if w_m >= half_gap_m && dw_m_s > 0.0 {
        Some(Wall::Plus)
    } else if w_m <= -half_gap_m && dw_m_s < 0.0 {
        Some(Wall::Minus)
    } else {
        None
    }
}
