//! Variational equations of the exact flow of the lumped bar (issue #11, item 1): the Jacobian
//! `∂x(t₁)/∂x(t₀)` of the solver's flow map, with saltation matrices at every event.
//!
//! # Built on the observer stream
//!
//! [`Variational`] is an [`Observer`]: it never re-runs or copies the solver. A run reports
//! smooth [`Segment`]s and [`Event`]s; the tangent map of the run is the product, in time order,
//! of one state transition matrix per segment and one saltation matrix per event. Both are 4×4
//! in the public coordinates `x = (u, u̇, v, v̇)` of [`State`]. The solver's results are untouched
//! (the layer only reads what it is shown), and nothing is allocated per segment or event.
//!
//! # Between events (closed form)
//!
//! Every mode is linear with constant coefficients plus a forcing that does not depend on the
//! state, so the transition matrix of a segment of length `τ` is that of the homogeneous part:
//!
//! * the bar of mass `m` (`M` in free flight, `M + m_d` for the pair), `α = C/2m`,
//!   `ω_d = √(K/m − α²)`:
//!   `Φ(τ) = e^{−ατ} [[cos + (α/ω_d) sin, sin/ω_d], [−(K/m) sin/ω_d, cos − (α/ω_d) sin]]`
//!   (`sin`, `cos` of `ω_d τ`), `det Φ = e^{−(C/m)τ}`;
//! * the ball in free flight: `[[1, τ], [0, 1]]` (its acceleration `F_ball/m_d` is constant);
//! * stick and wall contact (one body of mass `M + m_d`): first the projection `P` onto the
//!   constrained motion — `u̇, v̇ → (M u̇ + m_d v̇)/(M + m_d)` (momentum), and in wall contact
//!   `v → u ± l_g` — then the pair's `Φ` with `v` following `u` at fixed `w`.
//!
//! **Constrained phases.** During stick the motion lives on `ẇ = 0` (three dimensions: `u`, `u̇`,
//! `w`), during wall contact on `w = ±l_g`, `ẇ = 0` (two: `u`, `u̇`). The Jacobian stays 4×4:
//! it maps into that subspace (its rank drops to 3 or 2) and the saltation matrices at stick,
//! at a plastic impact (chatter accumulation, `e = 0`) and at unstick/release map between the
//! full and the constrained motion. A run that starts stuck or on a wall is differentiated along
//! the constraint (`P` applies at the start): a perturbation off it is not differentiable there
//! (a ball lifted off a wall falls back in a time `∝ √δw`).
//!
//! # At events (saltation)
//!
//! For an event on the surface `h(x, t) = 0` reached by the flow `f⁻` and followed by the reset
//! `x⁺ = g(x⁻)` and the flow `f⁺`, the first-order map of perturbations is
//! (Müller 1995; Leine & Nijmeijer 2004, §3.5; di Bernardo et al. 2008, §2.5)
//!
//! `S = G + (f⁺ − G f⁻) ∇hᵀ / (∇h·f⁻ + ∂h/∂t)`,  `G = ∂g/∂x`,
//!
//! with `f± = f±(x±, t)` evaluated at the event. The specialisations:
//!
//! | event | `h` | `G` | `f⁺ − G f⁻` |
//! |---|---|---|---|
//! | impact (`e`) at wall `s` | `v − u − s l_g` | restitution map on `(u̇, v̇)` | velocities and forces jump |
//! | impact accumulation (chatter limit), `e = 0` into contact | same | plastic map `P` | into the pair's flow |
//! | friction switch (`ẇ` changes sign) | `v̇ − u̇` | `I` | friction force `F_ball` reverses |
//! | stick | `v̇ − u̇` | `I` | ball joins the bar: `S` zeroes `δẇ` |
//! | unstick, contact release | `f_l ∓ m_d ü_pair(x, t)` | `I` | 0 for Coulomb and frictionless: at the threshold the friction (or wall) force equals what the pair needs; an as-published release switches its friction force `F` on |
//!
//! `det S = e²` for an impact of the frictionless lumped bar (`det G = −e` on the velocities,
//! `ẇ⁺/ẇ⁻ = −e` from the time shift); with friction the force jump adds a term.
//!
//! The solver jumps over an accumulating impact sequence (infinitely many impacts) to its
//! plastic limit at the first impact and rides the wall for the sequence's duration `Δt`; its
//! [`EventKind::ChatterLimit`] then marks the end of that sum. The variational layer sees the
//! impact followed by a contact segment and applies the plastic saltation. The dependence of
//! `Δt` on the state matters only when the ball leaves the wall at once at the limit; that case
//! is counted ([`EventCounts::chatter_releases`]) and treated as `S = I` there.
//!
//! An impact with `ẇ⁻ = 0` (a touch, grazing) has no saltation matrix (`∇h·f⁻ = 0`: the map
//! is not differentiable there); it is counted in [`EventCounts::grazing`] and only `G` is
//! applied. Near grazing `S` is large: that is the true sensitivity, not an error.
//!
//! # The stroboscopic map (periodic orbits)
//!
//! The flow is non-autonomous (forcing `F₀ sin Ωt`); the Jacobian is taken at fixed start and
//! end times. The stroboscopic map over `k` forcing periods, `P(x₀) = x(t₀ + kT)`, and its
//! Jacobian `DP` (whose eigenvalues are the Floquet multipliers of a periodic orbit) are
//! `flow_with_jacobian(&Exact::default(), &sys, &x0, x0.t_s + k·T, &mut ())`;
//! [`FlowJacobian::end_field`] is `∂x(t_end)/∂t_end`. The state passed in is the public
//! `(u, u̇, v, v̇)`; whether the ball starts stuck or on a wall is decided by the solver from
//! that state, as for any run (see "constrained phases" above for what the Jacobian then
//! means).
//!
//! # Parameter derivatives
//!
//! [`flow_with_param_derivative`] carries one extra column `d = ∂x/∂p` (zero at the start,
//! start state and times fixed) through the same segments and events:
//!
//! * segment: `d ← Φ(τ) d + ∫₀^τ Φ(τ − s) ∂f/∂p ds`;
//! * event: `d ← S d + ∂g/∂p + (f⁺ − G f⁻) (∂h/∂p) / (∇h·f⁻ + ∂h/∂t)` (the event time moves
//!   by `δt* = −(∇h·δx + ∂h/∂p δp)/rate`; the same derivation as `S`).
//!
//! The parameters ([`Param`]):
//!
//! * **restitution `e`** enters only the impact reset: `∂u̇⁺/∂e = μ/(1+μ) ẇ⁻`,
//!   `∂v̇⁺/∂e = (μ/(1+μ) − 1) ẇ⁻` (`μ = m_d/M`); zero at a plastic (accumulated) impact, whose
//!   limit does not depend on `e` (its duration does, which matters only at a chatter release,
//!   counted in [`EventCounts::chatter_releases`]);
//! * **friction level `F`** enters the free flight as the constant force `b F` on the ball and
//!   `−b F` on the bar (`b = ∂F_ball/∂F = ∓sgn ẇ`): closed form
//!   `Δ(u, u̇) = (I − Φ_M(τ)) (−b/K, 0)`, `Δv = b τ²/(2 m_d)`, `Δv̇ = b τ/m_d`. In stick and wall
//!   contact it enters only the unstick/release threshold `h`, where `f⁺ = f⁻` (Coulomb) or `h`
//!   does not hold `F` (as published: zero holding capacity), so the event term vanishes;
//! * **gap `gap_m = 2 l_g`** enters only the wall surfaces `h = w − s l_g`: `∂h/∂gap = −s/2`
//!   at each impact (the moving surface), and on the wall `v = u + s l_g` the projection (which
//!   keeps `δw = 0`) is followed by the offset `∂v/∂gap += s/2`;
//! * **frequency ratio `r = Ω/ω₁`** enters every segment through `∂F/∂r = ω₁ F₀ t cos Ωt`
//!   (absolute time `t`): the particular solution of `m ü + C u̇ + K u = F₀ t cos Ωt` is
//!   `u_p = Re[F₀ e^{st}(t/D − D'/D²)]`, `s = iΩ`, `D(s) = m s² + C s + K` (differentiate
//!   `L e^{st} = D(s) e^{st}` in `s`), and the segment adds `x_p(t₁) − Φ(τ) x_p(t₀)` (`m = M`
//!   in free flight; `M + m_d` for the pair, the ball following at fixed `w`). At unstick and
//!   release `∂h/∂r = r_m F₀ t cos Ωt · ω₁` (`r_m = m_d/(M + m_d)`), which matters only where
//!   `f⁺ ≠ f⁻` (the as-published release). The column is at fixed end time; the stroboscopic
//!   map's end `t₀ + 2πk/Ω` adds `end_field · (−kT/r)`
//!   (`orbit::continuation::map_param_derivative`).
//!
//! # Hertz contact phases (`contact.law = "hertz"`)
//!
//! The compliant phase of `solver/exact/hertz_phase.rs` (the lumped bar's side in
//! `solver/exact/lumped/hertz.rs`) has, with penetration `δ = s w − l_g`
//! (`s = ±1` the wall), the contact coordinates `y = (u, u̇, δ, δ̇)`
//! (`y = T x + const`, `T⁻¹ = [[1,0,0,0],[0,1,0,0],[1,0,s,0],[0,1,0,s]]`) and the field
//!
//! `M ü = F(t) − C u̇ − K u + s P − F_b`, `m_d v̈ = −s P + F_b`, `δ̈ = s (v̈ − ü)`,
//! `P = K_h δ^{3/2} (1 + D δ̇/δ̇₀)`,
//!
//! `F_b` the sliding friction with `σ = sgn ẇ` (0 when stuck), `δ̇₀` the approach speed at the
//! touch (or the floor `10⁻³ l_g max(Ω, ω_d)` when slower). Stuck (Coulomb, inside the contact):
//! the pair moves as one body at fixed `δ`.
//!
//! **Contact onset and release: `S = I`.** Both happen at `δ = 0`, where `P = 0` on both
//! sides: the elastic part is `δ^{3/2}`, and the damping part `K_h D δ^{3/2} δ̇/δ̇₀` is
//! weighted by the same `δ^{3/2}`, so it vanishes at `δ = 0` whatever `δ̇` is (a
//! Kelvin–Voigt or Hunt–Crossley law with a bare `c δ̇` term would jump by `c δ̇` there and give
//! `S ≠ I`). The friction force is the same on both sides (`σ = s` pressed in at the onset,
//! `σ = −s` leaving at the release, in flight and in contact alike). So `f⁺ = f⁻`, and
//! `S = I + (f⁺ − f⁻)∇hᵀ/rate = I` with `h = w − s l_g`, rate `ẇ ≠ 0`. (The release is built
//! with the general formula, so a friction force that differed would enter.) The contact is
//! ended by `δ = 0`, which is where the force returns to 0 (`1 + D δ̇/δ̇₀ ≥ 1 − eD > 0` on
//! the way out, `crate::damper::contact`).
//!
//! **The memory of the approach speed.** `δ̇₀` is fixed at the touch from the state there, so
//! inside the phase the field depends on the touch state as well as on the current one. The
//! perturbed trajectory touches at `t* + δt*`, `δt* = −δw/ẇ⁻`, with
//! `δδ̇₀ = s (δẇ − ẅ⁻ δw/ẇ⁻)` =: `cᵀ δx` (0 where the floor holds `δ̇₀`). The layer carries
//! `Z = [W | ζ]` (4×5), `W = ∂y/∂x(touch)` from `W = T` and `ζ = ∂y/∂δ̇₀` from 0, through
//!
//! `Z' = A(t) Z + [0 | b(t)]`, `A = ∂f/∂y`, `b = ∂f/∂δ̇₀`,
//!
//! with `P_δ = (3/2) K_h δ^{1/2}(1 + D δ̇/δ̇₀)`, `P_δ̇ = K_h δ^{3/2} D/δ̇₀`,
//! `P_δ̇₀ = −K_h δ^{3/2} D δ̇/δ̇₀²`: rows `ü`: `(−K/M, −C/M, s P_δ/M, s P_δ̇/M)`,
//! `δ̈`: `(s K/M, s C/M, −P_δ (1/M + 1/m_d), −P_δ̇ (1/M + 1/m_d))`, and
//! `b = (0, s P_δ̇₀/M, 0, −P_δ̇₀ (1/M + 1/m_d))`. The phase's tangent map (touch to release, or
//! to the end of the run) is `T⁻¹ (W + ζ cᵀ)`, handed to the sink as one
//! `Step::Segment { mode: Contact }` at the release. Its determinant is not Liouville's alone:
//! `det = exp(∫ tr A dt) · Π det S_friction · (1 + cᵀ W⁻¹ ζ)`, `tr A = −C/M − P_δ̇ (1/M + 1/m_d)`;
//! the last factor (the memory) is summed in [`Variational::approach_memory_log`].
//!
//! **Along the phase** the flow is Dormand–Prince's, not a closed form. `Z` is integrated as a
//! separate linear ODE along each accepted step's dense output (the observer reads
//! [`Segment::state_at`]; the solver is not touched, its results stay bit-identical), by an
//! adaptive Dormand–Prince 5(4) with its own error control, relative tolerance
//! [`HERTZ_TANGENT_RTOL`] (= the phase's `CONTACT_RTOL`, 1e-9) on every entry, absolute
//! `1e-9 · scaleᵢ/scaleⱼ` (`(l_g, v, δ_max, v)`). The dense output is 4th-order; tightening the
//! tangent tolerance to 1e-12 moves the Jacobian by ~2e-8 relative (measured, 0.08 mm, r = 1).
//! What limits a comparison with finite differences is the solver: its end state at
//! `CONTACT_RTOL = 1e-9` is not differentiable to better than ~1e-5 relative (its step-size
//! sequence moves with the start state); with the phase run at 1e-12 central differences
//! agree with this Jacobian to 2e-8 (frictionless) and 6e-7 (as published, friction switches
//! inside contacts) (measured; `tests/variational_hertz.rs` runs at the shipped tolerance).
//!
//! **Friction inside a contact** (the phase restarts at each): where `δ̇` crosses 0 the
//! sliding force reverses (`h = δ̇`, rate `δ̈⁻`, `f⁺ − f⁻ = ΔF_b (0, −1/M, 0, s(1/M + 1/m_d))`)
//! or Coulomb sticks (`f⁺` the stuck field: `S` zeroes `δδ̇`, a direction removed for good,
//! marked to the sink by an identity `Step::Event { kind: Stick }` after the phase); unstick at
//! `h = f_l ∓ (m_d ü_pair + s K_h δ^{3/2})` (the solver's test), where Coulomb's `f⁺ = f⁻`.
//! Each is the usual `S = I + (f⁺ − f⁻)∇hᵀ/(∇h·f⁻ + ∂h/∂t)` on `Z` (`h` does not hold `δ̇₀`).
//!
//! **Limits.** A touch at `ẇ = 0` (a pressed ball starting a resting contact) is counted as
//! grazing (a perturbation can lift the ball off). A run that ends inside a contact has the
//! partial map; a run started from such a state restarts the contact at `δ = 0` (the solver
//! puts the ball back on the wall), so Poincaré sections should be in free flight. The
//! parameter column ([`flow_with_param_derivative`]) is not built for this law: callers take
//! central differences of the map (the continuation does).
//!
//! # Not covered
//!
//! * The N-mode bar (`ModalExact`): refused here; [`super::variational_modal`] is the same
//!   construction with the modal transition matrices and the contact row `w = v − Σ φₙ qₙ`
//!   (either contact law).
//! * Parameter derivatives other than [`Param`]'s (mass ratio, forcing amplitude).
//!
//! References: P. C. Müller, "Calculation of Lyapunov exponents for dynamic systems with
//! discontinuities", Chaos, Solitons & Fractals 5 (1995) 1671–1681; R. I. Leine and
//! H. Nijmeijer, *Dynamics and Bifurcations of Non-Smooth Mechanical Systems*, Springer 2004.

