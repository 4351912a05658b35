//! The cutting process as a delay equation (issue #13): the delay stepping as a mode of the
//! lumped bar's exact event loop, not a third copy of it.
//!
//! The cut ([`Cutting`]) acts at the bar's force point (the lumped bar's `u`, positive away from
//! the workpiece). The chip is `h(t) = h0 + c_chip (s(t − T) − u(t))`, `T = 60/n`; while the tool
//! cuts (`h > 0`) the surface is renewed, `s(t) = u(t)`, and the force on the bar is
//! `c_force K_f b h`; out of the cut the force is 0 and `s(t) = s(t − T) + h0/c_chip`.
//!
//! Stepping. The run is cut into pieces no longer than a fraction of the fastest period
//! ([`ExactCutting::steps_per_period`]) that end at every breakpoint `t_k + T` of an event time
//! `t_k` (impacts, stick, release, chatter limits, the tool leaving or re-entering the cut, the
//! start). Over a piece the delayed surface `s(t − T)` is the quadratic through three values of
//! the stored history (Hermite pieces on its knots: values and one-sided velocities, and on the
//! sixth-order surface accelerations, exact at the knots); the breakpoints guarantee that no
//! piece reaches across a stored event. The pieces' ends, the windows, the cut events and their
//! count, and the history's start and end are the drive every bar shares
//! ([`super::super::cut_loop`]); this module is the lumped bar's arithmetic under it and the
//! surface [`History`].
//! With the linear law each piece is then a linear ODE with polynomial forcing, solved in closed
//! form by the same segment code as every other lumped run ([`super::Consts::bar_sum`]): in the
//! cut the stiffness gains `c_force K_f b c_chip`, out of it the bar is free. Its event
//! functions, the chip `±h` with the ball's walls, `ẇ = 0` and force margins, stay exponential
//! sums with polynomials of degree ≤ 2, searched jointly by [`super::roots`] with its
//! no-missed-root argument unchanged. So no impact and no cut event is missed, `|w| ≤ l_g`
//! holds as in every exact run, and the event limit applies (cut events counted against it).
//!
//! Accuracy. The only approximation is the quadratic for the delayed surface over a piece, and
//! the history it is fitted to. Two surfaces:
//!
//! - Fourth order (the three-quarter law, `hertz` contact, the modal bar, and
//!   [`ExactCutting::sixth_order`] `= false`): the history is a cubic Hermite on its knots
//!   (values and one-sided velocities), the quadratic goes through the piece's ends and middle.
//!   Its pointwise error is `O(Δ³)` in the piece length `Δ`, but that error,
//!   `∝ x(x − Δ/2)(x − Δ)`, averages to zero over the piece, and the run converges as `Δ⁴`:
//!   measured order 3.95 over 8–64 pieces per period (test `cutting_convergence_order`); at 32
//!   pieces per period the error in `u` is ~1.8e-11 m against 1e-6 m of motion.
//! - Sixth order (the default of the linear law on the restitution contact law): the knots also
//!   carry the bar's acceleration from either side ([`Segment::acceleration_at`], the closed
//!   form's; out of the cut the carried surface's), the history between them is the quintic
//!   Hermite (`O(Δ⁶)`), and the quadratic interpolates the history at the piece's three Gauss
//!   points: its error `∝ P₃(x)` is orthogonal to every quadratic over the piece, so a piece's
//!   state error is `O(Δ⁷)` and the run's `O(Δ⁶)`. Measured (test
//!   `sixth_order_surface_convergence_order`, the same run): order 5.95, 4.1e-12 m at its
//!   default of 10 pieces per period ([`SIXTH_ORDER_STEPS_PER_PERIOD`]: `steps_per_period`
//!   scaled by 10/32), below the fourth-order surface's 1.8e-11 m at 32. With impacts (the
//!   bench's run, test `pieces_per_period_error_on_the_speed_run`): 1.6e-10 m at the default
//!   against 2.4e-10 m. Three things keep the order: (1) the knot's acceleration from the right
//!   comes from the segment that starts there (it jumps at an impact, entering the cut, and a
//!   revolution after a jump of the surface); (2) a break of the surface at `t_k` is queued as a
//!   breakpoint again at `t_k + T` when the tool is out of the cut there (the surface carries
//!   it as it is) and, for a jump (the start), in the cut too (the bar turns it into a jump of
//!   `ü`, which a piece across `t_k + 2T` would carry as an `O(Δ³)` error; without this the
//!   order through loss of contact fell to ~3); (3) near the cut's boundary, where the chip's
//!   oscillation about the feed exceeds [`NEAR_CUT_BOUNDARY`] of it, the pieces are the
//!   fourth-order length with the ends-and-middle quadratic: the chip is an event function
//!   there, and the Gauss quadratic's pointwise error (`O(Δ³)`, it does not pass through the
//!   piece's ends, so the delayed surface jumps by that much at a piece boundary) on a long
//!   piece would move the tool's leaving and re-entering the cut. Where that jump still moves
//!   the chip's sign at a piece start, the cut event is put there. Through loss of contact
//!   (test `loss_of_contact_converges_with_the_history_order`): 5.8e-10 m at the default
//!   setting against the fourth-order surface's 9.2e-9 m, order 3.73 over the settings 32–256
//!   (the fourth-order 3.73).
//!
//! The energy books close with the cutting work as an entry of their own
//! ([`Segment::cutting_work_j`]; the integrals by Gauss–Legendre quadrature on the pieces).
//!
//! Cost. A run is ~20 000 pieces per simulated second on the paper's bar at 32 pieces per
//! period (~7 000 at the sixth order's 10), so the per-piece work is the run's cost. Each
//! piece's event search is first tried by its first step alone
//! ([`super::roots::first_step_clears`]: the amplitude-bound step at the piece start, where
//! the transcendentals are free); on most pieces that step already covers the piece, which is
//! the full search's own answer, and only the rest run the full search. The transcendentals of
//! the regular piece length (its Gauss nodes for the RMS and the books, its end) are cached
//! for the last two sets of constants (in and out of the cut), and the history's knots are found
//! from the last lookup. All of this gives the same numbers, to the bit, as computing afresh.
//! Measured (`vibrobar bench`, callgrind, example `cutting_speed`): 267M → 150M instructions
//! for the bench's 2 s run on the fourth-order surface, 9.1× the harmonic run of the same bar
//! (16.5M); 80M (4.85×) on the sixth-order surface's fewer pieces. The rest is the event loop's
//! own per-segment work, spread over many small items (a third of the pieces are cut short by
//! an impact or a breakpoint and miss the transcendentals' caches).
//!
//! Memory: the history holds one revolution plus a margin of knots in a ring sized once per run
//! ([`MAX_EVENT_KNOTS`] events per revolution beyond the pieces); beyond it the run stops with an
//! error naming the limit.
//!
//! The three-quarter law with a ball. Its force is the linear law's plus the remainder
//! `R = c_force F(h) − c_force K_f b h` (`O((h − h0)²)` near the feed: the slopes agree at `h0`).
//! Over each piece in the cut `R` is fitted as the quadratic through its values at the piece's
//! start, middle and end ([`super::super::cut_loop::remainder_fit`]), folded into the piece's polynomial forcing, and the
//! piece is solved in closed form by the same segment code, its events (the ball's and the chip's)
//! found by the same root search: so the event guarantees above hold unchanged for the motion the
//! pieces carry. The chip at the middle and end comes from the piece itself, run with the
//! previous fit in a dry run (no events counted, no observer called; it ends where the real piece
//! would, at an impact or at the piece end): a fixed-point iteration from `R` constant at its
//! start value, until the fit moves by less than [`REMAINDER_TOL`] of `c_force K_f b h0` at its
//! nodes and the piece's end settles (at most [`REMAINDER_MAX_ITERATIONS`]; measured on the
//! impacting runs of `three_quarter_with_an_impacting_ball_keeps_momentum_and_books`: mostly 3–5
//! dry runs, ~0.1 % of the pieces reach the cap and keep the last fit). Accuracy contract:
//! the quadratic fit of a smooth `R` has the delayed surface's error, `O(Δ³)` pointwise with a
//! zero mean, and the run converges as `Δ⁴` in the cut (measured 3.93 with 52 impacts, test
//! `three_quarter_with_a_ball_convergence_order`; against the DP5 bar alone with a ball out of
//! reach 2.2e-11 m at 32 and 8.2e-14 m at 128 pieces per period). Near the tool leaving the cut
//! `R ∝ h^{3/4}` has an unbounded slope and the fit only `O(Δ^{3/4})` on the piece next to the
//! chip's zero: through loss of contact the order drops as on the no-ball DP5 path (~1.6 there).
//! The books close with the cutting work of the force the pieces carry (linear part plus fit).
//!
//! Scope: the lumped bar with both contact laws and every friction law, both force laws (the
//! three-quarter law on the bar without a ball by [`super::cutting_nonlinear`]: DP5 steps on the
//! same pieces). Under `[contact] law = hertz` a wall touch starts the compliant phase of
//! [`super::super::hertz_cut`]: DP5 on bar + ball with the cutting force from the piece's delayed
//! surface quadratic, piece by piece (it stops at every piece end and breakpoint and resumes), the
//! tool leaving or re-entering the cut located on its dense output and stored as every cut event
//! is; its accuracy is the contact phase's (rtol 1e-9) on top of the pieces'. A modal bar goes to
//! [`super::modal::cutting`] (both force laws, the three-quarter law by the same remainder fit,
//! [`super::super::cut_loop::remainder_fit`], with or without a ball; both contact laws,
//! `hertz` through [`super::super::hertz_cut`]; kept and continued as here,
//! [`CutContinuation`] carrying the modal state).

