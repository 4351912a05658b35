//! The N-mode bar's side of the compliant (`hertz`) contact phase on a cutting run
//! ([`crate::solver::exact::hertz_cut`], written once for every bar): the modal phase's
//! right-hand side ([`super::super::hertz::PhaseBar`]) with the cut's force at the force point,
//!
//! `mₙq̈ₙ + cₙq̇ₙ + kₙqₙ = φₙ(x_f)(F(t) + F_cut) + φₙ(x_d)(s P − F_ball)`,  `m_d v̈ = −s P + F_ball`,
//!
//! on the state `[q₁…q_N, q̇₁…q̇_N, δ, δ̇, W_c]`, `u_f = Σφₙ(x_f)qₙ` the tool. The relative
//! tolerance is `CONTACT_RTOL`, or the run's own for a convergence study. Each accepted step
//! stores a knot of the surface history at its end (the force point's `u_f`, `u̇_f` in the cut,
//! the carried surface out of it).
//!
//! The approach-speed floor of the damping's reference (`APPROACH_FLOOR_REL·l_g·max(Ω, ω_d)`)
//! takes `ω_d` of the first mode with the piece's stiffness (`k₁ + k_c φ₁(x_f)²` in the cut),
//! which on one mode is the lumped phase's.

use super::super::hertz::{integrator, phase_state, PhaseBar, NY, Y};
use super::{energy_j, Book, Consts, St, NM};
use crate::damper::contact::Hertz;
use crate::params::State;
use crate::solver::dopri5::Dopri5;
use crate::solver::exact::driver::{cavity_constants, Cavity};
use crate::solver::exact::hertz_cut::{CutBar, CutContactSegment, CutPhaseBook};
use crate::solver::exact::hertz_phase::{CompliantBar, ContactPhase};
use crate::solver::exact::lumped::cutting::History;

/// A contact phase interrupted at a piece end or a cut event, to resume on the next piece.
pub(super) type Phase = ContactPhase<NY>;

/// The modal bar over one piece of a cutting run: in the cut or not, the delayed surface at the
/// state's time `d0` (read by [`Cavity::a_b`]).
pub(super) struct PieceBar<'a> {
    pub(super) cs: &'a Consts,
    pub(super) in_cut: bool,
    pub(super) d0: f64,
}

impl PieceBar<'_> {
    fn bar(&self) -> PhaseBar<'_> {
        let cs = self.cs;
        PhaseBar {
            n: cs.n,
            m: &cs.m,
            c: &cs.c,
            k: &cs.k,
            phi_f: &cs.phi_f,
            phi_d: &cs.phi_d,
            md: cs.md,
            kappa: cs.kappa,
        }
    }
    fn sum(&self, row: &[f64; NM], x: &[f64]) -> f64 {
        let mut s = 0.0;
        for i in 0..self.cs.n {
            s += row[i] * x[i];
        }
        s
    }
}

impl Cavity for PieceBar<'_> {
    type St = St;
    cavity_constants!(cs);
    fn kappa(&self) -> f64 {
        self.cs.kappa
    }
    fn a_b(&self, s: &St) -> f64 {
        self.cs.a_b(s, self.in_cut, self.d0)
    }
    fn held_acceleration(&self, s: &St) -> f64 {
        self.a_b(s) / (self.cs.md * self.cs.kappa)
    }
    fn a_b_rates(&self, _s: &St, _ab: f64) -> (f64, f64) {
        (0.0, 0.0)
    }
}