use crate::damper::contact::Hertz;
use crate::damper::friction::sliding_friction_on_ball_n;
use crate::error::SimError;
use crate::params::{ContactLaw, FrictionModel, State, System};
use crate::solver::dopri5::Dopri5;
use crate::solver::{
    CompliantContact, Event, EventKind, Mode, Observer, RunSummary, Segment, Solver,
};

/// A 4×4 matrix, row-major, on `(u, u̇, v, v̇)`.
pub type Mat4 = [[f64; 4]; 4];

/// Why the variational layer refuses a modal bar.
pub const VARIATIONAL_LUMPED_ONLY: &str = "this variational layer is the lumped bar's (4×4 tangent maps); the N-mode bar's 2N+2-dimensional tangent map is analysis::variational_modal";
/// Why the variational layer refuses a solver other than `exact`.
pub const VARIATIONAL_EXACT_ONLY: &str = "the variational flow (Jacobian, Lyapunov spectrum) needs the exact solver: its saltation matrices need the event times and states the exact solver resolves (a fixed-step solver puts events on its grid)";

/// `Unsupported` unless `solver` is the exact solver.
pub fn require_exact(solver: &dyn Solver) -> Result<(), SimError> {
    if solver.name() == "exact" {
        Ok(())
    } else {
        Err(SimError::Unsupported(VARIATIONAL_EXACT_ONLY))
    }
}