use super::{
    advance, initial_mode, Book, CutPiece, CutSeg, Exact, ExactSegment, Md, Search, St, CUT,
    HORIZON,
};
use super::{joint_search, Consts, EventSet, Osc, Trig};
use crate::error::SimError;
use crate::excitation::{Cutting, CuttingForceLaw};
use crate::params::{BarModel, State, System};
use crate::solver::exact::cut_loop::{self, CutCount, Pieces, CONTINUE_OTHER_BAR};
use crate::solver::exact::driver::Tally;
use crate::solver::exact::hertz_cut::{self, CutOver, PieceEnd};
use crate::solver::{Event, Mode, Observer, RunSummary, Segment, SegmentIntegrals, Solver};
use std::cell::{Cell, RefCell};
use std::collections::VecDeque;

/// The sixth-order path takes the fourth-order pieces where the chip's oscillation about the
/// feed exceeds this fraction of the feed (the tool may leave or re-enter the cut soon).
pub const NEAR_CUT_BOUNDARY: f64 = 0.5;

/// Events per revolution the surface history holds beyond its regular pieces.
pub const MAX_EVENT_KNOTS: usize = 1 << 15;

/// Default pieces per period of the fastest motion (the bar in the cut, or the harmonic force).
pub const DEFAULT_STEPS_PER_PERIOD: u32 = 32;

/// A breakpoint source where the surface jumps (a start, a continued run).
const BREAK_JUMP: u8 = 0;
/// A breakpoint source where the surface's slope (or a higher derivative) jumps: an event.
const BREAK_KINK: u8 = 1;
/// A breakpoint source where the surface's acceleration jumps (a jump `T` earlier, in the cut).
const BREAK_ACCEL: u8 = 2;

/// Pieces per period of the sixth-order surface (the linear law on the restitution contact law)
/// at [`DEFAULT_STEPS_PER_PERIOD`]: that path scales `steps_per_period` by this over
/// [`DEFAULT_STEPS_PER_PERIOD`] (pieces 3.2× longer for the same setting, more accurate than
/// the fourth-order paths' at the same setting: see the module doc).
pub const SIXTH_ORDER_STEPS_PER_PERIOD: u32 = 10;

/// The exact solver on a cutting run: [`Exact`]'s event loop with the delay stepping.
///
/// The initial state given to [`Solver::run`] is an offset from the static equilibrium of the
/// cut on a smooth surface (`K u = F_s + c_force F(h0)`, the history the tool at rest there,
/// the ball at rest at the cavity centre): `u_m`, `du_m_s` offset the bar, `v_m − u_m`,
/// `dv_m_s − du_m_s` place the ball relative to the cavity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExactCutting {
    /// Event limit and invariant checks, as for every exact run.
    pub exact: Exact,
    /// The cut.
    pub cutting: Cutting,
    /// Pieces per period of the fastest motion (≥ 4) on the fourth-order surface; the
    /// sixth-order surface takes [`SIXTH_ORDER_STEPS_PER_PERIOD`]/[`DEFAULT_STEPS_PER_PERIOD`]
    /// of them away from the cut's boundary (see the module doc).
    pub steps_per_period: u32,
    /// The sixth-order surface (on by default; it applies to the linear law on the restitution
    /// contact law of a lumped bar, the other runs keep the fourth-order one): see the module
    /// doc, "Accuracy".
    pub sixth_order: bool,
}

impl ExactCutting {
    /// The exact solver with defaults on `cutting`.
    pub fn new(cutting: Cutting) -> ExactCutting {
        ExactCutting {
            exact: Exact::default(),
            cutting,
            steps_per_period: DEFAULT_STEPS_PER_PERIOD,
            sixth_order: true,
        }
    }

    /// The static equilibrium of the cut on a smooth surface of a lumped bar of stiffness
    /// `k`: `u = (F_s + c_force F(h0))/K`.
    pub fn equilibrium_u_m(&self, sys: &System, k: f64) -> f64 {
        (sys.forcing.static_force_n + self.cutting.force_on_bar_n(self.cutting.feed_m)) / k
    }
}

/// One knot of the surface history: time, value and velocity from the left and the right
/// (they differ at an impact, and at a start with an offset), and the acceleration from either
/// side where the run knows it ([`History::quintic`]; NaN where not: the cubic Hermite then).
#[derive(Debug, Clone, Copy)]
struct Knot {
    t: f64,
    s_l: f64,
    ds_l: f64,
    s_r: f64,
    ds_r: f64,
    dds_l: f64,
    dds_r: f64,
}

impl Knot {
    /// A knot without accelerations (the cubic Hermite's).
    fn cubic(t: f64, s_l: f64, ds_l: f64, s_r: f64, ds_r: f64) -> Knot {
        Knot {
            t,
            s_l,
            ds_l,
            s_r,
            ds_r,
            dds_l: f64::NAN,
            dds_r: f64::NAN,
        }
    }
}

/// The quintic Hermite on `[0, 1]` through `y0, y1` with scaled slopes `d0 = h ẏ0`, `d1 = h ẏ1`
/// and scaled accelerations `e0 = h² ÿ0`, `e1 = h² ÿ1`: its coefficients `a0 … a5` in `θ`.
#[inline]
fn quintic_coeffs(y0: f64, d0: f64, e0: f64, y1: f64, d1: f64, e1: f64) -> [f64; 6] {
    let a2 = 0.5 * e0;
    let dv = y1 - y0 - d0 - a2;
    let dd = d1 - d0 - 2.0 * a2;
    let de = e1 - 2.0 * a2;
    [
        y0,
        d0,
        a2,
        10.0 * dv - 4.0 * dd + 0.5 * de,
        -15.0 * dv + 7.0 * dd - de,
        6.0 * dv - 3.0 * dd + 0.5 * de,
    ]
}

/// The machined surface over the last revolution, a ring sized once per run.
pub(in crate::solver::exact) struct History {
    k: VecDeque<Knot>,
    cap: usize,
    /// Overflow of the ring or of the breakpoint queue, reported after the observer call.
    full: bool,
    /// Breakpoint sources `t_k` (the breakpoints are `t_k + T`), in time order.
    bp: VecDeque<(f64, u8)>,
    /// The last segment was in the cut (the surface is renewed there).
    in_cut: bool,
    /// `T`, and the surface's advance `h0/c_chip` per revolution out of the cut.
    tau: f64,
    shift: f64,
    /// The last knot index a lookup found ([`History::locate`]).
    hint: Cell<usize>,
    /// The sixth-order surface: knots carry accelerations (quintic Hermite between them where
    /// both sides have one) and a piece's quadratic interpolates at its Gauss points
    /// ([`History::quadratic`]). Off: the cubic Hermite and the ends-and-middle quadratic.
    quintic: bool,
}

impl History {
    fn push(&mut self, kn: Knot) {
        if let Some(last) = self.k.back_mut() {
            if kn.t <= last.t {
                // The same instant again (an event right at a segment end): the right side.
                last.s_r = kn.s_r;
                last.ds_r = kn.ds_r;
                last.dds_r = kn.dds_r;
                return;
            }
        }
        if self.k.len() == self.cap {
            self.full = true;
            self.k.pop_front();
        }
        self.k.push_back(kn);
    }

