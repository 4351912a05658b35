//! The exact event-driven solver on an N-mode bar ([`ModalSystem`]).
//!
//! Between events every mode is linear with constant coefficients: in free flight mode `n`
//! obeys `mₙq̈ₙ + cₙq̇ₙ + kₙqₙ = φₙ(x_f)F(t) − φₙ(x_d)F_ball` with the constant sliding friction
//! `F_ball` of [`crate::damper::friction`], so each `qₙ` is its own closed form
//! ([`super::expsum::ExpSum`]: static part, forced harmonic, free decay) and the ball moves at
//! constant acceleration `F_ball/m_d`. The relative motion `w = v − Σφₙ(x_d)qₙ` is then one
//! [`ExpSumN`] (polynomial, harmonic, one decaying term per mode), and so are the response
//! `Σφₙ(x_r)qₙ` and the force point's velocity; events are the zeros of such sums, found by
//! [`super::roots_n`] (which cannot miss one: see its argument).
//!
//! The event logic is the one loop's ([`super::driver`]; this module is the N-mode bar's kernel
//! of it), with the bar's quantities read at the cavity through the contact row: impacts at `w = ±l_g` with the modal impact law
//! ([`crate::damper::impact::modal_impact`]; `w` is set to exactly `±l_g`, the ball coordinate
//! follows), `ẇ = 0` (as-published: the sign reverses; coulomb: stick if `|a_b| ≤ F κ` with
//! `κ = 1/m_d + Σφₙ(x_d)²/mₙ`, `a_b = Σφₙ(x_d)q̈ₙ` without the ball's force), the chatter test
//! with `ẅ` at the impact.
//!
//! Stick, wall contact and the chatter limit hold the ball at the cavity: the bar then moves in
//! its constrained modes ([`super::constrained`], computed when a run first holds the ball), the
//! holding force `f_c = m_d φ_dᵀq̈` is again an exponential sum, and unstick (`|f_c|` reaches
//! `F`) and release (`s·f_c` reaches the holding capacity) are its zeros, searched as above. The
//! chatter limit is the modal impact law at `e = 0` (only the contact row is equalised, the
//! other modal velocities keep their components), the ball held on the wall for the summed
//! sequence's duration, then the [`EventKind::ChatterLimit`] with the energy it removed.
//!
//! Under `contact.law = hertz` a wall touch starts the compliant contact phase of [`hertz`]
//! (Dopri5 on the N modes and the ball, the force through the contact row) instead of the impact
//! law; chatter limits and rigid wall contact do not occur under that law.
//!
//! The internal state keeps `w`, `ẇ` (relative coordinates, free of cancellation) beside the
//! modal coordinates; the public state has `v = w + Σφₙ(x_d)qₙ`.
//!
//! The observer protocol: a segment's `state_at` is [`ModalState::public`] (`u` at the response
//! point), `integral_u2` is `∫u(x_r)²`, `integrals` the forcing work `∫F u̇(x_f)`, the viscous
//! loss `Σcₙ∫q̇ₙ²` and the friction work `∫F_ball ẇ`, all in closed form; the segment also gives
//! its modal state and mechanical energy at any time ([`ModalExactSegment::modal_state_at`],
//! [`ModalExactSegment::mechanical_energy_j`]). A [`ModalObserver`] also sees the modal states
//! at the ends of every segment and around every impact.
//!
//! Accuracy (tests/modal_exact.rs, measured): one unit mode reproduces the lumped `Exact` to
//! 2.5e-12 of the scale and event times to 4e-12/Ω over 0.05 s of the paper's cases, and
//! through chatter limits and wall releases to 5.4e-11/Ω; a one-mode beam with the ball at the tip
//! is the lumped bar of its modal mass and stiffness to 1.5e-12 (0.1 mm gap; at 0.05 mm that
//! lighter bar amplifies rounding as the lumped solver does); without a ball the 4-mode beam is the
//! modal closed form to 9e-16 of the scale; the energy books close to 1.2e-14 of the forcing
//! work; the largest penetration over 2 s runs is 7e-19 m. Event times are resolved to
//! `1e-15/max(Ω, ω_N)` plus the rounding of `t`.
//!
//! Cost (the bench's own path, `vibrobar bench` beam rows and `examples/modal_exact_profile.rs
//! N LAW 1 case`; 2 s at ratio 1, 0.1 mm gap, against the lumped `Exact` run): the 4-mode beam
//! 1.8× without friction, 2.8× as published and 2.8× coulomb in instructions (31.4 M, 54.5 M,
//! 54.4 M against 17.3 M, 19.3 M, 19.5 M), after the eighth speed round of issue #8 §8 (the 3×
//! budget met; [`super::roots_n`] says what each change gave and what was tried). With friction
//! the `ẇ = 0` search resolves every mode an impact excites, and there are more friction
//! switches (3 300–3 700 events against 2 700 on the lumped bar); below resonance (r = 0.98–0.99)
//! the 4th mode rings across `ẇ = 0` in bursts of thousands of switches and the run costs 8–9×
//! the lumped one.

use std::cell::RefCell;

use super::driver::{self, wall_of, Cavity, Kernel, Md, Tally, HORIZON};
use super::expsum::{integral_square, ExpSum, Trig};
use crate::damper::impact::{modal_impact, modal_inverse_effective_mass_per_kg};
use crate::error::SimError;
use crate::limits::MAX_BEAM_MODES;
use crate::params::{CavityMotion, FrictionModel, State};
use crate::solver::modal_rk4::{ModalObserver, ModalRunSummary, Plain};
use crate::solver::{
    Event, EventKind, Mode, Observer, RunSummary, Segment, SegmentIntegrals, Wall,
};
use crate::structure::{ModalState, ModalSystem, Point};
use constrained::{ConstrainedModes, ConstrainedMotion, TermSum};
use expsum_n::{
    integral_product_n, integral_square_n, integral_square_n_to, sin_cos, ExpSumN, SquarePlan,
    Term, TrigN,
};
use roots_n::{first_root_n, CandN, Root, ScratchN, MAX_CANDS};

pub mod constrained;
pub mod cutting;
pub mod expsum_n;
mod hertz;
pub mod roots_n;

const NM: usize = MAX_BEAM_MODES;

/// The exact event-driven solver on a modal bar.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModalExact {
    /// Bound on the number of events; beyond it the run stops with [`SimError::TooManyEvents`].
    pub max_events: u64,
    /// Check confinement (`|w| ≤ l_g + 1e-12 m`) and finiteness at every event and segment end.
    pub check_invariants: bool,
}

impl Default for ModalExact {
    fn default() -> Self {
        ModalExact {
            max_events: 10_000_000,
            check_invariants: false,
        }
    }
}

