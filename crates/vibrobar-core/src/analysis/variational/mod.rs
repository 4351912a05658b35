//! Variational equations of the exact flow: the Jacobian `∂x(t₁)/∂x(t₀)` of the solver's flow
//! map, with saltation matrices at every event, written once for every bar.
//!
//! # Where things are
//!
//! * this file: the one layer ([`Variational`]: what happens at each event, the compliant
//!   contact phase, the end field), the bar trait it is written over ([`TangentBar`]), the
//!   sinks of the lumped bar's maps ([`TangentSink`], [`JacobianSink`]) and the derivations;
//! * [`lumped`]: the lumped bar's arithmetic (4×4 maps on `x = (u, u̇, v, v̇)` of
//!   [`State`](crate::params::State), the parameter column) and its flows
//!   ([`flow_with_jacobian`], [`flow_with_param_derivative`]);
//! * [`modal`]: the N-mode bar's arithmetic (`2N + 2` tangent columns on `(q, q̇, v, v̇)`,
//!   carried in place) and its flow ([`modal::modal_flow_with_jacobian`]).
//!
//! The Lyapunov spectrum ([`super::lyapunov_spectrum`]) and the periodic orbits and their
//! continuation ([`super::orbit`]) are built on these flows, once for both bars.
//!
//! # Built on the observer stream
//!
//! [`Variational`] is an [`Observer`]: it never re-runs or copies the solver. A run reports
//! smooth [`Segment`]s and [`Event`]s; the tangent map of the run is the product, in time order,
//! of one state transition matrix per segment and one saltation matrix per event. The solver's
//! results are untouched (the layer only reads what it is shown), and nothing is allocated per
//! segment or event.
//!
//! # One layer, one bar trait
//!
//! What happens at each event (which `h`, `G`, `f⁻`, `f⁺` and crossing rate, the counts, the
//! grazing and chatter-release cases, the phase that follows), the compliant contact phase
//! (onset, the approach-speed memory, friction events inside it, release) and the end field
//! are the layer's ([`Variational`], written once). A bar ([`TangentBar`]) gives its
//! arithmetic on its public coordinates: vector fields, resets, the contact row, the
//! transition map of a segment and where the maps go. The derivations below are the lumped
//! bar's; [`modal`] gives the N-mode bar's ingredients.
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
//! * the ball in free flight: `[[1, τ], [0, 1]]` (its acceleration `F_ball/m_d + g_s` is
//!   constant; `g_s` is a body force along the gap, gravity along the hole, which enters the
//!   vector fields at events and the pair's load `m_d g_s` in stick and wall contact, never a
//!   transition matrix or the gradient of a release threshold);
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
//! * Parameter columns on the N-mode bar (its orbit layer takes central differences of the
//!   map), and parameter derivatives other than [`Param`]'s (mass ratio, forcing amplitude).
//!
//! References: P. C. Müller, "Calculation of Lyapunov exponents for dynamic systems with
//! discontinuities", Chaos, Solitons & Fractals 5 (1995) 1671–1681; R. I. Leine and
//! H. Nijmeijer, *Dynamics and Bifurcations of Non-Smooth Mechanical Systems*, Springer 2004.

use crate::damper::contact::Hertz;
use crate::error::SimError;
use crate::params::{ContactLaw, Damper, Forcing, FrictionModel};
use crate::solver::dopri5::Dopri5;
use crate::solver::{CompliantContact, Event, EventKind, Mode, Observer, Segment, Solver};

pub mod lumped;
pub mod modal;

pub use lumped::{
    flow_with_jacobian, flow_with_param_derivative, FlowJacobian, LumpedBar,
    VARIATIONAL_LUMPED_ONLY, VARIATIONAL_NO_HERTZ_PARAM,
};

/// A 4×4 matrix, row-major, on `(u, u̇, v, v̇)`.
pub type Mat4 = [[f64; 4]; 4];

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
pub struct Phase {
    /// The mode.
    pub mode: Mode,
    /// The friction sign `σ` of a free flight (0 otherwise).
    pub sigma: f64,
}