    fn breakpoint(&mut self, t: f64) {
        self.queue_breakpoint(t, BREAK_KINK);
    }

    /// Queue the breakpoint source `t` where the surface breaks in its derivative of order
    /// `order` ([`BREAK_JUMP`], [`BREAK_KINK`], [`BREAK_ACCEL`]; the sixth-order path queues a
    /// breakpoint `t_k + T` again: see [`ExactCutting::drive`]).
    fn queue_breakpoint(&mut self, t: f64, order: u8) {
        if self.bp.back().is_some_and(|&b| b.0 >= t) {
            return;
        }
        if self.bp.len() == self.cap {
            self.full = true;
            return;
        }
        self.bp.push_back((t, order));
    }

    /// Drop knots no window can reach any more (keep one at or before `t`).
    fn trim(&mut self, t: f64) {
        while self.k.len() > 2 && self.k[1].t <= t {
            self.k.pop_front();
        }
    }

    /// An empty history of `cap` knots (and breakpoints), delay `tau`, advance `shift`.
    pub(in crate::solver::exact) fn new(cap: usize, in_cut: bool, tau: f64, shift: f64) -> History {
        History {
            k: VecDeque::with_capacity(cap),
            cap,
            full: false,
            bp: VecDeque::with_capacity(cap),
            in_cut,
            tau,
            shift,
            hint: Cell::new(0),
            quintic: false,
        }
    }

    /// The index of the first knot after `x` (`right`) or at/after `x`: the knots' partition
    /// point, found by walking from the last lookup's (the windows move forward a piece at a
    /// time, so a step or two), else by bisection. The same index either way: the only `i`
    /// with every knot before it on one side of `x` and every knot from it on the other.
    fn locate(&self, x: f64, right: bool) -> usize {
        let before = |k: &Knot| if right { k.t <= x } else { k.t < x };
        let n = self.k.len();
        let mut i = self.hint.get().min(n);
        for _ in 0..8 {
            if i > 0 && !before(&self.k[i - 1]) {
                i -= 1;
            } else if i < n && before(&self.k[i]) {
                i += 1;
            } else {
                self.hint.set(i);
                return i;
            }
        }
        let i = self.k.partition_point(before);
        self.hint.set(i);
        i
    }

    /// `s(x)`: from the right at a knot (`right`), else from the left; cubic Hermite between.
    pub(in crate::solver::exact) fn eval(&self, x: f64, right: bool) -> f64 {
        let n = self.k.len();
        let i = self.locate(x, right);
        // `i` is the first knot after x (right) or at/after x (left).
        if !right && i < n && self.k[i].t.to_bits() == x.to_bits() {
            return self.k[i].s_l;
        }
        if i == 0 {
            return self.k[0].s_l;
        }
        let k0 = &self.k[i - 1];
        if i == n {
            // At (or, by rounding, just past) the newest knot.
            return k0.s_r + k0.ds_r * (x - k0.t);
        }
        let k1 = &self.k[i];
        let h = k1.t - k0.t;
        let th = (x - k0.t) / h;
        if let Some(a) = self.quintic_between(k0, k1) {
            return a[0] + th * (a[1] + th * (a[2] + th * (a[3] + th * (a[4] + th * a[5]))));
        }
        let (t2, t3) = (th * th, th * th * th);
        (2.0 * t3 - 3.0 * t2 + 1.0) * k0.s_r
            + (t3 - 2.0 * t2 + th) * h * k0.ds_r
            + (-2.0 * t3 + 3.0 * t2) * k1.s_l
            + (t3 - t2) * h * k1.ds_l
    }

    /// The quintic Hermite's coefficients in `θ` between adjacent knots, where the history is
    /// quintic and both sides carry an acceleration.
    #[inline]
    fn quintic_between(&self, k0: &Knot, k1: &Knot) -> Option<[f64; 6]> {
        if !self.quintic || !k0.dds_r.is_finite() || !k1.dds_l.is_finite() {
            return None;
        }
        let h = k1.t - k0.t;
        Some(quintic_coeffs(
            k0.s_r,
            h * k0.ds_r,
            h * h * k0.dds_r,
            k1.s_l,
            h * k1.ds_l,
            h * h * k1.dds_l,
        ))
    }

    /// The surface's acceleration from the left at `x` (for the knot of a segment out of the
    /// cut): NaN where the history is not quintic there.
    fn accel_left(&self, x: f64) -> f64 {
        let i = self.locate(x, false);
        let n = self.k.len();
        if i < n && self.k[i].t.to_bits() == x.to_bits() {
            return self.k[i].dds_l;
        }
        if i == 0 || i == n {
            return self.k[i.min(n - 1)].dds_r;
        }
        let (k0, k1) = (&self.k[i - 1], &self.k[i]);
        match self.quintic_between(k0, k1) {
            Some(a) => {
                let h = k1.t - k0.t;
                let th = (x - k0.t) / h;
                (2.0 * a[2] + th * (6.0 * a[3] + th * (12.0 * a[4] + th * 20.0 * a[5]))) / (h * h)
            }
            None => f64::NAN,
        }
    }

    /// The surface's velocity from the left at `x` (for the knot of a segment out of the cut).
    fn slope_left(&self, x: f64) -> f64 {
        let i = self.locate(x, false);
        let n = self.k.len();
        if i < n && self.k[i].t.to_bits() == x.to_bits() {
            return self.k[i].ds_l;
        }
        if i == 0 || i == n {
            return self.k[i.min(n - 1)].ds_r;
        }
        let (k0, k1) = (&self.k[i - 1], &self.k[i]);
        let h = k1.t - k0.t;
        let th = (x - k0.t) / h;
        if let Some(a) = self.quintic_between(k0, k1) {
            return (a[1]
                + th * (2.0 * a[2] + th * (3.0 * a[3] + th * (4.0 * a[4] + th * 5.0 * a[5]))))
                / h;
        }
        let t2 = th * th;
        ((6.0 * t2 - 6.0 * th) * k0.s_r
            + (3.0 * t2 - 4.0 * th + 1.0) * h * k0.ds_r
            + (-6.0 * t2 + 6.0 * th) * k1.s_l
            + (3.0 * t2 - 2.0 * th) * h * k1.ds_l)
            / h
    }

    /// The surface's knot at `t` out of the cut: the one a revolution back, advanced by the
    /// feed. A segment end at a breakpoint `t_k + T` lands within rounding of the knot at `t_k`
    /// (`(t_k + T) − T` need not be `t_k`'s bits): there both of its sides (the slope jumps at
    /// a cut event or an impact), not one picked by the rounding; else the Hermite's.
    fn out_of_cut_knot(&self, t: f64) -> Knot {
        let x = t - self.tau;
        let near = 4.0 * f64::EPSILON * t.abs();
        let i = self.k.partition_point(|k| k.t < x - near);
        if let Some(k) = self.k.get(i).filter(|k| k.t <= x + near) {
            return Knot {
                t,
                s_l: k.s_l + self.shift,
                ds_l: k.ds_l,
                s_r: k.s_r + self.shift,
                ds_r: k.ds_r,
                dds_l: k.dds_l,
                dds_r: k.dds_r,
            };
        }
        let s = self.eval(x, false) + self.shift;
        let ds = self.slope_left(x);
        let dds = if self.quintic {
            self.accel_left(x)
        } else {
            f64::NAN
        };
        Knot {
            t,
            s_l: s,
            ds_l: ds,
            s_r: s,
            ds_r: ds,
            dds_l: dds,
            dds_r: dds,
        }
    }

    /// The surface's kink at a cut event at `t` (the knot there): its velocity from the right
    /// is the new side's, the bar's `u̇` entering the cut, the carried surface's leaving it.
    fn cut_event_slope(&mut self, t: f64, du: f64) {
        // The acceleration from the right: entering the cut the bar's, set by the next
        // segment's start (Recorder::segment); leaving it the carried surface's.
        let (ds, dds) = if self.in_cut {
            (du, f64::NAN)
        } else {
            let x = t - self.tau;
            let i = self.k.partition_point(|k| k.t <= x);
            // At or just after a knot: its right side; else the Hermite's slope.
            if i > 0 && self.k[i - 1].t.to_bits() == x.to_bits() {
                (self.k[i - 1].ds_r, self.k[i - 1].dds_r)
            } else {
                (self.slope_left(x), self.accel_left(x))
            }
        };
        let quintic = self.quintic;
        if let Some(last) = self.k.back_mut() {
            if last.t.to_bits() == t.to_bits() {
                last.ds_r = ds;
                if quintic {
                    last.dds_r = dds;
                }
            }
        }
    }

