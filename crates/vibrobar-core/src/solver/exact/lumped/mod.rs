//! The lumped bar's kernel of the exact solver: the one-degree-of-freedom bar of the paper
//! (mass `M`, stiffness `K`, damping `C`) and the ball.
//!
//! Between events every mode is linear with constant coefficients, so the motion is known in
//! closed form ([`expsum::ExpSum`]):
//!
//! * the bar (mass `M_eff`, stiffness `K`, damping `C`) under `F_s + F0 sin Ωt + F_c`:
//!   `u(τ) = u_c + A cos Ωτ + B sin Ωτ + e^{−ατ}(p cos ω_d τ + q sin ω_d τ)`, `τ = t − t_seg`
//!   (local time; the forcing phase enters through `sin/cos Ω t_seg`);
//! * the ball in free flight: constant acceleration `F_ball/m_d`.
//!
//! Modes: free flight with a constant friction sign `σ` (or frictionless), stick (`coulomb`, the
//! pair moves as one body of mass `M + m_d`), wall contact (pair as one body, ball pressed on a
//! wall). Events are the zeros of exponential sums (walls `l_g ∓ w`, `σẇ`, the force margins
//! `f ∓ m_d ü_pair`), found by [`roots::first_root`], which cannot miss a root (see its docs for
//! the argument, the departure rule at a segment start and the grazing case). One search does a
//! bounded amount of work: at its horizon it stops at its last proven point, the segment ends
//! there without an event, and the same mode goes on from the closed-form state (long
//! event-free flights, a ball stuck for good).
//!
//! The laws are those of [`crate::damper`]: the friction force of a slide, whether and how
//! strongly friction holds a ball at rest, the impact map and its plastic limit.
//!
//! The transitions between modes (impact, `ẇ = 0`, stick and unstick, wall contact and
//! release, the chatter test and its summed limit, the start) are the one event loop's,
//! [`driver`], written once for every bar: this module is the lumped bar's kernel of it (the
//! closed forms, the event functions, the impact law `u̇+ = u̇− + μ(1+e)/(1+μ) ẇ−`,
//! `ẇ+ = −e ẇ−`, the pair `M + m_d` moving as one body while the ball is held). The N-mode bar
//! is the other kernel ([`modal`]).
//!
//! Chatter (`0 < e < 1`, or `e = 1` with coulomb friction): after an impact whose relative
//! acceleration pushes the ball back to the same wall, the remaining impacts form a geometric
//! sequence ([`driver`] derives its duration). `ẅ` is frozen at its value at the impact, exact
//! to first order in the tiny `Δt`. When the sequence is below resolution (its first bounce is
//! lower than `1e-10 l_g`, or `Δt < 1e-9` forcing periods) the solver jumps to its limit: bar
//! and ball take the common momentum-conserving velocity (the plastic limit), the pair moves as
//! one body over `Δt` (reported as a `Contact` segment), and at `t + Δt` an
//! [`EventKind::ChatterLimit`] (with `before = after`, the pair state there) carries the
//! kinetic energy the infinitely many impacts removed; then the wall-contact test decides
//! between contact and release.
//!
//! Accuracy: the closed forms are exact up to rounding (`sin`/`cos` of `Ωt` with `t ~ 1 s`
//! carry ~1e-12 relative phase error); event times are resolved to ~1e-15 s, positions to
//! `1e-15 l_g`; the energy audit (forcing work − viscous loss + friction work − impact losses =
//! ΔE) closes to ~1e-12 relative on the paper cases. In chaotic runs the RMS over the window
//! is only defined statistically: rounding-level changes of an event time change it by a few %.

pub mod cutting;
mod cutting_nonlinear;
pub mod expsum;
pub mod hertz;
pub mod roots;

use super::driver::{self, wall_of, Cavity, Kernel, Md, Tally, CUT, HORIZON};
use super::{hertz_phase, modal, Exact};
use crate::damper::impact::{impact_energy_loss_j, impact_relative, plastic_limit};
use crate::error::SimError;
use crate::params::{Bar, FrictionModel, State, System};
use crate::solver::{
    Event, EventKind, Mode, Observer, RunSummary, Segment, SegmentIntegrals, Wall,
};
use expsum::{integral_product, integral_square, integral_square_to, ExpSum, Trig};
use roots::{first_root_multi_trig, first_step_clears, Cand, Root, Scratch};

/// Constants of one run.
#[derive(Debug, Clone, Copy)]
struct Consts {
    m: f64,
    md: f64,
    k: f64,
    c: f64,
    fs: f64,
    f0: f64,
    om: f64,
    lg: f64,
    e: f64,
    mu: f64,
    /// Friction level (0 when frictionless).
    fl: f64,
    model: FrictionModel,
    /// Tolerances on positions, velocities, forces.
    tol_x: f64,
    tol_v: f64,
    tol_f: f64,
    tol_t: f64,
    /// Chatter resolution: apex height and time.
    chatter_h: f64,
    chatter_t: f64,
    /// The bar alone and the bar with the ball riding on it.
    osc: [Osc; 2],
    /// The compliant contact law, `None` for the instantaneous restitution law.
    hertz: Option<crate::damper::contact::Hertz>,
    /// The bar's own stiffness `K` (mechanical energy, `a_b`). `k` is `K` plus the cutting
    /// stiffness while the tool cuts ([`cutting`]); without a cut the two are equal.
    k_spring: f64,
    /// The cut over the current piece of a cutting run ([`cutting`]); `None`: no cut.
    cut: Option<CutPiece>,
    /// `g_s`: the ball's acceleration from its body force along the gap (`+0.0` without one,
    /// whose runs stay bit-identical). In free flight the ball's acceleration gains it; while
    /// the ball is held the pair's load gains `m_d g_s`.
    gs: f64,
}

