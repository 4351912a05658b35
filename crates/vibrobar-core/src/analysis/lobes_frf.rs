//! Linear stability lobes straight from a measured receptance, with no modal fit. No I/O.
//!
//! **The same boundary as [`crate::analysis::lobes`]:** at the spindle speed `n` (`τ = 60/n`)
//! the limiting width is the smallest `b = −1/(2 K_o Re G(iω))` over the chatter frequencies
//! `ω` with `Re G < 0` and `ωτ = 3π + 2 arg G + 2πj`, `j ≥ 0`. Only `G` differs: here it is a
//! natural cubic spline ([`ComplexSpline`]) through the measured lines, in `ω`, real and
//! imaginary parts together.
//!
//! **Sweeping the lines.** The table walks the measured lines in order and, inside each
//! interval, evaluates the spline at sub-nodes no more than 0.02 rad of phase and 2 % of `|G|`
//! apart (where noise makes the phase flicker at small `|G|`, the sub-nodes follow it), with the
//! zeros of `Re G` inserted as nodes. Every cell of sub-nodes with `Re G ≤ 0` carries a lower
//! bound of `b` (its ends, or the minimum of `b` inside it from the spline's derivative), and a
//! speed visits the cells by increasing bound, solving `h(ω) = (ωτ − 3π − 2ψ)/2π ∈ ℤ` on the
//! spline where it crosses an integer, until the bound passes the best root. No model is
//! assumed: outside the measured band nothing is known, so a boundary is only searched inside
//! it ([`FrfLobeTable::band_edges_negative`] says when the band cuts a region of `Re G < 0`).
//!
//! **Resolution.** A peak whose half-power half-width `ζ·f` is less than 5 line spacings is too
//! coarsely sampled for its `Re G` minimum (the lowest point of its lobes) to be trusted;
//! [`peak_resolution`] finds such peaks from the measured magnitudes.

use crate::analysis::lobes::{
    crossing_frequency, epsilon, illinois, nearest_crossing, principal, stiffness_bound,
    BoundaryPoint,
};
use crate::error::ParamError;
use crate::structure::frf_data::{FrfDataError, FrfKind, MeasuredFrf};
use num_complex::Complex64;
use std::f64::consts::PI;

/// Largest phase step between sub-nodes, rad (as the model's lobes).
const MAX_PHASE_STEP: f64 = 0.02;
/// Largest relative step of `|G|` between sub-nodes.
const MAX_REL_STEP: f64 = 0.02;
/// Margin on a cell's lower bound of `b` before it is skipped (round-off between nodes).
const PRUNE_MARGIN: f64 = 1e-6;
/// Most sub-nodes of one table.
const MAX_NODES: usize = 20_000_000;
/// A peak is under-resolved where `ζ·f < UNDER_RESOLVED_LINES × Δf`.
pub const UNDER_RESOLVED_LINES: f64 = 5.0;
/// Peaks below this fraction of the largest `|G|` are not examined by [`peak_resolution`].
const PEAK_MIN_FRACTION: f64 = 1e-3;

/// A natural cubic spline through complex values at strictly increasing abscissae (second
/// derivative zero at both ends), evaluated with its first derivative.
#[derive(Debug, Clone)]
pub struct ComplexSpline {
    x: Vec<f64>,
    y: Vec<Complex64>,
    /// Second derivatives at the knots.
    m: Vec<Complex64>,
}

