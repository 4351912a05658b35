//! The compliant (`hertz`) contact phase on a cutting run of a modal bar (issue #13): the modal
//! phase's right-hand side ([`super::super::hertz::PhaseBar`]) with the cut's force at the force
//! point, run piece by piece as the lumped bar's ([`crate::solver::exact::cutting_hertz`]).
//!
//! During the contact the state `[q₁…q_N, q̇₁…q̇_N, δ, δ̇, W_c]` is integrated by [`Dopri5`]
//! (relative tolerance `CONTACT_RTOL`, or the run's own for a convergence study, the scales of the modal phase) with
//!
//! `mₙq̈ₙ + cₙq̇ₙ + kₙqₙ = φₙ(x_f)(F(t) + F_cut) + φₙ(x_d)(s P − F_ball)`,  `m_d v̈ = −s P + F_ball`,
//!
//! `F_cut = Cutting::force_on_bar_n(h)` in the cut (0 out of it; the one definition of the force
//! law), `h = h0 + c_chip (d(τ) − u_f)`, `u_f = Σφₙ(x_f)qₙ`, `d` the delayed surface's quadratic
//! over the piece (the one the closed-form pieces use). The phase stops at the piece's end (a
//! breakpoint `t_k + T` or the piece-length limit), its integrator state kept in [`Phase`], and
//! resumes on the next piece with that piece's quadratic. The chip (`h` in the cut, `−h` out of
//! it) is an event function located on the dense output: the sub-piece ends there, the driver
//! stores the surface's kink and the breakpoint as on every cut event, and the phase goes on with
//! the other force. Each accepted step is a `Mode::Contact` segment carrying the chip and the
//! cutting force, its integrals and cutting work Gauss–Legendre quadratures of the dense output,
//! and a knot of the surface history at its end (the force point's `u_f`, `u̇_f` in the cut, the
//! carried surface out of it). The release is an [`EventKind::Impact`] carrying the contact's
//! dissipated work `W_c`, so the books close with the cutting work to the integrator's tolerance.
//!
//! The approach-speed floor of the damping's reference (`APPROACH_FLOOR_REL·l_g·max(Ω, ω_d)`)
//! takes `ω_d` of the first mode with the piece's stiffness at the touch (`k₁ + k_c φ₁(x_f)²` in
//! the cut), which on one mode is the lumped phase's.

use super::super::hertz::{PhaseBar, NY, Y};
use super::{energy_j, Book, Consts, Run, St, GL8, NM};
use crate::damper::contact::Hertz;
use crate::damper::friction::can_stick;
use crate::error::SimError;
use crate::excitation::Cutting;
use crate::solver::dopri5::{DenseStep, Dopri5};
use crate::solver::exact::driver::{after_wall_free, wall_of, wall_touch, Md};
use crate::solver::exact::hertz::APPROACH_FLOOR_REL;
use crate::solver::exact::hertz_phase::{count_steps, run_phase, ContactPhase, Event};
use crate::solver::{CutSample, EventKind, Mode, Segment, SegmentIntegrals};

/// A contact phase interrupted at a piece end or a cut event, to resume on the next piece.
pub(super) type Phase = ContactPhase<NY>;

/// The cut over a sub-piece: the chip and the force from the piece's quadratic.
#[derive(Debug, Clone, Copy)]
struct CutOver {
    cut: Cutting,
    in_cut: bool,
    d: [f64; 3],
    h0: f64,
    c_chip: f64,
    /// Origin of `d(τ)`, `τ = t − t_ref`.
    t_ref: f64,
}

impl CutOver {
    fn chip(&self, t: f64, uf: f64) -> f64 {
        let x = t - self.t_ref;
        let d = self.d[0] + x * (self.d[1] + x * self.d[2]);
        self.h0 + self.c_chip * (d - uf)
    }
    /// `Cutting::force_on_bar_n` in the cut (the mode chooses, not the sign of `h`: the switch
    /// is located), 0 out of it.
    fn force(&self, t: f64, uf: f64) -> f64 {
        if self.in_cut {
            self.cut.force_on_bar_n(self.chip(t, uf))
        } else {
            0.0
        }
    }
}