/// The cut over one piece of a cutting run, in the local time `τ` of the segment starting at
/// the piece's start: the delayed surface `d(τ) = s(t − T)` is the quadratic `d0 + d1 τ + d2 τ²`
/// ([`cutting`] fits it to the stored history), the chip `h = h0 + c_chip (d − u)`.
#[derive(Debug, Clone, Copy)]
struct CutPiece {
    /// `c_force K_f b` (linear law): force per chip thickness.
    kfb: f64,
    /// `c_chip`.
    c_chip: f64,
    /// Feed `h0`.
    h0: f64,
    /// The tool cuts over this piece (the stiffness carries `c_force K_f b c_chip`).
    in_cut: bool,
    /// The delayed surface's coefficients.
    d: [f64; 3],
    /// Departure order of the chip function at the piece start (1 right after a cut event).
    order: usize,
    /// Tolerance on the chip thickness.
    tol: f64,
    /// The three-quarter law's remainder `c_force F(h) − c_force K_f b h` fitted as
    /// `r0 + r1 τ + r2 τ²` over the piece ([`cutting`]), `None` with the linear law (whose
    /// runs stay bit-identical).
    r: Option<[f64; 3]>,
}

impl CutPiece {
    /// The cutting force's polynomial part `c_force K_f b (h0 + c_chip d(τ))` in the cut, else 0
    /// (the part `−c_force K_f b c_chip u` is in the stiffness).
    fn poly(&self) -> [f64; 3] {
        if !self.in_cut {
            return [0.0; 3];
        }
        let k = self.kfb * self.c_chip;
        let p = [
            self.kfb * self.h0 + k * self.d[0],
            k * self.d[1],
            k * self.d[2],
        ];
        match self.r {
            None => p,
            Some(r) => [p[0] + r[0], p[1] + r[1], p[2] + r[2]],
        }
    }

    /// The chip thickness `h0 + c_chip (d − u)` over a segment whose bar motion is `u`.
    fn chip(&self, u: &ExpSum) -> ExpSum {
        let c = self.c_chip;
        ExpSum {
            f0: self.h0 + c * (self.d[0] - u.f0),
            k0: self.h0 + c * (self.d[0] - u.k0),
            c1: c * (self.d[1] - u.c1),
            c2: c * (self.d[2] - u.c2),
            a: -c * u.a,
            b: -c * u.b,
            p: -c * u.p,
            q: -c * u.q,
            ..*u
        }
    }

    /// What a segment keeps of the cut (chip, force, in or out) for outputs and the books.
    fn segment(&self, u: &ExpSum) -> CutSeg {
        CutSeg {
            h: self.chip(u),
            kfb: if self.in_cut { self.kfb } else { 0.0 },
            r: if self.in_cut { self.r } else { None },
        }
    }
}

/// The cut along one segment: its chip thickness and `c_force K_f b` (0 out of the cut).
#[derive(Debug, Clone, Copy)]
struct CutSeg {
    h: ExpSum,
    kfb: f64,
    /// The three-quarter law's fitted remainder (see [`CutPiece`]), in the cut only.
    r: Option<[f64; 3]>,
}

impl CutSeg {
    /// The cutting force the segment's closed form carries at local `τ`: `c_force K_f b h`
    /// plus the fitted remainder (three-quarter law).
    fn force_t(&self, h: f64, tau: f64) -> f64 {
        let f = self.kfb * h;
        match self.r {
            None => f,
            Some(r) => f + r[0] + tau * (r[1] + tau * r[2]),
        }
    }
}

impl Consts {
    /// The time tolerance of an event search starting at `t`: the run's own plus the rounding
    /// of `t` itself.
    #[inline]
    fn tol_t_at(&self, t: f64) -> f64 {
        self.tol_t + 4.0 * f64::EPSILON * t.abs()
    }

    /// Half the ball's acceleration in free flight under the friction force `fb`:
    /// `½(fb/m_d + g_s)` (`½ fb/m_d` to the bit without a body force).
    fn ball_half_acc(&self, fb: f64) -> f64 {
        if self.gs == 0.0 {
            0.5 * fb / self.md
        } else {
            0.5 * (fb / self.md + self.gs)
        }
    }

    /// The constant load on the pair while the ball is held: `m_d g_s` (0 without a body force).
    fn pair_load(&self) -> f64 {
        if self.gs == 0.0 {
            0.0
        } else {
            self.md * self.gs
        }
    }

    /// The constant of a held margin `k + sc·m_d (ü − g_s)`: `k − sc·m_d g_s` (`k` to the bit
    /// without a body force).
    fn margin_level(&self, sc: f64, k: f64) -> f64 {
        if self.gs == 0.0 {
            k
        } else {
            k - sc * self.md * self.gs
        }
    }

