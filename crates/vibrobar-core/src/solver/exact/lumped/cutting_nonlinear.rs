//! The three-quarter cutting law (issue #13) on the bar without a ball: a stated integrator, not
//! a closed form. The force `c_force F(h)` is not linear in the chip, so each piece of the delay
//! stepping ([`super::cutting`]: the same pieces, the same breakpoints `t_k + T`, the same
//! history) is one fixed step of Dormand–Prince 5(4) ([`crate::solver::dopri5`]), the delayed
//! surface read from the stored history (cubic Hermite on its knots) at every stage. A sign
//! change of the chip inside a step (sampled on the step's dense output, 16 points, then
//! bisected) shortens the step to end at the tool leaving or re-entering the cut, which is
//! where the force law switches; the mode (in or out of the cut), not the sign of `h`, chooses
//! the force, so the switch is never chattered over.
//!
//! The stored surface is read over the piece's window as the closed-form pieces read it: from
//! the right at its start, from the left at its end (a knot with a jump there, as at the start
//! with an offset, is seen from the piece's side). A step in the cut with the chip 0 at an end
//! (stopped at the tool leaving, or started where it re-entered) is taken as graded sub-steps
//! toward that end, where `h^{3/4}` has an unbounded slope.
//!
//! Accuracy: the history's Hermite pieces are 4th order, DP5 5th: the measured order in the
//! piece length is about 4 in the cut (test `three_quarter_convergence_order`). Through loss of
//! contact (1.5 b_lim, 20 ms) against an independent RK4: 9.5e-9 m at 32 and 1.1e-9 m at 128
//! pieces per period (the RK4's own level; before the window and the sub-steps 1.2e-7 m at
//! 128). Integrals of the segments (RMS, energy books) are Gauss–Legendre on the dense output.

use super::cutting::History;
use crate::error::SimError;
use crate::excitation::Cutting;
use crate::params::{Bar, State, System};
use crate::solver::dopri5::{DenseStep, Dopri5};
use crate::solver::{CutSample, Mode, Observer, Segment, SegmentIntegrals};
use std::cell::{Cell, RefCell};

/// One DP5 step of the bar in a cutting run.
struct DpSegment<'a> {
    step: DenseStep<2>,
    bar: &'a Bar,
    sys: &'a System,
    cut: &'a Cutting,
    /// The delayed surface over the step: `s(t − T)` as the quadratic through the step's ends
    /// and middle (for the chip and force columns and the cutting work only).
    d: [f64; 3],
    in_cut: bool,
}

impl DpSegment<'_> {
    fn th(&self, t: f64) -> f64 {
        ((t - self.step.t0) / self.step.h).clamp(0.0, 1.0)
    }
    fn y(&self, t: f64) -> [f64; 2] {
        self.step.at_theta(self.th(t))
    }
    fn chip(&self, t: f64) -> f64 {
        let x = t - self.step.t0;
        let d = self.d[0] + x * (self.d[1] + x * self.d[2]);
        self.cut.feed_m + self.cut.chip_direction_factor * (d - self.y(t)[0])
    }
    fn cut_force(&self, t: f64) -> f64 {
        if self.in_cut {
            self.cut.force_on_bar_n(self.chip(t))
        } else {
            0.0
        }
    }
    fn quad<const N: usize>(&self, a: f64, b: f64, f: impl Fn(f64) -> [f64; N]) -> [f64; N] {
        let mut sum = [0.0; N];
        if b <= a {
            return sum;
        }
        let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
        for (x, w) in super::cutting::GL8 {
            for (s, v) in sum.iter_mut().zip(f(mid + half * x)) {
                *s += w * v;
            }
        }
        sum.map(|s| half * s)
    }
}