/// Why the variational layer refuses a parameter derivative under the Hertz law.
pub const VARIATIONAL_NO_HERTZ_PARAM: &str = "the parameter column of the variational flow covers the instantaneous restitution law; under the hertz law take central differences of the map (orbit::continuation::map_param_derivative_fd)";
/// Why the variational layer refuses a bar without a ball.
pub const VARIATIONAL_NEEDS_BALL: &str =
    "the variational flow needs a damper (a solid bar is linear: its Jacobian is the bar's closed form)";

/// The identity.
pub const IDENTITY: Mat4 = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// `a · b`.
#[inline]
pub fn mat_mul(a: &Mat4, b: &Mat4) -> Mat4 {
    let mut c = [[0.0; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            c[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j] + a[i][3] * b[3][j];
        }
    }
    c
}

/// Determinant (Laplace expansion over 2×2 minors).
pub fn det4(m: &Mat4) -> f64 {
    let s0 = m[0][0] * m[1][1] - m[1][0] * m[0][1];
    let s1 = m[0][0] * m[1][2] - m[1][0] * m[0][2];
    let s2 = m[0][0] * m[1][3] - m[1][0] * m[0][3];
    let s3 = m[0][1] * m[1][2] - m[1][1] * m[0][2];
    let s4 = m[0][1] * m[1][3] - m[1][1] * m[0][3];
    let s5 = m[0][2] * m[1][3] - m[1][2] * m[0][3];
    let c5 = m[2][2] * m[3][3] - m[3][2] * m[2][3];
    let c4 = m[2][1] * m[3][3] - m[3][1] * m[2][3];
    let c3 = m[2][1] * m[3][2] - m[3][1] * m[2][2];
    let c2 = m[2][0] * m[3][3] - m[3][0] * m[2][3];
    let c1 = m[2][0] * m[3][2] - m[3][0] * m[2][2];
    let c0 = m[2][0] * m[3][1] - m[3][0] * m[2][1];
    s0 * c5 - s1 * c4 + s2 * c3 + s3 * c2 - s4 * c1 + s5 * c0
}

/// Where a tangent map comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Step {
    /// The transition matrix of a segment `[t0, t1]` in `mode`.
    Segment {
        /// Start.
        t0_s: f64,
        /// End.
        t1_s: f64,
        /// Mode.
        mode: Mode,
    },
    /// The saltation matrix of an event (`None` when the event has none: grazing, then the
    /// map is the reset's `G` alone).
    Event {
        /// Time.
        t_s: f64,
        /// What happened.
        kind: EventKind,
        /// Whether an impact was taken to its plastic limit (accumulation).
        plastic: bool,
    },
}

/// What receives the tangent maps of a run, in time order: `x ↦ m x` for each segment and event.
pub trait TangentSink {
    /// Apply `m`, the tangent map of `step`.
    fn apply(&mut self, m: &Mat4, step: Step);
}

/// Accumulates the Jacobian `J ← m J`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JacobianSink {
    /// The product so far.
    pub jacobian: Mat4,
}

impl Default for JacobianSink {
    fn default() -> Self {
        JacobianSink { jacobian: IDENTITY }
    }
}

impl TangentSink for JacobianSink {
    fn apply(&mut self, m: &Mat4, _step: Step) {
        self.jacobian = mat_mul(m, &self.jacobian);
    }
}

/// How many events of each kind the tangent map went through.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EventCounts {
    /// Impacts with restitution (ball leaves the wall).
    pub impacts: u64,
    /// Impacts taken to the plastic limit (accumulating sequence summed, or `e = 0` into contact).
    pub plastic_impacts: u64,
    /// Friction switches.
    pub friction_switches: u64,
    /// Stick events.
    pub sticks: u64,
    /// Unstick events.
    pub unsticks: u64,
    /// Chatter-limit (impact accumulation) events.
    pub chatter_limits: u64,
    /// Chatter limits where the ball left the wall at once (event-time sensitivity of the
    /// accumulation time not included there).
    pub chatter_releases: u64,
    /// Contact releases.
    pub releases: u64,
    /// Events without a saltation matrix (impact with `ẇ⁻ = 0`, or a vanishing crossing rate):
    /// the map is not differentiable there.
    pub grazing: u64,
    /// Compliant (`hertz`) contact phases entered (their releases are counted in `impacts`,
    /// the solver reports each as an impact; friction switches, sticks and unsticks inside
    /// them in those fields).
    pub compliant_contacts: u64,
}

/// The ball's phase: mode and friction sign of a free flight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Phase {
    pub(super) mode: Mode,
    pub(super) sigma: f64,
}

// The phase bookkeeping around events is the same for the lumped and the N-mode bar
// (variational_modal uses these too), so it is stated once here.
impl Phase {
    /// The phase after event `ev` when no segment follows to say it; `cur` is the phase the
    /// event ended.
    pub(super) fn default_after(ev: &Event, cur: Option<Phase>) -> Phase {
        let free = |dw: f64| Phase {
            mode: Mode::Free,
            sigma: crate::damper::friction::sgn0(dw),
        };
        match ev.kind {
            EventKind::Impact { wall, .. } if ev.after.dw_m_s() == 0.0 => Phase {
                mode: Mode::Contact(wall),
                sigma: 0.0,
            },
            EventKind::Impact { .. } => free(ev.after.dw_m_s()),
            EventKind::FrictionSwitch => Phase {
                mode: Mode::Free,
                sigma: -cur.map_or(0.0, |c| c.sigma),
            },
            EventKind::Stick => Phase {
                mode: Mode::Stick,
                sigma: 0.0,
            },
            EventKind::Unstick => free(0.0),
            EventKind::ChatterLimit { wall, .. } => Phase {
                mode: Mode::Contact(wall),
                sigma: 0.0,
            },
            EventKind::ContactRelease { wall } => Phase {
                mode: Mode::Free,
                sigma: -wall.sign(),
            },
        }
    }

    /// The phase before event `ev` implied by its kind (for an event that follows another at
    /// once).
    pub(super) fn before(ev: &Event, last: Option<Phase>) -> Phase {
        match ev.kind {
            EventKind::Impact { .. } | EventKind::FrictionSwitch | EventKind::Stick => Phase {
                mode: Mode::Free,
                sigma: last.map_or(0.0, |p| p.sigma),
            },
            EventKind::Unstick => Phase {
                mode: Mode::Stick,
                sigma: 0.0,
            },
            EventKind::ChatterLimit { wall, .. } | EventKind::ContactRelease { wall } => Phase {
                mode: Mode::Contact(wall),
                sigma: 0.0,
            },
        }
    }
}

/// An event waiting for the mode that follows it (its `f⁺`).
#[derive(Debug, Clone, Copy)]
struct Pending {
    ev: Event,
    before: Phase,
    /// The end of a compliant contact phase (the solver's `Impact` at the release).
    release: bool,
}

/// Constants of the lumped system.
#[derive(Debug, Clone, Copy)]
struct Lumped {
    m: f64,
    md: f64,
    k: f64,
    c: f64,
    e: f64,
    fl: f64,
    model: FrictionModel,
    fs: f64,
    f0: f64,
    om: f64,
    /// `∂Ω/∂ratio = ω₁`.
    om1: f64,
    /// The compliant law, `None` under the restitution law.
    hertz: Option<Hertz>,
    /// Half gap `l_g`.
    lg: f64,
}