    /// `a_b = (F − C u̇ − K u)/M`: bar acceleration without the ball force.
    fn a_b(&self, s: &St) -> f64 {
        (s.force - self.c * s.du - self.k_spring * s.u) / self.m
    }
    /// Bar (or pair, with `mass`) closed form from `(u0, du0)` at `t_seg`, extra constant force
    /// `fc`; and the forcing over the segment (both from one `sin_cos` of the phase).
    fn bar_sum(
        &self,
        mass: f64,
        fc: f64,
        t_seg: f64,
        u0: f64,
        du0: f64,
    ) -> Result<(ExpSum, ExpSum), SimError> {
        let (s0, c0) = (self.om * t_seg).sin_cos();
        let o = match self.osc.iter().find(|o| o.mass.to_bits() == mass.to_bits()) {
            Some(o) => *o,
            None => Osc::new(self, mass),
        };
        let (a, b) = if self.f0 == 0.0 {
            (0.0, 0.0)
        } else if o.undamped_resonance {
            // Undamped and at resonance to rounding: no bounded closed form.
            return Err(SimError::UndampedResonance {
                omega_rad_s: self.om,
            });
        } else if o.out_of_range {
            let dyn_k = o.kk.hypot(o.cw);
            return Err(SimError::ResponseOutOfRange {
                dynamic_stiffness_n_per_m: dyn_k,
                mass_kg: o.mass,
                omega_rad_s: self.om,
                amplitude_m: self.f0.abs() / dyn_k,
            });
        } else {
            (
                o.f0_d * (o.kk * s0 - o.cw * c0),
                o.f0_d * (o.kk * c0 + o.cw * s0),
            )
        };
        // The particular solution of the polynomial force: constant without a cut; in a cut
        // `A0 + A1 τ + A2 τ²` with `k A2 = P2`, `k A1 + 2c A2 = P1`, `k A0 + c A1 + 2m A2 = P0`.
        let (uc, c1, c2) = match &self.cut {
            None => ((self.fs + fc) / self.k, 0.0, 0.0),
            Some(cp) => {
                let [p0, p1, p2] = cp.poly();
                let a2 = p2 / self.k;
                let a1 = (p1 - 2.0 * self.c * a2) / self.k;
                let a0 = (self.fs + fc + p0 - self.c * a1 - 2.0 * mass * a2) / self.k;
                (a0, a1, a2)
            }
        };
        let (al, wd) = (o.al, o.wd);
        let p = u0 - uc - a;
        // `du0 − 0.0` is `du0` to the bit: runs without a cut are unchanged.
        let q = (du0 - c1 - self.om * b + al * p) / wd;
        let u = ExpSum {
            f0: u0,
            k0: uc,
            c1,
            c2,
            a,
            b,
            om: self.om,
            p,
            q,
            al,
            wd,
        };
        let mut force = self.force_sum(s0, c0, &u);
        if let Some(cp) = &self.cut {
            // The total force on the bar: the cutting force `c_force K_f b h` in the cut (the
            // stiffness `k` holds its `−c_force K_f b c_chip u`; `a_b` uses `K`).
            let kc = if cp.in_cut { cp.kfb * cp.c_chip } else { 0.0 };
            let [p0, p1, p2] = cp.poly();
            force = ExpSum {
                f0: force.f0 + p0 - kc * u.f0,
                k0: force.k0 + p0 - kc * u.k0,
                c1: p1 - kc * u.c1,
                c2: p2 - kc * u.c2,
                a: force.a - kc * u.a,
                b: force.b - kc * u.b,
                p: -kc * u.p,
                q: -kc * u.q,
                ..force
            };
        }
        Ok((u, force))
    }

    /// The forcing from `(sin, cos)(Ω t_seg)`.
    fn force_sum(&self, s0: f64, c0: f64, like: &ExpSum) -> ExpSum {
        ExpSum {
            f0: self.fs + self.f0 * s0,
            k0: self.fs,
            a: self.f0 * s0,
            b: self.f0 * c0,
            ..like.zero_like()
        }
    }
}

/// What the bar closed form needs of one oscillating mass (`M` alone, or `M + m_d`), computed
/// once per run instead of once per segment.
#[derive(Debug, Clone, Copy)]
struct Osc {
    mass: f64,
    kk: f64,
    cw: f64,
    /// `F0 / ((K − mΩ²)² + (CΩ)²)`.
    f0_d: f64,
    /// `C = 0` and `K − mΩ² = 0` to rounding: the response grows without bound.
    undamped_resonance: bool,
    /// `(K − mΩ²)² + (CΩ)²` is not a normal `f64` (underflow or overflow) or the amplitude
    /// overflows: the closed form cannot be evaluated, whatever the damping.
    out_of_range: bool,
    al: f64,
    wd: f64,
}

impl Osc {
    fn new(cs: &Consts, mass: f64) -> Osc {
        let kk = cs.k - mass * cs.om * cs.om;
        let cw = cs.c * cs.om;
        let d = kk * kk + cw * cw;
        let al = cs.c / (2.0 * mass);
        Osc {
            mass,
            kk,
            cw,
            f0_d: cs.f0 / d,
            undamped_resonance: cw == 0.0 && kk.abs() <= 8.0 * f64::EPSILON * cs.k,
            out_of_range: !d.is_normal() || !(cs.f0 / d).is_finite(),
            al,
            wd: (cs.k / mass - al * al).sqrt(),
        }
    }
}

/// Internal state: relative coordinates keep `w` free of cancellation.
#[derive(Debug, Clone, Copy)]
struct St {
    t: f64,
    u: f64,
    du: f64,
    w: f64,
    dw: f64,
    /// The external force `F(t)` (from the segment's closed form, which has its `sin Ωt`).
    force: f64,
}

impl St {
    fn public(&self) -> State {
        State {
            t_s: self.t,
            u_m: self.u,
            du_m_s: self.du,
            v_m: self.u + self.w,
            dv_m_s: self.du + self.dw,
            cavity: None,
        }
    }
}

/// One closed-form piece of the motion.
#[derive(Debug, Clone, Copy)]
pub struct ExactSegment {
    t0: f64,
    t1: f64,
    mode: Mode,
    u: ExpSum,
    w: ExpSum,
    force: ExpSum,
    c: f64,
    fb: f64,
    /// `M`, `K` and the ball's mass (`None` without a ball): the mechanical energy's constants.
    energy: (f64, f64, Option<f64>),
    /// Transcendentals at the local end time `end.tau` (where the next state is taken), shared
    /// by that state and `∫u²` up to `t1`.
    end: Trig,
    /// The cut along this segment (a cutting run), `None` otherwise.
    cut: Option<CutSeg>,
}

impl ExactSegment {
    fn at(&self, tau: f64) -> St {
        self.at_t(&Trig::new(tau, self.u.om, self.u.al, self.u.wd))
    }

    /// The state at the local end `end.tau` (time `t0 + end.tau`; callers set `t1`).
    fn at_end(&self) -> St {
        self.at_t(&self.end)
    }

