//! The cutting process (issue #13) on a modal bar ([`ModalSystem`]: the N-mode beam, measured
//! `[[modes]]`): the delay stepping of [`super::super::cutting`] (the same pieces ending at the
//! breakpoints `t_k + T`, the same [`History`] of the machined surface, the same quadratic for
//! the delayed surface over a piece, driven by [`super::super::cut_loop`]) on the modal bar's
//! event rules ([`super::ModalExact`]).
//!
//! The cut acts at the force point: `u_tip = Σ φ_f,n qₙ`, the chip `h = h0 + c_chip (s(t − T) −
//! u_tip)`. With the linear law the force `c_force K_f b h` is, in the cut, the stiffness
//! `k_c φ_f φ_fᵀ` (`k_c = c_force K_f b c_chip`) plus the polynomial forcing
//! `φ_f c_force K_f b (h0 + c_chip d(τ))` (`d` the delayed surface's quadratic). So over a piece
//! the bar is a linear system with constant coefficients,
//!
//! `M_h q̈ + C q̇ + K_c q = φ_f g_f(τ) + φ_d g_d`,
//!
//! with `K_c = K + k_c φ_f φ_fᵀ` in the cut (`K` out of it), `M_h = M + m_d φ_d φ_dᵀ` while the
//! ball is held at the cavity (stick, wall contact, a summed chatter sequence; `M` in free
//! flight), `g_f` the static force, the harmonic force and the cut's polynomial, `g_d = −F_ball`
//! the sliding friction in free flight. Four systems at most, each decomposed once per run when
//! first needed ([`LinSys`]): the rank-one (in the cut) or rank-two (in the cut, ball held)
//! coupling of the modes makes them a general symmetric quadratic eigenproblem
//! `(λ²M_h + λC + K_c)φ = 0`. Its eigenvalues come from nalgebra's real Schur form of the
//! first-order matrix (balanced by the modal frequencies), each pair is then polished by Newton
//! on the bordered quadratic problem (residual to rounding), and the modal coordinates
//! `zⱼ = φⱼᵀ(C q + M_h q̇ + λⱼ M_h q)/aⱼ`, `aⱼ = φⱼᵀ(2λⱼM_h + C)φⱼ`, come from the orthogonality of
//! the symmetric pencil: no inverse of the eigenvector matrix is formed. A general eigensolver
//! rather than the secular equation of [`super::super::constrained`]: with the ball held in the
//! cut the update is rank two, and one code path serves all four systems; the secular equation
//! would need a separate root bracketing per rank. Conditioning is tested (reconstruction of a
//! state from its `zⱼ`, `tests::decomposition_reconstructs_states`).
//!
//! Each `zⱼ` obeys `żⱼ = λⱼzⱼ + βⱼ·g(τ)` with polynomial and harmonic `g`: a closed form (a
//! polynomial, a harmonic and `e^{λⱼτ}`). Every quantity the events need (`w`, `ẇ`, the chip,
//! the holding force) is a real [`ExpSumN`] on one basis of terms (one per eigenpair), searched
//! jointly by [`first_root_n`] with its no-missed-root argument unchanged. That argument needs
//! every term to decay (`Re λ ≤ 0`): it holds here, because the coupled systems have symmetric
//! positive definite `M_h`, `K_c` and `C ≥ 0`, so no in-cut mode grows; a growth above the lobe
//! comes from the delayed surface, which is the forcing of each piece (the lumped path likewise
//! only ever sees the stiffness `K + k_c`). The decomposition checks `Re λ ≤ 0` and refuses
//! otherwise.
//!
//! Events: the modal event rules (impacts with [`modal_impact`], friction switches, stick,
//! unstick, wall contact and release, the chatter limit summed at `e = 0` and held on the wall),
//! with the bar's acceleration at the cavity including the cutting force; and the tool leaving or
//! re-entering the cut (`h` crossing 0), each adding a breakpoint to the history. Integrals for
//! the observers (RMS, the energy books with the cutting work) by Gauss–Legendre quadrature on
//! pieces of at most half a radian of the fastest motion.
//!
//! Accuracy: as on the lumped bar, the only approximation is the delayed surface's quadratic
//! over a piece; the run converges as `Δ⁴` in the piece length (measured in
//! `tests/modal_cutting.rs`, `modal_cutting_convergence_order`). A one-mode `[[modes]]` table is
//! the lumped cutting run (to 1e-9 relative, test `one_mode_table_is_the_lumped_cutting_run`).
//!
//! The three-quarter law, with and without a ball: as on the lumped bar
//! ([`super::super::cutting`]), the force is the linear law's plus the remainder
//! `R = c_force F(h) − c_force K_f b h`, fitted over each segment in the cut as the quadratic
//! through its start, middle and end values by the one fixed-point iteration of every bar
//! ([`cut_loop::remainder_fit`], its tolerance and cap; each dry run this segment with the
//! previous fit) and added to the polynomial forcing along `φ_f`. The segments stay closed forms and their
//! events the same joint search, so the guarantees above hold for the motion the pieces carry;
//! the books' cutting work is that force's. Measured (`tests/modal_cutting_three_quarter.rs`): a
//! one-mode table is the lumped three-quarter run to ~1e-13 relative (impacting ball, ball out
//! of reach through loss of contact); on the 4-mode paper beam the order is 3.99 in the cut and
//! 1.98 through loss of contact (where `R ∝ h^{3/4}` has an unbounded slope).
//!
//! Under `[contact] law = "hertz"` a wall touch starts the compliant contact phase of
//! [`cutting_hertz`] (DP5 on the modes and the ball with the cut's force, piece by piece).
//!
//! A run can be kept and continued ([`ModalCutting::run_keeping`], [`ModalCutting::continue_run`],
//! the same [`CutContinuation`] as the lumped bar's with the modal state): the history and the
//! state carry over, the ball's mode is found again from the state (a continued run is the
//! uninterrupted one to 1e-17 m without a ball, 7e-11 m of 3e-4 m with 2767 impacts; test
//! `a_continued_modal_run_is_the_uninterrupted_run`).
//!
//! Scope: both force laws, both contact laws; a run kept inside a `hertz` contact phase is
//! continued with the phase where it stopped, as on the lumped bar.

// The loops run over parallel per-mode and per-pair arrays (shapes, eigenpairs, coefficients).
#![allow(clippy::needless_range_loop)]

use super::super::cut_loop::{self, too_many_events, CutCount, Pieces, CONTINUE_OTHER_BAR};
use super::super::cutting::{
    BarEnd, CutContinuation, History, DEFAULT_STEPS_PER_PERIOD, GL8, MAX_EVENT_KNOTS,
};
use super::super::driver::{self, flight, wall_of, Cavity, Kernel, Md, Tally, CUT, HORIZON};
use super::super::expsum_n::{ExpSumN, Term, MAX_TERMS};
use super::super::hertz_cut::{self, CutOver, PieceEnd};
use super::super::hertz_phase;
use super::super::roots_n::{first_root_n, CandN, Root, ScratchN, MAX_CANDS};
use super::ModalExact;

/// The ball modes and their helpers are the modal solver's ([`super`]); a `HertzTouch` runs as
/// the contact phase of [`cutting_hertz`], never as a closed-form segment.
const HERTZ_REFUSED: &str =
    "a hertz contact phase runs in cutting_hertz, not as a closed-form segment";

#[path = "cutting_hertz.rs"]
mod cutting_hertz;
use crate::analysis::contact_test::CONTACT_RTOL;
use crate::damper::friction::{holding_capacity_n, sliding_friction_on_ball_n};
use crate::damper::impact::{modal_impact, modal_inverse_effective_mass_per_kg};
use crate::error::SimError;
use crate::excitation::{Cutting, CuttingForceLaw};
use crate::limits::MAX_BEAM_MODES;
use crate::params::{CavityMotion, FrictionModel, State};
use crate::solver::modal_rk4::ModalRunSummary;
use crate::solver::{
    CutSample, Event, EventKind, Mode, Observer, RunSummary, Segment, SegmentIntegrals,
};
use crate::structure::{ModalState, ModalSystem, Point};
use nalgebra::DMatrix;
use num_complex::Complex64 as C;

const NM: usize = MAX_BEAM_MODES;

/// The exact solver on a cutting run of a modal bar.
///
/// The initial state given to [`ModalCutting::run`] is an offset from the static equilibrium of
/// the cut on a smooth surface ([`ModalCutting::equilibrium_q_m`], the history the tool at rest
/// there, the ball at rest at the cavity centre): `q_m`, `dq_m_s` offset the modes, `v_m`,
/// `dv_m_s` the ball (so `w` is the state's own).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModalCutting {
    /// Event limit and invariant checks, as for every exact run.
    pub exact: ModalExact,
    /// The cut.
    pub cutting: Cutting,
    /// Pieces per period of the fastest motion (≥ 4).
    pub steps_per_period: u32,
}

/// One linear system of a cutting run, decomposed: the eigenpairs with `Im λ ≥ 0` (a complex
/// pair counted twice through `wt = 2`, a real eigenvalue once).
#[derive(Debug, Clone)]
struct LinSys {
    n: usize,
    lam: Vec<C>,
    wt: Vec<f64>,
    /// Mode shapes `φⱼ` (N entries each).
    phi: Vec<[C; NM]>,
    /// `1/aⱼ`.
    inv_a: Vec<C>,
    /// `φⱼᵀφ_f`, `φⱼᵀφ_d`, `φⱼᵀφ_r`.
    rho_f: Vec<C>,
    rho_d: Vec<C>,
    rho_r: Vec<C>,
    held: bool,
}