/// The force point's displacement of a phase state.
fn uf_of(cs: &Consts, y: &Y) -> f64 {
    let mut s = 0.0;
    for i in 0..cs.n {
        s += cs.phi_f[i] * y[i];
    }
    s
}

/// The solver's state of a phase state `y` at `t`.
fn st_of(cs: &Consts, sw: f64, t: f64, y: &Y) -> St {
    let n = cs.n;
    let mut s = St {
        t,
        q: [0.0; NM],
        dq: [0.0; NM],
        w: sw * (cs.lg + y[2 * n]),
        dw: sw * y[2 * n + 1],
    };
    s.q[..n].copy_from_slice(&y[..n]);
    s.dq[..n].copy_from_slice(&y[n..2 * n]);
    s
}

/// One accepted step of a contact phase on a cutting run, as a segment.
struct CutContactSegment<'a> {
    step: &'a DenseStep<NY>,
    th_end: f64,
    cs: &'a Consts,
    sw: f64,
    fb: f64,
    law: &'a Hertz,
    over: CutOver,
}

impl CutContactSegment<'_> {
    fn y_at(&self, t: f64) -> Y {
        let th = ((t - self.step.t0) / self.step.h).clamp(0.0, self.th_end);
        self.step.at_theta(th)
    }
    /// `∫_a^b f` by 8-point Gauss–Legendre over the step's dense output (degree 4).
    fn quad<const K: usize>(&self, a: f64, b: f64, f: impl Fn(f64, &Y) -> [f64; K]) -> [f64; K] {
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
    fn duf(&self, y: &Y) -> f64 {
        let n = self.cs.n;
        let mut s = 0.0;
        for i in 0..n {
            s += self.cs.phi_f[i] * y[n + i];
        }
        s
    }
}

impl Segment for CutContactSegment<'_> {
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
        st_of(self.cs, self.sw, t_s, &self.y_at(t_s)).public(self.cs)
    }
    fn integral_u2(&self, a_s: f64, b_s: f64) -> f64 {
        let cs = self.cs;
        self.quad(a_s, b_s, |_, y| {
            let mut ur = 0.0;
            for i in 0..cs.n {
                ur += cs.phi_r[i] * y[i];
            }
            [ur * ur]
        })[0]
    }
    fn integrals(&self, a_s: f64, b_s: f64) -> SegmentIntegrals {
        // The forcing work is the static and harmonic force's; the cut's is `cutting_work_j`.
        let cs = self.cs;
        let n = cs.n;
        let [u2, fw, vl] = self.quad(a_s, b_s, |t, y| {
            let (mut ur, mut visc) = (0.0, 0.0);
            for i in 0..n {
                ur += cs.phi_r[i] * y[i];
                visc += cs.c[i] * y[n + i] * y[n + i];
            }
            [ur * ur, (cs.fs + cs.harmonic(t)) * self.duf(y), visc]
        });
        SegmentIntegrals {
            u2_m2_s: u2,
            forcing_work_j: fw,
            viscous_loss_j: vl,
            friction_work_j: if self.fb == 0.0 {
                0.0
            } else {
                self.fb * self.sw * (self.y_at(b_s)[2 * n] - self.y_at(a_s)[2 * n])
            },
        }
    }
    fn mechanical_energy_j(&self, t_s: f64) -> f64 {
        let y = self.y_at(t_s);
        energy_j(self.cs, &st_of(self.cs, self.sw, t_s, &y), true)
            + self.law.elastic_energy_j(y[2 * self.cs.n])
    }
    fn cutting_at(&self, t_s: f64) -> Option<CutSample> {
        let uf = uf_of(self.cs, &self.y_at(t_s));
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
        let cs = self.cs;
        self.quad(a_s, b_s, |t, y| {
            [self.over.force(t, uf_of(cs, y)) * self.duf(y)]
        })[0]
    }
}