    /// The quadratic `d0 + d1 τ + d2 τ²` through the surface at the window `[a, b]`'s ends and
    /// middle (`τ = x − a`).
    fn quadratic(&self, a: f64, b: f64) -> [f64; 3] {
        let len = b - a;
        if self.quintic && len > 0.0 {
            return self.gauss_quadratic(a, len);
        }
        self.ends_quadratic(a, b)
    }

    /// The quadratic through the surface at the window `[a, b]`'s ends and middle.
    fn ends_quadratic(&self, a: f64, b: f64) -> [f64; 3] {
        let len = b - a;
        let y0 = self.eval(a, true);
        if len <= 0.0 {
            return [y0, 0.0, 0.0];
        }
        let ym = self.eval(a + 0.5 * len, true);
        let y1 = self.eval(b, false);
        let d2 = 2.0 * (y1 - 2.0 * ym + y0) / (len * len);
        let d1 = (y1 - y0) / len - d2 * len;
        [y0, d1, d2]
    }
}

impl History {
    /// The quadratic `d0 + d1 τ + d2 τ²` through the surface at the three Gauss–Legendre points
    /// of the window `[a, a + len]`: its error is the interpolation error `∝ P₃`, orthogonal to
    /// every quadratic over the window, so the piece's state error is `O(Δ⁷)` (not `O(Δ⁵)` as
    /// with the ends and middle) and the run's `O(Δ⁶)` on the quintic history. It does not
    /// pass through the window's ends: the delayed surface jumps by `O(Δ³)` at a piece
    /// boundary (the driver checks the chip's sign there).
    fn gauss_quadratic(&self, a: f64, len: f64) -> [f64; 3] {
        let g = 0.5 * GAUSS3;
        let (x0, x1, x2) = ((0.5 - g) * len, 0.5 * len, (0.5 + g) * len);
        let (f0, f1, f2) = (
            self.eval(a + x0, true),
            self.eval(a + x1, true),
            self.eval(a + x2, true),
        );
        // Newton's form about x0, x1, then the monomials in τ.
        let d01 = (f1 - f0) / (x1 - x0);
        let d12 = (f2 - f1) / (x2 - x1);
        let c2 = (d12 - d01) / (x2 - x0);
        [f0 - x0 * (d01 - c2 * x1), d01 - c2 * (x0 + x1), c2]
    }
}

/// `√(3/5)`: the 3-point Gauss–Legendre nodes on `[−1, 1]` are `0, ±√(3/5)`.
const GAUSS3: f64 = 0.774_596_669_241_483_4;

/// The history's interface for the modal cutting run ([`super::modal::cutting`]), which keeps
/// its own event loop and records the knots itself (the force point's `u` is not the public
/// state's).
impl History {
    /// The smooth surface of the tool at rest at `u_eq` up to `t0`, its right side at `t0` the
    /// start's (`u0`, `du0` in the cut, else the surface advanced by `shift`); `t0` a breakpoint.
    #[allow(clippy::too_many_arguments)]
    pub(in crate::solver::exact) fn smooth(
        cap: usize,
        tau: f64,
        shift: f64,
        t0: f64,
        u_eq: f64,
        in_cut: bool,
        u0: f64,
        du0: f64,
    ) -> History {
        let mut h = History::new(cap, in_cut, tau, shift);
        let (s_r, ds_r) = if in_cut {
            (u0, du0)
        } else {
            (u_eq + shift, 0.0)
        };
        h.push(Knot::cubic(t0 - 2.0 * tau, u_eq, 0.0, u_eq, 0.0));
        h.push(Knot::cubic(t0, u_eq, 0.0, s_r, ds_r));
        // The start is an event of the history (an offset jumps the surface).
        h.queue_breakpoint(t0, BREAK_JUMP);
        h
    }

    /// Store the surface `s`, `ṡ` at `t` (both sides).
    pub(in crate::solver::exact) fn record(&mut self, t: f64, s: f64, ds: f64) {
        self.push(Knot::cubic(t, s, ds, s, ds));
    }

    /// The right side at the newest knot, when it is at `t` (after an event in the cut).
    pub(in crate::solver::exact) fn record_right(&mut self, t: f64, s: f64, ds: f64) {
        if let Some(last) = self.k.back_mut() {
            if last.t.to_bits() == t.to_bits() {
                last.s_r = s;
                last.ds_r = ds;
            }
        }
    }

    /// Store the surface at `t` out of the cut ([`History::out_of_cut_knot`]).
    pub(in crate::solver::exact) fn record_out_of_cut(&mut self, t: f64) {
        let kn = self.out_of_cut_knot(t);
        self.push(kn);
    }

    /// A cut event at `t` (the tool's velocity `du` there): its breakpoint queued, the
    /// history's cut flag the side after the event, and the surface's kink
    /// ([`History::cut_event_slope`]) with that side.
    pub(in crate::solver::exact) fn cut_event(&mut self, t: f64, in_cut_after: bool, du: f64) {
        self.breakpoint(t);
        self.in_cut = in_cut_after;
        self.cut_event_slope(t, du);
    }

    /// Queue the breakpoint source `t`.
    pub(in crate::solver::exact) fn add_breakpoint(&mut self, t: f64) {
        self.breakpoint(t);
    }

    /// Drop the knots before `t` (one kept) and the breakpoints already passed at `t`.
    pub(in crate::solver::exact) fn forget_before(&mut self, t_knots: f64, t: f64) {
        self.trim(t_knots);
        while self.bp.front().is_some_and(|&(tk, _)| tk + self.tau <= t) {
            self.bp.pop_front();
        }
    }

    /// The next breakpoint source and the order of its break.
    pub(in crate::solver::exact) fn first_breakpoint(&self) -> Option<(f64, u8)> {
        self.bp.front().copied()
    }

    /// The quadratic through the surface over the window `[a, b]` ([`History::quadratic`]).
    pub(in crate::solver::exact) fn window_quadratic(&self, a: f64, b: f64) -> [f64; 3] {
        self.quadratic(a, b)
    }

    /// The surface and its slope at `x`, from the right.
    pub(in crate::solver::exact) fn value_slope(&self, x: f64) -> (f64, f64) {
        (self.eval(x, true), self.slope_left(x))
    }

    /// The ring or the breakpoint queue overflowed.
    pub(in crate::solver::exact) fn is_full(&self) -> bool {
        self.full
    }

    /// The history a run continued from `c` starts with (its knots and breakpoints, a ring of
    /// at least `cap`), `t0` (the continued run's start, where the cut changes) a breakpoint.
    /// `None` when `c`'s delay or surface advance is not `tau`'s and `shift`'s.
    pub(in crate::solver::exact) fn resumed(
        c: &CutContinuation,
        cap: usize,
        tau: f64,
        shift: f64,
        t0: f64,
    ) -> Option<History> {
        if c.tau.to_bits() != tau.to_bits() || c.shift.to_bits() != shift.to_bits() {
            return None;
        }
        let cap = cap.max(c.knots.len().max(c.bp.len()) + MAX_EVENT_KNOTS);
        let mut h = History::new(cap, c.in_cut, tau, shift);
        h.k.extend(c.knots.iter().copied());
        h.bp.extend(c.bp.iter().copied());
        // The cut changes here: a breakpoint of the history.
        h.queue_breakpoint(t0, BREAK_JUMP);
        Some(h)
    }

    /// Where a run ended, to continue it: this history, the public state, whether the tool
    /// cuts, the bar's own part.
    pub(in crate::solver::exact) fn into_continuation(
        self,
        state: State,
        in_cut: bool,
        bar: BarEnd,
    ) -> CutContinuation {
        CutContinuation {
            state,
            tau: self.tau,
            shift: self.shift,
            knots: self.k,
            bp: self.bp,
            in_cut,
            bar,
        }
    }
}

impl CutContinuation {
    /// The modal state at the end of a run on a modal bar.
    pub(in crate::solver::exact) fn modal_state(&self) -> Option<&crate::structure::ModalState> {
        match &self.bar {
            BarEnd::Modal(m, _) => Some(m),
            BarEnd::Lumped(_) => None,
        }
    }