impl Lumped {
    fn force(&self, t: f64) -> f64 {
        self.fs + self.f0 * (self.om * t).sin()
    }
    fn dforce_dt(&self, t: f64) -> f64 {
        self.f0 * self.om * (self.om * t).cos()
    }
    /// Friction force on the ball in a free flight with sign `σ`.
    fn fb(&self, sigma: f64) -> f64 {
        sliding_friction_on_ball_n(self.model, self.fl, sigma)
    }
    /// The free-flight friction sign `σ` whose sliding force is `fb` (`F_b = s F sgn σ`).
    fn sigma_of_fb(&self, fb: f64) -> f64 {
        crate::damper::friction::sign_factor(self.model) * crate::damper::friction::sgn0(fb)
    }
    fn mu_ratio(&self) -> f64 {
        self.md / (self.m + self.md)
    }

    /// The vector field `f = (u̇, ü, v̇, v̈)` of phase `p` at `x`, `t`.
    fn field(&self, p: Phase, x: &State, t: f64) -> [f64; 4] {
        let free = self.force(t) - self.c * x.du_m_s - self.k * x.u_m;
        match p.mode {
            Mode::Free | Mode::NoBall => {
                let fb = self.fb(p.sigma);
                [x.du_m_s, (free - fb) / self.m, x.dv_m_s, fb / self.md]
            }
            Mode::Stick | Mode::Contact(_) => {
                let a = free / (self.m + self.md);
                [x.du_m_s, a, x.dv_m_s, a]
            }
        }
    }

    /// `e^{−ατ}`-form transition matrix of the bar of mass `mass` over `τ` (2×2).
    fn bar_phi(&self, mass: f64, tau: f64) -> [[f64; 2]; 2] {
        let al = self.c / (2.0 * mass);
        let wn2 = self.k / mass;
        let wd = (wn2 - al * al).sqrt();
        let ex = (-al * tau).exp();
        let (s, co) = (wd * tau).sin_cos();
        let sw = s / wd;
        [
            [ex * (co + al * sw), ex * sw],
            [-wn2 * ex * sw, ex * (co - al * sw)],
        ]
    }

    /// `(u_p, u̇_p)(t)`: a particular solution of `mass ü + C u̇ + K u = F₀ t cos Ωt`,
    /// `Re[F₀ e^{st} (t/D − D'/D²)]`, `s = iΩ`, `D(s) = mass s² + C s + K` (differentiate
    /// `L e^{st} = D(s) e^{st}` in `s`).
    fn secular_particular(&self, mass: f64, t: f64) -> [f64; 2] {
        use nalgebra::Complex;
        let sj = Complex::new(0.0, self.om);
        let d = sj * sj * mass + sj * self.c + self.k;
        let dp = sj * (2.0 * mass) + self.c;
        let est = Complex::new(0.0, self.om * t).exp() * self.f0;
        let a = Complex::new(t, 0.0) / d - dp / (d * d);
        let u = est * a;
        let du = est * (sj * a + Complex::new(1.0, 0.0) / d);
        [u.re, du.re]
    }

    /// `∫ Φ(τ − s) (0, F₀ s cos Ωs / mass) ds` over `[t0, t1]`, from zero.
    fn secular_response(&self, mass: f64, t0: f64, t1: f64) -> [f64; 2] {
        let (a, b) = (
            self.secular_particular(mass, t0),
            self.secular_particular(mass, t1),
        );
        let p = self.bar_phi(mass, t1 - t0);
        [
            b[0] - p[0][0] * a[0] - p[0][1] * a[1],
            b[1] - p[1][0] * a[0] - p[1][1] * a[1],
        ]
    }

    /// The projection onto the constrained motion of phase `mode` (identity in free flight).
    fn projection(&self, mode: Mode) -> Mat4 {
        let r = self.mu_ratio();
        match mode {
            Mode::Free | Mode::NoBall => IDENTITY,
            Mode::Stick => [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0 - r, 0.0, r],
                [0.0, 0.0, 1.0, 0.0],
                [0.0, 1.0 - r, 0.0, r],
            ],
            Mode::Contact(_) => [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0 - r, 0.0, r],
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0 - r, 0.0, r],
            ],
        }
    }

    /// Transition matrix of a segment of phase `mode` and length `τ`.
    fn segment_stm(&self, mode: Mode, tau: f64) -> Mat4 {
        match mode {
            Mode::Free | Mode::NoBall => {
                let p = self.bar_phi(self.m, tau);
                [
                    [p[0][0], p[0][1], 0.0, 0.0],
                    [p[1][0], p[1][1], 0.0, 0.0],
                    [0.0, 0.0, 1.0, tau],
                    [0.0, 0.0, 0.0, 1.0],
                ]
            }
            Mode::Stick | Mode::Contact(_) => {
                let p = self.bar_phi(self.m + self.md, tau);
                // v(τ) = u(τ) + (v₀ − u₀), v̇ = u̇; then the projection at the start.
                let pair = [
                    [p[0][0], p[0][1], 0.0, 0.0],
                    [p[1][0], p[1][1], 0.0, 0.0],
                    [p[0][0] - 1.0, p[0][1], 1.0, 0.0],
                    [p[1][0], p[1][1], 0.0, 0.0],
                ];
                mat_mul(&pair, &self.projection(mode))
            }
        }
    }

    /// Restitution map on `(u̇, v̇)` as a 4×4 `G` (positions kept).
    fn impact_g(&self) -> Mat4 {
        // u̇⁺ = u̇ + β(v̇ − u̇), v̇⁺ = u̇⁺ − e(v̇ − u̇), β = μ(1+e)/(1+μ), μ = m_d/M.
        let mu = self.md / self.m;
        let beta = mu * (1.0 + self.e) / (1.0 + mu);
        [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0 - beta, 0.0, beta],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 1.0 - beta + self.e, 0.0, beta - self.e],
        ]
    }

    /// `G = ∂g/∂x` of the plastic limit (common momentum-conserving velocity).
    fn plastic_g(&self) -> Mat4 {
        let r = self.mu_ratio();
        [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0 - r, 0.0, r],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 1.0 - r, 0.0, r],
        ]
    }
}

impl Lumped {
    /// Contact coordinates `y = (u, u̇, δ, δ̇)` of a public state at wall `sw`:
    /// `δ = sw·w − l_g`, `δ̇ = sw·ẇ`.
    fn hz_y(&self, sw: f64, x: &State) -> [f64; 4] {
        [x.u_m, x.du_m_s, sw * x.w_m() - self.lg, sw * x.dw_m_s()]
    }

    /// The compliant phase's vector field in contact coordinates (`hertz.rs`):
    /// `M ü = F(t) − C u̇ − K u + sw P − F_b`, `m_d v̈ = −sw P + F_b`, `δ̈ = sw (v̈ − ü)`; stuck:
    /// the pair moves as one body at fixed `δ`.
    fn hz_field(&self, c: &CompliantContact, t: f64, y: &[f64; 4]) -> [f64; 4] {
        let free = self.force(t) - self.c * y[1] - self.k * y[0];
        if c.stuck {
            return [y[1], free / (self.m + self.md), 0.0, 0.0];
        }
        let sw = c.wall_sign;
        let p = c.law.force_n(y[2], y[3], c.reference_speed_m_s);
        let fb = c.ball_friction_n;
        let ddu = (free + sw * p - fb) / self.m;
        let ddv = (-sw * p + fb) / self.md;
        [y[1], ddu, y[3], sw * (ddv - ddu)]
    }

    /// The phase's vector field in public coordinates `(u̇, ü, v̇, v̈)` at `x`.
    fn hz_field_public(&self, c: &CompliantContact, t: f64, x: &State) -> [f64; 4] {
        let sw = c.wall_sign;
        let f = self.hz_field(c, t, &self.hz_y(sw, x));
        [f[0], f[1], f[0] + sw * f[2], f[1] + sw * f[3]]
    }