/// The closed form of one mode under a constant force and the harmonic forcing, computed once
/// per run.
#[derive(Debug, Clone, Copy, Default)]
struct ModeOsc {
    kk: f64,
    cw: f64,
    /// `φ_f F0 / ((k − mΩ²)² + (cΩ)²)`.
    f0_d: f64,
    al: f64,
    wd: f64,
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
    osc: [ModeOsc; NM],
    fs: f64,
    f0: f64,
    om: f64,
    md: f64,
    lg: f64,
    e: f64,
    fl: f64,
    model: FrictionModel,
    /// `1/m_d + Σφₙ(x_d)²/mₙ`.
    kappa: f64,
    tol_x: f64,
    tol_v: f64,
    tol_f: f64,
    tol_t: f64,
    chatter_h: f64,
    chatter_t: f64,
    /// The compliant law, when `contact.law = hertz` (wall touches start a compliant contact phase).
    hertz: Option<crate::damper::contact::Hertz>,
    /// `g_s`: the ball's acceleration from its body force along the gap (`+0.0` without one,
    /// whose runs stay bit-identical). In free flight the ball's acceleration gains it; while
    /// the ball is held the constrained modes carry the load `m_d g_s` at the cavity.
    gs: f64,
}

impl Consts {
    fn new(sys: &ModalSystem) -> Result<Consts, SimError> {
        let om = sys.omega_rad_s();
        let (md, lg, e, model) = match &sys.damper {
            Some(d) => (d.ball_mass_kg, d.half_gap_m(), d.restitution, d.friction),
            None => (1.0, f64::INFINITY, 0.0, FrictionModel::None),
        };
        let modes = sys.model.modes();
        let omax = sys.omega_max_rad_s();
        let mut cs = Consts {
            n: modes.len(),
            m: [0.0; NM],
            c: [0.0; NM],
            k: [0.0; NM],
            phi_f: sys.row(Point::Force),
            phi_d: sys.row(Point::Cavity),
            phi_r: sys.row(Point::Response),
            osc: [ModeOsc::default(); NM],
            fs: sys.forcing.static_force_n,
            f0: sys.forcing.amplitude_n,
            om,
            md,
            lg,
            e,
            fl: sys.friction_level_n(),
            model,
            kappa: 0.0,
            tol_x: 1e-15 * lg,
            tol_v: 1e-15 * lg * om.max(omax),
            tol_f: 1e-15
                * sys
                    .forcing
                    .amplitude_n
                    .abs()
                    .max(sys.forcing.static_force_n.abs())
                    .max(sys.friction_level_n())
                    .max(f64::MIN_POSITIVE),
            tol_t: 1e-15 / om.max(omax),
            chatter_h: 1e-10 * lg,
            chatter_t: 1e-9 * 2.0 * std::f64::consts::PI / om,
            hertz: sys
                .damper
                .filter(|d| d.contact.law == crate::params::ContactLaw::Hertz)
                .map(|d| crate::damper::contact::Hertz::of_damper(&d)),
            gs: match &sys.damper {
                Some(d) if d.gravity_along_gap_m_s2 != 0.0 => d.gravity_along_gap_m_s2,
                _ => 0.0,
            },
        };
        for (i, mode) in modes.iter().enumerate() {
            let (m, k) = (mode.modal_mass_kg, mode.modal_stiffness_n_per_m());
            // 2ζ√(km), the lumped bar's `C` formula (as `ModalRk4`).
            let c = 2.0 * mode.damping_ratio * (k * m).sqrt();
            cs.m[i] = m;
            cs.k[i] = k;
            cs.c[i] = c;
            let kk = k - m * om * om;
            let cw = c * om;
            let d = kk * kk + cw * cw;
            let f = cs.phi_f[i] * cs.f0;
            if f != 0.0 {
                if cw == 0.0 && kk.abs() <= 8.0 * f64::EPSILON * k {
                    return Err(SimError::UndampedResonance { omega_rad_s: om });
                }
                if !d.is_normal() || !(f / d).is_finite() {
                    let dyn_k = kk.hypot(cw);
                    return Err(SimError::ResponseOutOfRange {
                        dynamic_stiffness_n_per_m: dyn_k,
                        mass_kg: m,
                        omega_rad_s: om,
                        amplitude_m: f.abs() / dyn_k,
                    });
                }
            }
            let al = c / (2.0 * m);
            cs.osc[i] = ModeOsc {
                kk,
                cw,
                f0_d: if f == 0.0 { 0.0 } else { f / d },
                al,
                wd: (k / m - al * al).sqrt(),
            };
        }
        cs.kappa = if sys.damper.is_some() {
            modal_inverse_effective_mass_per_kg(md, &cs.phi_d[..cs.n], &cs.m[..cs.n])
        } else {
            0.0
        };
        Ok(cs)
    }

    fn tol_t_at(&self, t: f64) -> f64 {
        self.tol_t + 4.0 * f64::EPSILON * t.abs()
    }

    fn dot(&self, row: &[f64; NM], x: &[f64; NM]) -> f64 {
        let mut s = 0.0;
        for i in 0..self.n {
            s += row[i] * x[i];
        }
        s
    }

    /// Modal accelerations without the ball's force, and `a_b = Σφₙ(x_d)q̈ₙ`.
    fn a_b(&self, s: &St) -> f64 {
        let mut a = 0.0;
        for i in 0..self.n {
            a += self.phi_d[i]
                * (self.phi_f[i] * s.force - self.c[i] * s.dq[i] - self.k[i] * s.q[i])
                / self.m[i];
        }
        a
    }

    fn force_at(&self, t: f64) -> f64 {
        self.fs + self.f0 * (self.om * t).sin()
    }
}

/// Internal state: modal coordinates and the relative motion at the cavity.
#[derive(Debug, Clone, Copy)]
struct St {
    t: f64,
    q: [f64; NM],
    dq: [f64; NM],
    w: f64,
    dw: f64,
    /// `F(t)` from the segment's closed form.
    force: f64,
}

impl St {
    fn modal(&self, cs: &Consts) -> ModalState {
        ModalState {
            t_s: self.t,
            q_m: self.q,
            dq_m_s: self.dq,
            v_m: self.w + cs.dot(&cs.phi_d, &self.q),
            dv_m_s: self.dw + cs.dot(&cs.phi_d, &self.dq),
        }
    }

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
}

/// The closed-form motion of one free-flight segment (run-long buffer, rewritten per segment
/// where used).
#[derive(Debug, Clone)]
struct FreeMotion {
    /// `qₙ(τ)` per mode.
    modes: [ExpSum; NM],
    /// `w(τ)`.
    w: ExpSumN,
    /// `u(x_r, τ)`.
    ur: ExpSumN,
    /// `u̇(x_f, τ)`.
    duf: ExpSumN,
    /// `F(t0 + τ)`.
    force: ExpSumN,
    /// Friction force on the ball.
    fb: f64,
    /// The ball is absent (solid bar): `w` is not a motion.
    no_ball: bool,
}

