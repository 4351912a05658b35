//! The compliant (`hertz`) contact phase of the N-mode exact solver: the lumped phase
//! ([`crate::solver::exact::hertz`]) with the bar read at the cavity through the contact row.
//!
//! With penetration `δ = s·w − l_g ≥ 0` (`w = v − Σφₙ(x_d)qₙ`) and the force `P` of
//! [`crate::damper::contact`],
//!
//! `mₙq̈ₙ + cₙq̇ₙ + kₙqₙ = φₙ(x_f)F(t) + φₙ(x_d)(s P − F_ball)`,  `m_d v̈ = −s P + F_ball`,
//!
//! so `δ̈ = s(v̈ − Σφₙ(x_d)q̈ₙ)`. Friction acts as in the lumped phase (sliding with `σ = sgn ẇ`,
//! its switch where `ẇ` crosses 0 located on the dense output; coulomb may stick the ball to the
//! wall, `δ` frozen, the pair's acceleration at the cavity `a_b/(m_d κ)` as in the rigid contact,
//! until the friction needed leaves `[−f, f]`).
//!
//! The state `[q₁…q_N, q̇₁…q̇_N, δ, δ̇, W_c]` sits in a fixed-capacity array sized for
//! [`MAX_BEAM_MODES`] of which [`Dopri5`] integrates the first `2N + 3` (nothing is allocated
//! per step or contact). The driver, the integrator, its tolerance, the law, the damping's
//! reference speed floor and the bound on the work are the lumped phase's. Each accepted step
//! is a `Mode::Contact` segment: its integrals (`∫u(x_r)²`, the forcing work at `x_f`, the modal
//! viscous loss `Σcₙ∫q̇ₙ²`, the friction work `F_ball Δw`) by 5-point Gauss–Legendre on the dense
//! output, its mechanical energy every mode's plus the ball's plus Hertz's `(2/5)K_h δ^{5/2}`;
//! the release is an [`EventKind::Impact`] carrying `W_c`, so the books close.

use super::super::driver::{after_wall_free, wall_of, wall_touch, Cavity, Md};
use super::{energy_j, Book, Consts, St, NM};
use crate::analysis::contact_test::CONTACT_RTOL;
use crate::damper::contact::Hertz;
use crate::damper::friction::can_stick;
use crate::error::SimError;
use crate::limits::MAX_BEAM_MODES;
use crate::solver::dopri5::{DenseStep, Dopri5};
use crate::solver::exact::hertz::{APPROACH_FLOOR_REL, GL_W, GL_X};
use crate::solver::exact::hertz_phase::{count_steps, run_phase, Event};
use crate::solver::{EventKind, Mode, Segment, SegmentIntegrals};

/// Capacity of the phase's state: `N` displacements, `N` velocities, `δ`, `δ̇`, `W_c`.
pub(super) const NY: usize = 2 * NM + 3;
pub(super) type Y = [f64; NY];

/// The bar's side of a contact phase: the modes and the ball coupled at the cavity. Its
/// right-hand side is this phase's and the cutting run's ([`super::cutting`]'s phase), which
/// passes the force at the force point with the cut's included.
#[derive(Clone, Copy)]
pub(super) struct PhaseBar<'a> {
    pub(super) n: usize,
    pub(super) m: &'a [f64; NM],
    pub(super) c: &'a [f64; NM],
    pub(super) k: &'a [f64; NM],
    pub(super) phi_f: &'a [f64; NM],
    pub(super) phi_d: &'a [f64; NM],
    pub(super) md: f64,
    /// `1/m_d + Σφₙ(x_d)²/mₙ`.
    pub(super) kappa: f64,
}

