//! The N-mode bar's side of the compliant (`hertz`) contact phase ([`super::super::hertz_phase`],
//! written once for every bar), the bar read at the cavity through the contact row.
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
//! per step or contact). The phase itself (its friction, stick and release logic, the integrator, its tolerance,
//! the damping's reference speed floor and the bound on the work) is the one of
//! [`super::super::hertz_phase`], for every bar. Each accepted step
//! is a `Mode::Contact` segment: its integrals (`∫u(x_r)²`, the forcing work at `x_f`, the modal
//! viscous loss `Σcₙ∫q̇ₙ²`, the friction work `F_ball Δw`) by 5-point Gauss–Legendre on the dense
//! output, its mechanical energy every mode's plus the ball's plus Hertz's `(2/5)K_h δ^{5/2}`;
//! the release is an [`EventKind::Impact`] carrying `W_c`, so the books close.

use super::super::driver::wall_of;
use super::{energy_j, Book, Consts, St, NM};
use crate::analysis::contact_test::CONTACT_RTOL;
use crate::damper::contact::Hertz;
use crate::error::SimError;
use crate::limits::MAX_BEAM_MODES;
use crate::solver::dopri5::{DenseStep, Dopri5};
use crate::solver::exact::hertz::{GL_W, GL_X};
use crate::solver::exact::hertz_phase::{CompliantBar, PhaseBook, PhaseStep};
use crate::solver::{CompliantContact, EventKind, Mode, Segment, SegmentIntegrals};

/// Capacity of the phase's state: `N` displacements, `N` velocities, `δ`, `δ̇`, `W_c`.
pub(super) const NY: usize = crate::solver::exact::hertz_phase::MODAL_PHASE_LEN;
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

/// The phase's integrator on `n` modes with relative tolerance `rtol`: the scales `l_g` of
/// the displacements, `v_scale` of the velocities, `d_scale` of `δ` and the contact's kinetic
/// energy at `v_scale` of `W_c`.
pub(super) fn integrator(
    n: usize,
    lg: f64,
    meff: f64,
    rtol: f64,
    d_scale: f64,
    v_scale: f64,
) -> Dopri5<NY> {
    debug_assert!(n <= MAX_BEAM_MODES);
    let (id, idd, iw) = (2 * n, 2 * n + 1, 2 * n + 2);
    let mut atol = [0.0; NY];
    for i in 0..n {
        atol[i] = rtol * lg;
        atol[n + i] = rtol * v_scale;
    }
    atol[id] = rtol * d_scale;
    atol[idd] = rtol * v_scale;
    atol[iw] = rtol * 0.5 * meff * v_scale * v_scale;
    Dopri5::<NY> {
        rtol,
        atol,
        len: 2 * n + 3,
    }
}

/// The phase state at a touch of the modes `(q, q̇)` with the approach speed `approach`
/// (`δ = 0`, `W_c = 0`).
pub(super) fn phase_state(n: usize, q: &[f64; NM], dq: &[f64; NM], approach: f64) -> Y {
    let mut y: Y = [0.0; NY];
    y[..n].copy_from_slice(&q[..n]);
    y[n..2 * n].copy_from_slice(&dq[..n]);
    y[2 * n + 1] = approach;
    y
}

/// One accepted step of a contact phase, as a segment.
struct ContactSegment<'a> {
    step: &'a DenseStep<NY>,
    th_end: f64,
    cs: &'a Consts,
    sw: f64,
    fb: f64,
    law: &'a Hertz,
    /// `sw·ẇ` at the touch, the law's reference speed `δ̇₀`, the ball stuck (coulomb).
    approach: f64,
    v0: f64,
    stuck: bool,
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
    fn compliant_contact(&self) -> Option<CompliantContact> {
        Some(CompliantContact {
            wall_sign: self.sw,
            approach_m_s: self.approach,
            reference_speed_m_s: self.v0,
            ball_friction_n: self.fb,
            stuck: self.stuck,
            law: *self.law,
        })
    }
}

impl Consts {
    /// The bar's side of a contact phase.
    fn phase_bar(&self) -> PhaseBar<'_> {
        PhaseBar {
            n: self.n,
            m: &self.m,
            c: &self.c,
            k: &self.k,
            phi_f: &self.phi_f,
            phi_d: &self.phi_d,
            md: self.md,
            kappa: self.kappa,
        }
    }
}

impl CompliantBar<NY> for Consts {
    fn slots(&self) -> (usize, usize, usize) {
        let n = self.n;
        (2 * n, 2 * n + 1, 2 * n + 2)
    }
    fn omegas(&self) -> (f64, f64) {
        (self.om, self.om.max(self.osc[0].wd))
    }
    /// The bar's effective mass at the cavity against the ball, `1/κ`.
    fn contact_mass_kg(&self) -> f64 {
        1.0 / self.kappa
    }
    fn integrator(&self, d_scale: f64, v_scale: f64) -> Dopri5<NY> {
        integrator(
            self.n,
            self.lg,
            self.contact_mass_kg(),
            CONTACT_RTOL,
            d_scale,
            v_scale,
        )
    }
    fn phase_state(&self, s: &St, approach: f64) -> Y {
        phase_state(self.n, &s.q, &s.dq, approach)
    }
    fn force_at(&self, t: f64) -> f64 {
        Consts::force_at(self, t)
    }
    fn rhs(&self, law: &Hertz, v0: f64, sw: f64, stuck: bool, fb: f64, force: f64, y: &Y) -> Y {
        self.phase_bar().rhs(law, v0, sw, stuck, fb, force, y)
    }
    fn needed(&self, law: &Hertz, sw: f64, force: f64, y: &Y) -> f64 {
        self.phase_bar().needed(law, sw, force, y)
    }
    fn state_of(&self, sw: f64, t: f64, y: &Y) -> St {
        st_of(self, sw, t, y).0
    }
}

impl PhaseBook<Consts, NY> for Book<'_> {
    fn step(&mut self, cs: &Consts, step: &DenseStep<NY>, th_end: f64, p: &PhaseStep) {
        let seg = ContactSegment {
            step,
            th_end,
            cs,
            sw: p.sw,
            fb: p.fb,
            law: &p.law,
            approach: p.approach,
            v0: p.v0,
            stuck: p.stuck,
        };
        if seg.t_end_s() > seg.t_start_s() {
            self.obs.segment(&seg);
            if self.obs.wants_modal() {
                let a = st_of(cs, p.sw, step.t0, &step.y0).0.modal(cs);
                let b = seg.st_at(seg.t_end_s()).0.modal(cs);
                self.obs.modal_step(&a, &b);
            }
        }
    }
    fn penetration(&mut self, pen_m: f64) {
        if pen_m > self.tally.summary.max_penetration_m {
            self.tally.summary.max_penetration_m = pen_m;
        }
    }
    fn event(&mut self, cs: &Consts, kind: EventKind, at: &St) -> Result<(), SimError> {
        Book::event(self, cs, kind, at, at)
    }
}
