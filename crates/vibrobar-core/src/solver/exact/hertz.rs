//! The compliant (`hertz`) contact phase of the lumped exact solver.
//!
//! When free flight reaches a wall (`w = s·l_g`, found by the closed-form no-missed-root search),
//! the ball and bar are coupled by the contact force `P` of [`crate::damper::contact`] along the
//! contact row: with penetration `δ = s·w − l_g ≥ 0`,
//!
//! `M ü = F(t) − C u̇ − K u + s P − F_ball`,  `m_d v̈ = −s P + F_ball`,
//!
//! `F_ball` the sliding friction of [`crate::damper::friction`] with `σ = sgn ẇ`: friction keeps
//! acting during the contact, its sign switching where `ẇ` crosses 0 (located on the dense
//! output, the phase restarts there). Stick inside a contact is not modelled: the Hertz force at
//! `ẇ = 0` (peak compression) exceeds the friction level except below a penetration of
//! `(f/K_h)^{2/3}` (~1e-8 m for the paper's ball), where the ball slides on reversed.
//!
//! The state `[u, u̇, δ, δ̇, W_c]` (`W_c = ∫ P_damp δ̇ dt`, the contact's dissipation) is
//! integrated by [`Dopri5`] with relative tolerance [`CONTACT_RTOL`]; the phase ends where `δ`
//! falls below 0 on the dense output (force and penetration vanish together, see
//! [`crate::damper::contact`]). Each accepted step is a segment (`Mode::Contact`) whose
//! integrals come from Gauss–Legendre quadrature of the dense output and whose mechanical energy
//! includes the elastic energy `(2/5) K_h δ^{5/2}`. The end of the contact is reported as an
//! [`EventKind::Impact`] with the approach speed and `W_c` as its energy loss, so impact counts
//! and the energy books keep their meaning. Work is bounded by
//! [`MAX_CONTACT_STEPS`](super::hertz_phase::MAX_CONTACT_STEPS).

use super::driver::{after_wall_free, wall_of, wall_touch, Cavity, Md};
use super::hertz_phase::{count_steps, run_phase, Event};
use super::{Book, Consts, St};
use crate::analysis::contact_test::CONTACT_RTOL;
use crate::damper::contact::Hertz;
use crate::damper::friction::can_stick;
use crate::error::SimError;
use crate::solver::dopri5::{DenseStep, Dopri5};
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