/// Constants of one run.
struct Consts {
    n: usize,
    m: [f64; NM],
    c: [f64; NM],
    k: [f64; NM],
    phi_f: [f64; NM],
    phi_d: [f64; NM],
    phi_r: [f64; NM],
    fs: f64,
    f0: f64,
    om: f64,
    md: f64,
    lg: f64,
    e: f64,
    fl: f64,
    model: FrictionModel,
    kappa: f64,
    has_ball: bool,
    // The cut.
    kfb: f64,
    kc: f64,
    c_chip: f64,
    h0: f64,
    tol_x: f64,
    tol_v: f64,
    tol_f: f64,
    tol_h: f64,
    tol_t: f64,
    chatter_h: f64,
    chatter_t: f64,
    /// The cut's force law is the three-quarter law (its remainder over the linear law fitted
    /// per segment, [`remainder_fit`]); `cut` gives its force `c_force F(h)`.
    nonlinear: bool,
    cut: Cutting,
    /// The compliant law, when `contact.law = hertz` (wall touches start a contact phase).
    hertz: Option<crate::damper::contact::Hertz>,
    /// The contact phase's DP5 relative tolerance.
    contact_rtol: f64,
}

impl Consts {
    /// The three-quarter law's remainder `c_force F(h) − c_force K_f b h` at the chip `h`.
    fn remainder(&self, h: f64) -> f64 {
        self.cut.force_on_bar_n(h) - self.kfb * h
    }

    fn fb(&self, sigma: f64) -> f64 {
        sliding_friction_on_ball_n(self.model, self.fl, sigma)
    }
    fn frictional(&self) -> bool {
        self.model != FrictionModel::None && self.fl > 0.0
    }
    fn dot(&self, row: &[f64; NM], x: &[f64; NM]) -> f64 {
        let mut s = 0.0;
        for i in 0..self.n {
            s += row[i] * x[i];
        }
        s
    }
    fn harmonic(&self, t: f64) -> f64 {
        self.f0 * (self.om * t).sin()
    }
    /// The bar's acceleration at the cavity without the ball's force (the cut's force at the
    /// state's chip included).
    fn a_b(&self, s: &St, in_cut: bool, d0: f64) -> f64 {
        let cs = self;
        let mut f = cs.fs + cs.harmonic(s.t);
        if in_cut {
            let h = cs.h0 + cs.c_chip * (d0 - cs.dot(&cs.phi_f, &s.q));
            f += if cs.nonlinear {
                cs.cut.force_on_bar_n(h)
            } else {
                cs.kfb * h
            };
        }
        let mut a = 0.0;
        for i in 0..cs.n {
            a += cs.phi_d[i] * (cs.phi_f[i] * f - cs.c[i] * s.dq[i] - cs.k[i] * s.q[i]) / cs.m[i];
        }
        a
    }
}

/// Internal state: modal coordinates and the ball relative to the cavity.
#[derive(Debug, Clone, Copy)]
struct St {
    t: f64,
    q: [f64; NM],
    dq: [f64; NM],
    w: f64,
    dw: f64,
}

impl St {
    fn public(&self, cs: &Consts) -> State {
        let (ud, dud) = (cs.dot(&cs.phi_d, &self.q), cs.dot(&cs.phi_d, &self.dq));
        State {
            t_s: self.t,
            u_m: cs.dot(&cs.phi_r, &self.q),
            du_m_s: cs.dot(&cs.phi_r, &self.dq),
            v_m: self.w + ud,
            dv_m_s: self.dw + dud,
            cavity: Some(CavityMotion {
                u_cavity_m: ud,
                du_cavity_m_s: dud,
            }),
        }
    }
    fn modal(&self, cs: &Consts) -> ModalState {
        ModalState {
            t_s: self.t,
            q_m: self.q,
            dq_m_s: self.dq,
            v_m: self.w + cs.dot(&cs.phi_d, &self.q),
            dv_m_s: self.dw + cs.dot(&cs.phi_d, &self.dq),
        }
    }
}

/// Solve `a x = b` (complex, dense, partial pivoting); `None` when singular.
fn solve_c(a: &DMatrix<C>, b: &[C]) -> Option<Vec<C>> {
    let rhs = nalgebra::DVector::from_column_slice(b);
    a.clone()
        .lu()
        .solve(&rhs)
        .map(|x| x.iter().copied().collect())
}

impl LinSys {
    /// Decompose the system of `cs` in the cut or not, the ball held or not.
    fn new(cs: &Consts, in_cut: bool, held: bool) -> Result<LinSys, SimError> {
        let n = cs.n;
        let md = if held { cs.md } else { 0.0 };
        let kc = if in_cut { cs.kc } else { 0.0 };
        let mh = |i: usize, j: usize| -> f64 {
            (if i == j { cs.m[i] } else { 0.0 }) + md * cs.phi_d[i] * cs.phi_d[j]
        };
        let kk = |i: usize, j: usize| -> f64 {
            (if i == j { cs.k[i] } else { 0.0 }) + kc * cs.phi_f[i] * cs.phi_f[j]
        };
        let cc = |i: usize, j: usize| -> f64 {
            if i == j {
                cs.c[i]
            } else {
                0.0
            }
        };
        let m_mat = DMatrix::from_fn(n, n, mh);
        let minv = m_mat.clone().try_inverse().ok_or(SimError::Unsupported(
            "the bar's mass matrix with the ball held is singular (modal masses and ball mass)",
        ))?;
        // The first-order matrix on y = [ωₙ qₙ; q̇ₙ] (entries of the order of the frequencies).
        let sc: Vec<f64> = (0..n).map(|i| (cs.k[i] / cs.m[i]).sqrt()).collect();
        let mk = &minv * DMatrix::from_fn(n, n, kk);
        let mc = &minv * DMatrix::from_fn(n, n, cc);
        let a = DMatrix::from_fn(2 * n, 2 * n, |i, j| {
            if i < n {
                if j == n + i {
                    sc[i]
                } else {
                    0.0
                }
            } else if j < n {
                -mk[(i - n, j)] / sc[j]
            } else {
                -mc[(i - n, j - n)]
            }
        });
        let schur = nalgebra::Schur::try_new(a, f64::EPSILON, 1_000_000).ok_or(
            SimError::Unsupported("the eigenvalues of a modal bar in the cut did not converge"),
        )?;
        let ev = schur.complex_eigenvalues();
        let scale = ev.iter().map(|l| l.norm()).fold(0.0, f64::max);
        let quad = |l: C| -> DMatrix<C> {
            DMatrix::from_fn(n, n, |i, j| {
                C::from(mh(i, j)) * l * l + C::from(cc(i, j)) * l + C::from(kk(i, j))
            })
        };
        let dquad = |l: C, x: &[C]| -> Vec<C> {
            (0..n)
                .map(|i| {
                    (0..n)
                        .map(|j| (C::from(2.0 * mh(i, j)) * l + C::from(cc(i, j))) * x[j])
                        .sum()
                })
                .collect()
        };
        let mut s = LinSys {
            n: 0,
            lam: Vec::new(),
            wt: Vec::new(),
            phi: Vec::new(),
            inv_a: Vec::new(),
            rho_f: Vec::new(),
            rho_d: Vec::new(),
            rho_r: Vec::new(),
            held,
        };
        let mut count = 0usize;
        for l0 in ev.iter().copied().filter(|l| l.im >= -1e-9 * scale) {
            let real = l0.im.abs() <= 1e-9 * scale;
            if real && l0.im < 0.0 {
                continue;
            }
            let mut l = if real { C::new(l0.re, 0.0) } else { l0 };
            // Inverse iteration for the shape, then Newton on the bordered problem
            // (P(λ)φ = 0 with φ's largest entry held at 1).
            let ones = vec![C::new(1.0, 0.0); n];
            let mut p = quad(l);
            let mut x = match solve_c(&p, &ones) {
                Some(x) => x,
                None => {
                    p = quad(l * (1.0 + 1e-12));
                    solve_c(&p, &ones).ok_or(SimError::Unsupported(
                        "a mode shape of a modal bar in the cut could not be found",
                    ))?
                }
            };
            for _ in 0..8 {
                let kmax = (0..n)
                    .max_by(|&i, &j| x[i].norm().total_cmp(&x[j].norm()))
                    .unwrap_or(0);
                let piv = x[kmax];
                for v in x.iter_mut() {
                    *v /= piv;
                }
                let p = quad(l);
                let r: Vec<C> = (0..n)
                    .map(|i| -(0..n).map(|j| p[(i, j)] * x[j]).sum::<C>())
                    .collect();
                let mut jm = p.clone();
                let dp = dquad(l, &x);
                for i in 0..n {
                    jm[(i, kmax)] = dp[i];
                }
                let Some(d) = solve_c(&jm, &r) else { break };
                let dl = d[kmax];
                for i in 0..n {
                    if i != kmax {
                        x[i] += d[i];
                    }
                }
                l += if real { C::new(dl.re, 0.0) } else { dl };
                if dl.norm() <= 1e-15 * l.norm() {
                    break;
                }
            }
            if real {
                for v in x.iter_mut() {
                    *v = C::new(v.re, 0.0);
                }
            }
            if l.re > 0.0 {
                return Err(SimError::Unsupported(
                    "a mode of a modal bar in the cut grows (Re λ > 0): the bar's masses, \
                     damping or stiffness are not positive",
                ));
            }
            if s.lam.iter().any(|o| (*o - l).norm() <= 1e-9 * l.norm()) {
                return Err(SimError::Unsupported(
                    "two modes of a modal bar in the cut coincide (a repeated eigenvalue): \
                     perturb a modal frequency",
                ));
            }
            let mut phi = [C::new(0.0, 0.0); NM];
            phi[..n].copy_from_slice(&x);
            let dp = dquad(l, &x);
            let a: C = (0..n).map(|i| x[i] * dp[i]).sum();
            let row = |r: &[f64; NM]| -> C { (0..n).map(|i| x[i] * r[i]).sum() };
            s.rho_f.push(row(&cs.phi_f));
            s.rho_d.push(row(&cs.phi_d));
            s.rho_r.push(row(&cs.phi_r));
            s.inv_a.push(1.0 / a);
            s.lam.push(l);
            s.wt.push(if real { 1.0 } else { 2.0 });
            s.phi.push(phi);
            count += if real { 1 } else { 2 };
        }
        if count != 2 * n || s.lam.len() > MAX_TERMS {
            return Err(SimError::Unsupported(
                "the eigenvalues of a modal bar in the cut could not be paired (a nearly \
                 critically damped mode)",
            ));
        }
        s.n = s.lam.len();
        Ok(s)
    }