impl CompliantBar<NY> for PieceBar<'_> {
    fn slots(&self) -> (usize, usize, usize) {
        let n = self.cs.n;
        (2 * n, 2 * n + 1, 2 * n + 2)
    }
    fn omegas(&self) -> (f64, f64) {
        let cs = self.cs;
        let k1 = cs.k[0]
            + if self.in_cut {
                cs.kc * cs.phi_f[0] * cs.phi_f[0]
            } else {
                0.0
            };
        let al = cs.c[0] / (2.0 * cs.m[0]);
        let wd = (k1 / cs.m[0] - al * al).sqrt();
        (cs.om, cs.om.max(wd))
    }
    fn contact_mass_kg(&self) -> f64 {
        1.0 / self.cs.kappa
    }
    fn integrator(&self, d_scale: f64, v_scale: f64) -> Dopri5<NY> {
        let cs = self.cs;
        let meff = self.contact_mass_kg();
        integrator(cs.n, cs.lg, meff, cs.contact_rtol, d_scale, v_scale)
    }
    fn phase_state(&self, s: &St, approach: f64) -> Y {
        phase_state(self.cs.n, &s.q, &s.dq, approach)
    }
    fn force_at(&self, t: f64) -> f64 {
        self.cs.fs + self.cs.harmonic(t)
    }
    fn rhs(&self, law: &Hertz, v0: f64, sw: f64, stuck: bool, fb: f64, force: f64, y: &Y) -> Y {
        self.bar().rhs(law, v0, sw, stuck, fb, force, y)
    }
    fn needed(&self, law: &Hertz, sw: f64, force: f64, y: &Y) -> f64 {
        self.bar().needed(law, sw, force, y)
    }
    fn state_of(&self, sw: f64, t: f64, y: &Y) -> St {
        let n = self.cs.n;
        let mut s = St {
            t,
            q: [0.0; NM],
            dq: [0.0; NM],
            w: sw * (self.cs.lg + y[2 * n]),
            dw: sw * y[2 * n + 1],
        };
        s.q[..n].copy_from_slice(&y[..n]);
        s.dq[..n].copy_from_slice(&y[n..2 * n]);
        s
    }
}

impl CutBar<NY> for PieceBar<'_> {
    fn u_tool(&self, y: &Y) -> f64 {
        self.sum(&self.cs.phi_f, &y[..])
    }
    fn du_tool(&self, y: &Y) -> f64 {
        self.sum(&self.cs.phi_f, &y[self.cs.n..])
    }
    fn u_response(&self, y: &Y) -> f64 {
        self.sum(&self.cs.phi_r, &y[..])
    }
    fn viscous(&self, y: &Y) -> f64 {
        let n = self.cs.n;
        let mut visc = 0.0;
        for i in 0..n {
            visc += self.cs.c[i] * y[n + i] * y[n + i];
        }
        visc
    }
    fn viscous_scale(&self) -> f64 {
        1.0
    }
    fn cut_state(&self, sw: f64, t: f64, y: &Y, _force: f64) -> St {
        self.state_of(sw, t, y)
    }
    fn public(&self, s: &St) -> State {
        s.public(self.cs)
    }
    fn energy_j(&self, s: &St) -> f64 {
        energy_j(self.cs, s, true)
    }
}

/// The modal cutting run's books during a contact phase: the observer and the surface history.
pub(super) struct PhaseHost<'b, 'o, 'h> {
    pub(super) book: &'b mut Book<'o>,
    pub(super) hist: &'h mut History,
    pub(super) in_cut: bool,
}

impl CutPhaseBook<PieceBar<'_>, NY> for PhaseHost<'_, '_, '_> {
    fn segment(&mut self, seg: &CutContactSegment<'_, PieceBar<'_>, NY>) {
        use crate::solver::Segment;
        self.book.obs.segment(seg);
        // The surface knot at the step end.
        let t1 = seg.t_end_s();
        if self.in_cut {
            let y1 = seg.y_at(t1);
            let bar = seg.bar();
            self.hist.record(t1, bar.u_tool(&y1), bar.du_tool(&y1));
        } else {
            self.hist.record_out_of_cut(t1);
        }
    }
    fn penetration(&mut self, pen_m: f64) {
        if pen_m > self.book.tally.summary.max_penetration_m {
            self.book.tally.summary.max_penetration_m = pen_m;
        }
    }
}
