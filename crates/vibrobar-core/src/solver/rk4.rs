//! The paper's scheme, exactly: classical RK4 with a fixed step; after each step, if
//! `w ≥ l_g` with `ẇ > 0` or `w ≤ −l_g` with `ẇ < 0`, the impact map (Eqs. 4–5) is applied.
//!
//! Nothing is done about the penetration this leaves (the ball may sit slightly beyond the wall):
//! that is the scheme as published, and [`RunSummary::max_penetration_m`] reports it.
//! With `coulomb` friction, sticking is not modelled as a mode: `sgn(ẇ)` chatters about `ẇ = 0`,
//! as any fixed-step scheme with a discontinuous right-hand side does.

use super::{
    Event, EventKind, Mode, Observer, RunSummary, Segment, SegmentIntegrals, Solver, Wall,
};
use crate::damper::friction::{sign_factor, sliding_friction_on_ball_n};
use crate::damper::impact::{impact_energy_loss_j, impact_map};
use crate::error::SimError;
use crate::params::{Bar, BarModel, FrictionModel, State, System};
use crate::structure::{ModalState, ModalSystem};

/// Fixed-step classical Runge–Kutta 4 with the paper's after-step impact check.
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

/// Constants of the right-hand side, computed once per run.
#[derive(Clone, Copy)]
struct Rhs {
    m: f64,
    c: f64,
    k: f64,
    f0: f64,
    fs: f64,
    omega: f64,
    md: f64,
    friction: FrictionModel,
    level: f64,
}

impl Rhs {
    fn new(sys: &System, bar: &Bar) -> Rhs {
        let (md, friction) = match &sys.damper {
            Some(d) => (d.ball_mass_kg, d.friction),
            None => (1.0, FrictionModel::None),
        };
        Rhs {
            m: bar.mass_kg,
            c: bar.damping_n_s_per_m(),
            k: bar.stiffness_n_per_m,
            f0: sys.forcing.amplitude_n,
            fs: sys.forcing.static_force_n,
            omega: sys.omega_rad_s(),
            md,
            friction,
            level: sys.friction_level_n(),
        }
    }

    fn force(&self, t: f64) -> f64 {
        self.fs + self.f0 * (self.omega * t).sin()
    }

    fn friction_on_ball(&self, du: f64, dv: f64) -> f64 {
        sliding_friction_on_ball_n(self.friction, self.level, dv - du)
    }

    /// `(ü, v̈)` given the external force at this stage.
    fn acc(&self, f_ext: f64, u: f64, du: f64, dv: f64) -> (f64, f64) {
        let fb = self.friction_on_ball(du, dv);
        (
            (f_ext - self.c * du - self.k * u - fb) / self.m,
            fb / self.md,
        )
    }

    /// One classical RK4 step of size `h` from `s`.
    fn step(&self, s: &State, h: f64) -> State {
        let t = s.t_s;
        let f_a = self.force(t);
        let f_m = self.force(t + 0.5 * h);
        let f_b = self.force(t + h);
        let (u, du, v, dv) = (s.u_m, s.du_m_s, s.v_m, s.dv_m_s);

        let (a1, b1) = self.acc(f_a, u, du, dv);
        let (u2, du2, _v2, dv2) = (
            u + 0.5 * h * du,
            du + 0.5 * h * a1,
            v + 0.5 * h * dv,
            dv + 0.5 * h * b1,
        );
        let (a2, b2) = self.acc(f_m, u2, du2, dv2);
        let (u3, du3, _v3, dv3) = (
            u + 0.5 * h * du2,
            du + 0.5 * h * a2,
            v + 0.5 * h * dv2,
            dv + 0.5 * h * b2,
        );
        let (a3, b3) = self.acc(f_m, u3, du3, dv3);
        let (u4, du4, _v4, dv4) = (u + h * du3, du + h * a3, v + h * dv3, dv + h * b3);
        let (a4, b4) = self.acc(f_b, u4, du4, dv4);

        State {
            t_s: t + h,
            u_m: u + h / 6.0 * (du + 2.0 * du2 + 2.0 * du3 + du4),
            du_m_s: du + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
            v_m: v + h / 6.0 * (dv + 2.0 * dv2 + 2.0 * dv3 + dv4),
            dv_m_s: dv + h / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4),
            cavity: None,
        }
    }
}