impl ComplexSpline {
    /// The natural spline through `(x[i], y[i])`; `x` strictly increasing, at least 2 knots
    /// (the caller checks: [`MeasuredFrf::new`] does).
    pub fn natural(x: &[f64], y: &[Complex64]) -> ComplexSpline {
        let n = x.len();
        assert!(n >= 2 && y.len() == n, "a spline needs ≥ 2 knots");
        let zero = Complex64::new(0.0, 0.0);
        let mut m = vec![zero; n];
        if n > 2 {
            // h_{i−1} M_{i−1} + 2(h_{i−1} + h_i) M_i + h_i M_{i+1} = 6 (Δ_i − Δ_{i−1}) for the
            // inner knots, M_0 = M_{n−1} = 0; Thomas algorithm (diagonally dominant).
            let k = n - 2;
            let mut c = vec![0.0; k];
            let mut d = vec![zero; k];
            for j in 0..k {
                let i = j + 1;
                let (h0, h1) = (x[i] - x[i - 1], x[i + 1] - x[i]);
                let rhs = 6.0 * ((y[i + 1] - y[i]) / h1 - (y[i] - y[i - 1]) / h0);
                let diag = 2.0 * (h0 + h1);
                if j == 0 {
                    c[j] = h1 / diag;
                    d[j] = rhs / diag;
                } else {
                    let den = diag - h0 * c[j - 1];
                    c[j] = h1 / den;
                    d[j] = (rhs - h0 * d[j - 1]) / den;
                }
            }
            m[k] = d[k - 1];
            for j in (0..k - 1).rev() {
                m[j + 1] = d[j] - c[j] * m[j + 2];
            }
        }
        ComplexSpline {
            x: x.to_vec(),
            y: y.to_vec(),
            m,
        }
    }

    /// The knots.
    pub fn knots(&self) -> &[f64] {
        &self.x
    }

    /// The interval `[x_i, x_{i+1}]` holding `t` (the first or last beyond the ends).
    fn interval(&self, t: f64) -> usize {
        let i = self.x.partition_point(|&v| v <= t);
        i.clamp(1, self.x.len() - 1) - 1
    }

    /// `(S(t), S'(t))`; beyond the knots the end cubics continue.
    pub fn eval(&self, t: f64) -> (Complex64, Complex64) {
        self.eval_in(self.interval(t), t)
    }

    /// `(S(t), S'(t))` with the cubic of interval `i`.
    fn eval_in(&self, i: usize, t: f64) -> (Complex64, Complex64) {
        let (x0, x1) = (self.x[i], self.x[i + 1]);
        let h = x1 - x0;
        let (a, b) = (x1 - t, t - x0);
        let (m0, m1) = (self.m[i], self.m[i + 1]);
        let c0 = self.y[i] / h - m0 * (h / 6.0);
        let c1 = self.y[i + 1] / h - m1 * (h / 6.0);
        let s = m0 * (a * a * a / (6.0 * h)) + m1 * (b * b * b / (6.0 * h)) + c0 * a + c1 * b;
        let ds = -m0 * (a * a / (2.0 * h)) + m1 * (b * b / (2.0 * h)) - c0 + c1;
        (s, ds)
    }
}

/// One sub-node.
#[derive(Debug, Clone, Copy)]
struct Node {
    omega: f64,
    g: Complex64,
    /// Unwrapped phase of `G`.
    psi: f64,
    /// `d Re G/dω`.
    re_dg: f64,
}

/// One cell between sub-nodes `left` and `left + 1` with `Re G ≤ 0` on it.
#[derive(Debug, Clone, Copy)]
struct Cell {
    left: usize,
    /// A lower bound of `s = −1/(2 Re G)` on the cell.
    lower_s: f64,
    /// The minimum of `s` inside the cell: `(ω, ψ, s)`.
    interior_min: Option<(f64, f64, f64)>,
}

/// The speed-independent part of the lobes of a measured receptance (module docs).
#[derive(Debug, Clone)]
pub struct FrfLobeTable {
    spline: ComplexSpline,
    nodes: Vec<Node>,
    cells: Vec<Cell>,
    order: Vec<usize>,
}

impl FrfLobeTable {
    /// Tabulate a measured FRF (converted to receptance first; a 0 Hz line is dropped).
    pub fn new(frf: &MeasuredFrf) -> Result<Self, FrfDataError> {
        let g = frf.without_zero_frequency()?.to_receptance()?;
        let omega: Vec<f64> = g.freqs_hz.iter().map(|f| 2.0 * PI * f).collect();
        let spline = ComplexSpline::natural(&omega, &g.values);
        let mut t = FrfLobeTable {
            spline,
            nodes: Vec::new(),
            cells: Vec::new(),
            order: Vec::new(),
        };
        t.sweep()?;
        t.build_cells();
        Ok(t)
    }