    /// `A = ∂f/∂y` of [`Lumped::hz_field`] and `b = ∂f/∂δ̇₀` (the law's reference speed).
    /// With `P = K_h δ^{3/2}(1 + D δ̇/δ̇₀)`: `P_δ = (3/2) K_h δ^{1/2}(1 + D δ̇/δ̇₀)`,
    /// `P_δ̇ = K_h δ^{3/2} D/δ̇₀`, `P_δ̇₀ = −K_h δ^{3/2} D δ̇/δ̇₀²` (all 0 at `δ ≤ 0`).
    fn hz_jac(&self, c: &CompliantContact, y: &[f64; 4]) -> (Mat4, [f64; 4]) {
        if c.stuck {
            let mt = self.m + self.md;
            return (
                [
                    [0.0, 1.0, 0.0, 0.0],
                    [-self.k / mt, -self.c / mt, 0.0, 0.0],
                    [0.0, 0.0, 0.0, 0.0],
                    [0.0, 0.0, 0.0, 0.0],
                ],
                [0.0; 4],
            );
        }
        let sw = c.wall_sign;
        let d = y[2].max(0.0);
        let sq = d.sqrt();
        let kh = c.law.stiffness_n_m32;
        let v0 = c.reference_speed_m_s;
        let damp = c.law.damping;
        let fac = 1.0 + damp * y[3] / v0;
        let p_d = 1.5 * kh * sq * fac;
        let p_dd = kh * d * sq * damp / v0;
        let p_v0 = -kh * d * sq * damp * y[3] / (v0 * v0);
        let (m, md) = (self.m, self.md);
        let inv = 1.0 / m + 1.0 / md;
        (
            [
                [0.0, 1.0, 0.0, 0.0],
                [-self.k / m, -self.c / m, sw * p_d / m, sw * p_dd / m],
                [0.0, 0.0, 0.0, 1.0],
                [sw * self.k / m, sw * self.c / m, -p_d * inv, -p_dd * inv],
            ],
            [0.0, sw * p_v0 / m, 0.0, -p_v0 * inv],
        )
    }
}

/// Relative tolerance of the tangent integration along a compliant contact phase (that of the
/// phase itself, [`crate::analysis::contact_test::CONTACT_RTOL`]).
pub const HERTZ_TANGENT_RTOL: f64 = crate::analysis::contact_test::CONTACT_RTOL;

/// Most tangent-integrator steps (accepted or rejected) per step of a contact phase: the
/// tangent shares the phase's smoothness, so it takes one to a few; the bound only stops a
/// runaway.
pub const HERTZ_TANGENT_MAX_SUBSTEPS: u32 = 10_000;

/// A compliant contact phase in progress: its tangent map from the public state at the touch.
#[derive(Debug, Clone, Copy)]
struct HzPhase {
    t0: f64,
    t_last: f64,
    sw: f64,
    /// `∂y/∂x(touch)` (contact coordinates from public ones) and `∂y/∂δ̇₀`, as one 4×5 block
    /// row-major (`z[5i + j]`, `j = 4` the `δ̇₀` column).
    z: [f64; 20],
    /// `∂δ̇₀/∂x(touch)`.
    c: [f64; 4],
    /// The constants of the last step seen (a change marks a friction event).
    last: CompliantContact,
    /// Tangent step size to try next.
    h: f64,
    /// `Mode::Contact(wall)`.
    mode: Mode,
    /// A stick happened in this phase (a direction is removed for good).
    stuck_seen: bool,
    /// Row scales `(l_g, v, δ, v)` of the tolerance.
    scale: [f64; 4],
}

/// `S = G + (f⁺ − G f⁻) ∇hᵀ / rate`, `rate = ∇h·f⁻ + ∂h/∂t`. Returns `None` when the rate
/// vanishes (grazing).
fn saltation(
    g: &Mat4,
    f_minus: &[f64; 4],
    f_plus: &[f64; 4],
    grad_h: &[f64; 4],
    rate: f64,
) -> Option<Mat4> {
    if rate == 0.0 || !rate.is_finite() {
        return None;
    }
    let mut gf = [0.0; 4];
    for i in 0..4 {
        gf[i] = (0..4).map(|j| g[i][j] * f_minus[j]).sum();
    }
    let mut s = *g;
    for i in 0..4 {
        let d = (f_plus[i] - gf[i]) / rate;
        for j in 0..4 {
            s[i][j] += d * grad_h[j];
        }
    }
    Some(s)
}

/// The variational layer: an [`Observer`] that hands the tangent map of each segment and event
/// of a lumped exact run to a [`TangentSink`].
pub struct Variational<T: TangentSink> {
    sys: Lumped,
    /// The tangent maps go here.
    pub sink: T,
    /// Events seen.
    pub counts: EventCounts,
    cur: Option<Phase>,
    pending: Option<Pending>,
    /// The parameter whose derivative column `∂x/∂p` is carried (none by default).
    param: Option<Param>,
    /// `∂x/∂p` on `(u, u̇, v, v̇)` at the current time (zero at the start).
    dxdp: [f64; 4],
    /// The compliant contact phase in progress (`hertz` law).
    hz: Option<HzPhase>,
    /// The phase a run ended in, when it ended inside a compliant contact (for the end field).
    open_contact: Option<CompliantContact>,
    /// What stopped the tangent integration of a compliant phase (an observer cannot return an
    /// error; [`flow_with_jacobian`] and the spectrum report it after the run).
    pub failure: Option<SimError>,
    /// `Σ ln|det(W + ζcᵀ)/det W|` over the compliant phases closed so far: the phase-volume
    /// change of the law's memory of the approach speed (module docs, "Hertz contact phases").
    pub approach_memory_log: f64,
}

/// A parameter whose derivative `∂x(t_end)/∂p` the layer can carry (see "Parameter
/// derivatives" in the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Param {
    /// The coefficient of restitution `e`.
    Restitution,
    /// The sliding friction level `F` in newtons.
    FrictionForceN,
    /// The gap `gap_m = 2 l_g` in metres (the walls are at `|w| = l_g`).
    GapM,
    /// The forcing frequency ratio `Ω/ω₁` (at fixed start and end times: the stroboscopic
    /// map's end time `t₀ + 2πk/Ω` adds `end_field · ∂t_end/∂ratio`).
    FreqRatio,
}

/// `m · d`.
#[inline]
fn mat_vec(m: &Mat4, d: &[f64; 4]) -> [f64; 4] {
    [0, 1, 2, 3].map(|i| m[i][0] * d[0] + m[i][1] * d[1] + m[i][2] * d[2] + m[i][3] * d[3])
}

impl<T: TangentSink> Variational<T> {
    /// The layer for `sys` (lumped bar with a damper, either contact law).
    pub fn new(sys: &System, sink: T) -> Result<Self, SimError> {
        sys.validate()?;
        let bar = sys
            .lumped_bar()
            .ok_or(SimError::Unsupported(VARIATIONAL_LUMPED_ONLY))?;
        let d = sys
            .damper
            .ok_or(SimError::Unsupported(VARIATIONAL_NEEDS_BALL))?;
        let hertz = (d.contact.law == ContactLaw::Hertz).then(|| Hertz::of_damper(&d));
        Ok(Variational {
            sys: Lumped {
                m: bar.mass_kg,
                md: d.ball_mass_kg,
                k: bar.stiffness_n_per_m,
                c: bar.damping_n_s_per_m(),
                e: d.restitution,
                fl: sys.friction_level_n(),
                model: d.friction,
                fs: sys.forcing.static_force_n,
                f0: sys.forcing.amplitude_n,
                om: sys.omega_rad_s(),
                om1: sys.omega1_rad_s(),
                hertz,
                lg: d.half_gap_m(),
            },
            sink,
            counts: EventCounts::default(),
            cur: None,
            pending: None,
            param: None,
            dxdp: [0.0; 4],
            hz: None,
            open_contact: None,
            failure: None,
            approach_memory_log: 0.0,
        })
    }

    /// Also carry the column `∂x/∂p` of parameter `p` (from zero at the start). Restitution
    /// law only: under the `hertz` law the column is not built ([`flow_with_param_derivative`]
    /// refuses it).
    pub fn with_param(mut self, p: Param) -> Self {
        self.param = Some(p);
        self
    }

