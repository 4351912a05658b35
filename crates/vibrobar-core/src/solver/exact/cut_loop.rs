//! The drive of a cutting run that every bar shares: where the run's surface history starts,
//! where each piece ends (the step length or the next breakpoint `t_k + T`), the window of the
//! delayed surface a piece reads, what a cut event (the tool leaving or re-entering the cut)
//! does to the run (the cut flag, the chip's departure order, the surface's kink and breakpoint,
//! the event limit), the checks of the history, and where the run ended.
//!
//! The bars' own loops ([`super::lumped::cutting`], [`super::modal::cutting`]) keep their
//! arithmetic: how a piece is integrated (closed form, remainder fit, contact phase, DP5) and
//! which quadratic of the delayed surface it takes.
//!
//! The event limit. Both bars count the cut events against the run's limit, per spindle
//! revolution in the error; they differ in what they count them with ([`CutCount`], a constant
//! of each bar's loop, so that each bar's runs stop at the event they always stopped at).

use super::driver::{Md, Tally};
use super::lumped::cutting::{
    CutContinuation, History, CONTINUE_MISMATCH, REMAINDER_MAX_ITERATIONS, REMAINDER_TOL,
};
use crate::error::{EventLimitCause, SimError};
use crate::excitation::Cutting;
use crate::solver::Wall;

/// The error of a run whose surface history overflowed.
pub(super) const HISTORY_FULL: &str = "a cutting run had more events within one spindle \
                                        revolution than its surface history holds \
                                        (solver::exact::cutting::MAX_EVENT_KNOTS)";

/// The error of a run continued on another bar than the run it continues.
pub(super) const CONTINUE_OTHER_BAR: &str =
    "continuing a cutting run: the bar ([bar], or [beam]/[[modes]]) must be the continued run's";

/// How a bar's run counts the cut events against the event limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum CutCount {
    /// On a count of their own, the limit applying to it and to the ball's events apart; the
    /// summary's events are the sum at the end (the lumped bar).
    Apart,
    /// With the ball's events, one limit for the sum (the modal bar).
    WithBall,
}

/// The event limit's error of a cutting run: `count` events by `t`, per revolution `tau` since
/// `t0`.
#[cold]
#[inline(never)]
pub(super) fn too_many_events(count: u64, limit: u64, t: f64, t0: f64, tau: f64) -> SimError {
    SimError::TooManyEvents {
        limit,
        t_s: t,
        events_per_period: count as f64 / ((t - t0) / tau).max(f64::MIN_POSITIVE),
        cause: EventLimitCause::Dense,
    }
}

/// The surface history a run starts with, and whether the tool cuts at the start: `fresh()`
/// on a fresh start, else the history of the run `from` continues (`cap`, `tau`, `shift`, `t0`
/// as for [`History::resumed`]).
pub(super) fn start_history(
    from: Option<&CutContinuation>,
    (cap, tau, shift, t0): (usize, f64, f64, f64),
    fresh: impl FnOnce() -> (bool, History),
) -> Result<(bool, History), SimError> {
    match from {
        None => Ok(fresh()),
        Some(c) => Ok((
            c.in_cut(),
            History::resumed(c, cap, tau, shift, t0)
                .ok_or(SimError::Unsupported(CONTINUE_MISMATCH))?,
        )),
    }
}

/// The `hertz` contact phase under way where a run ended (`mode` its last), and its wall.
pub(super) fn contact_at_end<P>(mode: Md, phase: Option<P>) -> Option<(P, Wall)> {
    match (mode, phase) {
        (Md::HertzTouch(wall), Some(p)) => Some((p, wall)),
        _ => None,
    }
}

/// The cut's side of a run between its pieces.
#[derive(Debug, Clone, Copy)]
pub(super) struct Pieces {
    /// The tool is in the cut.
    pub in_cut: bool,
    /// The chip function's departure order at the next segment start (1 right after a cut
    /// event: the chip starts at its zero).
    pub order: usize,
    t0: f64,
    tau: f64,
    t_end: f64,
    count: CutCount,
    /// Cut events so far ([`CutCount::Apart`]).
    apart: u64,
    /// The time (bits) where the last piece ended and the end of its window: the next piece's
    /// window starts there (exactly `t_k`, not `t − T` in rounding).
    last: Option<(u64, f64)>,
}

impl Pieces {
    /// A run from `t0` to `t_end` of delay `tau`, the tool in the cut or not at the start.
    pub fn new(t0: f64, tau: f64, t_end: f64, in_cut: bool, count: CutCount) -> Pieces {
        Pieces {
            in_cut,
            order: 0,
            t0,
            tau,
            t_end,
            count,
            apart: 0,
            last: None,
        }
    }

    /// The end of the piece from `t` of length `len` at most, the end of its window on the
    /// delayed surface, and the breakpoint's order where it ends at one (the next breakpoint
    /// `t_k + T` inside it).
    #[inline]
    pub fn end(&self, h: &History, t: f64, len: f64) -> (f64, f64, Option<u8>) {
        let e = (t + len).min(self.t_end);
        match h.first_breakpoint() {
            Some((tk, order)) if tk + self.tau < e => (tk + self.tau, tk, Some(order)),
            _ => (e, e - self.tau, None),
        }
    }