/// One step seen as a segment: cubic Hermite interpolation between the end states.
struct StepSegment<'a> {
    rhs: &'a Rhs,
    a: State,
    b: State,
    has_ball: bool,
}

impl StepSegment<'_> {
    fn hermite(&self, t: f64) -> State {
        let h = self.b.t_s - self.a.t_s;
        if t <= self.a.t_s || h <= 0.0 {
            return State { t_s: t, ..self.a };
        }
        if t >= self.b.t_s {
            return State { t_s: t, ..self.b };
        }
        let (aa, ab) = self.rhs.acc(
            self.rhs.force(self.a.t_s),
            self.a.u_m,
            self.a.du_m_s,
            self.a.dv_m_s,
        );
        let (ba, bb) = self.rhs.acc(
            self.rhs.force(self.b.t_s),
            self.b.u_m,
            self.b.du_m_s,
            self.b.dv_m_s,
        );
        let s = (t - self.a.t_s) / h;
        let (h00, h10, h01, h11) = (
            (1.0 + 2.0 * s) * (1.0 - s) * (1.0 - s),
            s * (1.0 - s) * (1.0 - s),
            s * s * (3.0 - 2.0 * s),
            s * s * (s - 1.0),
        );
        // Cubic Hermite for positions (slopes: velocities) and velocities (slopes: accelerations).
        let pos =
            |p0: f64, v0: f64, p1: f64, v1: f64| h00 * p0 + h10 * h * v0 + h01 * p1 + h11 * h * v1;
        State {
            t_s: t,
            u_m: pos(self.a.u_m, self.a.du_m_s, self.b.u_m, self.b.du_m_s),
            du_m_s: pos(self.a.du_m_s, aa, self.b.du_m_s, ba),
            v_m: pos(self.a.v_m, self.a.dv_m_s, self.b.v_m, self.b.dv_m_s),
            dv_m_s: pos(self.a.dv_m_s, ab, self.b.dv_m_s, bb),
            cavity: None,
        }
    }
}

impl StepSegment<'_> {
    /// `∫|ẇ| dt` over `[a, b]` of the Hermite cubic of `w = v − u` (slopes `ẇ` at the step ends).
    fn w_total_variation(&self, a_s: f64, b_s: f64) -> f64 {
        hermite_total_variation(
            self.a.t_s,
            self.b.t_s - self.a.t_s,
            (self.a.w_m(), self.a.dw_m_s()),
            (self.b.w_m(), self.b.dw_m_s()),
            a_s,
            b_s,
        )
    }
}