impl Segment for DpSegment<'_> {
    fn t_start_s(&self) -> f64 {
        self.step.t0
    }
    fn t_end_s(&self) -> f64 {
        self.step.t0 + self.step.h
    }
    fn mode(&self) -> Mode {
        Mode::NoBall
    }
    fn state_at(&self, t_s: f64) -> State {
        let [u, du] = self.y(t_s);
        State {
            t_s,
            u_m: u,
            du_m_s: du,
            v_m: u,
            dv_m_s: du,
            cavity: None,
        }
    }
    fn integral_u2(&self, a_s: f64, b_s: f64) -> f64 {
        self.quad(a_s, b_s, |t| [self.y(t)[0].powi(2)])[0]
    }
    fn integrals(&self, a_s: f64, b_s: f64) -> SegmentIntegrals {
        let c = self.bar.damping_n_s_per_m();
        let [u2, fw, vl] = self.quad(a_s, b_s, |t| {
            let [u, du] = self.y(t);
            [u * u, self.sys.force_n(t) * du, du * du]
        });
        SegmentIntegrals {
            u2_m2_s: u2,
            forcing_work_j: fw,
            viscous_loss_j: c * vl,
            friction_work_j: 0.0,
        }
    }
    fn mechanical_energy_j(&self, t_s: f64) -> f64 {
        crate::model::lumped_mechanical_energy_j(
            self.bar.mass_kg,
            self.bar.stiffness_n_per_m,
            None,
            &self.state_at(t_s),
        )
    }
    fn cutting_at(&self, t_s: f64) -> Option<CutSample> {
        Some(CutSample {
            chip_thickness_m: self.chip(t_s),
            in_cut: self.in_cut,
            cutting_force_n: self.cut_force(t_s),
        })
    }
    fn cutting_work_j(&self, a_s: f64, b_s: f64) -> f64 {
        self.quad(a_s, b_s, |t| [self.cut_force(t) * self.y(t)[1]])[0]
    }
}

/// What the driver of [`super::cutting`] gives one nonlinear piece.
pub(in crate::solver::exact) struct Piece<'a> {
    pub bar: &'a Bar,
    pub sys: &'a System,
    pub cut: &'a Cutting,
    pub hist: &'a RefCell<History>,
    /// The piece's window on the stored surface, `[a, b]` (`a` the exact `t_k` after a
    /// breakpoint, `b` the next event's `t_k` or the piece end minus `T`): read from the right
    /// at `a` and from the left at `b`, as the closed-form pieces read it, so that a knot with
    /// a jump at either end is seen from the piece's side.
    pub win: (f64, f64),
    /// The piece starts at a located cut event (the chip 0 there).
    pub after_event: bool,
}

/// Sub-steps of a step in the cut with the chip 0 at an end, and their grading: the sub-step
/// nodes go as `(j/n)^GRADING` from the singular end.
const SINGULAR_SUBSTEPS: usize = 12;
const GRADING: i32 = 4;