impl PhaseBar<'_> {
    /// `a_b = Σφₙ(x_d)q̈ₙ` without the ball's force, under `force` at the force point.
    pub(super) fn a_b(&self, force: f64, y: &Y) -> f64 {
        let n = self.n;
        let mut a = 0.0;
        for i in 0..n {
            a += self.phi_d[i] * (self.phi_f[i] * force - self.c[i] * y[n + i] - self.k[i] * y[i])
                / self.m[i];
        }
        a
    }

    /// The pair's acceleration at the cavity while the ball is held.
    pub(super) fn pair_acc(&self, force: f64, y: &Y) -> f64 {
        self.a_b(force, y) / (self.md * self.kappa)
    }

    /// Friction the ball needs to move with the bar: `F_ball = m_d ü_pair + sw·P(δ, 0)`.
    pub(super) fn needed(&self, law: &Hertz, sw: f64, force: f64, y: &Y) -> f64 {
        self.md * self.pair_acc(force, y) + sw * law.elastic_force_n(y[2 * self.n])
    }

    /// `ẏ` at wall `sw`: stuck (the ball held, `δ` frozen) or sliding with the friction `fb` on
    /// the ball; `v0` the damping's reference speed.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn rhs(
        &self,
        law: &Hertz,
        v0: f64,
        sw: f64,
        stuck: bool,
        fb: f64,
        force: f64,
        y: &Y,
    ) -> Y {
        let n = self.n;
        let (id, idd, iw) = (2 * n, 2 * n + 1, 2 * n + 2);
        let mut out = [0.0; NY];
        // The force on the bar at the cavity: held, `−m_d ü_pair`; else `sw·P − F_ball`.
        let (on_bar, p, pd) = if stuck {
            (-self.md * self.pair_acc(force, y), 0.0, 0.0)
        } else {
            let (p, pd) = law.forces_n(y[id], y[idd], v0);
            (sw * p - fb, p, pd)
        };
        let mut ddud = 0.0;
        for i in 0..n {
            let a = (self.phi_f[i] * force - self.c[i] * y[n + i] - self.k[i] * y[i]
                + self.phi_d[i] * on_bar)
                / self.m[i];
            out[i] = y[n + i];
            out[n + i] = a;
            ddud += self.phi_d[i] * a;
        }
        if !stuck {
            let ddv = (-sw * p + fb) / self.md;
            out[id] = y[idd];
            out[idd] = sw * (ddv - ddud);
            out[iw] = pd * y[idd];
        }
        out
    }
}

/// One accepted step of a contact phase, as a segment.
struct ContactSegment<'a> {
    step: &'a DenseStep<NY>,
    th_end: f64,
    cs: &'a Consts,
    sw: f64,
    fb: f64,
    law: &'a Hertz,
}

impl ContactSegment<'_> {
    fn y_at(&self, t: f64) -> Y {
        let th = ((t - self.step.t0) / self.step.h).clamp(0.0, self.th_end);
        self.step.at_theta(th)
    }

    fn st_at(&self, t: f64) -> (St, f64) {
        st_of(self.cs, self.sw, t, &self.y_at(t))
    }
}

/// The solver's state of a phase state `y` at `t`, and the penetration `δ`.
fn st_of(cs: &Consts, sw: f64, t: f64, y: &Y) -> (St, f64) {
    let n = cs.n;
    let mut s = St {
        t,
        q: [0.0; NM],
        dq: [0.0; NM],
        w: sw * (cs.lg + y[2 * n]),
        dw: sw * y[2 * n + 1],
        force: cs.force_at(t),
    };
    s.q[..n].copy_from_slice(&y[..n]);
    s.dq[..n].copy_from_slice(&y[n..2 * n]);
    (s, y[2 * n])
}