    /// The spline of `G(ω)` (knots in rad/s).
    pub fn spline(&self) -> &ComplexSpline {
        &self.spline
    }

    /// `(G, dG/dω)` of the spline.
    fn eval(&self, w: f64) -> (Complex64, Complex64) {
        self.spline.eval(w)
    }

    /// The measured band, rad/s.
    pub fn band_rad_s(&self) -> (f64, f64) {
        let k = self.spline.knots();
        (k[0], k[k.len() - 1])
    }

    /// Whether `Re G < 0` at the lowest and at the highest line: a region of chatter
    /// frequencies cut by the band, whose lobes may continue outside it.
    pub fn band_edges_negative(&self) -> (bool, bool) {
        let (a, b) = (self.nodes[0], self.nodes[self.nodes.len() - 1]);
        (a.g.re < 0.0, b.g.re < 0.0)
    }

    /// Walk the lines; sub-nodes inside each interval (module docs).
    fn sweep(&mut self) -> Result<(), FrfDataError> {
        let knots = self.spline.knots().to_vec();
        let (g0, dg0) = self.eval(knots[0]);
        let mut last = Node {
            omega: knots[0],
            g: g0,
            psi: g0.arg(),
            re_dg: dg0.re,
        };
        self.nodes.push(last);
        for i in 0..knots.len() - 1 {
            let end = knots[i + 1];
            let mut step = end - knots[i];
            while last.omega < end {
                let mut h = step.min(end - last.omega);
                let next = loop {
                    let w = if h >= end - last.omega {
                        end
                    } else {
                        last.omega + h
                    };
                    let (g, dg) = self.spline.eval_in(i, w);
                    let (gm, _) = self.spline.eval_in(i, last.omega + 0.5 * (w - last.omega));
                    let dpsi = principal(g.arg() - last.g.arg());
                    let dpsi_m = principal(gm.arg() - last.g.arg());
                    let dmag = (g.norm() / last.g.norm()).ln().abs();
                    let ok = dpsi.abs() <= MAX_PHASE_STEP
                        && (dmag <= MAX_REL_STEP || !dmag.is_finite())
                        && (dpsi_m - 0.5 * dpsi).abs() <= 0.25 * MAX_PHASE_STEP;
                    if ok || h <= 1e-12 * last.omega.max(w) {
                        break Node {
                            omega: w,
                            g,
                            psi: last.psi + dpsi,
                            re_dg: dg.re,
                        };
                    }
                    h *= 0.5;
                };
                if (last.g.re < 0.0) != (next.g.re < 0.0) && last.g.re != 0.0 && next.g.re != 0.0 {
                    let sp = &self.spline;
                    let w0 = illinois(
                        |w| sp.eval_in(i, w).0.re,
                        last.omega,
                        next.omega,
                        last.g.re,
                        next.g.re,
                    );
                    if w0 > last.omega && w0 < next.omega {
                        let (gz, dgz) = sp.eval_in(i, w0);
                        self.nodes.push(Node {
                            omega: w0,
                            g: Complex64::new(0.0, gz.im),
                            psi: last.psi + principal(gz.arg() - last.g.arg()),
                            re_dg: dgz.re,
                        });
                    }
                }
                self.nodes.push(next);
                if self.nodes.len() > MAX_NODES {
                    return Err(FrfDataError::LineCount {
                        lines: self.nodes.len(),
                        min: 2,
                        max: MAX_NODES,
                    });
                }
                step = 2.0 * (next.omega - last.omega);
                last = next;
            }
        }
        Ok(())
    }