    /// The contact phase under way at the end of a run on a modal bar, and its wall.
    pub(in crate::solver::exact) fn modal_contact(
        &self,
    ) -> Option<(ModalContactPhase, crate::solver::Wall)> {
        match self.bar {
            BarEnd::Modal(_, c) => c,
            BarEnd::Lumped(_) => None,
        }
    }

    /// The contact phase under way at the end of a run on the lumped bar, and its wall.
    fn lumped_contact(&self) -> Option<(super::hertz_phase::ContactPhase<5>, crate::solver::Wall)> {
        match self.bar {
            BarEnd::Lumped(c) => c,
            BarEnd::Modal(..) => None,
        }
    }
}

/// The observer between the event loop and the caller's: stores the surface history at every
/// segment end and event, and queues the breakpoints.
struct Recorder<'a, 'b> {
    inner: &'a mut dyn Observer,
    hist: &'b RefCell<History>,
}

impl Observer for Recorder<'_, '_> {
    fn segment(&mut self, seg: &dyn Segment) {
        self.inner.segment(seg);
        let t1 = seg.t_end_s();
        let st = seg.state_at(t1);
        let mut h = self.hist.borrow_mut();
        // `in_cut` is the piece's (the driver sets it before each step of the event loop; a
        // cut event ends the step).
        if h.in_cut {
            let mut kn = Knot::cubic(t1, st.u_m, st.du_m_s, st.u_m, st.du_m_s);
            if h.quintic {
                // The bar's acceleration at the piece's end, and at its start: the knot there
                // takes its right side from this segment (it jumps after an event, entering the
                // cut, and where the delayed surface jumps a revolution after one).
                let t0 = seg.t_start_s();
                if let Some(last) = h.k.back_mut() {
                    if last.t.to_bits() == t0.to_bits() {
                        last.dds_r = seg.acceleration_at(t0).unwrap_or(f64::NAN);
                    }
                }
                let a = seg.acceleration_at(t1).unwrap_or(f64::NAN);
                kn.dds_l = a;
                kn.dds_r = a;
            }
            h.push(kn);
        } else {
            let kn = h.out_of_cut_knot(t1);
            h.push(kn);
        }
    }

    fn event(&mut self, ev: &Event) {
        self.inner.event(ev);
        let mut h = self.hist.borrow_mut();
        if h.in_cut {
            if let Some(last) = h.k.back_mut() {
                if last.t.to_bits() == ev.t_s.to_bits() {
                    last.s_r = ev.after.u_m;
                    last.ds_r = ev.after.du_m_s;
                    // The next segment's start sets it (Recorder::segment).
                    last.dds_r = f64::NAN;
                }
            }
        }
        h.breakpoint(ev.t_s);
    }
}

/// Gauss–Legendre nodes and weights on `[−1, 1]`, 8 points (exact for degree 15).
pub(crate) const GL8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
];

/// `∫_a^b f` by 8-point Gauss–Legendre on pieces of at most 1 rad of the fastest term (its
/// error on `e^{iθ}` over 1 rad is ~1e-22 relative, far below rounding; the sixth-order
/// surface's regular pieces, 2π/10 rad, are one interval); `f` gets the transcendentals at
/// the node.
fn quad<const N: usize>(
    seg: &ExactSegment,
    a: f64,
    b: f64,
    mut f: impl FnMut(&Trig) -> [f64; N],
) -> [f64; N] {
    let mut sum = [0.0; N];
    if b <= a {
        return sum;
    }
    let u = &seg.u;
    let rate = u.om.max(u.wd).max(u.al);
    let n = ((b - a) * rate).ceil().clamp(1.0, 1e6) as usize;
    let h = (b - a) / n as f64;
    if n == 1 {
        // One interval (a piece): its nodes' transcendentals, as below, from the cache.
        with_node_trigs([a, b, u.om, u.al, u.wd], |nodes| {
            for ((_, w), tr) in GL8.iter().zip(nodes) {
                for (s, v) in sum.iter_mut().zip(f(tr)) {
                    *s += w * v;
                }
            }
        });
        return sum.map(|s| 0.5 * h * s);
    }
    for i in 0..n {
        let mid = a + (i as f64 + 0.5) * h;
        for (x, w) in GL8 {
            let tr = Trig::new(mid + 0.5 * h * x, u.om, u.al, u.wd);
            for (s, v) in sum.iter_mut().zip(f(&tr)) {
                *s += w * v;
            }
        }
    }
    sum.map(|s| 0.5 * h * s)
}

/// The transcendentals at the 8 Gauss–Legendre nodes of `[a, b]` for `(om, al, wd)`: those
/// [`quad`] computes for one interval (`Trig::new` of the same node, to the bit).
type NodeKey = [u64; 5];

/// A placeholder of the empty cache (its key, all ones, is no `f64`s a piece has: a NaN).
const UNUSED_TRIG: Trig = Trig {
    ch: 1.0,
    sh: 0.0,
    em1: 0.0,
    cd: 1.0,
    sd: 0.0,
    chm1: 0.0,
    cdm1: 0.0,
    tau: 0.0,
};

thread_local! {
    /// The node tables of the last two keys. A run's regular pieces share their length (up to
    /// its rounding, a few values) and alternate between two sets of constants (in and out of
    /// the cut), so nearly every piece's integrals find their nodes here instead of computing 8
    /// exponentials and 16 sines and cosines.
    static NODES: RefCell<[(NodeKey, [Trig; 8]); 2]> =
        const { RefCell::new([([u64::MAX; 5], [UNUSED_TRIG; 8]); 2]) };
}

thread_local! {
    /// The transcendentals at the ends of the last two regular pieces (see [`NODES`]).
    static ENDS: RefCell<[([u64; 4], Trig); 2]> = const { RefCell::new([([u64::MAX; 4], UNUSED_TRIG); 2]) };
}

/// `Trig::new(tau, om, al, wd)` (to the bit), cached for the pieces' ends: a regular piece's
/// local end is its length, the same for most pieces of a run.
pub(in crate::solver::exact) fn end_trig(tau: f64, om: f64, al: f64, wd: f64) -> Trig {
    let key = [tau, om, al, wd].map(f64::to_bits);
    ENDS.with(|c| {
        let mut c = c.borrow_mut();
        if c[0].0 != key {
            c.swap(0, 1);
            if c[0].0 != key {
                c[0] = (key, Trig::new(tau, om, al, wd));
            }
        }
        c[0].1
    })
}

/// `g` of the node table of `[a, b]` and `(om, al, wd)`, cached (see [`NODES`]).
fn with_node_trigs<R>(x: [f64; 5], g: impl FnOnce(&[Trig; 8]) -> R) -> R {
    let key = x.map(f64::to_bits);
    NODES.with(|c| {
        let mut c = c.borrow_mut();
        if c[0].0 != key {
            // The older entry goes; the newer stays second.
            c.swap(0, 1);
            if c[0].0 != key {
                let [a, b, om, al, wd] = x;
                let h = b - a;
                let mid = a + 0.5 * h;
                c[0].0 = key;
                for (t, (x, _)) in c[0].1.iter_mut().zip(GL8) {
                    *t = Trig::new(mid + 0.5 * h * x, om, al, wd);
                }
            }
        }
        g(&c[0].1)
    })
}

/// `∫ u²` over local `[a, b]` of a cutting segment (the RMS's hot path).
pub(in crate::solver::exact) fn integral_u2(seg: &ExactSegment, a: f64, b: f64) -> f64 {
    quad(seg, a, b, |tr| [seg.u.value_t(tr).powi(2)])[0]
}

/// The integrals of a segment of a cutting run over local `[a, b]`: the forcing work is the
/// harmonic force's only, the cutting work [`cutting_work`].
pub(super) fn segment_integrals(
    seg: &ExactSegment,
    c: &CutSeg,
    a: f64,
    b: f64,
) -> SegmentIntegrals {
    let du = seg.u.deriv();
    let [u2, fw, vl] = quad(seg, a, b, |tr| {
        let (u, v) = (seg.u.value_t(tr), du.value_t(tr));
        let harmonic = seg.force.value_t(tr) - c.force_t(c.h.value_t(tr), tr.tau);
        [u * u, harmonic * v, v * v]
    });
    SegmentIntegrals {
        u2_m2_s: u2,
        forcing_work_j: fw,
        viscous_loss_j: seg.c * vl,
        friction_work_j: if seg.fb == 0.0 {
            0.0
        } else {
            seg.fb * seg.w.increment(a, b)
        },
    }
}