impl Phase {
    /// The phase after event `ev` when no segment follows to say it; `cur` is the phase the
    /// event ended.
    pub(crate) fn default_after(ev: &Event, cur: Option<Phase>) -> Phase {
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
    pub(crate) fn before(ev: &Event, last: Option<Phase>) -> Phase {
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

/// A parameter whose derivative `∂x(t_end)/∂p` the layer can carry (see "Parameter
/// derivatives" in the module docs; the lumped bar's).
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

/// Relative tolerance of the tangent integration along a compliant contact phase (that of the
/// phase itself, [`crate::analysis::contact_test::CONTACT_RTOL`]).
pub const HERTZ_TANGENT_RTOL: f64 = crate::analysis::contact_test::CONTACT_RTOL;

/// Most tangent-integrator steps (accepted or rejected) per step of a contact phase: the
/// tangent shares the phase's smoothness, so it takes one to a few; the bound only stops a
/// runaway.
pub const HERTZ_TANGENT_MAX_SUBSTEPS: u32 = 10_000;

/// What the layer reads of the ball, the cavity, the contact and friction laws and the
/// forcing: the same for every bar.
#[derive(Debug, Clone, Copy)]
pub struct Laws {
    /// `m_d`.
    pub md: f64,
    /// `e`.
    pub e: f64,
    /// The friction level `F` and the friction law.
    pub fl: f64,
    /// The friction law.
    pub model: FrictionModel,
    /// `F(t) = F_s + F₀ sin Ωt`: `F_s`.
    pub fs: f64,
    /// `F₀`.
    pub f0: f64,
    /// `Ω`.
    pub om: f64,
    /// `∂Ω/∂ratio = ω₁`.
    pub om1: f64,
    /// The compliant law, `None` under the restitution law.
    pub hertz: Option<Hertz>,
    /// Half gap `l_g`.
    pub lg: f64,
    /// `g_s`: the ball's acceleration from a constant body force along the gap
    /// (`damper.gravity_along_gap_m_s2`, gravity along the hole).
    pub gs: f64,
}

impl Laws {
    /// The laws of damper `d` with friction level `fl`, forcing `f` at `Ω = om`, `ω₁ = om1`.
    pub fn new(d: &Damper, fl: f64, f: &Forcing, om: f64, om1: f64) -> Laws {
        Laws {
            md: d.ball_mass_kg,
            e: d.restitution,
            fl,
            model: d.friction,
            fs: f.static_force_n,
            f0: f.amplitude_n,
            om,
            om1,
            hertz: (d.contact.law == ContactLaw::Hertz).then(|| Hertz::of_damper(d)),
            lg: d.half_gap_m(),
            gs: d.gravity_along_gap_m_s2,
        }
    }
    /// `F(t)`.
    pub fn force(&self, t: f64) -> f64 {
        self.fs + self.f0 * (self.om * t).sin()
    }
    /// `Ḟ(t)`.
    pub fn dforce_dt(&self, t: f64) -> f64 {
        self.f0 * self.om * (self.om * t).cos()
    }
    /// Friction force on the ball in a free flight with sign `σ`.
    pub fn fb(&self, sigma: f64) -> f64 {
        crate::damper::friction::sliding_friction_on_ball_n(self.model, self.fl, sigma)
    }
    /// The free-flight friction sign `σ` whose sliding force is `fb` (`F_b = s F sgn σ`).
    pub fn sigma_of_fb(&self, fb: f64) -> f64 {
        crate::damper::friction::sign_factor(self.model) * crate::damper::friction::sgn0(fb)
    }
    /// Friction is on and has a level.
    pub fn frictional(&self) -> bool {
        self.model != FrictionModel::None && self.fl > 0.0
    }
}

/// What happened at an event, for the bar's map ([`TangentBar::event_map`]): the saltation
/// `S = G + (f⁺ − G f⁻) ∇hᵀ / rate` and what a parameter column needs.
#[derive(Debug, Clone, Copy)]
pub struct EventMap<X, G> {
    /// The event.
    pub kind: EventKind,
    /// Its time.
    pub t_s: f64,
    /// The reset's Jacobian `G`.
    pub g: G,
    /// The field before.
    pub f_minus: X,
    /// The field after.
    pub f_plus: X,
    /// `∇h`.
    pub grad_h: X,
    /// `∇h·f⁻ + ∂h/∂t`.
    pub rate: f64,
    /// The rate is finite and not 0 (else grazing: only `G` applies).
    pub ok: bool,
    /// The state before.
    pub x: X,
    /// An impact taken to its plastic limit.
    pub plastic: bool,
    /// The end of a compliant contact phase.
    pub release: bool,
}

/// A compliant contact phase in progress (module docs, "Hertz contact phases"); its tangent
/// block `Z = [W | ζ]` is the bar's ([`TangentBar::hz_col`]).
#[derive(Debug, Clone, Copy)]
pub struct ContactPhase<X> {
    /// The touch.
    pub t0: f64,
    /// The end of the last step seen.
    pub t_last: f64,
    /// The wall, `±1`.
    pub sw: f64,
    /// `∂δ̇₀/∂x(touch)`.
    pub c: X,
    /// The constants of the last step seen (a change marks a friction event).
    pub last: CompliantContact,
    /// `Mode::Contact(wall)`.
    pub mode: Mode,
    /// A stick happened in this phase (a direction is removed for good).
    pub stuck_seen: bool,
    /// Scales `(l_g, v, δ_max, v)` of the tolerance.
    pub scale: [f64; 4],
}

impl<X> ContactPhase<X> {
    /// The scale of row `i` of `Z` (contact coordinates `(q, q̇, δ, δ̇)`) on a bar of `n`
    /// modes: `l_g`, the speed scale, `δ_max`, the speed scale.
    pub fn row_scale(&self, n: usize, i: usize) -> f64 {
        if i < n {
            self.scale[0]
        } else if i < 2 * n {
            self.scale[1]
        } else {
            self.scale[i - 2 * n + 2]
        }
    }

    /// The size of the perturbation column `j` of `Z` maps: positions `l_g`, velocities and
    /// `δ̇₀` (column `2n + 2`) the speed scale.
    pub fn col_scale(&self, n: usize, j: usize) -> f64 {
        if j < n || j == 2 * n {
            self.scale[0]
        } else {
            self.scale[1]
        }
    }
}

/// What the variational layer needs from a bar whose tangent maps go to `S` (module docs):
/// its arithmetic on its public coordinates `x` (the bar's, then the ball's `v`, `v̇`; the
/// contact row `w = v − φ_dᵀq`) and the maps.
pub trait TangentBar<S> {
    /// A vector on the public coordinates.
    type X: Copy + std::ops::Index<usize, Output = f64> + std::ops::IndexMut<usize>;
    /// The Jacobian `G` of an event's reset.
    type G: Copy;
    /// The dimension `D` of `x`.
    fn dim(&self) -> usize;
    /// The zero vector.
    fn zero(&self) -> Self::X;
    /// The ball, cavity, laws and forcing.
    fn laws(&self) -> &Laws;
    /// The contact's effective mass (a scale of a contact phase's tolerance).
    fn contact_mass_kg(&self) -> f64;
    /// `x` just before event `ev`.
    fn event_state(&self, sink: &S, ev: &Event) -> Self::X;
    /// `x` at the start `t0` of segment `seg` (a step of a contact phase).
    fn state_at_start(&self, sink: &S, seg: &dyn Segment, t0: f64) -> Self::X;
    /// The vector field of phase `p` at `x`, `t`.
    fn field(&self, p: Phase, x: &Self::X, t: f64) -> Self::X;
    /// `ẇ` of `x` (of a field: `ẅ`).
    fn dw(&self, x: &Self::X) -> f64;
    /// `∇w`.
    fn grad_w(&self) -> Self::X;
    /// `∇ẇ`.
    fn grad_dw(&self) -> Self::X;
    /// `∇h` and the rate of the unstick and release test with `f⁻` at `t`.
    fn hold_release(&self, t: f64, f_minus: &Self::X) -> (Self::X, f64);
    /// `G = I`.
    fn identity_g(&self) -> Self::G;
    /// `G` of an impact (`plastic`: taken to its plastic limit).
    fn impact_g(&self, plastic: bool) -> Self::G;
    /// `x⁺` after event `ev` with the reset `g` from `x`.
    fn after_reset(&self, g: &Self::G, plastic: bool, ev: &Event, x: &Self::X) -> Self::X;
    /// Hand on the transition map of segment `seg` (`mode`, `[t0, t1]`).
    fn segment_map(&mut self, sink: &mut S, seg: &dyn Segment, mode: Mode, t0: f64, t1: f64);
    /// Hand on the saltation map of an event.
    fn event_map(&mut self, sink: &mut S, e: &EventMap<Self::X, Self::G>);
    /// Hand on the identity as the map of `step` (a marker).
    fn mark(&mut self, sink: &mut S, step: Step);

    /// Contact coordinates `y = (q, q̇, δ, δ̇)` of `x` at wall `sw` (`δ = sw·w − l_g`).
    fn contact_coords(&self, sw: f64, x: &Self::X) -> Self::X;
    /// A tangent (or field) in contact coordinates back to public ones.
    fn public_tangent(&self, sw: f64, z: &Self::X) -> Self::X;
    /// The compliant phase's vector field at `y` (contact coordinates).
    fn hz_field(&self, c: &CompliantContact, t: f64, y: &Self::X) -> Self::X;
    /// `∇h` (contact coordinates) and the rate of the unstick inside a stuck phase.
    fn hz_unstick(
        &self,
        sw: f64,
        c: &CompliantContact,
        t: f64,
        y: &Self::X,
        f_minus: &Self::X,
    ) -> (Self::X, f64);
    /// Column `j` of the phase's block `Z = [W | ζ]` (`j = D`: `ζ`).
    fn hz_col(&self, j: usize) -> Self::X;
    /// Set column `j` of `Z`.
    fn hz_set_col(&mut self, j: usize, z: &Self::X);
    /// A new phase's block: the tangent integrator's first step `h0`.
    fn hz_begin(&mut self, h0: f64);
    /// Carry `Z` over step `seg` of `ph` (constants `ph.last`).
    fn hz_advance(&mut self, ph: &ContactPhase<Self::X>, seg: &dyn Segment)
        -> Result<(), SimError>;
    /// Hand on the phase's map `T⁻¹ (W + ζ cᵀ)` from its touch to `t_end`; returns
    /// `det(W + ζcᵀ)/det W` where it is defined.
    fn phase_map(&mut self, sink: &mut S, ph: &ContactPhase<Self::X>, t_end: f64) -> Option<f64>;
}

/// `P_δ`, `P_δ̇`, `P_δ̇₀` of the law `P = K_h δ^{3/2}(1 + D δ̇/δ̇₀)` at `δ` (0 below), `δ̇`:
/// `(3/2) K_h δ^{1/2}(1 + D δ̇/δ̇₀)`, `K_h δ^{3/2} D/δ̇₀`, `−K_h δ^{3/2} D δ̇/δ̇₀²`.
pub(crate) fn contact_partials(c: &CompliantContact, delta: f64, ddelta: f64) -> (f64, f64, f64) {
    let d = delta.max(0.0);
    let sq = d.sqrt();
    let kh = c.law.stiffness_n_m32;
    let v0 = c.reference_speed_m_s;
    let damp = c.law.damping;
    let fac = 1.0 + damp * ddelta / v0;
    (
        1.5 * kh * sq * fac,
        kh * d * sq * damp / v0,
        -kh * d * sq * damp * ddelta / (v0 * v0),
    )
}

/// Integrate the linear tangent equation `z' = f(t, z)` over `[a, b]` from the step `h`:
/// adaptive Dormand–Prince 5(4) with the error control of `ig`, at most
/// [`HERTZ_TANGENT_MAX_SUBSTEPS`] steps; `h` becomes the step to try next.
// Inlined into each bar's caller so that the integrator's constant length folds into its loops.
#[inline(always)]
pub(crate) fn tangent_advance<const L: usize, F>(
    ig: &Dopri5<L>,
    mut f: F,
    a: f64,
    b: f64,
    z: &mut [f64; L],
    h: &mut f64,
) -> Result<(), SimError>
where
    F: FnMut(f64, &[f64; L]) -> [f64; L],
{
    let (mut t, mut hs) = (a, h.min(b - a));
    let mut f0 = f(t, z);
    let mut tries = 0u32;
    loop {
        tries += 1;
        if tries > HERTZ_TANGENT_MAX_SUBSTEPS {
            return Err(SimError::ContactStepLimit {
                t_s: a,
                steps: HERTZ_TANGENT_MAX_SUBSTEPS as u64,
            });
        }
        let last = t + hs >= b;
        let hh = if last { b - t } else { hs };
        let at = ig.attempt(&mut f, t, z, &f0, hh);
        if at.err > 1.0 {
            hs = Dopri5::<L>::next_h(hh, at.err);
            if hs <= 4.0 * f64::EPSILON * t.abs().max(1e-300) || !hs.is_finite() {
                return Err(SimError::NonFinite { t_s: t });
            }
            continue;
        }
        *z = at.step.y1;
        f0 = at.f1;
        hs = Dopri5::<L>::next_h(hh, at.err);
        if last {
            break;
        }
        t += hh;
    }
    *h = hs;
    Ok(())
}

/// An event waiting for the phase that follows it (its `f⁺`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pending<X> {
    pub(crate) ev: Event,
    pub(crate) before: Phase,
    /// `x` just before it.
    pub(crate) x: X,
    /// The end of a compliant contact phase (the solver's `Impact` at the release).
    pub(crate) release: bool,
}

/// The variational layer: an [`Observer`] that hands the tangent map of each segment and event
/// of an exact run of the bar `B` to `S` (module docs). The lumped bar's is
/// `Variational<T: TangentSink>`; the N-mode bar's [`modal::ModalVariational`].
pub struct Variational<S, B: TangentBar<S> = LumpedBar> {
    pub(crate) bar: B,
    /// Where the tangent maps go.
    pub sink: S,
    /// Events seen.
    pub counts: EventCounts,
    pub(crate) cur: Option<Phase>,
    pub(crate) pending: Option<Pending<B::X>>,
    /// The compliant contact phase in progress (`hertz` law).
    pub(crate) hz: Option<ContactPhase<B::X>>,
    /// The phase a run ended in, when it ended inside a compliant contact (for the end field).
    pub(crate) open_contact: Option<CompliantContact>,
    /// What stopped the tangent integration of a compliant phase (an observer cannot return an
    /// error; the flows and the spectrum report it after the run).
    pub failure: Option<SimError>,
    /// `Σ ln|det(W + ζcᵀ)/det W|` over the compliant phases closed so far: the phase-volume
    /// change of the law's memory of the approach speed (module docs, "Hertz contact phases").
    pub approach_memory_log: f64,
}

impl<S, B: TangentBar<S>> Variational<S, B> {
    /// The layer of `bar` handing its maps to `sink`.
    pub(crate) fn with_bar(bar: B, sink: S) -> Self {
        Variational {
            bar,
            sink,
            counts: EventCounts::default(),
            cur: None,
            pending: None,
            hz: None,
            open_contact: None,
            failure: None,
            approach_memory_log: 0.0,
        }
    }

    /// [`Variational::finish`], then what stopped the tangent integration, if anything.
    pub(crate) fn conclude(&mut self) -> Result<(), SimError> {
        self.finish();
        self.failure.take().map_or(Ok(()), Err)
    }

    /// Apply what is still pending (an event at the very end of the run, a compliant phase the
    /// run ended in). Call once after the run; the flows do.
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

    /// The vector field at the end of a run (after [`Variational::finish`]) at `x_end`,
    /// `t_end`: `∂x(t_end)/∂t_end`.
    pub(crate) fn end_field(&self, t_end: f64, x_end: &B::X) -> B::X {
        let b = &self.bar;
        match self.open_contact {
            Some(c) => {
                let sw = c.wall_sign;
                b.public_tangent(sw, &b.hz_field(&c, t_end, &b.contact_coords(sw, x_end)))
            }
            None => {
                let p = self.cur.unwrap_or(Phase {
                    mode: Mode::Free,
                    sigma: crate::damper::friction::sgn0(b.dw(x_end)),
                });
                b.field(p, x_end, t_end)
            }
        }
    }

    /// Start, continue or (at a friction event) switch the compliant phase with step `seg`
    /// (constants `info`), then carry its tangent over the step.
    fn hz_segment(&mut self, seg: &dyn Segment, info: &CompliantContact) {
        let (t0, t1) = (seg.t_start_s(), seg.t_end_s());
        // At `δ = 0` the contact force vanishes: the phase's field is free flight with the
        // phase's friction force.
        let free_like = Phase {
            mode: Mode::Free,
            sigma: self.bar.laws().sigma_of_fb(info.ball_friction_n),
        };
        if let Some(p) = self.pending.take() {
            self.resolve(p, free_like, false);
        }
        if self.hz.is_some_and(|ph| ph.mode != seg.mode()) {
            self.hz_close(t0);
        }
        let x0 = self.bar.state_at_start(&self.sink, seg, t0);
        let mut ph = match self.hz {
            Some(ph) => ph,
            None => self.hz_start(seg, info, &x0, free_like),
        };
        // The same step constants are the same bits: a change is a friction event.
        if info.stuck != ph.last.stuck
            || info.ball_friction_n.to_bits() != ph.last.ball_friction_n.to_bits()
        {
            self.hz_friction_event(&mut ph, info, t0, &x0);
        }
        ph.last = *info;
        if t1 > t0 {
            if let Err(e) = self.bar.hz_advance(&ph, seg) {
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

    /// The touch: `Z = [T | 0]` (the onset's saltation is `I`) and the memory row `c`.
    fn hz_start(
        &mut self,
        seg: &dyn Segment,
        info: &CompliantContact,
        x0: &B::X,
        free_like: Phase,
    ) -> ContactPhase<B::X> {
        let b = &self.bar;
        let (t0, t1) = (seg.t_start_s(), seg.t_end_s());
        let sw = info.wall_sign;
        let d = b.dim();
        self.counts.compliant_contacts += 1;
        let before = self
            .cur
            .filter(|p| p.mode == Mode::Free)
            .unwrap_or(free_like);
        let (gw, gdw) = (b.grad_w(), b.grad_dw());
        // δ̇₀ = sw·ẇ(t*) at the perturbed touch time t* + δt*, δt* = −δw/ẇ:
        // δδ̇₀ = sw (δẇ − ẅ⁻ δw/ẇ⁻). Zero when the floor holds δ̇₀.
        let dw = b.dw(x0);
        let mut c = b.zero();
        if dw == 0.0 {
            // A touch at rest: not differentiable (a perturbation lifts the ball off).
            self.counts.grazing += 1;
        } else if info.approach_m_s >= info.reference_speed_m_s {
            let r = b.dw(&b.field(before, x0, t0)) / dw;
            for i in 0..d {
                c[i] = sw * gdw[i] - sw * r * gw[i];
            }
        }
        let (lg, om) = (b.laws().lg, b.laws().om);
        let v0 = info.reference_speed_m_s;
        let vs = v0.max(lg * om);
        let ds = info
            .law
            .with_damping(0.0)
            .max_penetration_m(b.contact_mass_kg(), v0);
        // W = T: the ball's (v, v̇) rows become (δ, δ̇) = sw (∇w, ∇ẇ)·x; ζ = 0.
        let zero = b.zero();
        for j in 0..=d {
            let mut col = zero;
            if j < d - 2 {
                col[j] = 1.0;
            }
            if j < d && gw[j] != 0.0 {
                col[d - 2] = sw * gw[j];
            }
            if j < d && gdw[j] != 0.0 {
                col[d - 1] = sw * gdw[j];
            }
            self.bar.hz_set_col(j, &col);
        }
        self.bar.hz_begin(t1 - t0);
        ContactPhase {
            t0,
            t_last: t0,
            sw,
            c,
            last: *info,
            mode: seg.mode(),
            stuck_seen: false,
            scale: [lg, vs, ds, vs],
        }
    }

    /// The saltation of a friction event inside a compliant phase (the step constants change
    /// from `ph.last` to `info` at `t`, public state `x`): `S = I + (f⁺ − f⁻) ∇hᵀ / (∇h·f⁻ +
    /// ∂h/∂t)` in contact coordinates, on every column of `Z` (`∂h/∂δ̇₀ = 0`: `ζ` just follows).
    fn hz_friction_event(
        &mut self,
        ph: &mut ContactPhase<B::X>,
        info: &CompliantContact,
        t: f64,
        x: &B::X,
    ) {
        let b = &self.bar;
        let d = b.dim();
        let y = b.contact_coords(ph.sw, x);
        let fm = b.hz_field(&ph.last, t, &y);
        let fp = b.hz_field(info, t, &y);
        let (grad, rate) = if ph.last.stuck {
            // Unstick: h = f_l ∓ needed, needed = m_d ü_pair + sw K_h δ^{3/2} (the solver's).
            self.counts.unsticks += 1;
            b.hz_unstick(ph.sw, &ph.last, t, &y, &fm)
        } else {
            // ẇ = 0: h = δ̇.
            if info.stuck {
                self.counts.sticks += 1;
                ph.stuck_seen = true;
            } else {
                self.counts.friction_switches += 1;
            }
            let mut g = b.zero();
            g[d - 1] = 1.0;
            (g, fm[d - 1])
        };
        if rate == 0.0 || !rate.is_finite() {
            self.counts.grazing += 1;
            return;
        }
        for j in 0..=d {
            let mut z = self.bar.hz_col(j);
            let gz: f64 = (0..d).map(|k| grad[k] * z[k]).sum();
            for i in 0..d {
                z[i] += (fp[i] - fm[i]) * gz / rate;
            }
            self.bar.hz_set_col(j, &z);
        }
    }

    /// Close the compliant phase at `t_end`: its map to the sink, the memory's volume to
    /// [`Variational::approach_memory_log`]. Returns the last step's constants.
    fn hz_close(&mut self, t_end: f64) -> Option<CompliantContact> {
        let ph = self.hz.take()?;
        if let Some(r) = self.bar.phase_map(&mut self.sink, &ph, t_end) {
            self.approach_memory_log += r.abs().ln();
        }
        if ph.stuck_seen {
            // The stick's saltation is inside the map above; this marks the direction it
            // removed (the spectrum's structural count).
            self.bar.mark(
                &mut self.sink,
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
    fn resolve(&mut self, p: Pending<B::X>, after: Phase, followed_by_contact: bool) {
        let b = &self.bar;
        let ev = &p.ev;
        let t = ev.t_s;
        let x = &p.x;
        let f_minus = b.field(p.before, x, t);
        let c = &mut self.counts;
        let mut plastic = false;
        let (g, grad_h, rate) = match ev.kind {
            EventKind::Impact { .. } if p.release => {
                // The end of a compliant phase (`δ = 0`, `P = 0`): h = w − sw·l_g, G = I; the
                // fields on both sides are free flight, with the friction of each side.
                c.impacts += 1;
                (b.identity_g(), b.grad_w(), b.dw(x))
            }
            EventKind::Impact { .. } => {
                plastic = followed_by_contact && b.laws().e > 0.0;
                if plastic {
                    c.plastic_impacts += 1;
                } else {
                    c.impacts += 1;
                }
                (b.impact_g(plastic), b.grad_w(), b.dw(x))
            }
            EventKind::FrictionSwitch | EventKind::Stick => {
                if ev.kind == EventKind::Stick {
                    c.sticks += 1;
                } else {
                    c.friction_switches += 1;
                }
                (b.identity_g(), b.grad_dw(), b.dw(&f_minus))
            }
            EventKind::Unstick | EventKind::ContactRelease { .. } => {
                if ev.kind == EventKind::Unstick {
                    c.unsticks += 1;
                } else {
                    c.releases += 1;
                }
                let (grad, rate) = b.hold_release(t, &f_minus);
                (b.identity_g(), grad, rate)
            }
            EventKind::ChatterLimit { .. } => {
                c.chatter_limits += 1;
                if matches!(after.mode, Mode::Free) {
                    c.chatter_releases += 1;
                }
                self.cur = Some(after);
                return;
            }
        };
        let x_plus = b.after_reset(&g, plastic, ev, x);
        let f_plus = b.field(after, &x_plus, t);
        let ok = rate != 0.0 && rate.is_finite();
        if !ok {
            c.grazing += 1;
        }
        let e = EventMap {
            kind: ev.kind,
            t_s: t,
            g,
            f_minus,
            f_plus,
            grad_h,
            rate,
            ok,
            x: *x,
            plastic,
            release: p.release,
        };
        self.bar.event_map(&mut self.sink, &e);
        self.cur = Some(after);
    }
}

impl<S, B: TangentBar<S>> Observer for Variational<S, B> {
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
        let sigma = if mode == Mode::Free && self.bar.laws().frictional() {
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
        self.bar.segment_map(&mut self.sink, seg, mode, t0, t1);
    }

    fn event(&mut self, ev: &Event) {
        if self.hz.is_some() {
            let last = self.hz_close(ev.t_s);
            if let (EventKind::Impact { .. }, Some(c)) = (ev.kind, last) {
                // The release (the solver reports the end of contact as the impact).
                let before = Phase {
                    mode: Mode::Free,
                    sigma: self.bar.laws().sigma_of_fb(c.ball_friction_n),
                };
                self.cur = Some(before);
                self.pending = Some(Pending {
                    ev: *ev,
                    before,
                    x: self.bar.event_state(&self.sink, ev),
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
            x: self.bar.event_state(&self.sink, ev),
            release: false,
        });
    }
}