/// Advance the bar state `y = [u, u̇]` from `t` by one DP5 step to `t_stop` (or to the tool
/// leaving / re-entering the cut before it), hand the step to `obs`; returns the new time and
/// whether the step ended at a cut event.
pub(in crate::solver::exact) fn step(
    p: &Piece,
    in_cut: bool,
    t0: f64,
    y: &mut [f64; 2],
    t_stop: f64,
    obs: &mut dyn Observer,
) -> Result<(f64, bool), SimError> {
    let (m, k, c) = (
        p.bar.mass_kg,
        p.bar.stiffness_n_per_m,
        p.bar.damping_n_s_per_m(),
    );
    let cut = p.cut;
    let (a, b_full) = p.win;
    // The window's end for the step under way (a step shortened to a cut event ends inside).
    let b_now = Cell::new(b_full);
    let surface = |t: f64| -> f64 {
        let hist = p.hist.borrow();
        let x = a + (t - t0);
        if t <= t0 {
            hist.eval(a, true)
        } else if x >= b_now.get() {
            hist.eval(b_now.get(), false)
        } else {
            hist.eval(x, true)
        }
    };
    let chip =
        |t: f64, u: f64| -> f64 { cut.feed_m + cut.chip_direction_factor * (surface(t) - u) };
    let mut rhs = |t: f64, y: &[f64; 2]| -> [f64; 2] {
        let f_cut = if in_cut {
            cut.force_on_bar_n(chip(t, y[0]))
        } else {
            0.0
        };
        [y[1], (p.sys.force_n(t) + f_cut - c * y[1] - k * y[0]) / m]
    };
    let dp = Dopri5::<2>::new(0.0, [1.0; 2]);
    let t = t0;
    let f0 = rhs(t, y);
    let mut h = t_stop - t;
    let mut att = dp.attempt(&mut rhs, t, y, &f0, h);
    // A sign change of the chip's margin (h in the cut, −h out of it) on the dense output.
    let margin = |st: &DenseStep<2>, th: f64| -> f64 {
        let u = st.comp(0, th);
        let hh = chip(st.t0 + th * st.h, u);
        if in_cut {
            hh
        } else {
            -hh
        }
    };
    let mut event = false;
    if let Some(th) = crate::solver::dopri5::first_sign_change(|th| margin(&att.step, th), 16) {
        if th < 1.0 {
            h *= th;
            b_now.set(a + h);
            att = dp.attempt(&mut rhs, t, y, &f0, h);
            event = true;
        }
    }
    // In the cut the force `∝ h^{3/4}` has an unbounded slope where the chip is 0: at the
    // step's end when it stops at the tool leaving, at its start right after the tool
    // re-entered. One DP5 step across such an end errs by O(h^{11/4}) (erratically, with where
    // the event falls in the piece); graded sub-steps toward the singular end(s) bring it under
    // the pieces' own error.
    let sing_start = in_cut && p.after_event;
    let sing_end = in_cut && event;
    let n_sub = if sing_start || sing_end {
        SINGULAR_SUBSTEPS
    } else {
        1
    };
    let node = |j: usize| -> f64 {
        let x = j as f64 / n_sub as f64;
        match (sing_start, sing_end) {
            (true, true) if x <= 0.5 => 0.5 * (2.0 * x).powi(GRADING),
            (true, true) => 1.0 - 0.5 * (2.0 - 2.0 * x).powi(GRADING),
            (true, false) => x.powi(GRADING),
            (false, true) => 1.0 - (1.0 - x).powi(GRADING),
            (false, false) => x,
        }
    };
    let b_end = b_now.get();
    let t1 = if event { t + h } else { t_stop };
    let mut ys = *y;
    for j in 0..n_sub {
        let (th0, th1) = (node(j), node(j + 1));
        let ts = t + th0 * h;
        // The last sub-step ends where the step does, to the bit (the knot of a cut event).
        let hs = if j + 1 == n_sub {
            t1 - ts
        } else {
            (th1 - th0) * h
        };
        // The sub-step's window: from the right at its start, from the left at its end.
        let xa = if j == 0 { a } else { a + th0 * h };
        let xb = if j + 1 == n_sub { b_end } else { a + th1 * h };
        let sub = if n_sub == 1 {
            att.step
        } else {
            b_now.set(xb);
            let fs = if j == 0 { f0 } else { rhs(ts, &ys) };
            // `surface` maps stage times by `a + (t − t0)`: exact for a sub-step's stages.
            dp.attempt(&mut rhs, ts, &ys, &fs, hs).step
        };
        if !sub.y1.iter().all(|x| x.is_finite()) {
            return Err(SimError::NonFinite { t_s: ts + hs });
        }
        let hist = p.hist.borrow();
        let (y0, ym, y1) = (
            hist.eval(xa, true),
            hist.eval(0.5 * (xa + xb), true),
            hist.eval(xb, false),
        );
        drop(hist);
        let d2 = 2.0 * (y1 - 2.0 * ym + y0) / (hs * hs);
        let seg = DpSegment {
            step: sub,
            bar: p.bar,
            sys: p.sys,
            cut,
            d: [y0, (y1 - y0) / hs - d2 * hs, d2],
            in_cut,
        };
        obs.segment(&seg);
        ys = sub.y1;
    }
    *y = ys;
    Ok((t1, event))
}