    /// `zⱼ(0)` of a state `(q, q̇)`.
    fn project(&self, cs: &Consts, q: &[f64; NM], dq: &[f64; NM], out: &mut [C]) {
        let n = cs.n;
        let md = if self.held { cs.md } else { 0.0 };
        let (dq_d, q_d) = (cs.dot(&cs.phi_d, dq), cs.dot(&cs.phi_d, q));
        for j in 0..self.n {
            let (phi, l) = (&self.phi[j], self.lam[j]);
            let mut acc = C::new(0.0, 0.0);
            for i in 0..n {
                acc += phi[i] * (cs.c[i] * q[i] + cs.m[i] * dq[i] + l * (cs.m[i] * q[i]));
            }
            acc += self.rho_d[j] * md * (dq_d + l * q_d);
            out[j] = acc * self.inv_a[j];
        }
    }
}

/// The closed form of one segment: `zⱼ(τ) − zⱼ(0) = (e^{λτ} − 1)Eⱼ + c1ⱼτ + c2ⱼτ² +
/// Hpⱼ(e^{iΩτ} − 1) + Hmⱼ(e^{−iΩτ} − 1)`, the ball's own motion, the cut's quadratic.
#[derive(Clone)]
struct Motion {
    sys: usize,
    t0: f64,
    x0: St,
    e: [C; MAX_TERMS],
    c0: [C; MAX_TERMS],
    c1: [C; MAX_TERMS],
    c2: [C; MAX_TERMS],
    hp: [C; MAX_TERMS],
    hm: [C; MAX_TERMS],
    /// Friction force on the ball (free flight).
    fb: f64,
    held: bool,
    in_cut: bool,
    /// `s(t − T)` over the segment, `d0 + d1τ + d2τ²`.
    d: [f64; 3],
    no_ball: bool,
    /// The three-quarter law's fitted remainder `r0 + r1τ + r2τ²` in the cut (set by the
    /// caller before [`Motion::build`], which adds it to the cut's polynomial forcing).
    r: Option<[f64; 3]>,
}

impl Motion {
    fn empty() -> Motion {
        let z = [C::new(0.0, 0.0); MAX_TERMS];
        Motion {
            sys: 0,
            t0: 0.0,
            x0: St {
                t: 0.0,
                q: [0.0; NM],
                dq: [0.0; NM],
                w: 0.0,
                dw: 0.0,
            },
            e: z,
            c0: z,
            c1: z,
            c2: z,
            hp: z,
            hm: z,
            fb: 0.0,
            held: false,
            in_cut: false,
            d: [0.0; 3],
            no_ball: false,
            r: None,
        }
    }

    /// Build the closed form from `s` on system `ls`.
    #[allow(clippy::too_many_arguments)]
    fn build(
        &mut self,
        cs: &Consts,
        ls: &LinSys,
        sys: usize,
        s: &St,
        in_cut: bool,
        d: [f64; 3],
        fb: f64,
        no_ball: bool,
    ) {
        self.sys = sys;
        self.t0 = s.t;
        self.x0 = *s;
        self.fb = fb;
        self.held = ls.held;
        self.in_cut = in_cut;
        self.d = d;
        self.no_ball = no_ball;
        let mut z0 = [C::new(0.0, 0.0); MAX_TERMS];
        ls.project(cs, &s.q, &s.dq, &mut z0);
        // g_f = p0 + p1 τ + p2 τ² + F0 sin(Ω(t0 + τ)).
        let (p0, p1, p2) = match (in_cut, self.r) {
            (false, _) => (cs.fs, 0.0, 0.0),
            (true, None) => {
                let k = cs.kfb * cs.c_chip;
                (cs.fs + cs.kfb * cs.h0 + k * d[0], k * d[1], k * d[2])
            }
            (true, Some(r)) => {
                let k = cs.kfb * cs.c_chip;
                (
                    cs.fs + cs.kfb * cs.h0 + k * d[0] + r[0],
                    k * d[1] + r[1],
                    k * d[2] + r[2],
                )
            }
        };
        let gd = if ls.held { 0.0 } else { -fb };
        let (sn, cn) = (cs.om * s.t).sin_cos();
        let hh = C::new(cs.f0 * sn, -cs.f0 * cn) * 0.5;
        let iom = C::new(0.0, cs.om);
        for j in 0..ls.n {
            let l = ls.lam[j];
            let bf = ls.rho_f[j] * ls.inv_a[j];
            let bd = ls.rho_d[j] * ls.inv_a[j];
            let (g0, g1, g2) = (bf * p0 + bd * gd, bf * p1, bf * p2);
            // The polynomial particular solution of ż = λz + g0 + g1τ + g2τ².
            let c2 = -g2 / l;
            let c1 = (2.0 * c2 - g1) / l;
            let c0 = (c1 - g0) / l;
            let hp = bf * hh / (iom - l);
            let hm = bf * hh.conj() / (-iom - l);
            self.c0[j] = c0;
            self.c1[j] = c1;
            self.c2[j] = c2;
            self.hp[j] = hp;
            self.hm[j] = hm;
            self.e[j] = z0[j] - c0 - hp - hm;
        }
    }

    /// `zⱼ(τ) − zⱼ(0)` for every pair.
    fn dz(&self, ls: &LinSys, cs: &Consts, tau: f64, out: &mut [C]) {
        let sh = (cs.om * tau).sin();
        let half_om = (0.5 * cs.om * tau).sin();
        let chm1 = -2.0 * half_om * half_om;
        let ep = C::new(chm1, sh);
        let em = C::new(chm1, -sh);
        for j in 0..ls.n {
            let l = ls.lam[j];
            let (ea, (sb, cb)) = ((l.re * tau).exp_m1(), (l.im * tau).sin_cos());
            let half = (0.5 * l.im * tau).sin();
            let e1 = C::new(ea * cb - 2.0 * half * half, (1.0 + ea) * sb);
            out[j] = e1 * self.e[j]
                + tau * (self.c1[j] + tau * self.c2[j])
                + self.hp[j] * ep
                + self.hm[j] * em;
        }
    }

    /// The state at `τ` after the segment start.
    fn at(&self, ls: &LinSys, cs: &Consts, tau: f64) -> St {
        let mut dz = [C::new(0.0, 0.0); MAX_TERMS];
        self.dz(ls, cs, tau, &mut dz);
        let mut s = self.x0;
        s.t = self.t0 + tau;
        for i in 0..cs.n {
            let (mut q, mut v) = (0.0, 0.0);
            for j in 0..ls.n {
                let pz = ls.phi[j][i] * dz[j];
                q += ls.wt[j] * pz.re;
                v += ls.wt[j] * (ls.lam[j] * pz).re;
            }
            s.q[i] += q;
            // The state expansion y = Σ [φⱼ; λⱼφⱼ] zⱼ holds under any forcing (Σφⱼφⱼᵀ/aⱼ = 0).
            s.dq[i] += v;
        }
        if self.no_ball {
            s.w = 0.0;
            s.dw = 0.0;
        } else if self.held {
            s.dw = 0.0;
        } else {
            let ud0 = cs.dot(&cs.phi_d, &self.x0.q);
            let dud0 = cs.dot(&cs.phi_d, &self.x0.dq);
            let v0 = self.x0.w + ud0;
            let dv0 = self.x0.dw + dud0;
            let acc = self.fb / cs.md;
            let v = v0 + tau * (dv0 + 0.5 * acc * tau);
            let dv = dv0 + acc * tau;
            s.w = v - cs.dot(&cs.phi_d, &s.q);
            s.dw = dv - cs.dot(&cs.phi_d, &s.dq);
        }
        s
    }