/// Run-long buffers.
struct Work {
    mo: FreeMotion,
    cands: [CandN; MAX_CANDS],
    ids: [u8; MAX_CANDS],
    search: ScratchN,
    end: TrigN,
    probe: RefCell<TrigN>,
    tmp: ExpSumN,
    sq: SquarePlans,
}

/// The plans of `∫u²` for the run's two bases: free flight and the ball held (the constrained
/// modes). Rebuilt where a basis changes; a segment's `integral_u2` (behind `&self`) uses them.
struct SquarePlans {
    free: RefCell<SquarePlan>,
    held: RefCell<SquarePlan>,
}

impl Work {
    fn new() -> Box<Work> {
        let z = ExpSumN::zero(0.0);
        Box::new(Work {
            mo: FreeMotion {
                modes: [ExpSum::default(); NM],
                w: z,
                ur: z,
                duf: z,
                force: z,
                fb: 0.0,
                no_ball: false,
            },
            cands: [CandN {
                g: z,
                order: 0,
                tol: 0.0,
            }; MAX_CANDS],
            ids: [0; MAX_CANDS],
            search: ScratchN::default(),
            end: TrigN::empty(),
            probe: RefCell::new(TrigN::empty()),
            tmp: z,
            sq: SquarePlans {
                free: RefCell::new(SquarePlan::new()),
                held: RefCell::new(SquarePlan::new()),
            },
        })
    }
}

/// The closed-form motion of one segment with the ball held at the cavity (stick, wall
/// contact): the constrained modes' closed form, and the sums the observers need on its basis.
struct PairMotion<'a> {
    motion: ConstrainedMotion<'a>,
    ur: ExpSumN,
    duf: ExpSumN,
    force: ExpSumN,
    /// `w`, constant while held.
    w: f64,
}

/// What moves during a segment.
enum SegMotion<'a> {
    Free(&'a FreeMotion),
    Pair(&'a PairMotion<'a>),
}

/// One closed-form piece of the motion, as the observers see it.
pub struct ModalExactSegment<'a> {
    t0: f64,
    t1: f64,
    mode: Mode,
    cs: &'a Consts,
    m: SegMotion<'a>,
    end: &'a TrigN,
    /// A run-long buffer for the transcendentals at an observer's sample time: a fresh
    /// `TrigN` would zero its full capacity (2 KB) for every sample.
    probe: &'a RefCell<TrigN>,
    sq: &'a SquarePlans,
}

impl ModalExactSegment<'_> {
    fn at_t(&self, tr: &TrigN) -> St {
        match self.m {
            SegMotion::Free(mo) => self.at_t_free(mo, tr),
            SegMotion::Pair(pm) => {
                let (q, dq) = pm.motion.state_at(tr.tau);
                St {
                    t: self.t0 + tr.tau,
                    q,
                    dq,
                    w: pm.w,
                    dw: 0.0,
                    force: pm.force.value_t(tr),
                }
            }
        }
    }

    /// The basis of the segment's sums (for its transcendentals).
    fn basis(&self) -> &ExpSumN {
        match self.m {
            SegMotion::Free(mo) => &mo.w,
            SegMotion::Pair(pm) => &pm.ur,
        }
    }

    fn at_t_free(&self, mo: &FreeMotion, tr: &TrigN) -> St {
        let mut s = St {
            t: 0.0,
            q: [0.0; NM],
            dq: [0.0; NM],
            w: 0.0,
            dw: 0.0,
            force: 0.0,
        };
        self.at_t_free_into(mo, tr, &mut s);
        s
    }

    /// [`ModalExactSegment::at_t_free`] written into `s` (only its first `n` modal entries:
    /// the others are zero in every state of a run), without a 0.5 KB state built and copied.
    fn at_t_free_into(&self, mo: &FreeMotion, tr: &TrigN, s: &mut St) {
        let cs = self.cs;
        s.t = self.t0 + tr.tau;
        s.force = mo.force.value_t(tr);
        s.w = 0.0;
        s.dw = 0.0;
        for i in 0..cs.n {
            let k = &tr.k[i];
            let t1 = Trig {
                ch: tr.ch,
                sh: tr.sh,
                em1: k.em1,
                cd: k.cd,
                sd: k.sd,
                chm1: tr.chm1,
                cdm1: k.cdm1,
                tau: tr.tau,
            };
            let [q, dq]: [f64; 2] = mo.modes[i].derivs_t(&t1);
            s.q[i] = q;
            s.dq[i] = dq;
        }
        if !mo.no_ball {
            let [w, dw]: [f64; 2] = mo.w.derivs_t(tr);
            s.w = w;
            s.dw = dw;
        }
    }

    fn at(&self, t_s: f64) -> St {
        let tau = t_s - self.t0;
        let mut s = if tau.to_bits() == self.end.tau.to_bits() {
            self.at_t(self.end)
        } else {
            let mut tr = self.probe.borrow_mut();
            tr.fill(tau, self.basis());
            self.at_t(&tr)
        };
        s.t = t_s;
        s
    }

    /// The modal state at `t_s` in `[t_start, t_end]`.
    pub fn modal_state_at(&self, t_s: f64) -> ModalState {
        self.at(t_s).modal(self.cs)
    }

    /// Mechanical energy `Σ(½mₙq̇ₙ² + ½kₙqₙ²) + ½m_d v̇²` at `t_s`.
    pub fn mechanical_energy_j(&self, t_s: f64) -> f64 {
        let ball = !matches!(self.m, SegMotion::Free(mo) if mo.no_ball);
        energy_j(self.cs, &self.modal_state_at(t_s), ball)
    }
}

fn energy_j(cs: &Consts, s: &ModalState, ball: bool) -> f64 {
    let mut e = 0.0;
    for i in 0..cs.n {
        e += 0.5 * cs.m[i] * s.dq_m_s[i] * s.dq_m_s[i] + 0.5 * cs.k[i] * s.q_m[i] * s.q_m[i];
    }
    if ball {
        e += 0.5 * cs.md * s.dv_m_s * s.dv_m_s;
    }
    e
}

