//! Exact linear stability lobes of regenerative chatter (issue #13 §4). No I/O.
//!
//! **The equation.** Linearised about the steady cut, the tip displacement `u` (at the force
//! point, positive away from the workpiece) of a bar with receptance `G(iω)` obeys
//! `u = G · K_o b [u(t − τ) − u(t)]` in the frequency domain, `K_o = K_f·c_force·c_chip` the
//! oriented cutting coefficient, `b` the width of cut, `τ = 60/n`. The characteristic equation
//! `1 + K_o b G(iω)(1 − e^{−iωτ}) = 0` has a root on the imaginary axis iff
//! `b = −1/(2 K_o Re G(iω))` (needs `Re G < 0`) and `ωτ = 3π + 2 arg G(iω) + 2πj`, `j ≥ 0`.
//! Every `ω` with `Re G < 0` is a chatter frequency of some lobe `j` at the speed
//! `n = 60ω/(ε + 2πj)`, `ε = (3π + 2 arg G) mod 2π ∈ (0, 2π]`.
//!
//! **At one spindle speed** the boundary is the smallest such `b` over all lobes: the roots
//! `ω` of `h(ω) = (ωτ − 3π − 2ψ(ω))/2π ∈ ℤ` (`ψ` the unwrapped phase of `G`) in `Re G < 0`,
//! each found by bracketed root finding (Illinois) to 1e-13 relative in `ω`, not read off a
//! grid. The grid ([`LobeTable`], built once per structure, independent of speed and
//! coefficient) only brackets: its nodes step at most 0.02 rad in phase and 2 % in `|G|` and
//! `ω`, so `h` is monotone enough between nodes that no integer crossing hides inside a cell,
//! and it carries, per cell, a lower bound of `b` (the cell's ends, or the refined minimum of
//! `b` inside it). Cells are visited by increasing lower bound and the search stops as soon as
//! the bound passes the best root found, so a speed costs a few root solves whatever the number
//! of lobes. Beyond the grid's last node `−Re G` decreases (all resonances lie below it); a
//! best root above the last node's `b` extends the grid, so no root beyond it can be smaller.
//!
//! **Three linearisations** ([`Linearisation`]): the ball free (it does not touch the wall at
//! small amplitude: the bar without the ball), the ball stuck at the cavity (its mass added
//! there, damping unchanged:
//! `G' = G_tt + G_tc G_ct m_d ω² / (1 − m_d ω² G_cc)` between tip `t` and cavity `c`), and the
//! solid reference bar (its own modes, ball free).

use crate::error::ParamError;
use crate::structure::{ModalModel, Point};
use num_complex::Complex64;
use std::f64::consts::PI;

/// Largest phase step between grid nodes, rad.
const MAX_PHASE_STEP: f64 = 0.02;
/// Largest relative step of `|G|` and of `ω` between grid nodes.
const MAX_REL_STEP: f64 = 0.02;
/// The grid starts this far below the lowest natural frequency (where `Re G > 0`).
const START_FRACTION: f64 = 1e-2;
/// The grid first ends this far above the highest natural frequency.
const END_FACTOR: f64 = 8.0;
/// The grid is never extended beyond this multiple of the highest natural frequency.
const MAX_END_FACTOR: f64 = 1e7;
/// Relative tolerance of every root in `ω` (the issue asks for 1e-9).
const ROOT_REL_TOL: f64 = 1e-13;
/// Margin on a cell's lower bound of `b` before it is skipped (round-off between nodes).
const PRUNE_MARGIN: f64 = 1e-6;

/// How the ball enters the linearisation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Linearisation {
    /// The ball does not touch the wall: the bar alone.
    BallFree,
    /// The ball held at the cavity (Coulomb sticking): its mass added there.
    BallStuck {
        /// Ball mass `m_d`.
        ball_mass_kg: f64,
    },
}

/// The tip receptance of a bar under one [`Linearisation`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipReceptance {
    model: ModalModel,
    lin: Linearisation,
}

