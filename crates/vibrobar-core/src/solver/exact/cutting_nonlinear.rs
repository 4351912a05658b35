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
//! Accuracy: the history's Hermite pieces are 4th order, DP5 5th: the measured order in the
//! piece length is about 4 (test `three_quarter_convergence_order`). Integrals of the segments
//! (RMS, energy books) are Gauss–Legendre on the dense output.

use super::cutting::History;
use crate::error::SimError;
use crate::excitation::Cutting;
use crate::params::{Bar, State, System};
use crate::solver::dopri5::{DenseStep, Dopri5};
use crate::solver::{CutSample, Mode, Observer, Segment, SegmentIntegrals};
use std::cell::RefCell;

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
pub(super) struct Piece<'a> {
    pub bar: &'a Bar,
    pub sys: &'a System,
    pub cut: &'a Cutting,
    pub hist: &'a RefCell<History>,
    pub tau: f64,
}

/// Advance the bar state `y = [u, u̇]` from `t` by one DP5 step to `t_stop` (or to the tool
/// leaving / re-entering the cut before it), hand the step to `obs`; returns the new time and
/// whether the step ended at a cut event.
pub(super) fn step(
    p: &Piece,
    in_cut: bool,
    t: f64,
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
    let chip = |t: f64, u: f64| -> f64 {
        let s = p.hist.borrow().eval(t - p.tau, true);
        cut.feed_m + cut.chip_direction_factor * (s - u)
    };
    let mut rhs = |t: f64, y: &[f64; 2]| -> [f64; 2] {
        let f_cut = if in_cut {
            cut.force_on_bar_n(chip(t, y[0]))
        } else {
            0.0
        };
        [y[1], (p.sys.force_n(t) + f_cut - c * y[1] - k * y[0]) / m]
    };
    let dp = Dopri5::<2> {
        rtol: 0.0,
        atol: [1.0; 2],
    };
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
            att = dp.attempt(&mut rhs, t, y, &f0, h);
            event = true;
        }
    }
    if !att.step.y1.iter().all(|x| x.is_finite()) {
        return Err(SimError::NonFinite { t_s: t + h });
    }
    let a = t - p.tau;
    let b = t + h - p.tau;
    let hist = p.hist.borrow();
    let (y0, ym, y1) = (
        hist.eval(a, true),
        hist.eval(0.5 * (a + b), true),
        hist.eval(b, false),
    );
    drop(hist);
    let d2 = 2.0 * (y1 - 2.0 * ym + y0) / (h * h);
    let seg = DpSegment {
        step: att.step,
        bar: p.bar,
        sys: p.sys,
        cut,
        d: [y0, (y1 - y0) / h - d2 * h, d2],
        in_cut,
    };
    obs.segment(&seg);
    *y = att.step.y1;
    let t1 = if event { t + h } else { t_stop };
    Ok((t1, event))
}