    /// The real sum `Σ wⱼ Re(ρⱼ zⱼ(τ))` of a row with coefficients `ρⱼ = φⱼᵀr`, starting at `f0`.
    fn row_sum(&self, ls: &LinSys, cs: &Consts, rho: &[C], f0: f64, out: &mut ExpSumN) {
        out.om = cs.om;
        out.n = ls.n;
        let (mut c1, mut c2) = (0.0, 0.0);
        let mut x = C::new(0.0, 0.0);
        let mut psum = 0.0;
        for j in 0..ls.n {
            let (w, r, l) = (ls.wt[j], rho[j], ls.lam[j]);
            let dj = r * self.e[j] * w;
            out.t[j] = Term {
                al: -l.re,
                wd: l.im,
                p: dj.re,
                q: -dj.im,
            };
            psum += dj.re;
            c1 += w * (r * self.c1[j]).re;
            c2 += w * (r * self.c2[j]).re;
            x += (r * self.hp[j] + (r * self.hm[j]).conj()) * w;
        }
        out.f0 = f0;
        out.c1 = c1;
        out.c2 = c2;
        out.a = x.re;
        out.b = -x.im;
        out.k0 = f0 - out.a - psum;
    }
}

/// One closed-form piece as the observers see it.
struct CutSegment<'a> {
    t1: f64,
    mode: Mode,
    cs: &'a Consts,
    ls: &'a LinSys,
    mo: &'a Motion,
}

impl CutSegment<'_> {
    fn st(&self, t: f64) -> St {
        self.mo.at(self.ls, self.cs, t - self.mo.t0)
    }
    fn chip(&self, s: &St) -> f64 {
        let x = s.t - self.mo.t0;
        let d = self.mo.d[0] + x * (self.mo.d[1] + x * self.mo.d[2]);
        self.cs.h0 + self.cs.c_chip * (d - self.cs.dot(&self.cs.phi_f, &s.q))
    }
    /// The cutting force the closed form carries: `c_force K_f b h`, plus the fitted remainder
    /// under the three-quarter law.
    fn cut_force(&self, s: &St) -> f64 {
        if !self.mo.in_cut {
            return 0.0;
        }
        let f = self.cs.kfb * self.chip(s);
        match self.mo.r {
            None => f,
            Some(r) => {
                let x = s.t - self.mo.t0;
                f + r[0] + x * (r[1] + x * r[2])
            }
        }
    }
    fn quad<const K: usize>(&self, a: f64, b: f64, f: impl Fn(&St) -> [f64; K]) -> [f64; K] {
        let mut sum = [0.0; K];
        if b <= a {
            return sum;
        }
        let rate = self
            .ls
            .lam
            .iter()
            .map(|l| l.norm())
            .fold(self.cs.om, f64::max);
        let n = ((b - a) * rate / 0.5).ceil().clamp(1.0, 1e6) as usize;
        let h = (b - a) / n as f64;
        for i in 0..n {
            let mid = a + (i as f64 + 0.5) * h;
            for (x, w) in GL8 {
                let s = self.st(mid + 0.5 * h * x);
                for (acc, v) in sum.iter_mut().zip(f(&s)) {
                    *acc += w * v;
                }
            }
        }
        sum.map(|s| 0.5 * h * s)
    }
}

fn energy_j(cs: &Consts, s: &St, ball: bool) -> f64 {
    let mut e = 0.0;
    for i in 0..cs.n {
        e += 0.5 * cs.m[i] * s.dq[i] * s.dq[i] + 0.5 * cs.k[i] * s.q[i] * s.q[i];
    }
    if ball {
        let dv = s.dw + cs.dot(&cs.phi_d, &s.dq);
        e += 0.5 * cs.md * dv * dv;
    }
    e
}

impl Segment for CutSegment<'_> {
    fn t_start_s(&self) -> f64 {
        self.mo.t0
    }
    fn t_end_s(&self) -> f64 {
        self.t1
    }
    fn mode(&self) -> Mode {
        self.mode
    }
    fn state_at(&self, t_s: f64) -> State {
        self.st(t_s).public(self.cs)
    }
    fn integral_u2(&self, a_s: f64, b_s: f64) -> f64 {
        let cs = self.cs;
        self.quad(a_s, b_s, |s| [cs.dot(&cs.phi_r, &s.q).powi(2)])[0]
    }
    fn integrals(&self, a_s: f64, b_s: f64) -> SegmentIntegrals {
        let cs = self.cs;
        let [u2, fw, vl] = self.quad(a_s, b_s, |s| {
            let ur = cs.dot(&cs.phi_r, &s.q);
            let duf = cs.dot(&cs.phi_f, &s.dq);
            let mut v = 0.0;
            for i in 0..cs.n {
                v += cs.c[i] * s.dq[i] * s.dq[i];
            }
            [ur * ur, (cs.fs + cs.harmonic(s.t)) * duf, v]
        });
        let fw_ball = if self.mo.held || self.mo.no_ball || self.mo.fb == 0.0 {
            0.0
        } else {
            self.mo.fb * (self.st(b_s).w - self.st(a_s).w)
        };
        SegmentIntegrals {
            u2_m2_s: u2,
            forcing_work_j: fw,
            viscous_loss_j: vl,
            friction_work_j: fw_ball,
        }
    }
    fn mechanical_energy_j(&self, t_s: f64) -> f64 {
        energy_j(self.cs, &self.st(t_s), !self.mo.no_ball)
    }
    fn cutting_at(&self, t_s: f64) -> Option<CutSample> {
        let s = self.st(t_s);
        Some(CutSample {
            chip_thickness_m: self.chip(&s),
            in_cut: self.mo.in_cut,
            cutting_force_n: self.cut_force(&s),
        })
    }
    fn cutting_work_j(&self, a_s: f64, b_s: f64) -> f64 {
        let cs = self.cs;
        self.quad(a_s, b_s, |s| [self.cut_force(s) * cs.dot(&cs.phi_f, &s.dq)])[0]
    }
}

/// Run bookkeeping: the observer and the books every kernel keeps ([`Tally`]).
struct Book<'a> {
    obs: &'a mut dyn Observer,
    tally: Tally,
}

impl Book<'_> {
    /// One more event at `t`, against the limit per revolution `tau` since `t0` (a cut event
    /// and a ball event alike: [`CutCount::WithBall`]).
    #[inline]
    fn count(&mut self, t: f64, t0: f64, tau: f64) -> Result<(), SimError> {
        let tally = &mut self.tally;
        tally.summary.events += 1;
        if tally.summary.events > tally.max_events {
            return Err(too_many_events(
                tally.summary.events,
                tally.max_events,
                t,
                t0,
                tau,
            ));
        }
        Ok(())
    }
}

/// Everything the stepping of one run shares.
struct Run<'h> {
    cs: Consts,
    /// `[out free, in free, out held, in held]`, decomposed when first needed.
    sys: [Option<LinSys>; 4],
    hist: &'h mut History,
    mo: Motion,
    cands: [CandN; MAX_CANDS],
    ids: [u8; MAX_CANDS],
    search: ScratchN,
    tmp: ExpSumN,
    t0: f64,
    tau: f64,
    /// The three-quarter law's remainder fit for the next segment (`None`: the linear law, or
    /// out of the cut).
    r: Option<[f64; 3]>,
    /// A dry run of the remainder fit: the segment stores no surface knot.
    dry: bool,
}

const CHIP: u8 = 10;

/// How a segment ended.
enum End {
    /// At its planned end.
    Planned,
    /// At the search's work bound (the same mode goes on).
    Horizon,
    /// At the zero of event function `id`.
    At(u8),
}