impl TipReceptance {
    /// `model` (every mode damped, `ζ ∈ (0, 1)`) under `lin`; errors name the field.
    pub fn new(model: &ModalModel, lin: Linearisation) -> Result<Self, ParamError> {
        for m in model.modes() {
            m.validate()?;
            if !(m.damping_ratio > 0.0 && m.damping_ratio < 1.0) {
                return Err(ParamError::OutOfRange {
                    field: "damping_ratio of every mode (lobes)",
                    value: m.damping_ratio,
                    allowed: "(0, 1) (an undamped mode has b_lim = 0 at its resonance)",
                });
            }
        }
        if let Linearisation::BallStuck { ball_mass_kg } = lin {
            crate::params::positive("damper.ball_mass_kg", ball_mass_kg)?;
        }
        Ok(TipReceptance { model: *model, lin })
    }

    /// `(G(iω), dG/dω)` at the force point (tip), m/N and m/(N·rad/s).
    pub fn eval(&self, omega_rad_s: f64) -> (Complex64, Complex64) {
        let w = omega_rad_s;
        let zero = Complex64::new(0.0, 0.0);
        let (mut gtt, mut dtt, mut gtc, mut dtc, mut gcc, mut dcc) =
            (zero, zero, zero, zero, zero, zero);
        let stuck = matches!(self.lin, Linearisation::BallStuck { .. });
        for m in self.model.modes() {
            let wn = m.omega_rad_s;
            let den = Complex64::new(wn * wn - w * w, 2.0 * m.damping_ratio * wn * w);
            let dden = Complex64::new(-2.0 * w, 2.0 * m.damping_ratio * wn);
            let inv = 1.0 / (m.modal_mass_kg * den);
            let dinv = -dden * inv / den;
            let (pt, pc) = (m.shape(Point::Force), m.shape(Point::Cavity));
            gtt += pt * pt * inv;
            dtt += pt * pt * dinv;
            if stuck {
                gtc += pt * pc * inv;
                dtc += pt * pc * dinv;
                gcc += pc * pc * inv;
                dcc += pc * pc * dinv;
            }
        }
        match self.lin {
            Linearisation::BallFree => (gtt, dtt),
            Linearisation::BallStuck { ball_mass_kg } => {
                let mu = ball_mass_kg * w * w;
                let dmu = 2.0 * ball_mass_kg * w;
                let d = 1.0 - mu * gcc;
                let dd = -dmu * gcc - mu * dcc;
                let num = gtc * gtc * mu;
                let dnum = 2.0 * gtc * dtc * mu + gtc * gtc * dmu;
                (gtt + num / d, dtt + (dnum * d - num * dd) / (d * d))
            }
        }
    }

    /// The unwrapped phase near a node: `psi_ref + principal(arg G − arg_ref)`.
    fn phase_near(g: Complex64, psi_ref: f64, arg_ref: f64) -> f64 {
        psi_ref + principal(g.arg() - arg_ref)
    }
}

/// `x` wrapped into (−π, π].
pub(crate) fn principal(x: f64) -> f64 {
    let y = x.rem_euclid(2.0 * PI);
    if y > PI {
        y - 2.0 * PI
    } else {
        y
    }
}

/// `ε = (3π + 2 arg G) mod 2π`, in (0, 2π].
pub(crate) fn epsilon(g: Complex64) -> f64 {
    let e = (3.0 * PI + 2.0 * g.arg()).rem_euclid(2.0 * PI);
    if e <= 0.0 {
        2.0 * PI
    } else {
        e
    }
}

/// `s = −1/(2 Re G)` (N/m; `b = s/K_o`), `+∞` where `Re G ≥ 0`.
pub(crate) fn stiffness_bound(re_g: f64) -> f64 {
    if re_g < 0.0 {
        -0.5 / re_g
    } else {
        f64::INFINITY
    }
}

/// `h(ω) = (ωτ − 3π − 2ψ)/2π`: on a lobe `h` is an integer.
pub(crate) fn lobe_phase(omega: f64, psi: f64, tau: f64) -> f64 {
    (omega * tau - 3.0 * PI - 2.0 * psi) / (2.0 * PI)
}

