//! Variational equations of the exact flow of the N-mode bar ([`ModalExact`], issue #11): the
//! Jacobian `∂x(t₁)/∂x(t₀)` of the modal solver's flow map, saltation matrices at every event.
//! The construction is the lumped layer's ([`super::variational`], whose module docs derive the
//! saltation matrix `S = G + (f⁺ − G f⁻) ∇hᵀ / (∇h·f⁻ + ∂h/∂t)`); this module gives its modal
//! ingredients.
//!
//! # Coordinates
//!
//! `x = (q₁ … q_N, q̇₁ … q̇_N, v, v̇)`, dimension `D = 2N + 2`: the fields of [`ModalState`]
//! (the ball's absolute `v`, so that the free flight is block diagonal). The relative motion is
//! the contact row `w = v − φ_dᵀq`, `φ_d = (φₙ(x_d))`; the orbit layer
//! ([`crate::analysis::orbit::modal`]) works in `(q, q̇, w, ẇ)` (`T J T⁻¹`).
//!
//! # Between events (closed form)
//!
//! * Free flight: every mode `mₙq̈ₙ + cₙq̇ₙ + kₙqₙ = φ_fn F(t) − φ_dn F_ball` is its own 2×2
//!   damped transition matrix (`αₙ = cₙ/2mₙ`, `ω_dn = √(kₙ/mₙ − αₙ²)`),
//!   `e^{−ατ}[[cos + (α/ω_d) sin, sin/ω_d], [−(k/m) sin/ω_d, cos − (α/ω_d) sin]]`; the ball
//!   (constant force `F_ball`) is `[[1, τ], [0, 1]]`. `det = Πₙ e^{−(cₙ/mₙ)τ}`.
//! * Ball held (stick, wall contact, the summed chatter sequence): the constrained system
//!   `M_c q̈ + C q̇ + K q = φ_f F(t)`, `M_c = diag(m) + m_d φ_dφ_dᵀ`
//!   ([`crate::solver::exact::constrained`]). First the projection `P` onto the constraint: the
//!   modal impact law at `e = 0` on the perturbation (the impulse `p = δẇ/κ` along the contact
//!   row, `κ = 1/m_d + Σφ_dn²/mₙ`, makes `δẇ = 0`), and on a wall also `δv ← φ_dᵀδq`
//!   (`δw = 0`); then the homogeneous constrained transition matrix `Ψ(τ)` (2N×2N), column `j`
//!   the eigen-expansion's motion from the basis vector `e_j` (the closed form from `e_j` minus
//!   the one from zero: the forced part cancels), with `δv(τ) = δv₀ + φ_dᵀ(δq(τ) − δq₀)`,
//!   `δv̇ = φ_dᵀδq̇(τ)`.
//!
//! # At events (saltation, `G`, `h`)
//!
//! | event | `h` | `G` |
//! |---|---|---|
//! | impact at wall `s` | `v − φ_dᵀq − s l_g` | modal impact law: `p = (1+e)ẇ/κ`, `q̇ₙ += φ_dn p/mₙ`, `v̇ −= p/m_d` |
//! | plastic impact (chatter limit, `e = 0` into contact) | same | the law at `e = 0` |
//! | friction switch, stick | `ẇ = v̇ − φ_dᵀq̇` | `I` |
//! | unstick, release | the holding force `f_c = a_b/κ`, `a_b = Σφ_dn(φ_fn F − cₙq̇ₙ − kₙqₙ)/mₙ` | `I` |
//!
//! The held vector field is `q̈ = D⁻¹(φ_f F − Cq̇ − Kq) − D⁻¹φ_d f_c`, `v̈ = f_c/m_d`
//! (Sherman–Morrison on `M_c`). At unstick (Coulomb) and at a frictionless release the free
//! field after equals the held field before (`F_ball = f_c` at the threshold), so `S = I`; the
//! as-published release switches its friction force on and gets the general formula.
//!
//! **Determinant of an impact.** `G` is the identity on positions and `∇h` has only position
//! entries, so `det S = det G · (1 + ∇hᵀG⁻¹(f⁺ − Gf⁻)/ẇ⁻) = (−e)·(1 + (ẇ⁺ − ẇ⁻)/ẇ⁻) = e²`
//! (`det G = 1 − (1+e) = −e`, the rank-one update along the contact row).
//!
//! **Phase volume.** Between impacts of the frictionless bar the volume shrinks by
//! `e^{−Σₙ(cₙ/mₙ)τ}` (the ball adds nothing), each impact multiplies it by `e²`, so over a
//! window `T` with `I` impacts `ln|det J|/T = −Σₙ cₙ/mₙ + 2 ln(e) I/T`: the sum of the Lyapunov
//! exponents of the frictionless modal bar (tested to 1e-9 in `tests/variational_modal.rs`).
//!
//! Grazing (an event with a vanishing crossing rate) has no saltation matrix: it is counted in
//! [`EventCounts::grazing`] and only `G` is applied. The chatter-limit release (the ball leaves
//! the wall at the end of the summed sequence) is `S = I`, counted in
//! [`EventCounts::chatter_releases`], as on the lumped bar.
//!
//! # Cost
//!
//! The tangent vectors are the columns of a fixed-capacity `D_MAX × D_MAX` buffer allocated
//! once per run ([`D_MAX`] from [`MAX_BEAM_MODES`]); a free segment costs `O(D)` per column,
//! an event `O(D)` per column, a held segment `O(N³)` to form `Ψ` plus `O(D²)` per column.
//! Nothing is allocated per segment or event. The constrained modes are computed when a run
//! first holds the ball.
//!
//! # Hertz contact phases
//!
//! The lumped layer's construction ([`super::variational`], "Hertz contact phases") with the
//! contact row: in the contact coordinates `y = (q, q̇, δ, δ̇)`, `δ = s(v − φ_dᵀq) − l_g`,
//! `δ̇ = s(v̇ − φ_dᵀq̇)`, the field of `solver/exact/modal/hertz.rs`
//! (`mₙq̈ₙ + cₙq̇ₙ + kₙqₙ = φ_fn F(t) + φ_dn(s P − F_b)`, `m_d v̈ = −s P + F_b`) has the Jacobian
//! rows `q̈ₙ: (−kₙ, −cₙ, φ_dn s P_δ, φ_dn s P_δ̇)/mₙ` and `δ̈ = s(−s δP/m_d − φ_dᵀq̈)`, whose
//! `δ` entry is `−P_δ κ` (`κ = 1/m_d + Σφ_dn²/mₙ`; the lumped `1/M + 1/m_d`). Onset and
//! release have `S = I` (the force is 0 on both sides); the memory of the approach speed is the
//! extra column `ζ = ∂y/∂δ̇₀` with `cᵀ = s(∇ẇ − (ẅ⁻/ẇ⁻)∇w)`, `∇w = (−φ_d, 0, 1, 0)`,
//! `∇ẇ = (0, −φ_d, 0, 1)`; the phase's map is `T⁻¹(W + ζcᵀ)`, applied to the carried columns at
//! the release. Friction inside a contact: reversal at `δ̇ = 0`, stick (the held modes, `δ`
//! frozen), unstick at `h = f_l ∓ (a_b/κ + s K_h δ^{3/2})`. The `D + 1` columns of `[W | ζ]`
//! are integrated one by one (each its own adaptive Dormand–Prince 5(4) at
//! [`HERTZ_TANGENT_RTOL`], along the solver's dense output), `O(N)` per column and stage.
//! `A(t)` reads only `δ`, `δ̇`, from the segment's public state.
//!
//! # Not covered
//!
//! Parameter columns (the orbit layer takes parameter derivatives by central differences of
//! the map).