    /// The cells with `Re G ≤ 0` and their visiting order.
    fn build_cells(&mut self) {
        for i in 0..self.nodes.len() - 1 {
            let (a, b) = (self.nodes[i], self.nodes[i + 1]);
            if a.g.re > 0.0 || b.g.re > 0.0 || (a.g.re == 0.0 && b.g.re == 0.0) {
                continue;
            }
            let (sa, sb) = (stiffness_bound(a.g.re), stiffness_bound(b.g.re));
            let interior_min = if a.re_dg < 0.0 && b.re_dg > 0.0 {
                let sp = &self.spline;
                let w = illinois(|w| sp.eval(w).1.re, a.omega, b.omega, a.re_dg, b.re_dg);
                let (g, _) = sp.eval(w);
                Some((
                    w,
                    a.psi + principal(g.arg() - a.g.arg()),
                    stiffness_bound(g.re),
                ))
            } else {
                None
            };
            let lower_s = interior_min.map_or(sa.min(sb), |m| m.2.min(sa).min(sb));
            self.cells.push(Cell {
                left: i,
                lower_s,
                interior_min,
            });
        }
        self.order = (0..self.cells.len()).collect();
        let cells = &self.cells;
        self.order
            .sort_by(|&i, &j| cells[i].lower_s.total_cmp(&cells[j].lower_s));
    }

    /// The smallest `s = −1/(2 Re G)` in the band and its `ω`: `(s, ω)` (the lowest point of
    /// every lobe, `b_lim,min = s/K_o`). `s` is `+∞` where `Re G ≥ 0` on every line.
    pub fn minimum(&self) -> (f64, f64) {
        self.cells
            .iter()
            .map(|c| {
                let (a, b) = (self.nodes[c.left], self.nodes[c.left + 1]);
                let mut best = (stiffness_bound(a.g.re), a.omega);
                if stiffness_bound(b.g.re) < best.0 {
                    best = (stiffness_bound(b.g.re), b.omega);
                }
                match c.interior_min {
                    Some((w, _, s)) if s < best.0 => (s, w),
                    _ => best,
                }
            })
            .fold((f64::INFINITY, f64::NAN), |best, x| {
                if x.0 < best.0 {
                    x
                } else {
                    best
                }
            })
    }

    fn nearest_root(&self, anchor: &Node, p: (f64, f64), q: (f64, f64), tau: f64) -> Option<f64> {
        let (k, l, r) = nearest_crossing(p, q, tau)?;
        let psi = |w: f64| anchor.psi + principal(self.eval(w).0.arg() - anchor.g.arg());
        Some(crossing_frequency(psi, l, r, k, tau))
    }

    /// The boundary at `spindle_rpm` for the oriented coefficient `K_o` (N/m²), inside the
    /// measured band; an error when no chatter frequency of any lobe lies in it.
    pub fn boundary_at(
        &self,
        spindle_rpm: f64,
        oriented_coefficient_n_m2: f64,
    ) -> Result<BoundaryPoint, ParamError> {
        crate::limits::check(
            "spindle speed of the lobes (--rpm)",
            spindle_rpm,
            crate::limits::SPINDLE_RPM_MIN,
            crate::limits::SPINDLE_RPM_MAX,
            "revolutions per minute of a lathe spindle",
        )?;
        crate::params::positive(
            "cutting.coefficient_n_m2 × direction factors",
            oriented_coefficient_n_m2,
        )?;
        let tau = 60.0 / spindle_rpm;
        let mut best: Option<(f64, f64)> = None;
        for &ci in &self.order {
            let c = self.cells[ci];
            if best.is_some_and(|b| c.lower_s * (1.0 - PRUNE_MARGIN) >= b.0) {
                break;
            }
            let (a, b) = (self.nodes[c.left], self.nodes[c.left + 1]);
            let (pa, pb) = ((a.omega, a.psi), (b.omega, b.psi));
            let candidates: [Option<f64>; 2] = match c.interior_min {
                Some((w, psi, _)) => [
                    self.nearest_root(&a, (w, psi), pa, tau),
                    self.nearest_root(&a, (w, psi), pb, tau),
                ],
                None if stiffness_bound(a.g.re) <= stiffness_bound(b.g.re) => {
                    [self.nearest_root(&a, pa, pb, tau), None]
                }
                None => [self.nearest_root(&a, pb, pa, tau), None],
            };
            for w in candidates.into_iter().flatten() {
                let s = stiffness_bound(self.eval(w).0.re);
                if s.is_finite() && best.is_none_or(|b| s < b.0) {
                    best = Some((s, w));
                }
            }
        }
        let Some((s, w)) = best else {
            return Err(ParamError::OutOfRange {
                field: "spindle speed (lobes from a measured FRF: no chatter frequency of any lobe inside the measured band)",
                value: spindle_rpm,
                allowed: "a speed whose lobes cross a part of the band where Re G < 0 (lower speeds, or a wider measured band)",
            });
        };
        let eps = epsilon(self.eval(w).0);
        let j = ((w * tau - eps) / (2.0 * PI)).round().max(0.0);
        Ok(BoundaryPoint {
            b_lim_m: s / oriented_coefficient_n_m2,
            chatter_frequency_hz: w / (2.0 * PI),
            lobe: j as u64,
        })
    }
}