/// `∫ c_force K_f b h u̇` over local `[a, b]` of a cutting segment.
pub(super) fn cutting_work(seg: &ExactSegment, c: &CutSeg, a: f64, b: f64) -> f64 {
    if c.kfb == 0.0 {
        return 0.0;
    }
    let du = seg.u.deriv();
    if c.r.is_some() {
        return quad(seg, a, b, |tr| {
            [c.force_t(c.h.value_t(tr), tr.tau) * du.value_t(tr)]
        })[0];
    }
    c.kfb * quad(seg, a, b, |tr| [c.h.value_t(tr) * du.value_t(tr)])[0]
}

/// The bar without a ball over one piece: the cut's chip is its only event function.
fn bar_only(
    cs: &Consts,
    s: &mut St,
    t_end_s: f64,
    book: &mut Book,
    search: &mut Search,
) -> Result<(), SimError> {
    let span = t_end_s - s.t;
    let tol_t = cs.tol_t_at(s.t);
    let (u, force) = cs.bar_sum(cs.m, 0.0, s.t, s.u, s.du)?;
    let mut set = EventSet::<1>::new(&u);
    let (best, which, end) = joint_search(cs, &mut set, search, span, tol_t, &u)?;
    let seg = ExactSegment {
        t0: s.t,
        t1: if which == 0 { t_end_s } else { s.t + best },
        mode: Mode::NoBall,
        u,
        w: u.zero_like(),
        force,
        c: cs.c,
        energy: cs.energy_consts(),
        fb: 0.0,
        end,
        cut: cs.cut.map(|c| c.segment(&u)),
    };
    let next = super::close_segment(&seg, book);
    book.check_state(&next)?;
    *s = St {
        w: 0.0,
        dw: 0.0,
        ..next
    };
    if which == CUT {
        book.cut_event = true;
    }
    debug_assert!(which == 0 || which == CUT || which == HORIZON);
    Ok(())
}

/// Fixed-point iterations of the three-quarter law's remainder fit per piece (at most).
pub const REMAINDER_MAX_ITERATIONS: usize = 12;

/// The iteration stops when the fitted remainder moves by less than this fraction of the
/// cutting force at the feed, `c_force K_f b h0` (at every node of the piece).
pub const REMAINDER_TOL: f64 = 1e-13;

/// The bar's displacement at three node times of a dry run (no events counted, the caller's
/// observer not called): exact where a segment covers the node, else the last segment's
/// closed form continued (replaced once a later segment covers it).
struct Probe {
    nodes: [f64; 3],
    u: [f64; 3],
    covered: [bool; 3],
}

impl Observer for Probe {
    fn segment(&mut self, seg: &dyn Segment) {
        let t1 = seg.t_end_s();
        for i in 0..3 {
            if !self.covered[i] {
                self.u[i] = seg.state_at(self.nodes[i]).u_m;
                self.covered[i] = self.nodes[i] <= t1;
            }
        }
    }
}

/// The three-quarter law's remainder fit over the piece from `s` (in the cut) up to `t_stop`
/// ([`cut_loop::remainder_fit`]), each dry run the piece the event loop will take (to `t_stop`
/// or to its first event) with the previous fit, the tool's displacement at the nodes from the
/// segments' closed forms.
fn remainder_fit(
    cs: &Consts,
    cut: &Cutting,
    mode: Md,
    s: &St,
    t_stop: f64,
    book: &Book,
    search: &mut Search,
) -> Result<[f64; 3], SimError> {
    let cp = cs.cut.expect("a cutting piece");
    cut_loop::remainder_fit(cut, cp.kfb, cp.d, s.u, t_stop - s.t, |r, len| {
        let mut c = *cs;
        if let Some(p) = c.cut.as_mut() {
            p.r = Some(*r);
        }
        let mut probe = Probe {
            nodes: [s.t, s.t + 0.5 * len, s.t + len],
            u: [s.u; 3],
            covered: [true, false, false],
        };
        let mut dry = Book {
            obs: &mut probe,
            tally: Tally {
                max_events: u64::MAX,
                check: false,
                ..book.tally
            },
            cut_event: false,
        };
        let mut st = *s;
        advance(&c, mode, &mut st, t_stop, &mut dry, search)?;
        let [_, um, u1] = probe.u;
        Ok((st.t - s.t, um, u1))
    })
}

/// The error of a continued run whose cut changes the surface history's delay or advance.
pub(in crate::solver::exact) const CONTINUE_MISMATCH: &str =
    "continuing a cutting run: [cutting] spindle_rpm, feed_m and chip_direction_factor must be \
     the continued run's (its surface history's delay and advance)";

/// An N-mode bar's contact phase under way where a run ended.
type ModalContactPhase = super::hertz_phase::ContactPhase<{ super::hertz_phase::MODAL_PHASE_LEN }>;

/// A bar's own part of where a cutting run ended: a `hertz` contact phase under way at the end
/// (its integrator state and wall), and on a modal bar the modal state.
// One per kept run: the modal variant's size (the modal state and phase inline) costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
pub(in crate::solver::exact) enum BarEnd {
    /// The lumped bar.
    Lumped(Option<(super::hertz_phase::ContactPhase<5>, crate::solver::Wall)>),
    /// A modal bar.
    Modal(
        crate::structure::ModalState,
        Option<(ModalContactPhase, crate::solver::Wall)>,
    ),
}

/// Where a cutting run ended: its final state, the machined surface over the last revolution
/// and the pending breakpoints, so that a run can go on from it with another cut (e.g. another
/// width: chatter grown at one width, then the width lowered).
#[derive(Debug, Clone)]
pub struct CutContinuation {
    state: State,
    knots: VecDeque<Knot>,
    bp: VecDeque<(f64, u8)>,
    in_cut: bool,
    tau: f64,
    shift: f64,
    /// The bar's own part.
    bar: BarEnd,
}

impl CutContinuation {
    /// The run's final state (absolute, not an offset from the equilibrium).
    pub fn state(&self) -> &State {
        &self.state
    }

    /// Whether the tool was in the cut at the end.
    pub fn in_cut(&self) -> bool {
        self.in_cut
    }
}