    /// `∂x/∂p` so far (zero when no parameter is carried).
    pub fn dx_dp(&self) -> [f64; 4] {
        self.dxdp
    }

    /// The inhomogeneous part of `∂x/∂p` over a segment of `mode` and length `τ`, from zero:
    /// `∫₀^τ Φ(τ − s) ∂f/∂p ds`. Only the friction level enters a vector field (the ball's
    /// sliding force `b F`, `b = ∂F_ball/∂F`, constant over a free flight).
    fn segment_param_term(&self, mode: Mode, sigma: f64, t0: f64, t1: f64) -> [f64; 4] {
        let s = &self.sys;
        let tau = t1 - t0;
        match (self.param, mode) {
            (Some(Param::FreqRatio), Mode::Free | Mode::NoBall) => {
                let r = s.secular_response(s.m, t0, t1);
                [r[0] * s.om1, r[1] * s.om1, 0.0, 0.0]
            }
            (Some(Param::FreqRatio), Mode::Stick | Mode::Contact(_)) => {
                // The pair moves as one body; the ball follows at fixed w.
                let r = s.secular_response(s.m + s.md, t0, t1);
                let (a, b) = (r[0] * s.om1, r[1] * s.om1);
                [a, b, a, b]
            }
            (Some(Param::FrictionForceN), Mode::Free) => {
                let b = sliding_friction_on_ball_n(s.model, 1.0, sigma);
                // Bar: M ü + C u̇ + K u = −b, from rest: (I − Φ(τ)) (−b/K, 0).
                let p = s.bar_phi(s.m, tau);
                let up = -b / s.k;
                // Ball: v̈ = b/m_d.
                let a = b / s.md;
                [
                    (1.0 - p[0][0]) * up,
                    -p[1][0] * up,
                    0.5 * a * tau * tau,
                    a * tau,
                ]
            }
            (Some(Param::GapM), Mode::Contact(wall)) => {
                // On the wall `v = u + s l_g`: the projection keeps `δw = 0`, the offset
                // `∂w/∂gap = s/2` (`l_g = gap/2`) is restored here.
                [0.0, 0.0, 0.5 * wall.sign(), 0.0]
            }
            _ => [0.0; 4],
        }
    }

    /// Apply what is still pending (an event at the very end of the run). Call once after the
    /// run; [`flow_with_jacobian`] does.
    pub fn finish(&mut self) {
        self.open_contact = None;
        if let Some(p) = self.pending.take() {
            let after = Phase::default_after(&p.ev, self.cur);
            self.resolve(p, after, false);
        }
        if let Some(ph) = self.hz {
            self.open_contact = self.hz_close(ph.t_last);
        }
    }

    /// Start, continue or (at a friction event) switch the compliant phase with step `seg`
    /// (constants `info`), then carry its tangent over the step.
    fn hz_segment(&mut self, seg: &dyn Segment, info: &CompliantContact) {
        let sys = self.sys;
        let (t0, t1) = (seg.t_start_s(), seg.t_end_s());
        let x0 = seg.state_at(t0);
        let sw = info.wall_sign;
        // At `δ = 0` the contact force vanishes: the phase's field is free flight with the
        // phase's friction force.
        let free_like = Phase {
            mode: Mode::Free,
            sigma: sys.sigma_of_fb(info.ball_friction_n),
        };
        if let Some(p) = self.pending.take() {
            self.resolve(p, free_like, false);
        }
        if self.hz.is_some_and(|ph| ph.mode != seg.mode()) {
            self.hz_close(t0);
        }
        let mut ph = match self.hz {
            Some(ph) => ph,
            None => {
                self.counts.compliant_contacts += 1;
                let before = self
                    .cur
                    .filter(|p| p.mode == Mode::Free)
                    .unwrap_or(free_like);
                // δ̇₀ = sw·ẇ(t*) at the perturbed touch time t* + δt*, δt* = −δw/ẇ:
                // δδ̇₀ = sw (δẇ − ẅ⁻ δw/ẇ⁻), δw = δv − δu. Zero when the floor holds δ̇₀.
                let dw = x0.dw_m_s();
                let mut c = [0.0; 4];
                if dw == 0.0 {
                    // A touch at rest: not differentiable (a perturbation lifts the ball off).
                    self.counts.grazing += 1;
                } else if info.approach_m_s >= info.reference_speed_m_s {
                    let f = sys.field(before, &x0, t0);
                    let r = (f[3] - f[1]) / dw;
                    c = [sw * r, -sw, -sw * r, sw];
                }
                let meff = sys.m * sys.md / (sys.m + sys.md);
                let v0 = info.reference_speed_m_s;
                let vs = v0.max(sys.lg * sys.om);
                let ds = info.law.with_damping(0.0).max_penetration_m(meff, v0);
                let mut z = [0.0; 20];
                // W = T: (u, u̇, v, v̇) → (u, u̇, δ, δ̇); the onset's saltation is I.
                z[0] = 1.0;
                z[6] = 1.0;
                z[10] = -sw;
                z[12] = sw;
                z[16] = -sw;
                z[18] = sw;
                HzPhase {
                    t0,
                    t_last: t0,
                    sw,
                    mode: seg.mode(),
                    z,
                    c,
                    last: *info,
                    h: t1 - t0,
                    stuck_seen: false,
                    scale: [sys.lg, vs, ds, vs],
                }
            }
        };
        // The same step constants are the same bits: a change is a friction event.
        if info.stuck != ph.last.stuck
            || info.ball_friction_n.to_bits() != ph.last.ball_friction_n.to_bits()
        {
            self.hz_friction_event(&mut ph, info, t0, &x0);
        }
        ph.last = *info;
        if t1 > t0 {
            if let Err(e) = Self::hz_advance(&sys, &mut ph, seg, info, t0, t1) {
                self.failure.get_or_insert(e);
            }
        }
        ph.t_last = t1;
        self.hz = Some(ph);
        self.cur = Some(Phase {
            mode: seg.mode(),
            sigma: free_like.sigma,
        });
    }

    /// The saltation of a friction event inside a compliant phase (the step constants change
    /// from `ph.last` to `info` at `t`): `S = I + (f⁺ − f⁻) ∇hᵀ / (∇h·f⁻ + ∂h/∂t)` in contact
    /// coordinates, on the whole block (`∂h/∂δ̇₀ = 0`: the `δ̇₀` column just follows).
    fn hz_friction_event(&mut self, ph: &mut HzPhase, info: &CompliantContact, t: f64, x: &State) {
        let sys = self.sys;
        let y = sys.hz_y(ph.sw, x);
        let fm = sys.hz_field(&ph.last, t, &y);
        let fp = sys.hz_field(info, t, &y);
        let (grad, rate) = if ph.last.stuck {
            // Unstick: h = f_l ∓ needed, needed = m_d ü_pair + sw K_h δ^{3/2} (hertz.rs).
            self.counts.unsticks += 1;
            let r = sys.md / (sys.m + sys.md);
            let kh = ph.last.law.stiffness_n_m32;
            let g = [
                -sys.k * r,
                -sys.c * r,
                ph.sw * 1.5 * kh * y[2].max(0.0).sqrt(),
                0.0,
            ];
            let rate = (0..4).map(|i| g[i] * fm[i]).sum::<f64>() + r * sys.dforce_dt(t);
            (g, rate)
        } else {
            // ẇ = 0: h = δ̇.
            if info.stuck {
                self.counts.sticks += 1;
                ph.stuck_seen = true;
            } else {
                self.counts.friction_switches += 1;
            }
            ([0.0, 0.0, 0.0, 1.0], fm[3])
        };
        if rate == 0.0 || !rate.is_finite() {
            self.counts.grazing += 1;
            return;
        }
        for j in 0..5 {
            let gz: f64 = (0..4).map(|k| grad[k] * ph.z[5 * k + j]).sum();
            for i in 0..4 {
                ph.z[5 * i + j] += (fp[i] - fm[i]) * gz / rate;
            }
        }
    }