// Index loops read as the linear algebra they are.
#![allow(clippy::needless_range_loop)]

use super::lyapunov_spectrum::Frame;
use super::variational::{
    EventCounts, Phase, Step, HERTZ_TANGENT_MAX_SUBSTEPS, HERTZ_TANGENT_RTOL,
    VARIATIONAL_NEEDS_BALL,
};
use crate::damper::contact::Hertz;
use crate::damper::friction::{sgn0, sign_factor, sliding_friction_on_ball_n};
use crate::damper::impact::modal_inverse_effective_mass_per_kg;
use crate::error::SimError;
use crate::limits::MAX_BEAM_MODES;
use crate::params::{ContactLaw, FrictionModel};
use crate::solver::dopri5::Dopri5;
use crate::solver::exact::constrained::ConstrainedModes;
use crate::solver::exact::modal::ModalExact;
use crate::solver::modal_rk4::ModalObserver;
use crate::solver::{CompliantContact, Event, EventKind, Mode, Observer, RunSummary, Segment};
use crate::structure::{ModalState, ModalSystem, Point};

const NM: usize = MAX_BEAM_MODES;
/// Largest state dimension `2N + 2`.
pub const D_MAX: usize = 2 * MAX_BEAM_MODES + 2;

/// A state or tangent vector on `(q, q̇, v, v̇)` (entries beyond `2N + 2` unused).
pub type VecD = [f64; D_MAX];

/// Constants of the modal system.
#[derive(Debug, Clone, Copy)]
struct Cs {
    n: usize,
    m: [f64; NM],
    c: [f64; NM],
    k: [f64; NM],
    phi_f: [f64; NM],
    phi_d: [f64; NM],
    al: [f64; NM],
    wd: [f64; NM],
    md: f64,
    e: f64,
    fl: f64,
    model: FrictionModel,
    fs: f64,
    f0: f64,
    om: f64,
    kappa: f64,
    /// The compliant law, `None` under the restitution law.
    hertz: Option<Hertz>,
    /// Half gap `l_g`.
    lg: f64,
}

impl Cs {
    fn new(sys: &ModalSystem) -> Result<Cs, SimError> {
        let d = sys
            .damper
            .ok_or(SimError::Unsupported(VARIATIONAL_NEEDS_BALL))?;
        let modes = sys.model.modes();
        let n = modes.len();
        let mut cs = Cs {
            n,
            m: [0.0; NM],
            c: [0.0; NM],
            k: [0.0; NM],
            phi_f: sys.row(Point::Force),
            phi_d: sys.row(Point::Cavity),
            al: [0.0; NM],
            wd: [0.0; NM],
            md: d.ball_mass_kg,
            e: d.restitution,
            fl: sys.friction_level_n(),
            model: d.friction,
            fs: sys.forcing.static_force_n,
            f0: sys.forcing.amplitude_n,
            om: sys.omega_rad_s(),
            kappa: 0.0,
            hertz: (d.contact.law == ContactLaw::Hertz).then(|| Hertz::of_damper(&d)),
            lg: d.half_gap_m(),
        };
        for (i, mode) in modes.iter().enumerate() {
            let (m, k) = (mode.modal_mass_kg, mode.modal_stiffness_n_per_m());
            // The solver's `cₙ = 2ζₙ√(kₙmₙ)`.
            let c = 2.0 * mode.damping_ratio * (k * m).sqrt();
            cs.m[i] = m;
            cs.k[i] = k;
            cs.c[i] = c;
            cs.al[i] = c / (2.0 * m);
            cs.wd[i] = (k / m - cs.al[i] * cs.al[i]).sqrt();
        }
        cs.kappa = modal_inverse_effective_mass_per_kg(cs.md, &cs.phi_d[..n], &cs.m[..n]);
        Ok(cs)
    }

    fn dim(&self) -> usize {
        2 * self.n + 2
    }

    fn force(&self, t: f64) -> f64 {
        self.fs + self.f0 * (self.om * t).sin()
    }

    fn dforce_dt(&self, t: f64) -> f64 {
        self.f0 * self.om * (self.om * t).cos()
    }

    fn fb(&self, sigma: f64) -> f64 {
        sliding_friction_on_ball_n(self.model, self.fl, sigma)
    }

    /// `φ_dᵀ y[offset..offset+N]`.
    fn dot_d(&self, y: &VecD, offset: usize) -> f64 {
        (0..self.n).map(|i| self.phi_d[i] * y[offset + i]).sum()
    }

    /// The vector field of phase `p` at `x`, `t`.
    fn field(&self, p: Phase, x: &VecD, t: f64) -> VecD {
        let n = self.n;
        let f_t = self.force(t);
        let mut f = [0.0; D_MAX];
        let mut a_b = 0.0;
        for i in 0..n {
            f[i] = x[n + i];
            let b = self.phi_f[i] * f_t - self.c[i] * x[n + i] - self.k[i] * x[i];
            f[n + i] = b / self.m[i];
            a_b += self.phi_d[i] * b / self.m[i];
        }
        f[2 * n] = x[2 * n + 1];
        // The force on the ball: sliding friction in free flight, the holding force held.
        let fball = match p.mode {
            Mode::Free | Mode::NoBall => self.fb(p.sigma),
            Mode::Stick | Mode::Contact(_) => a_b / self.kappa,
        };
        for i in 0..n {
            f[n + i] -= self.phi_d[i] * fball / self.m[i];
        }
        f[2 * n + 1] = fball / self.md;
        f
    }