/// `∫|ẇ| dt` over `[a, b]` of the cubic Hermite `w` of one step from `t_a` of length `h` with
/// end values and slopes `(w, ẇ)`: split at the roots of its quadratic derivative and sum `|Δw|`
/// over the pieces. Shared by [`Rk4`] and [`super::modal_rk4::ModalRk4`].
pub(crate) fn hermite_total_variation(
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
pub(crate) fn wall_hit(w_m: f64, dw_m_s: f64, half_gap_m: f64) -> Option<Wall> {
    if w_m >= half_gap_m && dw_m_s > 0.0 {
        Some(Wall::Plus)
    } else if w_m <= -half_gap_m && dw_m_s < 0.0 {
        Some(Wall::Minus)
    } else {
        None
    }
}

impl Segment for StepSegment<'_> {
    fn t_start_s(&self) -> f64 {
        self.a.t_s
    }
    fn t_end_s(&self) -> f64 {
        self.b.t_s
    }
    fn mode(&self) -> Mode {
        if self.has_ball {
            Mode::Free
        } else {
            Mode::NoBall
        }
    }
    fn state_at(&self, t_s: f64) -> State {
        self.hermite(t_s)
    }
    fn mechanical_energy_j(&self, t_s: f64) -> f64 {
        let r = self.rhs;
        let ball = if self.has_ball { Some(r.md) } else { None };
        crate::model::lumped_mechanical_energy_j(r.m, r.k, ball, &self.hermite(t_s))
    }
    fn integral_u2(&self, a_s: f64, b_s: f64) -> f64 {
        // Trapezoid over one step: matches the paper's RMS of the sampled history to O(dt²).
        let (sa, sb) = if a_s <= self.a.t_s && b_s >= self.b.t_s {
            (self.a, self.b)
        } else {
            (self.hermite(a_s), self.hermite(b_s))
        };
        0.5 * (b_s - a_s) * (sa.u_m * sa.u_m + sb.u_m * sb.u_m)
    }
    fn integrals(&self, a_s: f64, b_s: f64) -> SegmentIntegrals {
        let (sa, sb) = (self.hermite(a_s), self.hermite(b_s));
        let h = b_s - a_s;
        let trap = |f: &dyn Fn(&State) -> f64| 0.5 * h * (f(&sa) + f(&sb));
        let r = self.rhs;
        // `F_ball ẇ = ±F|ẇ|`, so the friction work is ±F times the total variation of `w`: this
        // keeps its sign on steps where ẇ reverses (the start-of-step force times Δw did not).
        let sign = sign_factor(r.friction);
        SegmentIntegrals {
            u2_m2_s: trap(&|s| s.u_m * s.u_m),
            forcing_work_j: trap(&|s| r.force(s.t_s) * s.du_m_s),
            viscous_loss_j: trap(&|s| r.c * s.du_m_s * s.du_m_s),
            friction_work_j: if sign == 0.0 || r.level == 0.0 {
                0.0
            } else {
                sign * r.level * self.w_total_variation(a_s, b_s)
            },
        }
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
        let bar = match &sys.bar {
            BarModel::Lumped(bar) => bar,
            // The same scheme mode by mode: the modal RK4 (its own step check: ω_N·dt).
            BarModel::Modal(model) => {
                let msys = ModalSystem::from_system(sys)?;
                let minit = ModalState::from_public(model, init)?;
                return Ok(super::modal_rk4::ModalRk4 { dt_s: self.dt_s }
                    .run(&msys, &minit, t_end_s, obs)?
                    .summary);
            }
        };
        let u_bound = divergence_bound_m(sys, bar, init);
        let rhs = Rhs::new(sys, bar);
        let has_ball = sys.damper.is_some();
        let (lg, mu, e) = match &sys.damper {
            Some(d) => (d.half_gap_m(), d.ball_mass_kg / bar.mass_kg, d.restitution),
            None => (f64::INFINITY, 0.0, 0.0),
        };
        let t0 = init.t_s;
        let span = t_end_s - t0;
        // Steps on the grid t0 + i·dt (no accumulated drift); a last partial step closes the run.
        let n_steps = if span > 0.0 {
            (span / self.dt_s - 1e-9).ceil().max(1.0) as u64
        } else {
            0
        };
        let mut summary = RunSummary {
            final_state: *init,
            max_penetration_m: f64::NEG_INFINITY,
            ..Default::default()
        };
        let mut s = *init;
        if !has_ball {
            s.v_m = 0.0;
            s.dv_m_s = 0.0;
        }
        for i in 1..=n_steps {
            let t_next = if i == n_steps {
                t_end_s
            } else {
                t0 + i as f64 * self.dt_s
            };
            let mut next = rhs.step(&s, t_next - s.t_s);
            next.t_s = t_next;
            if !(next.u_m.is_finite()
                && next.du_m_s.is_finite()
                && next.v_m.is_finite()
                && next.dv_m_s.is_finite())
            {
                return Err(SimError::NonFinite { t_s: t_next });
            }
            if next.u_m.abs() > u_bound {
                return Err(crate::error::ParamError::Diverged {
                    solver: "rk4",
                    field: "dt_s (--dt)",
                    value: self.dt_s,
                    t_s: t_next,
                    u_m: next.u_m,
                    bound_m: u_bound,
                }
                .into());
            }
            obs.segment(&StepSegment {
                rhs: &rhs,
                a: s,
                b: next,
                has_ball,
            });
            if has_ball {
                let w = next.w_m();
                let dw = next.dw_m_s();
                summary.max_penetration_m = summary.max_penetration_m.max(w.abs() - lg);
                if let Some(wall) = wall_hit(w, dw, lg) {
                    let (du, dv) = impact_map(mu, e, next.du_m_s, next.dv_m_s);
                    let after = State {
                        du_m_s: du,
                        dv_m_s: dv,
                        ..next
                    };
                    let d = sys.damper.as_ref().expect("has_ball");
                    obs.event(&Event {
                        t_s: t_next,
                        kind: EventKind::Impact {
                            wall,
                            dw_m_s: dw,
                            energy_loss_j: impact_energy_loss_j(bar.mass_kg, d.ball_mass_kg, e, dw),
                        },
                        before: next,
                        after,
                    });
                    summary.impacts += 1;
                    summary.events += 1;
                    next = after;
                }
            }
            s = next;
        }
        summary.final_state = s;
        if !has_ball {
            summary.max_penetration_m = f64::NEG_INFINITY;
        }
        Ok(summary)
    }
}