/// The nearest integer `k` that `h` crosses moving from `p` towards `q` (`(ω, ψ)` each), if
/// any, with the two points ordered by `ω`.
#[allow(clippy::type_complexity)]
pub(crate) fn nearest_crossing(
    p: (f64, f64),
    q: (f64, f64),
    tau: f64,
) -> Option<(f64, (f64, f64), (f64, f64))> {
    let (hp, hq) = (lobe_phase(p.0, p.1, tau), lobe_phase(q.0, q.1, tau));
    let k = if hq > hp { hp.ceil() } else { hp.floor() };
    let crossed = if hq > hp {
        k <= hq
    } else if hq < hp {
        k >= hq
    } else {
        k.total_cmp(&hp).is_eq()
    };
    let (l, r) = if p.0 < q.0 { (p, q) } else { (q, p) };
    crossed.then_some((k, l, r))
}

/// The root of `h = k` in `[l, r]` (`l`, `r` with their phases; `h − k` changes sign), the
/// phase at `ω` given by `psi`.
pub(crate) fn crossing_frequency(
    psi: impl Fn(f64) -> f64,
    l: (f64, f64),
    r: (f64, f64),
    k: f64,
    tau: f64,
) -> f64 {
    illinois(
        |w: f64| lobe_phase(w, psi(w), tau) - k,
        l.0,
        r.0,
        lobe_phase(l.0, l.1, tau) - k,
        lobe_phase(r.0, r.1, tau) - k,
    )
}

/// A root of `f` in `[a, b]` with `f(a)·f(b) ≤ 0` (Illinois), to `ROOT_REL_TOL`·|x|.
pub(crate) fn illinois(
    mut f: impl FnMut(f64) -> f64,
    mut a: f64,
    mut b: f64,
    mut fa: f64,
    mut fb: f64,
) -> f64 {
    if fa == 0.0 {
        return a;
    }
    if fb == 0.0 {
        return b;
    }
    let mut side = 0i8;
    for _ in 0..200 {
        // A secant through equal values is NaN or outside: bisect then.
        let x = (a * fb - b * fa) / (fb - fa);
        let x = if x > a.min(b) && x < a.max(b) {
            x
        } else {
            0.5 * (a + b)
        };
        let fx = f(x);
        if fx == 0.0 || (b - a).abs() <= ROOT_REL_TOL * x.abs() {
            return x;
        }
        if (fx > 0.0) == (fb > 0.0) {
            b = x;
            fb = fx;
            if side == 1 {
                fa *= 0.5;
            }
            side = 1;
        } else {
            a = x;
            fa = fx;
            if side == -1 {
                fb *= 0.5;
            }
            side = -1;
        }
    }
    0.5 * (a + b)
}

/// One grid node.
#[derive(Debug, Clone, Copy)]
struct Node {
    omega: f64,
    g: Complex64,
    /// Unwrapped phase of `G`.
    psi: f64,
    /// `d Re G/dω`.
    re_dg: f64,
}

/// One cell between nodes `i` and `i + 1` with `Re G ≤ 0` on it.
#[derive(Debug, Clone, Copy)]
struct Cell {
    /// Index of its left node.
    left: usize,
    /// A lower bound of `s = −1/(2 Re G)` on the cell.
    lower_s: f64,
    /// The refined local minimum of `s` inside the cell: `(ω, ψ, s)`.
    interior_min: Option<(f64, f64, f64)>,
}

/// The stability boundary at one spindle speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundaryPoint {
    /// Limiting width of cut `b_lim`, m.
    pub b_lim_m: f64,
    /// Chatter frequency on the boundary, Hz.
    pub chatter_frequency_hz: f64,
    /// Lobe index `j ≥ 0` (`ωτ = ε + 2πj`).
    pub lobe: u64,
}

/// The speed-independent part of the lobes of one receptance (module docs).
#[derive(Debug, Clone)]
pub struct LobeTable {
    rec: TipReceptance,
    nodes: Vec<Node>,
    cells: Vec<Cell>,
    /// Cells by increasing `lower_s`.
    order: Vec<usize>,
    /// Highest natural frequency (the grid's scale).
    omega_max: f64,
}