impl Segment for ModalExactSegment<'_> {
    fn t_start_s(&self) -> f64 {
        self.t0
    }
    fn t_end_s(&self) -> f64 {
        self.t1
    }
    fn mode(&self) -> Mode {
        self.mode
    }
    fn state_at(&self, t_s: f64) -> State {
        self.at(t_s).public(self.cs)
    }
    fn mechanical_energy_j(&self, t_s: f64) -> f64 {
        ModalExactSegment::mechanical_energy_j(self, t_s)
    }
    fn integral_u2(&self, a_s: f64, b_s: f64) -> f64 {
        let (ur, plan) = match self.m {
            SegMotion::Free(mo) => (&mo.ur, &self.sq.free),
            SegMotion::Pair(pm) => (&pm.ur, &self.sq.held),
        };
        // Up to the segment's end (its relative end `end.tau`, which `t1 − t0` equals to its
        // rounding), with the transcendentals already computed there; from its start (the
        // usual case) by the plan of its basis.
        if b_s.to_bits() == self.t1.to_bits() && self.end.n == ur.n {
            let a = a_s - self.t0;
            if a == 0.0 {
                return plan.borrow_mut().integral_square_to(ur, self.end);
            }
            return integral_square_n_to(ur, a, self.end);
        }
        integral_square_n(ur, a_s - self.t0, b_s - self.t0)
    }
    fn integrals(&self, a_s: f64, b_s: f64) -> SegmentIntegrals {
        let (a, b) = (a_s - self.t0, b_s - self.t0);
        let mo = match self.m {
            SegMotion::Free(mo) => mo,
            SegMotion::Pair(pm) => return pair_integrals(self.cs, pm, a, b),
        };
        let mut viscous = 0.0;
        for i in 0..self.cs.n {
            if self.cs.c[i] != 0.0 {
                viscous += self.cs.c[i] * integral_square(&mo.modes[i].deriv(), a, b);
            }
        }
        SegmentIntegrals {
            u2_m2_s: integral_square_n(&mo.ur, a, b),
            forcing_work_j: integral_product_n(&mo.force, &mo.duf, a, b),
            viscous_loss_j: viscous,
            friction_work_j: if mo.fb == 0.0 {
                0.0
            } else {
                mo.fb * mo.w.increment(a, b)
            },
        }
    }
}

/// The integrals of a held segment: `∫u²` at the response point, the forcing work at the
/// force point, the viscous loss `Σcₙ∫q̇ₙ²` (each `q̇ₙ` from the constrained closed form:
/// O(N) sums of 2N terms); no friction work (`ẇ = 0`).
fn pair_integrals(cs: &Consts, pm: &PairMotion, a: f64, b: f64) -> SegmentIntegrals {
    let mut viscous = 0.0;
    let mut unit = [0.0; NM];
    let mut dq = pm.ur;
    for i in 0..cs.n {
        if cs.c[i] == 0.0 {
            continue;
        }
        unit[i] = 1.0;
        to_expsum(&pm.motion.sum(&unit).deriv(), &mut dq);
        unit[i] = 0.0;
        viscous += cs.c[i] * integral_square_n(&dq, a, b);
    }
    SegmentIntegrals {
        u2_m2_s: integral_square_n(&pm.ur, a, b),
        forcing_work_j: integral_product_n(&pm.force, &pm.duf, a, b),
        viscous_loss_j: viscous,
        friction_work_j: 0.0,
    }
}

/// The constrained module's closed form as an [`ExpSumN`] (same terms; `f(0)` from them).
fn to_expsum(t: &TermSum, out: &mut ExpSumN) {
    out.om = t.omega_rad_s;
    out.k0 = t.constant;
    out.c1 = 0.0;
    out.c2 = 0.0;
    out.a = t.cos_omega;
    out.b = t.sin_omega;
    out.n = t.n_decays;
    let mut f0 = t.constant + t.cos_omega;
    for (o, d) in out.t.iter_mut().zip(t.decays()) {
        *o = Term {
            al: d[0],
            wd: d[1],
            p: d[2],
            q: d[3],
        };
        f0 += d[2];
    }
    out.f0 = f0;
}

/// Run bookkeeping: the books every kernel keeps ([`Tally`]) and the observer.
struct Book<'a> {
    obs: &'a mut dyn ModalObserver,
    tally: Tally,
}

impl Book<'_> {
    #[inline]
    fn check_state(&mut self, s: &St) -> Result<(), SimError> {
        self.tally.check_state(s)
    }

    fn event(
        &mut self,
        cs: &Consts,
        kind: EventKind,
        before: &St,
        after: &St,
    ) -> Result<(), SimError> {
        let impact = matches!(kind, EventKind::Impact { .. });
        let modal = (impact && self.obs.wants_modal()).then(|| before.modal(cs));
        self.event_from(
            cs,
            kind,
            before.public(cs),
            modal.as_ref(),
            after,
            after.public(cs),
        )
    }

    /// [`Book::event`] from what the observers see of the states: the public state before and
    /// after the event (`after_pub` is `after.public(cs)`) and, if they want it, the modal state
    /// before it.
    fn event_from(
        &mut self,
        cs: &Consts,
        kind: EventKind,
        before: State,
        before_modal: Option<&ModalState>,
        after: &St,
        after_pub: State,
    ) -> Result<(), SimError> {
        self.tally
            .count(after.t, &kind, || cs.limit_facts(cs.om, cs.osc[0].wd))?;
        self.check_state(after)?;
        self.obs.event(&Event {
            t_s: after.t,
            kind,
            before,
            after: after_pub,
        });
        if let (EventKind::Impact { energy_loss_j, .. }, Some(b)) = (kind, before_modal) {
            self.obs.modal_impact(b, &after.modal(cs), energy_loss_j)
        }
        Ok(())
    }

    /// [`Book::close`] of a free-flight segment, its end state written over its start `s`
    /// (unless an observer wants both modal states).
    fn close_free(&mut self, seg: &ModalExactSegment, mo: &FreeMotion, s: &mut St) {
        if self.obs.wants_modal() {
            *s = self.close(seg, s);
            return;
        }
        seg.at_t_free_into(mo, seg.end, s);
        s.t = seg.t1;
        if seg.t1 > seg.t0 {
            self.obs.segment(seg);
        }
    }

    /// Hand a finished segment to the observers (if not empty) and return the state at its end.
    /// `start` is the state the segment starts from.
    fn close(&mut self, seg: &ModalExactSegment, start: &St) -> St {
        let mut next = seg.at_t(seg.end);
        next.t = seg.t1;
        if seg.t1 > seg.t0 {
            self.obs.segment(seg);
            if self.obs.wants_modal() {
                self.obs
                    .modal_step(&start.modal(seg.cs), &next.modal(seg.cs));
            }
        }
        next
    }
}

/// The constrained modes, computed when a run first holds the ball (a run that never does
/// neither pays for them nor can fail on them).
struct Held<'s> {
    sys: &'s ModalSystem,
    cm: Option<Box<ConstrainedModes>>,
}

