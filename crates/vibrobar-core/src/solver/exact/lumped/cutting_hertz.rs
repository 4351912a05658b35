//! The compliant (`hertz`) contact phase on a cutting run of the lumped bar (issue #13): the
//! phase of [`super::hertz`] with the cut's force on the bar, cut into the delay stepping's
//! pieces ([`super::cutting`]).
//!
//! During the contact the state `[u, u̇, δ, δ̇, W_c]` is integrated by [`Dopri5`] (relative
//! tolerance [`CONTACT_RTOL`], the scales of [`super::hertz`]) with
//!
//! `M ü = F(t) + F_cut − C u̇ − K u + s P − F_ball`,  `m_d v̈ = −s P + F_ball`,
//!
//! `F_cut = c_force F(h)` in the cut (0 out of it), `h = h0 + c_chip (d(τ) − u)`, `d` the
//! delayed surface over the piece: the same quadratic through the stored history the
//! closed-form pieces use ([`super::CutPiece`]), so the phase reads the history on the piece's
//! window only and never across a stored event. The phase runs piece by piece: it stops at the
//! piece's end (a breakpoint `t_k + T` or the piece-length limit), its integrator state carried
//! over ([`Phase`]) and resumed on the next piece with that piece's quadratic. The chip
//! (`h` in the cut, `−h` out of it) is an event function of the phase, located on the dense
//! output (sampled, then bisected): the sub-piece ends there, the driver stores the surface's
//! renewal and the breakpoint `t_k + T` as on every other cut event, and the phase goes on with
//! the other force. Friction acts as in [`super::hertz`] (sliding with `σ = sgn ẇ`, its
//! switch and, with coulomb, stick located on the dense output). Each accepted step is a
//! segment (`Mode::Contact`) carrying the chip and the cutting force; its cutting work and
//! integrals are Gauss–Legendre quadratures of the dense output, so the books close with the
//! cutting work to the integrator's tolerance, as the harmonic run's Hertz books do.

use super::driver::{after_wall_free, wall_of, wall_touch, Cavity, Md};
use super::hertz::{ContactStep, APPROACH_FLOOR_REL};
use super::hertz_phase::{count_steps, run_phase, ContactPhase, Event};
use super::{Book, Consts, CutPiece, St};
use crate::analysis::contact_test::CONTACT_RTOL;
use crate::damper::contact::Hertz;
use crate::damper::friction::can_stick;
use crate::error::SimError;
use crate::excitation::Cutting;
use crate::solver::dopri5::{DenseStep, Dopri5};
use crate::solver::{CutSample, EventKind, Mode, Segment, SegmentIntegrals};

type Y = [f64; 5];

/// A contact phase interrupted at a piece end or a cut event, to resume on the next piece.
pub(in crate::solver::exact) type Phase = ContactPhase<5>;

/// The cut over a segment of a contact phase: chip and force from the piece's quadratic.
#[derive(Debug, Clone, Copy)]
struct CutOver {
    cut: Cutting,
    piece: CutPiece,
    /// Time origin of the quadratic `d(τ)`, `τ = t − t_ref` (the sub-piece's start).
    t_ref: f64,
}

impl CutOver {
    fn chip(&self, t: f64, u: f64) -> f64 {
        let (p, x) = (&self.piece, t - self.t_ref);
        let d = p.d[0] + x * (p.d[1] + x * p.d[2]);
        p.h0 + p.c_chip * (d - u)
    }
    /// The force on the bar: `c_force F(h)` in the cut (the mode chooses, not the sign of
    /// `h`: the switch is located, never chattered over), 0 out of it.
    fn force(&self, t: f64, u: f64) -> f64 {
        if self.piece.in_cut {
            self.cut.force_on_bar_n(self.chip(t, u))
        } else {
            0.0
        }
    }
}

/// One accepted step of a contact phase on a cutting run, as a segment.
#[derive(Debug, Clone, Copy)]
struct CutHertzSegment {
    base: ContactStep,
    cut: CutOver,
}

impl CutHertzSegment {
    /// `∫_a^b f` by 8-point Gauss–Legendre over the step's dense output.
    fn quad<const N: usize>(&self, a: f64, b: f64, f: impl Fn(f64, &Y) -> [f64; N]) -> [f64; N] {
        let mut sum = [0.0; N];
        if b <= a {
            return sum;
        }
        let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
        for (x, w) in super::cutting::GL8 {
            let t = mid + half * x;
            for (s, v) in sum.iter_mut().zip(f(t, &self.base.y_at(t))) {
                *s += w * v;
            }
        }
        sum.map(|s| half * s)
    }
}