impl ExactCutting {
    /// [`Solver::run`], also returning where the run ended, to continue it.
    pub fn run_keeping(
        &self,
        sys: &System,
        init: &State,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<(RunSummary, CutContinuation), SimError> {
        if let BarModel::Modal(model) = &sys.bar {
            let msys = crate::structure::ModalSystem::from_system(sys)?;
            let minit = crate::structure::ModalState::from_public(model, init)?;
            let (r, c) = self.modal().run_keeping(&msys, &minit, t_end_s, obs)?;
            return Ok((r.summary, c));
        }
        self.drive(sys, init, None, t_end_s, obs)
    }

    /// The modal cutting solver with this solver's settings.
    fn modal(&self) -> super::modal::cutting::ModalCutting {
        super::modal::cutting::ModalCutting {
            exact: super::modal::ModalExact {
                max_events: self.exact.max_events,
                check_invariants: self.exact.check_invariants,
            },
            cutting: self.cutting,
            steps_per_period: self.steps_per_period,
        }
    }

    /// Go on from `from` (the end of an earlier run of the same system) up to `t_end_s` with
    /// this solver's cut: the state and the surface history are the earlier run's, the force
    /// law and width are this cut's. The delay and the surface's advance out of the cut must be
    /// the earlier run's (same `spindle_rpm`, `feed_m`, `chip_direction_factor`). The ball's
    /// mode is found again from the state, as at a start.
    pub fn continue_run(
        &self,
        sys: &System,
        from: &CutContinuation,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<(RunSummary, CutContinuation), SimError> {
        match (&sys.bar, from.modal_state().is_some()) {
            (BarModel::Lumped(_), false) => self.drive(sys, &from.state, Some(from), t_end_s, obs),
            (BarModel::Modal(_), true) => {
                let msys = crate::structure::ModalSystem::from_system(sys)?;
                let (r, c) = self.modal().continue_run(&msys, from, t_end_s, obs)?;
                Ok((r.summary, c))
            }
            _ => Err(SimError::Unsupported(CONTINUE_OTHER_BAR)),
        }
    }

    fn drive(
        &self,
        sys: &System,
        init: &State,
        from: Option<&CutContinuation>,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<(RunSummary, CutContinuation), SimError> {
        let cut = &self.cutting;
        let bar = match &sys.bar {
            BarModel::Lumped(b) => *b,
            BarModel::Modal(_) => {
                return Err(SimError::Unsupported(
                    "[cutting] on a modal bar ([beam], [[modes]]) runs through \
                     solver::exact::modal::cutting",
                ))
            }
        };
        cut.validate()?;
        let nonlinear = cut.force_law == CuttingForceLaw::ThreeQuarter;
        // The sixth-order surface where every segment is a closed form that knows the bar's
        // acceleration: the linear law on the restitution contact law.
        let quintic = self.sixth_order
            && !nonlinear
            && sys
                .damper
                .is_none_or(|d| d.contact.law != crate::ContactLaw::Hertz);
        crate::limits::check(
            "steps_per_period (cutting pieces per fastest period)",
            self.steps_per_period as f64,
            4.0,
            1e6,
            "",
        )?;
        let k = bar.stiffness_n_per_m;
        let kfb = cut.force_direction_factor * cut.coefficient_n_m2 * cut.width_m;
        let kc = kfb * cut.chip_direction_factor;
        let tau = cut.delay_s();
        let u_eq = self.equilibrium_u_m(sys, k);
        let start = match from {
            Some(c) => State {
                cavity: None,
                ..c.state
            },
            None => State {
                u_m: u_eq + init.u_m,
                v_m: u_eq + init.v_m,
                cavity: None,
                ..*init
            },
        };
        // A continued run inside a `hertz` contact starts with the ball in the wall: the
        // state is checked at the wall, the penetration is the phase's.
        let checked = match from.and_then(|c| c.lumped_contact()) {
            Some((_, wall)) if sys.damper.is_some() => State {
                v_m: start.u_m + wall.sign() * sys.damper.map_or(0.0, |d| d.half_gap_m()),
                ..start
            },
            _ => start,
        };
        crate::solver::validate_run(sys, &checked, t_end_s)?;
        crate::solver::refuse_ball_body_force(
            sys.damper.as_ref(),
            crate::solver::GRAVITY_ALONG_GAP_CUTTING,
        )?;
        let t0 = start.t_s;
        // The two sets of constants: out of the cut the bar's own, in it the stiffness `K + kc`
        // (the damping `C` stays the bar's).
        let piece = CutPiece {
            kfb,
            c_chip: cut.chip_direction_factor,
            h0: cut.feed_m,
            in_cut: false,
            d: [u_eq, 0.0, 0.0],
            order: 0,
            tol: 1e-14 * (cut.feed_m + cut.chip_direction_factor * u_eq.abs()),
            r: None,
        };
        let mut cs_out = Consts::new(sys, &bar);
        cs_out.cut = Some(piece);
        let mut cs_in = cs_out;
        cs_in.k = k + kc;
        cs_in.osc = [
            Osc::new(&cs_in, cs_in.m),
            Osc::new(&cs_in, cs_in.m + cs_in.md),
        ];
        cs_in.cut = Some(CutPiece {
            in_cut: true,
            ..piece
        });
        let w_fast = (cs_in.k / cs_in.m)
            .sqrt()
            .max(if sys.forcing.amplitude_n != 0.0 {
                cs_in.om
            } else {
                0.0
            });
        let pieces_per_period = if quintic {
            self.steps_per_period as f64 * SIXTH_ORDER_STEPS_PER_PERIOD as f64
                / DEFAULT_STEPS_PER_PERIOD as f64
        } else {
            self.steps_per_period as f64
        };
        let h_max = (2.0 * std::f64::consts::PI / w_fast / pieces_per_period).min(tau);
        // Near the cut's boundary the sixth-order path takes the fourth-order pieces (see the
        // module doc): the chip there is an event function, and its pointwise error is O(Δ³).
        let h_near = (2.0 * std::f64::consts::PI / w_fast / self.steps_per_period as f64).min(tau);
        let pieces = (tau / h_near).ceil() + 4.0;
        let cap = 2 * pieces as usize + MAX_EVENT_KNOTS;
        let mut h0_chip = cut.feed_m - cut.chip_direction_factor * init.u_m;
        let shift = cut.feed_m / cut.chip_direction_factor;
        let (in_cut0, mut h) = cut_loop::start_history(from, (cap, tau, shift, t0), || {
            let in_cut = h0_chip > 0.0;
            let h = History::smooth(cap, tau, shift, t0, u_eq, in_cut, start.u_m, start.du_m_s);
            (in_cut, h)
        })?;
        h.quintic = quintic;
        if from.is_some() {
            // The chip at the start, from the continued surface.
            h0_chip = cut.feed_m + cut.chip_direction_factor * (h.eval(t0 - tau, true) - start.u_m);
        } else if quintic {
            // At rest before the start; after it the first segment's (in the cut) or the
            // smooth surface advanced (out of it).
            (h.k[0].dds_l, h.k[0].dds_r, h.k[1].dds_l) = (0.0, 0.0, 0.0);
            h.k[1].dds_r = if in_cut0 { f64::NAN } else { 0.0 };
        }
        let hist = RefCell::new(h);
        let mut rec = Recorder {
            inner: obs,
            hist: &hist,
        };
        let mut book = Book {
            obs: &mut rec,
            tally: Tally::new(
                RunSummary {
                    final_state: start,
                    max_penetration_m: f64::NEG_INFINITY,
                    ..Default::default()
                },
                self.exact.max_events,
                self.exact.check_invariants,
                cs_out.lg,
            ),
            cut_event: false,
        };
        let mut pc = Pieces::new(t0, tau, t_end_s, in_cut0, CutCount::Apart);
        let cut_force0 = match (in_cut0, nonlinear) {
            (false, _) => 0.0,
            (true, false) => kfb * h0_chip,
            (true, true) => cut.force_on_bar_n(h0_chip),
        };
        let mut s = St {
            t: t0,
            u: start.u_m,
            du: start.du_m_s,
            w: start.w_m(),
            dw: start.dw_m_s(),
            force: sys.force_n(t0) + cut_force0,
        };
        let has_ball = sys.damper.is_some();
        if !has_ball {
            s.w = 0.0;
            s.dw = 0.0;
        }
        let consts = |in_cut: bool, d: [f64; 3], order: usize| -> Consts {
            let mut c = if in_cut { cs_in } else { cs_out };
            if let Some(p) = c.cut.as_mut() {
                p.d = d;
                p.order = order;
            }
            c
        };
        let mut search = Search::default();
        // A `hertz` contact phase carried over a piece end or a cut event (or from the run
        // continued: it goes on where it stopped, the penetration kept).
        let resumed = from.and_then(|c| c.lumped_contact()).filter(|_| has_ball);
        let mut phase = resumed.map(|r| r.0);
        let mut mode = match resumed {
            Some((_, wall)) => Md::HertzTouch(wall),
            None if has_ball => {
                let d0 = hist.borrow().quadratic(t0 - tau, t0 - tau);
                initial_mode(&consts(in_cut0, d0, 0), &mut s, &mut book)?
            }
            None => Md::Stick,
        };
        // The quadratic of the piece starting at this time, fitted already.
        let mut fitted: Option<(u64, [f64; 3])> = None;
        while s.t < t_end_s {
            let (step_end, win_end, near, at_breakpoint) = {
                let mut h = hist.borrow_mut();
                h.forget_before(s.t - tau - h_max.max(h_near), s.t);
                let step = |len: f64| pc.end(&h, s.t, len);
                let (mut end, mut win, mut bp) = step(if quintic { h_max } else { h_near });
                // The chip's deviation from the feed, `D = c_chip (s(t − T) − u)`, as an
                // oscillation at the fastest frequency: its amplitude `√(D² + (Ḋ/ω)²)` against
                // the feed says whether the chip can reach 0 soon (from the long piece's
                // quadratic, kept for the piece when it is not).
                let near = quintic && {
                    let a = pc.window_start(s.t);
                    let d = h.quadratic(a, win.max(a));
                    let c = cut.chip_direction_factor;
                    let dd = c * (d[0] - s.u);
                    let ddot = c * (d[1] - s.du) / w_fast;
                    let near = dd.hypot(ddot) > NEAR_CUT_BOUNDARY * cut.feed_m;
                    if !near {
                        fitted = Some((s.t.to_bits(), d));
                    }
                    near
                };
                if near {
                    (end, win, bp) = step(h_near);
                }
                (end, win, near, bp)
            };
            while s.t < step_end {
                let (in_cut, order) = (pc.in_cut, pc.order);
                let a = pc.window_start(s.t);
                let d = match fitted.take() {
                    // The long piece's quadratic from the test above (same window).
                    Some((bits, d)) if bits == s.t.to_bits() => d,
                    _ if near => hist.borrow().ends_quadratic(a, win_end.max(a)),
                    _ => hist.borrow().quadratic(a, win_end.max(a)),
                };
                let cs = consts(in_cut, d, order);
                book.cut_event = false;
                hist.borrow_mut().in_cut = in_cut;
                let chip0 = cut.feed_m + cut.chip_direction_factor * (d[0] - s.u);
                if quintic
                    && !near
                    && order == 0
                    && ((in_cut && chip0 < 0.0) || (!in_cut && chip0 > 0.0))
                {
                    // The Gauss quadratic jumps by O(Δ³) at a piece boundary: where that moves
                    // the chip across zero, the cut event is here (not after a negative chip).
                    book.cut_event = true;
                } else if nonlinear && !has_ball {
                    // The three-quarter law: one DP5 step ([`super::cutting_nonlinear`]). The
                    // mode follows the chip's sign at a step start (a crossing at a step end).
                    let x = s.t - tau;
                    let hh = cut.feed_m
                        + cut.chip_direction_factor * (hist.borrow().eval(x, true) - s.u);
                    // Not right after a located cut event: the step redone to the event ends
                    // within rounding of the zero, on either side.
                    if order == 0 && ((in_cut && hh < 0.0) || (!in_cut && hh > 0.0)) {
                        book.cut_event = true;
                    } else {
                        let piece = super::cutting_nonlinear::Piece {
                            bar: &bar,
                            sys,
                            cut,
                            hist: &hist,
                            win: (a, win_end.max(a)),
                            after_event: order == 1,
                        };
                        let mut y = [s.u, s.du];
                        let (t1, ev) = super::cutting_nonlinear::step(
                            &piece, in_cut, s.t, &mut y, step_end, book.obs,
                        )?;
                        s = St {
                            t: t1,
                            u: y[0],
                            du: y[1],
                            ..s
                        };
                        book.cut_event = ev;
                    }
                } else if let (true, Md::HertzTouch(wall), Some(law)) = (has_ball, mode, cs.hertz) {
                    // A compliant contact phase over this piece ([`hertz_cut`]).
                    let (p, sw) = (cs.cut.expect("a cutting piece"), wall.sign());
                    let over = CutOver {
                        cut: *cut,
                        in_cut: p.in_cut,
                        d: p.d,
                        h0: p.h0,
                        c_chip: p.c_chip,
                        t_ref: s.t,
                    };
                    match hertz_cut::contact_piece(
                        &cs, &law, over, sw, &mut phase, &mut s, step_end, order, &mut book,
                    )? {
                        PieceEnd::Goes { cut_event } => book.cut_event = cut_event,
                        PieceEnd::Released { at, kind } => {
                            book.event(&cs, at.t, kind, &at, &at)?;
                            mode = super::hertz_phase::after_release(&cs, sw, &s);
                        }
                    }
                } else if has_ball {
                    let mut cs = cs;
                    if nonlinear && in_cut {
                        let r = remainder_fit(&cs, cut, mode, &s, step_end, &book, &mut search)?;
                        if let Some(p) = cs.cut.as_mut() {
                            p.r = Some(r);
                        }
                    }
                    match advance(&cs, mode, &mut s, step_end, &mut book, &mut search)? {
                        Some(m) => mode = m,
                        None => {
                            if let Md::Free { sigma, .. } = mode {
                                mode = Md::Free {
                                    sigma,
                                    k_plus: 0,
                                    k_minus: 0,
                                    k_sw: 0,
                                };
                            }
                        }
                    }
                } else {
                    bar_only(&cs, &mut s, step_end, &mut book, &mut search)?;
                }
                let du = s.du;
                pc.segment_done(
                    &mut hist.borrow_mut(),
                    &mut book.tally,
                    book.cut_event,
                    s.t,
                    || du,
                )?;
            }
            if let (true, Some(order)) = (quintic, at_breakpoint) {
                // The surface's break at `t_k` reaches `t_k + T` and from there `t_k + 2T`: out
                // of the cut as it was (the surface carried), in the cut two derivatives
                // smoother (through the bar). A jump becomes a jump in `ü`, which a piece
                // across `t_k + 2T` would carry as an O(Δ³) error of its delayed surface
                // (measured: the order through loss of contact fell to ~3 without it); a
                // kink becomes a jump in `u⃛`, O(Δ⁴) once per event, left as it is.
                if !pc.in_cut {
                    hist.borrow_mut().queue_breakpoint(s.t, order);
                } else if order == BREAK_JUMP {
                    hist.borrow_mut().queue_breakpoint(s.t, BREAK_ACCEL);
                }
            }
            pc.piece_done(s.t, win_end);
        }
        pc.finish(&mut book.tally);
        book.tally.summary.final_state = s.public();
        let summary = book.tally.summary;
        let end = (hist.into_inner()).into_continuation(
            summary.final_state,
            pc.in_cut,
            BarEnd::Lumped(cut_loop::contact_at_end(mode, phase)),
        );
        Ok((summary, end))
    }
}

impl Solver for ExactCutting {
    fn name(&self) -> &'static str {
        "exact"
    }

    fn run(
        &self,
        sys: &System,
        init: &State,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<RunSummary, SimError> {
        if let BarModel::Modal(model) = &sys.bar {
            // A modal bar ([beam], [[modes]]): the modal cutting run, its initial state the
            // public offset put into mode 1 (`ModalState::from_public`).
            let msys = crate::structure::ModalSystem::from_system(sys)?;
            let minit = crate::structure::ModalState::from_public(model, init)?;
            return Ok(super::modal::cutting::ModalCutting {
                exact: super::modal::ModalExact {
                    max_events: self.exact.max_events,
                    check_invariants: self.exact.check_invariants,
                },
                cutting: self.cutting,
                steps_per_period: self.steps_per_period,
            }
            .run(&msys, &minit, t_end_s, obs)?
            .summary);
        }
        self.drive(sys, init, None, t_end_s, obs).map(|r| r.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn same(a: &Trig, b: &Trig) -> bool {
        format!("{a:?}") == format!("{b:?}")
    }

    /// The caches give `Trig::new`'s values to the bit, with three keys cycling through the
    /// two entries (every lookup after the first round evicts one).
    #[test]
    fn node_and_end_caches_give_the_direct_values() {
        let keys = [
            [0.0, 4.9e-5, 3783.75, 37.8, 3924.6],
            [0.0, 4.9e-5, 3783.75, 37.8, 3783.6],
            [1e-6, 3.1e-5, 3783.75, 37.8, 3924.6],
        ];
        for k in keys.iter().cycle().take(12) {
            let [a, b, om, al, wd] = *k;
            let (h, mid) = (b - a, a + 0.5 * (b - a));
            with_node_trigs(*k, |t| {
                for (tr, (x, _)) in t.iter().zip(GL8) {
                    assert!(same(tr, &Trig::new(mid + 0.5 * h * x, om, al, wd)));
                }
            });
            assert!(same(&end_trig(b, om, al, wd), &Trig::new(b, om, al, wd)));
        }
    }

    /// The walk from the last lookup finds the partition point bisection finds, for queries
    /// at, between, before and after the knots, in and out of order, across trims.
    #[test]
    fn knot_lookup_from_the_last_one_is_the_partition_point() {
        let mut h = History::new(64, true, 1.0, 0.0);
        for i in 0..40 {
            let t = 0.1 * i as f64;
            h.push(Knot::cubic(t, t, 1.0, t, 1.0));
        }
        let mut checked = 0;
        for round in 0..3 {
            h.trim(0.5 * round as f64);
            for q in (0..90)
                .map(|i| -0.05 + 0.05 * i as f64)
                .chain([3.9, 0.0, 2.0, 0.3])
            {
                for right in [false, true] {
                    let want = if right {
                        h.k.partition_point(|k| k.t <= q)
                    } else {
                        h.k.partition_point(|k| k.t < q)
                    };
                    assert_eq!(h.locate(q, right), want, "{q} {right}");
                    checked += 1;
                }
            }
        }
        assert!(checked > 500);
    }
}