impl Held<'_> {
    fn get(&mut self) -> Result<&ConstrainedModes, SimError> {
        if self.cm.is_none() {
            self.cm = Some(Box::new(ConstrainedModes::new(self.sys)?));
        }
        Ok(self.cm.as_deref().expect("set above"))
    }
}

impl ModalExact {
    /// Integrate `sys` from `init` until `t_end_s`, reporting to an ordinary [`Observer`].
    pub fn run(
        &self,
        sys: &ModalSystem,
        init: &ModalState,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<ModalRunSummary, SimError> {
        self.run_modal(sys, init, t_end_s, &mut Plain(obs))
    }

    /// [`ModalExact::run`], also reporting the modal states to `obs` (`modal_step` per segment,
    /// `modal_impact` per impact; a chatter limit's loss is in its event).
    pub fn run_modal(
        &self,
        sys: &ModalSystem,
        init: &ModalState,
        t_end_s: f64,
        obs: &mut dyn ModalObserver,
    ) -> Result<ModalRunSummary, SimError> {
        self.run_counted(sys, init, t_end_s, obs).map(|(r, _)| r)
    }

    /// [`ModalExact::run_modal`], also returning the number of proven root-search steps (the
    /// cost measure of the search).
    pub fn run_counted(
        &self,
        sys: &ModalSystem,
        init: &ModalState,
        t_end_s: f64,
        obs: &mut dyn ModalObserver,
    ) -> Result<(ModalRunSummary, u64), SimError> {
        crate::solver::validate_modal_run(sys, init, t_end_s, None)?;
        crate::solver::refuse_ball_body_force_hertz(sys.damper.as_ref())?;
        let cs = Consts::new(sys)?;
        let mut book = Book {
            obs,
            tally: Tally::new(
                RunSummary {
                    max_penetration_m: f64::NEG_INFINITY,
                    ..Default::default()
                },
                self.max_events,
                self.check_invariants,
                cs.lg,
            ),
        };
        let mut s = St {
            t: init.t_s,
            q: init.q_m,
            dq: init.dq_m_s,
            w: 0.0,
            dw: 0.0,
            force: cs.force_at(init.t_s),
        };
        let mut work = Work::new();
        if sys.damper.is_none() {
            free_flight(&cs, None, &mut s, t_end_s, &mut book, &mut work)?;
            book.tally.summary.max_penetration_m = f64::NEG_INFINITY;
            book.tally.summary.final_state = s.public(&cs);
            let fin = s.modal(&cs);
            return Ok((
                ModalRunSummary {
                    summary: book.tally.summary,
                    final_state: ModalState {
                        v_m: 0.0,
                        dv_m_s: 0.0,
                        ..fin
                    },
                },
                work.search.steps,
            ));
        }
        s.w = init.w_m(&sys.model);
        s.dw = init.dw_m_s(&sys.model);
        let mut held = Held { sys, cm: None };
        driver::run(
            &mut ModalRun {
                cs: &cs,
                book: &mut book,
                work: &mut work,
                held: &mut held,
            },
            &mut s,
            t_end_s,
        )?;
        book.tally.summary.final_state = s.public(&cs);
        Ok((
            ModalRunSummary {
                summary: book.tally.summary,
                final_state: s.modal(&cs),
            },
            work.search.steps,
        ))
    }
}

/// The N-mode bar as a kernel of the one event loop ([`driver`]): its run constants, books,
/// buffers and the constrained modes of the ball held.
struct ModalRun<'r, 'o, 's> {
    cs: &'r Consts,
    book: &'r mut Book<'o>,
    work: &'r mut Work,
    held: &'r mut Held<'s>,
}

driver::ball_state!(St, |s| s.w.is_finite()
    && s.dw.is_finite()
    && s.q.iter().all(|x| x.is_finite())
    && s.dq.iter().all(|x| x.is_finite()));

impl Cavity for Consts {
    type St = St;
    driver::cavity_constants!();
    fn kappa(&self) -> f64 {
        self.kappa
    }
    fn a_b(&self, s: &St) -> f64 {
        Consts::a_b(self, s)
    }
    /// The bar's effective mass at the cavity and the ball move together: `a_b/(m_d κ)`; with
    /// a body force on the ball `(a_b + g_s (m_d κ − 1))/(m_d κ)` (`m_d κ − 1 = m_d/M_eff`).
    fn held_acceleration(&self, s: &St) -> f64 {
        if self.gs == 0.0 {
            Consts::a_b(self, s) / (self.md * self.kappa)
        } else {
            let mk = self.md * self.kappa;
            (Consts::a_b(self, s) + self.gs * (mk - 1.0)) / mk
        }
    }
    fn ball_gravity(&self) -> f64 {
        self.gs
    }
    fn a_b_rates(&self, s: &St, _ab: f64) -> (f64, f64) {
        let (sn, cn) = (self.om * s.t).sin_cos();
        let dforce = self.f0 * self.om * cn;
        let ddforce = -self.f0 * self.om * self.om * sn;
        let (mut dab, mut ddab) = (0.0, 0.0);
        for i in 0..self.n {
            let (m, c, k) = (self.m[i], self.c[i], self.k[i]);
            let acc = (self.phi_f[i] * s.force - c * s.dq[i] - k * s.q[i]) / m;
            let jerk = (self.phi_f[i] * dforce - c * acc - k * s.dq[i]) / m;
            let snap = (self.phi_f[i] * ddforce - c * jerk - k * acc) / m;
            dab += self.phi_d[i] * jerk;
            ddab += self.phi_d[i] * snap;
        }
        (dab, ddab)
    }
}

impl Kernel for ModalRun<'_, '_, '_> {
    type Cs = Consts;
    fn cs(&self) -> &Consts {
        self.cs
    }
    fn free_flight(
        &mut self,
        sigma: f64,
        orders: [usize; 3],
        s: &mut St,
        t_end_s: f64,
    ) -> Result<u8, SimError> {
        free_flight(
            self.cs,
            Some((sigma, orders)),
            s,
            t_end_s,
            self.book,
            self.work,
        )
    }
    fn held(&mut self, mode: Md, s: &mut St, t_end_s: f64) -> Result<u8, SimError> {
        pair_motion(self.cs, self.held, mode, s, t_end_s, self.book, self.work)
    }
    fn impact_law(&mut self, sw: f64, s: &mut St) -> Result<(), SimError> {
        impact_law(self.cs, sw, s, self.book)
    }
    fn chatter_hold(&mut self, sw: f64, dt: f64, s: &mut St) -> Result<f64, SimError> {
        chatter_hold(self.cs, sw, dt, s, self.book, self.work, self.held)
    }
    fn event(&mut self, kind: EventKind, before: &St, after: &St) -> Result<(), SimError> {
        self.book.event(self.cs, kind, before, after)
    }
    fn compliant_contact(
        &mut self,
        wall: Wall,
        s: &mut St,
        t_end_s: f64,
    ) -> Result<Option<Md>, SimError> {
        let law = self.cs.hertz.expect("a hertz touch needs the hertz law");
        super::hertz_phase::contact(self.cs, &law, wall.sign(), s, t_end_s, &mut *self.book)
    }
}

