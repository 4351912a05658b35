//! The lumped bar's side of the compliant (`hertz`) contact phase ([`super::hertz_phase`],
//! written once for every bar): with penetration `δ = s·w − l_g ≥ 0`,
//!
//! `M ü = F(t) − C u̇ − K u + s P − F_ball`,  `m_d v̈ = −s P + F_ball`,
//!
//! on the phase state `[u, u̇, δ, δ̇, W_c]`; while the ball is stuck (coulomb) the pair moves as
//! one body of mass `M + m_d`. Stick inside a contact is rare: the Hertz force at `ẇ = 0` (peak
//! compression) exceeds the friction level except below a penetration of `(f/K_h)^{2/3}`
//! (~1e-8 m for the paper's ball). Each accepted step is a segment ([`HertzSegment`]) whose
//! integrals come from Gauss–Legendre quadrature of the dense output. Work is bounded by
//! [`MAX_CONTACT_STEPS`](super::hertz_phase::MAX_CONTACT_STEPS).

use super::driver::wall_of;
use super::hertz_phase::{CompliantBar, PhaseBook, PhaseStep};
use super::{Book, Consts, St};
use crate::analysis::contact_test::CONTACT_RTOL;
use crate::damper::contact::Hertz;
use crate::error::SimError;
use crate::solver::dopri5::{DenseStep, Dopri5};
use crate::solver::exact::hertz_cut::{CutBar, CutContactSegment, CutPhaseBook};
use crate::solver::{CompliantContact, EventKind, Mode, Segment, SegmentIntegrals};

/// Below this approach speed (as a fraction of `l_g·ω`) the damping's reference speed `δ̇₀` is
/// held at the floor: a ball arriving at (nearly) zero speed and pressed on the wall would
/// otherwise get an unbounded damping coefficient `D/δ̇₀`. Such a contact is a resting one
/// (heavily damped), its restitution is not the target's.
pub const APPROACH_FLOOR_REL: f64 = 1e-3;

type Y = [f64; 5];

/// One accepted step of a contact phase, as a segment.
#[derive(Debug, Clone, Copy)]
pub struct HertzSegment {
    base: ContactStep,
    /// `sw·ẇ` at the touch and the law's reference speed `δ̇₀ = max(approach, floor)`.
    approach: f64,
    v0: f64,
    stuck: bool,
}

/// A lumped contact segment: one
/// accepted step (the fraction `th_end` of it inside the phase) at the wall `sw`, the
/// constants their integrals read, and the state and energy on it.
#[derive(Debug, Clone, Copy)]
pub(in crate::solver::exact) struct ContactStep {
    pub(in crate::solver::exact) step: DenseStep<5>,
    /// Fraction of the step inside the phase.
    pub(in crate::solver::exact) th_end: f64,
    pub(in crate::solver::exact) sw: f64,
    pub(in crate::solver::exact) lg: f64,
    pub(in crate::solver::exact) m: f64,
    /// The bar's own stiffness `K`.
    pub(in crate::solver::exact) k: f64,
    pub(in crate::solver::exact) md: f64,
    pub(in crate::solver::exact) c: f64,
    pub(in crate::solver::exact) fs: f64,
    pub(in crate::solver::exact) f0: f64,
    pub(in crate::solver::exact) om: f64,
    pub(in crate::solver::exact) fb: f64,
    pub(in crate::solver::exact) law: Hertz,
}