    /// Where the window of the delayed surface of a segment from `t` starts: where the last
    /// piece's ended when `t` is that piece's end, else `t − T`.
    #[inline]
    pub fn window_start(&self, t: f64) -> f64 {
        match self.last {
            Some((bits, x)) if bits == t.to_bits() => x,
            _ => t - self.tau,
        }
    }

    /// A piece (up to its breakpoint or step end) done at `t`, its window ending at `win_end`.
    #[inline]
    pub fn piece_done(&mut self, t: f64, win_end: f64) {
        self.last = Some((t.to_bits(), win_end));
    }

    /// After a segment of a piece ended at `t` (at a cut event when `cut_event`): the history
    /// checked, and at a cut event the cut flag turned, the surface's kink stored with the tool's
    /// velocity `du()` and its breakpoint queued, the event counted.
    #[inline]
    pub fn segment_done(
        &mut self,
        h: &mut History,
        tally: &mut Tally,
        cut_event: bool,
        t: f64,
        du: impl FnOnce() -> f64,
    ) -> Result<(), SimError> {
        if h.is_full() {
            return Err(SimError::Unsupported(HISTORY_FULL));
        }
        if !cut_event {
            self.order = 0;
            return Ok(());
        }
        self.in_cut = !self.in_cut;
        self.order = 1;
        h.cut_event(t, self.in_cut, du());
        let count = match self.count {
            CutCount::Apart => {
                self.apart += 1;
                self.apart
            }
            CutCount::WithBall => {
                tally.summary.events += 1;
                tally.summary.events
            }
        };
        if count > tally.max_events {
            return Err(too_many_events(
                count,
                tally.max_events,
                t,
                self.t0,
                self.tau,
            ));
        }
        Ok(())
    }

    /// The run's books at its end: the cut events counted apart added to its events.
    pub fn finish(&self, tally: &mut Tally) {
        tally.summary.events += self.apart;
    }
}

/// The three-quarter law's remainder `R = c_force F(h) − c_force K_f b h` over a segment of the
/// tool from `u0` (in the cut, `d` the delayed surface's quadratic, `len` the segment's planned
/// length) as the quadratic `r0 + r1 τ + r2 τ²` through its values at the segment's start,
/// middle and end: `dry(fit, len)` runs the segment with `fit` (a dry run: no events counted, no
/// observer) and returns the length it reached and the tool's displacement at `len/2` and `len`
/// along it (continued past an event that ends it early) ([`fit_remainder`]).
pub(super) fn remainder_fit(
    cut: &Cutting,
    kfb: f64,
    d: [f64; 3],
    u0: f64,
    len: f64,
    mut dry: impl FnMut(&[f64; 3], f64) -> Result<(f64, f64, f64), SimError>,
) -> Result<[f64; 3], SimError> {
    let (h0, c_chip) = (cut.feed_m, cut.chip_direction_factor);
    let rem = |tau: f64, u: f64| -> f64 {
        let dd = d[0] + tau * (d[1] + tau * d[2]);
        let h = h0 + c_chip * (dd - u);
        cut.force_on_bar_n(h) - kfb * h
    };
    let r0 = rem(0.0, u0);
    let scale = REMAINDER_TOL * (kfb * h0).abs();
    fit_remainder(r0, scale, len, |r, len| {
        let (end, um, u1) = dry(r, len)?;
        Ok((end, rem(0.5 * len, um), rem(len, u1)))
    })
}

/// The fixed-point iteration of the three-quarter law's remainder fit over one piece, shared
/// by every bar's [`remainder_fit`]: from
/// `R` constant at its start value `r0`, `dry(fit, len)` runs the piece with `fit` (a dry run:
/// no events counted, no observer) and returns the length it reached and `R` at `len/2` and
/// `len` along it; the next fit is the quadratic through `r0` and those values. It stops when
/// the fit moves by at most `scale` at the nodes and the piece's end settles, or after
/// [`REMAINDER_MAX_ITERATIONS`] dry runs (keeping the last fit).
fn fit_remainder(
    r0: f64,
    scale: f64,
    mut len: f64,
    mut dry: impl FnMut(&[f64; 3], f64) -> Result<(f64, f64, f64), SimError>,
) -> Result<[f64; 3], SimError> {
    let mut r = [r0, 0.0, 0.0];
    for _ in 0..REMAINDER_MAX_ITERATIONS {
        let (end, rm, r1) = dry(&r, len)?;
        let mut next = [r0, 0.0, 0.0];
        if len > 0.0 {
            next[2] = 2.0 * (r1 - 2.0 * rm + r0) / (len * len);
            next[1] = (r1 - r0) / len - next[2] * len;
        }
        let settled = (0..3).all(|i| {
            let x = [0.0, 0.5, 1.0][i] * len;
            let a = r[0] + x * (r[1] + x * r[2]);
            let b = next[0] + x * (next[1] + x * next[2]);
            (a - b).abs() <= scale
        });
        let same_end = end.to_bits() == len.to_bits();
        r = next;
        if settled && same_end {
            break;
        }
        len = end;
    }
    Ok(r)
}