/// Fill `mo` with the free-flight closed form from `s` with friction force `fb` on the ball.
fn build_free(cs: &Consts, s: &St, fb: f64, no_ball: bool, mo: &mut FreeMotion) {
    // (The inlined kernel: libm's sincos was 1.5 % of a 4-mode beam run's time.)
    let (s0, c0) = sin_cos(cs.om * s.t);
    let n = cs.n;
    let om = cs.om;
    let (mut wa, mut wb, mut ra, mut rb, mut rk0, mut rf0, mut fa, mut fb_, mut fk0, mut ff0) =
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    let mut dv0 = s.dw;
    for i in 0..n {
        let o = &cs.osc[i];
        let qc = (cs.phi_f[i] * cs.fs - cs.phi_d[i] * fb) / cs.k[i];
        let (a, b) = if o.f0_d == 0.0 {
            (0.0, 0.0)
        } else {
            (
                o.f0_d * (o.kk * s0 - o.cw * c0),
                o.f0_d * (o.kk * c0 + o.cw * s0),
            )
        };
        let p = s.q[i] - qc - a;
        let q = (s.dq[i] - om * b + o.al * p) / o.wd;
        let m = ExpSum {
            f0: s.q[i],
            k0: qc,
            c1: 0.0,
            c2: 0.0,
            a,
            b,
            om,
            p,
            q,
            al: o.al,
            wd: o.wd,
        };
        mo.modes[i] = m;
        let (pd, pr, pf) = (cs.phi_d[i], cs.phi_r[i], cs.phi_f[i]);
        dv0 += pd * s.dq[i];
        wa -= pd * a;
        wb -= pd * b;
        mo.w.t[i] = Term {
            al: o.al,
            wd: o.wd,
            p: -pd * p,
            q: -pd * q,
        };
        ra += pr * a;
        rb += pr * b;
        rk0 += pr * qc;
        rf0 += pr * s.q[i];
        mo.ur.t[i] = Term {
            al: o.al,
            wd: o.wd,
            p: pr * p,
            q: pr * q,
        };
        fa += pf * a;
        fb_ += pf * b;
        fk0 += pf * qc;
        ff0 += pf * s.q[i];
        mo.duf.t[i] = Term {
            al: o.al,
            wd: o.wd,
            p: pf * p,
            q: pf * q,
        };
    }
    let wsum = |t: &[Term]| t.iter().map(|x| x.p).sum::<f64>();
    mo.w.n = n;
    mo.w.om = om;
    mo.w.f0 = s.w;
    mo.w.c1 = dv0;
    mo.w.c2 = if cs.gs == 0.0 {
        0.5 * fb / cs.md
    } else {
        0.5 * (fb / cs.md + cs.gs)
    };
    mo.w.a = wa;
    mo.w.b = wb;
    mo.w.k0 = s.w - wa - wsum(&mo.w.t[..n]);
    mo.ur.n = n;
    mo.ur.om = om;
    mo.ur.f0 = rf0;
    mo.ur.k0 = rk0;
    mo.ur.c1 = 0.0;
    mo.ur.c2 = 0.0;
    mo.ur.a = ra;
    mo.ur.b = rb;
    // u(x_f) in `duf`'s buffer, then differentiated in place.
    mo.duf.n = n;
    mo.duf.om = om;
    mo.duf.f0 = ff0;
    mo.duf.k0 = fk0;
    mo.duf.c1 = 0.0;
    mo.duf.c2 = 0.0;
    mo.duf.a = fa;
    mo.duf.b = fb_;
    mo.duf.deriv_in_place();
    mo.force.n = n;
    mo.force.om = om;
    mo.force.f0 = cs.fs + cs.f0 * s0;
    mo.force.k0 = cs.fs;
    mo.force.c1 = 0.0;
    mo.force.c2 = 0.0;
    mo.force.a = cs.f0 * s0;
    mo.force.b = cs.f0 * c0;
    for i in 0..n {
        mo.force.t[i] = Term {
            al: cs.osc[i].al,
            wd: cs.osc[i].wd,
            p: 0.0,
            q: 0.0,
        };
    }
    mo.fb = fb;
    mo.no_ball = no_ball;
}

/// The segment's joint event search over `cands` (what each means in `ids`): the earliest zero
/// on `[0, span]` as `(τ, which)` (`which = 0`: none before `span`, [`HORIZON`]: the search's
/// work bound reached), and the transcendentals at `τ` in `end` (the search's own where it has
/// them at `τ`, else computed on `basis`).
fn joint_search(
    cands: &[CandN],
    ids: &[u8],
    search: &mut ScratchN,
    end: &mut TrigN,
    span: f64,
    tol_t: f64,
    basis: &ExpSumN,
) -> (f64, u8) {
    let (best, which) = if cands.is_empty() {
        (span, 0)
    } else {
        let (root, i) = first_root_n(cands, 0.0, span, tol_t, search);
        match root {
            Root::At(t) => (t, ids[i]),
            Root::None => (span, 0),
            Root::Horizon(t) => (t, HORIZON),
        }
    };
    if which != 0 && search.trig_full && search.trig.tau.to_bits() == best.to_bits() {
        end.copy_from(&search.trig);
    } else {
        end.fill(best, basis);
    }
    (best, which)
}