impl Segment for CutHertzSegment {
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
        self.quad(a_s, b_s, |_, y| [y[0] * y[0]])[0]
    }
    fn integrals(&self, a_s: f64, b_s: f64) -> SegmentIntegrals {
        // The forcing work is the harmonic force's only; the cut's is `cutting_work_j`.
        let [u2, fw, vl] = self.quad(a_s, b_s, |t, y| {
            let f = self.base.fs + self.base.f0 * (self.base.om * t).sin();
            [y[0] * y[0], f * y[1], y[1] * y[1]]
        });
        SegmentIntegrals {
            u2_m2_s: u2,
            forcing_work_j: fw,
            viscous_loss_j: self.base.c * vl,
            friction_work_j: if self.base.fb == 0.0 {
                0.0
            } else {
                self.base.fb * self.base.sw * (self.base.y_at(b_s)[2] - self.base.y_at(a_s)[2])
            },
        }
    }
    fn mechanical_energy_j(&self, t_s: f64) -> f64 {
        self.base.mechanical_energy_j(t_s)
    }
    fn cutting_at(&self, t_s: f64) -> Option<CutSample> {
        let u = self.base.y_at(t_s)[0];
        Some(CutSample {
            chip_thickness_m: self.cut.chip(t_s, u),
            in_cut: self.cut.piece.in_cut,
            cutting_force_n: self.cut.force(t_s, u),
        })
    }
    fn cutting_work_j(&self, a_s: f64, b_s: f64) -> f64 {
        if !self.cut.piece.in_cut {
            return 0.0;
        }
        self.quad(a_s, b_s, |t, y| [self.cut.force(t, y[0]) * y[1]])[0]
    }
}