    /// The modal impact law at restitution `e` on a tangent (or state) vector, in place.
    fn impact_law(&self, e: f64, y: &mut VecD) {
        let n = self.n;
        let dw = y[2 * n + 1] - self.dot_d(y, n);
        let p = (1.0 + e) * dw / self.kappa;
        for i in 0..n {
            y[n + i] += self.phi_d[i] * p / self.m[i];
        }
        y[2 * n + 1] -= p / self.md;
    }
}

/// The compliant (`hertz`) contact phase in the contact coordinates `y = (q, q̇, δ, δ̇)`,
/// `δ = s(v − φ_dᵀq) − l_g`, `δ̇ = s(v̇ − φ_dᵀq̇)` (module docs, "Hertz contact phases").
impl Cs {
    /// The free-flight friction sign `σ` whose sliding force is `fb`.
    fn sigma_of_fb(&self, fb: f64) -> f64 {
        sign_factor(self.model) * sgn0(fb)
    }

    /// `y` of a public vector `x` at wall `sw`.
    fn contact_coords(&self, sw: f64, x: &VecD) -> VecD {
        let n = self.n;
        let mut y = *x;
        y[2 * n] = sw * (x[2 * n] - self.dot_d(x, 0)) - self.lg;
        y[2 * n + 1] = sw * (x[2 * n + 1] - self.dot_d(x, n));
        y
    }

    /// A tangent vector in contact coordinates back to public ones (`δv = φ_dᵀδq + s δδ`).
    fn public_tangent(&self, sw: f64, z: &VecD) -> VecD {
        let n = self.n;
        let mut x = *z;
        x[2 * n] = self.dot_d(z, 0) + sw * z[2 * n];
        x[2 * n + 1] = self.dot_d(z, n) + sw * z[2 * n + 1];
        x
    }

    /// The phase's vector field at `y` (`solver/exact/modal/hertz.rs`): the modes under the
    /// force `s P − F_b` at the cavity, `m_d v̈ = −s P + F_b`, `δ̈ = s(v̈ − φ_dᵀq̈)`; stuck: the
    /// ball held (the force `−a_b/κ` on the bar), `δ` frozen.
    fn hz_field(&self, c: &CompliantContact, t: f64, y: &VecD) -> VecD {
        let n = self.n;
        let f_t = self.force(t);
        let mut f = [0.0; D_MAX];
        let mut b = [0.0; NM];
        let mut a_b = 0.0;
        for i in 0..n {
            b[i] = self.phi_f[i] * f_t - self.c[i] * y[n + i] - self.k[i] * y[i];
            a_b += self.phi_d[i] * b[i] / self.m[i];
        }
        let sw = c.wall_sign;
        let (on_bar, p) = if c.stuck {
            (-a_b / self.kappa, 0.0)
        } else {
            let p = c.law.force_n(y[2 * n], y[2 * n + 1], c.reference_speed_m_s);
            (sw * p - c.ball_friction_n, p)
        };
        let mut acc = 0.0;
        for i in 0..n {
            f[i] = y[n + i];
            f[n + i] = (b[i] + self.phi_d[i] * on_bar) / self.m[i];
            acc += self.phi_d[i] * f[n + i];
        }
        if !c.stuck {
            f[2 * n] = y[2 * n + 1];
            f[2 * n + 1] = sw * ((-sw * p + c.ball_friction_n) / self.md - acc);
        }
        f
    }

    /// The phase's vector field in public coordinates at `x`.
    fn hz_field_public(&self, c: &CompliantContact, t: f64, x: &VecD) -> VecD {
        let sw = c.wall_sign;
        let f = self.hz_field(c, t, &self.contact_coords(sw, x));
        self.public_tangent(sw, &f)
    }

    /// `A z + γ b` (`A = ∂f/∂y`, `b = ∂f/∂δ̇₀`) at the penetration `delta`, rate `ddelta`:
    /// with `P_δ = (3/2) K_h δ^{1/2}(1 + D δ̇/δ̇₀)`, `P_δ̇ = K_h δ^{3/2} D/δ̇₀`,
    /// `P_δ̇₀ = −K_h δ^{3/2} D δ̇/δ̇₀²` and `δP = P_δ z_δ + P_δ̇ z_δ̇ + P_δ̇₀ γ`, the rows
    /// `q̈ₙ: (−kₙz_qₙ − cₙz_q̇ₙ + φ_dn s δP)/mₙ`, `δ̈: s(−s δP/m_d − φ_dᵀq̈)`; stuck, the held
    /// modes with `δ` frozen.
    fn hz_tangent(
        &self,
        c: &CompliantContact,
        delta: f64,
        ddelta: f64,
        z: &VecD,
        gamma: f64,
    ) -> VecD {
        let n = self.n;
        let mut dz = [0.0; D_MAX];
        let mut b = [0.0; NM];
        for i in 0..n {
            dz[i] = z[n + i];
            b[i] = -self.k[i] * z[i] - self.c[i] * z[n + i];
        }
        if c.stuck {
            let a_b: f64 = (0..n).map(|i| self.phi_d[i] * b[i] / self.m[i]).sum();
            for i in 0..n {
                dz[n + i] = (b[i] - self.phi_d[i] * a_b / self.kappa) / self.m[i];
            }
            return dz;
        }
        let sw = c.wall_sign;
        let d = delta.max(0.0);
        let sq = d.sqrt();
        let kh = c.law.stiffness_n_m32;
        let v0 = c.reference_speed_m_s;
        let damp = c.law.damping;
        let p_d = 1.5 * kh * sq * (1.0 + damp * ddelta / v0);
        let p_dd = kh * d * sq * damp / v0;
        let p_v0 = -kh * d * sq * damp * ddelta / (v0 * v0);
        let dp = p_d * z[2 * n] + p_dd * z[2 * n + 1] + p_v0 * gamma;
        let mut acc = 0.0;
        for i in 0..n {
            dz[n + i] = (b[i] + self.phi_d[i] * sw * dp) / self.m[i];
            acc += self.phi_d[i] * dz[n + i];
        }
        dz[2 * n] = z[2 * n + 1];
        dz[2 * n + 1] = sw * (-sw * dp / self.md - acc);
        dz
    }

