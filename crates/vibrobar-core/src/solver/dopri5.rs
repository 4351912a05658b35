//! Dormand–Prince 5(4) with its 4th-order dense output (Hairer, Nørsett & Wanner, *Solving ODEs
//! I*, §II.5–6, the `DOPRI5` coefficients), for the nonlinear contact phase of the `hertz` law.
//!
//! Hand-written, not a crate: the phase needs a fixed-size state on the stack (`[f64; N]`, `N =
//! 2·modes + 2`), no allocation per step or per contact, and the step's dense output as a value
//! to bracket the end of contact on. The maintained Rust ODE crates checked (`ode_solvers` 0.6:
//! `Vec` per step and a stored solution; `diffsol`: sparse/dense matrix machinery for stiff
//! systems; `differential-equations`: boxed dynamic state) all allocate or add far more than
//! these sixty lines. The method is the standard non-stiff workhorse: the contact period (tens
//! of µs) is the fastest time scale of the phase, so an explicit method is not stiff there.

/// One accepted step and its dense output: `y(t0 + θh) = r0 + θ(r1 + (1−θ)(r2 + θ(r3 + (1−θ) r4)))`.
#[derive(Debug, Clone, Copy)]
pub struct DenseStep<const N: usize> {
    /// Start time.
    pub t0: f64,
    /// Step size.
    pub h: f64,
    /// State at the start and at the end.
    pub y0: [f64; N],
    /// State at `t0 + h`.
    pub y1: [f64; N],
    r: [[f64; N]; 5],
    /// Components integrated (the rest are carried unchanged).
    len: usize,
}

impl<const N: usize> DenseStep<N> {
    /// The dense output at local fraction `θ ∈ [0, 1]` (4th order, continuous across steps).
    #[inline]
    pub fn at_theta(&self, th: f64) -> [f64; N] {
        let t1 = 1.0 - th;
        let mut y = self.r[0];
        for (i, yi) in y.iter_mut().enumerate().take(self.len) {
            let r = |k: usize| self.r[k][i];
            *yi = r(0) + th * (r(1) + t1 * (r(2) + th * (r(3) + t1 * r(4))));
        }
        y
    }
    /// Bounds `(lo, hi)` of component `i` of the dense output over the whole step `θ ∈ [0, 1]`:
    /// `r0 + θ r1` lies between `y0` and `y1`, and `θ(1−θ) ≤ 1/4` bounds the rest. Lets an event
    /// scan skip a step where the component cannot reach 0 (exact: no sample can be outside).
    #[inline]
    pub fn comp_bounds(&self, i: usize) -> (f64, f64) {
        let r = |k: usize| self.r[k][i];
        let (a, b) = (r(0), r(0) + r(1));
        let curv = 0.25 * (r(2).abs() + r(3).abs() + 0.25 * r(4).abs());
        // Margin for the rounding of the evaluated polynomial.
        let round =
            8.0 * f64::EPSILON * (r(0).abs() + r(1).abs() + r(2).abs() + r(3).abs() + r(4).abs());
        (a.min(b) - curv - round, a.max(b) + curv + round)
    }
    /// One component of the dense output at `θ`.
    #[inline]
    pub fn comp(&self, i: usize, th: f64) -> f64 {
        let t1 = 1.0 - th;
        let r = |k: usize| self.r[k][i];
        r(0) + th * (r(1) + t1 * (r(2) + th * (r(3) + t1 * r(4))))
    }
}

/// Error control of [`Dopri5`]: `|err_i| ≤ atol_i + rtol·max(|y0_i|, |y1_i|)` in the RMS norm
/// over the first `len` components.
#[derive(Debug, Clone, Copy)]
pub struct Dopri5<const N: usize> {
    /// Relative tolerance.
    pub rtol: f64,
    /// Absolute tolerance per component.
    pub atol: [f64; N],
    /// Components integrated, `≤ N`: a fixed-capacity state (the N-mode bar's, sized for
    /// [`crate::limits::MAX_BEAM_MODES`]) integrates only its first `len`; the rest are carried
    /// unchanged and left out of the error norm.
    pub len: usize,
}

const C: [f64; 7] = [0.0, 0.2, 0.3, 0.8, 8.0 / 9.0, 1.0, 1.0];
const A21: f64 = 0.2;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;
const D1: f64 = -12715105075.0 / 11282082432.0;
const D3: f64 = 87487479700.0 / 32700410799.0;
const D4: f64 = -10690763975.0 / 1880347072.0;
const D5: f64 = 701980252875.0 / 199316789632.0;
const D6: f64 = -1453857185.0 / 822651844.0;
const D7: f64 = 69997945.0 / 29380423.0;

/// Outcome of one attempted step.
#[derive(Debug, Clone, Copy)]
pub struct Attempt<const N: usize> {
    /// The step (valid whether accepted or not).
    pub step: DenseStep<N>,
    /// Derivative at the end (first stage of the next step, FSAL).
    pub f1: [f64; N],
    /// Scaled error norm; the step is accepted when `≤ 1`.
    pub err: f64,
}

impl<const N: usize> Dopri5<N> {
    /// Every component integrated.
    pub fn new(rtol: f64, atol: [f64; N]) -> Self {
        Dopri5 { rtol, atol, len: N }
    }