    fn at_t(&self, tr: &Trig) -> St {
        let tau = tr.tau;
        let [u, du]: [f64; 2] = self.u.derivs_t(tr);
        let [w, dw]: [f64; 2] = self.w.derivs_t(tr);
        St {
            t: self.t0 + tau,
            u,
            du,
            w,
            dw,
            force: self.force.value_t(tr),
        }
    }
}

impl Segment for ExactSegment {
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
        let tau = t_s - self.t0;
        // A cutting run asks for the state at each piece's end (its surface history), where the
        // segment already holds the transcendentals (`Trig::new` of the same `τ`, to the bit).
        let mut s = if self.cut.is_some() && tau.to_bits() == self.end.tau.to_bits() {
            self.at_t(&self.end)
        } else {
            self.at(tau)
        }
        .public();
        s.t_s = t_s;
        s
    }
    fn displacement_sum(&self) -> Option<ExpSum> {
        // A cut's segment holds the displacement piece by piece.
        self.cut.is_none().then_some(self.u)
    }
    fn acceleration_at(&self, t_s: f64) -> Option<f64> {
        let tau = t_s - self.t0;
        let trig = if tau.to_bits() == self.end.tau.to_bits() {
            self.end
        } else {
            Trig::new(tau, self.u.om, self.u.al, self.u.wd)
        };
        Some(self.u.second_derivative_t(&trig))
    }
    fn mechanical_energy_j(&self, t_s: f64) -> f64 {
        let (m, k, md) = self.energy;
        crate::model::lumped_mechanical_energy_j(m, k, md, &self.state_at(t_s))
    }
    fn integral_u2(&self, a_s: f64, b_s: f64) -> f64 {
        if self.cut.is_some() {
            return cutting::integral_u2(self, a_s - self.t0, b_s - self.t0);
        }
        if b_s.to_bits() == self.t1.to_bits() {
            // Up to the segment end: its transcendentals are known (local end `end.tau`, which
            // is `t1 − t0` up to the rounding of `t1`).
            integral_square_to(&self.u, a_s - self.t0, self.end.tau, Some(&self.end))
        } else {
            integral_square(&self.u, a_s - self.t0, b_s - self.t0)
        }
    }
    fn cutting_work_j(&self, a_s: f64, b_s: f64) -> f64 {
        match &self.cut {
            Some(c) => cutting::cutting_work(self, c, a_s - self.t0, b_s - self.t0),
            None => 0.0,
        }
    }

    fn cutting_at(&self, t_s: f64) -> Option<crate::solver::CutSample> {
        self.cut.map(|c| {
            let h = c.h.value(t_s - self.t0);
            crate::solver::CutSample {
                chip_thickness_m: h,
                in_cut: c.kfb > 0.0,
                cutting_force_n: match c.r {
                    None => c.kfb * h.max(0.0),
                    Some(_) => c.force_t(h, t_s - self.t0),
                },
            }
        })
    }

    fn integrals(&self, a_s: f64, b_s: f64) -> SegmentIntegrals {
        let (a, b) = (a_s - self.t0, b_s - self.t0);
        if let Some(c) = &self.cut {
            return cutting::segment_integrals(self, c, a, b);
        }
        let du = self.u.deriv();
        SegmentIntegrals {
            u2_m2_s: integral_square(&self.u, a, b),
            forcing_work_j: integral_product(&self.force, &du, a, b),
            viscous_loss_j: self.c * integral_square(&du, a, b),
            friction_work_j: if self.fb == 0.0 {
                0.0
            } else {
                // From the increment, not `w(b) − w(a)`: a slide far shorter than `l_g` would
                // lose its length to the rounding of `w` (friction work 1e-7 relative off).
                self.fb * self.w.increment(a, b)
            },
        }
    }
}

/// Run bookkeeping: the books every kernel keeps ([`Tally`]) and the observer.
struct Book<'a> {
    obs: &'a mut dyn Observer,
    tally: Tally,
    /// Set when a segment ended at a cut event ([`CUT`]); the cutting driver clears it.
    cut_event: bool,
}

impl Book<'_> {
    #[inline]
    fn check_state(&mut self, s: &St) -> Result<(), SimError> {
        self.tally.check_state(s)
    }

    #[inline]
    fn event(
        &mut self,
        cs: &Consts,
        t: f64,
        kind: EventKind,
        before: &St,
        after: &St,
    ) -> Result<(), SimError> {
        self.tally
            .count(t, &kind, || cs.limit_facts(cs.om, cs.osc[0].wd))?;
        self.check_state(after)?;
        self.obs.event(&Event {
            t_s: t,
            kind,
            before: before.public(),
            after: after.public(),
        });
        Ok(())
    }
}

impl Consts {
    /// `M`, `K`, `m_d` of [`ExactSegment::mechanical_energy_j`].
    fn energy_consts(&self) -> (f64, f64, Option<f64>) {
        (
            self.m,
            self.k_spring,
            self.lg.is_finite().then_some(self.md),
        )
    }