/// How well one resonance peak of a measured FRF is sampled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeakResolution {
    /// Frequency of the peak line, Hz.
    pub peak_hz: f64,
    /// `ζ·f` estimated as half the half-power bandwidth (linear interpolation of `|G|`), Hz.
    pub zeta_f_hz: f64,
    /// The line spacing at the peak, Hz.
    pub line_spacing_hz: f64,
    /// `ζ·f < 5 Δf`: too few lines across the peak.
    pub under_resolved: bool,
}

/// The resonance peaks of the receptance magnitude of `frf` (those at least 0.1 % of the largest,
/// with both half-power points inside the band) and how well each is resolved, highest first.
pub fn peak_resolution(frf: &MeasuredFrf) -> Result<Vec<PeakResolution>, FrfDataError> {
    let g = if frf.kind == FrfKind::Receptance {
        frf.clone()
    } else {
        frf.without_zero_frequency()?.to_receptance()?
    };
    let a: Vec<f64> = g.values.iter().map(|v| v.norm()).collect();
    let f = &g.freqs_hz;
    let n = a.len();
    let top = a.iter().copied().fold(0.0, f64::max);
    let mut cand: Vec<usize> = (1..n.saturating_sub(1))
        .filter(|&i| a[i] >= a[i - 1] && a[i] > a[i + 1] && a[i] >= PEAK_MIN_FRACTION * top)
        .collect();
    cand.sort_by(|&i, &j| a[j].total_cmp(&a[i]));
    let mut taken: Vec<(usize, usize)> = Vec::new();
    let mut out = Vec::new();
    for i in cand {
        if taken.iter().any(|&(l, r)| i >= l && i <= r) {
            continue;
        }
        let half = a[i] / std::f64::consts::SQRT_2;
        // Walk down each side to the first line under half power; a higher line first means
        // this is a shoulder of a larger peak, not a peak of its own.
        let side = |dir: isize| -> Option<(usize, f64)> {
            let mut j = i as isize;
            loop {
                let k = j + dir;
                if k < 0 || k as usize >= n {
                    return None;
                }
                let ku = k as usize;
                if a[ku] > a[i] {
                    return None;
                }
                if a[ku] <= half {
                    let ju = j as usize;
                    let t = (a[ju] - half) / (a[ju] - a[ku]);
                    return Some((ku, f[ju] + t * (f[ku] - f[ju])));
                }
                j = k;
            }
        };
        let (Some((l, fl)), Some((r, fr))) = (side(-1), side(1)) else {
            continue;
        };
        taken.push((l, r));
        let spacing = 0.5 * (f[i + 1] - f[i - 1]);
        let zeta_f = 0.5 * (fr - fl);
        out.push(PeakResolution {
            peak_hz: f[i],
            zeta_f_hz: zeta_f,
            line_spacing_hz: spacing,
            under_resolved: zeta_f < UNDER_RESOLVED_LINES * spacing,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spline_matches_a_hand_solved_case_and_lines() {
        // Knots (0,0), (1,1), (2,0): M₁ = −3, S(0.5) = 0.6875, S'(0) = 1.5·… (closed form).
        let c = |v: f64| Complex64::new(v, -2.0 * v);
        let s = ComplexSpline::natural(&[0.0, 1.0, 2.0], &[c(0.0), c(1.0), c(0.0)]);
        let (v, d) = s.eval(0.5);
        assert!((v - c(0.6875)).norm() < 1e-15, "{v}");
        // S'(x) on [0,1] = −M₁·… : S = −x³/2 + 1.5x, S' = −1.5x² + 1.5 → S'(0.5) = 1.125.
        assert!((d - c(1.125)).norm() < 1e-15, "{d}");
        assert!((s.eval(1.5).0 - c(0.6875)).norm() < 1e-15);
        // Knots are interpolated and a straight line is reproduced (uneven knots).
        let x = [0.0, 0.3, 1.1, 1.2, 4.0, 4.5];
        let y: Vec<Complex64> = x
            .iter()
            .map(|&t| Complex64::new(2.0 * t - 1.0, 0.5 * t))
            .collect();
        let s = ComplexSpline::natural(&x, &y);
        for (&t, &v) in x.iter().zip(&y) {
            assert!((s.eval(t).0 - v).norm() < 1e-14);
        }
        for t in [0.1, 0.7, 2.5, 4.4] {
            let (v, d) = s.eval(t);
            assert!((v - Complex64::new(2.0 * t - 1.0, 0.5 * t)).norm() < 1e-14);
            assert!((d - Complex64::new(2.0, 0.5)).norm() < 1e-13);
        }
    }

    #[test]
    fn spline_converges_at_fourth_order_inside() {
        // sin on [0, 6] sampled at h and h/2: the error at an inner point falls 16×.
        let err = |n: usize| {
            let x: Vec<f64> = (0..=n).map(|i| 6.0 * i as f64 / n as f64).collect();
            let y: Vec<Complex64> = x
                .iter()
                .map(|&t| Complex64::new(t.sin(), t.cos()))
                .collect();
            let s = ComplexSpline::natural(&x, &y);
            let t = 3.0 + 0.5 * 6.0 / n as f64;
            (s.eval(t).0 - Complex64::new(t.sin(), t.cos())).norm()
        };
        let (e1, e2) = (err(40), err(80));
        let order = (e1 / e2).log2();
        assert!((order - 4.0).abs() < 0.3, "order {order} ({e1:e}, {e2:e})");
    }

    fn sdof_frf(df: f64, zeta: f64, fn_hz: f64) -> MeasuredFrf {
        let (m, wn) = (0.5, 2.0 * PI * fn_hz);
        let k = m * wn * wn;
        let freqs: Vec<f64> = (1..)
            .map(|i| i as f64 * df)
            .take_while(|&f| f <= 3.0 * fn_hz)
            .collect();
        let values = freqs
            .iter()
            .map(|&f| {
                let w = 2.0 * PI * f;
                1.0 / Complex64::new(k - m * w * w, 2.0 * zeta * m * wn * w)
            })
            .collect();
        MeasuredFrf::new(
            freqs,
            values,
            FrfKind::Receptance,
            None,
            true,
            String::new(),
        )
        .unwrap()
    }

    #[test]
    fn peak_resolution_estimates_zeta_f_and_flags_coarse_lines() {
        // ζ·f = 0.02·500 = 10 Hz: resolved at 0.5 Hz lines, not at 4 Hz lines.
        let fine = peak_resolution(&sdof_frf(0.5, 0.02, 500.0)).unwrap();
        assert_eq!(fine.len(), 1);
        // Half-power points of one mode: f_n√(1 − 2ζ² ∓ 2ζ√(1 − ζ²)), to the line spacing.
        let (z, fnh): (f64, f64) = (0.02, 500.0);
        let bw = fnh
            * ((1.0 - 2.0 * z * z + 2.0 * z * (1.0 - z * z).sqrt()).sqrt()
                - (1.0 - 2.0 * z * z - 2.0 * z * (1.0 - z * z).sqrt()).sqrt());
        assert!(
            (fine[0].zeta_f_hz - 0.5 * bw).abs() < 0.01 * bw,
            "{fine:?} {bw}"
        );
        assert!(!fine[0].under_resolved);
        let coarse = peak_resolution(&sdof_frf(4.0, 0.02, 500.0)).unwrap();
        assert!(coarse[0].under_resolved, "{coarse:?}");
    }
}