/// One free-flight segment with friction sign `σ` and departure orders `[wall +, wall −,
/// ẇ = 0]` (`None`: the bar without a ball, one segment to the end) ([`Kernel::free_flight`]).
/// Returns which event ended it.
fn free_flight(
    cs: &Consts,
    flight: Option<(f64, [usize; 3])>,
    s: &mut St,
    t_end_s: f64,
    book: &mut Book,
    work: &mut Work,
) -> Result<u8, SimError> {
    let span = t_end_s - s.t;
    let tol_t = cs.tol_t_at(s.t);
    let (sigma, [k_plus, k_minus, k_sw]) = flight.unwrap_or((0.0, [0; 3]));
    let fb = cs.fb(sigma);
    build_free(cs, s, fb, flight.is_none(), &mut work.mo);
    let mut nc = 0;
    if flight.is_some() {
        let both_walls = !cs.frictional() || sigma == 0.0;
        let w = &work.mo.w;
        let mut push = |id: u8, order: usize, tol: f64, src: &ExpSumN, sc: f64, k: f64| {
            let c = &mut work.cands[nc];
            c.g.set_affine(src, sc, k);
            c.order = order;
            c.tol = tol;
            // A constant margin that is not below −tol never falls (see `Exact`).
            if c.g.is_constant() && c.g.f0 >= -tol {
                return;
            }
            work.ids[nc] = id;
            nc += 1;
        };
        if both_walls || sigma > 0.0 {
            push(1, k_plus, cs.tol_x, w, -1.0, cs.lg);
        }
        if both_walls || sigma < 0.0 {
            push(2, k_minus, cs.tol_x, w, 1.0, cs.lg);
        }
        if cs.frictional() && sigma != 0.0 {
            work.tmp.set_deriv(w);
            push(3, k_sw, cs.tol_v, &work.tmp, sigma, 0.0);
        }
    }
    let (best, which) = joint_search(
        &work.cands[..nc],
        &work.ids,
        &mut work.search,
        &mut work.end,
        span,
        tol_t,
        &work.mo.w,
    );
    let seg = ModalExactSegment {
        t0: s.t,
        t1: if which == 0 { t_end_s } else { s.t + best },
        mode: if flight.is_some() {
            Mode::Free
        } else {
            Mode::NoBall
        },
        cs,
        m: SegMotion::Free(&work.mo),
        end: &work.end,
        probe: &work.probe,
        sq: &work.sq,
    };
    // (`s` is the end state from here on: the event maps work on it in place.)
    book.close_free(&seg, &work.mo, s);
    if flight.is_none() {
        if book.tally.check
            && !(s.q.iter().all(|x| x.is_finite()) && s.dq.iter().all(|x| x.is_finite()))
        {
            return Err(SimError::NonFinite { t_s: s.t });
        }
        return Ok(0);
    }
    book.check_state(s)?;
    Ok(which)
}

/// The modal impact law at wall `sw` ([`Kernel::impact_law`]).
fn impact_law(cs: &Consts, sw: f64, s: &mut St, book: &mut Book) -> Result<(), SimError> {
    s.w = sw * cs.lg;
    let dw = if sw * s.dw > 0.0 { s.dw } else { 0.0 };
    s.dw = dw;
    // `s` becomes the state after the impact in place. What the observers see of the state
    // before it is taken first (a copy of the whole 0.5 KB state per impact was ~5 % of a
    // 4-mode beam run's time, measured with perf; the modal state only if they ask for it).
    let before_pub = s.public(cs);
    let before_modal = book.obs.wants_modal().then(|| s.modal(cs));
    let mut dv = dw + cs.dot(&cs.phi_d, &s.dq);
    let n = cs.n;
    let law = modal_impact(
        cs.md,
        cs.e,
        &cs.phi_d[..n],
        &cs.m[..n],
        dw,
        &mut s.dq[..n],
        &mut dv,
    );
    // The law's ẇ+ = −e ẇ− exactly (the ball velocity follows from it).
    s.dw = -cs.e * dw;
    // (Formed here, where the new `ẇ` is still in a register: read back from memory in
    // `event_from`, with `w` as one 16-byte load over two 8-byte stores, it stalled the store
    // forwarding, ~4 % of a 4-mode beam run's time, measured with perf.)
    let after_pub = s.public(cs);
    book.event_from(
        cs,
        EventKind::Impact {
            wall: wall_of(sw),
            dw_m_s: dw,
            energy_loss_j: law.energy_loss_j,
        },
        before_pub,
        before_modal.as_ref(),
        s,
        after_pub,
    )
}

/// The sums of a held segment from its constrained closed form.
fn build_pair<'a>(cs: &Consts, motion: ConstrainedMotion<'a>, t0: f64, w: f64) -> PairMotion<'a> {
    let z = ExpSumN::zero(cs.om);
    let mut pm = PairMotion {
        motion,
        ur: z,
        duf: z,
        force: z,
        w,
    };
    to_expsum(&motion.sum_at(Point::Response), &mut pm.ur);
    to_expsum(&motion.sum_at(Point::Force).deriv(), &mut pm.duf);
    let (s0, c0) = sin_cos(cs.om * t0);
    let f = &mut pm.force;
    f.om = cs.om;
    f.n = pm.ur.n;
    for (d, t) in f.t[..pm.ur.n].iter_mut().zip(&pm.ur.t[..pm.ur.n]) {
        *d = Term {
            p: 0.0,
            q: 0.0,
            ..*t
        };
    }
    f.k0 = cs.fs;
    f.f0 = cs.fs + cs.f0 * s0;
    f.a = cs.f0 * s0;
    f.b = cs.f0 * c0;
    pm
}

/// One segment of the ball held at the cavity: stuck (coulomb) away from the walls, or pressed
/// on a wall. Events: unstick when the holding force `f_c = m_d φ_dᵀq̈` reaches `±F`, release
/// when `s·f_c` reaches the holding capacity (0 without friction) ([`Kernel::held`]).
fn pair_motion(
    cs: &Consts,
    held: &mut Held,
    mode: Md,
    s: &mut St,
    t_end_s: f64,
    book: &mut Book,
    work: &mut Work,
) -> Result<u8, SimError> {
    let span = t_end_s - s.t;
    let tol_t = cs.tol_t_at(s.t);
    let cm = held.get()?;
    let motion = cm.segment(s.t, &s.q, &s.dq);
    let pm = build_pair(cs, motion, s.t, s.w);
    to_expsum(&motion.holding_force(), &mut work.tmp);
    let fc = &work.tmp;
    let f_hold = crate::damper::friction::holding_capacity_n(cs.model, cs.fl);
    let mut nc = 0;
    // Margins `k + sc·f`, `f = m_d (φ_dᵀq̈ − g_s)` the force the bar exerts on the ball
    // (`holding_force` is `m_d φ_dᵀq̈`; the constant `−m_d g_s` folds into `k`).
    let mut push = |id: u8, sc: f64, k: f64| {
        let k = if cs.gs == 0.0 {
            k
        } else {
            k - sc * cs.md * cs.gs
        };
        let c = &mut work.cands[nc];
        c.g.set_affine(fc, sc, k);
        c.order = 0;
        c.tol = cs.tol_f;
        if c.g.is_constant() && c.g.f0 >= -cs.tol_f {
            return;
        }
        work.ids[nc] = id;
        nc += 1;
    };
    let seg_mode = match mode {
        Md::Stick => {
            push(1, -1.0, cs.fl); // the bar pulls the ball ahead: it lags
            push(2, 1.0, cs.fl); // … or back: it leads
            Mode::Stick
        }
        Md::Contact(wall) => {
            push(3, -wall.sign(), f_hold);
            Mode::Contact(wall)
        }
        Md::Free { .. } | Md::HertzTouch(_) => {
            unreachable!("pair_motion is called for stick and contact")
        }
    };
    let (best, which) = joint_search(
        &work.cands[..nc],
        &work.ids,
        &mut work.search,
        &mut work.end,
        span,
        tol_t,
        &pm.ur,
    );
    let seg = ModalExactSegment {
        t0: s.t,
        t1: if which == 0 { t_end_s } else { s.t + best },
        mode: seg_mode,
        cs,
        m: SegMotion::Pair(&pm),
        end: &work.end,
        probe: &work.probe,
        sq: &work.sq,
    };
    let mut next = book.close(&seg, s);
    next.dw = 0.0;
    book.check_state(&next)?;
    *s = next;
    Ok(which)
}