    /// One step of size `h` from `(t, y)` with derivative `f0 = f(t, y)`.
    pub fn attempt<F: FnMut(f64, &[f64; N]) -> [f64; N]>(
        &self,
        f: &mut F,
        t: f64,
        y: &[f64; N],
        f0: &[f64; N],
        h: f64,
    ) -> Attempt<N> {
        let len = self.len.min(N);
        let lin = |cs: &[(f64, &[f64; N])]| {
            let mut out = *y;
            for (i, o) in out.iter_mut().enumerate().take(len) {
                let mut acc = 0.0;
                for (c, k) in cs {
                    acc += c * k[i];
                }
                *o += h * acc;
            }
            out
        };
        let k1 = *f0;
        let k2 = f(t + C[1] * h, &lin(&[(A21, &k1)]));
        let k3 = f(t + C[2] * h, &lin(&[(A31, &k1), (A32, &k2)]));
        let k4 = f(t + C[3] * h, &lin(&[(A41, &k1), (A42, &k2), (A43, &k3)]));
        let k5 = f(
            t + C[4] * h,
            &lin(&[(A51, &k1), (A52, &k2), (A53, &k3), (A54, &k4)]),
        );
        let k6 = f(
            t + h,
            &lin(&[(A61, &k1), (A62, &k2), (A63, &k3), (A64, &k4), (A65, &k5)]),
        );
        let y1 = lin(&[(A71, &k1), (A73, &k3), (A74, &k4), (A75, &k5), (A76, &k6)]);
        let k7 = f(t + h, &y1);
        let mut acc = 0.0;
        let mut r = [[0.0; N]; 5];
        r[0] = *y;
        for i in 0..len {
            let e =
                h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i]);
            let sc = self.atol[i] + self.rtol * y[i].abs().max(y1[i].abs());
            acc += (e / sc) * (e / sc);
            let dy = y1[i] - y[i];
            let bspl = h * k1[i] - dy;
            r[0][i] = y[i];
            r[1][i] = dy;
            r[2][i] = bspl;
            r[3][i] = dy - h * k7[i] - bspl;
            r[4][i] =
                h * (D1 * k1[i] + D3 * k3[i] + D4 * k4[i] + D5 * k5[i] + D6 * k6[i] + D7 * k7[i]);
        }
        let err = (acc / len as f64).sqrt();
        Attempt {
            step: DenseStep {
                t0: t,
                h,
                y0: *y,
                y1,
                r,
                len,
            },
            f1: k7,
            err: if err.is_nan() { f64::INFINITY } else { err },
        }
    }

    /// The next step size after an error `err` on a step of size `h` (safety 0.9, factor
    /// within [0.2, 5]).
    #[inline]
    pub fn next_h(h: f64, err: f64) -> f64 {
        let fac = if err == 0.0 {
            5.0
        } else {
            (0.9 * err.powf(-0.2)).clamp(0.2, 5.0)
        };
        h * fac
    }
}

/// The first `θ ∈ (0, 1]` where `g(θ)` changes sign from `g(0) ≥ 0` to `< 0`, bracketed on the
/// dense output: `samples` equal sub-intervals are scanned (a sign change inside one sub-interval
/// that comes back within it is missed only if `g` wiggles faster than the step's polynomial of
/// degree 4 allows: with `samples ≥ 5` a degree-4 polynomial has at most 4 roots, so every
/// sub-interval holding an odd number of them shows a sign change), then bisected to rounding.
pub fn first_sign_change<G: Fn(f64) -> f64>(g: G, samples: usize) -> Option<f64> {
    let mut a = 0.0;
    let mut ga = g(0.0);
    for k in 1..=samples {
        let b = k as f64 / samples as f64;
        let gb = g(b);
        if ga >= 0.0 && gb < 0.0 {
            let (mut lo, mut hi) = (a, b);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                if g(mid) >= 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            return Some(hi);
        }
        a = b;
        ga = gb;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The harmonic oscillator over ten periods: the end state and the dense output between
    /// steps agree with `cos t` to the tolerance (5th order steps, 4th order interpolant).
    #[test]
    fn oscillator_end_state_and_dense_output_match_the_closed_form() {
        let ig = Dopri5::<2>::new(1e-11, [1e-13; 2]);
        let mut f = |_t: f64, y: &[f64; 2]| [y[1], -y[0]];
        let (mut t, mut y, mut h) = (0.0_f64, [1.0, 0.0], 1e-3_f64);
        let mut f0 = f(t, &y);
        let t_end = 20.0 * std::f64::consts::PI;
        let mut worst_dense = 0.0_f64;
        let mut steps = 0;
        while t < t_end {
            h = h.min(t_end - t);
            let a = ig.attempt(&mut f, t, &y, &f0, h);
            if a.err <= 1.0 {
                let mid = a.step.at_theta(0.5);
                worst_dense = worst_dense.max((mid[0] - (t + 0.5 * h).cos()).abs());
                t += h;
                y = a.step.y1;
                f0 = a.f1;
                steps += 1;
            }
            h = Dopri5::<2>::next_h(h, a.err);
        }
        assert!((y[0] - t_end.cos()).abs() < 1e-8, "{y:?}");
        assert!(worst_dense < 1e-8, "{worst_dense}");
        assert!(steps < 5000, "{steps}");
    }

    /// The sign-change bracket finds `cos` zero at `π/2` on a step of the dense output.
    #[test]
    fn sign_change_is_bracketed_to_rounding() {
        let th = first_sign_change(|x| (3.0 * x).cos(), 8).unwrap();
        assert!((3.0 * th - std::f64::consts::FRAC_PI_2).abs() < 1e-14);
        assert!(first_sign_change(|x| 1.0 + x, 8).is_none());
    }
}