    /// The constants of a run of `sys` (validated) with its lumped `bar`.
    fn new(sys: &System, bar: &Bar) -> Consts {
        let om = sys.omega_rad_s();
        let (md, lg, e, model) = match &sys.damper {
            Some(d) => (d.ball_mass_kg, d.half_gap_m(), d.restitution, d.friction),
            None => (1.0, f64::INFINITY, 0.0, FrictionModel::None),
        };
        let wn = bar.natural_freq_rad_s();
        let f_scale = sys
            .forcing
            .amplitude_n
            .abs()
            .max(sys.forcing.static_force_n.abs())
            .max(sys.friction_level_n());
        let mut cs = Consts {
            m: bar.mass_kg,
            md,
            k: bar.stiffness_n_per_m,
            c: bar.damping_n_s_per_m(),
            fs: sys.forcing.static_force_n,
            f0: sys.forcing.amplitude_n,
            om,
            lg,
            e,
            mu: md / bar.mass_kg,
            fl: sys.friction_level_n(),
            model,
            tol_x: 1e-15 * lg,
            tol_v: 1e-15 * lg * om.max(wn),
            tol_f: 1e-15 * f_scale.max(f64::MIN_POSITIVE),
            tol_t: 1e-15 / om.max(wn),
            chatter_h: 1e-10 * lg,
            chatter_t: 1e-9 * 2.0 * std::f64::consts::PI / om,
            osc: [Osc {
                mass: f64::NAN,
                kk: 0.0,
                cw: 0.0,
                f0_d: 0.0,
                undamped_resonance: false,
                out_of_range: false,
                al: 0.0,
                wd: 0.0,
            }; 2],
            hertz: sys
                .damper
                .filter(|d| d.contact.law == crate::params::ContactLaw::Hertz)
                .map(|d| crate::damper::contact::Hertz::of_damper(&d)),
            k_spring: bar.stiffness_n_per_m,
            cut: None,
            gs: match &sys.damper {
                Some(d) if d.gravity_along_gap_m_s2 != 0.0 => d.gravity_along_gap_m_s2,
                _ => 0.0,
            },
        };
        cs.osc = [Osc::new(&cs, cs.m), Osc::new(&cs, cs.m + cs.md)];
        cs
    }
}

/// The exact solver's run of `sys` (its bar lumped, `bar`) from `init` to `t_end_s`.
pub(in crate::solver) fn run(
    ex: &Exact,
    sys: &System,
    bar: &Bar,
    init: &State,
    t_end_s: f64,
    obs: &mut dyn Observer,
) -> Result<RunSummary, SimError> {
    crate::solver::validate_run(sys, init, t_end_s)?;
    crate::solver::refuse_ball_body_force_hertz(sys.damper.as_ref())?;
    let cs = Consts::new(sys, bar);
    let mut book = Book {
        obs,
        tally: Tally::new(
            RunSummary {
                final_state: *init,
                max_penetration_m: f64::NEG_INFINITY,
                ..Default::default()
            },
            ex.max_events,
            ex.check_invariants,
            cs.lg,
        ),
        cut_event: false,
    };
    let mut s = St {
        t: init.t_s,
        u: init.u_m,
        du: init.du_m_s,
        w: init.w_m(),
        dw: init.dw_m_s(),
        force: sys.force_n(init.t_s),
    };
    if sys.damper.is_none() {
        return solid_bar(&cs, s, t_end_s, &mut book);
    }
    let mut search = Search::default();
    driver::run(
        &mut Lumped {
            cs: &cs,
            book: &mut book,
            search: &mut search,
        },
        &mut s,
        t_end_s,
    )?;
    book.tally.summary.final_state = s.public();
    Ok(book.tally.summary)
}

/// The lumped bar as a kernel of the one event loop ([`driver`]): its run constants, books and
/// search buffers.
struct Lumped<'r, 'o> {
    cs: &'r Consts,
    book: &'r mut Book<'o>,
    search: &'r mut Search,
}

driver::ball_state!(St, |s| s.u.is_finite()
    && s.du.is_finite()
    && s.w.is_finite()
    && s.dw.is_finite());

impl Cavity for Consts {
    type St = St;
    driver::cavity_constants!();
    fn kappa(&self) -> f64 {
        1.0 / self.md + 1.0 / self.m
    }
    fn a_b(&self, s: &St) -> f64 {
        Consts::a_b(self, s)
    }
    /// The pair (`M + m_d`) moves as one body: `a_b M/(M + m_d)`, with a body force on the
    /// ball `(a_b M + m_d g_s)/(M + m_d)`.
    fn held_acceleration(&self, s: &St) -> f64 {
        if self.gs == 0.0 {
            Consts::a_b(self, s) * self.m / (self.m + self.md)
        } else {
            (Consts::a_b(self, s) * self.m + self.md * self.gs) / (self.m + self.md)
        }
    }
    fn ball_gravity(&self) -> f64 {
        self.gs
    }
    fn a_b_rates(&self, s: &St, ab: f64) -> (f64, f64) {
        let dforce = self.f0 * self.om * (self.om * s.t).cos();
        let dab = (dforce - self.c * ab - self.k * s.du) / self.m;
        let ddforce = -self.f0 * self.om * self.om * (self.om * s.t).sin();
        (dab, (ddforce - self.c * dab - self.k * ab) / self.m)
    }
}

