//! The lumped bar's kernel: the paper's one-mode bar `M ü + C u̇ + K u = F(t) − F_ball`,
//! `m_d v̈ = F_ball`, `w = v − u`, with the impact map of Eqs. 4–5. [`super::Rk4`] runs it on a
//! [`BarModel::Lumped`](crate::params::BarModel::Lumped) system; its arithmetic is the paper
//! reproduction's, operation for operation.

use super::{BarKernel, Drive, Hermite};
use crate::damper::impact::{impact_energy_loss_j, impact_map};
use crate::error::SimError;
use crate::params::{Bar, State, System};
use crate::solver::{Observer, RunSummary};

/// The lumped bar's run (the system, the state and the step already checked by [`super::Rk4`]).
pub(super) fn run(
    sys: &System,
    bar: &Bar,
    init: &State,
    t_end_s: f64,
    dt_s: f64,
    obs: &mut dyn Observer,
) -> Result<RunSummary, SimError> {
    let (mu, e) = match &sys.damper {
        Some(d) => (d.ball_mass_kg / bar.mass_kg, d.restitution),
        None => (0.0, 0.0),
    };
    let kernel = Lumped {
        rhs: Rhs::new(sys, bar),
        mu,
        e,
    };
    let bound = divergence_bound_m(sys, bar, init);
    let half_gap = sys.damper.map(|d| d.half_gap_m());
    let (summary, _) = super::run_steps(&kernel, init, t_end_s, dt_s, bound, half_gap, obs)?;
    Ok(summary)
}

/// Constants of the right-hand side, computed once per run.
#[derive(Clone, Copy)]
struct Rhs {
    m: f64,
    c: f64,
    k: f64,
    drive: Drive,
}

impl Rhs {
    fn new(sys: &System, bar: &Bar) -> Rhs {
        Rhs {
            m: bar.mass_kg,
            c: bar.damping_n_s_per_m(),
            k: bar.stiffness_n_per_m,
            drive: Drive::new(
                &sys.forcing,
                sys.omega_rad_s(),
                sys.damper.as_ref(),
                sys.friction_level_n(),
            ),
        }
    }

    fn force(&self, t: f64) -> f64 {
        self.drive.force(t)
    }

    /// `(ü, v̈)` given the external force at this stage.
    fn acc(&self, f_ext: f64, u: f64, du: f64, dv: f64) -> (f64, f64) {
        let fb = self.drive.friction_on_ball(dv - du);
        (
            (f_ext - self.c * du - self.k * u - fb) / self.m,
            self.drive.ball_acc(fb),
        )
    }

    /// One classical RK4 step of size `h` from `s` (inlined into the step loop: the hot path).
    #[inline(always)]
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

/// The lumped bar as a [`BarKernel`]: its right-hand side and the impact map's constants
/// (`μ = m_d/M`, `e`).
struct Lumped {
    rhs: Rhs,
    mu: f64,
    e: f64,
}

impl BarKernel for Lumped {
    type S = State;
    type Stages = ();
    const SOLVER: &'static str = "rk4";

    fn drive(&self) -> &Drive {
        &self.rhs.drive
    }
    fn stages(&self) {}
    #[inline(always)]
    fn step(&self, s: &State, h: f64, _: &mut ()) -> State {
        self.rhs.step(s, h)
    }
    fn is_finite(&self, s: &State) -> bool {
        s.u_m.is_finite() && s.du_m_s.is_finite() && s.v_m.is_finite() && s.dv_m_s.is_finite()
    }
    fn beyond(&self, s: &State, bound: f64) -> Option<f64> {
        (s.u_m.abs() > bound).then_some(s.u_m)
    }
    fn contact(&self, s: &State) -> (f64, f64) {
        (s.w_m(), s.dw_m_s())
    }
    fn impact(&self, s: &State, dw: f64) -> (State, f64) {
        let (du, dv) = impact_map(self.mu, self.e, s.du_m_s, s.dv_m_s);
        let after = State {
            du_m_s: du,
            dv_m_s: dv,
            ..*s
        };
        let r = &self.rhs;
        (after, impact_energy_loss_j(r.m, r.drive.md, self.e, dw))
    }
    fn interpolate(&self, a: &State, b: &State, w: &Hermite) -> State {
        let r = &self.rhs;
        let (aa, ab) = r.acc(r.force(a.t_s), a.u_m, a.du_m_s, a.dv_m_s);
        let (ba, bb) = r.acc(r.force(b.t_s), b.u_m, b.du_m_s, b.dv_m_s);
        State {
            t_s: w.t,
            u_m: w.pos(a.u_m, a.du_m_s, b.u_m, b.du_m_s),
            du_m_s: w.pos(a.du_m_s, aa, b.du_m_s, ba),
            v_m: w.pos(a.v_m, a.dv_m_s, b.v_m, b.dv_m_s),
            dv_m_s: w.pos(a.dv_m_s, ab, b.dv_m_s, bb),
            cavity: None,
        }
    }
    fn public(&self, s: &State) -> State {
        *s
    }
    fn response(&self, s: &State) -> f64 {
        s.u_m
    }
    fn force_point_velocity(&self, s: &State) -> f64 {
        s.du_m_s
    }
    fn viscous_power(&self, s: &State) -> f64 {
        self.rhs.c * s.du_m_s * s.du_m_s
    }
    fn energy(&self, s: &State, has_ball: bool) -> f64 {
        let r = &self.rhs;
        let ball = if has_ball { Some(r.drive.md) } else { None };
        crate::model::lumped_mechanical_energy_j(r.m, r.k, ball, s)
    }
}

/// `|u|` beyond which an `rk4` run has diverged: [`crate::limits::RK4_DIVERGENCE_FACTOR`] times the system's
/// own displacement scale (static deflection under every force, initial displacement and
/// velocities over `ω_n`, half gap) with the lumped `bar` (a modal bar's bound is
/// [`super::modal::divergence_bound_m`]).
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
