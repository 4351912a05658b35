//! The compliant (`hertz`) contact phase, written once for every bar ([`contact`]), and its
//! integrator: adaptive [`Dopri5`] steps on a fixed-size state, each accepted step handed on
//! with its dense output, until an event component falls below 0 (located on the dense
//! output), with a bound on the work ([`run_phase`]).
//!
//! When free flight reaches a wall (`w = s·l_g`), the ball and the bar are coupled by the
//! contact force `P` of [`crate::damper::contact`] along the contact row: with the penetration
//! `δ = s·w − l_g ≥ 0`, the bar feels `s P − F_ball` at the cavity and the ball `−s P + F_ball`,
//! `F_ball` the sliding friction with `σ = sgn ẇ`. Friction keeps acting during the contact,
//! its sign switching where `ẇ` crosses 0 (located on the dense output, the phase restarts
//! there); under `coulomb` the ball sticks there while the friction it needs to move with the
//! bar, `F_ball = m_d ü_pair + s P(δ, 0)`, stays within `F`, and slides again when it leaves
//! `[−F, F]`. The phase state is the bar's (its [`CompliantBar`]), then `δ`, `δ̇` and
//! `W_c = ∫ P_damp δ̇ dt` (the contact's dissipation); it ends where `δ` falls below 0 (force and
//! penetration vanish together). Each accepted step is a segment (`Mode::Contact`) whose
//! mechanical energy includes the elastic energy `(2/5) K_h δ^{5/2}`; the end of the contact is
//! reported as an [`EventKind::Impact`] with the approach speed and `W_c` as its energy loss,
//! so impact counts and the energy books keep their meaning.

use super::driver::{after_wall_free, wall_of, wall_touch, BallState, Cavity, Md};
use super::hertz::APPROACH_FLOOR_REL;
use crate::damper::contact::Hertz;
use crate::damper::friction::can_stick;
use crate::error::SimError;
use crate::solver::dopri5::{first_sign_change, DenseStep, Dopri5};
use crate::solver::EventKind;

/// Most integrator steps (accepted or rejected) one contact phase may take. A contact of the
/// paper's ball takes ~30–60; a ball resting on a wall for a whole bar period a few thousand.
pub const MAX_CONTACT_STEPS: u64 = 200_000;

/// Sub-intervals scanned per step for a sign change of an event component (≥ 5: the dense
/// output is a degree-4 polynomial, see [`first_sign_change`]).
const EVENT_SAMPLES: usize = 8;

/// An event function of the phase: it ends where `g(t, y)` falls below 0.
pub type EventFn<'a, const N: usize> = &'a dyn Fn(f64, &[f64; N]) -> f64;

/// An event of the phase: where `g` falls below 0.
#[derive(Clone, Copy)]
pub enum Event<'a, const N: usize> {
    /// `g = sign·y[i]`: one component. A step where [`DenseStep::comp_bounds`] keeps it
    /// positive is skipped without sampling (most steps of a contact: the penetration is far
    /// from 0), and the samples read that one component; the event found is the same.
    Comp {
        /// Component.
        i: usize,
        /// `±1`.
        sign: f64,
    },
    /// Any function of the state.
    Fn(EventFn<'a, N>),
}

/// How a phase ended: at event `which` (index into the events given), at `t_end` of the run
/// (`which = None`).
#[derive(Debug, Clone, Copy)]
pub struct PhaseEnd<const N: usize> {
    /// Time of the end.
    pub t: f64,
    /// State there.
    pub y: [f64; N],
    /// Event that ended it, if any.
    pub which: Option<usize>,
    /// Steps taken (accepted and rejected).
    pub steps: u64,
}

/// One [`run_phase`] call of a phase that restarts (friction switches, stick, cut pieces):
/// its steps added to the phase's `total`, and the step limit, of the call or of the whole
/// phase, reported at the phase's touch `t_touch_s` (one rule for every compliant solver).
pub fn count_steps<const N: usize>(
    end: Result<PhaseEnd<N>, SimError>,
    total: &mut u64,
    t_touch_s: f64,
) -> Result<PhaseEnd<N>, SimError> {
    let limit = || SimError::ContactStepLimit {
        t_s: t_touch_s,
        steps: MAX_CONTACT_STEPS,
    };
    let end = end.map_err(|e| match e {
        SimError::ContactStepLimit { .. } => limit(),
        e => e,
    })?;
    *total += end.steps;
    if *total > MAX_CONTACT_STEPS {
        return Err(limit());
    }
    Ok(end)
}

