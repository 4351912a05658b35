//! The driver of one compliant contact phase: adaptive [`Dopri5`] steps on a fixed-size state,
//! each accepted step handed on with its dense output, until an event component falls below 0
//! (located on the dense output), with a bound on the work.

use crate::error::SimError;
use crate::solver::dopri5::{first_sign_change, DenseStep, Dopri5};

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