impl LobeTable {
    /// Tabulate `rec` from below its lowest resonance to [`END_FACTOR`] × its highest.
    pub fn new(rec: TipReceptance) -> Result<Self, ParamError> {
        let modes = rec.model.modes();
        let omega_min = modes
            .iter()
            .map(|m| m.omega_rad_s)
            .fold(f64::INFINITY, f64::min);
        let omega_max = modes.iter().map(|m| m.omega_rad_s).fold(0.0, f64::max);
        // A stuck ball lowers every resonance, never below ω₁/√(1 + m_d Σφ_c²/m) > 0; start low
        // enough to be under all of them.
        let start = match rec.lin {
            Linearisation::BallFree => START_FRACTION * omega_min,
            Linearisation::BallStuck { ball_mass_kg } => {
                let extra: f64 = modes
                    .iter()
                    .map(|m| m.shape_cavity * m.shape_cavity / m.modal_mass_kg)
                    .sum::<f64>()
                    * ball_mass_kg;
                START_FRACTION * omega_min / (1.0 + extra).sqrt()
            }
        };
        let (g, dg) = rec.eval(start);
        let mut t = LobeTable {
            rec,
            nodes: vec![Node {
                omega: start,
                g,
                psi: g.arg(),
                re_dg: dg.re,
            }],
            cells: Vec::new(),
            order: Vec::new(),
            omega_max,
        };
        t.extend_to(END_FACTOR * omega_max)?;
        Ok(t)
    }

    /// The receptance tabulated.
    pub fn receptance(&self) -> &TipReceptance {
        &self.rec
    }

    /// Continue the grid to `omega_end` and rebuild the cells.
    fn extend_to(&mut self, omega_end: f64) -> Result<(), ParamError> {
        let first_new_cell = self.nodes.len() - 1;
        let mut last = *self.nodes.last().expect("the grid has a first node");
        let mut step = MAX_REL_STEP * last.omega;
        while last.omega < omega_end {
            let mut h = step
                .min(MAX_REL_STEP * last.omega)
                .min(omega_end - last.omega);
            let next = loop {
                let w = last.omega + h;
                let (g, dg) = self.rec.eval(w);
                let wm = last.omega + 0.5 * h;
                let (gm, _) = self.rec.eval(wm);
                let dpsi = principal(g.arg() - last.g.arg());
                let dpsi_m = principal(gm.arg() - last.g.arg());
                let dmag = (g.norm() / last.g.norm()).ln().abs();
                let ok = dpsi.abs() <= MAX_PHASE_STEP
                    && dmag <= MAX_REL_STEP
                    && (dpsi_m - 0.5 * dpsi).abs() <= 0.25 * MAX_PHASE_STEP;
                if ok || h <= 1e-12 * last.omega {
                    break Node {
                        omega: w,
                        g,
                        psi: last.psi + dpsi,
                        re_dg: dg.re,
                    };
                }
                h *= 0.5;
            };
            if !(next.g.re.is_finite() && next.g.im.is_finite()) {
                return Err(ParamError::NotFinite {
                    field: "tip receptance of the modes (lobes)",
                    value: next.g.re,
                });
            }
            // A sign change of Re G inside the step: insert the zero as a node, so every cell
            // lies on one side of it.
            if (last.g.re < 0.0) != (next.g.re < 0.0) && last.g.re != 0.0 && next.g.re != 0.0 {
                let rec = self.rec;
                let w0 = illinois(
                    |w| rec.eval(w).0.re,
                    last.omega,
                    next.omega,
                    last.g.re,
                    next.g.re,
                );
                if w0 > last.omega && w0 < next.omega {
                    let (g0, dg0) = rec.eval(w0);
                    let zero = Node {
                        omega: w0,
                        g: Complex64::new(0.0, g0.im),
                        psi: TipReceptance::phase_near(g0, last.psi, last.g.arg()),
                        re_dg: dg0.re,
                    };
                    self.nodes.push(zero);
                }
            }
            self.nodes.push(next);
            step = 2.0 * h;
            last = next;
        }
        crate::limits::check_count(
            "lobe grid nodes",
            self.nodes.len(),
            2,
            10_000_000,
            "a structure with more phase changes than the grid may hold",
        )?;
        self.build_cells(first_new_cell);
        Ok(())
    }

