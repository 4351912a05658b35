//! The compliant (`hertz`) contact phase on a cutting run, written once for every bar: the
//! phase of [`super::hertz_phase`] with the cut's force on the bar, cut into the delay
//! stepping's pieces ([`super::cutting`]).
//!
//! During the contact the bar's phase state and the ball (`[…bar…, δ, δ̇, W_c]`, the bar's
//! [`CompliantBar`]) are integrated by [`Dopri5`] with the bar's right-hand side under the
//! external force at the force point `F(t) + F_cut`,
//!
//! `F_cut = Cutting::force_on_bar_n(h)` in the cut (0 out of it; the one definition of the force
//! law), `h = h0 + c_chip (d(τ) − u_f)`, `u_f` the bar's displacement at the force point and
//! `d` the delayed surface over the piece: the same quadratic through the stored history the
//! closed-form pieces use, so the phase reads the history on the piece's window only and never
//! across a stored event. The phase runs piece by piece: it stops at the piece's end (a
//! breakpoint `t_k + T` or the piece-length limit), its integrator state carried over
//! ([`ContactPhase`]) and resumed on the next piece with that piece's quadratic. The chip (`h`
//! in the cut, `−h` out of it) is an event function of the phase, located on the dense output
//! (sampled, then bisected): the sub-piece ends there, the driver stores the surface's renewal
//! and the breakpoint `t_k + T` as on every other cut event, and the phase goes on with the other
//! force. Friction acts as in the phase without the cut (sliding with `σ = sgn ẇ`, its switch
//! and, with coulomb, stick located on the dense output). Each accepted step is a segment
//! (`Mode::Contact`, [`CutContactSegment`]) carrying the chip and the cutting force; its
//! integrals and cutting work are Gauss–Legendre quadratures of the dense output, so the books
//! close with the cutting work to the integrator's tolerance. The release is an
//! [`EventKind::Impact`] carrying the contact's dissipated work `W_c`, handed back to the bar's
//! cutting run ([`PieceEnd::Released`]), which stores it as every event of its history.
//!
//! A bar takes part through [`CutBar`] (its displacement and velocity at the force point, its
//! response point, its viscous loss and energy on a phase state) and its cutting run's books
//! through [`CutPhaseBook`].

use super::cutting::GL8;
use super::driver::{wall_of, BallState};
use super::hertz_phase::{CompliantBar, ContactPhase, Event};
use crate::damper::contact::Hertz;
use crate::error::SimError;
use crate::excitation::Cutting;
use crate::params::State;
use crate::solver::dopri5::DenseStep;
use crate::solver::{CutSample, EventKind, Mode, Segment, SegmentIntegrals};

/// The cut over a sub-piece: the chip and the force from the piece's quadratic.
#[derive(Debug, Clone, Copy)]
pub(super) struct CutOver {
    /// The cut (its force law).
    pub cut: Cutting,
    /// The tool cuts over the sub-piece.
    pub in_cut: bool,
    /// The delayed surface's quadratic `d(τ) = d0 + d1 τ + d2 τ²`.
    pub d: [f64; 3],
    /// Feed `h0`.
    pub h0: f64,
    /// `c_chip`.
    pub c_chip: f64,
    /// Origin of `d(τ)`, `τ = t − t_ref` (the sub-piece's start).
    pub t_ref: f64,
}

impl CutOver {
    /// The chip `h0 + c_chip (d(τ) − u_f)` at `t` with the force point at `uf`.
    pub fn chip(&self, t: f64, uf: f64) -> f64 {
        let x = t - self.t_ref;
        let d = self.d[0] + x * (self.d[1] + x * self.d[2]);
        self.h0 + self.c_chip * (d - uf)
    }
    /// `Cutting::force_on_bar_n` in the cut (the mode chooses, not the sign of `h`: the switch
    /// is located, never chattered over), 0 out of it.
    pub fn force(&self, t: f64, uf: f64) -> f64 {
        if self.in_cut {
            self.cut.force_on_bar_n(self.chip(t, uf))
        } else {
            0.0
        }
    }
}

/// The bar's side of a contact phase on a cutting run, besides its [`CompliantBar`] side: what
/// the cut and the segments read of a phase state.
pub(super) trait CutBar<const N: usize>: CompliantBar<N> {
    /// The displacement at the force point (the tool).
    fn u_tool(&self, y: &[f64; N]) -> f64;
    /// The velocity at the force point.
    fn du_tool(&self, y: &[f64; N]) -> f64;
    /// The displacement at the response point.
    fn u_response(&self, y: &[f64; N]) -> f64;
    /// The viscous power density whose integral, times [`CutBar::viscous_scale`], is the
    /// viscous loss.
    fn viscous(&self, y: &[f64; N]) -> f64;
    /// See [`CutBar::viscous`].
    fn viscous_scale(&self) -> f64;
    /// The solver's state of the phase state `y` at `t` under the external force `force` (the
    /// cut's included).
    fn cut_state(&self, sw: f64, t: f64, y: &[f64; N], force: f64) -> Self::St;
    /// The public state of a solver's state (its external force not read).
    fn public(&self, s: &Self::St) -> State;
    /// Bar and ball's mechanical energy (without the contact's elastic energy).
    fn energy_j(&self, s: &Self::St) -> f64;
}