/// How a sub-piece of a contact phase ended.
pub(super) struct PieceEnd {
    /// The next mode: [`Md::HertzTouch`] while the contact goes on.
    pub(super) mode: Md,
    /// The tool left or re-entered the cut at the end (the driver stores the cut event).
    pub(super) cut_event: bool,
}

/// The contact phase at wall `sw` over one sub-piece of a modal cutting run: from `s` (a touch,
/// or where `phase` stopped) to `t_stop`, to a cut event (the phase kept), or to the release.
/// `d` is the delayed surface's quadratic from `s.t`; `order` is 1 right after a located cut
/// event (the chip then starts at its zero, on either side by rounding).
#[allow(clippy::too_many_arguments)]
pub(super) fn contact_piece(
    run: &mut Run,
    law: &Hertz,
    cut: &Cutting,
    sw: f64,
    phase: &mut Option<Phase>,
    s: &mut St,
    t_stop: f64,
    in_cut: bool,
    d: [f64; 3],
    order: usize,
    book: &mut Book,
) -> Result<PieceEnd, SimError> {
    let cs = &run.cs;
    let n = cs.n;
    let (id, idd, iw) = (2 * n, 2 * n + 1, 2 * n + 2);
    let over = CutOver {
        cut: *cut,
        in_cut,
        d,
        h0: cs.h0,
        c_chip: cs.c_chip,
        t_ref: s.t,
    };
    let meff = 1.0 / cs.kappa;
    let mut ph = match phase.take() {
        Some(p) if p.t.to_bits() == s.t.to_bits() => p,
        _ => {
            // A touch: `s.w = sw·l_g`, `s.dw` the approach velocity (or 0, resting).
            let approach = (sw * s.dw).max(0.0);
            let k1 = cs.k[0]
                + if in_cut {
                    cs.kc * cs.phi_f[0] * cs.phi_f[0]
                } else {
                    0.0
                };
            let al = cs.c[0] / (2.0 * cs.m[0]);
            let wd = (k1 / cs.m[0] - al * al).sqrt();
            let floor = APPROACH_FLOOR_REL * cs.lg * cs.om.max(wd);
            let v0 = approach.max(floor);
            let mut y: Y = [0.0; NY];
            y[..n].copy_from_slice(&s.q[..n]);
            y[n..2 * n].copy_from_slice(&s.dq[..n]);
            y[idd] = approach;
            Phase {
                t: s.t,
                y,
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
    let cut_sign = if in_cut { 1.0 } else { -1.0 };
    let margin = |t: f64, y: &Y| cut_sign * over.chip(t, uf_of(cs, y));
    // Not right after a located cut event: a piece that starts on the other side of the chip's
    // zero (the delayed surface's kink at a breakpoint) switches the force at once.
    if order == 0 && margin(ph.t, &ph.y) < 0.0 {
        *phase = Some(ph);
        return Ok(PieceEnd {
            mode: Md::HertzTouch(wall_of(sw)),
            cut_event: true,
        });
    }
    let v0 = ph.v0;
    let rtol = cs.contact_rtol;
    let d_scale = law.with_damping(0.0).max_penetration_m(meff, v0);
    let v_scale = v0.max(cs.lg * cs.om);
    let mut atol = [0.0; NY];
    for i in 0..n {
        atol[i] = rtol * cs.lg;
        atol[n + i] = rtol * v_scale;
    }
    atol[id] = rtol * d_scale;
    atol[idd] = rtol * v_scale;
    atol[iw] = rtol * 0.5 * meff * v_scale * v_scale;
    let ig = Dopri5::<NY> {
        rtol,
        atol,
        len: 2 * n + 3,
    };
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
    // The force at the force point: static, harmonic and the cut's.
    let force_at = |t: f64, y: &Y| cs.fs + cs.harmonic(t) + over.force(t, uf_of(cs, y));
    let needed = |t: f64, y: &Y| bar.needed(law, sw, force_at(t, y), y);
    let hist = &mut *run.hist;
    loop {
        let (stuck, sigma) = (ph.stuck, ph.sigma);
        let fb = if stuck { 0.0 } else { cs.fb(sigma) };
        let mut f = |t: f64, y: &Y| bar.rhs(law, v0, sw, stuck, fb, force_at(t, y), y);
        // Events: 0 release (δ < 0); sliding with friction: 1 δ̇ crosses 0; stuck: 1, 2 the
        // friction needed leaves [−f, f]; last: the chip's margin.
        let dsign = if sw * sigma >= 0.0 { 1.0 } else { -1.0 };
        let release = Event::Comp { i: id, sign: 1.0 };
        let switch = Event::Comp {
            i: idd,
            sign: dsign,
        };
        let lag = |t: f64, y: &Y| cs.fl - needed(t, y);
        let lead = |t: f64, y: &Y| cs.fl + needed(t, y);
        let chip = Event::Fn(&margin);
        let slide_ev: [Event<'_, NY>; 3] = [release, switch, chip];
        let frictionless_ev: [Event<'_, NY>; 2] = [release, chip];
        let stuck_ev: [Event<'_, NY>; 4] = [release, Event::Fn(&lag), Event::Fn(&lead), chip];
        let events: &[Event<'_, NY>] = if stuck {
            &stuck_ev
        } else if cs.frictional() {
            &slide_ev
        } else {
            &frictionless_ev
        };
        let chip_ev = events.len() - 1;
        let (mut h, mut max_pen) = (ph.h, ph.max_pen);
        let end = run_phase(&ig, &mut f, ph.t, ph.y, ph.h, t_stop, events, |st, th| {
            for j in 0..=4 {
                max_pen = max_pen.max(st.comp(id, th * j as f64 / 4.0));
            }
            let seg = CutContactSegment {
                step: st,
                th_end: th,
                cs,
                sw,
                fb,
                law,
                over,
            };
            let t1 = seg.t_end_s();
            if t1 > seg.t_start_s() {
                book.obs.segment(&seg);
                // The surface knot at the step end.
                if in_cut {
                    let y1 = seg.y_at(t1);
                    hist.record(t1, uf_of(cs, &y1), seg.duf(&y1));
                } else {
                    hist.record_out_of_cut(t1);
                }
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
        if ph.max_pen > book.summary.max_penetration_m {
            book.summary.max_penetration_m = ph.max_pen;
        }
        let here = st_of(cs, sw, end.t, &end.y);
        match (end.which, stuck) {
            (Some(j), _) if j == chip_ev => {
                // The tool left or re-entered the cut: the driver stores the event; the phase
                // goes on with the other force.
                *s = here;
                *phase = Some(ph);
                return Ok(PieceEnd {
                    mode: Md::HertzTouch(wall_of(sw)),
                    cut_event: true,
                });
            }
            (None, _) => {
                // The piece (or the run) ends inside the contact.
                *s = here;
                *phase = Some(ph);
                return Ok(PieceEnd {
                    mode: Md::HertzTouch(wall_of(sw)),
                    cut_event: false,
                });
            }
            (Some(1), false) => {
                // ẇ = 0 inside the contact: stick if coulomb can hold the ball, else the
                // sliding friction reverses.
                ph.y[idd] = 0.0;
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
        ph.y[id] = 0.0;
        let at = st_of(cs, sw, ph.t, &ph.y);
        let (approach, w_c) = (ph.approach, ph.y[iw]);
        *phase = None;
        *s = at;
        run.event(
            EventKind::Impact {
                wall: wall_of(sw),
                dw_m_s: sw * approach,
                energy_loss_j: w_c,
            },
            &at,
            &at,
            in_cut,
            book,
        )?;
        let x = s.t - run.tau;
        let d0 = run.hist.value_slope(x).0;
        let mode = if s.dw == 0.0 {
            let k = super::CutKernel::new(run, book, in_cut, d, order, d0);
            wall_touch(&k, sw, s)
        } else {
            after_wall_free(sw, s.dw)
        };
        return Ok(PieceEnd {
            mode,
            cut_event: false,
        });
    }
}