impl Kernel for Lumped<'_, '_> {
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
        free_flight(self.cs, sigma, orders, s, t_end_s, self.book, self.search)
    }
    fn held(&mut self, mode: Md, s: &mut St, t_end_s: f64) -> Result<u8, SimError> {
        pair_motion(self.cs, mode, s, t_end_s, self.book, self.search)
    }
    fn impact_law(&mut self, sw: f64, s: &mut St) -> Result<(), SimError> {
        let cs = self.cs;
        s.w = sw * cs.lg;
        // A graze (touch with ẇ ≈ 0 or already leaving by round-off) hits with ẇ− = 0.
        let dw = if sw * s.dw > 0.0 { s.dw } else { 0.0 };
        let before = St { dw, ..*s };
        let (du_plus, dw_plus) = impact_relative(cs.mu, cs.e, s.du, dw);
        let after = St {
            du: du_plus,
            dw: dw_plus,
            ..*s
        };
        self.book.event(
            cs,
            s.t,
            EventKind::Impact {
                wall: wall_of(sw),
                dw_m_s: dw,
                energy_loss_j: impact_energy_loss_j(cs.m, cs.md, cs.e, dw),
            },
            &before,
            &after,
        )?;
        *s = after;
        Ok(())
    }
    fn chatter_hold(&mut self, sw: f64, dt: f64, s: &mut St) -> Result<f64, SimError> {
        let cs = self.cs;
        let mtot = cs.m + cs.md;
        let (v, loss) = plastic_limit(cs.m, cs.md, s.du, s.du + s.dw);
        let (u, force) = cs.bar_sum(mtot, cs.pair_load(), s.t, s.u, v)?;
        let seg = ExactSegment {
            t0: s.t,
            t1: s.t + dt,
            mode: Mode::Contact(wall_of(sw)),
            u,
            w: ExpSum::constant(sw * cs.lg, &u),
            force,
            c: cs.c,
            energy: cs.energy_consts(),
            fb: 0.0,
            end: Trig::new(dt, u.om, u.al, u.wd),
            cut: cs.cut.map(|c| c.segment(&u)),
        };
        let mut next = close_segment(&seg, self.book);
        next.dw = 0.0;
        *s = next;
        Ok(loss)
    }
    fn event(&mut self, kind: EventKind, before: &St, after: &St) -> Result<(), SimError> {
        self.book.event(self.cs, after.t, kind, before, after)
    }
    fn compliant_contact(
        &mut self,
        wall: Wall,
        s: &mut St,
        t_end_s: f64,
    ) -> Result<Option<Md>, SimError> {
        let law = self.cs.hertz.expect("a hertz touch needs the hertz law");
        hertz_phase::contact(self.cs, &law, wall.sign(), s, t_end_s, &mut *self.book)
    }
    fn cut_event(&mut self) {
        self.book.cut_event = true;
    }
}

/// One segment of mode `mode` from `s`, at most to `t_end_s`; the next mode, or `None` when
/// `t_end_s` was reached: the one event loop ([`driver::advance`]) on the lumped bar, with or
/// without a cut.
fn advance(
    cs: &Consts,
    mode: Md,
    s: &mut St,
    t_end_s: f64,
    book: &mut Book,
    search: &mut Search,
) -> Result<Option<Md>, SimError> {
    driver::advance(&mut Lumped { cs, book, search }, mode, s, t_end_s)
}

/// Mode at the start of a run (or after the state was set from outside).
fn initial_mode(cs: &Consts, s: &mut St, book: &mut Book) -> Result<Md, SimError> {
    let search = &mut Search::default();
    driver::initial_mode(&mut Lumped { cs, book, search }, s)
}

/// The bar without a ball: one closed-form segment to the end.
fn solid_bar(
    cs: &Consts,
    mut s: St,
    t_end_s: f64,
    book: &mut Book,
) -> Result<RunSummary, SimError> {
    s.w = 0.0;
    s.dw = 0.0;
    let (u, force) = cs.bar_sum(cs.m, 0.0, s.t, s.u, s.du)?;
    let seg = ExactSegment {
        t0: s.t,
        t1: t_end_s,
        mode: Mode::NoBall,
        u,
        w: u.zero_like(),
        force,
        c: cs.c,
        energy: cs.energy_consts(),
        fb: 0.0,
        end: Trig::new(t_end_s - s.t, u.om, u.al, u.wd),
        cut: cs.cut.map(|c| c.segment(&u)),
    };
    if t_end_s > s.t {
        book.obs.segment(&seg);
        s = seg.at_end();
        s.t = t_end_s;
    }
    if book.tally.check && !(s.u.is_finite() && s.du.is_finite()) {
        return Err(SimError::NonFinite { t_s: s.t });
    }
    book.tally.summary.final_state = s.public();
    Ok(book.tally.summary)
}

/// Per-run scratch of the event searches (the root finder's buffers for large candidate sets).
type Search = Scratch;

/// The event functions of one segment and what each means (`ids`), on the stack: the capacity
/// `N` is the number of event functions the mode has (a wider set is a wider `N`); pushing more
/// fails loudly, nothing is ever dropped silently.
struct EventSet<const N: usize> {
    cands: [Cand; N],
    ids: [u8; N],
    n: usize,
}

impl<const N: usize> EventSet<N> {
    fn new(like: &ExpSum) -> Self {
        EventSet {
            cands: [Cand::new(*like, 0, 0.0); N],
            ids: [0; N],
            n: 0,
        }
    }
    fn push(&mut self, id: u8, c: Cand) {
        assert!(
            self.n < N,
            "a mode declared {N} event functions and pushed more"
        );
        self.cands[self.n] = c;
        self.ids[self.n] = id;
        self.n += 1;
    }
}

/// Hand a finished segment to the observer (if not empty) and return the state at its end.
fn close_segment(seg: &ExactSegment, book: &mut Book) -> St {
    if seg.t1 > seg.t0 {
        book.obs.segment(seg);
    }
    let mut next = seg.at_end();
    next.t = seg.t1;
    next
}