impl ContactStep {
    /// The step `step` (the fraction `th_end` inside the phase) at the wall `sw` of a bar with
    /// `cs`'s constants and spring `k`, the ball's friction `fb`.
    pub(super) fn new(
        cs: &Consts,
        step: DenseStep<5>,
        th_end: f64,
        sw: f64,
        k: f64,
        fb: f64,
        law: Hertz,
    ) -> ContactStep {
        ContactStep {
            step,
            th_end,
            sw,
            lg: cs.lg,
            m: cs.m,
            k,
            md: cs.md,
            c: cs.c,
            fs: cs.fs,
            f0: cs.f0,
            om: cs.om,
            fb,
            law,
        }
    }
    pub(in crate::solver::exact) fn y_at(&self, t: f64) -> Y {
        let th = ((t - self.step.t0) / self.step.h).clamp(0.0, self.th_end);
        self.step.at_theta(th)
    }
    pub(in crate::solver::exact) fn t_end_s(&self) -> f64 {
        self.step.t0 + self.th_end * self.step.h
    }
    pub(in crate::solver::exact) fn mode(&self) -> Mode {
        Mode::Contact(wall_of(self.sw))
    }
    /// The public state (`w = sw·(l_g + δ)`).
    pub(in crate::solver::exact) fn state_at(&self, t_s: f64) -> crate::params::State {
        let y = self.y_at(t_s);
        let w = self.sw * (self.lg + y[2]);
        let dw = self.sw * y[3];
        crate::params::State {
            t_s,
            u_m: y[0],
            du_m_s: y[1],
            v_m: y[0] + w,
            dv_m_s: y[1] + dw,
            cavity: None,
        }
    }
    /// Bar, ball and the contact's elastic energy.
    pub(in crate::solver::exact) fn mechanical_energy_j(&self, t_s: f64) -> f64 {
        let s = self.state_at(t_s);
        let y = self.y_at(t_s);
        crate::model::lumped_mechanical_energy_j(self.m, self.k, Some(self.md), &s)
            + self.law.elastic_energy_j(y[2])
    }
}

/// 5-point Gauss–Legendre nodes and weights on [−1, 1].
pub(crate) const GL_X: [f64; 5] = [
    -0.906_179_845_938_664,
    -0.538_469_310_105_683,
    0.0,
    0.538_469_310_105_683,
    0.906_179_845_938_664,
];
pub(crate) const GL_W: [f64; 5] = [
    0.236_926_885_056_189,
    0.478_628_670_499_366,
    0.568_888_888_888_889,
    0.478_628_670_499_366,
    0.236_926_885_056_189,
];

impl Segment for HertzSegment {
    fn t_start_s(&self) -> f64 {
        self.base.step.t0
    }
    fn t_end_s(&self) -> f64 {
        self.base.t_end_s()
    }
    fn mode(&self) -> Mode {
        self.base.mode()
    }
    fn state_at(&self, t_s: f64) -> crate::params::State {
        self.base.state_at(t_s)
    }
    fn integral_u2(&self, a_s: f64, b_s: f64) -> f64 {
        // The `u2_m2_s` of `integrals`, term for term (the RMS hot path: no forcing `sin`).
        let (mid, half) = (0.5 * (a_s + b_s), 0.5 * (b_s - a_s));
        let mut u2 = 0.0;
        for (x, wgt) in GL_X.iter().zip(GL_W) {
            let u = self.base.y_at(mid + half * x)[0];
            u2 += wgt * half * u * u;
        }
        u2
    }
    fn integrals(&self, a_s: f64, b_s: f64) -> SegmentIntegrals {
        let (mid, half) = (0.5 * (a_s + b_s), 0.5 * (b_s - a_s));
        let mut out = SegmentIntegrals::default();
        for (x, wgt) in GL_X.iter().zip(GL_W) {
            let t = mid + half * x;
            let y = self.base.y_at(t);
            let f = self.base.fs + self.base.f0 * (self.base.om * t).sin();
            out.u2_m2_s += wgt * half * y[0] * y[0];
            out.forcing_work_j += wgt * half * f * y[1];
            out.viscous_loss_j += wgt * half * self.base.c * y[1] * y[1];
        }
        if self.base.fb != 0.0 {
            out.friction_work_j =
                self.base.fb * self.base.sw * (self.base.y_at(b_s)[2] - self.base.y_at(a_s)[2]);
        }
        out
    }
    fn mechanical_energy_j(&self, t_s: f64) -> f64 {
        self.base.mechanical_energy_j(t_s)
    }
    fn compliant_contact(&self) -> Option<CompliantContact> {
        Some(CompliantContact {
            wall_sign: self.base.sw,
            approach_m_s: self.approach,
            reference_speed_m_s: self.v0,
            ball_friction_n: self.base.fb,
            stuck: self.stuck,
            law: self.base.law,
        })
    }
}