    /// Integrate the phase's variational equation `Z' = A(t) Z + [0 | b(t)]` over `[a, b]`
    /// along the step's dense output (module docs): adaptive Dormand–Prince 5(4) with relative
    /// tolerance [`HERTZ_TANGENT_RTOL`] on every entry.
    fn hz_advance(
        sys: &Lumped,
        ph: &mut HzPhase,
        seg: &dyn Segment,
        info: &CompliantContact,
        a: f64,
        b: f64,
    ) -> Result<(), SimError> {
        let sw = ph.sw;
        // Entry (i, j) maps a perturbation of size `col_j` to one of size `scale_i`.
        let col = [
            ph.scale[0],
            ph.scale[1],
            ph.scale[0],
            ph.scale[1],
            ph.scale[1],
        ];
        let mut atol = [0.0; 20];
        for i in 0..4 {
            for j in 0..5 {
                atol[5 * i + j] = HERTZ_TANGENT_RTOL * ph.scale[i] / col[j];
            }
        }
        let ig = Dopri5::<20>::new(HERTZ_TANGENT_RTOL, atol);
        let mut f = |t: f64, z: &[f64; 20]| {
            let y = sys.hz_y(sw, &seg.state_at(t));
            let (am, bv) = sys.hz_jac(info, &y);
            let mut dz = [0.0; 20];
            for i in 0..4 {
                for j in 0..5 {
                    let mut acc = if j == 4 { bv[i] } else { 0.0 };
                    for k in 0..4 {
                        acc += am[i][k] * z[5 * k + j];
                    }
                    dz[5 * i + j] = acc;
                }
            }
            dz
        };
        let (mut t, mut h) = (a, ph.h.min(b - a));
        let mut z = ph.z;
        let mut f0 = f(t, &z);
        let mut tries = 0u32;
        loop {
            tries += 1;
            if tries > HERTZ_TANGENT_MAX_SUBSTEPS {
                return Err(SimError::ContactStepLimit {
                    t_s: a,
                    steps: HERTZ_TANGENT_MAX_SUBSTEPS as u64,
                });
            }
            let last = t + h >= b;
            let hh = if last { b - t } else { h };
            let at = ig.attempt(&mut f, t, &z, &f0, hh);
            if at.err > 1.0 {
                h = Dopri5::<20>::next_h(hh, at.err);
                if h <= 4.0 * f64::EPSILON * t.abs().max(1e-300) || !h.is_finite() {
                    return Err(SimError::NonFinite { t_s: t });
                }
                continue;
            }
            z = at.step.y1;
            f0 = at.f1;
            h = Dopri5::<20>::next_h(hh, at.err);
            if last {
                break;
            }
            t += hh;
        }
        ph.z = z;
        ph.h = h;
        Ok(())
    }

    /// Close the compliant phase at `t_end`: hand its tangent map
    /// `T⁻¹ (W + ζ cᵀ)` (public coordinates at the touch → public at `t_end`) to the sink.
    /// Returns the last step's constants.
    fn hz_close(&mut self, t_end: f64) -> Option<CompliantContact> {
        let ph = self.hz.take()?;
        let mut w = [[0.0; 4]; 4];
        let mut wm = [[0.0; 4]; 4];
        for i in 0..4 {
            for j in 0..4 {
                w[i][j] = ph.z[5 * i + j];
                wm[i][j] = w[i][j] + ph.z[5 * i + 4] * ph.c[j];
            }
        }
        let (dw, dm) = (det4(&w), det4(&wm));
        if dw != 0.0 && dm != 0.0 && (dm / dw).is_finite() {
            self.approach_memory_log += (dm / dw).abs().ln();
        }
        let sw = ph.sw;
        let t_inv = [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [1.0, 0.0, sw, 0.0],
            [0.0, 1.0, 0.0, sw],
        ];
        self.sink.apply(
            &mat_mul(&t_inv, &wm),
            Step::Segment {
                t0_s: ph.t0,
                t1_s: t_end,
                mode: ph.mode,
            },
        );
        if ph.stuck_seen {
            // The stick's saltation is inside the map above; this marks the direction it
            // removed (the spectrum's structural count).
            self.sink.apply(
                &IDENTITY,
                Step::Event {
                    t_s: t_end,
                    kind: EventKind::Stick,
                    plastic: false,
                },
            );
        }
        Some(ph.last)
    }

    /// Build and apply the saltation of `p` with the phase `after` that follows it.
    fn resolve(&mut self, p: Pending, after: Phase, followed_by_contact: bool) {
        if p.release {
            // The end of a compliant phase (`δ = 0`, `P = 0`): h = w − sw·l_g, G = I; the
            // fields on both sides are free flight, with the friction of each side.
            self.counts.impacts += 1;
            let ev = &p.ev;
            let fm = self.sys.field(p.before, &ev.before, ev.t_s);
            let fp = self.sys.field(after, &ev.after, ev.t_s);
            let salt = saltation(
                &IDENTITY,
                &fm,
                &fp,
                &[-1.0, 0.0, 1.0, 0.0],
                ev.before.dw_m_s(),
            );
            let m = salt.unwrap_or_else(|| {
                self.counts.grazing += 1;
                IDENTITY
            });
            self.sink.apply(
                &m,
                Step::Event {
                    t_s: ev.t_s,
                    kind: ev.kind,
                    plastic: false,
                },
            );
            self.cur = Some(after);
            return;
        }
        let s = &self.sys;
        let ev = &p.ev;
        let t = ev.t_s;
        let x = &ev.before;
        let f_minus = s.field(p.before, x, t);
        let mut plastic = false;
        let (g, grad, rate, x_plus) = match ev.kind {
            EventKind::Impact { .. } => {
                plastic = followed_by_contact && s.e > 0.0;
                let g = if plastic { s.plastic_g() } else { s.impact_g() };
                if plastic {
                    self.counts.plastic_impacts += 1;
                } else {
                    self.counts.impacts += 1;
                }
                let mut xp = ev.after;
                if plastic {
                    let v = (1.0 - s.mu_ratio()) * x.du_m_s + s.mu_ratio() * x.dv_m_s;
                    xp.du_m_s = v;
                    xp.dv_m_s = v;
                }
                (g, [-1.0, 0.0, 1.0, 0.0], x.dw_m_s(), xp)
            }
            EventKind::FrictionSwitch | EventKind::Stick => {
                if ev.kind == EventKind::Stick {
                    self.counts.sticks += 1;
                } else {
                    self.counts.friction_switches += 1;
                }
                (
                    IDENTITY,
                    [0.0, -1.0, 0.0, 1.0],
                    f_minus[3] - f_minus[1],
                    ev.after,
                )
            }
            EventKind::Unstick | EventKind::ContactRelease { .. } => {
                if ev.kind == EventKind::Unstick {
                    self.counts.unsticks += 1;
                } else {
                    self.counts.releases += 1;
                }
                // h = f_l − q·m_d ü_pair with ü_pair = (F(t) − C u̇ − K u)/(M + m_d); only
                // the direction of ∇h and the rate matter up to a common factor.
                let r = s.md / (s.m + s.md);
                let grad = [-s.k * r, -s.c * r, 0.0, 0.0];
                let rate = grad[0] * f_minus[0] + grad[1] * f_minus[1] + r * s.dforce_dt(t);
                (IDENTITY, grad, rate, ev.after)
            }
            EventKind::ChatterLimit { .. } => {
                self.counts.chatter_limits += 1;
                if matches!(after.mode, Mode::Free) {
                    self.counts.chatter_releases += 1;
                }
                self.cur = Some(after);
                return;
            }
        };
        let f_plus = s.field(after, &x_plus, t);
        let salt = saltation(&g, &f_minus, &f_plus, &grad, rate);
        if let Some(p) = self.param {
            // d⁺ = S d⁻ + ∂g/∂p + (f⁺ − G f⁻) (∂h/∂p) / rate.
            let mut q = [0.0; 4];
            if p == Param::FreqRatio
                && matches!(
                    ev.kind,
                    EventKind::Unstick | EventKind::ContactRelease { .. }
                )
                && salt.is_some()
            {
                // h = r (F(t) − C u̇ − K u) − threshold: ∂h/∂ratio = r F₀ t cos Ωt · ω₁.
                let r = s.md / (s.m + s.md);
                let dh = r * s.f0 * t * (s.om * t).cos() * s.om1;
                let gf = mat_vec(&g, &f_minus);
                for i in 0..4 {
                    q[i] = (f_plus[i] - gf[i]) * dh / rate;
                }
            }
            if let EventKind::Impact { wall, .. } = ev.kind {
                match p {
                    Param::Restitution if !plastic => {
                        let mu = s.md / s.m;
                        let db = mu / (1.0 + mu) * x.dw_m_s();
                        q[1] = db;
                        q[3] = db - x.dw_m_s();
                    }
                    Param::GapM if salt.is_some() => {
                        let gf = mat_vec(&g, &f_minus);
                        // h = w − s l_g with l_g = gap/2.
                        let dh = -0.5 * wall.sign();
                        for i in 0..4 {
                            q[i] = (f_plus[i] - gf[i]) * dh / rate;
                        }
                    }
                    _ => {}
                }
            }
            // Unstick and release: `h` holds the friction level only for Coulomb, where
            // `f⁺ = f⁻` at the threshold, so the term vanishes; no other event's `h` or `g`
            // depends on these parameters.
            let d = mat_vec(salt.as_ref().unwrap_or(&g), &self.dxdp);
            self.dxdp = [0, 1, 2, 3].map(|i| d[i] + q[i]);
        }
        let m = match salt {
            Some(m) => m,
            None => {
                self.counts.grazing += 1;
                g
            }
        };
        self.sink.apply(
            &m,
            Step::Event {
                t_s: t,
                kind: ev.kind,
                plastic,
            },
        );
        self.cur = Some(after);
    }
}