/// Integrate `y' = f(t, y)` from `(t0, y0)` with first step `h0` until the first event: event
/// `k` is `events[k](t, y)` falling below 0 (each is `≥ 0` at the start), or until `t_end`. Every accepted step is passed to `on_step` with the fraction `θ_end ∈ (0, 1]` of it
/// that belongs to the phase. No allocation.
#[allow(clippy::too_many_arguments)]
pub fn run_phase<const N: usize, F, S>(
    ig: &Dopri5<N>,
    f: &mut F,
    t0: f64,
    y0: [f64; N],
    h0: f64,
    t_end: f64,
    events: &[Event<'_, N>],
    mut on_step: S,
) -> Result<PhaseEnd<N>, SimError>
where
    F: FnMut(f64, &[f64; N]) -> [f64; N],
    S: FnMut(&DenseStep<N>, f64),
{
    let (mut t, mut y, mut h) = (t0, y0, h0);
    let mut f0 = f(t, &y);
    let mut steps = 0u64;
    loop {
        steps += 1;
        if steps > MAX_CONTACT_STEPS {
            return Err(SimError::ContactStepLimit {
                t_s: t0,
                steps: MAX_CONTACT_STEPS,
            });
        }
        let last = t + h >= t_end;
        let hh = if last { t_end - t } else { h };
        let a = ig.attempt(f, t, &y, &f0, hh);
        if a.err > 1.0 {
            h = Dopri5::<N>::next_h(hh, a.err);
            if h <= 4.0 * f64::EPSILON * t.abs().max(1e-300) || !h.is_finite() {
                return Err(SimError::NonFinite { t_s: t });
            }
            continue;
        }
        let st = &a.step;
        // The earliest event inside the step.
        let mut best: Option<(f64, usize)> = None;
        for (k, ev) in events.iter().enumerate() {
            let found = match *ev {
                Event::Comp { i, sign } => {
                    let (lo, hi) = st.comp_bounds(i);
                    if (sign > 0.0 && lo > 0.0) || (sign < 0.0 && hi < 0.0) {
                        None
                    } else {
                        first_sign_change(|th| sign * st.comp(i, th), EVENT_SAMPLES)
                    }
                }
                Event::Fn(g) => {
                    first_sign_change(|th| g(st.t0 + th * st.h, &st.at_theta(th)), EVENT_SAMPLES)
                }
            };
            if let Some(th) = found {
                if best.is_none_or(|(b, _)| th < b) {
                    best = Some((th, k));
                }
            }
        }
        if let Some((th, k)) = best {
            on_step(st, th);
            let ye = st.at_theta(th);
            return Ok(PhaseEnd {
                t: st.t0 + th * st.h,
                y: ye,
                which: Some(k),
                steps,
            });
        }
        on_step(st, 1.0);
        t = if last { t_end } else { t + hh };
        y = st.y1;
        f0 = a.f1;
        if last {
            return Ok(PhaseEnd {
                t,
                y,
                which: None,
                steps,
            });
        }
        h = Dopri5::<N>::next_h(hh, a.err);
    }
}

/// The length of an N-mode bar's phase state at the largest mode count: `N` displacements,
/// `N` velocities, `δ`, `δ̇`, `W_c`.
pub(super) const MODAL_PHASE_LEN: usize = 2 * crate::limits::MAX_BEAM_MODES + 3;

/// A contact phase interrupted at a piece end or a cut event of a cutting run (or at the end of
/// a run kept to be continued), to resume where it stopped.
#[derive(Debug, Clone, Copy)]
pub(super) struct ContactPhase<const N: usize> {
    /// Where it stopped (`t` is the driver's `s.t` to the bit).
    pub(super) t: f64,
    /// The phase state there.
    pub(super) y: [f64; N],
    /// Step size to try next.
    pub(super) h: f64,
    /// The approach speed (reported at the release) and the damping's reference `δ̇₀`.
    pub(super) approach: f64,
    pub(super) v0: f64,
    /// Friction: sliding sign, stuck (coulomb).
    pub(super) sigma: f64,
    pub(super) stuck: bool,
    pub(super) max_pen: f64,
    pub(super) steps: u64,
    /// The touch time (named by the step-limit error).
    pub(super) t_touch: f64,
}

impl<const N: usize> ContactPhase<N> {
    /// The phase from the touch `s` at wall `sw` (`s.w = sw·l_g`, `s.dw` the approach velocity,
    /// or 0 resting): `δ = 0`, the damping's reference speed the approach speed held at its
    /// floor, a first step of a fiftieth of the undamped contact time, and friction sliding
    /// with `σ = sgn ẇ = sw·sgn δ̇` (at the touch `δ̇ ≥ 0`, pressed in: `σ = sw`).
    pub(super) fn touch<C: CompliantBar<N>>(cs: &C, law: &Hertz, sw: f64, s: &C::St) -> Self {
        let approach = (sw * s.dw()).max(0.0);
        let floor = APPROACH_FLOOR_REL * cs.half_gap_m() * cs.omegas().1;
        let v0 = approach.max(floor);
        ContactPhase {
            t: s.t(),
            y: cs.phase_state(s, approach),
            h: law.undamped_contact_time_s(cs.contact_mass_kg(), v0) / 50.0,
            approach,
            v0,
            sigma: if cs.frictional() { sw } else { 0.0 },
            stuck: false,
            max_pen: 0.0,
            steps: 0,
            t_touch: s.t(),
        }
    }

    /// The phase's integrator: the scales of its tolerances are the impact's own penetration
    /// and speed, and the bar's motion.
    pub(super) fn integrator<C: CompliantBar<N>>(&self, cs: &C, law: &Hertz) -> Dopri5<N> {
        let meff = cs.contact_mass_kg();
        let d_scale = law.with_damping(0.0).max_penetration_m(meff, self.v0);
        let v_scale = self.v0.max(cs.half_gap_m() * cs.omegas().0);
        cs.integrator(d_scale, v_scale)
    }

    /// The phase from where it stands up to `t_end` or its first event ([`run_phase`]), its
    /// state, step, steps and largest penetration (`δ` in slot `id`) updated. Each accepted
    /// step goes to `on_step`, which says whether its size is a guide to the next.
    pub(super) fn advance<F, S>(
        &mut self,
        ig: &Dopri5<N>,
        f: &mut F,
        t_end: f64,
        events: &[Event<'_, N>],
        id: usize,
        mut on_step: S,
    ) -> Result<PhaseEnd<N>, SimError>
    where
        F: FnMut(f64, &[f64; N]) -> [f64; N],
        S: FnMut(&DenseStep<N>, f64) -> bool,
    {
        let (mut h, mut max_pen) = (self.h, self.max_pen);
        let end = run_phase(ig, f, self.t, self.y, self.h, t_end, events, |st, th| {
            for k in 0..=4 {
                max_pen = max_pen.max(st.comp(id, th * k as f64 / 4.0));
            }
            if on_step(st, th) {
                h = st.h;
            }
        });
        let end = count_steps(end, &mut self.steps, self.t_touch)?;
        (self.h, self.max_pen, self.t, self.y) = (h, max_pen, end.t, end.y);
        Ok(end)
    }

    /// The events of the phase (the first `n` of the array): 0 the release (`δ < 0`); sliding
    /// with friction, 1 `δ̇` crossing 0 (the sign of `ẇ`); stuck, 1 and 2 the friction needed
    /// leaving `[−f, f]` (`lag = f − needed`, `lead = f + needed`); last, `extra` if any.
    pub(super) fn events<'a, C: CompliantBar<N>>(
        &self,
        cs: &C,
        sw: f64,
        lag: EventFn<'a, N>,
        lead: EventFn<'a, N>,
        extra: Option<Event<'a, N>>,
    ) -> ([Event<'a, N>; 4], usize) {
        let (id, idd, _) = cs.slots();
        let mut ev = [Event::Comp { i: id, sign: 1.0 }; 4];
        let mut n = 1;
        if self.stuck {
            (ev[1], ev[2], n) = (Event::Fn(lag), Event::Fn(lead), 3);
        } else if cs.frictional() {
            let sign = if sw * self.sigma >= 0.0 { 1.0 } else { -1.0 };
            (ev[1], n) = (Event::Comp { i: idd, sign }, 2);
        }
        if let Some(e) = extra {
            ev[n] = e;
            n += 1;
        }
        (ev, n)
    }

    /// The phase stopped at event `which` of [`ContactPhase::events`] (the extra one already
    /// handled): a change of friction, and the phase goes on (`true`). At `ẇ = 0` inside the
    /// contact the ball sticks if coulomb can hold it (the friction `needed` within `f`), else the
    /// sliding friction reverses; stuck, where friction can no longer hold, the ball slides the
    /// way the needed force pulls (`F_ball = −f sgn ẇ` = the sign of the needed force at the
    /// limit, so `ẇ` against it).
    pub(super) fn friction_switch<C: CompliantBar<N>>(
        &mut self,
        cs: &C,
        which: Option<usize>,
        needed: impl Fn(f64, &[f64; N]) -> f64,
    ) -> bool {
        match (which, self.stuck) {
            (Some(1), false) => {
                self.y[cs.slots().1] = 0.0;
                if can_stick(cs.friction_model())
                    && needed(self.t, &self.y).abs() <= cs.friction_level_n()
                {
                    self.stuck = true;
                } else {
                    self.sigma = -self.sigma;
                }
                true
            }
            (Some(k @ (1 | 2)), true) => {
                self.stuck = false;
                self.sigma = if k == 1 { -1.0 } else { 1.0 };
                true
            }
            _ => false,
        }
    }
}

/// The bar's side of a compliant contact phase with a phase state of `N` components: its
/// right-hand side, the friction the ball needs to move with it, and the solver's state of a
/// phase state.
pub(super) trait CompliantBar<const N: usize>: Cavity {
    /// Where `δ`, `δ̇` and `W_c` sit in the phase state.
    fn slots(&self) -> (usize, usize, usize);
    /// The scales of the approach floor and the velocity tolerance: `(Ω, max(Ω, ω_d,1))`.
    fn omegas(&self) -> (f64, f64);
    /// The effective mass of the contact (the bar's at the cavity against the ball).
    fn contact_mass_kg(&self) -> f64;
    /// The integrator with the tolerances of a contact whose penetration and speed scales are
    /// `d_scale`, `v_scale`.
    fn integrator(&self, d_scale: f64, v_scale: f64) -> Dopri5<N>;
    /// The phase state at the touch `s` with the approach speed `approach` (`δ = 0`).
    fn phase_state(&self, s: &Self::St, approach: f64) -> [f64; N];
    /// The external force at `t`.
    fn force_at(&self, t: f64) -> f64;
    /// `ẏ` at wall `sw`: stuck (the ball held, `δ` frozen) or sliding with the friction `fb` on
    /// the ball; `v0` the damping's reference speed, `force` the external force.
    #[allow(clippy::too_many_arguments)]
    fn rhs(
        &self,
        law: &Hertz,
        v0: f64,
        sw: f64,
        stuck: bool,
        fb: f64,
        force: f64,
        y: &[f64; N],
    ) -> [f64; N];
    /// The friction the ball needs to move with the bar, `m_d ü_pair + sw·P(δ, 0)`.
    fn needed(&self, law: &Hertz, sw: f64, force: f64, y: &[f64; N]) -> f64;
    /// The solver's state of the phase state `y` at `t` (`w = sw·(l_g + δ)`).
    fn state_of(&self, sw: f64, t: f64, y: &[f64; N]) -> Self::St;
}

/// The constants of one step of a contact phase, for its segment.
#[derive(Debug, Clone, Copy)]
pub(super) struct PhaseStep {
    /// The wall, `±1`.
    pub sw: f64,
    /// Sliding friction on the ball (0 when stuck).
    pub fb: f64,
    /// `sw·ẇ` at the touch.
    pub approach: f64,
    /// The law's reference speed `δ̇₀`.
    pub v0: f64,
    /// The ball is stuck to the wall by friction.
    pub stuck: bool,
    /// The law.
    pub law: Hertz,
}

/// Where a contact phase reports: its steps as segments, the penetration, the event at its end.
pub(super) trait PhaseBook<C: Cavity, const N: usize> {
    /// An accepted step (the fraction `th_end` of it inside the phase).
    fn step(&mut self, cs: &C, step: &DenseStep<N>, th_end: f64, p: &PhaseStep);
    /// The largest penetration of the phase.
    fn penetration(&mut self, pen_m: f64);
    /// The event at the end of the contact.
    fn event(&mut self, cs: &C, kind: EventKind, at: &C::St) -> Result<(), SimError>;
}

/// The contact phase at wall `sw` from the touch `s` (`s.w = sw·l_g`, `sw·s.dw ≥ 0`). On return
/// `s` is the state at the release (`w = sw·l_g`, `ẇ` leaving) or at `t_end_s`; the next mode,
/// or `None` at the end of the run.
pub(super) fn contact<const N: usize, C, B>(
    cs: &C,
    law: &Hertz,
    sw: f64,
    s: &mut C::St,
    t_end_s: f64,
    book: &mut B,
) -> Result<Option<Md>, SimError>
where
    C: CompliantBar<N>,
    B: PhaseBook<C, N>,
    C::St: Copy,
{
    let (id, _, iw) = cs.slots();
    let mut ph = ContactPhase::touch(cs, law, sw, s);
    let ig = ph.integrator(cs, law);
    let (approach, v0) = (ph.approach, ph.v0);
    let fl = cs.friction_level_n();
    let needed = |t: f64, y: &[f64; N]| cs.needed(law, sw, cs.force_at(t), y);
    loop {
        let (stuck, sigma) = (ph.stuck, ph.sigma);
        let fb = if stuck { 0.0 } else { cs.fb(sigma) };
        // The last `(t, F(t))`: the 6th and 7th stages of a step are both at `t + h`.
        let mut last = (f64::NAN, 0.0);
        let mut f = |t: f64, y: &[f64; N]| {
            let force = if t.to_bits() == last.0.to_bits() {
                last.1
            } else {
                let v = cs.force_at(t);
                last = (t, v);
                v
            };
            cs.rhs(law, v0, sw, stuck, fb, force, y)
        };
        let lag = |t: f64, y: &[f64; N]| fl - needed(t, y);
        let lead = |t: f64, y: &[f64; N]| fl + needed(t, y);
        let (events, ne) = ph.events(cs, sw, &lag, &lead, None);
        let step = PhaseStep {
            sw,
            fb,
            approach,
            v0,
            stuck,
            law: *law,
        };
        let end = ph.advance(&ig, &mut f, t_end_s, &events[..ne], id, |st, th| {
            book.step(cs, st, th, &step);
            true
        })?;
        if ph.friction_switch(cs, end.which, needed) {
            continue;
        }
        let (t, mut y) = (ph.t, ph.y);
        return match end.which {
            Some(_) => {
                // Released: δ = 0 with δ̇ ≤ 0.
                y[id] = 0.0;
                book.penetration(ph.max_pen);
                let at = cs.state_of(sw, t, &y);
                book.event(
                    cs,
                    EventKind::Impact {
                        wall: wall_of(sw),
                        dw_m_s: sw * approach,
                        energy_loss_j: y[iw],
                    },
                    &at,
                )?;
                *s = at;
                Ok(Some(after_release(cs, sw, s)))
            }
            None => {
                // End of the run inside the contact.
                *s = cs.state_of(sw, t, &y);
                Ok(None)
            }
        };
    }
}

/// The next mode after a release at wall `sw` with the state `s` (`w = sw·l_g`): the wall's
/// contact test where the ball leaves at rest relative to the bar, else free flight away from
/// the wall.
pub(super) fn after_release<C: Cavity>(cs: &C, sw: f64, s: &C::St) -> Md {
    if s.dw() == 0.0 {
        wall_touch(cs, sw, s)
    } else {
        after_wall_free(sw, s.dw())
    }
}