impl Segment for ContactSegment<'_> {
    fn t_start_s(&self) -> f64 {
        self.step.t0
    }
    fn t_end_s(&self) -> f64 {
        self.step.t0 + self.th_end * self.step.h
    }
    fn mode(&self) -> Mode {
        Mode::Contact(wall_of(self.sw))
    }
    fn state_at(&self, t_s: f64) -> crate::params::State {
        self.st_at(t_s).0.public(self.cs)
    }
    fn integral_u2(&self, a_s: f64, b_s: f64) -> f64 {
        // The `u2_m2_s` of `integrals`, term for term (the RMS hot path: no forcing `sin`).
        let cs = self.cs;
        let (mid, half) = (0.5 * (a_s + b_s), 0.5 * (b_s - a_s));
        let mut u2 = 0.0;
        for (x, wgt) in GL_X.iter().zip(GL_W) {
            let y = self.y_at(mid + half * x);
            let mut ur = 0.0;
            for (p, q) in cs.phi_r[..cs.n].iter().zip(&y[..cs.n]) {
                ur += p * q;
            }
            u2 += wgt * half * ur * ur;
        }
        u2
    }
    fn integrals(&self, a_s: f64, b_s: f64) -> SegmentIntegrals {
        let cs = self.cs;
        let n = cs.n;
        let (mid, half) = (0.5 * (a_s + b_s), 0.5 * (b_s - a_s));
        let mut out = SegmentIntegrals::default();
        for (x, wgt) in GL_X.iter().zip(GL_W) {
            let t = mid + half * x;
            let y = self.y_at(t);
            let (mut ur, mut duf, mut visc) = (0.0, 0.0, 0.0);
            for i in 0..n {
                ur += cs.phi_r[i] * y[i];
                duf += cs.phi_f[i] * y[n + i];
                visc += cs.c[i] * y[n + i] * y[n + i];
            }
            out.u2_m2_s += wgt * half * ur * ur;
            out.forcing_work_j += wgt * half * cs.force_at(t) * duf;
            out.viscous_loss_j += wgt * half * visc;
        }
        if self.fb != 0.0 {
            out.friction_work_j =
                self.fb * self.sw * (self.y_at(b_s)[2 * n] - self.y_at(a_s)[2 * n]);
        }
        out
    }
    fn mechanical_energy_j(&self, t_s: f64) -> f64 {
        let (s, delta) = self.st_at(t_s);
        energy_j(self.cs, &s.modal(self.cs), true) + self.law.elastic_energy_j(delta)
    }
}