impl<T: TangentSink> Observer for Variational<T> {
    fn segment(&mut self, seg: &dyn Segment) {
        if let Some(info) = seg.compliant_contact() {
            self.hz_segment(seg, &info);
            return;
        }
        if self.hz.is_some() {
            // A phase ends with the solver's release event; close it if it did not.
            self.hz_close(seg.t_start_s());
        }
        let (t0, t1) = (seg.t_start_s(), seg.t_end_s());
        let mode = seg.mode();
        // The friction sign matters only with a friction force.
        let frictional = self.sys.model != FrictionModel::None && self.sys.fl > 0.0;
        let sigma = if mode == Mode::Free && frictional {
            crate::damper::friction::sgn0(seg.state_at(0.5 * (t0 + t1)).dw_m_s())
        } else {
            0.0
        };
        let phase = Phase { mode, sigma };
        if let Some(p) = self.pending.take() {
            let contact = matches!(mode, Mode::Contact(_));
            self.resolve(p, phase, contact);
        }
        self.cur = Some(phase);
        let m = self.sys.segment_stm(mode, t1 - t0);
        if self.param.is_some() {
            // The friction sign even at a zero level (the derivative there is not zero).
            let sig = if mode == Mode::Free && self.sys.model != FrictionModel::None {
                crate::damper::friction::sgn0(seg.state_at(0.5 * (t0 + t1)).dw_m_s())
            } else {
                0.0
            };
            let q = self.segment_param_term(mode, sig, t0, t1);
            let d = mat_vec(&m, &self.dxdp);
            self.dxdp = [0, 1, 2, 3].map(|i| d[i] + q[i]);
        }
        self.sink.apply(
            &m,
            Step::Segment {
                t0_s: t0,
                t1_s: t1,
                mode,
            },
        );
    }

    fn event(&mut self, ev: &Event) {
        if self.hz.is_some() {
            let last = self.hz_close(ev.t_s);
            if let (EventKind::Impact { .. }, Some(c)) = (ev.kind, last) {
                // The release (the solver reports the end of contact as the impact).
                let before = Phase {
                    mode: Mode::Free,
                    sigma: self.sys.sigma_of_fb(c.ball_friction_n),
                };
                self.cur = Some(before);
                self.pending = Some(Pending {
                    ev: *ev,
                    before,
                    release: true,
                });
                return;
            }
        }
        if let Some(p) = self.pending.take() {
            // Two events at one instant (no segment between): the second's kind says what
            // phase the first led to.
            let next_before = Phase::before(ev, self.cur);
            let contact = matches!(next_before.mode, Mode::Contact(_));
            self.resolve(p, next_before, contact);
        }
        let before = match self.cur {
            Some(c) => c,
            None => Phase::before(ev, None),
        };
        self.pending = Some(Pending {
            ev: *ev,
            before,
            release: false,
        });
    }
}

/// The end state of a run, its Jacobian and the events it went through.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlowJacobian {
    /// The state at `t_end_s`.
    pub state: State,
    /// `∂x(t_end)/∂x(t₀)` on `x = (u, u̇, v, v̇)`, at fixed start and end times.
    pub jacobian: Mat4,
    /// The vector field at the end, `∂x(t_end)/∂t_end` (for a phase condition or a period
    /// derivative).
    pub end_field: [f64; 4],
    /// The events the tangent map went through.
    pub events: EventCounts,
    /// The solver's summary.
    pub summary: RunSummary,
}

/// Run the exact solver `solver` (any other is refused) on `sys` from `init` to `t_end_s` and return the end state with
/// the Jacobian of the flow map (the stroboscopic map over `k` forcing periods is
/// `t_end_s = init.t_s + k·T`). `extra` sees the run too (`&mut ()` for nothing).
pub fn flow_with_jacobian(
    solver: &dyn Solver,
    sys: &System,
    init: &State,
    t_end_s: f64,
    extra: &mut dyn Observer,
) -> Result<FlowJacobian, SimError> {
    flow_tangent(solver, sys, init, t_end_s, None, extra).map(|(f, _)| f)
}

/// [`flow_with_jacobian`] plus `∂x(t_end)/∂p` at fixed start state and times, on
/// `(u, u̇, v, v̇)`.
pub fn flow_with_param_derivative(
    solver: &dyn Solver,
    sys: &System,
    init: &State,
    t_end_s: f64,
    param: Param,
    extra: &mut dyn Observer,
) -> Result<(FlowJacobian, [f64; 4]), SimError> {
    flow_tangent(solver, sys, init, t_end_s, Some(param), extra)
}

fn flow_tangent(
    solver: &dyn Solver,
    sys: &System,
    init: &State,
    t_end_s: f64,
    param: Option<Param>,
    extra: &mut dyn Observer,
) -> Result<(FlowJacobian, [f64; 4]), SimError> {
    require_exact(solver)?;
    let mut var = Variational::new(sys, JacobianSink::default())?;
    if param.is_some() && var.sys.hertz.is_some() {
        return Err(SimError::Unsupported(VARIATIONAL_NO_HERTZ_PARAM));
    }
    var.param = param;
    let summary = {
        let v: &mut dyn Observer = &mut var;
        solver.run(
            sys,
            init,
            t_end_s,
            &mut crate::solver::Fanout(&mut [v, extra]),
        )?
    };
    var.finish();
    if let Some(e) = var.failure.take() {
        return Err(e);
    }
    let jacobian = var.sink.jacobian;
    let end_phase = var.cur.unwrap_or(Phase {
        mode: Mode::Free,
        sigma: crate::damper::friction::sgn0(summary.final_state.dw_m_s()),
    });
    let end_field = match var.open_contact {
        Some(c) => var.sys.hz_field_public(&c, t_end_s, &summary.final_state),
        None => var.sys.field(end_phase, &summary.final_state, t_end_s),
    };
    Ok((
        FlowJacobian {
            state: summary.final_state,
            jacobian,
            end_field,
            events: var.counts,
            summary,
        },
        var.dxdp,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn determinant_of_products_and_blocks() {
        let a: Mat4 = [
            [2.0, 1.0, 0.0, 3.0],
            [0.5, -1.0, 2.0, 0.0],
            [1.0, 0.0, 1.0, 1.0],
            [0.0, 2.0, -1.0, 4.0],
        ];
        let b: Mat4 = [
            [1.0, 0.0, 2.0, 0.0],
            [0.0, 3.0, 0.0, 1.0],
            [1.0, 1.0, 1.0, 0.0],
            [0.0, 0.0, 0.5, 2.0],
        ];
        let (da, db) = (det4(&a), det4(&b));
        assert!((det4(&mat_mul(&a, &b)) - da * db).abs() < 1e-12 * (da * db).abs());
        assert!((det4(&IDENTITY) - 1.0).abs() < 1e-15);
    }
}