/// Hold the ball over a summed chatter sequence at wall `sw` ([`Kernel::chatter_hold`]): the
/// plastic limit now (the modal impact law at `e = 0`: only the contact row is equalised), the
/// ball held on the wall for the sequence's duration `dt`; returns the energy the infinitely
/// many impacts removed. (Never inlined: its held segment's sums make a stack frame of ~100 KB,
/// which the inlining caller probed page by page at every impact, a third of its time,
/// measured with perf.)
#[inline(never)]
#[cold]
fn chatter_hold(
    cs: &Consts,
    sw: f64,
    dt: f64,
    s: &mut St,
    book: &mut Book,
    work: &mut Work,
    held: &mut Held,
) -> Result<f64, SimError> {
    let n = cs.n;
    let mut after = *s;
    let mut dv = s.dw + cs.dot(&cs.phi_d, &s.dq);
    let law = modal_impact(
        cs.md,
        0.0,
        &cs.phi_d[..n],
        &cs.m[..n],
        s.dw,
        &mut after.dq[..n],
        &mut dv,
    );
    after.dw = 0.0;
    after.w = sw * cs.lg;
    let cm = held.get()?;
    let motion = cm.segment(after.t, &after.q, &after.dq);
    let pm = build_pair(cs, motion, after.t, after.w);
    work.end.fill(dt, &pm.ur);
    let seg = ModalExactSegment {
        t0: after.t,
        t1: after.t + dt,
        mode: Mode::Contact(wall_of(sw)),
        cs,
        m: SegMotion::Pair(&pm),
        end: &work.end,
        probe: &work.probe,
        sq: &work.sq,
    };
    let mut next = book.close(&seg, &after);
    next.dw = 0.0;
    next.w = sw * cs.lg;
    *s = next;
    Ok(law.energy_loss_j)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{Damper, Forcing, STANDARD_GRAVITY_M_S2};
    use crate::structure::{Beam, Structure};

    fn beam4(friction: FrictionModel) -> ModalSystem {
        ModalSystem {
            model: Structure::Beam(Beam {
                modes: Some(4),
                ..Beam::default()
            })
            .modal_model()
            .unwrap(),
            damper: Some(Damper::paper(0.1e-3, friction)),
            forcing: Forcing::paper(1.0),
            gravity_m_s2: STANDARD_GRAVITY_M_S2,
        }
    }

    fn start(cs: &Consts) -> St {
        let mut s = St {
            t: 0.013,
            q: [0.0; NM],
            dq: [0.0; NM],
            w: 1e-5,
            dw: 0.02,
            force: cs.force_at(0.013),
        };
        for i in 0..4 {
            s.q[i] = 3e-5 / (1.0 + i as f64).powi(3);
            s.dq[i] = -0.1 / (1.0 + i as f64);
        }
        s
    }

    /// The segment's inherent `modal_state_at` starts at the state it was built from, agrees
    /// with the public `state_at`, and its `mechanical_energy_j` changes over the segment by
    /// exactly the segment's books (forcing − viscous + friction work): free flight (sliding
    /// as published) and a held segment (coulomb stick, constrained modes).
    #[test]
    fn segment_modal_state_and_energy_follow_the_books() {
        for friction in [FrictionModel::AsPublished, FrictionModel::Coulomb] {
            let sys = beam4(friction);
            let cs = Consts::new(&sys).unwrap();
            let s = start(&cs);
            let mut work = Work::new();
            let held_modes = ConstrainedModes::new(&sys).unwrap();
            let t1 = s.t + 3e-4;
            let pm;
            let seg = if friction == FrictionModel::AsPublished {
                build_free(&cs, &s, cs.fb(1.0), false, &mut work.mo);
                work.end.fill(t1 - s.t, &work.mo.w);
                ModalExactSegment {
                    t0: s.t,
                    t1,
                    mode: Mode::Free,
                    cs: &cs,
                    m: SegMotion::Free(&work.mo),
                    end: &work.end,
                    probe: &work.probe,
                    sq: &work.sq,
                }
            } else {
                pm = build_pair(&cs, held_modes.segment(s.t, &s.q, &s.dq), s.t, s.w);
                work.end.fill(t1 - s.t, &pm.ur);
                ModalExactSegment {
                    t0: s.t,
                    t1,
                    mode: Mode::Stick,
                    cs: &cs,
                    m: SegMotion::Pair(&pm),
                    end: &work.end,
                    probe: &work.probe,
                    sq: &work.sq,
                }
            };
            let want = if friction == FrictionModel::Coulomb {
                St { dw: 0.0, ..s }
            } else {
                s
            }
            .modal(&cs);
            let m0 = seg.modal_state_at(s.t);
            for i in 0..4 {
                assert!((m0.q_m[i] - want.q_m[i]).abs() <= 1e-14 * want.q_m[i].abs());
                assert!((m0.dq_m_s[i] - want.dq_m_s[i]).abs() <= 1e-13 * want.dq_m_s[i].abs());
            }
            assert!((m0.v_m - want.v_m).abs() <= 1e-15 * want.v_m.abs());
            let tm = s.t + 1.7e-4;
            let (pub_m, mod_m) = (seg.state_at(tm), seg.modal_state_at(tm).public(&sys.model));
            assert!((pub_m.u_m - mod_m.u_m).abs() <= 1e-15 * mod_m.u_m.abs().max(1e-9));
            let e0 = seg.mechanical_energy_j(s.t);
            assert!((e0 - sys.mechanical_energy_j(&m0)).abs() <= 1e-15 * e0);
            let books = seg.integrals(s.t, t1);
            let de = seg.mechanical_energy_j(t1) - e0;
            let flow = books.forcing_work_j - books.viscous_loss_j + books.friction_work_j;
            assert!(
                (de - flow).abs() <= 1e-11 * books.forcing_work_j.abs().max(de.abs()),
                "{friction}: ΔE {de:e}, books {flow:e}"
            );
            if friction == FrictionModel::AsPublished {
                assert!(books.friction_work_j > 0.0);
            }
        }
    }
}