    /// `∇h` and the rate of the unstick inside a stuck contact phase at `y`:
    /// `h = f_l ∓ (a_b/κ + s K_h δ^{3/2})` (the solver's test; the sign is a common factor).
    fn hz_unstick(&self, sw: f64, law: &Hertz, t: f64, y: &VecD, f_minus: &VecD) -> (VecD, f64) {
        let n = self.n;
        let mut g = [0.0; D_MAX];
        let mut dh_dt = 0.0;
        for i in 0..n {
            g[i] = -self.phi_d[i] * self.k[i] / (self.m[i] * self.kappa);
            g[n + i] = -self.phi_d[i] * self.c[i] / (self.m[i] * self.kappa);
            dh_dt += self.phi_d[i] * self.phi_f[i] / (self.m[i] * self.kappa);
        }
        g[2 * n] = sw * 1.5 * law.stiffness_n_m32 * y[2 * n].max(0.0).sqrt();
        let rate =
            (0..self.dim()).map(|i| g[i] * f_minus[i]).sum::<f64>() + dh_dt * self.dforce_dt(t);
        (g, rate)
    }
}

/// The 2N×2N homogeneous transition matrix of the held motion over `τ`, from the eigen-expansion
/// (module docs): `psi[i][j] = ∂(q, q̇)ᵢ(τ)/∂(q, q̇)ⱼ(0)`.
fn held_transition(cm: &ConstrainedModes, n: usize, tau: f64, psi: &mut [[f64; 2 * NM]; 2 * NM]) {
    let zero = [0.0; NM];
    let (q0, dq0) = cm.segment(0.0, &zero, &zero).state_at(tau);
    let mut unit = [0.0; NM];
    for j in 0..2 * n {
        let (q, dq) = if j < n {
            unit[j] = 1.0;
            let r = cm.segment(0.0, &unit, &zero).state_at(tau);
            unit[j] = 0.0;
            r
        } else {
            unit[j - n] = 1.0;
            let r = cm.segment(0.0, &zero, &unit).state_at(tau);
            unit[j - n] = 0.0;
            r
        };
        for i in 0..n {
            psi[i][j] = q[i] - q0[i];
            psi[n + i][j] = dq[i] - dq0[i];
        }
    }
}

/// An event waiting for the phase that follows it.
#[derive(Debug, Clone, Copy)]
struct Pending {
    ev: Event,
    before: Phase,
    x_before: VecD,
    /// The end of a compliant contact phase (the solver's `Impact` at the release).
    release: bool,
}

/// A compliant contact phase in progress: its tangent map from the public state at the touch
/// (the columns of `Z = [W | ζ]` in [`ModalVariational`]'s buffer, contact coordinates).
#[derive(Debug, Clone, Copy)]
struct HzPhase {
    t0: f64,
    t_last: f64,
    sw: f64,
    /// `∂δ̇₀/∂x(touch)`.
    c: VecD,
    /// The constants of the last step seen (a change marks a friction event).
    last: CompliantContact,
    /// Tangent step size to try next, per column.
    h: [f64; D_MAX + 1],
    /// `Mode::Contact(wall)`.
    mode: Mode,
    /// A stick happened in this phase (a direction is removed for good).
    stuck_seen: bool,
    /// Row scales `(l_g, v, δ_max, v)` of the tolerance: modes, mode rates, `δ`, `δ̇`.
    scale: [f64; 4],
}

impl HzPhase {
    /// The scale of row `i` of `[W | ζ]` (contact coordinates) on a bar of `n` modes.
    fn row_scale(&self, n: usize, i: usize) -> f64 {
        if i < n {
            self.scale[0]
        } else if i < 2 * n {
            self.scale[1]
        } else {
            self.scale[i - 2 * n + 2]
        }
    }

    /// The size of a perturbation column `j` maps: the modes and the ball's position `l_g`,
    /// their rates and `δ̇₀` (column `2N + 2`) the speed scale.
    fn col_scale(&self, n: usize, j: usize) -> f64 {
        if j < n || j == 2 * n {
            self.scale[0]
        } else {
            self.scale[1]
        }
    }
}

/// The variational layer of a modal exact run: a [`ModalObserver`] carrying `cols` tangent
/// vectors (the columns of `Y`, `Y ← (tangent map) Y`) through every segment and event.
pub struct ModalVariational {
    cs: Cs,
    sys: ModalSystem,
    held: Option<Box<ConstrainedModes>>,
    psi: Box<[[f64; 2 * NM]; 2 * NM]>,
    /// The tangent vectors (columns of `Y`).
    pub cols: Box<[VecD; D_MAX]>,
    /// How many columns are carried.
    pub ncols: usize,
    /// Events seen.
    pub counts: EventCounts,
    cur: Option<Phase>,
    pending: Option<Pending>,
    /// The modal state now (end of the last segment, or after the last event).
    x_cur: VecD,
    /// Re-orthonormalisation (Lyapunov spectrum), when set.
    qr: Option<Box<Qr>>,
    /// The compliant contact phase in progress (`hertz` law) and its columns `[W | ζ]`.
    hz: Option<HzPhase>,
    hz_z: Box<[VecD; D_MAX + 1]>,
    /// The phase a run ended in, when it ended inside a compliant contact (for the end field).
    open_contact: Option<CompliantContact>,
    /// What stopped the tangent integration of a compliant phase (reported after the run).
    pub failure: Option<SimError>,
    /// `Σ ln|1 + cᵀW⁻¹ζ|` over the compliant phases closed so far: the law's memory of the
    /// approach speed ([`super::variational`], "Hertz contact phases").
    pub approach_memory_log: f64,
}

/// QR re-orthonormalisation state: the spectrum's frame
/// ([`super::lyapunov_spectrum::Frame`]) in the coordinates scaled by `scale`.
pub(crate) struct Qr {
    /// Scale of every coordinate.
    pub scale: VecD,
    /// The frame's bookkeeping (logs, collapsed directions, impacts, steps).
    pub frame: Frame,
}