    /// Cells from node `from` on (earlier cells are kept), then the visiting order.
    fn build_cells(&mut self, from: usize) {
        let rec = self.rec;
        for i in from..self.nodes.len() - 1 {
            let (a, b) = (self.nodes[i], self.nodes[i + 1]);
            if a.g.re > 0.0 || b.g.re > 0.0 || (a.g.re == 0.0 && b.g.re == 0.0) {
                continue;
            }
            let (sa, sb) = (stiffness_bound(a.g.re), stiffness_bound(b.g.re));
            // An interior minimum of s (maximum of −Re G): d Re G/dω goes from < 0 to > 0.
            let interior_min = if a.re_dg < 0.0 && b.re_dg > 0.0 {
                let w = illinois(|w| rec.eval(w).1.re, a.omega, b.omega, a.re_dg, b.re_dg);
                let (g, _) = rec.eval(w);
                Some((
                    w,
                    TipReceptance::phase_near(g, a.psi, a.g.arg()),
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

    /// The smallest `s = −1/(2 Re G)` over all frequencies and its frequency: `(s, ω)`; the
    /// lowest point of every lobe (`b_lim,min = s/K_o`).
    pub fn minimum(&self) -> (f64, f64) {
        self.cells
            .iter()
            .filter_map(|c| c.interior_min)
            .map(|(w, _, s)| (s, w))
            .fold((f64::INFINITY, f64::NAN), |best, x| {
                if x.0 < best.0 {
                    x
                } else {
                    best
                }
            })
    }

    /// The spindle speed (rpm) at which lobe `j` has its lowest point: `60ω*/(ε(ω*) + 2πj)`,
    /// `ω*` of [`LobeTable::minimum`].
    pub fn lobe_minimum_rpm(&self, j: u64) -> f64 {
        let (_, w) = self.minimum();
        let eps = epsilon(self.rec.eval(w).0);
        60.0 * w / (eps + 2.0 * PI * j as f64)
    }

    /// The root of `h = k` in `[l, r]` (`l`, `r` with their phases; `h − k` changes sign),
    /// phases unwrapped from node `anchor`.
    fn solve(&self, anchor: &Node, l: (f64, f64), r: (f64, f64), k: f64, tau: f64) -> f64 {
        let rec = self.rec;
        let psi = |w: f64| TipReceptance::phase_near(rec.eval(w).0, anchor.psi, anchor.g.arg());
        crossing_frequency(psi, l, r, k, tau)
    }

    /// The nearest integer crossing of `h` moving from `p` towards `q` (`(ω, ψ)` each), if any.
    fn nearest_root(&self, anchor: &Node, p: (f64, f64), q: (f64, f64), tau: f64) -> Option<f64> {
        let (k, l, r) = nearest_crossing(p, q, tau)?;
        Some(self.solve(anchor, l, r, k, tau))
    }

    /// The smallest `s` of a root at delay `tau`, with its `ω`, if the grid certifies it (no
    /// root beyond the grid can be smaller).
    fn search(&self, tau: f64) -> Option<(f64, f64)> {
        let mut best: Option<(f64, f64)> = None;
        for &ci in &self.order {
            let c = self.cells[ci];
            if best.is_some_and(|b| c.lower_s * (1.0 - PRUNE_MARGIN) >= b.0) {
                break;
            }
            let (a, b) = (self.nodes[c.left], self.nodes[c.left + 1]);
            let (pa, pb) = ((a.omega, a.psi), (b.omega, b.psi));
            // The best root of the cell is the one nearest to where s is smallest.
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
                let s = stiffness_bound(self.rec.eval(w).0.re);
                if s.is_finite() && best.is_none_or(|b| s < b.0) {
                    best = Some((s, w));
                }
            }
        }
        let tail = stiffness_bound(self.nodes.last()?.g.re);
        best.filter(|b| b.0 < tail)
    }

    /// The boundary at `spindle_rpm` for the oriented coefficient `K_o` (N/m²): the smallest
    /// `b` over all lobes (module docs). Extends the grid when a root may lie beyond it.
    pub fn boundary_at(
        &mut self,
        spindle_rpm: f64,
        oriented_coefficient_n_m2: f64,
    ) -> Result<BoundaryPoint, ParamError> {
        let tau = 60.0 / spindle_rpm;
        loop {
            if let Some((s, w)) = self.search(tau) {
                let eps = epsilon(self.rec.eval(w).0);
                let j = ((w * tau - eps) / (2.0 * PI)).round().max(0.0);
                return Ok(BoundaryPoint {
                    b_lim_m: s / oriented_coefficient_n_m2,
                    chatter_frequency_hz: w / (2.0 * PI),
                    lobe: j as u64,
                });
            }
            let end = self.nodes.last().map_or(0.0, |n| n.omega);
            if end >= MAX_END_FACTOR * self.omega_max {
                return Err(ParamError::OutOfRange {
                    field:
                        "spindle speed (lobes: no chatter frequency within 1e7 × the highest mode)",
                    value: spindle_rpm,
                    allowed:
                        "a speed whose first lobe lies below 1e7 × the highest natural frequency",
                });
            }
            self.extend_to(2.0 * end)?;
        }
    }
}

/// Everything the lobes of a scenario need, in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LobeSpec {
    /// The bar with the cavity.
    pub damped: ModalModel,
    /// The solid reference bar (or the same modes: the `no_ball` reference).
    pub solid: ModalModel,
    /// Ball mass `m_d` (the stuck-ball boundary).
    pub ball_mass_kg: f64,
    /// `K_o = K_f·c_force·c_chip`, N/m².
    pub oriented_coefficient_n_m2: f64,
}

/// One row of the lobes: the three boundaries at one spindle speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LobeRow {
    /// Spindle speed, rpm.
    pub spindle_rpm: f64,
    /// The damped bar, ball free.
    pub ball_free: BoundaryPoint,
    /// The damped bar, ball stuck at the cavity.
    pub ball_stuck: BoundaryPoint,
    /// The solid reference bar.
    pub solid: BoundaryPoint,
}

/// The three lobe tables of a spec.
#[derive(Debug, Clone)]
pub struct Lobes {
    spec: LobeSpec,
    /// Ball free, ball stuck, solid.
    tables: [LobeTable; 3],
}

impl Lobes {
    /// Check the spec and tabulate its three receptances.
    pub fn new(spec: &LobeSpec) -> Result<Self, ParamError> {
        crate::params::positive(
            "cutting.coefficient_n_m2 × direction factors",
            spec.oriented_coefficient_n_m2,
        )?;
        let free = TipReceptance::new(&spec.damped, Linearisation::BallFree)?;
        let stuck = TipReceptance::new(
            &spec.damped,
            Linearisation::BallStuck {
                ball_mass_kg: spec.ball_mass_kg,
            },
        )?;
        let solid = TipReceptance::new(&spec.solid, Linearisation::BallFree)?;
        Ok(Lobes {
            spec: *spec,
            tables: [
                LobeTable::new(free)?,
                LobeTable::new(stuck)?,
                LobeTable::new(solid)?,
            ],
        })
    }

    /// The tables: ball free, ball stuck, solid.
    pub fn tables(&self) -> &[LobeTable; 3] {
        &self.tables
    }

    /// The three boundaries at `spindle_rpm`, checked against the spindle range of
    /// [`crate::limits`] (the same as `[cutting] spindle_rpm`).
    pub fn row(&mut self, spindle_rpm: f64) -> Result<LobeRow, ParamError> {
        crate::limits::check(
            "spindle speed of the lobes (--rpm)",
            spindle_rpm,
            crate::limits::SPINDLE_RPM_MIN,
            crate::limits::SPINDLE_RPM_MAX,
            "revolutions per minute of a lathe spindle",
        )?;
        let k = self.spec.oriented_coefficient_n_m2;
        let [a, b, c] = &mut self.tables;
        Ok(LobeRow {
            spindle_rpm,
            ball_free: a.boundary_at(spindle_rpm, k)?,
            ball_stuck: b.boundary_at(spindle_rpm, k)?,
            solid: c.boundary_at(spindle_rpm, k)?,
        })
    }
}

/// The lobes of `spec` at every speed of `rpms`, in order.
pub fn lobes(spec: &LobeSpec, rpms: &[f64]) -> Result<Vec<LobeRow>, ParamError> {
    let mut l = Lobes::new(spec)?;
    rpms.iter().map(|&n| l.row(n)).collect()
}