/// One free-flight segment with friction sign `σ` (0: no friction force) and the departure
/// orders `[wall +, wall −, ẇ = 0]` of its event functions ([`Kernel::free_flight`]). Events:
/// impact at a wall, `ẇ = 0` (friction switch or stick).
fn free_flight(
    cs: &Consts,
    sigma: f64,
    [k_plus, k_minus, k_sw]: [usize; 3],
    s: &mut St,
    t_end_s: f64,
    book: &mut Book,
    search: &mut Search,
) -> Result<u8, SimError> {
    let span = t_end_s - s.t;
    let tol_t = cs.tol_t_at(s.t);
    let fb = cs.fb(sigma);
    let (u, force) = cs.bar_sum(cs.m, -fb, s.t, s.u, s.du)?;
    let w = ExpSum {
        f0: s.w,
        k0: s.w + u.a + u.p,
        // `− u.c1`, `− u.c2`: the bar's polynomial part in a cut (0 otherwise, to the bit).
        c1: s.du + s.dw - u.c1,
        c2: cs.ball_half_acc(fb) - u.c2,
        a: -u.a,
        b: -u.b,
        p: -u.p,
        q: -u.q,
        ..u
    };
    // Candidates and what they mean: 1 wall +, 2 wall −, 3 ẇ = 0.
    let both_walls = !cs.frictional() || sigma == 0.0;
    let mut set = EventSet::<4>::new(&w);
    if both_walls || sigma > 0.0 {
        let g = w.affine(-1.0, cs.lg);
        set.push(1, Cand::new(g, k_plus, cs.tol_x));
    }
    if both_walls || sigma < 0.0 {
        let g = w.affine(1.0, cs.lg);
        set.push(2, Cand::new(g, k_minus, cs.tol_x));
    }
    if cs.frictional() && sigma != 0.0 {
        let g = w.deriv().affine(sigma, 0.0);
        set.push(3, Cand::new(g, k_sw, cs.tol_v));
    }
    let (best, which, end) = joint_search(cs, &mut set, search, span, tol_t, &u)?;
    let seg = ExactSegment {
        t0: s.t,
        t1: if which == 0 { t_end_s } else { s.t + best },
        mode: Mode::Free,
        u,
        w,
        force,
        c: cs.c,
        energy: cs.energy_consts(),
        fb,
        end,
        cut: cs.cut.map(|c| c.segment(&u)),
    };
    let next = close_segment(&seg, book);
    book.check_state(&next)?;
    *s = next;
    Ok(which)
}

/// One segment of the pair moving as one body: stuck together away from the walls (`coulomb`)
/// or the ball pressed on a wall ([`Kernel::held`]). Events: unstick when `|m_d ü_pair|` reaches
/// `f`, release when the force pressing the ball on the wall reaches 0 (`f_hold`).
fn pair_motion(
    cs: &Consts,
    mode: Md,
    s: &mut St,
    t_end_s: f64,
    book: &mut Book,
    search: &mut Search,
) -> Result<u8, SimError> {
    let span = t_end_s - s.t;
    let tol_t = cs.tol_t_at(s.t);
    let (u, force) = cs.bar_sum(cs.m + cs.md, cs.pair_load(), s.t, s.u, s.du)?;
    let ddu = u.deriv().deriv();
    let w = ExpSum::constant(s.w, &u);
    // Margins that stay positive while the mode holds: `k + sc·f` with `f = m_d (ü − g_s)` the
    // force the bar exerts on the ball (`m_d ü` without a body force).
    let mk =
        |sc: f64, k: f64| Cand::new(ddu.affine(sc * cs.md, cs.margin_level(sc, k)), 0, cs.tol_f);
    let mut set = EventSet::<3>::new(&w);
    let seg_mode = match mode {
        Md::Stick => {
            set.push(1, mk(-1.0, cs.fl)); // ball lags
            set.push(2, mk(1.0, cs.fl)); // ball leads
            Mode::Stick
        }
        Md::Contact(wall) => {
            set.push(3, mk(-wall.sign(), cs.f_hold()));
            Mode::Contact(wall)
        }
        Md::Free { .. } | Md::HertzTouch(_) => {
            unreachable!("pair_motion is called for stick and contact")
        }
    };
    let (best, which, end) = joint_search(cs, &mut set, search, span, tol_t, &u)?;
    let seg = ExactSegment {
        t0: s.t,
        t1: if which == 0 { t_end_s } else { s.t + best },
        mode: seg_mode,
        u,
        w,
        force,
        c: cs.c,
        energy: cs.energy_consts(),
        fb: 0.0,
        end,
        cut: cs.cut.map(|c| c.segment(&u)),
    };
    let mut next = close_segment(&seg, book);
    next.dw = 0.0;
    book.check_state(&next)?;
    *s = next;
    Ok(which)
}

/// The segment's joint event search: drop the margins that cannot fall, find the earliest zero
/// on `[0, span]`, and return `(τ, which, Trig at τ)`; `which = 0` means no event before `span`,
/// [`HORIZON`] no event before `τ < span` with the search's work bound reached.
/// The transcendentals the search already has at the zero are reused for the end state.
fn joint_search<const N: usize>(
    cs: &Consts,
    set: &mut EventSet<N>,
    scratch: &mut Scratch,
    span: f64,
    tol_t: f64,
    u: &ExpSum,
) -> Result<(f64, u8, Trig), SimError> {
    let n = if let Some(cp) = &cs.cut {
        // The chip function, positive while the mode holds: `h` in the cut, `−h` out of it.
        let h = cp.chip(u);
        let g = if cp.in_cut { h } else { h.affine(-1.0, 0.0) };
        set.push(CUT, Cand::new(g, cp.order, cp.tol));
        let n = drop_constant_margins(&mut set.cands[..set.n], &mut set.ids[..set.n]);
        // A cutting run's pieces are short: most are cleared by the search's first step alone,
        // which is the full search's own answer (`Root::None`; see `first_step_clears`), and
        // most end at the regular piece length, whose transcendentals are cached.
        if first_step_clears(&set.cands[..n], span, tol_t) {
            return Ok((span, 0, cutting::end_trig(span, u.om, u.al, u.wd)));
        }
        n
    } else {
        drop_constant_margins(&mut set.cands[..set.n], &mut set.ids[..set.n])
    };
    let (root, i, trig) = first_root_multi_trig(&set.cands[..n], 0.0, span, tol_t, scratch);
    let (best, which) = match root {
        Root::At(t) => (t, set.ids[i]),
        Root::None => (span, 0),
        Root::Horizon(t) => (t, HORIZON),
    };
    let end = match trig {
        Some(tr) if tr.tau.to_bits() == best.to_bits() => tr,
        _ => Trig::new(best, u.om, u.al, u.wd),
    };
    Ok((best, which, end))
}