/// `x` of a modal state.
pub fn to_vec(cs_n: usize, s: &ModalState) -> VecD {
    let mut x = [0.0; D_MAX];
    x[..cs_n].copy_from_slice(&s.q_m[..cs_n]);
    x[cs_n..2 * cs_n].copy_from_slice(&s.dq_m_s[..cs_n]);
    x[2 * cs_n] = s.v_m;
    x[2 * cs_n + 1] = s.dv_m_s;
    x
}

impl ModalVariational {
    /// The layer for `sys` (a ball under the restitution law) starting at `init`, carrying the
    /// identity (the Jacobian).
    pub fn new(sys: &ModalSystem, init: &ModalState) -> Result<ModalVariational, SimError> {
        sys.validate()?;
        let cs = Cs::new(sys)?;
        let mut cols = Box::new([[0.0; D_MAX]; D_MAX]);
        let d = cs.dim();
        for (j, c) in cols.iter_mut().enumerate().take(d) {
            c[j] = 1.0;
        }
        Ok(ModalVariational {
            cs,
            sys: sys.clone(),
            held: None,
            psi: Box::new([[0.0; 2 * NM]; 2 * NM]),
            cols,
            ncols: d,
            counts: EventCounts::default(),
            cur: None,
            pending: None,
            x_cur: to_vec(cs.n, init),
            qr: None,
            hz: None,
            hz_z: Box::new([[0.0; D_MAX]; D_MAX + 1]),
            open_contact: None,
            failure: None,
            approach_memory_log: 0.0,
        })
    }

    /// State dimension `2N + 2`.
    pub fn dim(&self) -> usize {
        self.cs.dim()
    }

    /// Restart the carried columns' run at `init` (between runs of one spectrum).
    pub(crate) fn restart_at(&mut self, init: &ModalState) {
        self.x_cur = to_vec(self.cs.n, init);
        self.cur = None;
        self.pending = None;
        self.hz = None;
    }

    /// Re-orthonormalise every two steps in the coordinates scaled by `scale` (Lyapunov).
    pub(crate) fn with_qr(mut self, scale: VecD) -> Self {
        let d = self.dim();
        self.qr = Some(Box::new(Qr {
            scale,
            frame: Frame::new(d, self.cs.e, self.cs.hertz.is_some()),
        }));
        // Start from the identity in scaled coordinates: column j is s_j e_j.
        for j in 0..d {
            self.cols[j] = [0.0; D_MAX];
            self.cols[j][j] = scale[j];
        }
        self
    }

    pub(crate) fn qr_state(&mut self) -> Option<&mut Qr> {
        self.qr.as_deref_mut()
    }

    /// The Jacobian carried so far (`Y` as a `D × D` matrix, row-major).
    pub fn jacobian(&self) -> Vec<Vec<f64>> {
        let d = self.dim();
        (0..d)
            .map(|i| (0..self.ncols).map(|j| self.cols[j][i]).collect())
            .collect()
    }

    /// Apply the free-flight transition over `τ` to every column.
    fn apply_free(&mut self, tau: f64) {
        let cs = &self.cs;
        let n = cs.n;
        let mut blocks = [[0.0; 4]; NM];
        for i in 0..n {
            let (al, wd) = (cs.al[i], cs.wd[i]);
            let wn2 = cs.k[i] / cs.m[i];
            let ex = (-al * tau).exp();
            let (s, co) = (wd * tau).sin_cos();
            let sw = s / wd;
            blocks[i] = [
                ex * (co + al * sw),
                ex * sw,
                -wn2 * ex * sw,
                ex * (co - al * sw),
            ];
        }
        for y in self.cols.iter_mut().take(self.ncols) {
            for (i, b) in blocks.iter().enumerate().take(n) {
                let (a, da) = (y[i], y[n + i]);
                y[i] = b[0] * a + b[1] * da;
                y[n + i] = b[2] * a + b[3] * da;
            }
            y[2 * n] += tau * y[2 * n + 1];
        }
    }

    /// Apply the held transition (projection, then `Ψ(τ)`) to every column.
    fn apply_held(&mut self, mode: Mode, tau: f64) {
        let n = self.cs.n;
        if self.held.is_none() {
            // The solver computed the same modes for this run already (it could not have
            // reached a held segment otherwise), so this cannot fail here.
            match ConstrainedModes::new(&self.sys) {
                Ok(cm) => self.held = Some(Box::new(cm)),
                Err(_) => return,
            }
        }
        let cm = self.held.as_deref().expect("set above");
        held_transition(cm, n, tau, &mut self.psi);
        let cs = self.cs;
        let wall = matches!(mode, Mode::Contact(_));
        let mut tmp = [0.0; 2 * NM];
        for y in self.cols.iter_mut().take(self.ncols) {
            cs.impact_law(0.0, y);
            if wall {
                y[2 * n] = cs.dot_d(y, 0);
            }
            let dq0 = cs.dot_d(y, 0);
            for (i, t) in tmp.iter_mut().enumerate().take(2 * n) {
                *t = (0..2 * n).map(|j| self.psi[i][j] * y[j]).sum();
            }
            y[..2 * n].copy_from_slice(&tmp[..2 * n]);
            y[2 * n] += cs.dot_d(y, 0) - dq0;
            y[2 * n + 1] = cs.dot_d(y, n);
        }
    }

    /// Apply what is still pending (an event at the very end of the run, a compliant phase the
    /// run ended in).
    pub fn finish(&mut self) {
        self.open_contact = None;
        if let Some(p) = self.pending.take() {
            let after = Phase::default_after(&p.ev, self.cur);
            let contact = matches!(after.mode, Mode::Contact(_));
            self.resolve(p, after, contact);
        }
        if let Some(ph) = self.hz {
            self.open_contact = self.hz_close(ph.t_last);
        }
    }