/// Where the phase reports on a cutting run: its steps as segments, its penetration.
pub(super) trait CutPhaseBook<C: CutBar<N>, const N: usize> {
    /// An accepted step of positive length.
    fn segment(&mut self, seg: &CutContactSegment<'_, C, N>);
    /// The largest penetration so far of the phase.
    fn penetration(&mut self, pen_m: f64);
}

/// One accepted step of a contact phase on a cutting run, as a segment.
pub(super) struct CutContactSegment<'a, C, const N: usize> {
    step: &'a DenseStep<N>,
    th_end: f64,
    bar: &'a C,
    sw: f64,
    fb: f64,
    law: &'a Hertz,
    over: CutOver,
}

impl<C: CutBar<N>, const N: usize> CutContactSegment<'_, C, N> {
    /// The phase state at `t` (clamped to the step's part inside the phase).
    pub fn y_at(&self, t: f64) -> [f64; N] {
        let th = ((t - self.step.t0) / self.step.h).clamp(0.0, self.th_end);
        self.step.at_theta(th)
    }
    /// The bar.
    pub fn bar(&self) -> &C {
        self.bar
    }
    fn state(&self, t: f64) -> C::St {
        self.bar.state_of(self.sw, t, &self.y_at(t))
    }
    /// `∫_a^b f` by 8-point Gauss–Legendre over the step's dense output (degree 4).
    fn quad<const K: usize>(
        &self,
        a: f64,
        b: f64,
        f: impl Fn(f64, &[f64; N]) -> [f64; K],
    ) -> [f64; K] {
        let mut sum = [0.0; K];
        if b <= a {
            return sum;
        }
        let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
        for (x, w) in GL8 {
            let t = mid + half * x;
            for (s, v) in sum.iter_mut().zip(f(t, &self.y_at(t))) {
                *s += w * v;
            }
        }
        sum.map(|s| half * s)
    }
}

impl<C: CutBar<N>, const N: usize> Segment for CutContactSegment<'_, C, N> {
    fn t_start_s(&self) -> f64 {
        self.step.t0
    }
    fn t_end_s(&self) -> f64 {
        self.step.t0 + self.th_end * self.step.h
    }
    fn mode(&self) -> Mode {
        Mode::Contact(wall_of(self.sw))
    }
    fn state_at(&self, t_s: f64) -> State {
        self.bar.public(&self.state(t_s))
    }
    fn integral_u2(&self, a_s: f64, b_s: f64) -> f64 {
        self.quad(a_s, b_s, |_, y| {
            let u = self.bar.u_response(y);
            [u * u]
        })[0]
    }
    fn integrals(&self, a_s: f64, b_s: f64) -> SegmentIntegrals {
        // The forcing work is the static and harmonic force's; the cut's is `cutting_work_j`.
        let bar = self.bar;
        let [u2, fw, vl] = self.quad(a_s, b_s, |t, y| {
            let u = bar.u_response(y);
            [u * u, bar.force_at(t) * bar.du_tool(y), bar.viscous(y)]
        });
        let id = bar.slots().0;
        SegmentIntegrals {
            u2_m2_s: u2,
            forcing_work_j: fw,
            viscous_loss_j: bar.viscous_scale() * vl,
            friction_work_j: if self.fb == 0.0 {
                0.0
            } else {
                self.fb * self.sw * (self.y_at(b_s)[id] - self.y_at(a_s)[id])
            },
        }
    }
    fn mechanical_energy_j(&self, t_s: f64) -> f64 {
        let y = self.y_at(t_s);
        self.bar.energy_j(&self.state(t_s)) + self.law.elastic_energy_j(y[self.bar.slots().0])
    }
    fn cutting_at(&self, t_s: f64) -> Option<CutSample> {
        let uf = self.bar.u_tool(&self.y_at(t_s));
        Some(CutSample {
            chip_thickness_m: self.over.chip(t_s, uf),
            in_cut: self.over.in_cut,
            cutting_force_n: self.over.force(t_s, uf),
        })
    }
    fn cutting_work_j(&self, a_s: f64, b_s: f64) -> f64 {
        if !self.over.in_cut {
            return 0.0;
        }
        let bar = self.bar;
        self.quad(a_s, b_s, |t, y| {
            [self.over.force(t, bar.u_tool(y)) * bar.du_tool(y)]
        })[0]
    }
}