/// What the lumped contact segments share, with and without the cut (`cutting_hertz`): one
/// accepted step (the fraction `th_end` of it inside the phase) at the wall `sw`, the
/// constants their integrals read, and the state and energy on it.
#[derive(Debug, Clone, Copy)]
pub(super) struct ContactStep {
    pub(super) step: DenseStep<5>,
    /// Fraction of the step inside the phase.
    pub(super) th_end: f64,
    pub(super) sw: f64,
    pub(super) lg: f64,
    pub(super) m: f64,
    /// The bar's own stiffness `K`.
    pub(super) k: f64,
    pub(super) md: f64,
    pub(super) c: f64,
    pub(super) fs: f64,
    pub(super) f0: f64,
    pub(super) om: f64,
    pub(super) fb: f64,
    pub(super) law: Hertz,
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
    pub(super) fn y_at(&self, t: f64) -> Y {
        let th = ((t - self.step.t0) / self.step.h).clamp(0.0, self.th_end);
        self.step.at_theta(th)
    }
    pub(super) fn t_end_s(&self) -> f64 {
        self.step.t0 + self.th_end * self.step.h
    }
    pub(super) fn mode(&self) -> Mode {
        Mode::Contact(wall_of(self.sw))
    }
    /// The public state (`w = sw·(l_g + δ)`).
    pub(super) fn state_at(&self, t_s: f64) -> crate::params::State {
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
    pub(super) fn mechanical_energy_j(&self, t_s: f64) -> f64 {
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

/// The contact phase at wall `sw`, from the state `s` at the touch (`s.w = sw·l_g`, `s.dw` the
/// approach velocity, `sw·s.dw ≥ 0`). On return `s` is the state at the release (`w = sw·l_g`,
/// `ẇ` leaving) or at `t_end_s`; the next mode, or `None` at the end of the run.
pub(super) fn contact(
    cs: &Consts,
    law: &Hertz,
    sw: f64,
    s: &mut St,
    t_end_s: f64,
    book: &mut Book,
) -> Result<Option<Md>, SimError> {
    let t0 = s.t;
    let approach = (sw * s.dw).max(0.0);
    let floor = APPROACH_FLOOR_REL * cs.lg * cs.om.max(cs.osc[0].wd);
    let v0 = approach.max(floor);
    // Scales of the tolerances: the impact's own penetration and speed, the bar's motion.
    let meff = cs.m * cs.md / (cs.m + cs.md);
    let d_scale = law.with_damping(0.0).max_penetration_m(meff, v0);
    let v_scale = v0.max(cs.lg * cs.om);
    let ig = Dopri5::<5>::new(
        CONTACT_RTOL,
        [
            CONTACT_RTOL * cs.lg,
            CONTACT_RTOL * v_scale,
            CONTACT_RTOL * d_scale,
            CONTACT_RTOL * v_scale,
            CONTACT_RTOL * 0.5 * meff * v_scale * v_scale,
        ],
    );
    let mut y: Y = [s.u, s.du, 0.0, approach, 0.0];
    let mut t = t0;
    let mut h = law.undamped_contact_time_s(meff, v0) / 50.0;
    let mut steps = 0u64;
    let mut max_pen = 0.0_f64;
    // Friction: sliding with σ = sgn ẇ = sw·sgn δ̇ (at the touch δ̇ ≥ 0, pressed in: σ = sw), or
    // stuck (coulomb, at ẇ = 0 while the friction needed stays within f).
    let mut sigma = if cs.frictional() { sw } else { 0.0 };
    let mut stuck = false;
    let mtot = cs.m + cs.md;
    let force_at = |t: f64| cs.fs + cs.f0 * (cs.om * t).sin();
    // Friction the ball needs to move with the bar: F_ball = m_d ü_pair + sw·P(δ, 0).
    let needed = |t: f64, y: &Y| {
        let ddu = (force_at(t) - cs.c * y[1] - cs.k * y[0]) / mtot;
        cs.md * ddu + sw * law.elastic_force_n(y[2])
    };
    loop {
        let fb = if stuck { 0.0 } else { cs.fb(sigma) };
        // The last `(t, F(t))`: the 6th and 7th stages of a step are both at `t + h`.
        let mut last = (f64::NAN, 0.0);
        let mut f = |t: f64, y: &Y| {
            let force = if t.to_bits() == last.0.to_bits() {
                last.1
            } else {
                let v = force_at(t);
                last = (t, v);
                v
            };
            if stuck {
                let ddu = (force - cs.c * y[1] - cs.k * y[0]) / mtot;
                return [y[1], ddu, 0.0, 0.0, 0.0];
            }
            let (p, pd) = law.forces_n(y[2], y[3], v0);
            let ddu = (force - cs.c * y[1] - cs.k * y[0] + sw * p - fb) / cs.m;
            let ddv = (-sw * p + fb) / cs.md;
            // δ̈ = sw·(v̈ − ü).
            [y[1], ddu, y[3], sw * (ddv - ddu), pd * y[3]]
        };
        // Events: 0 release (δ < 0); sliding with friction: 1 δ̇ crosses 0 (the sign of ẇ);
        // stuck: 1, 2 the friction needed leaves [−f, f].
        let dsign = if sw * sigma >= 0.0 { 1.0 } else { -1.0 };
        let release = Event::Comp { i: 2, sign: 1.0 };
        let switch = Event::Comp { i: 3, sign: dsign };
        let lag = |t: f64, y: &Y| cs.fl - needed(t, y);
        let lead = |t: f64, y: &Y| cs.fl + needed(t, y);
        let slide_ev: [Event<'_, 5>; 2] = [release, switch];
        let stuck_ev: [Event<'_, 5>; 3] = [release, Event::Fn(&lag), Event::Fn(&lead)];
        let events: &[Event<'_, 5>] = if stuck {
            &stuck_ev
        } else if cs.frictional() {
            &slide_ev
        } else {
            &slide_ev[..1]
        };
        let seg_of = |step: DenseStep<5>, th_end: f64| HertzSegment {
            base: ContactStep::new(cs, step, th_end, sw, cs.k, fb, *law),
            approach,
            v0,
            stuck,
        };
        let end = run_phase(&ig, &mut f, t, y, h, t_end_s, events, |st, th| {
            let seg = seg_of(*st, th);
            for k in 0..=4 {
                max_pen = max_pen.max(st.comp(2, th * k as f64 / 4.0));
            }
            if seg.t_end_s() > seg.t_start_s() {
                book.obs.segment(&seg);
            }
            h = st.h;
        });
        let end = count_steps(end, &mut steps, t0)?;
        t = end.t;
        y = end.y;
        match (end.which, stuck) {
            (Some(1), false) => {
                // ẇ = 0 inside the contact: stick if coulomb can hold the ball, else the
                // sliding friction reverses.
                y[3] = 0.0;
                if can_stick(cs.model) && needed(t, &y).abs() <= cs.fl {
                    stuck = true;
                } else {
                    sigma = -sigma;
                }
                continue;
            }
            (Some(k @ (1 | 2)), true) => {
                // Friction can no longer hold: slide the way the needed force pulls (F_ball = −f
                // sgn ẇ = sign of the needed force at the limit, so ẇ against it).
                stuck = false;
                sigma = if k == 1 { -1.0 } else { 1.0 };
                continue;
            }
            _ => {}
        }
        match end.which {
            Some(_) => {
                y[2] = 0.0;
                // Released: δ = 0 with δ̇ ≤ 0.
                let pen = max_pen;
                if pen > book.summary.max_penetration_m {
                    book.summary.max_penetration_m = pen;
                }
                let before = St {
                    t,
                    u: y[0],
                    du: y[1],
                    w: sw * cs.lg,
                    dw: sw * y[3],
                    force: cs.fs + cs.f0 * (cs.om * t).sin(),
                };
                book.event(
                    cs,
                    t,
                    EventKind::Impact {
                        wall: wall_of(sw),
                        dw_m_s: sw * approach,
                        energy_loss_j: y[4],
                    },
                    &before,
                    &before,
                )?;
                *s = before;
                if s.dw == 0.0 {
                    return Ok(Some(wall_touch(cs, sw, s)));
                }
                return Ok(Some(after_wall_free(sw, s.dw)));
            }
            None => {
                // End of the run inside the contact.
                *s = St {
                    t,
                    u: y[0],
                    du: y[1],
                    w: sw * (cs.lg + y[2]),
                    dw: sw * y[3],
                    force: cs.fs + cs.f0 * (cs.om * t).sin(),
                };
                return Ok(None);
            }
        }
    }
}