/// Move the candidates that are constant and not below `−tol` past the returned count: such a
/// margin (the pair at rest and unforced) never falls through zero, so the mode holds, as the
/// entry tests decide at equality. Searched, an exact 0 would be a root at once, and the
/// release, the graze back (ẅ ≡ 0, departure unconfirmed) and the contact test would loop at one
/// instant until the event limit. `ids` is permuted alongside.
fn drop_constant_margins(cands: &mut [Cand], ids: &mut [u8]) -> usize {
    let mut n = cands.len();
    let mut k = 0;
    while k < n {
        if cands[k].g.is_constant() && cands[k].g.f0 >= -cands[k].tol {
            cands.swap(k, n - 1);
            ids.swap(k, n - 1);
            n -= 1;
        } else {
            k += 1;
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::EventLimitCause;

    fn book(obs: &mut dyn Observer, check: bool) -> Book<'_> {
        Book {
            obs,
            tally: Tally::new(
                RunSummary {
                    max_penetration_m: f64::NEG_INFINITY,
                    ..Default::default()
                },
                10,
                check,
                1e-4,
            ),
            cut_event: false,
        }
    }

    fn st(w: f64, u: f64) -> St {
        St {
            t: 0.5,
            u,
            du: 0.0,
            w,
            dw: 0.0,
            force: 0.0,
        }
    }

    fn tail_cause(cs: &Consts, kinds: &[EventKind]) -> EventLimitCause {
        let mut t = driver::Tail::new(kinds.len() as u64);
        for (i, k) in kinds.iter().enumerate() {
            t.record(i as f64 * 1e-6, k);
        }
        match t.error(
            &cs.limit_facts(cs.om, cs.osc[0].wd),
            kinds.len() as u64,
            1e-3,
        ) {
            SimError::TooManyEvents { cause, .. } => cause,
            e => panic!("{e:?}"),
        }
    }

    /// Bug A10: the event-limit error named no cause. The last events before the limit name it.
    #[test]
    fn regression_event_limit_names_a_ball_resting_on_a_wall_and_stick_slip() {
        let sys = System::paper_damped(1e-3, FrictionModel::Coulomb, 1.0);
        let cs = Consts::new(&sys, sys.lumped_bar().unwrap());
        let wall = Wall::Plus;
        let graze = EventKind::Impact {
            wall,
            dw_m_s: 0.0,
            energy_loss_j: 0.0,
        };
        let release = EventKind::ContactRelease { wall };
        let on_wall: Vec<EventKind> = (0..100)
            .map(|i| if i % 2 == 0 { graze } else { release })
            .collect();
        assert_eq!(tail_cause(&cs, &on_wall), EventLimitCause::RestingOnWall);
        let stick_slip: Vec<EventKind> = (0..100)
            .map(|i| {
                if i % 2 == 0 {
                    EventKind::Stick
                } else {
                    EventKind::Unstick
                }
            })
            .collect();
        assert_eq!(tail_cause(&cs, &stick_slip), EventLimitCause::StickSlip);
        // Ordinary impacts at modest speed, coulomb: just many events.
        let hits: Vec<EventKind> = (0..100)
            .map(|_| EventKind::Impact {
                wall,
                dw_m_s: 1e-3,
                energy_loss_j: 0.0,
            })
            .collect();
        assert_eq!(tail_cause(&cs, &hits), EventLimitCause::Dense);
    }

    /// Bug A10: K = 1e-300 N/m with ζ = 0.01 was called an "undamped bar" forced at resonance:
    /// `(K − MΩ²)² + (CΩ)²` underflowed to 0, which the resonance test took for resonance. It
    /// is a response outside floating-point range, damped or not; only C = 0 at K = MΩ² (to
    /// rounding) is the undamped resonance.
    #[test]
    fn regression_tiny_stiffness_with_damping_was_called_an_undamped_bar() {
        let mut sys = System::paper_damped(1e-3, FrictionModel::None, 1.0);
        let bar = sys.bar.as_lumped_mut().unwrap();
        bar.stiffness_n_per_m = 1e-300;
        let bar = *bar;
        let cs = Consts::new(&sys, &bar);
        match cs.bar_sum(cs.m, 0.0, 0.0, 0.0, 0.0) {
            Err(e @ SimError::ResponseOutOfRange { .. }) => {
                assert!(!e.to_string().contains("undamped"), "{e}")
            }
            other => panic!("{other:?}"),
        }
        // The genuine case keeps its name.
        let mut und = System::paper_damped(1e-3, FrictionModel::None, 1.0);
        let bar = und.bar.as_lumped_mut().unwrap();
        bar.damping_ratio = 0.0;
        let bar = *bar;
        let cs = Consts::new(&und, &bar);
        assert!(matches!(
            cs.bar_sum(cs.m, 0.0, 0.0, 0.0, 0.0),
            Err(SimError::UndampedResonance { .. })
        ));
        // And a damped bar at resonance is fine.
        let sys = System::paper_damped(1e-3, FrictionModel::None, 1.0);
        let cs = Consts::new(&sys, sys.lumped_bar().unwrap());
        assert!(cs.bar_sum(cs.m, 0.0, 0.0, 0.0, 0.0).is_ok());
    }

    #[test]
    fn invariant_mode_reports_confinement_and_non_finite_states() {
        let mut o = ();
        let mut b = book(&mut o, true);
        assert!(b.check_state(&st(1e-4 + 0.5e-12, 0.0)).is_ok());
        assert!(matches!(
            b.check_state(&st(-1e-4 - 2e-12, 0.0)),
            Err(SimError::Confinement { .. })
        ));
        assert!(matches!(
            b.check_state(&st(0.0, f64::NAN)),
            Err(SimError::NonFinite { .. })
        ));
        // Without the mode the run goes on, but the penetration is still recorded.
        let mut o2 = ();
        let mut b2 = book(&mut o2, false);
        assert!(b2.check_state(&st(1e-4 + 2e-12, 0.0)).is_ok());
        assert!(b2.tally.summary.max_penetration_m > 1.9e-12);
    }
}