impl Run<'_> {
    fn sys_index(in_cut: bool, held: bool) -> usize {
        in_cut as usize + 2 * held as usize
    }

    fn ensure(&mut self, in_cut: bool, held: bool) -> Result<usize, SimError> {
        let i = Self::sys_index(in_cut, held);
        if self.sys[i].is_none() {
            self.sys[i] = Some(LinSys::new(&self.cs, in_cut, held)?);
        }
        Ok(i)
    }

    /// One segment from `s` in `mode` up to `t_stop` at most (a forced end `t_forced` for a
    /// summed chatter sequence), with the chip's departure order `chip_order`. Hands it to the
    /// observer; `s` becomes its end state.
    #[allow(clippy::too_many_arguments)]
    fn segment(
        &mut self,
        mode: Md,
        no_ball: bool,
        in_cut: bool,
        d: [f64; 3],
        chip_order: usize,
        s: &mut St,
        t_stop: f64,
        book: &mut Book,
    ) -> Result<End, SimError> {
        let held = matches!(mode, Md::Stick | Md::Contact(_));
        let si = self.ensure(in_cut, held)?;
        let ls = self.sys[si].as_ref().expect("ensured");
        let cs = &self.cs;
        let (sigma, orders) = match mode {
            Md::Free {
                sigma,
                k_plus,
                k_minus,
                k_sw,
            } => (sigma, [k_plus, k_minus, k_sw]),
            _ => (0.0, [0; 3]),
        };
        let fb = if held || no_ball { 0.0 } else { cs.fb(sigma) };
        self.mo.r = if in_cut { self.r } else { None };
        self.mo.build(cs, ls, si, s, in_cut, d, fb, no_ball);
        let mo = &self.mo;
        let mut nc = 0;
        let mut push = |cands: &mut [CandN; MAX_CANDS],
                        ids: &mut [u8; MAX_CANDS],
                        id: u8,
                        order: usize,
                        tol: f64,
                        g: &ExpSumN,
                        sc: f64,
                        k: f64| {
            let c = &mut cands[nc];
            c.g.set_affine(g, sc, k);
            c.order = order;
            c.tol = tol;
            if c.g.is_constant() && c.g.f0 >= -tol {
                return;
            }
            ids[nc] = id;
            nc += 1;
        };
        // The chip: h = h0 + c_chip (d(τ) − u_f(τ)); its margin h in the cut, −h out of it.
        let uf0 = cs.dot(&cs.phi_f, &s.q);
        mo.row_sum(ls, cs, &ls.rho_f, uf0, &mut self.tmp);
        {
            let t = &mut self.tmp;
            // h as an affine map of u_f plus the quadratic.
            let src = *t;
            t.set_affine(&src, -cs.c_chip, cs.h0 + cs.c_chip * d[0]);
            t.c1 += cs.c_chip * d[1];
            t.c2 += cs.c_chip * d[2];
        }
        let chip = self.tmp;
        let sg = if in_cut { 1.0 } else { -1.0 };
        push(
            &mut self.cands,
            &mut self.ids,
            CHIP,
            chip_order,
            cs.tol_h,
            &chip,
            sg,
            0.0,
        );
        if !no_ball {
            let ud0 = cs.dot(&cs.phi_d, &s.q);
            let mut ud = ExpSumN::zero(cs.om);
            mo.row_sum(ls, cs, &ls.rho_d, ud0, &mut ud);
            match mode {
                Md::Free { .. } => {
                    // w = v − u_d, v = v0 + v̇0 τ + ½(F_ball/m_d)τ².
                    let dud0 = cs.dot(&cs.phi_d, &s.dq);
                    let mut w = ud.affine(-1.0, s.w + ud0);
                    w.f0 = s.w;
                    w.c1 += s.dw + dud0;
                    w.c2 += 0.5 * fb / cs.md;
                    w.k0 = w.f0 - w.a - w.t[..w.n].iter().map(|t| t.p).sum::<f64>();
                    let both = !cs.frictional() || sigma == 0.0;
                    if both || sigma > 0.0 {
                        push(
                            &mut self.cands,
                            &mut self.ids,
                            1,
                            orders[0],
                            cs.tol_x,
                            &w,
                            -1.0,
                            cs.lg,
                        );
                    }
                    if both || sigma < 0.0 {
                        push(
                            &mut self.cands,
                            &mut self.ids,
                            2,
                            orders[1],
                            cs.tol_x,
                            &w,
                            1.0,
                            cs.lg,
                        );
                    }
                    if cs.frictional() && sigma != 0.0 {
                        let dw = w.deriv();
                        push(
                            &mut self.cands,
                            &mut self.ids,
                            3,
                            orders[2],
                            cs.tol_v,
                            &dw,
                            sigma,
                            0.0,
                        );
                    }
                }
                Md::Stick | Md::Contact(_) => {
                    // The holding force on the ball, m_d ü_d.
                    let fc = ud.deriv().deriv().affine(cs.md, 0.0);
                    match mode {
                        Md::Stick => {
                            push(
                                &mut self.cands,
                                &mut self.ids,
                                4,
                                0,
                                cs.tol_f,
                                &fc,
                                -1.0,
                                cs.fl,
                            );
                            push(
                                &mut self.cands,
                                &mut self.ids,
                                5,
                                0,
                                cs.tol_f,
                                &fc,
                                1.0,
                                cs.fl,
                            );
                        }
                        Md::Contact(wall) => {
                            let hold = holding_capacity_n(cs.model, cs.fl);
                            push(
                                &mut self.cands,
                                &mut self.ids,
                                6,
                                0,
                                cs.tol_f,
                                &fc,
                                -wall.sign(),
                                hold,
                            );
                        }
                        Md::Free { .. } | Md::HertzTouch(_) => unreachable!(),
                    }
                }
                Md::HertzTouch(_) => unreachable!("{HERTZ_REFUSED}"),
            }
        }
        let span = t_stop - s.t;
        let tol_t = cs.tol_t + 4.0 * f64::EPSILON * s.t.abs();
        let (best, end) = if nc == 0 || span <= 0.0 {
            (span.max(0.0), End::Planned)
        } else {
            let (root, i) = first_root_n(&self.cands[..nc], 0.0, span, tol_t, &mut self.search);
            match root {
                Root::At(t) => (t, End::At(self.ids[i])),
                Root::None => (span, End::Planned),
                Root::Horizon(t) => (t, End::Horizon),
            }
        };
        let t1 = if matches!(end, End::Planned) {
            t_stop
        } else {
            s.t + best
        };
        let seg_mode = if no_ball {
            Mode::NoBall
        } else {
            match mode {
                Md::Free { .. } => Mode::Free,
                Md::Stick => Mode::Stick,
                Md::Contact(w) => Mode::Contact(w),
                Md::HertzTouch(_) => unreachable!("{HERTZ_REFUSED}"),
            }
        };
        let seg = CutSegment {
            t1,
            mode: seg_mode,
            cs,
            ls,
            mo,
        };
        let mut next = mo.at(ls, cs, best);
        next.t = t1;
        if held {
            next.w = s.w;
            next.dw = 0.0;
        }
        if t1 > s.t {
            book.obs.segment(&seg);
        }
        if !(next.q.iter().all(|x| x.is_finite()) && next.dq.iter().all(|x| x.is_finite())) {
            return Err(SimError::NonFinite { t_s: t1 });
        }
        book.tally.check_state(&next)?;
        *s = next;
        if self.dry {
            return Ok(end);
        }
        // The surface knot at the segment end.
        if in_cut {
            let (sv, ds) = (cs.dot(&cs.phi_f, &s.q), cs.dot(&cs.phi_f, &s.dq));
            self.hist.record(s.t, sv, ds);
        } else {
            self.hist.record_out_of_cut(s.t);
        }
        Ok(end)
    }

    /// Hand an event to the observer, store the surface's right side and queue its breakpoint.
    fn event(
        &mut self,
        kind: EventKind,
        before: &St,
        after: &St,
        in_cut: bool,
        book: &mut Book,
    ) -> Result<(), SimError> {
        let cs = &self.cs;
        book.count(after.t, self.t0, self.tau)?;
        if let EventKind::Impact { .. } = kind {
            book.tally.summary.impacts += 1;
        }
        book.tally.check_state(after)?;
        book.obs.event(&Event {
            t_s: after.t,
            kind,
            before: before.public(cs),
            after: after.public(cs),
        });
        if in_cut {
            self.hist.record_right(
                after.t,
                cs.dot(&cs.phi_f, &after.q),
                cs.dot(&cs.phi_f, &after.dq),
            );
        }
        self.hist.add_breakpoint(after.t);
        Ok(())
    }
}

impl ModalCutting {
    /// The exact solver with defaults on `cutting`.
    pub fn new(cutting: Cutting) -> ModalCutting {
        ModalCutting {
            exact: ModalExact::default(),
            cutting,
            steps_per_period: DEFAULT_STEPS_PER_PERIOD,
        }
    }

    /// The static equilibrium of the cut on a smooth surface: `kₙqₙ = φ_f,n (F_s + c_force
    /// F(h0))`.
    pub fn equilibrium_q_m(&self, sys: &ModalSystem) -> [f64; NM] {
        let f = sys.forcing.static_force_n + self.cutting.force_on_bar_n(self.cutting.feed_m);
        let mut q = [0.0; NM];
        for (i, m) in sys.model.modes().iter().enumerate() {
            q[i] = m.shape_force * f / m.modal_stiffness_n_per_m();
        }
        q
    }