/// The contact phase at wall `sw` from the touch `s` (`s.w = sw·l_g`, `sw·s.dw ≥ 0`). On return
/// `s` is the state at the release (`w = sw·l_g`, `ẇ` leaving) or at `t_end_s`; the next mode,
/// or `None` at the end of the run.
pub(super) fn contact(
    cs: &Consts,
    sw: f64,
    s: &mut St,
    t_end_s: f64,
    book: &mut Book,
) -> Result<Option<Md>, SimError> {
    let law = cs.hertz.expect("a hertz touch needs the hertz law");
    let n = cs.n;
    debug_assert!(n <= MAX_BEAM_MODES);
    let (id, idd, iw) = (2 * n, 2 * n + 1, 2 * n + 2);
    let t0 = s.t;
    let approach = (sw * s.dw).max(0.0);
    let floor = APPROACH_FLOOR_REL * cs.lg * cs.om.max(cs.osc[0].wd);
    let v0 = approach.max(floor);
    // Scales of the tolerances: the impact's own penetration and speed (the bar's effective
    // mass at the cavity against the ball), the bar's motion.
    let meff = 1.0 / cs.kappa;
    let d_scale = law.with_damping(0.0).max_penetration_m(meff, v0);
    let v_scale = v0.max(cs.lg * cs.om);
    let mut atol = [0.0; NY];
    for i in 0..n {
        atol[i] = CONTACT_RTOL * cs.lg;
        atol[n + i] = CONTACT_RTOL * v_scale;
    }
    atol[id] = CONTACT_RTOL * d_scale;
    atol[idd] = CONTACT_RTOL * v_scale;
    atol[iw] = CONTACT_RTOL * 0.5 * meff * v_scale * v_scale;
    let ig = Dopri5::<NY> {
        rtol: CONTACT_RTOL,
        atol,
        len: 2 * n + 3,
    };
    let mut y: Y = [0.0; NY];
    y[..n].copy_from_slice(&s.q[..n]);
    y[n..2 * n].copy_from_slice(&s.dq[..n]);
    y[idd] = approach;
    let mut t = t0;
    let mut h = law.undamped_contact_time_s(meff, v0) / 50.0;
    let mut steps = 0u64;
    let mut max_pen = 0.0_f64;
    let mut sigma = if cs.frictional() { sw } else { 0.0 };
    let mut stuck = false;
    let bar = PhaseBar {
        n,
        m: &cs.m,
        c: &cs.c,
        k: &cs.k,
        phi_f: &cs.phi_f,
        phi_d: &cs.phi_d,
        md: cs.md,
        kappa: cs.kappa,
    };
    let needed = |t: f64, y: &Y| bar.needed(&law, sw, cs.force_at(t), y);
    loop {
        let fb = if stuck { 0.0 } else { cs.fb(sigma) };
        // The last `(t, F(t))`: the 6th and 7th stages of a step are both at `t + h`.
        let mut last = (f64::NAN, 0.0);
        let mut f = |t: f64, y: &Y| {
            let force = if t.to_bits() == last.0.to_bits() {
                last.1
            } else {
                let v = cs.force_at(t);
                last = (t, v);
                v
            };
            bar.rhs(&law, v0, sw, stuck, fb, force, y)
        };
        // Events: 0 release (δ < 0); sliding with friction: 1 δ̇ crosses 0 (the sign of ẇ);
        // stuck: 1, 2 the friction needed leaves [−f, f].
        let dsign = if sw * sigma >= 0.0 { 1.0 } else { -1.0 };
        let release = Event::Comp { i: id, sign: 1.0 };
        let switch = Event::Comp {
            i: idd,
            sign: dsign,
        };
        let lag = |t: f64, y: &Y| cs.fl - needed(t, y);
        let lead = |t: f64, y: &Y| cs.fl + needed(t, y);
        let slide_ev: [Event<'_, NY>; 2] = [release, switch];
        let stuck_ev: [Event<'_, NY>; 3] = [release, Event::Fn(&lag), Event::Fn(&lead)];
        let events: &[Event<'_, NY>] = if stuck {
            &stuck_ev
        } else if cs.frictional() {
            &slide_ev
        } else {
            &slide_ev[..1]
        };
        let end = run_phase(&ig, &mut f, t, y, h, t_end_s, events, |st, th| {
            for k in 0..=4 {
                max_pen = max_pen.max(st.comp(id, th * k as f64 / 4.0));
            }
            let seg = ContactSegment {
                step: st,
                th_end: th,
                cs,
                sw,
                fb,
                law: &law,
            };
            if seg.t_end_s() > seg.t_start_s() {
                book.obs.segment(&seg);
                if book.obs.wants_modal() {
                    let a = st_of(cs, sw, st.t0, &st.y0).0.modal(cs);
                    let b = seg.st_at(seg.t_end_s()).0.modal(cs);
                    book.obs.modal_step(&a, &b);
                }
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
                y[idd] = 0.0;
                if can_stick(cs.model) && needed(t, &y).abs() <= cs.fl {
                    stuck = true;
                } else {
                    sigma = -sigma;
                }
                continue;
            }
            (Some(k @ (1 | 2)), true) => {
                stuck = false;
                sigma = if k == 1 { -1.0 } else { 1.0 };
                continue;
            }
            _ => {}
        }
        return match end.which {
            Some(_) => {
                // Released: δ = 0 with δ̇ ≤ 0.
                y[id] = 0.0;
                if max_pen > book.summary.max_penetration_m {
                    book.summary.max_penetration_m = max_pen;
                }
                let (at, _) = st_of(cs, sw, t, &y);
                book.event(
                    cs,
                    EventKind::Impact {
                        wall: wall_of(sw),
                        dw_m_s: sw * approach,
                        energy_loss_j: y[iw],
                    },
                    &at,
                    &at,
                )?;
                *s = at;
                if s.dw == 0.0 {
                    Ok(Some(wall_touch(cs, sw, s)))
                } else {
                    Ok(Some(after_wall_free(sw, s.dw)))
                }
            }
            None => {
                // End of the run inside the contact.
                *s = st_of(cs, sw, t, &y).0;
                Ok(None)
            }
        };
    }
}