impl CompliantBar<5> for Consts {
    fn slots(&self) -> (usize, usize, usize) {
        (2, 3, 4)
    }
    fn omegas(&self) -> (f64, f64) {
        (self.om, self.om.max(self.osc[0].wd))
    }
    fn contact_mass_kg(&self) -> f64 {
        self.m * self.md / (self.m + self.md)
    }
    fn integrator(&self, d_scale: f64, v_scale: f64) -> Dopri5<5> {
        let meff = self.contact_mass_kg();
        Dopri5::<5>::new(
            CONTACT_RTOL,
            [
                CONTACT_RTOL * self.lg,
                CONTACT_RTOL * v_scale,
                CONTACT_RTOL * d_scale,
                CONTACT_RTOL * v_scale,
                CONTACT_RTOL * 0.5 * meff * v_scale * v_scale,
            ],
        )
    }
    fn phase_state(&self, s: &St, approach: f64) -> Y {
        [s.u, s.du, 0.0, approach, 0.0]
    }
    fn force_at(&self, t: f64) -> f64 {
        self.fs + self.f0 * (self.om * t).sin()
    }
    fn rhs(&self, law: &Hertz, v0: f64, sw: f64, stuck: bool, fb: f64, force: f64, y: &Y) -> Y {
        // The bar's own stiffness: a cut's force comes in `force`.
        let k = self.k_spring;
        if stuck {
            let ddu = (force - self.c * y[1] - k * y[0]) / (self.m + self.md);
            return [y[1], ddu, 0.0, 0.0, 0.0];
        }
        let (p, pd) = law.forces_n(y[2], y[3], v0);
        let ddu = (force - self.c * y[1] - k * y[0] + sw * p - fb) / self.m;
        let ddv = (-sw * p + fb) / self.md;
        // δ̈ = sw·(v̈ − ü).
        [y[1], ddu, y[3], sw * (ddv - ddu), pd * y[3]]
    }
    fn needed(&self, law: &Hertz, sw: f64, force: f64, y: &Y) -> f64 {
        let ddu = (force - self.c * y[1] - self.k_spring * y[0]) / (self.m + self.md);
        self.md * ddu + sw * law.elastic_force_n(y[2])
    }
    fn state_of(&self, sw: f64, t: f64, y: &Y) -> St {
        St {
            t,
            u: y[0],
            du: y[1],
            w: sw * (self.lg + y[2]),
            dw: sw * y[3],
            force: self.force_at(t),
        }
    }
}

impl PhaseBook<Consts, 5> for Book<'_> {
    fn step(&mut self, cs: &Consts, step: &DenseStep<5>, th_end: f64, p: &PhaseStep) {
        let seg = HertzSegment {
            base: ContactStep::new(cs, *step, th_end, p.sw, cs.k, p.fb, p.law),
            approach: p.approach,
            v0: p.v0,
            stuck: p.stuck,
        };
        if seg.t_end_s() > seg.t_start_s() {
            self.obs.segment(&seg);
        }
    }
    fn penetration(&mut self, pen_m: f64) {
        if pen_m > self.tally.summary.max_penetration_m {
            self.tally.summary.max_penetration_m = pen_m;
        }
    }
    fn event(&mut self, cs: &Consts, kind: EventKind, at: &St) -> Result<(), SimError> {
        Book::event(self, cs, at.t, kind, at, at)
    }
}

impl CutBar<5> for Consts {
    fn u_tool(&self, y: &Y) -> f64 {
        y[0]
    }
    fn du_tool(&self, y: &Y) -> f64 {
        y[1]
    }
    fn u_response(&self, y: &Y) -> f64 {
        y[0]
    }
    fn viscous(&self, y: &Y) -> f64 {
        y[1] * y[1]
    }
    fn viscous_scale(&self) -> f64 {
        self.c
    }
    fn cut_state(&self, sw: f64, t: f64, y: &Y, force: f64) -> St {
        St {
            force,
            ..self.state_of(sw, t, y)
        }
    }
    fn public(&self, s: &St) -> crate::params::State {
        s.public()
    }
    fn energy_j(&self, s: &St) -> f64 {
        crate::model::lumped_mechanical_energy_j(self.m, self.k_spring, Some(self.md), &s.public())
    }
}

impl CutPhaseBook<Consts, 5> for Book<'_> {
    fn segment(&mut self, seg: &CutContactSegment<'_, Consts, 5>) {
        self.obs.segment(seg);
    }
    fn penetration(&mut self, pen_m: f64) {
        PhaseBook::penetration(self, pen_m);
    }
}