    /// Integrate the cutting run of `sys` from the offset `init` (module docs) until `t_end_s`.
    pub fn run(
        &self,
        sys: &ModalSystem,
        init: &ModalState,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<ModalRunSummary, SimError> {
        self.run_with_contact_rtol(sys, init, t_end_s, CONTACT_RTOL, obs)
    }

    /// [`ModalCutting::run`] with the `hertz` contact phase's DP5 relative tolerance `rtol`
    /// (in [1e-13, 1e-3]) in place of [`CONTACT_RTOL`]: for measuring the run's convergence
    /// with it.
    pub fn run_with_contact_rtol(
        &self,
        sys: &ModalSystem,
        init: &ModalState,
        t_end_s: f64,
        rtol: f64,
        obs: &mut dyn Observer,
    ) -> Result<ModalRunSummary, SimError> {
        crate::limits::check(
            "contact phase relative tolerance (rtol)",
            rtol,
            1e-13,
            1e-3,
            "",
        )?;
        self.drive(sys, init, None, t_end_s, rtol, obs).map(|r| r.0)
    }

    /// [`ModalCutting::run`], also returning where the run ended, to continue it.
    pub fn run_keeping(
        &self,
        sys: &ModalSystem,
        init: &ModalState,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<(ModalRunSummary, CutContinuation), SimError> {
        self.drive(sys, init, None, t_end_s, CONTACT_RTOL, obs)
    }

    /// Go on from `from` (the end of an earlier run of the same modal bar) up to `t_end_s` with
    /// this solver's cut, as [`crate::solver::exact::cutting::ExactCutting::continue_run`] does
    /// on the lumped bar: the state and the surface history are the earlier run's, the force law
    /// and width this cut's; the delay and the surface's advance must be the earlier run's. The
    /// ball's mode is found again from the state, as at a start; a run that ended inside a
    /// `hertz` contact phase goes on with the phase where it stopped (the penetration and the
    /// contact's dissipation kept).
    pub fn continue_run(
        &self,
        sys: &ModalSystem,
        from: &CutContinuation,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<(ModalRunSummary, CutContinuation), SimError> {
        let Some(init) = from.modal_state() else {
            return Err(SimError::Unsupported(CONTINUE_OTHER_BAR));
        };
        self.drive(sys, init, Some(from), t_end_s, CONTACT_RTOL, obs)
    }

    fn drive(
        &self,
        sys: &ModalSystem,
        init: &ModalState,
        from: Option<&CutContinuation>,
        t_end_s: f64,
        rtol: f64,
        obs: &mut dyn Observer,
    ) -> Result<(ModalRunSummary, CutContinuation), SimError> {
        let cut = &self.cutting;
        cut.validate()?;
        crate::limits::check(
            "steps_per_period (cutting pieces per fastest period)",
            self.steps_per_period as f64,
            4.0,
            1e6,
            "",
        )?;
        let q_eq = self.equilibrium_q_m(sys);
        let mut start = *init;
        if from.is_none() {
            // A fresh start: `init` is an offset from the equilibrium (a continued run's state
            // is absolute).
            for i in 0..MAX_BEAM_MODES {
                start.q_m[i] += q_eq[i];
            }
            let u_d_eq: f64 = sys
                .model
                .modes()
                .iter()
                .zip(&q_eq)
                .map(|(m, q)| m.shape_cavity * q)
                .sum();
            start.v_m += u_d_eq;
        }
        // A continued run inside a `hertz` contact starts with the ball in the wall: the state
        // is checked at the wall, the penetration is the phase's.
        let resumed = from
            .and_then(|c| c.modal_contact())
            .filter(|_| sys.damper.is_some());
        let checked = match (resumed, &sys.damper) {
            (Some((_, wall)), Some(d)) => {
                let u_d: f64 = (sys.model.modes().iter())
                    .zip(&start.q_m)
                    .map(|(m, q)| m.shape_cavity * q)
                    .sum();
                ModalState {
                    v_m: u_d + wall.sign() * d.half_gap_m(),
                    ..start
                }
            }
            _ => start,
        };
        crate::solver::validate_modal_run(sys, &checked, t_end_s, None)?;
        crate::solver::refuse_ball_body_force(
            sys.damper.as_ref(),
            crate::solver::GRAVITY_ALONG_GAP_CUTTING,
        )?;
        let modes = sys.model.modes();
        let n = modes.len();
        let (md, lg, e, model) = match &sys.damper {
            Some(d) => (d.ball_mass_kg, d.half_gap_m(), d.restitution, d.friction),
            None => (1.0, f64::INFINITY, 0.0, FrictionModel::None),
        };
        let om = sys.omega_rad_s();
        let omax = sys.omega_max_rad_s();
        let kfb = cut.force_direction_factor * cut.coefficient_n_m2 * cut.width_m;
        let u_f_eq: f64 = modes
            .iter()
            .zip(&q_eq)
            .map(|(m, q)| m.shape_force * q)
            .sum();
        let mut cs = Consts {
            n,
            m: [0.0; NM],
            c: [0.0; NM],
            k: [0.0; NM],
            phi_f: sys.row(Point::Force),
            phi_d: sys.row(Point::Cavity),
            phi_r: sys.row(Point::Response),
            fs: sys.forcing.static_force_n,
            f0: sys.forcing.amplitude_n,
            om,
            md,
            lg,
            e,
            fl: sys.friction_level_n(),
            model,
            kappa: 0.0,
            has_ball: sys.damper.is_some(),
            kfb,
            kc: kfb * cut.chip_direction_factor,
            c_chip: cut.chip_direction_factor,
            h0: cut.feed_m,
            tol_x: 1e-15 * lg,
            tol_v: 1e-15 * lg * om.max(omax),
            tol_f: 1e-15
                * sys
                    .forcing
                    .amplitude_n
                    .abs()
                    .max(sys.forcing.static_force_n.abs())
                    .max(sys.friction_level_n())
                    .max(cut.force_on_bar_n(cut.feed_m))
                    .max(f64::MIN_POSITIVE),
            tol_h: 1e-14 * (cut.feed_m + cut.chip_direction_factor * u_f_eq.abs()),
            tol_t: 0.0,
            chatter_h: 1e-10 * lg,
            chatter_t: 1e-9 * 2.0 * std::f64::consts::PI / om,
            nonlinear: cut.force_law == CuttingForceLaw::ThreeQuarter,
            cut: *cut,
            hertz: sys
                .damper
                .filter(|d| d.contact.law == crate::params::ContactLaw::Hertz)
                .map(|d| crate::damper::contact::Hertz::of_damper(&d)),
            contact_rtol: rtol,
        };
        for (i, mode) in modes.iter().enumerate() {
            let (m, k) = (mode.modal_mass_kg, mode.modal_stiffness_n_per_m());
            cs.m[i] = m;
            cs.k[i] = k;
            cs.c[i] = 2.0 * mode.damping_ratio * (k * m).sqrt();
        }
        if cs.has_ball {
            cs.kappa = modal_inverse_effective_mass_per_kg(md, &cs.phi_d[..n], &cs.m[..n]);
        }
        let tau = cut.delay_s();
        let shift = cut.feed_m / cut.chip_direction_factor;
        let in_free = LinSys::new(&cs, true, false)?;
        let w_fast = in_free
            .lam
            .iter()
            .map(|l| l.norm())
            .fold(0.0, f64::max)
            .max(if cs.f0 != 0.0 { om } else { 0.0 });
        cs.tol_t = 1e-15 / om.max(omax).max(w_fast);
        let h_max = (2.0 * std::f64::consts::PI / w_fast / self.steps_per_period as f64).min(tau);
        let cap = 2 * ((tau / h_max).ceil() + 4.0) as usize + MAX_EVENT_KNOTS;
        let t0 = start.t_s;
        let mut s = St {
            t: t0,
            q: start.q_m,
            dq: start.dq_m_s,
            w: 0.0,
            dw: 0.0,
        };
        if cs.has_ball {
            s.w = start.w_m(&sys.model);
            s.dw = start.dw_m_s(&sys.model);
        }
        let u_f0 = cs.dot(&cs.phi_f, &s.q);
        let du_f0 = cs.dot(&cs.phi_f, &s.dq);
        let (in_cut, mut hist) = cut_loop::start_history(from, (cap, tau, shift, t0), || {
            let in_cut = cut.feed_m - cut.chip_direction_factor * (u_f0 - u_f_eq) > 0.0;
            let h = History::smooth(cap, tau, shift, t0, u_f_eq, in_cut, u_f0, du_f0);
            (in_cut, h)
        })?;
        let mut run = Run {
            cs,
            sys: [None, Some(in_free), None, None],
            hist: &mut hist,
            mo: Motion::empty(),
            cands: [CandN {
                g: ExpSumN::zero(0.0),
                order: 0,
                tol: 0.0,
            }; MAX_CANDS],
            ids: [0; MAX_CANDS],
            search: ScratchN::default(),
            tmp: ExpSumN::zero(0.0),
            t0,
            tau,
            r: None,
            dry: false,
        };
        let mut book = Book {
            obs,
            tally: Tally::new(
                RunSummary {
                    final_state: s.public(&run.cs),
                    max_penetration_m: f64::NEG_INFINITY,
                    ..Default::default()
                },
                self.exact.max_events,
                self.exact.check_invariants,
                run.cs.lg,
            ),
        };
        let has_ball = run.cs.has_ball;
        // A `hertz` contact phase carried over a piece end or a cut event (or from the run
        // continued: it goes on where it stopped).
        let mut phase: Option<cutting_hertz::Phase> = resumed.map(|r| r.0);
        let mut mode = match resumed {
            Some((_, wall)) => Md::HertzTouch(wall),
            None if has_ball => {
                let d0 = run.hist.window_quadratic(t0 - tau, t0 - tau)[0];
                let mut k = CutKernel::new(&mut run, &mut book, in_cut, [0.0; 3], 0, d0);
                driver::initial_mode(&mut k, &mut s)?
            }
            None => flight(0.0),
        };
        let mut pc = Pieces::new(t0, tau, t_end_s, in_cut, CutCount::WithBall);
        while s.t < t_end_s {
            let (step_end, win_end) = {
                let h = &mut *run.hist;
                h.forget_before(s.t - tau - h_max, s.t);
                let (end, win, _) = pc.end(h, s.t, h_max);
                (end, win)
            };
            while s.t < step_end {
                let (in_cut, chip_order) = (pc.in_cut, pc.order);
                let a = pc.window_start(s.t);
                let d = run.hist.window_quadratic(a, win_end.max(a));
                run.r = None;
                let cut_event = if let (Md::HertzTouch(wall), Some(law)) = (mode, run.cs.hertz) {
                    // A compliant contact phase over this piece ([`hertz_cut`]).
                    let sw = wall.sign();
                    let over = CutOver {
                        cut: *cut,
                        in_cut,
                        d,
                        h0: run.cs.h0,
                        c_chip: run.cs.c_chip,
                        t_ref: s.t,
                    };
                    let bar = cutting_hertz::PieceBar {
                        cs: &run.cs,
                        in_cut,
                        d0: d[0],
                    };
                    let mut host = cutting_hertz::PhaseHost {
                        book: &mut book,
                        hist: &mut *run.hist,
                        in_cut,
                    };
                    let end = hertz_cut::contact_piece(
                        &bar, &law, over, sw, &mut phase, &mut s, step_end, chip_order, &mut host,
                    )?;
                    match end {
                        PieceEnd::Goes { cut_event } => cut_event,
                        PieceEnd::Released { at, kind } => {
                            run.event(kind, &at, &at, in_cut, &mut book)?;
                            let bar = cutting_hertz::PieceBar {
                                cs: &run.cs,
                                in_cut,
                                d0: run.hist.value_slope(s.t - run.tau).0,
                            };
                            mode = hertz_phase::after_release(&bar, sw, &s);
                            false
                        }
                    }
                } else {
                    if run.cs.nonlinear && in_cut {
                        let r = remainder_fit(
                            &mut run, mode, !has_ball, d, chip_order, &s, step_end, &book,
                        )?;
                        run.r = Some(r);
                    }
                    let mut k =
                        CutKernel::new(&mut run, &mut book, in_cut, d, chip_order, f64::NAN);
                    let next = driver::advance(&mut k, mode, &mut s, step_end)?;
                    mode = match (next, mode) {
                        (Some(m), _) => m,
                        // At the piece's end the same flight goes on, no zero at hand.
                        (None, Md::Free { sigma, .. }) => flight(sigma),
                        (None, m) => m,
                    };
                    k.cut_event
                };
                let cs = &run.cs;
                pc.segment_done(run.hist, &mut book.tally, cut_event, s.t, || {
                    cs.dot(&cs.phi_f, &s.dq)
                })?;
            }
            pc.piece_done(s.t, win_end);
        }
        pc.finish(&mut book.tally);
        book.tally.summary.final_state = s.public(&run.cs);
        let summary = ModalRunSummary {
            summary: book.tally.summary,
            final_state: s.modal(&run.cs),
        };
        let end = hist.into_continuation(
            summary.summary.final_state,
            pc.in_cut,
            BarEnd::Modal(summary.final_state, cut_loop::contact_at_end(mode, phase)),
        );
        Ok((summary, end))
    }
}

/// The three-quarter law's remainder fit over the next segment from `s` (in the cut)
/// ([`cut_loop::remainder_fit`]), each dry run this very segment (mode, chip order, delayed
/// surface `d`) with the previous fit, the tool at the nodes from its closed form.
#[allow(clippy::too_many_arguments)]
fn remainder_fit(
    run: &mut Run,
    mode: Md,
    no_ball: bool,
    d: [f64; 3],
    chip_order: usize,
    s: &St,
    t_stop: f64,
    book: &Book,
) -> Result<[f64; 3], SimError> {
    let u0 = run.cs.dot(&run.cs.phi_f, &s.q);
    let (cut, kfb) = (run.cs.cut, run.cs.kfb);
    run.dry = true;
    let fit = cut_loop::remainder_fit(&cut, kfb, d, u0, t_stop - s.t, |r, len| {
        run.r = Some(*r);
        let mut st = *s;
        let mut null = ();
        let mut dry = Book {
            obs: &mut null,
            tally: Tally {
                max_events: u64::MAX,
                check: false,
                ..book.tally
            },
        };
        run.segment(
            mode, no_ball, true, d, chip_order, &mut st, t_stop, &mut dry,
        )?;
        let (cs, mo) = (&run.cs, &run.mo);
        let ls = run.sys[mo.sys].as_ref().expect("built by the segment");
        let (xm, x1) = (mo.at(ls, cs, 0.5 * len), mo.at(ls, cs, len));
        Ok((
            st.t - s.t,
            cs.dot(&cs.phi_f, &xm.q),
            cs.dot(&cs.phi_f, &x1.q),
        ))
    });
    run.dry = false;
    fit
}

/// The modal bar in a cut as a kernel of the one event loop ([`driver`]): the run, the piece's
/// delayed surface and the chip's state. The transitions read `a_b` with the cut's force at the
/// delayed surface's value `d0` at the state's time.
///
/// A start at `ẇ = 0` under the as-published law with `a_b = 0` exactly stays at rest here: the
/// derivatives of `a_b` would carry the delayed surface's, which the piece does not hold.
struct CutKernel<'a, 'h, 'o> {
    run: &'a mut Run<'h>,
    book: &'a mut Book<'o>,
    in_cut: bool,
    /// The delayed surface's quadratic over the piece.
    d: [f64; 3],
    /// The chip function's departure order at the segment start.
    chip_order: usize,
    /// The delayed surface at the current state's time (set where a segment ends at a ball
    /// event, and after a summed chatter sequence).
    d0: f64,
    /// The segment ended where the tool left or re-entered the cut.
    cut_event: bool,
}

impl<'a, 'h, 'o> CutKernel<'a, 'h, 'o> {
    fn new(
        run: &'a mut Run<'h>,
        book: &'a mut Book<'o>,
        in_cut: bool,
        d: [f64; 3],
        chip_order: usize,
        d0: f64,
    ) -> Self {
        CutKernel {
            run,
            book,
            in_cut,
            d,
            chip_order,
            d0,
            cut_event: false,
        }
    }

    /// One segment in `mode` (the ball held or in flight) and which event ended it, in the
    /// loop's numbering ([`Kernel::free_flight`], [`Kernel::held`]).
    fn piece(&mut self, mode: Md, s: &mut St, t_end_s: f64) -> Result<u8, SimError> {
        let no_ball = !self.run.cs.has_ball;
        let end = self.run.segment(
            mode,
            no_ball,
            self.in_cut,
            self.d,
            self.chip_order,
            s,
            t_end_s,
            self.book,
        )?;
        let id = match end {
            End::Planned => return Ok(0),
            End::Horizon => return Ok(HORIZON),
            End::At(CHIP) => return Ok(CUT),
            End::At(id) => id,
        };
        self.d0 = self.run.hist.value_slope(s.t - self.run.tau).0;
        // Stick's margins are 4 (lags) and 5 (leads), contact's release 6.
        Ok(if id >= 4 { id - 3 } else { id })
    }
}

driver::ball_state!(St, |s| s.w.is_finite()
    && s.dw.is_finite()
    && s.q.iter().all(|x| x.is_finite())
    && s.dq.iter().all(|x| x.is_finite()));

impl Cavity for CutKernel<'_, '_, '_> {
    type St = St;
    driver::cavity_constants!(run.cs);
    fn kappa(&self) -> f64 {
        self.run.cs.kappa
    }
    fn a_b(&self, s: &St) -> f64 {
        self.run.cs.a_b(s, self.in_cut, self.d0)
    }
    fn held_acceleration(&self, s: &St) -> f64 {
        self.run.cs.a_b(s, self.in_cut, self.d0) / (self.run.cs.md * self.run.cs.kappa)
    }
    fn a_b_rates(&self, _s: &St, _ab: f64) -> (f64, f64) {
        (0.0, 0.0)
    }
}

impl Kernel for CutKernel<'_, '_, '_> {
    type Cs = Self;
    fn cs(&self) -> &Self {
        self
    }
    fn free_flight(
        &mut self,
        sigma: f64,
        [k_plus, k_minus, k_sw]: [usize; 3],
        s: &mut St,
        t_end_s: f64,
    ) -> Result<u8, SimError> {
        let mode = Md::Free {
            sigma,
            k_plus,
            k_minus,
            k_sw,
        };
        self.piece(mode, s, t_end_s)
    }
    fn held(&mut self, mode: Md, s: &mut St, t_end_s: f64) -> Result<u8, SimError> {
        self.piece(mode, s, t_end_s)
    }
    fn impact_law(&mut self, sw: f64, s: &mut St) -> Result<(), SimError> {
        let cs = &self.run.cs;
        let n = cs.n;
        s.w = sw * cs.lg;
        let dw = if sw * s.dw > 0.0 { s.dw } else { 0.0 };
        s.dw = dw;
        let before = *s;
        let mut dv = dw + cs.dot(&cs.phi_d, &s.dq);
        let law = modal_impact(
            cs.md,
            cs.e,
            &cs.phi_d[..n],
            &cs.m[..n],
            dw,
            &mut s.dq[..n],
            &mut dv,
        );
        s.dw = -cs.e * dw;
        let after = *s;
        self.event(
            EventKind::Impact {
                wall: wall_of(sw),
                dw_m_s: dw,
                energy_loss_j: law.energy_loss_j,
            },
            &before,
            &after,
        )
    }
    /// The plastic limit now, the ball held on the wall for `dt` on the delayed surface's
    /// tangent line through it. A chip or release zero inside the summed sequence ends it there;
    /// the contact test then decides with the state reached (the cut's change is found again by
    /// the next segment's search from order 0, within the time resolution).
    fn chatter_hold(&mut self, sw: f64, dt: f64, s: &mut St) -> Result<f64, SimError> {
        let run = &mut *self.run;
        let cs = &run.cs;
        let n = cs.n;
        let mut dv = s.dw + cs.dot(&cs.phi_d, &s.dq);
        let law = modal_impact(
            cs.md,
            0.0,
            &cs.phi_d[..n],
            &cs.m[..n],
            s.dw,
            &mut s.dq[..n],
            &mut dv,
        );
        s.dw = 0.0;
        s.w = sw * cs.lg;
        // The delayed surface over the short hold: its tangent line (a few ns of a revolution).
        let (sv, ds) = run.hist.value_slope(s.t - run.tau);
        let t_stop = s.t + dt;
        // The three-quarter law's remainder over the short hold: its value at the start.
        run.r = if cs.nonlinear && self.in_cut {
            let h = cs.h0 + cs.c_chip * (sv - cs.dot(&cs.phi_f, &s.q));
            Some([cs.remainder(h), 0.0, 0.0])
        } else {
            None
        };
        run.segment(
            Md::Contact(wall_of(sw)),
            false,
            self.in_cut,
            [sv, ds, 0.0],
            0,
            s,
            t_stop,
            self.book,
        )?;
        s.w = sw * run.cs.lg;
        s.dw = 0.0;
        self.d0 = run.hist.value_slope(s.t - run.tau).0;
        Ok(law.energy_loss_j)
    }
    fn event(&mut self, kind: EventKind, before: &St, after: &St) -> Result<(), SimError> {
        self.run.event(kind, before, after, self.in_cut, self.book)
    }
    fn compliant_contact(
        &mut self,
        _wall: crate::solver::Wall,
        _s: &mut St,
        _t_end_s: f64,
    ) -> Result<Option<Md>, SimError> {
        // The cutting loop runs a compliant contact piece by piece itself ([`cutting_hertz`]).
        Err(SimError::Unsupported(HERTZ_REFUSED))
    }
    fn cut_event(&mut self) {
        self.cut_event = true;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Constants of a small test system.
    fn cs_placeholder() -> Consts {
        let mut c = Consts {
            n: 1,
            m: [0.0; NM],
            c: [0.0; NM],
            k: [0.0; NM],
            phi_f: [0.0; NM],
            phi_d: [0.0; NM],
            phi_r: [0.0; NM],
            fs: 0.0,
            f0: 0.0,
            om: 1.0,
            md: 1.0,
            lg: 1.0,
            e: 0.0,
            fl: 0.0,
            model: FrictionModel::None,
            kappa: 0.0,
            has_ball: false,
            kfb: 0.0,
            kc: 0.0,
            c_chip: 1.0,
            h0: 1.0,
            tol_x: 0.0,
            tol_v: 0.0,
            tol_f: 0.0,
            tol_h: 0.0,
            tol_t: 0.0,
            chatter_h: 0.0,
            chatter_t: 0.0,
            nonlinear: false,
            cut: Cutting {
                coefficient_n_m2: 0.0,
                width_m: 0.0,
                feed_m: 1.0,
                spindle_rpm: 1.0,
                force_direction_factor: 1.0,
                chip_direction_factor: 1.0,
                force_law: CuttingForceLaw::Linear,
            },
            hertz: None,
            contact_rtol: 0.0,
        };
        c.m[0] = 1.0;
        c.k[0] = 1.0;
        c.c[0] = 0.1;
        c
    }

    fn consts3(held: bool) -> (Consts, LinSys, LinSys) {
        let mut cs = cs_placeholder();
        cs.n = 3;
        for i in 0..3 {
            cs.m[i] = 0.5 + 0.3 * i as f64;
            cs.k[i] = 1e6 * (1.0 + 9.0 * (i * i) as f64);
            cs.c[i] = 0.02 * (cs.k[i] * cs.m[i]).sqrt();
            cs.phi_f[i] = 1.0;
            cs.phi_d[i] = [0.9, -0.5, 0.2][i];
            cs.phi_r[i] = 1.0;
        }
        cs.md = 0.1;
        cs.kc = 3e5;
        let a = LinSys::new(&cs, true, held).unwrap();
        let b = LinSys::new(&cs, false, held).unwrap();
        (cs, a, b)
    }

    /// The eigenpairs satisfy the quadratic problem, and a state is rebuilt from its modal
    /// coordinates `zⱼ` (the conditioning of the decomposition), for all four systems.
    #[test]
    fn decomposition_reconstructs_states() {
        for held in [false, true] {
            let (cs, a, b) = consts3(held);
            for ls in [&a, &b] {
                assert_eq!(ls.n, 3);
                let q = [1e-6, -3e-7, 2e-7];
                let dq = [1e-3, 4e-4, -2e-3];
                let mut qq = [0.0; NM];
                let mut dd = [0.0; NM];
                qq[..3].copy_from_slice(&q);
                dd[..3].copy_from_slice(&dq);
                let mut z = [C::new(0.0, 0.0); MAX_TERMS];
                ls.project(&cs, &qq, &dd, &mut z);
                for i in 0..3 {
                    let (mut qr, mut vr) = (0.0, 0.0);
                    for j in 0..ls.n {
                        qr += ls.wt[j] * (ls.phi[j][i] * z[j]).re;
                        vr += ls.wt[j] * (ls.lam[j] * ls.phi[j][i] * z[j]).re;
                    }
                    assert!((qr - q[i]).abs() <= 1e-14 * 1e-6, "q {i}: {qr} vs {}", q[i]);
                    assert!(
                        (vr - dq[i]).abs() <= 1e-14 * 2e-3,
                        "dq {i}: {vr} vs {}",
                        dq[i]
                    );
                }
                for j in 0..ls.n {
                    assert!(ls.lam[j].re < 0.0);
                }
            }
        }
    }

    /// A segment's closed form under polynomial and harmonic forcing is the ODE's solution (a
    /// fine RK4 of the coupled modes).
    #[test]
    fn closed_form_segment_solves_the_ode() {
        let (mut cs, _, _) = consts3(false);
        cs.kfb = 3e5;
        cs.c_chip = 1.0;
        cs.h0 = 1e-4;
        cs.fs = 2.0;
        cs.f0 = 5.0;
        cs.om = 2500.0;
        let ls = LinSys::new(&cs, true, false).unwrap();
        let mut s = St {
            t: 0.3,
            q: [0.0; NM],
            dq: [0.0; NM],
            w: 0.0,
            dw: 0.0,
        };
        s.q[..3].copy_from_slice(&[1e-6, -2e-7, 5e-8]);
        s.dq[..3].copy_from_slice(&[1e-3, 2e-4, -1e-4]);
        let d = [2e-6, 3e-3, -40.0];
        let mut mo = Motion::empty();
        mo.build(&cs, &ls, 1, &s, true, d, 0.0, true);
        let t_end = 2e-3;
        let rhs = |t: f64, y: &[f64; 6]| -> [f64; 6] {
            let x = t - 0.3;
            let uf = y[0] + y[1] + y[2];
            let f = cs.fs
                + cs.f0 * (cs.om * t).sin()
                + cs.kfb * (cs.h0 + cs.c_chip * (d[0] + x * (d[1] + x * d[2]) - uf));
            let mut o = [0.0; 6];
            for i in 0..3 {
                o[i] = y[3 + i];
                o[3 + i] = (f - cs.c[i] * y[3 + i] - cs.k[i] * y[i]) / cs.m[i];
            }
            o
        };
        let mut y = [s.q[0], s.q[1], s.q[2], s.dq[0], s.dq[1], s.dq[2]];
        let n = 20_000;
        let h = t_end / n as f64;
        let mut t = 0.3;
        let add = |y: &[f64; 6], k: &[f64; 6], a: f64| -> [f64; 6] {
            let mut o = *y;
            for i in 0..6 {
                o[i] += a * k[i];
            }
            o
        };
        for _ in 0..n {
            let k1 = rhs(t, &y);
            let k2 = rhs(t + 0.5 * h, &add(&y, &k1, 0.5 * h));
            let k3 = rhs(t + 0.5 * h, &add(&y, &k2, 0.5 * h));
            let k4 = rhs(t + h, &add(&y, &k3, h));
            for i in 0..6 {
                y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            t += h;
        }
        let e = mo.at(&ls, &cs, t_end);
        for i in 0..3 {
            let (sq, sv) = (
                y[..3].iter().map(|x| x.abs()).fold(0.0, f64::max),
                y[3..].iter().map(|x| x.abs()).fold(0.0, f64::max),
            );
            assert!(
                (e.q[i] - y[i]).abs() < 1e-9 * sq,
                "q{i}: {} vs {}",
                e.q[i],
                y[i]
            );
            assert!(
                (e.dq[i] - y[3 + i]).abs() < 1e-9 * sv,
                "dq{i}: {} vs {}",
                e.dq[i],
                y[3 + i]
            );
        }
        // The chip sum is the chip of that state.
        let mut g = ExpSumN::zero(cs.om);
        mo.row_sum(&ls, &cs, &ls.rho_f, cs.dot(&cs.phi_f, &s.q), &mut g);
        let uf = e.q[0] + e.q[1] + e.q[2];
        assert!(
            (g.value(t_end) - uf).abs() < 1e-12 * uf.abs(),
            "{} vs {uf}",
            g.value(t_end)
        );
    }
}