    /// Start, continue or (at a friction event) switch the compliant phase with step `seg`
    /// (constants `info`), then carry its tangent over the step.
    fn hz_segment(&mut self, seg: &dyn Segment, info: &CompliantContact) {
        let cs = self.cs;
        let n = cs.n;
        let d = cs.dim();
        let (t0, t1) = (seg.t_start_s(), seg.t_end_s());
        let sw = info.wall_sign;
        // At `δ = 0` the contact force vanishes: the phase's field is free flight with the
        // phase's friction force.
        let free_like = Phase {
            mode: Mode::Free,
            sigma: cs.sigma_of_fb(info.ball_friction_n),
        };
        if let Some(p) = self.pending.take() {
            self.resolve(p, free_like, false);
        }
        if self.hz.is_some_and(|ph| ph.mode != seg.mode()) {
            self.hz_close(t0);
        }
        // The state at the step's start: the modes as the last step left them, the ball as the
        // phase restarts it (`ẇ = 0` exactly after a friction event).
        let p0 = seg.state_at(t0);
        let mut x0 = self.x_cur;
        x0[2 * n] = p0.v_m;
        x0[2 * n + 1] = p0.dv_m_s;
        let mut ph = match self.hz {
            Some(ph) => ph,
            None => {
                self.counts.compliant_contacts += 1;
                let before = self
                    .cur
                    .filter(|p| p.mode == Mode::Free)
                    .unwrap_or(free_like);
                // δ̇₀ = s·ẇ(t*) at the perturbed touch time t* + δt*, δt* = −δw/ẇ:
                // δδ̇₀ = s (δẇ − ẅ⁻ δw/ẇ⁻), δw = δv − φ_dᵀδq. Zero when the floor holds δ̇₀.
                let dw = p0.dw_m_s();
                let mut c = [0.0; D_MAX];
                if dw == 0.0 {
                    // A touch at rest: not differentiable (a perturbation lifts the ball off).
                    self.counts.grazing += 1;
                } else if info.approach_m_s >= info.reference_speed_m_s {
                    let f = cs.field(before, &x0, t0);
                    let r = (f[2 * n + 1] - cs.dot_d(&f, n)) / dw;
                    for i in 0..n {
                        c[i] = sw * r * cs.phi_d[i];
                        c[n + i] = -sw * cs.phi_d[i];
                    }
                    c[2 * n] = -sw * r;
                    c[2 * n + 1] = sw;
                }
                let v0 = info.reference_speed_m_s;
                let vs = v0.max(cs.lg * cs.om);
                let ds = info
                    .law
                    .with_damping(0.0)
                    .max_penetration_m(1.0 / cs.kappa, v0);
                // W = T: (q, q̇, v, v̇) → (q, q̇, δ, δ̇); the onset's saltation is I.
                for (j, z) in self.hz_z.iter_mut().enumerate().take(d + 1) {
                    *z = [0.0; D_MAX];
                    if j < d {
                        z[j] = 1.0;
                    }
                    if j < n {
                        z[2 * n] = -sw * cs.phi_d[j];
                    } else if j < 2 * n {
                        z[2 * n + 1] = -sw * cs.phi_d[j - n];
                    } else if j < d {
                        z[j] = sw;
                    }
                }
                HzPhase {
                    t0,
                    t_last: t0,
                    sw,
                    c,
                    last: *info,
                    h: [t1 - t0; D_MAX + 1],
                    mode: seg.mode(),
                    stuck_seen: false,
                    scale: [cs.lg, vs, ds, vs],
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
            if let Err(e) = self.hz_advance(&mut ph, seg, info, t0, t1) {
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
    /// from `ph.last` to `info` at `t`, public state `x`):
    /// `S = I + (f⁺ − f⁻) ∇hᵀ / (∇h·f⁻ + ∂h/∂t)` in contact coordinates, on every column of
    /// `[W | ζ]` (`∂h/∂δ̇₀ = 0`: the `ζ` column just follows).
    fn hz_friction_event(&mut self, ph: &mut HzPhase, info: &CompliantContact, t: f64, x: &VecD) {
        let cs = self.cs;
        let d = cs.dim();
        let y = cs.contact_coords(ph.sw, x);
        let fm = cs.hz_field(&ph.last, t, &y);
        let fp = cs.hz_field(info, t, &y);
        let (grad, rate) = if ph.last.stuck {
            self.counts.unsticks += 1;
            cs.hz_unstick(ph.sw, &ph.last.law, t, &y, &fm)
        } else {
            // ẇ = 0: h = δ̇.
            if info.stuck {
                self.counts.sticks += 1;
                ph.stuck_seen = true;
            } else {
                self.counts.friction_switches += 1;
            }
            let mut g = [0.0; D_MAX];
            g[d - 1] = 1.0;
            (g, fm[d - 1])
        };
        if rate == 0.0 || !rate.is_finite() {
            self.counts.grazing += 1;
            return;
        }
        for z in self.hz_z.iter_mut().take(d + 1) {
            let gz: f64 = (0..d).map(|k| grad[k] * z[k]).sum();
            for i in 0..d {
                z[i] += (fp[i] - fm[i]) * gz / rate;
            }
        }
    }

    /// Integrate the phase's variational equation `z' = A(t) z (+ b(t) for ζ)` over `[a, b]`
    /// along the step's dense output, column by column: adaptive Dormand–Prince 5(4) with
    /// relative tolerance [`HERTZ_TANGENT_RTOL`] on every entry (the lumped layer's, there on
    /// the whole block at once).
    fn hz_advance(
        &mut self,
        ph: &mut HzPhase,
        seg: &dyn Segment,
        info: &CompliantContact,
        a: f64,
        b: f64,
    ) -> Result<(), SimError> {
        let cs = self.cs;
        let (n, d) = (cs.n, cs.dim());
        let sw = ph.sw;
        let sc = *ph;
        let (row, col) = (|i| sc.row_scale(n, i), |j| sc.col_scale(n, j));
        for j in 0..=d {
            let mut atol = [0.0; D_MAX];
            for (i, at) in atol.iter_mut().enumerate().take(d) {
                *at = HERTZ_TANGENT_RTOL * row(i) / col(j);
            }
            let ig = Dopri5::<D_MAX> {
                rtol: HERTZ_TANGENT_RTOL,
                atol,
                len: d,
            };
            let gamma = if j == d { 1.0 } else { 0.0 };
            let mut f = |t: f64, z: &VecD| {
                let x = seg.state_at(t);
                cs.hz_tangent(info, sw * x.w_m() - cs.lg, sw * x.dw_m_s(), z, gamma)
            };
            let (mut t, mut h) = (a, ph.h[j].min(b - a));
            let mut z = self.hz_z[j];
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
                    h = Dopri5::<D_MAX>::next_h(hh, at.err);
                    if h <= 4.0 * f64::EPSILON * t.abs().max(1e-300) || !h.is_finite() {
                        return Err(SimError::NonFinite { t_s: t });
                    }
                    continue;
                }
                z = at.step.y1;
                f0 = at.f1;
                h = Dopri5::<D_MAX>::next_h(hh, at.err);
                if last {
                    break;
                }
                t += hh;
            }
            self.hz_z[j] = z;
            ph.h[j] = h;
        }
        Ok(())
    }

    /// Close the compliant phase at `t_end`: apply its tangent map `T⁻¹ (W + ζ cᵀ)` (public
    /// coordinates at the touch → public at `t_end`) to the columns. Returns the last step's
    /// constants.
    fn hz_close(&mut self, t_end: f64) -> Option<CompliantContact> {
        let ph = self.hz.take()?;
        let cs = self.cs;
        let d = cs.dim();
        let z = &self.hz_z;
        for y in self.cols.iter_mut().take(self.ncols) {
            let g: f64 = (0..d).map(|j| ph.c[j] * y[j]).sum();
            let mut m = [0.0; D_MAX];
            for i in 0..d {
                m[i] = z[d][i] * g + (0..d).map(|j| z[j][i] * y[j]).sum::<f64>();
            }
            *y = cs.public_tangent(ph.sw, &m);
        }
        let memory = self.memory_factor(&ph);
        if memory != 0.0 && memory.is_finite() {
            self.approach_memory_log += memory.abs().ln();
        }
        self.step_done(Step::Segment {
            t0_s: ph.t0,
            t1_s: t_end,
            mode: ph.mode,
        });
        if ph.stuck_seen {
            // The stick's saltation is inside the map above; this marks the direction it
            // removed (the spectrum's structural count).
            self.step_done(Step::Event {
                t_s: t_end,
                kind: EventKind::Stick,
                plastic: false,
            });
        }
        Some(ph.last)
    }

    /// `det(W + ζcᵀ)/det W = 1 + cᵀW⁻¹ζ` of the phase just closed (Gaussian elimination with
    /// partial pivoting in the tolerance's scaled coordinates, on the buffer, which the phase
    /// no longer needs); 0 where `W` is singular (a stick removed a direction).
    fn memory_factor(&mut self, ph: &HzPhase) -> f64 {
        let cs = self.cs;
        let (n, d) = (cs.n, cs.dim());
        if ph.c[..d].iter().all(|c| *c == 0.0) {
            return 1.0;
        }
        let (row, col) = (|i| ph.row_scale(n, i), |j| ph.col_scale(n, j));
        // a = R W C (columns 0..d), r = R ζ (column d); cᵀW⁻¹ζ = (Cc)ᵀ a⁻¹ r.
        let a = &mut self.hz_z;
        for j in 0..=d {
            let cj = if j < d { col(j) } else { 1.0 };
            for i in 0..d {
                a[j][i] *= cj / row(i);
            }
        }
        for k in 0..d {
            let p = (k..d)
                .max_by(|&i, &l| a[k][i].abs().total_cmp(&a[k][l].abs()))
                .expect("k < d");
            let piv = a[k][p];
            if piv == 0.0 || !piv.is_finite() {
                return 0.0;
            }
            for col in a.iter_mut().take(d + 1).skip(k) {
                col.swap(k, p);
            }
            for i in k + 1..d {
                let f = a[k][i] / piv;
                for col in a.iter_mut().take(d + 1).skip(k) {
                    col[i] -= f * col[k];
                }
            }
        }
        let mut sol = [0.0; D_MAX];
        for k in (0..d).rev() {
            let mut acc = a[d][k];
            for j in k + 1..d {
                acc -= a[j][k] * sol[j];
            }
            sol[k] = acc / a[k][k];
        }
        1.0 + (0..d).map(|j| ph.c[j] * col(j) * sol[j]).sum::<f64>()
    }

    /// Build and apply the saltation of `p` with the phase `after` that follows it.
    fn resolve(&mut self, p: Pending, after: Phase, followed_by_contact: bool) {
        let cs = self.cs;
        let n = cs.n;
        let d = cs.dim();
        let ev = &p.ev;
        let t = ev.t_s;
        let x = &p.x_before;
        let f_minus = cs.field(p.before, x, t);
        let mut grad = [0.0; D_MAX];
        // `G`: `None` is the identity, `Some(e)` the impact law at `e`.
        let (g, rate, plastic) = match ev.kind {
            EventKind::Impact { .. } if p.release => {
                // The end of a compliant phase (`δ = 0`, `P = 0`): h = w − s·l_g, G = I; the
                // fields on both sides are free flight, with the friction of each side.
                self.counts.impacts += 1;
                for i in 0..n {
                    grad[i] = -cs.phi_d[i];
                }
                grad[2 * n] = 1.0;
                (None, x[2 * n + 1] - cs.dot_d(x, n), false)
            }
            EventKind::Impact { .. } => {
                let plastic = followed_by_contact && cs.e > 0.0;
                if plastic {
                    self.counts.plastic_impacts += 1;
                } else {
                    self.counts.impacts += 1;
                }
                for i in 0..n {
                    grad[i] = -cs.phi_d[i];
                }
                grad[2 * n] = 1.0;
                let dw = x[2 * n + 1] - cs.dot_d(x, n);
                (Some(if plastic { 0.0 } else { cs.e }), dw, plastic)
            }
            EventKind::FrictionSwitch | EventKind::Stick => {
                if ev.kind == EventKind::Stick {
                    self.counts.sticks += 1;
                } else {
                    self.counts.friction_switches += 1;
                }
                for i in 0..n {
                    grad[n + i] = -cs.phi_d[i];
                }
                grad[2 * n + 1] = 1.0;
                let rate = (0..d).map(|i| grad[i] * f_minus[i]).sum();
                (None, rate, false)
            }
            EventKind::Unstick | EventKind::ContactRelease { .. } => {
                if ev.kind == EventKind::Unstick {
                    self.counts.unsticks += 1;
                } else {
                    self.counts.releases += 1;
                }
                // h = a_b (times 1/κ, a common factor that cancels in S).
                let mut dh_dt = 0.0;
                for i in 0..n {
                    grad[i] = -cs.phi_d[i] * cs.k[i] / cs.m[i];
                    grad[n + i] = -cs.phi_d[i] * cs.c[i] / cs.m[i];
                    dh_dt += cs.phi_d[i] * cs.phi_f[i] / cs.m[i];
                }
                let rate =
                    (0..d).map(|i| grad[i] * f_minus[i]).sum::<f64>() + dh_dt * cs.dforce_dt(t);
                (None, rate, false)
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
        let mut x_plus = *x;
        if let Some(e) = g {
            cs.impact_law(e, &mut x_plus);
        }
        let f_plus = cs.field(after, &x_plus, t);
        let mut gf = f_minus;
        if let Some(e) = g {
            cs.impact_law(e, &mut gf);
        }
        let ok = rate != 0.0 && rate.is_finite();
        if !ok {
            self.counts.grazing += 1;
        }
        let mut a = [0.0; D_MAX];
        for i in 0..d {
            a[i] = (f_plus[i] - gf[i]) / rate;
        }
        for y in self.cols.iter_mut().take(self.ncols) {
            let th: f64 = (0..d).map(|i| grad[i] * y[i]).sum();
            if let Some(e) = g {
                cs.impact_law(e, y);
            }
            if ok {
                for i in 0..d {
                    y[i] += a[i] * th;
                }
            }
        }
        self.cur = Some(after);
        self.step_done(Step::Event {
            t_s: t,
            kind: ev.kind,
            plastic,
        });
    }

    /// Count a step with the frame; re-orthonormalise when it is due
    /// (`lyapunov_spectrum::STEPS_PER_QR`).
    fn step_done(&mut self, step: Step) {
        if self.qr.as_deref_mut().is_some_and(|q| q.frame.note(&step)) {
            self.flush();
        }
    }

    /// Re-orthonormalise now (Gram–Schmidt in the scaled coordinates), adding `ln Rᵢᵢ` to the
    /// logs.
    pub(crate) fn flush(&mut self) {
        let d = self.dim();
        let Some(q) = self.qr.as_deref_mut() else {
            return;
        };
        if q.frame.steps == 0 {
            return;
        }
        let mut cols: Vec<Vec<f64>> = self.cols[..d]
            .iter()
            .map(|c| (0..d).map(|r| c[r] / q.scale[r]).collect())
            .collect();
        q.frame.orthonormalise(&mut cols);
        for (c, s) in self.cols.iter_mut().zip(&cols) {
            for r in 0..d {
                c[r] = s[r] * q.scale[r];
            }
        }
    }
}

impl Observer for ModalVariational {
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
        let frictional = self.cs.model != FrictionModel::None && self.cs.fl > 0.0;
        let sigma = if mode == Mode::Free && frictional {
            sgn0(seg.state_at(0.5 * (t0 + t1)).dw_m_s())
        } else {
            0.0
        };
        let phase = Phase { mode, sigma };
        if let Some(p) = self.pending.take() {
            let contact = matches!(mode, Mode::Contact(_));
            self.resolve(p, phase, contact);
        }
        self.cur = Some(phase);
        match mode {
            Mode::Free | Mode::NoBall => self.apply_free(t1 - t0),
            Mode::Stick | Mode::Contact(_) => self.apply_held(mode, t1 - t0),
        }
        self.step_done(Step::Segment {
            t0_s: t0,
            t1_s: t1,
            mode,
        });
    }

    fn event(&mut self, ev: &Event) {
        if self.hz.is_some() {
            let last = self.hz_close(ev.t_s);
            if let (EventKind::Impact { .. }, Some(c)) = (ev.kind, last) {
                // The release (the solver reports the end of contact as the impact).
                let before = Phase {
                    mode: Mode::Free,
                    sigma: self.cs.sigma_of_fb(c.ball_friction_n),
                };
                self.cur = Some(before);
                self.pending = Some(Pending {
                    ev: *ev,
                    before,
                    x_before: self.x_cur,
                    release: true,
                });
                return;
            }
        }
        if let Some(p) = self.pending.take() {
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
            x_before: self.x_cur,
            release: false,
        });
    }
}

impl ModalObserver for ModalVariational {
    fn modal_step(&mut self, _a: &ModalState, b: &ModalState) {
        self.x_cur = to_vec(self.cs.n, b);
        if let Some(p) = self.pending.as_mut() {
            // Not reached: a segment resolves the pending event first.
            p.x_before = self.x_cur;
        }
    }

    fn modal_impact(&mut self, before: &ModalState, after: &ModalState, _loss: f64) {
        if let Some(p) = self.pending.as_mut() {
            p.x_before = to_vec(self.cs.n, before);
        }
        self.x_cur = to_vec(self.cs.n, after);
    }
}

/// The end state of a modal run, its Jacobian and the events it went through.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalFlowJacobian {
    /// The modal state at `t_end_s`.
    pub state: ModalState,
    /// `∂x(t_end)/∂x(t₀)` on `x = (q, q̇, v, v̇)` (`D × D`, row-major), fixed start and end times.
    pub jacobian: Vec<Vec<f64>>,
    /// `∂x(t_end)/∂t_end`, the vector field at the end.
    pub end_field: Vec<f64>,
    /// Events the tangent map went through.
    pub events: EventCounts,
    /// The solver's summary.
    pub summary: RunSummary,
}

/// Run [`ModalExact`] on `sys` from `init` to `t_end_s` and return the end state with the
/// Jacobian of the flow map (the stroboscopic map over `k` periods: `t_end_s = init.t_s + kT`).
pub fn modal_flow_with_jacobian(
    sys: &ModalSystem,
    init: &ModalState,
    t_end_s: f64,
) -> Result<ModalFlowJacobian, SimError> {
    let mut var = ModalVariational::new(sys, init)?;
    let r = ModalExact::default().run_modal(sys, init, t_end_s, &mut var)?;
    var.finish();
    if let Some(e) = var.failure.take() {
        return Err(e);
    }
    let n = var.cs.n;
    let x_end = to_vec(n, &r.final_state);
    let end_phase = var.cur.unwrap_or(Phase {
        mode: Mode::Free,
        sigma: sgn0(r.final_state.dw_m_s(&sys.model)),
    });
    let f = match var.open_contact {
        Some(c) => var.cs.hz_field_public(&c, t_end_s, &x_end),
        None => var.cs.field(end_phase, &x_end, t_end_s),
    };
    Ok(ModalFlowJacobian {
        state: r.final_state,
        jacobian: var.jacobian(),
        end_field: f[..var.dim()].to_vec(),
        events: var.counts,
        summary: r.summary,
    })
}