/// `|u|` beyond which an `rk4` run has diverged: [`crate::limits::RK4_DIVERGENCE_FACTOR`] times the system's
/// own displacement scale (static deflection under every force, initial displacement and
/// velocities over `ω_n`, half gap) with the lumped `bar` (a modal bar's bound is
/// [`super::modal_rk4::divergence_bound_m`]).
pub fn divergence_bound_m(sys: &System, bar: &Bar, init: &State) -> f64 {
    let forces =
        sys.forcing.static_force_n.abs() + sys.forcing.amplitude_n.abs() + sys.friction_level_n();
    let scale = forces / bar.stiffness_n_per_m
        + init.u_m.abs()
        + (init.du_m_s.abs() + init.dw_m_s().abs()) / bar.natural_freq_rad_s()
        + sys.damper.map_or(0.0, |d| d.half_gap_m());
    crate::limits::RK4_DIVERGENCE_FACTOR * scale
}

#[cfg(test)]
mod divergence_tests {
    use super::*;
    use crate::params::{State, System};

    /// The backstop must never fire on physics: an undamped bar forced at resonance grows by
    /// `F0/(2K)·ω_n t`, at most `F0/(2K)·crate::limits::MAX_PHASE_RAD` within the phase limit.
    #[test]
    fn rk4_divergence_bound_is_far_above_resonant_growth() {
        let mut sys = System::paper_solid(1.0);
        let mut bar = *sys.lumped_bar().unwrap();
        bar.damping_ratio = 0.0;
        sys.bar = bar.into();
        let growth =
            sys.forcing.amplitude_n / (2.0 * bar.stiffness_n_per_m) * crate::limits::MAX_PHASE_RAD;
        let bound = divergence_bound_m(&sys, &bar, &State::REST);
        assert!(bound > 100.0 * growth, "bound {bound} vs growth {growth}");
        // Every term counts: a free bar launched at 1 m/s has a bound of 1e12 · 1/ω_n.
        let mut sys = System::paper_solid(1.0);
        sys.forcing.amplitude_n = 0.0;
        let init = State {
            du_m_s: 1.0,
            dv_m_s: 1.0,
            ..State::REST
        };
        let bar = *sys.lumped_bar().unwrap();
        let wn = bar.natural_freq_rad_s();
        let b = divergence_bound_m(&sys, &bar, &init);
        assert!(
            (b / (crate::limits::RK4_DIVERGENCE_FACTOR / wn) - 1.0).abs() < 1e-12,
            "{b}"
        );
    }
}