/// The contact phase at wall `sw` over one sub-piece of a cutting run: from `s` (a touch, or
/// where `phase` stopped) to `t_stop` (the piece end), to the tool leaving or re-entering the
/// cut (`book.cut_event` set, the phase kept in `phase`), or to the release. `cs` is the
/// piece's constants (its cut, the delayed surface's quadratic from `s.t`); `order` is 1 right
/// after a located cut event (the chip then starts at its zero, on either side by rounding).
/// Returns the next mode: [`Md::HertzTouch`] while the contact goes on.
#[allow(clippy::too_many_arguments)]
pub(in crate::solver::exact) fn contact_piece(
    cs: &Consts,
    law: &Hertz,
    cut: &Cutting,
    sw: f64,
    phase: &mut Option<Phase>,
    s: &mut St,
    t_stop: f64,
    order: usize,
    book: &mut Book,
) -> Result<Md, SimError> {
    let piece = cs.cut.expect("a cutting piece");
    let over = CutOver {
        cut: *cut,
        piece,
        t_ref: s.t,
    };
    let k = cs.k_spring;
    let meff = cs.m * cs.md / (cs.m + cs.md);
    let mut ph = match phase.take() {
        Some(p) if p.t.to_bits() == s.t.to_bits() => p,
        _ => {
            // A touch: `s.w = sw·l_g`, `s.dw` the approach velocity (or 0, resting).
            let approach = (sw * s.dw).max(0.0);
            let floor = APPROACH_FLOOR_REL * cs.lg * cs.om.max(cs.osc[0].wd);
            let v0 = approach.max(floor);
            Phase {
                t: s.t,
                y: [s.u, s.du, 0.0, approach, 0.0],
                h: law.undamped_contact_time_s(meff, v0) / 50.0,
                approach,
                v0,
                sigma: if cs.frictional() { sw } else { 0.0 },
                stuck: false,
                max_pen: 0.0,
                steps: 0,
                t_touch: s.t,
            }
        }
    };
    let cut_sign = if piece.in_cut { 1.0 } else { -1.0 };
    let margin = |t: f64, y: &Y| cut_sign * over.chip(t, y[0]);
    // Not right after a located cut event (the chip is at its zero): a piece that starts on
    // the other side of the chip's zero (the delayed surface's kink at a breakpoint) switches
    // the force at once.
    if order == 0 && margin(ph.t, &ph.y) < 0.0 {
        *phase = Some(ph);
        book.cut_event = true;
        return Ok(Md::HertzTouch(wall_of(sw)));
    }
    let d_scale = law.with_damping(0.0).max_penetration_m(meff, ph.v0);
    let v_scale = ph.v0.max(cs.lg * cs.om);
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
    let mtot = cs.m + cs.md;
    // The external force on the bar: the harmonic force and the cut's.
    let force_at = |t: f64, u: f64| cs.fs + cs.f0 * (cs.om * t).sin() + over.force(t, u);
    // Friction the ball needs to move with the bar: F_ball = m_d ü_pair + sw·P(δ, 0).
    let needed = |t: f64, y: &Y| {
        let ddu = (force_at(t, y[0]) - cs.c * y[1] - k * y[0]) / mtot;
        cs.md * ddu + sw * law.elastic_force_n(y[2])
    };
    let v0 = ph.v0;
    loop {
        let (stuck, sigma) = (ph.stuck, ph.sigma);
        let fb = if stuck { 0.0 } else { cs.fb(sigma) };
        let mut f = |t: f64, y: &Y| {
            let force = force_at(t, y[0]);
            if stuck {
                let ddu = (force - cs.c * y[1] - k * y[0]) / mtot;
                return [y[1], ddu, 0.0, 0.0, 0.0];
            }
            let (p, pd) = law.forces_n(y[2], y[3], v0);
            let ddu = (force - cs.c * y[1] - k * y[0] + sw * p - fb) / cs.m;
            let ddv = (-sw * p + fb) / cs.md;
            [y[1], ddu, y[3], sw * (ddv - ddu), pd * y[3]]
        };
        // Events: 0 release (δ < 0); sliding with friction: 1 δ̇ crosses 0; stuck: 1, 2 the
        // friction needed leaves [−f, f]; last: the chip's margin.
        let dsign = if sw * sigma >= 0.0 { 1.0 } else { -1.0 };
        let release = Event::Comp { i: 2, sign: 1.0 };
        let switch = Event::Comp { i: 3, sign: dsign };
        let lag = |t: f64, y: &Y| cs.fl - needed(t, y);
        let lead = |t: f64, y: &Y| cs.fl + needed(t, y);
        let chip = Event::Fn(&margin);
        let slide_ev: [Event<'_, 5>; 3] = [release, switch, chip];
        let frictionless_ev: [Event<'_, 5>; 2] = [release, chip];
        let stuck_ev: [Event<'_, 5>; 4] = [release, Event::Fn(&lag), Event::Fn(&lead), chip];
        let events: &[Event<'_, 5>] = if stuck {
            &stuck_ev
        } else if cs.frictional() {
            &slide_ev
        } else {
            &frictionless_ev
        };
        let chip_ev = events.len() - 1;
        let seg_of = |step: DenseStep<5>, th_end: f64| CutHertzSegment {
            base: ContactStep::new(cs, step, th_end, sw, k, fb, *law),
            cut: over,
        };
        let (mut h, mut max_pen) = (ph.h, ph.max_pen);
        let end = run_phase(&ig, &mut f, ph.t, ph.y, ph.h, t_stop, events, |st, th| {
            let seg = seg_of(*st, th);
            for j in 0..=4 {
                max_pen = max_pen.max(st.comp(2, th * j as f64 / 4.0));
            }
            if seg.t_end_s() > seg.t_start_s() {
                book.obs.segment(&seg);
            }
            // The step clipped to the piece end is no guide to the next piece's first step.
            if th < 1.0 || st.t0 + st.h < t_stop - 1e-9 * st.h {
                h = st.h;
            }
        });
        let end = count_steps(end, &mut ph.steps, ph.t_touch)?;
        ph.h = h;
        ph.max_pen = max_pen;
        ph.t = end.t;
        ph.y = end.y;
        if ph.max_pen > book.tally.summary.max_penetration_m {
            book.tally.summary.max_penetration_m = ph.max_pen;
        }
        let y = end.y;
        let here = St {
            t: end.t,
            u: y[0],
            du: y[1],
            w: sw * (cs.lg + y[2]),
            dw: sw * y[3],
            force: force_at(end.t, y[0]),
        };
        match (end.which, stuck) {
            (Some(j), _) if j == chip_ev => {
                // The tool left or re-entered the cut: the driver switches the force and stores
                // the event; the phase goes on.
                *s = here;
                *phase = Some(ph);
                book.cut_event = true;
                return Ok(Md::HertzTouch(wall_of(sw)));
            }
            (None, _) => {
                // The piece (or the run) ends inside the contact.
                *s = here;
                *phase = Some(ph);
                return Ok(Md::HertzTouch(wall_of(sw)));
            }
            (Some(1), false) => {
                // ẇ = 0 inside the contact: stick if coulomb can hold the ball, else the
                // sliding friction reverses (as in `hertz::contact`).
                ph.y[3] = 0.0;
                if can_stick(cs.model) && needed(ph.t, &ph.y).abs() <= cs.fl {
                    ph.stuck = true;
                } else {
                    ph.sigma = -ph.sigma;
                }
                continue;
            }
            (Some(j @ (1 | 2)), true) => {
                ph.stuck = false;
                ph.sigma = if j == 1 { -1.0 } else { 1.0 };
                continue;
            }
            _ => {}
        }
        // Released: δ = 0 with δ̇ ≤ 0.
        let before = St {
            w: sw * cs.lg,
            ..here
        };
        book.event(
            cs,
            before.t,
            EventKind::Impact {
                wall: wall_of(sw),
                dw_m_s: sw * ph.approach,
                energy_loss_j: y[4],
            },
            &before,
            &before,
        )?;
        *s = before;
        *phase = None;
        if s.dw == 0.0 {
            return Ok(wall_touch(cs, sw, s));
        }
        return Ok(after_wall_free(sw, s.dw));
    }
}