/// How a sub-piece of a contact phase ended.
pub(super) enum PieceEnd<S> {
    /// The contact goes on: the piece (or the run) ended inside it, or the tool left or
    /// re-entered the cut (`cut_event`: the driver stores the cut event), the phase kept.
    Goes {
        /// The sub-piece ended at the chip's zero.
        cut_event: bool,
    },
    /// The ball left the wall at `at` (`w = sw·l_g`, `ẇ` leaving): the event `kind` to store,
    /// then the next mode from the state.
    Released {
        /// The state at the release.
        at: S,
        /// The impact event closing the contact (its approach speed and `W_c`).
        kind: EventKind,
    },
}

/// The contact phase at wall `sw` over one sub-piece of a cutting run: from `s` (a touch, or
/// where `phase` stopped) to `t_stop` (the piece end), to the tool leaving or re-entering the cut
/// (the phase kept in `phase`), or to the release. `cs` is the bar over the piece, `over` the
/// cut over it (its quadratic from `s.t`); `order` is 1 right after a located cut event (the
/// chip then starts at its zero, on either side by rounding).
#[allow(clippy::too_many_arguments)]
pub(super) fn contact_piece<const N: usize, C, B>(
    cs: &C,
    law: &Hertz,
    over: CutOver,
    sw: f64,
    phase: &mut Option<ContactPhase<N>>,
    s: &mut C::St,
    t_stop: f64,
    order: usize,
    book: &mut B,
) -> Result<PieceEnd<C::St>, SimError>
where
    C: CutBar<N>,
    B: CutPhaseBook<C, N>,
    C::St: Copy,
{
    let (id, _, iw) = cs.slots();
    let mut ph = match phase.take() {
        Some(p) if p.t.to_bits() == s.t().to_bits() => p,
        _ => ContactPhase::touch(cs, law, sw, s),
    };
    let cut_sign = if over.in_cut { 1.0 } else { -1.0 };
    let margin = |t: f64, y: &[f64; N]| cut_sign * over.chip(t, cs.u_tool(y));
    // Not right after a located cut event (the chip is at its zero): a piece that starts on
    // the other side of the chip's zero (the delayed surface's kink at a breakpoint) switches
    // the force at once.
    if order == 0 && margin(ph.t, &ph.y) < 0.0 {
        *phase = Some(ph);
        return Ok(PieceEnd::Goes { cut_event: true });
    }
    let v0 = ph.v0;
    let ig = ph.integrator(cs, law);
    let fl = cs.friction_level_n();
    // The external force at the force point: static, harmonic and the cut's.
    let force_at = |t: f64, y: &[f64; N]| cs.force_at(t) + over.force(t, cs.u_tool(y));
    // Friction the ball needs to move with the bar: F_ball = m_d ü_pair + sw·P(δ, 0).
    let needed = |t: f64, y: &[f64; N]| cs.needed(law, sw, force_at(t, y), y);
    loop {
        let (stuck, sigma) = (ph.stuck, ph.sigma);
        let fb = if stuck { 0.0 } else { cs.fb(sigma) };
        let mut f = |t: f64, y: &[f64; N]| cs.rhs(law, v0, sw, stuck, fb, force_at(t, y), y);
        // The phase's events, and last the chip's margin.
        let lag = |t: f64, y: &[f64; N]| fl - needed(t, y);
        let lead = |t: f64, y: &[f64; N]| fl + needed(t, y);
        let (events, ne) = ph.events(cs, sw, &lag, &lead, Some(Event::Fn(&margin)));
        let end = ph.advance(&ig, &mut f, t_stop, &events[..ne], id, |st, th| {
            let seg = CutContactSegment {
                step: st,
                th_end: th,
                bar: cs,
                sw,
                fb,
                law,
                over,
            };
            if seg.t_end_s() > seg.t_start_s() {
                book.segment(&seg);
            }
            // The step clipped to the piece end is no guide to the next piece's first step.
            th < 1.0 || st.t0 + st.h < t_stop - 1e-9 * st.h
        })?;
        book.penetration(ph.max_pen);
        let cut_event = end.which == Some(ne - 1);
        if cut_event || end.which.is_none() {
            // The piece (or the run) ends inside the contact, or the tool left or re-entered
            // the cut (the driver stores the event; the phase goes on with the other force).
            *s = cs.cut_state(sw, end.t, &end.y, force_at(end.t, &end.y));
            *phase = Some(ph);
            return Ok(PieceEnd::Goes { cut_event });
        }
        if ph.friction_switch(cs, end.which, needed) {
            continue;
        }
        // Released: δ = 0 with δ̇ ≤ 0.
        let force = force_at(ph.t, &ph.y);
        ph.y[id] = 0.0;
        let at = cs.cut_state(sw, ph.t, &ph.y, force);
        *phase = None;
        *s = at;
        return Ok(PieceEnd::Released {
            at,
            kind: EventKind::Impact {
                wall: wall_of(sw),
                dw_m_s: sw * ph.approach,
                energy_loss_j: ph.y[iw],
            },
        });
    }
}
